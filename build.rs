//! Records the versions of the numerical dependencies (from Cargo.lock) as `RB_VERSION_<NAME>`
//! environment variables, and the build's own identity (`RB_SOURCE_HASH`, `RB_GIT_COMMIT`), so
//! every output can name them.
use std::path::{Path, PathBuf};
use std::process::Command;

/// The files and directories whose changes make another program: the build script reruns when
/// any of them changes, and `RB_GIT_COMMIT` is marked modified when any differs from the commit.
const BUILD_INPUTS: [&str; 6] = [
    "src",
    "build.rs",
    "Cargo.toml",
    "Cargo.lock",
    "python/rockbench/worker.py",
    "python/rockbench/engines",
];

fn main() {
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=Cargo.toml");
    println!("cargo:rerun-if-changed=build.rs");
    source_hash();
    worker_hash();
    git_commit();
    let lock = std::fs::read_to_string("Cargo.lock").unwrap_or_default();
    let mut found = Vec::new();
    let mut name: Option<String> = None;
    for line in lock.lines() {
        if let Some(n) = line.strip_prefix("name = ") {
            name = Some(n.trim_matches('"').to_string());
        } else if let Some(v) = line.strip_prefix("version = ")
            && let Some(n) = name.take()
            && ["clarabel", "nalgebra", "rapier2d-f64", "pyo3"].contains(&n.as_str())
        {
            let key = n.to_ascii_uppercase().replace('-', "_");
            println!("cargo:rustc-env=RB_VERSION_{key}={}", v.trim_matches('"'));
            found.push(key);
        }
    }
    // Dependencies not in the lock file (a feature turned off) read as "none".
    for key in ["CLARABEL", "NALGEBRA", "RAPIER2D_F64", "PYO3"] {
        if !found.iter().any(|f| f == key) {
            println!("cargo:rustc-env=RB_VERSION_{key}=none");
        }
    }
}

/// `RB_SOURCE_HASH`: FNV-1a of every file under src/ (paths and contents, sorted), the
/// program's identity in the fragility run cache's keys.
fn source_hash() {
    println!("cargo:rerun-if-changed=src");
    let mut files = Vec::new();
    let mut stack = vec![PathBuf::from("src")];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                println!("cargo:rerun-if-changed={}", p.display());
                files.push(p);
            }
        }
    }
    println!("cargo:rustc-env=RB_SOURCE_HASH={}", fnv(files));
}

/// `RB_WORKER_HASH`: FNV-1a of the Python sources of the MuJoCo and PyBullet worker
/// (python/rockbench/worker.py and python/rockbench/engines/*.py) and of the Siconos worker
/// (python/rockbench/siconos_worker.py), part of the run stores' keys of those engines.
fn worker_hash() {
    let mut files = vec![
        PathBuf::from("python/rockbench/worker.py"),
        PathBuf::from("python/rockbench/siconos_worker.py"),
    ];
    println!("cargo:rerun-if-changed=python/rockbench/engines");
    if let Ok(rd) = std::fs::read_dir("python/rockbench/engines") {
        for e in rd.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "py") {
                files.push(p);
            }
        }
    }
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    println!("cargo:rustc-env=RB_WORKER_HASH={}", fnv(files));
}

/// `RB_GIT_COMMIT`: the commit the program was built from (`git rev-parse HEAD` in the package's
/// directory at build time), with ` (modified)` when a build input differs from it, or `unknown
/// (not built from a git checkout)`. The script reruns when HEAD or the branch it names moves.
fn git_commit() {
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git").args(args).output().ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    };
    let commit = git(&["rev-parse", "--verify", "HEAD"]).filter(|c| !c.is_empty());
    let Some(commit) = commit else {
        println!("cargo:rustc-env=RB_GIT_COMMIT=unknown (not built from a git checkout)");
        return;
    };
    // HEAD, the branch's loose ref and the packed refs: whichever exist (a path that does not
    // exist would rerun the script on every build).
    let mut watched = vec![git(&["rev-parse", "--git-path", "HEAD"])];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watched.push(git(&["rev-parse", "--git-path", &branch]));
    }
    watched.push(git(&["rev-parse", "--git-path", "packed-refs"]));
    for path in watched.into_iter().flatten() {
        if Path::new(&path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    let mut status = vec!["status", "--porcelain", "--"];
    status.extend(BUILD_INPUTS);
    let modified = git(&status).is_none_or(|s| !s.is_empty());
    let suffix = if modified { " (modified)" } else { "" };
    println!("cargo:rustc-env=RB_GIT_COMMIT={commit}{suffix}");
}

/// FNV-1a of the files' paths and contents, in sorted order.
fn fnv(mut files: Vec<PathBuf>) -> String {
    files.sort();
    let mut h: u64 = 0xcbf29ce484222325;
    for f in files {
        let bytes = std::fs::read(&f).unwrap_or_default();
        for b in f.display().to_string().bytes().chain(bytes) {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    format!("{h:016x}")
}
