//! The Python sources of the worker engines (MuJoCo's and PyBullet's worker, its engines and
//! Siconos' worker) and their FNV-1a hash, part of the run stores' keys of those engines. The
//! build script compiles the hash in (`RB_WORKER_HASH`) with the same functions; the program
//! hashes the files again where they are, so an edited worker never reuses an old result.

use std::path::{Path, PathBuf};

/// The worker's own files, relative to the package's directory.
pub const WORKER_FILES: [&str; 2] = [
    "python/rockbench/worker.py",
    "python/rockbench/siconos_worker.py",
];

/// The folder of the worker's engine modules (every `.py` in it).
pub const WORKER_ENGINES: &str = "python/rockbench/engines";

/// The worker's files under `root`, as paths relative to it.
pub fn worker_files(root: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = WORKER_FILES.iter().map(PathBuf::from).collect();
    if let Ok(rd) = std::fs::read_dir(root.join(WORKER_ENGINES)) {
        for e in rd.flatten() {
            if e.path().extension().is_some_and(|x| x == "py") {
                files.push(Path::new(WORKER_ENGINES).join(e.file_name()));
            }
        }
    }
    files
}

/// FNV-1a of `files` (relative to `root`; sorted): each one's relative path, then its contents
/// (none for a file that cannot be read).
pub fn fnv(root: &Path, mut files: Vec<PathBuf>) -> String {
    files.sort();
    let mut h: u64 = 0xcbf29ce484222325;
    for f in files {
        let bytes = std::fs::read(root.join(&f)).unwrap_or_default();
        for b in f.display().to_string().bytes().chain(bytes) {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    format!("{h:016x}")
}
