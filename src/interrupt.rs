//! A Ctrl-C (SIGINT) or SIGTERM asked of long work that can stop cleanly.
//!
//! While an [`Interrupt`] lives, the first SIGINT or SIGTERM only sets a flag, and:
//! - a checkpointed native run reads it after every step, writes its checkpoint at that step
//!   and exits;
//! - any other run, a comparison and a work-precision benchmark stop with nothing written;
//! - a comparison's or an animation's video stops (ffmpeg killed, the file removed), and the
//!   generation of the reference data writes nothing;
//! - a stability map, a fragility study, a spectrum, a sensitivity study, accuracy gates, the
//!   validation suite and a convergence study start no run after it, stop the runs under way,
//!   keep nothing those runs answered and write no output; the same command resumes from the
//!   runs kept in their store or cache (a sensitivity study's runs.csv).
//!
//! Runs stop through [`go_on_unless_interrupted`] (native and rapier within a step); an
//! external engine's worker is killed, not left running. The command ends with [`Stopped`]
//! (exit status 130). The handler is installed with `SA_RESETHAND`, so a second signal ends
//! the process as it would have without one.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// The conventional exit status of a process stopped by SIGINT (128 + 2).
pub const EXIT_STATUS: u8 = 130;

/// Long work stopped by an interrupt: what was kept and how it resumes, one line. The command
/// line exits with [`EXIT_STATUS`].
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Stopped(pub String);

impl Stopped {
    /// Stopped work that keeps no runs (a run, a comparison, a benchmark); `hint` follows the
    /// line where there is a way to keep them.
    pub fn nothing_written(hint: &str) -> Stopped {
        Stopped(format!("interrupted; nothing is written{hint}"))
    }

    /// Stopped work whose finished runs are kept in the store `store` (none: `--no-cache`),
    /// from which the same command resumes `what`.
    pub fn kept_in(store: Option<&std::path::Path>, what: &str) -> Stopped {
        Stopped(match store {
            Some(dir) => format!(
                "interrupted; the runs finished are kept in {}, and the same command resumes {what} from them",
                dir.display()
            ),
            None => "interrupted; nothing is kept (--no-cache)".to_string(),
        })
    }
}

/// Whether a signal has asked the work to stop (never while no [`Interrupt`] is installed: a
/// signal then ends the process).
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// A run's observer ([`crate::engines::Progress`]) that stops it once a signal has come.
pub fn go_on_unless_interrupted(_t: f64) -> std::ops::ControlFlow<()> {
    if requested() {
        std::ops::ControlFlow::Break(())
    } else {
        std::ops::ControlFlow::Continue(())
    }
}

/// The handler, installed for its lifetime; the signals' earlier dispositions come back on drop.
pub struct Interrupt {
    #[cfg(unix)]
    before: [(libc::c_int, libc::sigaction); 2],
}

#[cfg(unix)]
extern "C" fn on_signal(_: libc::c_int) {
    // Async-signal-safe: one atomic store.
    REQUESTED.store(true, Ordering::SeqCst);
}

impl Interrupt {
    #[cfg(unix)]
    pub fn install() -> Self {
        REQUESTED.store(false, Ordering::SeqCst);
        let install = |signal: libc::c_int| {
            // SAFETY: `sigaction` is given zeroed structures of its own type, filled with a
            // handler that only stores to an atomic; the old disposition is written to `old`.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as usize;
                action.sa_flags = libc::SA_RESETHAND;
                libc::sigemptyset(&mut action.sa_mask);
                let mut old: libc::sigaction = std::mem::zeroed();
                libc::sigaction(signal, &action, &mut old);
                (signal, old)
            }
        };
        Interrupt {
            before: [install(libc::SIGINT), install(libc::SIGTERM)],
        }
    }

    #[cfg(not(unix))]
    pub fn install() -> Self {
        Interrupt {}
    }

    /// Whether a signal has asked the run to stop.
    pub fn requested(&self) -> bool {
        requested()
    }
}

impl Drop for Interrupt {
    fn drop(&mut self) {
        REQUESTED.store(false, Ordering::SeqCst);
        #[cfg(unix)]
        for (signal, old) in &self.before {
            // SAFETY: puts back the disposition `install` read.
            unsafe {
                libc::sigaction(*signal, old, std::ptr::null_mut());
            }
        }
    }
}
