//! The `rockbench` command line: one file per subcommand.

mod check;
mod run;
mod stress;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "rockbench",
    version,
    about = "Rigid-block rocking: native theta-method QP solver and cross-validation harness"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one engine on a scene; writes DIR/trajectory.csv and DIR/summary.json.
    Run(run::RunArgs),
    /// Check a scene file without running it.
    Check(check::CheckArgs),
    /// Stability map: every engine over a grid of scenes, with the invariants of each run.
    Stress(stress::StressArgs),
}

/// Parse the command line and run it.
pub fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Run(a) => run::run(a),
        Command::Check(a) => check::check(a),
        Command::Stress(a) => stress::stress(a),
    }
}
