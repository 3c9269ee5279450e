//! The `rockbench` command line (see `rockbench::cli`).

use std::process::ExitCode;

fn main() -> ExitCode {
    match rockbench::cli::main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}");
            eprintln!("error: {}", msg.replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
