//! The bad-input catalogue (tests/bad_inputs/expected.toml): every case runs the built
//! `rockbench check` and must fail with exactly one line on stderr that names the file, the
//! field and the problem, with a non-zero exit and no panic.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(serde::Deserialize)]
struct Catalogue {
    case: Vec<Case>,
}

#[derive(serde::Deserialize)]
struct Case {
    file: String,
    why: String,
    field: String,
    message: String,
    #[serde(default)]
    set: Vec<String>,
}

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_inputs")
}

fn catalogue() -> Vec<Case> {
    let text = std::fs::read_to_string(dir().join("expected.toml")).unwrap();
    toml::from_str::<Catalogue>(&text).unwrap().case
}

/// Run `rockbench check` on one case; `Err` describes how it fell short.
fn run_case(c: &Case) -> Result<(), String> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_rockbench"));
    cmd.arg("check").arg(dir().join(&c.file));
    for s in &c.set {
        cmd.arg("--set").arg(s);
    }
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run rockbench: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    let mut problems = Vec::new();
    if out.status.success() {
        problems.push("exit status 0".to_string());
    }
    if stderr.contains("panicked") || out.status.code() == Some(101) {
        problems.push("panicked".to_string());
    }
    if lines.len() != 1 {
        problems.push(format!("{} lines on stderr", lines.len()));
    }
    let line = lines.first().copied().unwrap_or("");
    for (what, needle) in [
        ("file name", c.file.as_str()),
        ("field", &format!("{}: ", c.field)),
        ("message", &c.message),
    ] {
        if !line.contains(needle) {
            problems.push(format!("no {what} `{needle}`"));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} ({}): {}\n    stderr: {}",
            c.file,
            c.why,
            problems.join(", "),
            stderr.trim_end()
        ))
    }
}

#[test]
fn every_bad_input_fails_with_one_precise_line() {
    let cases = catalogue();
    let failures: Vec<String> = cases.iter().filter_map(|c| run_case(c).err()).collect();
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs fell short:\n  {}",
        failures.len(),
        cases.len(),
        failures.join("\n  ")
    );
}

#[test]
fn catalogue_is_complete_and_large_enough() {
    let cases = catalogue();
    assert!(cases.len() >= 45, "only {} cases", cases.len());
    // Every file in the directory is a case, and every case names its reason.
    let mut listed: Vec<&str> = cases.iter().map(|c| c.file.as_str()).collect();
    listed.sort();
    let before = listed.len();
    listed.dedup();
    assert_eq!(before, listed.len(), "a file is listed twice");
    for entry in std::fs::read_dir(dir()).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() || p.file_name().unwrap() == "expected.toml" {
            continue;
        }
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        assert!(
            listed.contains(&name.as_str()),
            "{name} has no entry in expected.toml"
        );
    }
    for c in &cases {
        assert!(!c.why.is_empty() && !c.message.is_empty(), "{}", c.file);
    }
}

/// The same checks hold for a good scene: `check` succeeds silently on stderr (so the bad
/// cases fail for their fault, not for the template they were made from).
#[test]
fn templates_of_the_catalogue_are_valid() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for scene in [
        "validation/scenes/housner-slender.toml",
        "validation/scenes/two-block-free-rocking.toml",
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_rockbench"))
            .arg("check")
            .arg(root.join(scene))
            .output()
            .unwrap();
        assert!(out.status.success(), "{scene}: {:?}", out);
        assert!(out.stderr.is_empty());
    }
    // The one-block template with a good CSV record is valid too.
    let tmp = common::tmp("rb-bad", "template");
    std::fs::create_dir_all(tmp.join("records")).unwrap();
    std::fs::copy(dir().join("records/good.csv"), tmp.join("records/good.csv")).unwrap();
    let text = "name = \"ok\"\nduration = 1.0\n\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n\n[excitation.horizontal]\nkind = \"record\"\nfile = \"records/good.csv\"\n";
    std::fs::write(tmp.join("ok.toml"), text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .arg("check")
        .arg(tmp.join("ok.toml"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{:?}", out);
}

/// `--set` reaches into arrays: `blocks[1].density` changes the second block only, and the
/// catalogue's two-block template (used by the `set-index-*` cases) is valid without it.
#[test]
fn set_indexes_the_blocks_array() {
    let file = dir().join("set-index-out-of-range.toml");
    let plain = rockbench::scene::load_scene(&file).unwrap();
    let set = rockbench::scene::load_scene_with_overrides(
        &file,
        &[
            "blocks[1].density=3000".into(),
            "blocks[0].width=1.5".into(),
        ],
    )
    .unwrap();
    assert_eq!(plain.blocks[1].density, 2500.0);
    assert_eq!(set.blocks[1].density, 3000.0);
    assert_eq!(set.blocks[0].density, plain.blocks[0].density);
    assert_eq!(set.blocks[0].width, 1.5);
    assert_eq!(set.blocks[1].width, plain.blocks[1].width);
}

/// `check --engine` asks the engines named whether they can model the scene: Housner's model
/// is one block on a rigid base, so the two-block stack is one line naming the engine and why,
/// while the slender block passes; an unknown engine is one line.
#[test]
fn check_asks_the_engines_named_whether_they_can_model_the_scene() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let check = |scene: &str, engines: &str| {
        Command::new(env!("CARGO_BIN_EXE_rockbench"))
            .arg("check")
            .arg(root.join(scene))
            .args(["--engine", engines])
            .output()
            .unwrap()
    };
    let o = check(
        "validation/scenes/two-block-free-rocking.toml",
        "native,housner",
    );
    let err = common::one_error_line(&o);
    assert!(
        err.contains("two-block-free-rocking.toml: engine housner cannot model this scene: "),
        "{err}"
    );
    assert!(err.contains("2 blocks"), "{err}");
    let o = check("validation/scenes/housner-slender.toml", "native,housner");
    assert!(o.status.success(), "{o:?}");
    let o = check("validation/scenes/housner-slender.toml", "bogus");
    let err = common::one_error_line(&o);
    assert!(err.contains("--engine: unknown engine `bogus`"), "{err}");
    // Housner's model is driven by the ground's acceleration: a displacement record (impulses
    // at its samples) passed `check` and was refused by `run`.
    let dir = common::tmp("rb-check", "displacement");
    std::fs::write(dir.join("d.csv"), "0,0\n0.1,0.01\n0.2,0\n").unwrap();
    std::fs::write(
        dir.join("moved.toml"),
        "name = \"moved\"\nduration = 1\n[[blocks]]\nname = \"b\"\nwidth = 1\nheight = 2.5\n\
         [excitation.horizontal]\nkind = \"displacement\"\nfile = \"d.csv\"\n",
    )
    .unwrap();
    let o = check(dir.join("moved.toml").to_str().unwrap(), "native,housner");
    let err = common::one_error_line(&o);
    assert!(
        err.contains("engine housner cannot model this scene: ")
            && err.contains("prescribes a displacement history"),
        "{err}"
    );
    let o = check(dir.join("moved.toml").to_str().unwrap(), "native");
    assert!(o.status.success(), "{o:?}");
}
