//! `rockbench bench SCENE --engines ... --dt ... --repeat N --reference R --out DIR`: the
//! work-precision benchmark (see `crate::bench`).

use crate::bench::{BenchOptions, bench, write};
use crate::compare::ReferenceSpec;
use anyhow::{Result, anyhow};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Engines, comma-separated (native runs every solver/stepper variant).
    #[arg(long, default_value = "native,rapier,mujoco", value_delimiter = ',', long_help = super::engines_help("Engines, comma-separated (native runs every solver/stepper variant)."))]
    engines: Vec<String>,
    /// Step sizes, s, comma-separated.
    #[arg(long, default_value = "2e-3,1e-3,5e-4", value_delimiter = ',')]
    dt: Vec<f64>,
    /// Runs per cell; the wall time is their median.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Reference: an engine name or a trajectory.csv.
    #[arg(long, default_value = "housner")]
    reference: String,
    /// Override a scene field for every run (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Also write DIR/paper/ (LaTeX table, the figure as SVG, PDF and CSV).
    #[arg(long)]
    paper: bool,
    #[arg(long, default_value = "out/bench")]
    out: PathBuf,
}

/// The most timed runs of each configuration.
const MAX_REPEAT: usize = 1000;

pub fn run(a: BenchArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    if a.paper {
        crate::paper::check_tools().map_err(anyhow::Error::msg)?;
    }
    if !(1..=MAX_REPEAT).contains(&a.repeat) {
        return Err(anyhow!(
            "--repeat: from 1 to {MAX_REPEAT} (got {})",
            a.repeat
        ));
    }
    let opts = BenchOptions {
        engines: a.engines,
        dts: a.dt,
        repeat: a.repeat,
        reference: ReferenceSpec::parse(&a.reference),
        overrides: a.set,
    };
    // A Ctrl-C stops the runs under way (external workers killed) and writes nothing: a
    // benchmark keeps no runs (it times them), so it is made again whole.
    let interrupt = crate::interrupt::Interrupt::install();
    let rows = bench(&a.scene, &opts, &|r| {
        if interrupt.requested() {
            return;
        }
        eprintln!(
            "{} {} dt={}: {}{}",
            r.engine,
            r.variant,
            r.dt.map(|d| format!("{d:e}")).unwrap_or("-".into()),
            r.status,
            match (r.median_wall_s, r.rms_error) {
                (Some(w), Some(e)) => format!(" {w:.4} s, RMS error {e:.3e} rad"),
                _ => r
                    .reason
                    .clone()
                    .map(|x| format!(" ({x})"))
                    .unwrap_or_default(),
            }
        )
    });
    if interrupt.requested() {
        return Err(crate::interrupt::Stopped::nothing_written("").into());
    }
    drop(interrupt);
    let rows = rows.map_err(|e| anyhow!(e))?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    // An earlier benchmark's paper (its work_precision.csv says one was written here) is not
    // this one's.
    if !a.paper && a.out.join("work_precision.csv").is_file() {
        super::remove_stale(&a.out, &["paper"])?;
    }
    write(&a.out, &rows, &command).map_err(|e| anyhow!(e))?;
    if a.paper {
        crate::paper::write_bench(
            &a.out.join("paper"),
            &rows,
            &crate::bench::plot(&rows),
            &command,
        )
        .map_err(|e| anyhow!(e))?;
        println!("wrote {}/paper/", a.out.display());
    }
    println!("wrote {}/work_precision.{{csv,md,svg}}", a.out.display());
    Ok(())
}
