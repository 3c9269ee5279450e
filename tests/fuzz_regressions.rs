//! Inputs that crashed (or would hang or exhaust memory in) the parsers, found by fuzzing or
//! review, replayed through the same calls as the fuzz targets in fuzz/fuzz_targets/. Add a
//! file under tests/fuzz_regressions/<target>/ for every crash `make fuzz` finds.

use rockbench::engines::registry::check_scene_str;
use rockbench::excitation::records::{Quantity, parse_at2, parse_two_column};
use rockbench::scene::parse_scene_str;
use std::path::{Path, PathBuf};

fn inputs(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz_regressions")
        .join(target);
    let mut v: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

fn scene(target: &str, is_json: bool) -> usize {
    let cases = inputs(target);
    for (p, data) in &cases {
        let Ok(text) = std::str::from_utf8(data) else {
            continue;
        };
        if let Err(e) = parse_scene_str(text, is_json, "fuzz", &[]) {
            assert!(!e.to_string().contains('\n'), "{}: {e}", p.display());
        }
        let base = Path::new("/nonexistent-rockbench-fuzz");
        let r = check_scene_str(text, is_json, "fuzz", &[], base);
        assert!(r.is_err(), "{}: expected a refusal", p.display());
    }
    cases.len()
}

#[test]
fn scene_toml_regressions() {
    assert!(scene("scene_toml", false) >= 1);
}

#[test]
fn scene_json_regressions() {
    assert!(scene("scene_json", true) >= 1);
}

#[test]
fn record_regressions() {
    for (target, parse) in [
        ("record_at2", parse_at2 as fn(&str) -> Result<_, String>),
        ("record_csv", |text| {
            parse_two_column(text, Quantity::Acceleration)
        }),
    ] {
        let cases = inputs(target);
        assert!(!cases.is_empty());
        for (p, data) in cases {
            let text = String::from_utf8_lossy(&data);
            match parse(&text) {
                Ok(s) => assert!(
                    s.t.windows(2).all(|w| w[1] > w[0])
                        && s.t.iter().chain(&s.v).all(|x| x.is_finite()),
                    "{}: accepted a bad record",
                    p.display()
                ),
                Err(e) => assert!(!e.contains('\n'), "{}: {e}", p.display()),
            }
        }
    }
}
