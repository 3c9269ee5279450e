//! `rockbench references [--out DIR] [--check]`: regenerate the generated validation scenes
//! and `reference-data/` (see `rockbench::validation::references`).

use crate::validation::references::{generate, same_file, write_tree};
use anyhow::{Result, bail};
use std::path::PathBuf;

/// Absolute tolerance on the numbers of the converged native run (the two-block case) when
/// checking: its Clarabel/active-set steps may round differently on another CPU, and the
/// motion after the first impacts amplifies such differences. Everything else must agree to
/// 1e-9 relative.
pub const NATIVE_CHECK_TOL: f64 = 1e-6;

#[derive(clap::Args)]
pub struct ReferencesArgs {
    /// Repository root: scene files are read from ROOT/validation/scenes.
    #[arg(long, default_value = ".")]
    root: PathBuf,
    /// Write the generated tree under this directory (default: the root itself).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not write: compare the generated files with those under the root and fail on any
    /// difference.
    #[arg(long)]
    check: bool,
}

pub fn references_cmd(a: ReferencesArgs) -> Result<()> {
    // A Ctrl-C stops the generation and writes nothing; once the tree is written, it is
    // written whole.
    let interrupt = crate::interrupt::Interrupt::install();
    let tree = generate(&a.root);
    if interrupt.requested() {
        return Err(crate::interrupt::Stopped::nothing_written("").into());
    }
    let tree = tree.map_err(anyhow::Error::msg)?;
    if a.check {
        let mut bad = Vec::new();
        for (rel, text) in &tree {
            let p = a.root.join(rel);
            match std::fs::read_to_string(&p) {
                Ok(old) => {
                    if let Err(e) = same_file(rel, &old, text, NATIVE_CHECK_TOL) {
                        bad.push(e);
                    }
                }
                Err(e) => bad.push(format!("{}: {e}", p.display())),
            }
        }
        if !bad.is_empty() {
            bail!(
                "{} generated files differ from the committed ones:\n{}",
                bad.len(),
                bad.join("\n")
            );
        }
        println!("{} files reproduced", tree.len());
        return Ok(());
    }
    let out = a.out.unwrap_or(a.root);
    write_tree(&tree, &out).map_err(anyhow::Error::msg)?;
    println!("wrote {} files under {}", tree.len(), out.display());
    Ok(())
}
