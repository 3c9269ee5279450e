//! `rockbench check SCENE`: validate a scene without running it.

use crate::engines::registry::load_scene_with_overrides;
use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CheckArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// Override a scene field, e.g. --set native.dt=5e-4 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

pub fn check(a: CheckArgs) -> Result<()> {
    let s = load_scene_with_overrides(&a.scene, &a.set)?;
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
    Ok(())
}
