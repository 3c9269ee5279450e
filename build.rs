//! Records the versions of the numerical dependencies (from Cargo.lock) as `RB_VERSION_<NAME>`
//! environment variables, and the build's own identity (`RB_SOURCE_HASH`, `RB_GIT_COMMIT`), so
//! every output can name them.
use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "src/worker_sources.rs"]
mod worker_sources;

/// The files and directories whose changes make another program: the build script reruns when
/// any of them changes, and `RB_GIT_COMMIT` is marked modified when any differs from the commit.
const BUILD_INPUTS: [&str; 7] = [
    "src",
    "build.rs",
    "Cargo.toml",
    "Cargo.lock",
    worker_sources::WORKER_FILES[0],
    worker_sources::WORKER_FILES[1],
    worker_sources::WORKER_ENGINES,
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
    println!(
        "cargo:rustc-env=RB_SOURCE_HASH={}",
        worker_sources::fnv(Path::new("."), files)
    );
}

/// `RB_WORKER_HASH`: FNV-1a of the Python sources of the worker engines
/// ([`worker_sources::worker_files`]), part of the run stores' keys of those engines.
fn worker_hash() {
    println!("cargo:rerun-if-changed={}", worker_sources::WORKER_ENGINES);
    let files = worker_sources::worker_files(Path::new("."));
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    println!(
        "cargo:rustc-env=RB_WORKER_HASH={}",
        worker_sources::fnv(Path::new("."), files)
    );
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
