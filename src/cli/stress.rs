//! `rockbench stress [--quick] [--engines ...] --out DIR`: the stability map.

use crate::engines::registry;
use crate::invariants::Tolerances;
use crate::stress::{
    CellResult, Contracts, Judge, KnownList, csv, grid, html, index_html, run_cell,
    run_cell_stored, totals,
};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct StressArgs {
    /// The small grid for CI (runs in well under a minute in release mode).
    #[arg(long)]
    quick: bool,
    /// Engines to run, comma-separated (default: every engine built in whose contract is
    /// measured, see the engine list below). Engines that are not built into this binary are
    /// reported as skipped.
    #[arg(long, value_delimiter = ',', long_help = engines_help())]
    engines: Vec<String>,
    /// Output directory: stress.csv, `<engine>.csv`, `<engine>.html`, stress.json.
    #[arg(long, default_value = "out/stress")]
    out: PathBuf,
    /// Known, explained violations and failures (default: validation/stress-known.toml where
    /// it exists; a file given here must exist).
    #[arg(long)]
    known: Option<PathBuf>,
    /// A run longer than this (s) is abandoned and its cell counted as failed (each of a cell's
    /// runs: the main run, the mirrored run and its probes, the rerun).
    #[arg(long, default_value_t = 600.0)]
    timeout: f64,
    /// Only the cells of these factors (comma-separated; default all).
    #[arg(long, value_delimiter = ',')]
    factors: Vec<String>,
    /// Change one promise of an engine's contract, ENGINE.CHECK=LIMIT (repeatable), e.g.
    /// `--contract rapier.standing=1e-9` to hold rapier to round-off.
    #[arg(long = "contract", value_name = "ENGINE.CHECK=LIMIT")]
    contract: Vec<String>,
    /// Run store: each cell's run (what it measured, before it is judged) is kept here under the
    /// content hash of its scene, engine, tolerances and program, and read back by a later map,
    /// so an interrupted map resumes and an unchanged one costs nothing (timeouts and panics are
    /// not kept).
    #[arg(long, default_value = ".cache/rockbench/stress")]
    cache_dir: PathBuf,
    /// Make every run again (the store is neither read nor written).
    #[arg(long)]
    no_cache: bool,
}

/// The list of known violations read when `--known` is not given, where it exists.
const DEFAULT_KNOWN: &str = "validation/stress-known.toml";

fn engines_help() -> String {
    super::engines_help(&format!(
        "Engines to run, comma-separated (default: {}). Engines that are not built into this \
         binary are reported as skipped.",
        registry::stress_defaults().join(",")
    ))
}

pub fn stress(a: StressArgs) -> Result<()> {
    super::check_out_dir(&a.out)?;
    let engines: Vec<String> = if a.engines.is_empty() {
        registry::stress_defaults()
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        a.engines.clone()
    };
    let timeout = super::seconds("--timeout", a.timeout, false)?;
    registry::check_names("--engines", engines.iter().map(String::as_str))
        .map_err(anyhow::Error::msg)?;
    let known_path = match &a.known {
        Some(p) => Some(p.clone()),
        None => Some(PathBuf::from(DEFAULT_KNOWN)).filter(|p| p.exists()),
    };
    let known = match &known_path {
        Some(p) => KnownList::load(p).map_err(anyhow::Error::msg)?,
        None => KnownList::default(),
    };
    let contracts = Contracts::with_changes(&a.contract).map_err(anyhow::Error::msg)?;
    let judge = Judge { contracts, known };
    let tol = Tolerances::default();
    let cells: Vec<_> = grid(a.quick)
        .into_iter()
        .filter(|c| a.factors.is_empty() || a.factors.iter().any(|f| f == c.factor))
        .collect();
    if cells.is_empty() {
        bail!("--factors: no cell matches {:?}", a.factors);
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let meta = serde_json::json!({
        "rockbench": crate::build_info::VERSION,
        "rockbench_git_commit": crate::build_info::GIT_COMMIT,
        "rockbench_source_hash": crate::build_info::SOURCE_HASH,
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "grid": if a.quick { "quick" } else { "full" },
        "design": format!("one factor at a time around the base case: {}", crate::stress::BASE_CASE),
        "factors": crate::stress::FACTORS.iter().map(|(f, d)| serde_json::json!({"factor": f, "varies": d})).collect::<Vec<_>>(),
        "tolerances": tol,
        "timeout_s": a.timeout,
        "known": known_path.as_ref().map(|p| p.display().to_string()),
        "engines": engines,
        "contracts": engines.iter().map(|e| judge.contracts.of(e)).collect::<Vec<_>>(),
    });
    let store = if a.no_cache {
        None
    } else {
        std::fs::create_dir_all(&a.cache_dir)
            .with_context(|| format!("--cache-dir: {}", a.cache_dir.display()))?;
        Some(a.cache_dir.clone())
    };
    let mut from_store = 0usize;
    let mut all: Vec<CellResult> = Vec::new();
    let mut unexplained = 0;
    // Each engine's pages, written once every engine's cells are run.
    let mut pages: Vec<(String, String)> = Vec::new();
    // A Ctrl-C starts no cell after it and stops the one under way, whose answer is not kept;
    // nothing is written, and the same command resumes from the cells kept in the store.
    let interrupt = crate::interrupt::Interrupt::install();
    let total = engines.len() * cells.len();
    for engine in &engines {
        let mut results = Vec::new();
        for cell in &cells {
            let answer = match &store {
                Some(dir) => run_cell_stored(engine, cell, &tol, timeout, &judge, dir)
                    .map_err(anyhow::Error::msg),
                None => Ok((run_cell(engine, cell, &tol, timeout, &judge), false)),
            };
            if interrupt.requested() {
                bail!(crate::interrupt::Stopped(format!(
                    "interrupted after {} of {total} cells; {}",
                    all.len() + results.len(),
                    match &store {
                        Some(dir) => format!(
                            "the cells run are kept in {}, and the same command resumes the map from them",
                            dir.display()
                        ),
                        None => "nothing is kept (--no-cache)".to_string(),
                    }
                )));
            }
            let (r, stored) = answer?;
            from_store += usize::from(stored);
            if r.status != crate::stress::Status::Skipped {
                let issues: Vec<String> = r
                    .issues
                    .iter()
                    .map(|i| {
                        format!(
                            "{} BROKEN{}",
                            i.check,
                            if i.explanation.is_some() {
                                " (known)"
                            } else {
                                ", unexplained"
                            }
                        )
                    })
                    .chain(r.beyond_strict().iter().map(|j| {
                        format!(
                            "{} {:.2e} (beyond round-off {:.0e}, within contract {:.2e})",
                            j.check, j.value, j.strict_limit, j.limit
                        )
                    }))
                    .collect();
                println!(
                    "{engine:<8} {:<14} {:<8} {:<11} {:>8.3} s{} {}",
                    r.factor,
                    r.label,
                    r.status.as_str(),
                    r.wall_s,
                    if stored { " (stored)" } else { "" },
                    if issues.is_empty() {
                        String::new()
                    } else {
                        issues.join(", ")
                    }
                );
                for i in r.issues.iter().filter(|i| i.explanation.is_none()) {
                    println!("         {}: {}", i.check, i.detail);
                }
            }
            results.push(r);
        }
        let t = totals(&results);
        println!(
            "{engine}: {} cells, {} finished, {} failed, {} unsupported, {} skipped; {} broken promises of its contract, {} measurements beyond round-off within it; {} unexplained issues; {:.1} s in runs",
            t.cells,
            t.finished,
            t.failed,
            t.unsupported,
            t.skipped,
            t.violations,
            t.beyond_strict,
            t.unexplained,
            t.wall_s
        );
        unexplained += t.unexplained;
        pages.push((format!("{engine}.csv"), csv(&results)));
        let mut m = meta.clone();
        m["engine"] = engine.clone().into();
        m["totals"] = serde_json::to_value(&t)?;
        pages.push((
            format!("{engine}.html"),
            html(engine, &results, &judge.contracts.of(engine), &m),
        ));
        all.extend(results);
    }
    drop(interrupt);
    for (name, text) in pages {
        let p = a.out.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
    }
    // An earlier map's pages of engines this one did not run.
    let stale: Vec<String> = registry::ENGINES
        .iter()
        .filter(|e| !engines.iter().any(|x| x == e.name))
        .flat_map(|e| [format!("{}.csv", e.name), format!("{}.html", e.name)])
        .collect();
    super::remove_stale(
        &a.out,
        &stale.iter().map(String::as_str).collect::<Vec<_>>(),
    )?;
    std::fs::write(a.out.join("stress.csv"), csv(&all))?;
    let per_engine: serde_json::Map<String, serde_json::Value> = engines
        .iter()
        .map(|e| {
            let r: Vec<CellResult> = all.iter().filter(|r| &r.engine == e).cloned().collect();
            (
                e.clone(),
                serde_json::to_value(totals(&r)).unwrap_or_default(),
            )
        })
        .collect();
    let mut m = meta;
    m["totals"] = per_engine.into();
    m["runs_from_store"] = from_store.into();
    m["store"] = store.as_ref().map(|d| d.display().to_string()).into();
    m["cells"] = serde_json::to_value(&all)?;
    std::fs::write(
        a.out.join("stress.json"),
        serde_json::to_string_pretty(&m)? + "\n",
    )?;
    let contracts: Vec<_> = engines.iter().map(|e| judge.contracts.of(e)).collect();
    std::fs::write(a.out.join("index.html"), index_html(&all, &contracts))?;
    println!(
        "Each engine is judged against its own contract (the strict invariants are measured beside it):"
    );
    for c in &contracts {
        println!("  {}", c.line());
        for p in c
            .promises
            .iter()
            .filter(|p| !matches!(p.check, "finite" | "complete"))
        {
            println!("      {}: {}", p.check, p.measured);
        }
    }
    println!("wrote {}", a.out.display());
    if unexplained > 0 {
        bail!(
            "{unexplained} broken contract promises or failed runs, unexplained (see {}/stress.csv)",
            a.out.display()
        );
    }
    Ok(())
}
