//! What program this is: the package version, the commit it was built from and the hash of its
//! sources, fixed at build time (build.rs), so that every output names the program that wrote it
//! wherever it is run.

/// The package version (Cargo.toml).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The commit the program was built from, with ` (modified)` when a build input (src/, build.rs,
/// Cargo.toml, Cargo.lock, the Python engines' worker) differed from it at build time, or
/// `unknown (not built from a git checkout)`.
pub const GIT_COMMIT: &str = env!("RB_GIT_COMMIT");

/// FNV-1a of every file under src/ as compiled: the exact identity of the program's code, which
/// a modified commit alone does not give.
pub const SOURCE_HASH: &str = env!("RB_SOURCE_HASH");

/// `rockbench --version`: the version, then the commit and the source hash.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("RB_GIT_COMMIT"),
    ", sources ",
    env!("RB_SOURCE_HASH"),
    ")"
);

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    fn git(args: &[&str]) -> Option<String> {
        let out = Command::new("git")
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    }

    #[test]
    fn the_build_names_the_commit_of_its_own_checkout() {
        let Some(head) = git(&["rev-parse", "HEAD"]) else {
            assert!(GIT_COMMIT.starts_with("unknown"), "{GIT_COMMIT}");
            return;
        };
        // The tests are built from this checkout, so the program's commit is its HEAD (with a
        // mark if the build inputs differ from it).
        assert!(
            GIT_COMMIT == head || GIT_COMMIT == format!("{head} (modified)"),
            "{GIT_COMMIT} against HEAD {head}"
        );
        assert_eq!(SOURCE_HASH.len(), 16);
        assert!(SOURCE_HASH.bytes().all(|b| b.is_ascii_hexdigit()));
        assert!(LONG_VERSION.contains(GIT_COMMIT) && LONG_VERSION.contains(SOURCE_HASH));
    }
}
