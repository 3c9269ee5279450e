//! Records the versions of the numerical dependencies (from Cargo.lock) as `RB_VERSION_<NAME>`
//! environment variables, so every output can name them.
fn main() {
    println!("cargo:rerun-if-changed=Cargo.lock");
    source_hash();
    worker_hash();
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
    let mut stack = vec![std::path::PathBuf::from("src")];
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
/// (python/rockbench/worker.py and python/rockbench/engines/*.py), part of the run cache's
/// keys of those engines.
fn worker_hash() {
    let mut files = vec![std::path::PathBuf::from("python/rockbench/worker.py")];
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

/// FNV-1a of the files' paths and contents, in sorted order.
fn fnv(mut files: Vec<std::path::PathBuf>) -> String {
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
