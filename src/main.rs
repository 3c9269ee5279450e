//! The `rockbench` command line (see `rockbench::cli`).

use std::process::ExitCode;

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, which turns a closed pipe (`rockbench run ... | head`) into a
    // panic on the next print; the default action ends the process quietly instead.
    #[cfg(unix)]
    // SAFETY: called once at start-up, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    rockbench::allocator::keep_freed_memory();
    match rockbench::cli::main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}");
            eprintln!("error: {}", msg.replace('\n', " "));
            let suspended = matches!(
                e.downcast_ref(),
                Some(rockbench::engines::EngineError::Suspended { .. })
            );
            let stopped = e.downcast_ref::<rockbench::interrupt::Stopped>().is_some();
            if suspended || stopped {
                ExitCode::from(rockbench::interrupt::EXIT_STATUS)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
