//! `rockbench gate GATES.toml [--junit FILE]`: evaluate accuracy gates.

use crate::gates::{GateOptions, junit::junit_xml, load_gates, run_gates, table};
use anyhow::{Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct GateArgs {
    /// Gate file (TOML, `[[gate]]` tables; see `rockbench::gates`).
    gates: PathBuf,
    /// Write the results as JUnit XML to this file.
    #[arg(long)]
    junit: Option<PathBuf>,
    /// Run cache directory (also $ROCKBENCH_CACHE_DIR).
    #[arg(long, env = "ROCKBENCH_CACHE_DIR", default_value = ".cache/rockbench")]
    cache_dir: PathBuf,
    /// Run every engine again (the cache is neither read nor written).
    #[arg(long)]
    no_cache: bool,
    /// Engines run at once (default: the number of cores, at most 2).
    #[arg(long)]
    jobs: Option<usize>,
    /// No progress indicator on stderr.
    #[arg(long)]
    quiet: bool,
}

pub fn gate_cmd(a: GateArgs) -> Result<()> {
    let gates = load_gates(&a.gates)?;
    let opts = GateOptions {
        cache_dir: (!a.no_cache).then(|| a.cache_dir.clone()),
        jobs: a.jobs.unwrap_or_else(crate::compare::default_jobs),
        progress: !a.quiet,
    };
    let (results, stats) = run_gates(&gates, &opts);
    print!("{}", table(&results));
    for r in results.iter().filter(|r| r.outcome.is_bad()) {
        println!("{}: {}: {}", r.outcome.word(), r.gate.name, r.message);
    }
    println!(
        "engine runs: {} from the cache, {} run now{}",
        stats.hits,
        stats.runs,
        if a.no_cache {
            " (cache disabled)".to_string()
        } else {
            format!(" (cache {})", a.cache_dir.display())
        }
    );
    if let Some(p) = &a.junit {
        if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(d)?;
        }
        let suite = a.gates.display().to_string();
        std::fs::write(p, junit_xml(&results, &suite))
            .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
        println!("wrote {}", p.display());
    }
    let bad: Vec<String> = results
        .iter()
        .filter(|r| r.outcome.is_bad())
        .map(|r| format!("{} ({})", r.gate.name, r.outcome.word().to_lowercase()))
        .collect();
    let passed = results.iter().filter(|r| !r.outcome.is_bad()).count();
    if !bad.is_empty() {
        bail!(
            "{} of {} gates failed: {}",
            bad.len(),
            results.len(),
            bad.join(", ")
        );
    }
    println!("{passed} of {} gates as expected", results.len());
    Ok(())
}
