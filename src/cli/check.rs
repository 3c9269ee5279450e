//! `rockbench check SCENE`: validate a scene without running it; `--engine` also asks the
//! engines named whether they can model it; `--collapse` adds its static collapse acceleration
//! ([`crate::native::collapse`]).

use crate::engines::registry::load_scene_with_overrides;
use crate::native::collapse::collapse_onset;
use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CheckArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Override a scene field, e.g. --set native.dt=5e-4 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Also print the scene's rest interval at the start (the horizontal ground accelerations
    /// under which its blocks stay at rest: the static theorem on the closed points, exact for
    /// the associative law), the loading's peak and the first instant the loading leaves the
    /// interval (docs/method.md).
    #[arg(long)]
    collapse: bool,
    /// Also check that these engines can model the scene (comma-separated): the scenes an
    /// engine cannot model (Housner's: one block on the ground, an acceleration input, ...)
    /// are skipped by `compare` and refused by `run`.
    #[arg(long, value_delimiter = ',')]
    engine: Vec<String>,
}

pub fn check(a: CheckArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    let s = load_scene_with_overrides(&a.scene, &a.set)?;
    crate::engines::registry::check_names("--engine", a.engine.iter().map(|e| e.trim()))
        .map_err(anyhow::Error::msg)?;
    for name in &a.engine {
        let engine = crate::engines::engine_by_name(name.trim())?;
        if let Some(why) = engine.cannot_model(&s) {
            anyhow::bail!(
                "{}: engine {} cannot model this scene: {why}",
                a.scene.display(),
                engine.name()
            );
        }
    }
    println!(
        "{}: ok ({} block{}, {} s, {})",
        a.scene.display(),
        s.blocks.len(),
        if s.blocks.len() == 1 { "" } else { "s" },
        s.duration,
        if s.has_excitation() {
            "ground excitation"
        } else {
            "free rocking"
        }
    );
    if a.collapse {
        println!("{}", collapse_onset(&s)?);
    }
    Ok(())
}
