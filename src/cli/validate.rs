//! `rockbench validate [SUITE] --gates GATES --out DIR`: run the validation suite on every
//! engine, evaluate its gates and write `DIR/report.html` (summary matrix, the paper's
//! two-block case, one section per case) with each comparison's report under `DIR/<case>/`.

use crate::gates::{junit::junit_xml, load_gates};
use crate::report::provenance::Provenance;
use crate::report::write_comparison;
use crate::validation::report::{PaperClaims, matrix_text, render};
use crate::validation::{ValidateOptions, load_suite, validate};
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct ValidateArgs {
    /// Suite file (TOML, `[[case]]` tables; see `rockbench::validation`).
    #[arg(default_value = "validation/suite.toml")]
    suite: PathBuf,
    /// Gate file of the suite.
    #[arg(long, default_value = "validation/gates-full.toml")]
    gates: PathBuf,
    /// Engines to run, comma-separated (gates of other engines are left out).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "native,housner,rapier,mujoco,pybullet",
        long_help = super::engines_help("Engines to run, comma-separated (gates of other engines are left out; Siconos runs in `make validate-siconos`).")
    )]
    engines: Vec<String>,
    /// Only these cases (repeatable); default all.
    #[arg(long = "case")]
    cases: Vec<String>,
    /// Output directory.
    #[arg(long, default_value = "out/validation")]
    out: PathBuf,
    /// Also write DIR/paper/ (the matrix and the paper case's tables and figures as LaTeX,
    /// SVG, PDF and CSV).
    #[arg(long)]
    paper: bool,
    #[command(flatten)]
    run_cache: super::RunCacheArgs,
}

/// `path` relative to the current directory when it is under it.
fn shown(path: &Path) -> String {
    let cwd = std::env::current_dir().unwrap_or_default();
    let p = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    p.strip_prefix(&cwd)
        .map(|r| r.display().to_string())
        .unwrap_or_else(|_| p.display().to_string())
}

pub fn validate_cmd(a: ValidateArgs) -> Result<()> {
    super::check_out_dir(&a.out)?;
    if a.paper {
        crate::paper::check_tools().map_err(anyhow::Error::msg)?;
    }
    crate::engines::registry::check_names("--engines", a.engines.iter().map(String::as_str))
        .map_err(anyhow::Error::msg)?;
    let mut cases = load_suite(&a.suite)?;
    if !a.cases.is_empty() {
        for c in &a.cases {
            if !cases.iter().any(|x| &x.name == c) {
                bail!(
                    "--case: no case `{c}` in {} (cases: {})",
                    a.suite.display(),
                    cases
                        .iter()
                        .map(|x| x.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        cases.retain(|c| a.cases.contains(&c.name));
    }
    // The paper's claims are read before any run: a bad reference.toml stops the suite with
    // nothing written.
    let claims = cases
        .iter()
        .find(|c| c.paper)
        .and_then(|c| c.references.as_ref().map(|d| (c, d)))
        .map(|(c, d)| {
            PaperClaims::read(d).map_err(|e| {
                anyhow::anyhow!("{}: case `{}`.references: {e}", a.suite.display(), c.name)
            })
        })
        .transpose()?;
    let all_gates = load_gates(&a.gates)?;
    // With --case, only the gates of the chosen cases.
    let gates: Vec<_> = all_gates
        .into_iter()
        .filter(|g| a.cases.is_empty() || crate::validation::case_of(&cases, g).is_some())
        .collect();
    let opts = ValidateOptions {
        engines: a.engines.clone(),
        cache_dir: a.run_cache.cache_dir()?,
        jobs: a.run_cache.jobs()?,
        progress: a.run_cache.progress(),
    };
    // A Ctrl-C starts no run after it and stops those under way; nothing is written, and the
    // same command resumes from the runs kept in the run cache.
    let interrupt = crate::interrupt::Interrupt::install();
    let validated = validate(&cases, &gates, &opts);
    if interrupt.requested() {
        return Err(
            crate::interrupt::Stopped::kept_in(opts.cache_dir.as_deref(), "the suite").into(),
        );
    }
    drop(interrupt);
    let (results, stats) = validated.map_err(anyhow::Error::msg)?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    std::fs::create_dir_all(&a.out).map_err(|e| anyhow::anyhow!("{}: {e}", a.out.display()))?;
    for r in &results {
        for run in &r.runs {
            if let Ok(c) = &run.comparison {
                write_comparison(&a.out.join(&run.dir), c, &command).map_err(anyhow::Error::msg)?;
            }
        }
    }
    let prov = Provenance::collect(&command);
    let (html, md, plots) = render(&results, &a.engines, claims.as_ref(), &prov, &shown);
    let io = |p: &Path, e: std::io::Error| anyhow::anyhow!("{}: {e}", p.display());
    let pd = a.out.join("plots");
    std::fs::create_dir_all(&pd).map_err(|e| io(&pd, e))?;
    for (name, svg) in plots {
        let p = pd.join(name);
        std::fs::write(&p, svg).map_err(|e| io(&p, e))?;
    }
    for (name, text) in [("report.html", html), ("report.md", md)] {
        let p = a.out.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p, e))?;
    }
    let gate_results: Vec<_> = results.iter().flat_map(|r| r.gates.clone()).collect();
    let p = a.out.join("junit.xml");
    std::fs::write(&p, junit_xml(&gate_results, &a.gates.display().to_string()))
        .map_err(|e| io(&p, e))?;
    if a.paper {
        let (head, rows) = crate::validation::report::matrix(&results, &a.engines);
        let paper_case = results.iter().find(|r| r.case.paper).and_then(|r| {
            let c = r.runs.iter().find_map(|run| run.comparison.as_ref().ok())?;
            Some((r.case.name.as_str(), c))
        });
        crate::paper::write_validation(&a.out.join("paper"), &head, &rows, paper_case, &command)
            .map_err(anyhow::Error::msg)?;
    }
    print!("{}", matrix_text(&results, &a.engines));
    for g in gate_results.iter().filter(|g| g.outcome.is_bad()) {
        println!("{}: {}: {}", g.outcome.word(), g.gate.name, g.message);
    }
    println!(
        "engine runs: {} from the cache, {} run now; wrote {}/report.html",
        stats.hits,
        stats.runs,
        a.out.display()
    );
    let bad = gate_results.iter().filter(|g| g.outcome.is_bad()).count();
    if bad > 0 {
        bail!("{bad} of {} gates not as expected", gate_results.len());
    }
    println!(
        "{} of {} gates as expected",
        gate_results.len(),
        gate_results.len()
    );
    Ok(())
}
