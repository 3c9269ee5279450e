//! `rockbench fragility STUDY.toml --out DIR`: a fragility study (see `crate::fragility` and
//! docs/fragility.md). Writes DIR/outcomes.csv, capacities.csv, fits.csv, differences.csv,
//! fragility.json and report.html (and DIR/paper/ with `--paper`).

use crate::fragility::{self, report, study};
use anyhow::{Result, anyhow};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct FragilityArgs {
    /// The study file (TOML).
    study: PathBuf,
    #[arg(long, default_value = "out/fragility")]
    out: PathBuf,
    /// Parallel runs (default: every core).
    #[arg(long)]
    jobs: Option<usize>,
    /// Also write DIR/paper/ (LaTeX tables, figures as SVG, PDF and CSV).
    #[arg(long)]
    paper: bool,
    /// Check the study, its scenes, suite and records, and stop (nothing runs).
    #[arg(long)]
    check: bool,
    /// No progress line.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: FragilityArgs) -> Result<()> {
    super::check_out_dir(&a.out)?;
    if a.paper {
        crate::paper::check_tools().map_err(anyhow::Error::msg)?;
    }
    let st = study::load_study(&a.study).map_err(|e| anyhow!("{e}"))?;
    if a.check {
        println!(
            "{}: {} scene(s), suite {} ({} records), {} level(s), engines {}, {} limit state(s): ok",
            a.study.display(),
            st.scenes.len(),
            st.suite.header.name,
            st.suite.records.len(),
            st.file.intensity.levels.len(),
            st.file.engines.join(","),
            st.limit_states.len()
        );
        return Ok(());
    }
    report::check_study_out(&a.out, &st.cache_dir).map_err(|e| anyhow!(e))?;
    super::check_jobs(a.jobs)?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.jobs.unwrap_or(0))
        .build()
        .map_err(|e| anyhow!("--jobs: {e}"))?;
    // A Ctrl-C starts no run after it and stops those under way; the runs finished are in the
    // cache, and the same command resumes from them.
    let interrupt = crate::interrupt::Interrupt::install();
    let res = pool.install(|| fragility::run_study(&st, a.quiet));
    if interrupt.requested() {
        let kept = crate::interrupt::Stopped::kept_in(Some(&st.cache_dir), "the study");
        return Err(crate::interrupt::Stopped(format!("{}: {kept}", a.study.display())).into());
    }
    drop(interrupt);
    let res = res.map_err(|e| anyhow!("{}: {e}", a.study.display()))?;
    report::write_all(&a.out, &st, &res, &command, a.paper).map_err(|e| anyhow!(e))?;
    for f in &res.fits {
        if let Some(x) = f.fit {
            println!(
                "{} {} {} {:?}: theta {:.4} [{}], beta {:.3}{}",
                f.scene,
                f.engine,
                f.limit_state,
                f.method,
                x.theta,
                f.theta_ci
                    .map(|(a, b)| format!("{a:.4} - {b:.4}"))
                    .unwrap_or_else(|| "-".into()),
                x.beta,
                f.resample_note(st.file.fit.bootstrap)
                    .map(|n| format!("; {n}"))
                    .unwrap_or_default()
            );
        }
    }
    println!("wrote {}", a.out.display());
    Ok(())
}
