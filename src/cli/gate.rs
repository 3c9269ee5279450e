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
    #[command(flatten)]
    run_cache: super::RunCacheArgs,
}

pub fn gate_cmd(a: GateArgs) -> Result<()> {
    let gates = load_gates(&a.gates)?;
    if let Some(p) = &a.junit {
        let mut inputs = vec![("the gate file".to_string(), a.gates.clone())];
        for g in &gates {
            inputs.push((format!("gate {}'s scene", g.name), g.scene_path.clone()));
            inputs.extend(
                g.scene
                    .record_files()
                    .into_iter()
                    .map(|r| (format!("gate {}'s record", g.name), r)),
            );
            if let crate::compare::ReferenceSpec::File(f) = &g.reference {
                inputs.push((format!("gate {}'s reference", g.name), f.clone()));
            }
        }
        super::check_not_an_input(p, "--junit", &inputs)?;
    }
    let opts = GateOptions {
        cache_dir: a.run_cache.cache_dir()?,
        jobs: a.run_cache.jobs()?,
        progress: a.run_cache.progress(),
    };
    // A Ctrl-C starts no run after it and stops those under way; nothing is printed as a
    // verdict, and the same command resumes from the runs kept in the run cache.
    let interrupt = crate::interrupt::Interrupt::install();
    let (results, stats) = run_gates(&gates, &opts);
    if interrupt.requested() {
        return Err(
            crate::interrupt::Stopped::kept_in(opts.cache_dir.as_deref(), "the gates").into(),
        );
    }
    drop(interrupt);
    print!("{}", table(&results));
    for r in results.iter().filter(|r| r.outcome.is_bad()) {
        println!("{}: {}: {}", r.outcome.word(), r.gate.name, r.message);
    }
    println!(
        "engine runs: {} from the cache, {} run now{}",
        stats.hits,
        stats.runs,
        match &opts.cache_dir {
            None => " (cache disabled)".to_string(),
            Some(dir) => format!(" (cache {})", dir.display()),
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
