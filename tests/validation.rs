//! The validation suite: the committed reference data are what the generator gives, the suite
//! runner's matrix and exit status on a small subset, and its report rendered by headless
//! Chromium.

mod common;

use common::root;

use rockbench::validation::references::same_file;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rockbench"))
}

fn tmp(name: &str) -> common::TmpDir {
    common::tmp("rb-val", name)
}

fn run(cmd: &mut Command) -> (bool, String, String) {
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

fn files_under(dir: &Path, base: &Path, out: &mut BTreeSet<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files_under(&p, base, out);
        } else {
            out.insert(p.strip_prefix(base).unwrap().display().to_string());
        }
    }
}

/// `rockbench references` regenerates every committed reference file (and the generated
/// pulse scenes) into a temporary directory; each must match the committed one. Tolerance:
/// none on text, 1e-9 relative on numbers (libm differences between machines), and 1e-6
/// absolute on the converged native run of the two-block case (solver round-off amplified by
/// the chaotic motion after the first impacts). Only the `date:` line of PROVENANCE.md may
/// differ. No committed reference file may be left that the generator no longer writes.
#[test]
fn references_are_reproduced() {
    let out = tmp("refs");
    let (ok, so, se) = run(bin().args([
        "references",
        "--root",
        root().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(ok, "{so}\n{se}");
    let mut generated = BTreeSet::new();
    files_under(&out, &out, &mut generated);
    let mut committed = BTreeSet::new();
    files_under(&root().join("reference-data"), &root(), &mut committed);
    let generated_refs: BTreeSet<String> = generated
        .iter()
        .filter(|f| f.starts_with("reference-data/"))
        .cloned()
        .collect();
    assert_eq!(
        generated_refs, committed,
        "reference-data/ is not what the generator writes"
    );
    let mut bad = Vec::new();
    for rel in &generated {
        let new = std::fs::read_to_string(out.join(rel)).unwrap();
        let old = std::fs::read_to_string(root().join(rel))
            .unwrap_or_else(|e| panic!("{rel}: not committed: {e}"));
        if let Err(e) = same_file(rel, &old, &new, 1e-6) {
            bad.push(e);
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    // Every case directory has its provenance, naming the generator and the command.
    for d in std::fs::read_dir(root().join("reference-data")).unwrap() {
        let p = d.unwrap().path().join("PROVENANCE.md");
        let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        for key in [
            "- generator:",
            "- command:",
            "- date:",
            "- why it can be trusted:",
        ] {
            assert!(text.contains(key), "{}: no `{key}`", p.display());
        }
    }
}

/// The rectangular-pulse thresholds found by bisection with the (nonlinear) Housner engine
/// agree with the linearised closed form a / (g tan alpha) = 1 / (1 - exp(-p t1)) within
/// 0.05 % for the slender block (alpha ~ 0.1), and the below/above scenes bracket them.
#[test]
fn rectangular_thresholds_match_the_closed_form() {
    let text =
        std::fs::read_to_string(root().join("reference-data/pulse-overturning/reference.toml"))
            .unwrap();
    let t: toml::Table = toml::from_str(&text).unwrap();
    let g = 9.81;
    let alpha = (0.4f64 / 4.0).atan();
    let r = (0.2f64).hypot(2.0);
    let p = (3.0 * g / (4.0 * r)).sqrt();
    let mut n = 0;
    for (name, v) in &t {
        let Some(c) = v.as_table() else { continue };
        if c.get("shape").and_then(|s| s.as_str()) != Some("rectangular") {
            continue;
        }
        let pt1 = c["p_t1"]
            .as_float()
            .or(c["p_t1"].as_integer().map(|i| i as f64))
            .unwrap();
        let a = c["threshold_m_per_s2"].as_float().unwrap();
        let closed = 1.0 / (1.0 - (-pt1).exp());
        let ratio = a / (g * alpha.tan());
        assert!(
            ((ratio - closed) / closed).abs() < 5e-4,
            "{name}: {ratio} against the closed form {closed}"
        );
        let t1 = c["pulse_duration_s"].as_float().unwrap();
        assert!((p * t1 - pt1).abs() < 1e-9, "{name}");
        assert_eq!(c["below_overturns"].as_bool(), Some(false), "{name}");
        assert_eq!(c["above_overturns"].as_bool(), Some(true), "{name}");
        n += 1;
    }
    assert_eq!(n, 2);
}

fn write_subset(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let r = root();
    let scene = |s: &str| r.join("validation/scenes").join(s).display().to_string();
    let refs = |s: &str| r.join("reference-data").join(s).display().to_string();
    let suite = format!(
        r#"[[case]]
name = "slender"
title = "slender block"
reference = "housner"
references = "{slender_refs}"
[[case.run]]
label = "default"
scene = "{slender}"
[[case.run]]
label = "paper-stepper"
scene = "{slender}"
set = ['native.stepper="paper"']

[[case]]
name = "two-block"
title = "the paper's case"
reference = "{two_traj}"
references = "{two_refs}"
paper = true
[[case.run]]
label = "default"
scene = "{two}"

[[case]]
name = "column"
title = "standing column"
reference = "{col_traj}"
[[case.run]]
label = "default"
scene = "{col}"
"#,
        slender_refs = refs("housner-slender"),
        slender = scene("housner-slender.toml"),
        two_traj = refs("two-block-free-rocking/trajectory.csv"),
        two_refs = refs("two-block-free-rocking"),
        two = scene("two-block-free-rocking.toml"),
        col_traj = refs("standing-column/trajectory.csv"),
        col = scene("standing-column.toml"),
    );
    let good = format!(
        r#"[[gate]]
name = "slender-impact"
scene = "{slender}"
engine = "native"
reference = "housner"
metric = "impact_time_1"
tolerance = 5e-4

[[gate]]
name = "slender-rest"
scene = "{slender}"
set = ['native.stepper="paper"']
engine = "native"
reference = "housner"
metric = "rest_time_1e-4"
tolerance = 0.05
expect = "known-failure"
reason = "the paper's stepper: each impact loses a little more energy than Housner's r"

[[gate]]
name = "two-block-ground-impact"
scene = "{two}"
engine = "native"
reference = "{two_traj}"
block = "pedestal"
metric = "impact_time_1"
tolerance = 2e-3

[[gate]]
name = "column-drift"
scene = "{col}"
engine = "native"
reference = "{col_traj}"
block = "b19"
metric = "max_drift"
check = "value"
tolerance = 1e-9
"#,
        slender = scene("housner-slender.toml"),
        two = scene("two-block-free-rocking.toml"),
        two_traj = refs("two-block-free-rocking/trajectory.csv"),
        col = scene("standing-column.toml"),
        col_traj = refs("standing-column/trajectory.csv"),
    );
    // The same plus a gate no engine can meet (Housner's own first impact time to 0 s).
    let bad = format!(
        "{good}\n[[gate]]\nname = \"impossible\"\nscene = \"{}\"\nengine = \"native\"\nreference = \"housner\"\nmetric = \"impact_time_1\"\ntolerance = 0.0\n",
        scene("housner-slender.toml")
    );
    let (s, g, b) = (
        dir.join("suite.toml"),
        dir.join("gates.toml"),
        dir.join("gates-bad.toml"),
    );
    std::fs::write(&s, suite).unwrap();
    std::fs::write(&g, good).unwrap();
    std::fs::write(&b, bad).unwrap();
    (s, g, b)
}

/// `rockbench validate` on a small subset (three cases, native and Housner): the matrix says
/// pass / skipped / reference where it should, the report has the summary matrix, the paper's
/// section with its claim and the engines' rest times, one section per case with a link to
/// each comparison's report; a failing gate makes it exit non-zero and shows FAIL. The HTML
/// renders in headless Chromium with its plot.
#[test]
fn validate_subset_matrix_and_report() {
    let dir = tmp("subset");
    let (suite, gates, bad) = write_subset(&dir);
    let out = dir.join("out");
    let cache = dir.join("cache");
    let args = |g: &Path, o: &Path| -> Vec<String> {
        vec![
            "validate".into(),
            suite.display().to_string(),
            "--gates".into(),
            g.display().to_string(),
            "--engines".into(),
            "native,housner".into(),
            "--out".into(),
            o.display().to_string(),
            "--cache-dir".into(),
            cache.display().to_string(),
            "--quiet".into(),
        ]
    };
    let (ok, so, se) = run(bin().args(args(&gates, &out)));
    assert!(ok, "{so}\n{se}");
    // The matrix as printed: case, native, housner.
    let line = |case: &str| {
        so.lines()
            .find(|l| l.split_whitespace().next() == Some(case))
            .unwrap_or_else(|| panic!("no matrix row {case}:\n{so}"))
            .to_string()
    };
    let slender = line("slender");
    assert!(slender.contains("pass (1 known)"), "{slender}");
    assert!(slender.contains("reference"), "{slender}");
    let column = line("column");
    assert!(
        column.contains("pass") && column.contains("skipped"),
        "{column}"
    );
    assert!(line("two-block").contains("pass"), "{so}");
    assert!(so.contains("4 of 4 gates as expected"), "{so}");

    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for needle in [
        "Summary matrix",
        "The paper&#39;s two-block case",
        "about 3.5 s",
        "slender: slender block",
        "column: standing column",
        "Known failures",
        "slender/default/report.html",
    ] {
        let n = needle.replace("&#39;", "'");
        assert!(html.contains(&n), "report.html lacks {n}");
        assert!(md.contains(&n), "report.md lacks {n}");
    }
    // Each comparison wrote its own report where the link points.
    for c in ["slender", "two-block", "column"] {
        assert!(out.join(c).join("default/report.html").is_file(), "{c}");
    }
    // The paper's table: a row for native, for the converged run and for the paper itself;
    // the converged rest of the stack at 1e-4 rad is in the 4.4-4.95 s of independent
    // computations, and native's at its default step within 0.05 s of it.
    let rest_1e4 = |start: &str| -> f64 {
        let row = md
            .lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no row {start} in the paper's table:\n{md}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        cells[4].parse().unwrap_or_else(|_| panic!("{row}"))
    };
    let converged = rest_1e4("| `native, dt = 5e-5 s (reference-data)` |");
    assert!((4.4..=4.95).contains(&converged), "{converged}");
    let native = rest_1e4("| `native` |");
    assert!(
        (native - converged).abs() <= 0.05,
        "{native} vs {converged}"
    );
    assert!(md.contains("| the paper |"), "{md}");
    // Headings twinned.
    let md_heads = md.lines().filter(|l| l.starts_with('#')).count();
    let html_heads =
        html.matches("<h1").count() + html.matches("<h2").count() + html.matches("<h3").count();
    assert_eq!(md_heads, html_heads);

    // A failing gate: non-zero exit, FAIL in the matrix and in the report.
    let out_bad = dir.join("out-bad");
    let (ok, so, se) = run(bin().args(args(&bad, &out_bad)));
    assert!(!ok, "a failing gate must fail the run:\n{so}");
    assert!(line_has(&so, "slender", "FAIL (1)"), "{so}");
    assert!(se.contains("1 of 5 gates not as expected"), "{se}");
    let html_bad = std::fs::read_to_string(out_bad.join("report.html")).unwrap();
    assert!(html_bad.contains("FAIL (1 gate)"), "no FAIL in the report");
    // In the verdict style shared with the comparison report and the stress map.
    assert!(
        html_bad.contains("<td class=\"v v-differs\"><b>FAIL (1 gate)</b>"),
        "the FAIL cell is not a red verdict cell"
    );
    assert!(html.contains("<table class=\"verdict\" id=\"matrix\">"));

    common::assert_report_renders(&out);
}

fn line_has(so: &str, case: &str, what: &str) -> bool {
    so.lines()
        .any(|l| l.split_whitespace().next() == Some(case) && l.contains(what))
}

/// A suite file with a problem is one line naming the file and the field.
#[test]
fn a_bad_suite_is_one_clear_line() {
    let dir = tmp("badsuite");
    let p = dir.join("suite.toml");
    std::fs::write(
        &p,
        "[[case]]\nname = \"x\"\ntitle = \"t\"\nreference = \"housner\"\n[[case.run]]\nlabel = \"a\"\nscene = \"nope.toml\"\n",
    )
    .unwrap();
    let (ok, _, se) = run(bin().args(["validate", p.to_str().unwrap(), "--quiet"]));
    assert!(!ok);
    let first = se.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    assert!(
        first.contains("suite.toml") && first.contains("case[0] (x).run[0].scene"),
        "{se}"
    );
    std::fs::write(
        &p,
        "[[case]]\nname = \"x\"\ntitle = \"t\"\nreference = \"housner\"\nrun = []\nbogus = 1\n",
    )
    .unwrap();
    let (ok, _, se) = run(bin().args(["validate", p.to_str().unwrap(), "--quiet"]));
    assert!(!ok);
    assert!(se.contains("bogus"), "{se}");
    // A reference that is neither a trajectory file nor an engine of the registry.
    let scene = root().join("validation/scenes/housner-slender.toml");
    std::fs::write(
        &p,
        format!(
            "[[case]]\nname = \"x\"\ntitle = \"t\"\nreference = \"housnr\"\n[[case.run]]\nlabel = \"a\"\nscene = \"{}\"\n",
            scene.display()
        ),
    )
    .unwrap();
    let (ok, _, se) = run(bin().args(["validate", p.to_str().unwrap(), "--quiet"]));
    assert!(!ok);
    assert_eq!(se.trim().lines().count(), 1, "{se}");
    assert!(
        se.contains("suite.toml") && se.contains("case[0] (x).reference: unknown engine `housnr`"),
        "{se}"
    );
    // The paper's case with a reference.toml that cannot be read: refused before any run,
    // nothing written.
    let refs = dir.join("refs");
    std::fs::create_dir_all(&refs).unwrap();
    std::fs::write(refs.join("PROVENANCE.md"), "test\n").unwrap();
    let out = dir.join("out");
    for (reference, says) in [
        ("[paper\n", "refs/reference.toml: line 1: invalid TOML"),
        (
            "[paper]\nrest_time_s = \"soon\"\n",
            "paper.rest_time_s: must be a time >= 0",
        ),
    ] {
        std::fs::write(refs.join("reference.toml"), reference).unwrap();
        std::fs::write(
            &p,
            format!(
                "[[case]]\nname = \"x\"\ntitle = \"t\"\nreference = \"housner\"\npaper = true\nreferences = \"refs\"\n[[case.run]]\nlabel = \"a\"\nscene = \"{}\"\n",
                scene.display()
            ),
        )
        .unwrap();
        let (ok, _, se) = run(bin().args([
            "validate",
            p.to_str().unwrap(),
            "--engines",
            "native",
            "--no-cache",
            "--quiet",
            "--gates",
            root().join("validation/gates.toml").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]));
        assert!(!ok);
        assert_eq!(se.trim().lines().count(), 1, "{se}");
        assert!(
            se.contains("suite.toml: case `x`.references: ") && se.contains(says),
            "{se}"
        );
        assert!(!out.exists(), "validate wrote {}", out.display());
    }
    // An engine of --engines that is not in the registry.
    let (ok, _, se) = run(bin().args([
        "validate",
        root().join("validation/suite.toml").to_str().unwrap(),
        "--engines",
        "native,bogus",
        "--quiet",
    ]));
    assert!(!ok);
    assert_eq!(
        se.trim(),
        format!(
            "error: --engines: unknown engine `bogus` (known: {})",
            rockbench::engines::registry::names().join(", ")
        )
    );
}

/// The suite and both gate files load; every gate belongs to a case; every case has its
/// reference data with provenance; in the full gate file every engine but the case's reference
/// is gated on every case, and `make test`'s gate file is a subset of it.
#[test]
fn suite_and_gate_files_are_consistent() {
    use rockbench::compare::ReferenceSpec;
    use rockbench::gates::load_gates;
    use rockbench::validation::{assign_gates, load_suite};
    let record = root().join("validation/records/elcentro-1940.AT2");
    assert!(
        record.is_file(),
        "{} is missing: run `make records` (make test does)",
        record.display()
    );
    let cases = load_suite(&root().join("validation/suite.toml")).unwrap();
    let full = load_gates(&root().join("validation/gates-full.toml")).unwrap();
    let quick = load_gates(&root().join("validation/gates.toml")).unwrap();
    let owner = assign_gates(&cases, &full).unwrap();
    assign_gates(&cases, &quick).unwrap();
    for g in &quick {
        assert!(
            full.iter().any(|f| f.name == g.name),
            "{} not in gates-full",
            g.name
        );
    }
    for (k, c) in cases.iter().enumerate() {
        let refs = c
            .references
            .as_ref()
            .unwrap_or_else(|| panic!("{}: no references", c.name));
        assert!(refs.join("PROVENANCE.md").is_file(), "{}", c.name);
        for e in ["native", "rapier", "mujoco", "pybullet"] {
            if c.reference == ReferenceSpec::Engine(e.into()) {
                continue;
            }
            assert!(
                full.iter()
                    .zip(&owner)
                    .any(|(g, o)| *o == k && g.engine == e),
                "case {}: no gate on {e}",
                c.name
            );
        }
    }
    // Every scene in validation/scenes is a run of some case.
    for f in std::fs::read_dir(root().join("validation/scenes")).unwrap() {
        let p = f.unwrap().path();
        assert!(
            cases.iter().any(|c| c
                .runs
                .iter()
                .any(|r| r.scene_path.canonicalize().unwrap() == p.canonicalize().unwrap())),
            "{} is in no case",
            p.display()
        );
    }
}

/// Gate files: `include` takes another file's gates first (a cycle is an error naming the
/// field), and `target` replaces the reference's value by a stated number.
#[test]
fn gate_include_and_target() {
    let dir = tmp("include");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let g = |name: &str, target: f64| {
        format!(
            "[[gate]]\nname = \"{name}\"\nscene = \"{}\"\nengine = \"native\"\nreference = \"housner\"\nmetric = \"impact_time_1\"\ntolerance = 5e-4\ntarget = {target}\n",
            scene.display()
        )
    };
    // Housner's first impact is at 0.46738 s; native's within 1e-4 s of it.
    std::fs::write(dir.join("a.toml"), g("near-stated", 0.4674)).unwrap();
    std::fs::write(
        dir.join("b.toml"),
        format!("include = [\"a.toml\"]\n\n{}", g("far-stated", 0.3)),
    )
    .unwrap();
    let gates = rockbench::gates::load_gates(&dir.join("b.toml")).unwrap();
    let names: Vec<&str> = gates.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["near-stated", "far-stated"]);
    assert_eq!(gates[1].target, Some(0.3));
    let (ok, so, se) = run(bin().args([
        "gate",
        dir.join("b.toml").to_str().unwrap(),
        "--no-cache",
        "--quiet",
    ]));
    assert!(!ok, "{so}");
    assert!(so.contains("FAIL: far-stated"), "{so}");
    assert!(!so.contains("FAIL: near-stated"), "{so}");
    assert!(se.contains("1 of 2 gates failed"), "{se}");
    // A file that includes itself.
    std::fs::write(
        dir.join("c.toml"),
        format!("include = [\"c.toml\"]\n\n{}", g("x", 0.4674)),
    )
    .unwrap();
    let e = rockbench::gates::load_gates(&dir.join("c.toml")).unwrap_err();
    assert!(e.to_string().contains("include[0]"), "{e}");
}

/// The colonnade of the validation suite is `rockbench::colonnade`'s of five columns (the one
/// the benchmark's series grows): the same blocks in the same places, friction and duration,
/// under El Centro x2.
#[test]
fn the_validation_colonnade_is_the_generated_one() {
    let file = root().join("validation/scenes/colonnade-elcentro.toml");
    let scene = rockbench::scene::load_scene(&file).unwrap();
    let spec = rockbench::colonnade::ColonnadeSpec::row(5);
    let generated =
        rockbench::scene::parse_scene_str(&spec.to_toml(), false, "colonnade", &[]).unwrap();
    assert_eq!(scene.blocks.len(), generated.blocks.len());
    let (a, b) = (scene.layout(), generated.layout());
    for (i, (s, g)) in scene.blocks.iter().zip(&generated.blocks).enumerate() {
        assert_eq!(s.name, g.name);
        assert_eq!(
            (s.width, s.height, s.density),
            (g.width, g.height, g.density)
        );
        assert_eq!(
            (a.blocks[i].x, a.blocks[i].z),
            (b.blocks[i].x, b.blocks[i].z)
        );
    }
    assert_eq!(scene.contact.friction, generated.contact.friction);
    assert_eq!(scene.duration, spec.duration);
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("file = \"../records/elcentro-1940.AT2\"\nscale = 2.0\n"));
}

/// Every contact problem of the single-object validation scenes (2 s of each, default
/// settings, and the two-block case under Coulomb's law), as its back-end solved it, is its
/// QP's minimiser within 1e-12 m: certified by its duality gap (`native.certify`,
/// `rockbench::native::solver::certificate`), independently of the back-end, with no row
/// violated; and the certified run is the same run to the bit. Measured: 4006 / 4503 / 2000 /
/// 3927 / 1027 / 2000 problems, the largest bound 9.1e-16 m (the sliding block; 5.6e-19 m on
/// the two-block case under either law), for displacements of up to 1.6e-3 m a step. A run of
/// the engine reports its certificates in its notes, and its settings record the setting.
#[test]
fn every_problem_of_the_single_object_scenes_is_certified() {
    use rockbench::native::stepper_for;
    let runs: [(&str, &[&str]); 6] = [
        ("two-block-free-rocking", &[]),
        (
            "two-block-free-rocking",
            &["native.friction_law=\"coulomb\""],
        ),
        ("earthquake-elcentro", &[]),
        ("housner-slender", &[]),
        ("sliding-block", &[]),
        ("standing-column", &[]),
    ];
    for (name, set) in runs {
        let path = common::root().join(format!("validation/scenes/{name}.toml"));
        let plain: Vec<String> = set.iter().map(|s| s.to_string()).collect();
        let mut certified = plain.clone();
        certified.push("native.certify=true".into());
        let load =
            |set: &[String]| rockbench::scene::load_scene_with_overrides(&path, set).unwrap();
        let (mut a, mut sa) = stepper_for(&load(&plain)).unwrap();
        let (mut b, mut sb) = stepper_for(&load(&certified)).unwrap();
        let steps = (2.0f64.min(load(&plain).duration) / a.settings.dt).round() as usize;
        for _ in 0..steps {
            a.step(&mut sa).unwrap();
            b.step(&mut sb).unwrap();
        }
        assert_eq!(
            (&sa.q, &sa.v),
            (&sb.q, &sb.v),
            "{name} {set:?}: not the same run"
        );
        assert!(a.certified().is_none());
        let r = b.certified().unwrap();
        assert!(r.solutions >= steps as u64, "{name} {set:?}: {r:?}");
        assert_eq!(r.violated, 0, "{name} {set:?}: {r:?}");
        assert!(r.worst <= 1e-12, "{name} {set:?}: {r:?}");
    }
    let path = common::root().join("validation/scenes/two-block-free-rocking.toml");
    let scene = rockbench::scene::load_scene_with_overrides(
        &path,
        &[
            "native.certify=true".to_string(),
            "duration = 0.5".to_string(),
        ],
    )
    .unwrap();
    let engine = rockbench::engines::engine_by_name("native").unwrap();
    let (out, _) = rockbench::engines::run_timed(engine.as_ref(), &scene).unwrap();
    assert_eq!(out.settings["certify"], serde_json::json!(true));
    let note = out
        .notes
        .iter()
        .find(|n| n.starts_with("certificates: "))
        .expect("a note of the certificates");
    assert!(
        note.contains(" step problems solved, each displacement within "),
        "{note}"
    );
}

/// A gate belongs to the case run with its scene and overrides in any order (a key is never
/// given twice): the same overrides listed otherwise were "not a run of any case".
#[test]
fn a_gate_with_its_cases_overrides_in_another_order_is_that_cases() {
    use rockbench::gates::load_gates;
    use rockbench::validation::{assign_gates, load_suite};
    let dir = tmp("order");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let suite = dir.join("suite.toml");
    std::fs::write(
        &suite,
        format!(
            "[[case]]\nname = \"c\"\ntitle = \"c\"\ndescription = \"c\"\nreference = \"housner\"\n\n\
             [[case.run]]\nlabel = \"short\"\nscene = \"{}\"\nset = [\"duration=2.0\", \"native.dt=5e-4\"]\n",
            scene.display()
        ),
    )
    .unwrap();
    let gates = dir.join("gates.toml");
    let gate = |set: &str| {
        format!(
            "[[gate]]\nname = \"g\"\nscene = \"{}\"\nset = {set}\nengine = \"native\"\n\
             reference = \"housner\"\nmetric = \"impact_time_1\"\ntolerance = 5e-4\n",
            scene.display()
        )
    };
    let cases = load_suite(&suite).unwrap();
    std::fs::write(&gates, gate("[\"native.dt=5e-4\", \"duration=2.0\"]")).unwrap();
    assert_eq!(
        assign_gates(&cases, &load_gates(&gates).unwrap()),
        Ok(vec![0])
    );
    std::fs::write(&gates, gate("[\"native.dt=1e-3\", \"duration=2.0\"]")).unwrap();
    let e = assign_gates(&cases, &load_gates(&gates).unwrap()).unwrap_err();
    assert!(e.contains("is not a run of any case of the suite"), "{e}");
}
