//! Records the versions of the numerical dependencies (from Cargo.lock) as `RB_VERSION_<NAME>`
//! environment variables, so every output can name them.
fn main() {
    println!("cargo:rerun-if-changed=Cargo.lock");
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
