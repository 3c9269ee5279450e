//! `rockbench compare`: the files it writes, skipped engines, a trajectory file as the
//! reference, and the HTML report rendered by headless Chromium.

mod common;

use common::{bin, root, run_ok};

use std::path::Path;

fn tmp(name: &str) -> common::TmpDir {
    common::tmp("rb-cmp", name)
}

fn csv_rows(p: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(p).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        h,
        [
            "scene",
            "engine",
            "block",
            "metric",
            "value",
            "reference",
            "unit"
        ]
    );
    r.records()
        .map(|x| x.unwrap().iter().map(String::from).collect())
        .collect()
}

/// The two-block case with every engine asked for: native runs, the engines missing from
/// this build and Housner (single block only) are listed as skipped, and every file is there.
/// Then the same scene against the first run's trajectory file: identical, so zero error.
#[test]
fn two_block_compare_writes_every_file_and_lists_skipped_engines() {
    let out = tmp("two");
    let scene = root().join("validation/scenes/two-block-free-rocking.toml");
    run_ok(bin().args([
        "compare",
        scene.to_str().unwrap(),
        "--engines",
        "native,rapier,mujoco,pybullet,housner",
        "--reference",
        "native",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]));
    for f in [
        "metrics.csv",
        "metrics.json",
        "report.md",
        "report.html",
        "native/trajectory.csv",
        "native/summary.json",
        "plots/rotation-statue.svg",
        "plots/rotation-pedestal-on-statue.svg",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let runs = json["runs"].as_array().unwrap();
    let status = |e: &str| {
        let r = runs.iter().find(|r| r["engine"] == e).unwrap();
        (
            r["status"].as_str().unwrap().to_string(),
            r["reason"].as_str().unwrap_or("").to_string(),
        )
    };
    assert_eq!(status("native").0, "ok");
    for e in ["rapier", "mujoco", "pybullet"] {
        let (s, why) = status(e);
        assert!(s == "skipped" || s == "ok" || s == "failed", "{e}: {s}");
        if s == "skipped" {
            assert!(why.contains(e), "{e}: {why}");
        }
    }
    let (s, why) = status("housner");
    assert_eq!(s, "skipped");
    assert!(why.contains("2 blocks"), "{why}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for text in [&md, &html] {
        assert!(text.contains("pedestal/statue"));
        assert!(text.contains("housner"));
        assert!(text.contains("Provenance"));
        assert!(text.contains("rotation φ (rad)") || text.contains("rest"));
    }
    // Self-contained: the animation's inline script and its JSON data, nothing fetched.
    assert!(html.contains("<svg") && !html.contains("src=\"http"));
    assert_eq!(html.matches("<script").count(), 2);
    assert!(!html.contains("<script src"));
    // Provenance: versions, machine, the exact command.
    for text in [&md, &html] {
        assert!(text.contains(concat!("rockbench ", env!("CARGO_PKG_VERSION"))));
        assert!(text.contains("git commit") && text.contains("CPU") && text.contains("OS"));
        assert!(text.contains(rockbench::build_info::GIT_COMMIT));
        assert!(text.contains(rockbench::build_info::SOURCE_HASH));
        assert!(text.contains("--engines native,rapier,mujoco,pybullet,housner"));
    }
    // Every plot in the Markdown twin exists as a file.
    for line in md.lines().filter(|l| l.starts_with("![")) {
        let file = line.rsplit_once("](").unwrap().1.trim_end_matches(')');
        assert!(out.join(file).is_file(), "{file}");
    }
    // The summary names the statue's rest at the four thresholds.
    assert!(md.contains("interface `pedestal/statue`") && md.contains("at 3e-2 rad"));

    // The same scene against that trajectory as a reference file: the engine is
    // deterministic, so every rotation error is exactly zero and every impact matches.
    let out2 = tmp("two-file");
    let reference = out.join("native/trajectory.csv");
    run_ok(bin().args([
        "compare",
        scene.to_str().unwrap(),
        "--engines",
        "native",
        "--reference",
        reference.to_str().unwrap(),
        "--quiet",
        "--out",
        out2.to_str().unwrap(),
    ]));
    let rows = csv_rows(&out2.join("metrics.csv"));
    let get = |block: &str, metric: &str| {
        rows.iter()
            .find(|r| r[2] == block && r[3] == metric)
            .unwrap_or_else(|| panic!("{block} {metric}"))
            .clone()
    };
    for b in ["pedestal", "statue", "pedestal/statue"] {
        assert_eq!(get(b, "rotation_max_error")[4].parse::<f64>().unwrap(), 0.0);
    }
    assert_eq!(get("pedestal/statue", "impacts_unmatched")[4], "0");
    let first = get("pedestal/statue", "impact_time_1");
    assert_eq!(first[4], first[5]);
    // The upper block's first crossing on its pedestal (VALIDATION.md: ~0.615 s).
    let t1: f64 = first[4].parse().unwrap();
    assert!((t1 - 0.615).abs() < 0.01, "{t1}");
}

/// A reference file or a setting that cannot give a comparison is one line naming it, exit 1,
/// nothing written: a file that is not a trajectory, one sample, a value that is not finite, a
/// window outside the run, a window of one time, no job, no timing run or too many, a common
/// grid too fine or too coarse for the run.
#[test]
fn bad_reference_file_or_setting_is_one_line_naming_it() {
    let out = tmp("badref");
    let header = "t,block_x,block_z,block_phi,block_vx,block_vz,block_omega\n";
    let sample = |t: f64, phi: &str| format!("{t},0,1.25,{phi},0,0,0\n");
    let files = [
        ("bad.csv", "t,block_x\n0,1\n".to_string(), "header must be"),
        (
            "single.csv",
            format!("{header}{}", sample(0.0, "0.05")),
            "1 sample(s); a reference needs at least two",
        ),
        (
            "nan.csv",
            format!("{header}{}{}", sample(0.0, "0.05"), sample(1e-3, "nan")),
            "`block_phi` is not finite at sample 1",
        ),
    ];
    let scene = root().join("validation/scenes/housner-slender.toml");
    let compare = |extra: &[&str], o: &Path| {
        let mut args = vec![
            "compare",
            scene.to_str().unwrap(),
            "--engines",
            "native",
            "--quiet",
            "--out",
            o.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        bin().args(args).output().unwrap()
    };
    let mut cases: Vec<(Vec<String>, String)> = Vec::new();
    for (name, text, message) in files {
        let path = out.join(name);
        std::fs::write(&path, text).unwrap();
        let path = path.to_str().unwrap().to_string();
        cases.push((
            vec!["--reference".into(), path.clone()],
            format!("--reference {path}: {message}"),
        ));
    }
    for (setting, message) in [
        (["--engines", "native"], "--engines: native is given twice"),
        (
            ["--window", "5,9"],
            "--window: 5,9 s lies outside the scene's run",
        ),
        (
            ["--window", "0.5"],
            "--window: two times T0,T1 (got 1 value(s))",
        ),
        (["--jobs", "0"], "--jobs: at least 1 (got 0)"),
        (
            ["--timing-runs", "0"],
            "--timing-runs: from 1 to 1000 (got 0)",
        ),
        (
            ["--timing-runs", "4294967297"],
            "--timing-runs: from 1 to 1000 (got 4294967297)",
        ),
        // A grid of 4e300 points panicked; of 4e10 it aborted out of memory; of one point
        // (spacing 1e300 s) it compared the runs at t = 0 alone and reported them agreeing.
        (
            ["--grid-dt", "1e-300"],
            "--grid-dt: 1e-300 s makes 3.9999999999999996e300 points over the compared 4 s",
        ),
        (
            ["--grid-dt", "1e-10"],
            "--grid-dt: 0.0000000001 s makes 40000000001 points over the compared 4 s; at most 1e7",
        ),
        (
            ["--grid-dt", "1e300"],
            "--grid-dt: 1e300 s leaves fewer than 10 intervals in the compared 4 s",
        ),
        (
            ["--window", "1e300,1e301"],
            "--window: 1e300,1e301 s lies outside the scene's run",
        ),
    ] {
        cases.push((setting.map(String::from).to_vec(), message.to_string()));
    }
    // A reference that covers part of the run: its metrics would be of that part.
    let short = out.join("short.csv");
    std::fs::write(
        &short,
        format!("{header}{}{}", sample(0.0, "0.05"), sample(0.049, "0.05")),
    )
    .unwrap();
    let short = short.to_str().unwrap().to_string();
    cases.push((
        vec!["--reference".into(), short.clone()],
        format!("--reference {short}: covers 0 to 0.049 s; a reference must cover the run"),
    ));
    // A worker engine's setting that its worker refuses: bad input, as a table checked at load
    // (it was a failed run in a report of nothing compared, exit 0).
    cases.push((
        vec![
            "--engines".into(),
            "mujoco".into(),
            "--set".into(),
            "duration=0.05".into(),
            "--set".into(),
            "mujoco.solimp=[0.99,0.999,0.0001,0.5]".into(),
        ],
        "housner-slender.toml: mujoco.solimp: must be 3 or 5 finite numbers".into(),
    ));
    for (k, (extra, message)) in cases.iter().enumerate() {
        let o = out.join(format!("o{k}"));
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let r = compare(&extra, &o);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(message.as_str()), "{extra:?}: {err}");
        assert!(!o.exists(), "{extra:?} wrote {}", o.display());
    }
}

/// Slender block, native against Housner: the rows carry Housner's exact first impact as
/// the reference value, and the report renders in headless Chromium.
#[test]
fn slender_report_renders_in_headless_chromium() {
    let out = tmp("slender");
    run_ok(
        bin().args([
            "compare",
            root()
                .join("validation/scenes/housner-slender.toml")
                .to_str()
                .unwrap(),
            "--engines",
            "native,housner",
            "--reference",
            "housner",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]),
    );
    let rows = csv_rows(&out.join("metrics.csv"));
    let r = rows
        .iter()
        .find(|r| r[1] == "native" && r[2] == "block" && r[3] == "impact_time_1")
        .unwrap();
    let reference: f64 = r[5].parse().unwrap();
    assert!((reference - 0.4674).abs() < 1e-4, "{reference}");

    common::assert_report_renders(&out);
}

/// An output folder used again: what the earlier comparison wrote and this one does not
/// (another engine's run, its paper) is removed, so the folder holds one comparison; a
/// reference file inside it is refused (it would be written over or removed), and so is a run
/// whose outputs would land on its own scene file.
#[test]
fn an_output_folder_used_again_holds_one_comparison_and_no_input_is_written_over() {
    let dir = tmp("again");
    let out = dir.join("out");
    let scene = root().join("validation/scenes/housner-slender.toml");
    // Engines built in every build (the default features or none).
    let compare = |engines: &str| {
        bin()
            .args(["compare", scene.to_str().unwrap(), "--engines", engines])
            .args([
                "--reference",
                "native",
                "--set",
                "duration=0.3",
                "--quiet",
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = compare("housner");
    assert!(o.status.success(), "{o:?}");
    std::fs::create_dir_all(out.join("paper")).unwrap();
    assert!(out.join("housner/trajectory.csv").is_file());
    let o = compare("native");
    assert!(o.status.success(), "{o:?}");
    assert!(out.join("native/trajectory.csv").is_file());
    assert!(!out.join("housner").exists() && !out.join("paper").exists());
    // The reference read from inside the folder the comparison rewrites.
    let reference = out.join("native/trajectory.csv");
    let o = bin()
        .args(["compare", scene.to_str().unwrap(), "--engines", "housner"])
        .args([
            "--reference",
            reference.to_str().unwrap(),
            "--set",
            "duration=0.3",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("would write over --reference"), "{err}");
    // The scene read from an engine's folder of the comparison: removed as a stale folder.
    let inside = out.join("native/scene.json");
    assert!(inside.is_file());
    let o = bin()
        .args(["compare", inside.to_str().unwrap(), "--engines", "housner"])
        .args(["--reference", "native", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("would write over the scene"), "{err}");
    assert!(inside.is_file());
    // A run into the folder of its own scene.json.
    let own = dir.join("own");
    std::fs::create_dir_all(&own).unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    let json = bin()
        .args([
            "run",
            scene.to_str().unwrap(),
            "--engine",
            "housner",
            "--set",
            "duration=0.1",
        ])
        .arg("--out")
        .arg(&own)
        .output()
        .unwrap();
    assert!(json.status.success());
    let before = std::fs::read_to_string(own.join("scene.json")).unwrap();
    let o = bin()
        .args([
            "run",
            own.join("scene.json").to_str().unwrap(),
            "--engine",
            "housner",
        ])
        .args(["--set", "duration=0.05", "--out"])
        .arg(&own)
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("would write over the scene"), "{err}");
    assert_eq!(
        std::fs::read_to_string(own.join("scene.json")).unwrap(),
        before
    );
    assert!(!text.is_empty());
}

/// A tool the outputs asked for is missing (`--paper`'s rsvg-convert, `--video`'s ffmpeg):
/// refused in one line before any engine runs, nothing written (the whole comparison was
/// written, then the command failed).
#[test]
fn a_missing_tool_is_refused_before_any_run() {
    let dir = tmp("tools");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let empty = dir.join("no-tools");
    std::fs::create_dir_all(&empty).unwrap();
    for (flag, tool) in [("--paper", "rsvg-convert"), ("--video", "ffmpeg")] {
        let out = dir.join(flag.trim_start_matches('-'));
        let o = bin()
            .env("PATH", &empty)
            .args(["compare", scene.to_str().unwrap(), "--engines", "native"])
            .args(["--reference", "housner", flag, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(err.contains(flag) && err.contains(tool), "{err}");
        assert!(!out.exists(), "{flag}: {} written", out.display());
    }
}

/// A window starting after a block came to rest: its rest times are when it came to rest (the
/// whole run's), not the window's start (both engines "at rest from 3.3 s", agreeing to 0 %).
#[test]
fn a_window_after_the_rest_reports_the_rest_times_of_the_run() {
    let dir = tmp("window-rest");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let rest = |window: Option<&str>, out: &str| -> Vec<(String, String, String)> {
        let mut cmd = bin();
        cmd.args(["compare", scene.to_str().unwrap(), "--engines", "native"])
            .args(["--reference", "housner", "--quiet", "--out"])
            .arg(dir.join(out));
        if let Some(w) = window {
            cmd.args(["--window", w]);
        }
        run_ok(&mut cmd);
        csv_rows(&dir.join(out).join("metrics.csv"))
            .into_iter()
            .filter(|r| r[3].starts_with("rest_time_"))
            .map(|r| (r[3].clone(), r[4].clone(), r[5].clone()))
            .collect()
    };
    let (whole, late) = (rest(None, "whole"), rest(Some("3.3,4"), "late"));
    assert_eq!(whole.len(), 4);
    assert_eq!(whole, late);
    for (m, v, r) in &late {
        let (v, r): (f64, f64) = (v.parse().unwrap(), r.parse().unwrap());
        assert!(v < 3.3 && r < 3.3, "{m}: {v} {r}");
    }
}

/// No output lands on an input: `animate`'s page or video on a run's files or its scene,
/// `gate --junit` on the gate file or a gate's scene, a run's outputs on the record its scene
/// reads. Each is refused in one line and the input is left as it was (each was written over,
/// exit 0).
#[test]
fn no_output_file_lands_on_an_input() {
    let dir = tmp("inputs");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let run_dir = dir.join("run");
    run_ok(
        bin()
            .args(["run", scene.to_str().unwrap(), "--engine", "housner"])
            .args(["--set", "duration=0.1", "--quiet", "--out"])
            .arg(&run_dir),
    );
    let unchanged = |p: &Path, before: &str| {
        assert_eq!(
            std::fs::read_to_string(p).unwrap(),
            before,
            "{}",
            p.display()
        );
    };
    for f in ["summary.json", "trajectory.csv", "scene.json"] {
        let target = run_dir.join(f);
        let before = std::fs::read_to_string(&target).unwrap();
        let o = bin()
            .arg("animate")
            .arg(&run_dir)
            .args(["--out", target.to_str().unwrap()])
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(err.contains(&format!("the run's {f}, an input")), "{err}");
        unchanged(&target, &before);
    }
    let own_scene = dir.join("scene.toml");
    std::fs::copy(&scene, &own_scene).unwrap();
    let before = std::fs::read_to_string(&own_scene).unwrap();
    let o = bin()
        .arg("animate")
        .arg(&run_dir)
        .arg("--scene")
        .arg(&own_scene)
        .arg("--out")
        .arg(&own_scene)
        .output()
        .unwrap();
    assert!(common::one_error_line(&o).contains("the scene (--scene)"));
    unchanged(&own_scene, &before);

    // A gate's JUnit file on the gate file, or on its scene.
    let gates = dir.join("gates.toml");
    let text = format!(
        "[[gate]]\nname = \"g\"\nscene = \"{}\"\nset = [\"duration=0.1\"]\nengine = \"housner\"\n\
         reference = \"native\"\nmetric = \"max_abs_rotation\"\ntolerance = 1.0\n",
        own_scene.display()
    );
    std::fs::write(&gates, &text).unwrap();
    for (target, what) in [(&gates, "the gate file"), (&own_scene, "gate g's scene")] {
        let before = std::fs::read_to_string(target).unwrap();
        let o = bin()
            .arg("gate")
            .arg(&gates)
            .arg("--junit")
            .arg(target)
            .arg("--no-cache")
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(err.contains(what), "{err}");
        unchanged(target, &before);
    }

    // A run's outputs on the record its scene reads.
    let rec_dir = dir.join("rr");
    std::fs::create_dir_all(&rec_dir).unwrap();
    let record = rec_dir.join("trajectory.csv");
    std::fs::write(&record, "0,0\n0.1,0.5\n0.2,0\n").unwrap();
    let rec_scene = dir.join("record.toml");
    std::fs::write(
        &rec_scene,
        "name = \"r\"\nduration = 0.2\n[[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1.0\n\
         [excitation.horizontal]\nkind = \"record\"\nfile = \"rr/trajectory.csv\"\n",
    )
    .unwrap();
    for command in ["run", "compare"] {
        let o = bin()
            .args([command, rec_scene.to_str().unwrap(), "--quiet", "--out"])
            .arg(&rec_dir)
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(
            err.contains("would write over the record"),
            "{command}: {err}"
        );
        unchanged(&record, "0,0\n0.1,0.5\n0.2,0\n");
    }
}
