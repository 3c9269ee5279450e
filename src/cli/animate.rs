//! `rockbench animate RUN_DIR... --out FILE.html [--video FILE.mp4|gif]`: the motion of runs
//! made with `rockbench run`, overlaid (the first run, or `--reference`, solid).

use crate::engines::registry::load_scene;
use crate::report::PALETTE;
use crate::report::animate::{Animation, REFERENCE_COLOR, Track, page};
use crate::scene::Scene;
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
    let text = std::fs::read_to_string(&sp).map_err(|e| {
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

fn scene_of(a: &AnimateArgs, first: &Path, summary: &Summary) -> Result<Scene> {
    let path = match &a.scene {
        Some(p) => p.clone(),
        None if first.join("scene.json").is_file() => first.join("scene.json"),
        None => PathBuf::from(&summary.scene_file),
    };
    load_scene(&path).map_err(|e| anyhow::anyhow!("{e}"))
}

pub fn animate(a: AnimateArgs) -> Result<()> {
    if let Some(v) = &a.video {
        crate::report::animate::video_kind(v).map_err(anyhow::Error::msg)?;
        writable(v).map_err(|e| anyhow::anyhow!("--video: {}: {e}", v.display()))?;
    }
    let runs: Vec<(PathBuf, Summary, Trajectory)> = a
        .runs
        .iter()
        .map(|d| read_run(d).map(|(s, t)| (d.clone(), s, t)))
        .collect::<Result<_>>()?;
    let scene = scene_of(&a, &runs[0].0, &runs[0].1)?;
    let ref_index = match &a.reference {
        None => 0,
        Some(r) => runs
            .iter()
            .position(|(d, s, _)| s.engine == *r || d == Path::new(r))
            .ok_or_else(|| anyhow::anyhow!("--reference {r}: not one of the runs given"))?,
    };
    let mut tracks = Vec::new();
    for (k, (d, s, tr)) in runs.iter().enumerate() {
        if tr.blocks.len() != scene.blocks.len()
            || tr
                .blocks
                .iter()
                .zip(&scene.blocks)
                .any(|(h, b)| h.name != b.name)
        {
            bail!(
                "{}: its blocks are not the scene's ({}); give the scene with --scene",
                d.display(),
                scene.source
            );
        }
        // Times that do not increase, or a value that is not finite, would draw a wrong motion.
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
    if let Some(parent) = a.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .map_err(|e| anyhow::anyhow!("{}: {e}", parent.display()))?;
    }
    std::fs::write(
        &a.out,
        page(&format!("rockbench: {}", scene.name), &intro, &anim),
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", a.out.display()))?;
    println!("wrote {}", a.out.display());
    if let Some(v) = &a.video {
        if let Err(e) = anim.write_video(v) {
            // Nothing half-written: neither the page nor a part of the video.
            let _ = std::fs::remove_file(&a.out);
            let _ = std::fs::remove_file(v);
            anyhow::bail!(e);
        }
        println!("wrote {}", v.display());
    }
    Ok(())
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
