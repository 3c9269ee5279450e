//! `rockbench converge SCENE --engines ... --dt ... --reference R|self --out DIR`: the observed
//! order of accuracy of every engine (see `crate::converge`).

use crate::converge::{ConvergeOptions, ConvergeReference, converge, write};
use crate::gates::cache::RunCache;
use anyhow::{Result, anyhow};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ConvergeArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Engines, comma-separated (each needs a step size: native, rapier, mujoco, pybullet).
    #[arg(long, default_value = "native,rapier", value_delimiter = ',', long_help = super::engines_help("Engines, comma-separated (each needs a step size, see the registry's step settings)."))]
    engines: Vec<String>,
    /// Step sizes, s, comma-separated.
    #[arg(long, default_value = "2e-3,1e-3,5e-4,2.5e-4", value_delimiter = ',')]
    dt: Vec<f64>,
    /// Reference: an engine name, a trajectory.csv, or `self` (each engine's finest run).
    #[arg(long, default_value = "housner")]
    reference: String,
    /// Override a scene field for every run (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Also write DIR/paper/ (LaTeX tables, figures as SVG, PDF and CSV).
    #[arg(long)]
    paper: bool,
    /// Run cache directory (also $ROCKBENCH_CACHE_DIR), shared with `gate` and `validate`:
    /// runs made before (the same scene, settings, step, engine and build) are read back, so
    /// an interrupted study resumes and a repeated one runs nothing.
    #[arg(long, env = "ROCKBENCH_CACHE_DIR", default_value = ".cache/rockbench")]
    cache_dir: PathBuf,
    /// Run every engine again (the cache is neither read nor written).
    #[arg(long)]
    no_cache: bool,
    #[arg(long, default_value = "out/converge")]
    out: PathBuf,
}

pub fn run(a: ConvergeArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    if a.paper {
        crate::paper::check_tools().map_err(anyhow::Error::msg)?;
    }
    let reference = ConvergeReference::parse(&a.reference);
    if matches!(reference, ConvergeReference::Finest) && a.dt.len() < 3 {
        return Err(anyhow!(
            "--dt: a `self` reference needs at least three step sizes (the finest is the reference)"
        ));
    }
    if a.dt.len() < 2 {
        return Err(anyhow!("--dt: an order needs at least two step sizes"));
    }
    let cache = RunCache::new(if a.no_cache {
        None
    } else {
        std::fs::create_dir_all(&a.cache_dir)
            .map_err(|e| anyhow!("--cache-dir: {}: {e}", a.cache_dir.display()))?;
        Some(a.cache_dir.clone())
    });
    let opts = ConvergeOptions {
        engines: a.engines,
        dts: a.dt,
        reference,
        overrides: a.set,
    };
    let runner = |engine: &str, scene: &crate::scene::Scene| cache.run(engine, scene);
    // A Ctrl-C starts no run after it and stops those under way; nothing is written, and the
    // same command resumes from the runs kept in the run cache.
    let interrupt = crate::interrupt::Interrupt::install();
    let c = converge(&a.scene, &opts, &runner, &|r| {
        if interrupt.requested() {
            return;
        }
        eprintln!(
            "{} dt={}: {}{}{}",
            r.engine,
            r.dt_label(),
            r.status,
            r.wall_time_s
                .map(|w| format!(" {w:.4} s"))
                .or(r.reason.as_ref().map(|x| format!(" ({x})")))
                .unwrap_or_default(),
            if r.cached { " (cached)" } else { "" }
        )
    });
    if interrupt.requested() {
        let store = (!a.no_cache).then_some(a.cache_dir.as_path());
        return Err(crate::interrupt::Stopped::kept_in(store, "the study").into());
    }
    drop(interrupt);
    let c = c.map_err(|e| anyhow!(e))?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    // An earlier study's figures of quantities this one does not plot, and its paper when none
    // is asked for, are not this one's (its converge.csv says one was written here).
    if a.out.join("converge.csv").is_file() {
        let mut stale = vec!["converge-*.svg"];
        if !a.paper {
            stale.push("paper");
        }
        super::remove_stale(&a.out, &stale)?;
    }
    write(&a.out, &c, &command).map_err(|e| anyhow!(e))?;
    for o in c
        .orders
        .iter()
        .filter(|o| o.quantity == "impact_time_1" || o.quantity == "rotation_rms_error_to_impact_1")
    {
        println!(
            "{:<10} {:<16} {:<32} order {}",
            o.engine,
            o.series,
            o.quantity,
            o.order.map(|v| format!("{v:.2}")).unwrap_or("n/a".into())
        );
    }
    if a.paper {
        crate::paper::write_converge(&a.out.join("paper"), &c, &command).map_err(|e| anyhow!(e))?;
    }
    println!(
        "wrote {}/converge.{{csv,md,json}}, orders.csv, converge-*.svg",
        a.out.display()
    );
    Ok(())
}
