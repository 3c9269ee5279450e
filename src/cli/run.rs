//! `rockbench run SCENE --engine E --out DIR`: one engine, one scene.

use crate::engines::registry::load_scene_with_overrides;
use crate::engines::{engine_by_name, run_timed, write_outputs};
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct RunArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Engine name (see `rockbench run --help`): native, housner, ...
    #[arg(long, default_value = "native", long_help = super::engines_help("Engine name."))]
    engine: String,
    /// Override a scene field, e.g. --set native.dt=5e-4 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Output directory.
    #[arg(long, default_value = "out/run")]
    out: PathBuf,
}

pub fn run(a: RunArgs) -> Result<()> {
    let s = load_scene_with_overrides(&a.scene, &a.set)?;
    let e = engine_by_name(&a.engine)?;
    let (output, mut summary) = run_timed(e.as_ref(), &s)?;
    summary.command = Some(std::env::args().collect::<Vec<_>>().join(" "));
    write_outputs(&a.out, &output, &summary)
        .with_context(|| format!("writing {}", a.out.display()))?;
    // The scene as run (overrides applied), for `rockbench animate`.
    let sp = a.out.join("scene.json");
    std::fs::write(
        &sp,
        serde_json::to_string_pretty(&s.to_json()).unwrap_or_default() + "\n",
    )
    .with_context(|| format!("writing {}", sp.display()))?;
    print_summary(&summary);
    println!("wrote {}", a.out.display());
    Ok(())
}

/// A few lines per block: impacts, peaks, rest times.
pub fn print_summary(s: &crate::summary::Summary) {
    println!(
        "{} on {}: {} steps in {:.3} s wall",
        s.engine, s.scene, s.steps, s.wall_time_s
    );
    for b in &s.blocks {
        let imp: Vec<String> = b
            .impacts
            .iter()
            .take(6)
            .map(|t| format!("{t:.4}"))
            .collect();
        let pk: Vec<String> = b
            .peaks
            .iter()
            .skip(1)
            .take(4)
            .map(|p| format!("{:.4}", p.amplitude))
            .collect();
        let rest = |k: &str| {
            b.rest_times
                .get(k)
                .copied()
                .flatten()
                .map(|t| format!("{t:.3}"))
                .unwrap_or_else(|| "-".into())
        };
        println!(
            "  {:<10} impacts ({}): [{}{}]  peaks after impacts: [{}]  rest 1e-4/1e-3/1e-2/3e-2: {}/{}/{}/{} s{}",
            b.name,
            b.rotation,
            imp.join(", "),
            if b.impacts.len() > 6 { ", ..." } else { "" },
            pk.join(", "),
            rest("1e-4"),
            rest("1e-3"),
            rest("1e-2"),
            rest("3e-2"),
            if b.overturned { "  OVERTURNED" } else { "" }
        );
    }
    for n in &s.notes {
        println!("  note: {n}");
    }
}
