//! The `rockbench` command line.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use rockbench::engines::{engine_by_name, run_timed, write_outputs};
use rockbench::scene::load_scene_with_overrides;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "rockbench",
    version,
    about = "Rigid-block rocking: native theta-method QP solver and cross-validation harness"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one engine on a scene; writes DIR/trajectory.csv and DIR/summary.json.
    Run {
        /// Scene file (TOML or JSON).
        scene: PathBuf,
        /// Engine: native or housner.
        #[arg(long, default_value = "native")]
        engine: String,
        /// Override a scene field, e.g. --set native.dt=5e-4 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory.
        #[arg(long, default_value = "out/run")]
        out: PathBuf,
    },
    /// Check a scene file without running it.
    Check {
        scene: PathBuf,
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}");
            eprintln!("error: {}", msg.replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { scene, set } => {
            let s = load_scene_with_overrides(&scene, &set)?;
            println!(
                "{}: ok ({} block{}, {} s, {})",
                scene.display(),
                s.blocks.len(),
                if s.blocks.len() == 1 { "" } else { "s" },
                s.duration,
                if s.has_excitation() {
                    "ground excitation"
                } else {
                    "free rocking"
                }
            );
        }
        Command::Run {
            scene,
            engine,
            set,
            out,
        } => {
            let s = load_scene_with_overrides(&scene, &set)?;
            let e = engine_by_name(&engine)?;
            let (output, mut summary) = run_timed(e.as_ref(), &s)?;
            summary.command = Some(std::env::args().collect::<Vec<_>>().join(" "));
            write_outputs(&out, &output, &summary)
                .with_context(|| format!("writing {}", out.display()))?;
            print_summary(&summary);
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}

fn print_summary(s: &rockbench::summary::Summary) {
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
