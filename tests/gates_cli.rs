//! `rockbench gate`: failing and passing gates, known failures, JUnit XML, the run cache and
//! one-line errors for bad gate files.

mod common;

use common::root;

use std::path::Path;
use std::process::{Command, Output};

fn tmp(name: &str) -> common::TmpDir {
    common::tmp("rb-gate", name)
}

fn slender() -> String {
    root()
        .join("validation/scenes/housner-slender.toml")
        .display()
        .to_string()
}

fn gate(dir: &Path, file_text: &str) -> (Output, String, String) {
    let f = dir.join("gates.toml");
    std::fs::write(&f, file_text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .args([
            "gate",
            f.to_str().unwrap(),
            "--quiet",
            "--cache-dir",
            dir.join("cache").to_str().unwrap(),
            "--junit",
            dir.join("junit.xml").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&o.stdout).to_string();
    let se = String::from_utf8_lossy(&o.stderr).to_string();
    (o, so, se)
}

fn gate_toml(name: &str, metric: &str, tol: f64, extra: &str) -> String {
    format!(
        "[[gate]]\nname = \"{name}\"\nscene = \"{}\"\nengine = \"native\"\nreference = \"housner\"\n\
         metric = \"{metric}\"\ntolerance = {tol:e}\n{extra}\n",
        slender()
    )
}

#[test]
fn impossible_tolerance_fails_names_the_gate_and_the_rerun_is_cached() {
    let dir = tmp("impossible");
    let text = gate_toml("first-impact", "impact_time_1", 1e-3, "")
        + &gate_toml("impossible-rms", "rotation_rms_error", 0.0, "");
    let (o, so, se) = gate(&dir, &text);
    assert_eq!(o.status.code(), Some(1), "{so}\n{se}");
    assert!(se.contains("impossible-rms"), "{se}");
    assert!(!se.contains("first-impact"), "{se}");
    assert!(so.contains("0 from the cache, 2 run now"), "{so}");

    // The JUnit XML parses: two cases, one failure, on the impossible gate.
    let xml = std::fs::read_to_string(dir.join("junit.xml")).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let suites = doc.root_element();
    assert_eq!(suites.tag_name().name(), "testsuites");
    assert_eq!(suites.attribute("tests"), Some("2"));
    assert_eq!(suites.attribute("failures"), Some("1"));
    let cases: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("testcase"))
        .collect();
    assert_eq!(cases.len(), 2);
    let property = |name: &str| {
        doc.descendants()
            .find(|n| n.has_tag_name("property") && n.attribute("name") == Some(name))
            .and_then(|n| n.attribute("value"))
    };
    assert_eq!(
        property("rockbench_git_commit"),
        Some(rockbench::build_info::GIT_COMMIT)
    );
    assert_eq!(
        property("rockbench_source_hash"),
        Some(rockbench::build_info::SOURCE_HASH)
    );
    let failing: Vec<&str> = cases
        .iter()
        .filter(|c| c.children().any(|n| n.has_tag_name("failure")))
        .map(|c| c.attribute("name").unwrap())
        .collect();
    assert_eq!(failing, ["impossible-rms"]);

    // Unchanged gates: both engine runs come from the cache, with the same verdicts.
    let (o2, so2, se2) = gate(&dir, &text);
    assert_eq!(o2.status.code(), Some(1), "{so2}\n{se2}");
    assert!(so2.contains("2 from the cache, 0 run now"), "{so2}");
    let table_rows = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| l.starts_with("first-impact") || l.starts_with("impossible-rms"))
            .map(|l| l.replace("cached", "ran"))
            .collect()
    };
    assert_eq!(table_rows(&so), table_rows(&so2));

    // A changed setting is a different run.
    let changed = text.replace(
        "engine = \"native\"\nreference",
        "set = [\"native.dt=2e-3\"]\nengine = \"native\"\nreference",
    );
    let (_, so3, _) = gate(&dir, &changed);
    assert!(so3.contains("0 from the cache, 2 run now"), "{so3}");
}

#[test]
fn known_failures_pass_while_failing_and_fail_when_they_start_passing() {
    let dir = tmp("known");
    let still = gate_toml(
        "still-broken",
        "rotation_rms_error",
        0.0,
        "expect = \"known-failure\"\nreason = \"pointwise error is never exactly zero\"",
    );
    let (o, so, se) = gate(&dir, &still);
    assert_eq!(o.status.code(), Some(0), "{so}\n{se}");
    assert!(so.contains("known failure"), "{so}");
    let xml = std::fs::read_to_string(dir.join("junit.xml")).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    assert!(doc.descendants().any(|n| n.has_tag_name("skipped")));

    let fixed = gate_toml(
        "now-fixed",
        "impact_time_1",
        1.0,
        "expect = \"known-failure\"\nreason = \"was late\"",
    );
    let (o, so, se) = gate(&dir, &fixed);
    assert_eq!(o.status.code(), Some(1), "{so}\n{se}");
    assert!(
        se.contains("now-fixed") && se.contains("unexpected pass"),
        "{se}"
    );
}

#[test]
fn bad_gate_files_are_one_line_naming_the_field() {
    let dir = tmp("bad");
    // Reference trajectories that cannot be compared: refused when the gates load, even for a
    // known failure (it would count as "still failing" and switch the gate off).
    let good =
        std::fs::read_to_string(root().join("reference-data/housner-slender/trajectory.csv"))
            .unwrap();
    let mut lines: Vec<&str> = good.lines().collect();
    let with_nan = {
        let mut cols: Vec<&str> = lines[5].split(',').collect();
        cols[1] = "NaN";
        cols.join(",")
    };
    lines[5] = &with_nan;
    std::fs::write(dir.join("nan.csv"), lines.join("\n") + "\n").unwrap();
    std::fs::write(dir.join("empty.csv"), "").unwrap();
    let known = |file: &str| {
        gate_toml(
            "a",
            "impact_time_1",
            1e-3,
            "expect = \"known-failure\"\nreason = \"r\"",
        )
        .replace(
            "reference = \"housner\"",
            &format!("reference = \"{}\"", dir.join(file).display()),
        )
    };
    std::fs::write(
        dir.join("one.toml"),
        gate_toml("g1", "impact_time_1", 1e-3, ""),
    )
    .unwrap();
    let cases = [
        (
            "include = [\"one.toml\", \"one.toml\"]\n".to_string(),
            "include[1]: ",
        ),
        // An error up to an impact the gates do not compute (it was accepted, then never
        // produced).
        (
            gate_toml("a", "rotation_rms_error_to_impact_2", 1e-3, ""),
            "gate[0] (a).metric: `rotation_rms_error_to_impact_2`: gates compute the errors up to impacts 1 and 3, not 2",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "") + &gate_toml("a ", "impact_time_2", 1e-3, ""),
            "gate[1] (a ).name: another gate has this name",
        ),
        (
            gate_toml(
                "a",
                "impact_time_1",
                1e-3,
                "check = \"value\"\ntarget = 100",
            ),
            "gate[0] (a).target: check = \"value\" compares |value|",
        ),
        // A relative difference from a stated 0 divides by 0: it failed on every run.
        (
            gate_toml(
                "a",
                "impact_time_1",
                1e-3,
                "check = \"rel-diff\"\ntarget = 0",
            ),
            "gate[0] (a).target: check = \"rel-diff\" divides by |target|, which is 0: give abs-diff",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "")
                .replace("reference = \"housner\"", "reference = \"native\""),
            "gate[0] (a).reference: `native` is the gate's engine",
        ),
        (known("nan.csv"), "gate[0] (a).reference"),
        (known("empty.csv"), "gate[0] (a).reference"),
        (
            gate_toml("a", "impact_time_1", 1e-3, "").replace("tolerance", "tolerence"),
            "tolerence",
        ),
        (
            gate_toml("a", "impact_time_1", -1.0, ""),
            "gate[0] (a).tolerance",
        ),
        (
            gate_toml("a", "impact_tme_1", 1e-3, ""),
            "gate[0] (a).metric",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "expect = \"known-failure\""),
            "gate[0] (a).reason",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "expect = \"maybe\""),
            "expect",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "block = \"statue\""),
            "gate[0] (a).block",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "") + &gate_toml("a", "impact_time_2", 1e-3, ""),
            "gate[1] (a).name",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "").replace(&slender(), "nowhere.toml"),
            "gate[0] (a).scene",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "set = [\"native.dt=-1\"]"),
            "native.dt",
        ),
        ("[[gate]\n".to_string(), "line 1"),
        (
            gate_toml(
                "a",
                "impact_time_1",
                1e-3,
                "expect = \"known-failure\"\nreason = \"r\"",
            )
            .replace("engine = \"native\"", "engine = \"bogus\""),
            "gate[0] (a).engine: unknown engine `bogus`",
        ),
        (
            gate_toml("a", "impact_time_1", 1e-3, "")
                .replace("reference = \"housner\"", "reference = \"bogusref\""),
            "gate[0] (a).reference: unknown engine `bogusref`",
        ),
    ];
    for (text, field) in cases {
        let (o, so, se) = gate(&dir, &text);
        assert_eq!(o.status.code(), Some(1), "{text}\n{so}{se}");
        assert_eq!(se.trim().lines().count(), 1, "{se}");
        assert!(
            se.contains("gates.toml") && se.contains(field),
            "want {field}: {se}"
        );
    }
}

#[test]
fn validation_gates_file_is_valid() {
    // Parsing only (the gates themselves run in `make gates`).
    let gates = rockbench::gates::load_gates(&root().join("validation/gates.toml")).unwrap();
    assert!(gates.len() >= 5);
}

#[test]
fn a_metric_past_the_impacts_in_the_window_fails_with_their_counts() {
    let dir = tmp("past-the-impacts");
    // The slender block's first impact is at 0.467 s: a 0.6 s run has one.
    let text = gate_toml(
        "third-impact",
        "rotation_rms_error_to_impact_3",
        1e-3,
        "set = [\"duration=0.6\"]",
    );
    let (o, so, se) = gate(&dir, &text);
    assert_eq!(o.status.code(), Some(1), "{so}\n{se}");
    let xml = std::fs::read_to_string(dir.join("junit.xml")).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let failure = doc
        .descendants()
        .find(|n| n.has_tag_name("failure"))
        .and_then(|n| n.attribute("message"))
        .unwrap_or_default()
        .to_string();
    assert_eq!(
        failure,
        "metric rotation_rms_error_to_impact_3 not produced (in the compared window, block: 1 \
         impacts, the reference 1)"
    );
}

#[test]
fn a_cache_dir_that_cannot_be_made_is_one_error_before_any_run() {
    let dir = tmp("cache-is-a-file");
    let f = dir.join("gates.toml");
    std::fs::write(&f, gate_toml("first-impact", "impact_time_1", 1e-3, "")).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .args(["gate", f.to_str().unwrap(), "--quiet", "--cache-dir"])
        .arg(&file)
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(
        err.contains("--cache-dir: ") && err.contains("a-file"),
        "{err}"
    );
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}

/// A worker engine's runs are cached per interpreter: the same gates run with another
/// `$ROCKBENCH_PYTHON` (here a second path to the project's Python, as a second venv would be)
/// run MuJoCo again and take only the Housner reference from the cache.
#[test]
fn another_interpreter_does_not_reuse_a_worker_engines_cached_run() {
    let dir = tmp("interpreter");
    let python = root().join(".venv/bin/python");
    let other = dir.join("other-python");
    std::os::unix::fs::symlink(&python, &other).unwrap();
    let text = format!(
        "[[gate]]\nname = \"mujoco-rms\"\nscene = \"{}\"\nset = [\"duration=0.2\"]\n\
         engine = \"mujoco\"\nreference = \"housner\"\nmetric = \"rotation_rms_error\"\n\
         tolerance = 1e-3\n",
        slender()
    );
    let f = dir.join("gates.toml");
    std::fs::write(&f, text).unwrap();
    let run_with = |interpreter: &Path| {
        let o = Command::new(env!("CARGO_BIN_EXE_rockbench"))
            .env("ROCKBENCH_PYTHON", interpreter)
            .args(["gate", f.to_str().unwrap(), "--quiet", "--cache-dir"])
            .arg(dir.join("cache"))
            .output()
            .unwrap();
        let so = String::from_utf8_lossy(&o.stdout).to_string();
        let se = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.code().is_some_and(|c| c <= 1), "{so}\n{se}");
        so
    };
    let first = run_with(&python);
    assert!(first.contains("0 from the cache, 2 run now"), "{first}");
    let again = run_with(&python);
    assert!(again.contains("2 from the cache, 0 run now"), "{again}");
    let other_run = run_with(&other);
    assert!(
        other_run.contains("1 from the cache, 1 run now"),
        "{other_run}"
    );
}
