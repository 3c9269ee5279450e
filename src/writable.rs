//! Whether a command can write its outputs where it is told to, checked before any work: a
//! folder that cannot be made or written in, found when the outputs are written, wastes every
//! run made before.

use std::path::{Path, PathBuf};

/// The folder `dir` can be made (with its missing parents) and written in: the nearest folder
/// that exists at or above it is a directory in which this process makes a folder (tried, and
/// removed). `Err` says why, naming that folder.
pub fn check_can_write_in(dir: &Path) -> Result<(), String> {
    let abs = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    let mut existing: PathBuf = abs;
    while !existing.exists() {
        match existing.parent() {
            Some(p) => existing = p.to_path_buf(),
            None => break,
        }
    }
    if !existing.is_dir() {
        return Err(format!("{} is a file, not a directory", existing.display()));
    }
    let probe = existing.join(format!(".rockbench-write-check-{}", std::process::id()));
    std::fs::create_dir(&probe)
        .and_then(|()| std::fs::remove_dir(&probe))
        .map_err(|e| format!("cannot write in {} ({e})", existing.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_that_cannot_be_made_is_named() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(check_can_write_in(&dir.path().join("a/b")), Ok(()));
        assert!(
            std::fs::read_dir(dir.path()).unwrap().next().is_none(),
            "nothing left"
        );
        let file = dir.path().join("f");
        std::fs::write(&file, "x").unwrap();
        let e = check_can_write_in(&file.join("below")).unwrap_err();
        assert_eq!(e, format!("{} is a file, not a directory", file.display()));
        // /proc takes no folder, even from root.
        let e = check_can_write_in(Path::new("/proc/rockbench/out")).unwrap_err();
        assert!(e.starts_with("cannot write in /proc ("), "{e}");
    }
}
