//! `rockbench run SCENE --engine E --out DIR`: one engine, one scene.

use crate::engines::native::NativeEngine;
use crate::engines::registry::load_scene_with_overrides;
use crate::engines::{engine_by_name, run_timed_reporting, timed, write_outputs};
use crate::native::checkpoint::Checkpointing;
use anyhow::{Context, Result};
use std::cell::Cell;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::{Duration, Instant};

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
    /// Seconds between progress lines on stderr (simulated time reached, time left).
    #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
    progress_interval: f64,
    /// No progress lines.
    #[arg(long)]
    quiet: bool,
    /// Native engine: write the run's state to FILE as it goes (its samples to FILE.samples), and
    /// resume from FILE when it is there (same build, same scene and overrides); both removed
    /// once the outputs are written. The outputs are those of an uninterrupted run, to the bit.
    /// A Ctrl-C (or SIGTERM) writes the checkpoint at the step reached and ends the run (exit
    /// status 130); a second one ends the process at once.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds of wall time between checkpoint writes.
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    checkpoint_interval: f64,
    /// Stop after this step once its checkpoint is written (tests; a batch job's slice).
    #[arg(long, value_name = "STEP", requires = "checkpoint")]
    stop_after_step: Option<u64>,
}

/// The progress line of a run: at most one every `interval`, none in the first `interval`.
/// The time left is at the rate since the line before (or since this process's first step): a
/// run's cost a step can grow a thousandfold when a wall starts to move (the 860-block wall of
/// the dynamic series when El Centro x2 leaves its rest interval at 4.18 s), which a mean since
/// the start would hide, and a resumed run starts late.
struct ProgressLine {
    engine: String,
    duration: f64,
    interval: Duration,
    /// When this process reported its first step.
    start: Cell<Option<Instant>>,
    /// The simulated time of the last line (or of the first step), and when.
    last: Cell<Option<(f64, Instant)>>,
}

impl ProgressLine {
    fn new(engine: &str, duration: f64, interval: Duration) -> Self {
        ProgressLine {
            engine: engine.to_string(),
            duration,
            interval,
            start: Cell::new(None),
            last: Cell::new(None),
        }
    }

    fn report(&self, t: f64) {
        if t.is_nan() {
            return; // an external worker's run: its time is not known
        }
        let now = Instant::now();
        let (Some(start), Some((t_last, at_last))) = (self.start.get(), self.last.get()) else {
            self.start.set(Some(now));
            self.last.set(Some((t, now)));
            return;
        };
        let recent = now.duration_since(at_last);
        if recent < self.interval {
            return;
        }
        self.last.set(Some((t, now)));
        let elapsed = now.duration_since(start).as_secs_f64();
        eprintln!(
            "{}",
            progress_text(
                &self.engine,
                t,
                self.duration,
                elapsed,
                (t - t_last, recent.as_secs_f64())
            )
        );
    }
}

/// `native: 1.234 of 5 s simulated (24.7 %), 12 s elapsed, about 37 s left at the rate of the
/// last 10 s`: the time left at the rate of `recent = (simulated, wall)` seconds.
fn progress_text(
    engine: &str,
    t: f64,
    duration: f64,
    elapsed: f64,
    (simulated, wall): (f64, f64),
) -> String {
    let fraction = if duration > 0.0 {
        (t / duration).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let left = if simulated > 0.0 {
        format!(
            ", about {:.0} s left at the rate of the last {wall:.0} s",
            wall * (duration - t).max(0.0) / simulated
        )
    } else {
        String::new()
    };
    format!(
        "{engine}: {t:.3} of {duration} s simulated ({:.1} %), {elapsed:.0} s elapsed{left}",
        100.0 * fraction
    )
}

pub fn run(a: RunArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    super::check_input_outside(
        &a.out,
        "the scene",
        &a.scene,
        &["scene.json", "trajectory.csv", "summary.json"],
    )?;
    let s = load_scene_with_overrides(&a.scene, &a.set)?;
    for record in s.record_files() {
        super::check_input_outside(
            &a.out,
            "the record",
            &record,
            &["scene.json", "trajectory.csv", "summary.json"],
        )?;
    }
    let e = engine_by_name(&a.engine)?;
    let line = ProgressLine::new(
        e.name(),
        s.duration,
        super::seconds("--progress-interval", a.progress_interval, true)?,
    );
    let quiet = a.quiet;
    // A run stops cleanly on Ctrl-C: a checkpointed one with its checkpoint written at the
    // step reached, any other with nothing written (an external engine's worker killed).
    let interrupt = crate::interrupt::Interrupt::install();
    let progress = |t: f64| {
        if !quiet {
            line.report(t)
        }
        if interrupt.requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let (output, mut summary) = match &a.checkpoint {
        None => {
            let made = run_timed_reporting(e.as_ref(), &s, &progress);
            if interrupt.requested() {
                return Err(crate::interrupt::Stopped::nothing_written(
                    " (`--checkpoint FILE` makes a native run that resumes)",
                )
                .into());
            }
            made?
        }
        Some(path) => {
            if e.name() != "native" {
                anyhow::bail!(
                    "--checkpoint: only the native engine resumes from a checkpoint (engine `{}`)",
                    e.name()
                );
            }
            if a.stop_after_step == Some(0) {
                anyhow::bail!("--stop-after-step: steps are counted from 1 (got 0)");
            }
            let checkpointing = Checkpointing {
                path: path.clone(),
                interval: super::seconds("--checkpoint-interval", a.checkpoint_interval, true)?,
                stop_after_step: a.stop_after_step,
            };
            timed("native", &s, || {
                NativeEngine.run_checkpointed(&s, &progress, Some(&checkpointing))
            })?
        }
    };
    drop(interrupt);
    summary.command = Some(std::env::args().collect::<Vec<_>>().join(" "));
    write_outputs(&a.out, &s, &output, &summary)
        .with_context(|| format!("writing {}", a.out.display()))?;
    if let Some(path) = &a.checkpoint {
        crate::native::checkpoint::remove(path).map_err(anyhow::Error::msg)?;
    }
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

#[cfg(test)]
mod tests {
    use super::progress_text;

    #[test]
    fn the_progress_line_gives_the_time_left_at_the_recent_rate() {
        assert_eq!(
            progress_text("native", 1.25, 5.0, 10.0, (1.25, 10.0)),
            "native: 1.250 of 5 s simulated (25.0 %), 10 s elapsed, about 30 s left at the rate of the last 10 s"
        );
        assert_eq!(
            progress_text("rapier", 0.0, 5.0, 0.5, (0.0, 0.5)),
            "rapier: 0.000 of 5 s simulated (0.0 %), 0 s elapsed"
        );
        assert_eq!(
            progress_text("native", 5.0, 5.0, 8.0, (0.5, 1.0)),
            "native: 5.000 of 5 s simulated (100.0 %), 8 s elapsed, about 0 s left at the rate of the last 1 s"
        );
        // A wall that starts to move: 4.18 s simulated in the first 20 s, then 0.002 s in the
        // last 12 s. The time left is the last 12 s's rate (about 4900 s), not the run's mean
        // (about 4 s).
        assert_eq!(
            progress_text("native", 4.182, 5.0, 32.0, (0.002, 12.0)),
            "native: 4.182 of 5 s simulated (83.6 %), 32 s elapsed, about 4908 s left at the rate of the last 12 s"
        );
    }
}
