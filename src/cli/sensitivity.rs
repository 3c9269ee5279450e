//! `rockbench sensitivity SCENE --perturb KEY=VALUE --configs ... --members N --out DIR`: a scene
//! run as ensembles perturbed at round-off (see `crate::sensitivity`).

use crate::sensitivity::{Study, parse_configs};
use anyhow::{Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SensitivityArgs {
    /// Scene file (TOML or JSON).
    scene: PathBuf,
    /// The scene value perturbed, and its value: member k runs with VALUE (1 + k epsilon).
    #[arg(long, value_name = "KEY=VALUE")]
    perturb: String,
    /// Configurations, comma-separated, each ENGINE[:KEY=VALUE[;KEY=VALUE...]]; the first is
    /// the one every other is compared with first.
    #[arg(long, default_value = "native,rapier")]
    configs: String,
    /// Runs a configuration (2 or more).
    #[arg(long, default_value_t = 4)]
    members: usize,
    /// The relative perturbation between neighbouring members.
    #[arg(long, default_value_t = 1e-12)]
    epsilon: f64,
    /// Override a scene field for every run (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    #[arg(long, default_value = "out/sensitivity")]
    out: PathBuf,
}

pub fn run(a: SensitivityArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    let Some((key, value)) = a.perturb.split_once('=') else {
        bail!("--perturb: needs KEY=VALUE (got {:?})", a.perturb);
    };
    let Ok(value) = value.trim().parse::<f64>() else {
        bail!("--perturb: {value:?} is not a number");
    };
    let study = Study {
        about: format!("`{}`", a.scene.display()),
        scene: a.scene,
        perturb: (key.trim().to_string(), value),
        epsilon: a.epsilon,
        members: a.members,
        configs: parse_configs(&a.configs)?,
        sets: a.set,
    };
    let interrupt = crate::interrupt::Interrupt::install();
    let md = study.run(&a.out, &|line| eprintln!("{line}"))?;
    drop(interrupt);
    print!("{md}");
    eprintln!("wrote {}", a.out.join("sensitivity.md").display());
    Ok(())
}
