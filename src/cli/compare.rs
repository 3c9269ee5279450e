//! `rockbench compare SCENE --engines a,b,c --reference ENGINE|FILE --out DIR`: run every
//! engine once, compare each with the reference, write the metrics and the report.

use crate::compare::{
    CompareOptions, ReferenceSpec, compare_with_runner, default_jobs, run_engine_reporting,
};
use crate::engines::registry::load_scene_with_overrides;
use crate::report::{summary_paragraphs_for, write_comparison};
use anyhow::{Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CompareArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Engines to run, comma-separated. Engines not built into this rockbench, or that cannot
    /// model the scene, are listed as skipped with the reason.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "native,rapier,mujoco,pybullet,housner",
        long_help = super::engines_help("Engines, comma-separated.")
    )]
    engines: Vec<String>,
    /// The reference: an engine name (run too if not in --engines) or a trajectory.csv file.
    #[arg(long, default_value = "native")]
    reference: String,
    /// Output directory.
    #[arg(long, default_value = "out/compare")]
    out: PathBuf,
    /// Override a scene field, e.g. --set native.dt=5e-4 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Spacing of the common grid for rotation errors, s.
    #[arg(long, default_value_t = 1e-3)]
    grid_dt: f64,
    /// Rotation errors are also reported up to the reference's K-th impact for these K.
    #[arg(long, value_delimiter = ',', default_value = "1,3")]
    up_to_impacts: Vec<usize>,
    /// Compare only on this window, s (`T0,T1`).
    #[arg(long, value_delimiter = ',', value_name = "T0,T1")]
    window: Option<Vec<f64>>,
    /// Engines run at once (default: the number of cores, at most 2). Use 1 for wall times
    /// that are not disturbed by another engine running.
    #[arg(long)]
    jobs: Option<usize>,
    /// Run each engine this many times and report the median wall time (the trajectory is
    /// the first run's). Combine with --jobs 1 for comparable timings.
    #[arg(long, default_value_t = 1)]
    timing_runs: usize,
    /// Also write DIR/paper/ (LaTeX tables, figures as SVG, PDF and CSV).
    #[arg(long)]
    paper: bool,
    /// No progress indicator on stderr.
    #[arg(long)]
    quiet: bool,
    /// Also write the animation as a video, DIR/animation.mp4 (or .gif with `--video gif`),
    /// through ffmpeg.
    #[arg(long, num_args = 0..=1, default_missing_value = "mp4", value_name = "mp4|gif")]
    video: Option<String>,
}

/// The most runs of each engine `--timing-runs` may ask for.
const MAX_TIMING_RUNS: usize = 1000;

pub fn compare_cmd(a: CompareArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    if a.up_to_impacts.contains(&0) {
        bail!("--up-to-impacts: impacts are counted from 1");
    }
    if let Some(k) =
        (1..a.up_to_impacts.len()).find(|&i| a.up_to_impacts[..i].contains(&a.up_to_impacts[i]))
    {
        bail!("--up-to-impacts: {} is given twice", a.up_to_impacts[k]);
    }
    if let Some(v) = &a.video
        && v != "mp4"
        && v != "gif"
    {
        bail!("--video: mp4 or gif (got `{v}`)");
    }
    if a.paper {
        crate::paper::check_tools().map_err(anyhow::Error::msg)?;
    }
    if a.video.is_some() {
        crate::report::animate::check_ffmpeg().map_err(anyhow::Error::msg)?;
    }
    // The engines' folders of --out are rewritten or removed: the scene may not be in it.
    super::check_input_outside(&a.out, "the scene", &a.scene, &[])?;
    let scene = load_scene_with_overrides(&a.scene, &a.set)?;
    for record in scene.record_files() {
        super::check_input_outside(&a.out, "the record", &record, &[])?;
    }
    let reference = ReferenceSpec::parse(&a.reference);
    if let ReferenceSpec::File(f) = &reference {
        // The engines' folders, plots and paper of --out are rewritten or removed.
        super::check_input_outside(&a.out, "--reference", f, &[])?;
    }
    let mut opts = CompareOptions::new(a.engines.clone(), reference);
    opts.metrics.grid_dt = a.grid_dt;
    opts.metrics.up_to_impacts = a.up_to_impacts.clone();
    if let Some(w) = &a.window {
        let &[t0, t1] = w.as_slice() else {
            bail!("--window: two times T0,T1 (got {} value(s))", w.len());
        };
        if t1 <= t0 || !t0.is_finite() || !t1.is_finite() {
            bail!(
                "--window: T1 must be greater than T0 (got {},{})",
                crate::scene::num(t0),
                crate::scene::num(t1)
            );
        }
        if t1 <= 0.0 || t0 >= scene.duration {
            bail!(
                "--window: {},{} s lies outside the scene's run, 0 to {} s",
                crate::scene::num(t0),
                crate::scene::num(t1),
                crate::scene::num(scene.duration)
            );
        }
        opts.metrics.window = Some((t0, t1));
    }
    let (t0, t1) = opts.metrics.window.unwrap_or((0.0, scene.duration));
    let span = t1.min(scene.duration) - t0.max(0.0);
    crate::metrics::check_grid(a.grid_dt, span).map_err(|e| anyhow::anyhow!("--grid-dt: {e}"))?;
    super::check_jobs(a.jobs)?;
    if a.timing_runs == 0 || a.timing_runs > MAX_TIMING_RUNS {
        bail!(
            "--timing-runs: from 1 to {MAX_TIMING_RUNS} (got {})",
            a.timing_runs
        );
    }
    opts.jobs = a.jobs.unwrap_or_else(default_jobs);
    opts.progress = !a.quiet;
    opts.timing_runs = a.timing_runs;
    // A Ctrl-C stops the runs under way (external workers killed) and writes nothing: a
    // comparison keeps no runs, so it is made again whole. After the runs its files are
    // written whole, and a video under way stops (ffmpeg killed, the file removed).
    let interrupt = crate::interrupt::Interrupt::install();
    let runner = |name: &str, scene: &crate::scene::Scene| {
        run_engine_reporting(name, scene, &crate::interrupt::go_on_unless_interrupted)
    };
    let compared = compare_with_runner(&scene, &opts, &runner);
    if interrupt.requested() {
        return Err(crate::interrupt::Stopped::nothing_written("").into());
    }
    let c = compared?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    // What an earlier comparison wrote here (its metrics.csv says so) and this one will not
    // (another engine's run, a plot of another block, a paper or video not asked for) would
    // sit beside its outputs.
    if a.out.join("metrics.csv").is_file() {
        let mut stale: Vec<&str> = crate::engines::registry::names();
        stale.push("plots");
        if !a.paper {
            stale.push("paper");
        }
        stale.extend(["animation.mp4", "animation.gif"]);
        super::remove_stale(&a.out, &stale)?;
    }
    write_comparison(&a.out, &c, &command).map_err(anyhow::Error::msg)?;
    if a.paper {
        crate::paper::write_compare(&a.out.join("paper"), &c, &command)
            .map_err(anyhow::Error::msg)?;
    }
    if let Some(v) = &a.video {
        let path = a.out.join(format!("animation.{v}"));
        let tracks = crate::report::animation_tracks(&c);
        let written = crate::report::animate::Animation::new(&c.scene, &tracks)
            .write_video(&path, &crate::interrupt::requested);
        if written.is_err() && interrupt.requested() {
            return Err(crate::interrupt::Stopped(format!(
                "interrupted; {} is written without its video (the same command with \
                 --video writes it again)",
                a.out.display()
            ))
            .into());
        }
        written.map_err(anyhow::Error::msg)?;
        println!("wrote {}", path.display());
    }
    for p in summary_paragraphs_for(&c) {
        println!("{p}\n");
    }
    println!(
        "wrote {}/{{metrics.csv, metrics.json, report.md, report.html}} ({} metric rows)",
        a.out.display(),
        c.rows.len()
    );
    Ok(())
}
