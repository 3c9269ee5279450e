//! `rockbench animate RUN_DIR... --out FILE.html [--video FILE.mp4|gif]`: the motion of runs
//! made with `rockbench run`, overlaid (the first run, or `--reference`, solid).

use crate::engines::registry::load_scene;
use crate::report::PALETTE;
use crate::report::animate::{Animation, REFERENCE_COLOR, Track, check_drawable, page};
use crate::scene::{Scene, json_sha256};
use crate::summary::Summary;
use crate::trajectory::Trajectory;
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct AnimateArgs {
    /// Output directories of `rockbench run` (each with trajectory.csv and summary.json).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    /// The page to write.
    #[arg(long, default_value = "out/animation.html")]
    out: PathBuf,
    /// The scene (default: RUN_DIR/scene.json of the first run, else the scene file named in
    /// its summary.json).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// The run drawn solid (a RUN_DIR or its engine name; default the first).
    #[arg(long)]
    reference: Option<String>,
    /// Also write a video (.mp4 or .gif) through ffmpeg.
    #[arg(long, value_name = "FILE")]
    video: Option<PathBuf>,
}

fn read_run(dir: &Path) -> Result<(Summary, Trajectory)> {
    let sp = dir.join("summary.json");
    let text = crate::input_file::read_to_string(&sp).map_err(|e| {
        anyhow::anyhow!(
            "{}: cannot read ({e}); is it a `rockbench run` output directory?",
            sp.display()
        )
    })?;
    let summary: Summary = serde_json::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: not a rockbench summary: {e}", sp.display()))?;
    let tp = dir.join("trajectory.csv");
    // The reader's errors name the file.
    let tr = Trajectory::read_csv(&tp).map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok((summary, tr))
}

/// A run directory's own scene, `scene.json` (written with its trajectory since the summary
/// records `scene_sha256`), as JSON; `None` for a directory without one. A `scene.json` that
/// is not the summary's scene is an error: the directory mixes two runs.
fn run_scene(dir: &Path, summary: &Summary) -> Result<Option<serde_json::Value>> {
    let p = dir.join("scene.json");
    if !p.is_file() {
        return Ok(None);
    }
    let text = crate::input_file::read_to_string(&p)
        .map_err(|e| anyhow::anyhow!("{}: cannot read ({e})", p.display()))?;
    let scene: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: not a scene's JSON: {e}", p.display()))?;
    if !summary.scene_sha256.is_empty() && json_sha256(&scene) != summary.scene_sha256 {
        bail!(
            "{}: not the scene of {} (its sha256 differs from the summary's scene_sha256): the \
             directory mixes two runs",
            p.display(),
            dir.join("summary.json").display()
        );
    }
    Ok(Some(scene))
}

/// The scene drawn: `--scene`, else the first run's `scene.json`, else the scene file its
/// summary names, which must still be the scene of that run (its `scene_sha256`).
fn scene_of(a: &AnimateArgs, first: &Path, summary: &Summary) -> Result<Scene> {
    let load = |p: &Path| load_scene(p).map_err(|e| anyhow::anyhow!("{e}"));
    if let Some(p) = &a.scene {
        return load(p);
    }
    if first.join("scene.json").is_file() {
        return load(&first.join("scene.json"));
    }
    let path = PathBuf::from(&summary.scene_file);
    let scene = load(&path).map_err(|e| {
        anyhow::anyhow!(
            "{e} (the scene named in {}; give it with --scene)",
            first.join("summary.json").display()
        )
    })?;
    if !summary.scene_sha256.is_empty() && scene.sha256() != summary.scene_sha256 {
        bail!(
            "{}: not the scene of the run in {} (changed since the run, or another file of that \
             name): give the run's scene with --scene",
            path.display(),
            first.display()
        );
    }
    Ok(scene)
}

/// The parts of a scene's JSON that the page draws besides the trajectories: the blocks and
/// the ground's motion.
const DRAWN_PARTS: [&str; 2] = ["blocks", "excitation"];

/// Check that run `dir` (its summary, trajectory and own scene, if it has one) is drawn right
/// over `scene`: the summary is of this trajectory, the run's blocks and ground motion are the
/// scene's, and the trajectory spans the scene's duration.
fn check_run(
    scene: &Scene,
    dir: &Path,
    summary: &Summary,
    tr: &Trajectory,
    own: Option<&serde_json::Value>,
) -> Result<()> {
    let csv = dir.join("trajectory.csv");
    if !summary.trajectory_sha256.is_empty() {
        let bytes = crate::input_file::read(&csv)
            .map_err(|e| anyhow::anyhow!("{}: cannot read ({e})", csv.display()))?;
        if crate::digest::sha256_hex(&bytes) != summary.trajectory_sha256 {
            bail!(
                "{}: not the trajectory of {} (its sha256 differs from the summary's \
                 trajectory_sha256): the directory mixes two runs, or the file was changed",
                csv.display(),
                dir.join("summary.json").display()
            );
        }
    }
    let names = |it: &mut dyn Iterator<Item = &String>| it.cloned().collect::<Vec<_>>();
    let in_summary = names(&mut summary.blocks.iter().map(|b| &b.name));
    let in_trajectory = names(&mut tr.blocks.iter().map(|b| &b.name));
    if in_summary != in_trajectory || summary.samples != tr.t.len() {
        bail!(
            "{}: not the summary of {} ({} samples of {}, the trajectory {} of {})",
            dir.join("summary.json").display(),
            dir.join("trajectory.csv").display(),
            summary.samples,
            in_summary.join(", "),
            tr.t.len(),
            in_trajectory.join(", ")
        );
    }
    if in_trajectory != names(&mut scene.blocks.iter().map(|b| &b.name)) {
        bail!(
            "{}: its blocks are not the scene's ({}); give the scene with --scene",
            dir.display(),
            scene.source
        );
    }
    if let Some(own) = own {
        let drawn = scene.to_json();
        if let Some(part) = DRAWN_PARTS.iter().find(|k| own.get(**k) != drawn.get(**k)) {
            bail!(
                "{}: the run's {part} differ from those of the scene drawn ({})",
                dir.join("scene.json").display(),
                scene.source
            );
        }
    }
    // The ground drawn is the records' as they are now: they must be those the run read.
    if !summary.record_sha256.is_empty() {
        let now = scene.record_hashes();
        if let Some((file, _)) = summary
            .record_sha256
            .iter()
            .find(|(f, h)| now.get(*f) != Some(*h))
        {
            bail!(
                "{file}: not the record the run in {} read (its sha256 differs from the summary's \
                 record_sha256): the ground drawn would not be the run's",
                dir.display()
            );
        }
    }
    let end = tr.t.last().copied().unwrap_or(0.0);
    let slack = 0.5 * summary.output_interval.max(0.0) + 1e-9 * scene.duration.max(1.0);
    if (end - scene.duration).abs() > slack {
        bail!(
            "{}: ends at t = {end} s, the scene drawn ({}) at {} s",
            dir.join("trajectory.csv").display(),
            scene.source,
            scene.duration
        );
    }
    check_drawable(scene, tr)
        .map_err(|e| anyhow::anyhow!("{}: {e}", dir.join("trajectory.csv").display()))
}

pub fn animate(a: AnimateArgs) -> Result<()> {
    // A Ctrl-C stops a video under way (ffmpeg killed, the file removed) and writes no page.
    let interrupt = crate::interrupt::Interrupt::install();
    if let Some(v) = &a.video {
        crate::report::animate::video_kind(v).map_err(anyhow::Error::msg)?;
        if super::same_file(v, &a.out) {
            bail!(
                "--video {}: the page's own path (--out): give the video another name",
                v.display()
            );
        }
        writable(v).map_err(|e| anyhow::anyhow!("--video: {}: {e}", v.display()))?;
        crate::report::animate::check_ffmpeg().map_err(anyhow::Error::msg)?;
    }
    let runs: Vec<(PathBuf, Summary, Trajectory)> = a
        .runs
        .iter()
        .map(|d| read_run(d).map(|(s, t)| (d.clone(), s, t)))
        .collect::<Result<_>>()?;
    let scene = scene_of(&a, &runs[0].0, &runs[0].1)?;
    // The page and the video may not land on what they are drawn from.
    let mut inputs: Vec<(String, PathBuf)> = a
        .runs
        .iter()
        .flat_map(|d| {
            ["trajectory.csv", "summary.json", "scene.json"]
                .map(|f| (format!("the run's {f}"), d.join(f)))
        })
        .collect();
    inputs.extend(
        a.scene
            .iter()
            .map(|p| ("the scene (--scene)".into(), p.clone())),
    );
    inputs.extend(
        scene
            .record_files()
            .into_iter()
            .map(|p| ("the scene's record".into(), p)),
    );
    super::check_not_an_input(&a.out, "--out", &inputs)?;
    if let Some(v) = &a.video {
        super::check_not_an_input(v, "--video", &inputs)?;
    }
    let ref_index = match &a.reference {
        None => 0,
        Some(r) => reference_index(&runs, r)?,
    };
    let mut tracks = Vec::new();
    for (k, (d, s, tr)) in runs.iter().enumerate() {
        let own = run_scene(d, s)?;
        check_run(&scene, d, s, tr, own.as_ref())?;
        // Times that do not increase, a value that is not finite or a start that is not the
        // scene's would draw a wrong motion.
        let run = crate::metrics::Run {
            name: d.join("trajectory.csv").display().to_string(),
            trajectory: tr.clone(),
            exact_impacts: None,
            cost: Default::default(),
        };
        crate::metrics::check_reference_file(&scene, &run).map_err(|e| anyhow::anyhow!("{e}"))?;
        // Two runs of one engine are told apart by their directory.
        let name = if runs.iter().filter(|r| r.1.engine == s.engine).count() > 1 {
            format!("{} ({})", s.engine, d.display())
        } else {
            s.engine.clone()
        };
        tracks.push(Track {
            name,
            color: if k == ref_index {
                REFERENCE_COLOR.into()
            } else {
                PALETTE[tracks.iter().filter(|t: &&Track| !t.reference).count() % PALETTE.len()]
                    .to_string()
            },
            reference: k == ref_index,
            trajectory: tr.clone(),
        });
    }
    let anim = Animation::new(&scene, &tracks);
    let intro = format!(
        "Scene {} ({} block{}, {} s): {}. Blocks drawn to scale from each trajectory; the first \
         run (or --reference) solid, the others outlined.",
        scene.name,
        scene.blocks.len(),
        if scene.blocks.len() == 1 { "" } else { "s" },
        scene.duration,
        runs.iter()
            .map(|(d, s, _)| format!("{} ({})", s.engine, d.display()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    // The video first: a page is written only with the video asked for beside it.
    if let Some(v) = &a.video {
        let written = anim
            .write_video(v, &crate::interrupt::requested)
            .and_then(|()| match std::fs::metadata(v) {
                Ok(m) if m.len() > 0 => Ok(()),
                _ => Err(format!(
                    "--video: ffmpeg reported success but wrote no {}",
                    v.display()
                )),
            });
        if let Err(e) = written {
            // Nothing half-written.
            let _ = std::fs::remove_file(v);
            if interrupt.requested() {
                return Err(crate::interrupt::Stopped::nothing_written("").into());
            }
            bail!(e);
        }
    }
    let written = a
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or(Ok(()), std::fs::create_dir_all)
        .and_then(|()| {
            std::fs::write(
                &a.out,
                page(&format!("rockbench: {}", scene.name), &intro, &anim),
            )
        });
    if let Err(e) = written {
        if let Some(v) = &a.video {
            let _ = std::fs::remove_file(v);
        }
        bail!("{}: {e}", a.out.display());
    }
    println!("wrote {}", a.out.display());
    if let Some(v) = &a.video {
        println!("wrote {}", v.display());
    }
    Ok(())
}

/// The run `--reference r` names: a run directory given (however its path is spelt), or the
/// one run of engine `r`.
fn reference_index(runs: &[(PathBuf, Summary, Trajectory)], r: &str) -> Result<usize> {
    if let Some(k) = runs
        .iter()
        .position(|(d, _, _)| super::same_file(d, Path::new(r)))
    {
        return Ok(k);
    }
    let of_engine: Vec<usize> = (0..runs.len()).filter(|&k| runs[k].1.engine == r).collect();
    match of_engine[..] {
        [k] => Ok(k),
        [] => bail!("--reference {r}: not one of the runs given, nor the engine of one"),
        _ => bail!(
            "--reference {r}: {} runs are of that engine: name the run directory",
            of_engine.len()
        ),
    }
}

/// Check that `path` can be written (its folder made if need be), leaving no file behind.
fn writable(path: &std::path::Path) -> std::io::Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    let existed = path.exists();
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)?;
    if !existed {
        std::fs::remove_file(path)?;
    }
    Ok(())
}
