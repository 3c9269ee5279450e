//! Inputs that crashed (or would hang or exhaust memory in) the parsers, found by fuzzing or
//! review, replayed through the same calls as the fuzz targets in fuzz/fuzz_targets/. Add a
//! file under tests/fuzz_regressions/<target>/ for every crash `make fuzz` finds.

use rockbench::engines::registry::check_scene_str;
use rockbench::excitation::records::{Quantity, parse_at2, parse_two_column};
use rockbench::scene::parse_scene_str;
use rockbench::trajectory::Trajectory;
use std::path::{Path, PathBuf};

/// The files the suite, study and gate targets find beside their input.
#[path = "../fuzz/fuzz_targets/fixture.rs"]
mod fixture;

fn inputs(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    files(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fuzz_regressions")
            .join(target),
    )
}

/// A fuzz target's seeds (fuzz/seeds/<target>/): inputs it must accept.
fn seeds(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    files(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/seeds")
            .join(target),
    )
}

/// Every file of a folder, sorted by path; none for a folder that does not exist.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<_> = entries
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
    for (p, data) in seeds(target) {
        let text = std::str::from_utf8(&data).unwrap();
        let r = parse_scene_str(text, is_json, "fuzz", &[]);
        assert!(
            r.is_ok(),
            "{}: seed refused: {}",
            p.display(),
            r.unwrap_err()
        );
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
        let good = seeds(target);
        assert!(!good.is_empty(), "{target}: no seed");
        for (p, data) in good {
            let r = parse(&String::from_utf8_lossy(&data));
            assert!(
                r.is_ok(),
                "{}: seed refused: {}",
                p.display(),
                r.unwrap_err()
            );
        }
    }
}

/// The suite, study and gate targets' inputs: the seeds are accepted, the regressions refused
/// in one line that names the file read.
#[test]
fn suite_study_and_gate_regressions_and_seeds() {
    // Each loader's error as (the file it names, its line).
    type Load = fn(&Path) -> Result<(), (String, String)>;
    for (target, load) in [
        (
            "suite_manifest",
            (|p| {
                rockbench::excitation::suite::load_suite(p)
                    .map(|_| ())
                    .map_err(|e| (e.file.clone(), e.to_string()))
            }) as Load,
        ),
        ("study_file", |p| {
            rockbench::fragility::study::load_study(p)
                .map(|_| ())
                .map_err(|e| (e.file.clone(), e.to_string()))
        }),
        ("gate_file", |p| {
            rockbench::gates::load_gates(p)
                .map(|_| ())
                .map_err(|e| (e.file.clone(), e.to_string()))
        }),
    ] {
        let dir = tempfile::tempdir().unwrap();
        fixture::write_into(dir.path());
        let name = format!("replayed-{target}.toml");
        let good = seeds(target);
        assert!(!good.is_empty(), "{target}: no seed");
        for (p, data) in good {
            let r = load(&fixture::input(dir.path(), &name, &data));
            assert!(r.is_ok(), "{}: refused: {}", p.display(), r.unwrap_err().1);
        }
        for (p, data) in inputs(target) {
            let path = fixture::input(dir.path(), &name, &data);
            let (file, line) = load(&path).expect_err(&format!("{}: accepted", p.display()));
            if target == "gate_file" {
                // A gate file's error may name a file it includes, all of them in the folder.
                assert!(!line.contains('\n'), "{}: {line}", p.display());
                assert_eq!(Path::new(&file).parent(), Some(dir.path()), "{line}");
            } else {
                fixture::assert_one_line_naming(&path, &file, &line);
            }
        }
    }
}

/// The trajectory target's inputs: the seeds read and write back to themselves, the
/// regressions are refused in one line.
#[test]
fn trajectory_regressions_and_seeds() {
    let good = seeds("trajectory_csv");
    assert!(!good.is_empty());
    for (p, data) in good {
        let tr = Trajectory::parse_csv(&String::from_utf8_lossy(&data))
            .unwrap_or_else(|e| panic!("{}: refused: {e}", p.display()));
        let mut out = Vec::new();
        tr.write_csv_to(&mut out).unwrap();
        assert_eq!(
            Trajectory::parse_csv(std::str::from_utf8(&out).unwrap()).unwrap(),
            tr,
            "{}",
            p.display()
        );
    }
    for (p, data) in inputs("trajectory_csv") {
        let e = Trajectory::parse_csv(&String::from_utf8_lossy(&data))
            .expect_err(&format!("{}: accepted", p.display()));
        assert!(!e.contains('\n'), "{}: {e}", p.display());
    }
}

/// The checkpoint target's seeds are a checkpoint file and its sealed content, written by an
/// earlier build: each is read whole, to the check of the build that wrote it (this build's
/// own, or "another rockbench build"), so the fuzzer starts from the format as it is. A change
/// of the format fails here: write them again as fuzz/fuzz_targets/checkpoint.rs says.
#[test]
fn checkpoint_regressions_and_seeds() {
    use rockbench::native::checkpoint::{Checkpoint, seal};
    let read = |data: &[u8]| {
        let (&mode, rest) = data.split_first().expect("a mode byte");
        let file = if mode % 2 == 1 {
            seal(rest.to_vec())
        } else {
            rest.to_vec()
        };
        Checkpoint::from_file_bytes(&file, fixture::SCENE)
    };
    let good = seeds("checkpoint");
    assert_eq!(good.len(), 2);
    for (p, data) in good {
        if let Err(e) = read(&data) {
            assert!(
                e.starts_with("written by another rockbench build")
                    || e == "written for another scene, other --set overrides or other record files",
                "{}: the seed is not read to its build's check: {e}",
                p.display()
            );
        }
    }
    for (p, data) in inputs("checkpoint") {
        let e = read(&data).map(|_| ()).expect_err(&p.display().to_string());
        assert!(!e.contains('\n'), "{}: {e}", p.display());
    }
}

/// The resume target's seeds pick each stopped run with nothing changed: it resumes to its end.
/// Its crashes replay here: each ends in the outputs or one error line.
#[test]
fn resume_regressions_and_seeds() {
    let dir = std::env::temp_dir().join(format!("rb-fuzz-resume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = seeds("resume");
    assert_eq!(good.len(), 2);
    for (p, data) in good {
        let resumed = fixture::resume_changed(&dir, &data);
        assert_eq!(resumed, Ok(()), "{}", p.display());
    }
    for (p, data) in inputs("resume") {
        if let Err(e) = fixture::resume_changed(&dir, &data) {
            assert!(!e.contains('\n'), "{}: {e}", p.display());
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
