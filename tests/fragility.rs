//! `rockbench fragility`: study and suite checks (one line, nothing run), an end-to-end study
//! on synthetic records (outputs, the cache making a second run free), and the early stops
//! against full runs.

mod common;
use common::{bin, run_ok, tmp};
use std::path::Path;

/// A PEER .AT2 record: a sine burst of `cycles` cycles of period `period` s and peak `peak` g,
/// sampled at 0.01 s, then 2 s of zeros.
fn at2(peak: f64, period: f64, cycles: f64) -> String {
    let dt = 0.01;
    let n = ((cycles * period + 2.0) / dt) as usize;
    let mut s = format!(
        "synthetic\nsine burst\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {n}, DT= {dt:.4} SEC\n"
    );
    for k in 0..n {
        let t = k as f64 * dt;
        let a = if t <= cycles * period {
            peak * (2.0 * std::f64::consts::PI * t / period).sin()
        } else {
            0.0
        };
        s += &format!("{a:15.7E}");
        if k % 5 == 4 {
            s.push('\n');
        }
    }
    s.push('\n');
    s
}

/// A folder with a block scene, six records in three pairs, a manifest and a study.
fn fixture(dir: &Path, engines: &str, extra: &str) -> std::path::PathBuf {
    std::fs::write(
        dir.join("block.toml"),
        "name = \"block\"\nduration = 1.0\n\n[[blocks]]\nname = \"block\"\nwidth = 0.3\nheight = 1.5\n\n[contact]\nfriction = 2.0\n",
    )
    .unwrap();
    let mut manifest = String::from("[suite]\nname = \"synthetic\"\n\n");
    let periods = [0.4, 0.55, 0.7, 0.85, 1.0, 1.2];
    for (k, p) in periods.iter().enumerate() {
        let name = format!("r{k}.AT2");
        std::fs::write(dir.join(&name), at2(0.5, *p, 2.0)).unwrap();
        manifest += &format!(
            "[[record]]\nid = \"r{k}\"\nfile = \"{name}\"\npair = \"p{}\"\nevent = \"burst\"\n\n",
            k / 2
        );
    }
    std::fs::write(dir.join("suite.toml"), manifest).unwrap();
    let study = format!(
        "name = \"t\"\nscenes = [\"block.toml\"]\nsuite = \"suite.toml\"\nengines = [{engines}]\ncache = \"cache\"\ntail = 3.0\n{extra}\n[intensity]\nmeasure = \"pga-ratio\"\nlevels = [1.2, 1.6, 2.2, 3.0, 4.0, 5.5]\n\n[fit]\nbootstrap = 200\n"
    );
    let p = dir.join("study.toml");
    std::fs::write(&p, study).unwrap();
    p
}

fn fails_with(study: &Path, out: &Path, needles: &[&str]) {
    let o = bin()
        .args(["fragility"])
        .arg(study)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "succeeded: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "not one line: {err}");
    for n in needles {
        assert!(lines[0].contains(n), "`{n}` not in: {}", lines[0]);
    }
    assert!(!lines[0].contains("panicked"), "{err}");
    assert!(!out.exists(), "wrote {}", out.display());
    assert!(
        !study.parent().unwrap().join("cache").exists(),
        "ran something"
    );
}

#[test]
fn bad_studies_stop_before_running_with_one_line() {
    let d = tmp("rb-fragility", "bad");
    let study = fixture(&d, "\"native\"", "");
    let out = d.join("out");
    let text = std::fs::read_to_string(&study).unwrap();
    let edit = |from: &str, to: &str| std::fs::write(&study, text.replace(from, to)).unwrap();

    edit("levels = [1.2,", "levels = [0.0,");
    fails_with(&study, &out, &["study.toml", "intensity.levels[0]", "> 0"]);
    edit("levels = [1.2,", "levels = [-1,");
    fails_with(&study, &out, &["intensity.levels[0]", "> 0"]);

    std::fs::write(
        &study,
        text.clone() + "\n[[limit_state]]\nname = \"x\"\nkind = \"toppling\"\n",
    )
    .unwrap();
    fails_with(
        &study,
        &out,
        &["limit_state[0].kind", "unknown variant `toppling`"],
    );
    // A limit state named as another column of outcomes.csv: two columns of one name, and the
    // Python tables kept the limit state's values under it.
    for name in ["overturned", "level", "t_end"] {
        std::fs::write(
            &study,
            text.clone() + &format!("\n[[limit_state]]\nname = \"{name}\"\nkind = \"overturn\"\n"),
        )
        .unwrap();
        fails_with(
            &study,
            &out,
            &["limit_state[0].name", "names a column of outcomes.csv"],
        );
    }

    std::fs::write(
        &study,
        text.replace("engines = [\"native\"]", "engines = [\"nope\"]"),
    )
    .unwrap();
    fails_with(&study, &out, &["engines[0]", "unknown engine `nope`"]);

    // A manifest naming a missing file.
    std::fs::write(&study, &text).unwrap();
    let manifest = std::fs::read_to_string(d.join("suite.toml")).unwrap();
    std::fs::write(d.join("suite.toml"), manifest.replace("r3.AT2", "gone.AT2")).unwrap();
    fails_with(
        &study,
        &out,
        &["suite", "suite.toml", "record[3].file", "gone.AT2"],
    );

    // A P695 factor that alone takes its record beyond any ground motion: the suite's error,
    // not the study's levels.
    let mut factors = manifest.clone();
    for k in 0..6 {
        let factor = if k == 4 { "1e300" } else { "1.0" };
        factors = factors.replace(
            &format!("id = \"r{k}\"\n"),
            &format!("id = \"r{k}\"\np695_factor = {factor}\n"),
        );
    }
    std::fs::write(d.join("suite.toml"), factors).unwrap();
    std::fs::write(&study, text.replace("\"pga-ratio\"", "\"p695\"")).unwrap();
    fails_with(
        &study,
        &out,
        &["study.toml", "suite", "record `r4`", "p695_factor 1e300"],
    );
    std::fs::write(&study, &text).unwrap();

    // A broken record: truncated data.
    std::fs::write(d.join("suite.toml"), &manifest).unwrap();
    let rec = std::fs::read_to_string(d.join("r2.AT2")).unwrap();
    let cut: String = rec.lines().take(20).collect::<Vec<_>>().join("\n");
    std::fs::write(d.join("r2.AT2"), cut).unwrap();
    fails_with(&study, &out, &["record[2].file", "r2.AT2", "truncated"]);
    std::fs::write(d.join("r2.AT2"), &rec).unwrap();

    // Manifest metadata that disagrees with the file.
    std::fs::write(
        d.join("suite.toml"),
        manifest.replace("id = \"r1\"\n", "id = \"r1\"\nnpts = 12\n"),
    )
    .unwrap();
    fails_with(&study, &out, &["record[1].npts", "12"]);
    std::fs::write(
        d.join("suite.toml"),
        manifest.replace("id = \"r1\"\n", "id = \"r1\"\npga = 0.9\n"),
    )
    .unwrap();
    fails_with(&study, &out, &["record[1].pga", "0.9 g"]);
    std::fs::write(
        d.join("suite.toml"),
        manifest.replace("id = \"r1\"", "id = \"r0\""),
    )
    .unwrap();
    fails_with(&study, &out, &["record[1].id", "twice"]);
    std::fs::write(d.join("suite.toml"), &manifest).unwrap();

    // A relative-rotation limit state needs a block on a pedestal.
    std::fs::write(
        &study,
        text.clone()
            + "\n[[limit_state]]\nname = \"x\"\nkind = \"relative-rotation\"\nblock = \"block\"\nthreshold = 0.5\n",
    )
    .unwrap();
    fails_with(&study, &out, &["limit_state[0].block", "ground"]);

    // An engine that cannot model a scene's blocks: Housner under a stack.
    std::fs::write(
        d.join("stack.toml"),
        "name = \"stack\"\nduration = 1.0\n\n[[blocks]]\nname = \"base\"\nwidth = 1.0\nheight = 0.5\n\n[[blocks]]\nname = \"block\"\nwidth = 0.3\nheight = 1.5\n",
    )
    .unwrap();
    std::fs::write(
        &study,
        text.replace("[\"block.toml\"]", "[\"block.toml\", \"stack.toml\"]")
            .replace(
                "engines = [\"native\"]",
                "engines = [\"native\", \"housner\"]",
            ),
    )
    .unwrap();
    fails_with(
        &study,
        &out,
        &[
            "engines[1]",
            "`housner` cannot run scenes[1] (`stack`)",
            "single block",
        ],
    );

    // A stripe or a scene listed twice (counted twice in the fit), resamples beyond memory.
    edit("levels = [1.2, 1.6,", "levels = [1.2, 1.2,");
    fails_with(
        &study,
        &out,
        &["intensity.levels[1]", "1.2 is listed twice"],
    );
    edit("levels = [1.2, 1.6,", "levels = [1.2, 1.2000000000000002,");
    fails_with(&study, &out, &["intensity.levels[1]", "is listed twice"]);
    edit("[\"block.toml\"]", "[\"block.toml\", \"block.toml\"]");
    fails_with(&study, &out, &["scenes[1]", "`block.toml` is listed twice"]);
    edit("[\"block.toml\"]", "[\"block.toml\", \"./block.toml\"]");
    fails_with(
        &study,
        &out,
        &["scenes[1]", "`./block.toml` is listed twice"],
    );
    edit("name = \"t\"", "name = \" \"");
    fails_with(&study, &out, &["study.toml: name: must not be empty"]);
    // Two scenes of one name would be pooled into one fit.
    std::fs::write(
        d.join("narrow.toml"),
        std::fs::read_to_string(d.join("block.toml"))
            .unwrap()
            .replace("width = 0.3", "width = 0.25"),
    )
    .unwrap();
    edit("[\"block.toml\"]", "[\"block.toml\", \"narrow.toml\"]");
    fails_with(
        &study,
        &out,
        &[
            "scenes[1]",
            "scene name `block` is also scenes[0]'s (`block.toml`)",
        ],
    );
    // One motion under two ids would count twice in a fit.
    let manifest = std::fs::read_to_string(d.join("suite.toml")).unwrap();
    std::fs::write(
        d.join("suite.toml"),
        format!("{manifest}[[record]]\nid = \"again\"\nfile = \"r0.AT2\"\n"),
    )
    .unwrap();
    edit("name = \"t\"", "name = \"t\"");
    fails_with(
        &study,
        &out,
        &["record[6].file", "has the same bytes as record[0] (`r0`)"],
    );
    // The same samples in other bytes (a line end added) are the same motion.
    let copy = std::fs::read_to_string(d.join("r0.AT2")).unwrap() + "\n";
    std::fs::write(d.join("r0-copy.AT2"), copy).unwrap();
    std::fs::write(
        d.join("suite.toml"),
        format!("{manifest}[[record]]\nid = \"again\"\nfile = \"r0-copy.AT2\"\n"),
    )
    .unwrap();
    fails_with(
        &study,
        &out,
        &["record[6].file", "has the same samples as record[0] (`r0`)"],
    );
    std::fs::write(d.join("suite.toml"), manifest).unwrap();
    // A run cache that is a file, found at --check rather than at the first run.
    edit("cache = \"cache\"", "cache = \"suite.toml\"");
    fails_with(
        &study,
        &out,
        &["cache", "suite.toml is a file, not a folder"],
    );
    edit("bootstrap = 200", "bootstrap = 10000000000000");
    fails_with(
        &study,
        &out,
        &["fit.bootstrap", "at most 1000000 resamples"],
    );

    // Runs that no engine can make, refused at load (each would fail every run reaching it):
    // a tail too long for the steps, a level that scales a record beyond floating point, a
    // record whose samples are 1e12 s apart.
    edit("tail = 3.0", "tail = 1e300");
    fails_with(
        &study,
        &out,
        &[
            "study.toml: tail: scene `block` under the longest record",
            "native.dt",
        ],
    );
    edit("5.5]", "1e308]");
    fails_with(
        &study,
        &out,
        &[
            "intensity.levels[5]",
            "level 1e308 scales record",
            "g; at most 1000 g",
        ],
    );
    // A level far beyond any ground motion (the solver fails on it at the first step).
    edit("5.5]", "1e15]");
    fails_with(
        &study,
        &out,
        &[
            "intensity.levels[5]",
            "level 1e15 scales record",
            "at most 1000 g",
        ],
    );
    std::fs::write(&study, text.clone() + "\n[ida]\nmax = 1e15\n").unwrap();
    fails_with(&study, &out, &["ida.max", "level 1e15 scales record"]);
    // An IDA that would never end its bisection, or fill without end.
    std::fs::write(&study, text.clone() + "\n[ida]\ntolerance = 1e-300\n").unwrap();
    fails_with(&study, &out, &["ida.tolerance", "must be at least 1e-12"]);
    std::fs::write(&study, text.clone() + "\n[ida]\nfill = 1000000000\n").unwrap();
    fails_with(&study, &out, &["ida.fill", "at most 100 levels"]);
    // A hunt of some thousand doublings from a start of 1e-300, or of steps of 1e-9.
    std::fs::write(&study, text.clone() + "\n[ida]\nstart = 1e-300\n").unwrap();
    fails_with(
        &study,
        &out,
        &["ida.start", "the hunt from 1e-300", "at most 200"],
    );
    std::fs::write(&study, text.clone() + "\n[ida]\nfactor = 1.000000001\n").unwrap();
    fails_with(&study, &out, &["ida.factor", "steps; at most 200"]);
    let r0 = d.join("r0.AT2");
    let record = std::fs::read_to_string(&r0).unwrap();
    std::fs::write(&r0, record.replace("DT= 0.0100", "DT= 1e12")).unwrap();
    std::fs::write(&study, &text).unwrap();
    fails_with(
        &study,
        &out,
        &[
            "study.toml: suite: scene `block` under the longest record, `r0`",
            "native.dt",
        ],
    );
    // A record of 1e308 g: its PGA in m/s^2 is not finite (it was blamed on the level).
    let mut huge = record.clone();
    let first_value = huge.lines().nth(4).unwrap()[..15].to_string();
    huge = huge.replacen(&first_value, "  1.0000000E+308", 1);
    std::fs::write(&r0, huge).unwrap();
    fails_with(
        &study,
        &out,
        &["study.toml: suite: record `r0`", "is not finite"],
    );
    std::fs::write(&r0, record).unwrap();

    // A hunt that would start above its highest level.
    std::fs::write(&study, text.clone() + "\n[ida]\nstart = 10\nmax = 1\n").unwrap();
    fails_with(
        &study,
        &out,
        &["ida.start", "starts at 10", "below the highest level"],
    );
    std::fs::write(&study, text.clone() + "\n[ida]\nstart = 6\n").unwrap();
    fails_with(&study, &out, &["ida.start", "no higher than 5.5"]);

    // An --out whose files the outputs would replace: the working directory, or a folder of
    // other files. Refused before anything runs, the files kept.
    std::fs::write(&study, &text).unwrap();
    let mine = d.join("mine");
    std::fs::create_dir_all(mine.join("sub")).unwrap();
    std::fs::write(mine.join("canary.txt"), "precious").unwrap();
    for (cwd, out, message) in [
        (mine.clone(), ".", "is the working directory or holds it"),
        (d.to_path_buf(), "mine", "holds files and no fragility.json"),
    ] {
        let o = bin()
            .args(["fragility"])
            .arg(&study)
            .args(["--out", out])
            .current_dir(cwd)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(message), "{err}");
        assert_eq!(
            std::fs::read_to_string(mine.join("canary.txt")).unwrap(),
            "precious"
        );
        assert!(mine.join("sub").is_dir());
        assert!(!d.join("cache").exists(), "ran something");
    }

    // And the fixture itself is good.
    std::fs::write(&study, &text).unwrap();
    let o = run_ok(bin().args(["fragility", "--check"]).arg(&study));
    assert!(o.contains("6 records") && o.contains("ok"), "{o}");
}

#[test]
fn a_study_writes_its_outputs_and_a_second_run_costs_nothing() {
    let d = tmp("rb-fragility", "run");
    let study = fixture(
        &d,
        "\"auto\", \"native\"",
        "[ida]\nfactor = 1.5\ntolerance = 0.05\nfill = 2\n",
    );
    let out = d.join("out");
    run_ok(
        bin()
            .args(["fragility", "--quiet"])
            .arg(&study)
            .arg("--out")
            .arg(&out),
    );
    for f in [
        "outcomes.csv",
        "capacities.csv",
        "fits.csv",
        "differences.csv",
        "fragility.json",
        "report.html",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    let rows = j["rows"].as_array().unwrap();
    let stripes = rows.iter().filter(|r| r["method"] == "stripes").count();
    assert_eq!(stripes, 2 * 6 * 6, "engines x records x levels");
    // Only IDA levels that are also stripe levels come from the cache on the first run.
    let cached = j["counts"]["cached"].as_u64().unwrap() as usize;
    let ida_at_stripes = rows
        .iter()
        .filter(|r| {
            r["method"] == "ida"
                && [1.2, 1.6, 2.2, 3.0, 4.0, 5.5].contains(&r["level"].as_f64().unwrap())
        })
        .count();
    assert_eq!(cached, ida_at_stripes);
    // The auto engine ran Housner for the single block.
    assert!(
        rows.iter()
            .filter(|r| r["engine"] == "auto")
            .all(|r| r["outcome"]["ran"] == "housner")
    );
    // Overturning fit exists for both engines, and a paired difference with an interval.
    let fits = j["fits"].as_array().unwrap();
    let over: Vec<&serde_json::Value> = fits
        .iter()
        .filter(|f| f["limit_state"] == "overturn" && f["method"] == "stripes")
        .collect();
    assert_eq!(over.len(), 2);
    for f in &over {
        assert!(f["fit"]["theta"].as_f64().unwrap() > 1.0, "{f}");
        let ci = f["theta_ci"].as_array().unwrap();
        assert!(ci[0].as_f64().unwrap() <= f["fit"]["theta"].as_f64().unwrap());
    }
    let diffs = j["differences"].as_array().unwrap();
    assert!(
        diffs
            .iter()
            .any(|x| x["engine"] == "native" && x["reference"] == "auto")
    );
    // IDA capacities: one per engine x record x limit state.
    assert_eq!(j["capacities"].as_array().unwrap().len(), 2 * 6 * 3);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("native") && html.contains("auto"));
    // Runs per engine: every row of the matrix counted once, by how it ended.
    assert!(html.contains("<h2>Runs per engine</h2>"), "{html}");
    let rows = j["rows"].as_array().unwrap();
    for e in ["auto", "native"] {
        let mine: Vec<_> = rows.iter().filter(|r| r["engine"] == e).collect();
        let stopped = |s: &str| mine.iter().filter(|r| r["outcome"]["stop"] == s).count();
        let row = format!(
            "<tr><td>{e}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            mine.len(),
            mine.iter().filter(|r| r["cached"] == true).count(),
            stopped("overturned"),
            stopped("at-rest"),
            stopped("below-tipping-energy"),
            stopped("end")
        );
        assert!(html.contains(&row), "{row} not in the report");
    }

    // Second run: every run from the cache, the same fits; with the paper outputs.
    run_ok(
        bin()
            .args(["fragility", "--quiet", "--paper"])
            .arg(&study)
            .arg("--out")
            .arg(&out),
    );
    let paper = out.join("paper");
    let tex = std::fs::read_to_string(paper.join("fits.tex")).unwrap();
    assert!(
        tex.contains("\\toprule") && tex.contains("overturn"),
        "{tex}"
    );
    assert!(paper.join("differences.tex").is_file());
    assert!(paper.join("fragility-block-stripes-overturn.pdf").is_file());
    assert!(paper.join("README.md").is_file());
    let j2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    assert_eq!(j2["counts"]["cached"], j2["counts"]["runs"]);
    assert_eq!(j2["fits"], j["fits"]);
}

/// The early stops change no outcome: the same study with `early_stop = false` gives the same
/// exceedances (rotations to 1e-6 of alpha, residual sliding to 1e-9 m) on the native engine
/// and Housner's, whose block cannot slide: its residual sliding is nil (a run stopped while
/// the block was tilted counted its centroid's offset as sliding).
#[test]
fn early_stops_change_no_outcome() {
    let d = tmp("rb-fragility", "early");
    let study = fixture(
        &d,
        "\"native\", \"housner\"",
        "[[limit_state]]\nname = \"slide-1mm\"\nkind = \"sliding\"\nthreshold = 0.001\n\n\
         [[limit_state]]\nname = \"rotation-0.3\"\nkind = \"rotation\"\nthreshold = 0.3\n",
    );
    let text = std::fs::read_to_string(&study).unwrap();
    let out1 = d.join("out1");
    let out2 = d.join("out2");
    run_ok(
        bin()
            .args(["fragility", "--quiet"])
            .arg(&study)
            .arg("--out")
            .arg(&out1),
    );
    std::fs::write(
        &study,
        text.replace("tail = 3.0", "tail = 3.0\nearly_stop = false"),
    )
    .unwrap();
    run_ok(
        bin()
            .args(["fragility", "--quiet"])
            .arg(&study)
            .arg("--out")
            .arg(&out2),
    );
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p.join("fragility.json")).unwrap()).unwrap()
    };
    let (a, b) = (read(&out1), read(&out2));
    // The settings each engine ran with, defaults filled in.
    let native = &a["engine_settings"]["block"]["native"];
    assert_eq!(native["dt"], 1e-3, "{}", a["engine_settings"]);
    assert_eq!(native["stepper"], "impact");
    assert!(a["engine_settings"]["block"]["housner"].is_object());
    let (ra, rb) = (a["rows"].as_array().unwrap(), b["rows"].as_array().unwrap());
    assert_eq!(ra.len(), rb.len());
    let mut early = 0;
    for (x, y) in ra.iter().zip(rb) {
        assert_eq!(x["record"], y["record"]);
        assert_eq!(x["level"], y["level"]);
        assert_eq!(x["exceeded"], y["exceeded"], "{x} vs {y}");
        if x["outcome"]["stop"] != "end" {
            early += 1;
        }
        if x["outcome"]["overturned"] == serde_json::json!([false]) {
            let (p, q) = (
                x["outcome"]["rotation"][0].as_f64().unwrap(),
                y["outcome"]["rotation"][0].as_f64().unwrap(),
            );
            assert!((p - q).abs() <= 1e-6 + 0.02 * q, "{p} vs {q}");
            let (s, u) = (
                x["outcome"]["sliding"][0].as_f64().unwrap(),
                y["outcome"]["sliding"][0].as_f64().unwrap(),
            );
            assert!((s - u).abs() <= 1e-9, "sliding {s} vs {u}: {x}");
            if x["engine"] == "housner" {
                assert!(s <= 1e-12 && u <= 1e-12, "Housner's block slid {s}, {u}");
            }
        }
    }
    assert!(
        early > ra.len() / 2,
        "only {early} of {} stopped early",
        ra.len()
    );
}

/// The FEMA P695 sets written by `make records`: 44 far-field components in 22 pairs, 28 + 28
/// near-field ones, each read and checked by the suite loader (`--check` of a study on each),
/// the normalisation factor shared by both components of a record.
#[test]
fn the_p695_suites_load_and_check() {
    let root = common::root();
    let dir = root.join("validation/records/p695");
    assert!(
        dir.join("farfield.toml").is_file(),
        "run `make records` first (writes validation/records/p695/)"
    );
    for (set, n) in [
        ("farfield", 44),
        ("nearfield-pulse", 28),
        ("nearfield-no-pulse", 28),
    ] {
        let d = tmp("rb-fragility", set);
        let study = d.join("study.toml");
        std::fs::write(
            &study,
            format!(
                "name = \"p\"\nscenes = [\"{}\"]\nsuite = \"{}\"\nengines = [\"native\"]\n\n[intensity]\nmeasure = \"p695\"\nlevels = [1.0]\n",
                root.join("validation/scenes/two-block-free-rocking.toml").display(),
                dir.join(format!("{set}.toml")).display()
            ),
        )
        .unwrap();
        let o = run_ok(bin().args(["fragility", "--check"]).arg(&study));
        assert!(o.contains(&format!("({n} records)")), "{o}");
        let text = std::fs::read_to_string(dir.join(format!("{set}.toml"))).unwrap();
        let m: toml::Value = toml::from_str(&text).unwrap();
        let recs = m["record"].as_array().unwrap();
        assert_eq!(recs.len(), n);
        let mut factor = std::collections::BTreeMap::new();
        for r in recs {
            let f = r["p695_factor"].as_float().unwrap();
            let old = factor.insert(r["pair"].as_str().unwrap().to_string(), f);
            assert!(old.is_none_or(|o| o == f), "{r}");
            assert!(r["pga"].as_float().unwrap() > 0.0 && r["npts"].as_integer().unwrap() > 100);
        }
        assert_eq!(factor.len(), n / 2);
    }
}

/// The CPU seconds process `pid` has used (utime + stime in /proc, in clock ticks).
fn cpu_seconds(pid: u32) -> f64 {
    let fields = common::proc_stat(pid);
    // After the command's name: state is field 3, utime 14 and stime 15.
    let tick = |k: usize| fields.get(k - 3).and_then(|v| v.parse::<f64>().ok());
    // SAFETY: sysconf reads a constant of the system.
    let per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    tick(14)
        .zip(tick(15))
        .map_or(0.0, |(u, s)| (u + s) / per_second)
}

/// Ctrl-C while a run with early stops (a study's default) is under way: the run stops, is
/// not stored, and the study ends at once. The native runs take ten million steps a simulated
/// second (dt 1e-7 s), and the signal comes once the study has used half a second of CPU, when
/// its first run is under way: a run left to finish would be stored.
#[test]
fn a_run_under_way_with_early_stops_stops_on_ctrl_c_and_is_not_stored() {
    let d = tmp("rb-fragility", "interrupt-early");
    let study = fixture(&d, "\"native\"", "");
    let scene = d.join("block.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text + "\n[native]\ndt = 1e-7\n").unwrap();
    let child = bin()
        .args(["fragility", "--quiet", "--jobs", "1"])
        .arg(&study)
        .arg("--out")
        .arg(d.join("out"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while cpu_seconds(child.id()) < 0.5 {
        assert!(t0.elapsed().as_secs() < 120, "no work after 120 s");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    // SAFETY: signals a child of this process, which has not been waited for.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) },
        0
    );
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        err.contains(": interrupted; the runs finished are kept in "),
        "{err}"
    );
    let stored: Vec<_> = std::fs::read_dir(d.join("cache"))
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|sub| {
            std::fs::read_dir(sub.path())
                .into_iter()
                .flatten()
                .flatten()
        })
        .map(|e| e.path())
        .collect();
    assert!(stored.is_empty(), "a stopped run was stored: {stored:?}");
    assert!(!d.join("out").exists(), "an output folder was written");
}

/// Ctrl-C in the middle of a study: it exits with status 130 and one line saying where the runs
/// finished are kept, every cache entry left is whole (parses, no temporary file), no output
/// folder is written, and the rerun resumes from the entries.
#[test]
fn an_interrupted_study_leaves_whole_entries_and_resumes() {
    let d = tmp("rb-fragility", "interrupt");
    let study = fixture(&d, "\"native\"", "");
    let text = std::fs::read_to_string(&study).unwrap();
    // Full-length runs of a minute, so that the study is still running when interrupted even
    // on a loaded machine (24 runs of about 0.25 s each, one at a time).
    std::fs::write(
        &study,
        text.replace("tail = 3.0", "tail = 60.0\nearly_stop = false"),
    )
    .unwrap();
    let out = d.join("out");
    let mut cmd = bin();
    cmd.args(["fragility", "--quiet", "--jobs", "1"])
        .arg(&study)
        .arg("--out")
        .arg(&out);
    // Ctrl-C from a terminal: SIGINT at its default disposition. A process started in the
    // background by a non-interactive shell inherits SIGINT ignored (POSIX), and so would the
    // study, which would then finish in spite of the interrupt.
    unsafe {
        use std::os::unix::process::CommandExt;
        cmd.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut child = cmd.stderr(std::process::Stdio::piped()).spawn().unwrap();
    let cache = d.join("cache");
    let entries = |dir: &Path| -> Vec<std::path::PathBuf> {
        let mut v = Vec::new();
        for sub in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            for f in std::fs::read_dir(sub.path())
                .into_iter()
                .flatten()
                .flatten()
            {
                v.push(f.path());
            }
        }
        v
    };
    let t0 = std::time::Instant::now();
    while entries(&cache)
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .count()
        < 1
    {
        assert!(t0.elapsed().as_secs() < 120, "no cache entries after 120 s");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with(&format!(
            "error: {}: interrupted; the runs finished are kept in ",
            study.display()
        )) && err
            .trim_end()
            .ends_with("the same command resumes the study from them"),
        "{err}"
    );
    assert!(!out.exists(), "an output folder was written");
    let json = entries(&cache);
    assert!(
        json.iter()
            .all(|p| p.extension().is_some_and(|e| e == "json")),
        "{json:?}"
    );
    for p in &json {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p).unwrap()).expect("a whole entry");
        assert!(v["sha256"].is_string() && v["entry"]["rotation"].is_array());
    }
    run_ok(
        bin()
            .args(["fragility", "--quiet"])
            .arg(&study)
            .arg("--out")
            .arg(&out),
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    assert!(j["counts"]["cached"].as_u64().unwrap() >= json.len() as u64);
}

/// A run spec whose record file changed after the study read it (its key holds the bytes'
/// hash): the run is an error naming the record, not another record's outcome stored under
/// this key; the same spec runs again once the file holds its bytes.
#[test]
fn a_spec_whose_record_changed_since_the_study_read_it_is_an_error() {
    use rockbench::fragility::{self, Runner, run, study};
    let d = tmp("rb-fragility", "record-changed");
    let p = fixture(&d, "\"native\"", "");
    let st = study::load_study(&p).unwrap();
    let spec = fragility::stripe_specs(&st)
        .into_iter()
        .find(|s| s.record_id == "r1")
        .unwrap();
    let record = d.join("r1.AT2");
    let original = std::fs::read(&record).unwrap();
    std::fs::write(&record, at2(0.5, 0.3, 2.0)).unwrap();
    let cache = d.join("changed-cache");
    let err = Runner::new(cache.clone(), true).get(&spec).unwrap_err();
    assert!(
        err.contains("record r1") && err.contains("has changed since the study read it"),
        "{err}"
    );
    assert!(run::run_one(&spec).is_err());
    assert!(!cache.exists() || std::fs::read_dir(&cache).unwrap().count() == 0);
    std::fs::write(&record, original).unwrap();
    assert!(Runner::new(cache, true).get(&spec).is_ok());
}

/// IDA capacities do not depend on the order of the limit states: each is the lowest level
/// run for its record that exceeds it, over every limit state's runs (an earlier limit
/// state's capacity was fixed before the later hunts ran levels below it: an overturn capacity
/// of 1.31 where a run at 1.10 overturned, and a fitted median 2.9 % apart).
#[test]
fn ida_capacities_do_not_depend_on_the_order_of_the_limit_states() {
    use rockbench::fragility::{self, study};
    let d = tmp("rb-fragility", "ida-order");
    let states = [
        "[[limit_state]]\nname = \"r01\"\nkind = \"rotation\"\nthreshold = 0.1\n",
        "[[limit_state]]\nname = \"r05\"\nkind = \"rotation\"\nthreshold = 0.5\n",
        "[[limit_state]]\nname = \"over\"\nkind = \"overturn\"\n",
    ];
    let ida = "\n[ida]\nstart = 1.2\nfactor = 1.8\nmax = 5.0\ntolerance = 0.05\nfill = 1\n";
    let forward = format!("{ida}{}", states.concat());
    let backward = format!("{ida}{}{}{}", states[2], states[1], states[0]);
    let capacities = |extra: &str| {
        let p = fixture(&d, "\"native\"", extra);
        let scene = std::fs::read_to_string(d.join("block.toml")).unwrap();
        std::fs::write(d.join("block.toml"), scene + "\n[native]\ndt = 2e-3\n").unwrap();
        let st = study::load_study(&p).unwrap();
        let res = fragility::run_study(&st, true).unwrap();
        let mut caps: Vec<(String, String, f64, bool, bool)> = res
            .capacities
            .iter()
            .map(|c| {
                let k = st
                    .limit_states
                    .iter()
                    .position(|l| l.name == c.limit_state)
                    .unwrap();
                // The lowest IDA level of the record that exceeds it, from the rows.
                let lowest = res
                    .rows
                    .iter()
                    .filter(|r| r.record == c.record && r.method == fragility::Method::Ida)
                    .filter(|r| r.exceeded[k])
                    .map(|r| r.level)
                    .fold(f64::INFINITY, f64::min);
                if !c.censored {
                    assert_eq!(c.capacity, lowest, "{} {}", c.record, c.limit_state);
                }
                (
                    c.record.clone(),
                    c.limit_state.clone(),
                    c.capacity,
                    c.censored,
                    c.resurrection,
                )
            })
            .collect();
        caps.sort_by(|a, b| (&a.0, &a.1).cmp(&(&b.0, &b.1)));
        caps
    };
    let a = capacities(&forward);
    let b = capacities(&backward);
    assert_eq!(a.len(), 18);
    assert_eq!(a, b);
}

/// The units of work a distributed study hands out: a run spec read back from its JSON (the
/// scene's engine tables included) has the same key and the same outcome; the IDA jobs run one
/// by one through a cache give the rows and capacities of the study, and the study assembled
/// from that cache makes no new run.
#[test]
fn specs_and_ida_jobs_run_apart_give_the_study() {
    use rockbench::fragility::{self, Runner, run, study};
    let d = tmp("rb-fragility", "units");
    let p = fixture(
        &d,
        "\"native\"",
        "\n[ida]\nstart = 1.2\nfactor = 1.5\nmax = 4.0\nfill = 1\n",
    );
    let scene = std::fs::read_to_string(d.join("block.toml")).unwrap();
    std::fs::write(
        d.join("block.toml"),
        scene + "\n[native]\ntheta = 0.7\ndt = 2e-3\n",
    )
    .unwrap();
    let st = study::load_study(&p).unwrap();
    let specs = fragility::stripe_specs(&st);
    let text = serde_json::to_string(&specs[3]).unwrap();
    let back: run::RunSpec = serde_json::from_str(&text).unwrap();
    assert_eq!(back.key(), specs[3].key());
    assert_eq!(back.scene.engines, specs[3].scene.engines);
    assert!(back.scene.engines.contains_key("native"));
    let (a, b) = (
        run::run_one(&back).unwrap(),
        run::run_one(&specs[3]).unwrap(),
    );
    assert_eq!(
        (&a.rotation, &a.overturned, a.stop),
        (&b.rotation, &b.overturned, b.stop)
    );

    let cache = d.join("units-cache");
    let runner = Runner::new(cache.clone(), true);
    for s in &specs {
        runner.get(s).unwrap();
    }
    let jobs = fragility::ida_jobs(&st);
    assert_eq!(jobs.len(), 6);
    let mut caps = Vec::new();
    for chunk in jobs.chunks(4) {
        for (_, c) in fragility::run_ida_jobs(&st, &runner, chunk).unwrap() {
            caps.extend(c);
        }
    }
    let made = runner.made();
    assert!(made > specs.len(), "IDA made no run of its own");
    let mut whole = st.clone();
    whole.cache_dir = cache;
    let res = fragility::run_study(&whole, true).unwrap();
    assert_eq!(res.counts.made, 0);
    assert_eq!(res.counts.cached, res.counts.runs);
    let entries: usize = std::fs::read_dir(&whole.cache_dir)
        .unwrap()
        .map(|e| std::fs::read_dir(e.unwrap().path()).unwrap().count())
        .sum();
    assert_eq!(entries, made);
    let key = |c: &fragility::Capacity| {
        (
            c.record.clone(),
            c.limit_state.clone(),
            c.capacity.to_bits(),
            c.censored,
        )
    };
    assert_eq!(
        caps.iter().map(key).collect::<Vec<_>>(),
        res.capacities.iter().map(key).collect::<Vec<_>>()
    );
    assert!(fragility::run_ida_jobs(&st, &runner, &[(0, "rapier".into(), "r0".into())]).is_err());
}

/// A worker engine's run spec names the interpreter it was made for, and its key follows it:
/// another interpreter's outcome is never taken for this one's. The engines of this program
/// name none.
#[test]
fn a_worker_engines_spec_keys_its_interpreter() {
    use rockbench::fragility::{self, study};
    let d = tmp("rb-fragility", "interpreter");
    let p = fixture(&d, "\"native\", \"mujoco\"", "");
    let st = study::load_study(&p).unwrap();
    let specs = fragility::stripe_specs(&st);
    let native = specs.iter().find(|s| s.engine == "native").unwrap();
    assert_eq!(native.python, None);
    let mujoco = specs.iter().find(|s| s.engine == "mujoco").unwrap();
    let python = mujoco.python.as_deref().unwrap();
    assert!(Path::new(python).is_absolute(), "{python}");
    assert!(python.ends_with("bin/python"), "{python}");
    let mut elsewhere = mujoco.clone();
    elsewhere.python = Some("/another/venv/bin/python".into());
    assert_ne!(elsewhere.key(), mujoco.key());
}

/// An IDA started above some records' capacities steps down to them (a record exceeding at
/// the start had the start for its capacity, counted as exact): every capacity lies below the
/// start, with a level that does not exceed within the bisection's tolerance below it.
#[test]
fn an_ida_started_above_a_capacity_steps_down_to_it() {
    let d = tmp("rb-fragility", "ida-down");
    let study = fixture(
        &d,
        "\"housner\"",
        "[[limit_state]]\nname = \"rotation-0.3\"\nkind = \"rotation\"\nthreshold = 0.3\n",
    );
    let text = std::fs::read_to_string(&study).unwrap();
    let (start, tolerance) = (6.0, 0.002);
    std::fs::write(
        &study,
        format!("{text}\n[ida]\nstart = {start}\ntolerance = {tolerance}\nmax = 40.0\n"),
    )
    .unwrap();
    let out = d.join("out");
    run_ok(
        bin()
            .args(["fragility", "--quiet"])
            .arg(&study)
            .arg("--out")
            .arg(&out),
    );
    let table = |f: &str| {
        let mut r = csv::Reader::from_path(out.join(f)).unwrap();
        let h = r.headers().unwrap().clone();
        let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
        (h, rows)
    };
    let (hc, caps) = table("capacities.csv");
    let (ho, runs) = table("outcomes.csv");
    let col = |h: &csv::StringRecord, n: &str| h.iter().position(|x| x == n).unwrap();
    let mut below = 0;
    for c in caps
        .iter()
        .filter(|c| &c[col(&hc, "limit_state")] == "rotation-0.3")
    {
        let record = &c[col(&hc, "record")];
        let cap: f64 = c[col(&hc, "capacity")].parse().unwrap();
        assert_eq!(&c[col(&hc, "censored")], "false", "{c:?}");
        assert!(cap < start, "record {record}: capacity {cap}, the start");
        let safe_below = runs.iter().any(|o| {
            let level: f64 = o[col(&ho, "level")].parse().unwrap();
            &o[col(&ho, "record")] == record
                && &o[col(&ho, "method")] == "ida"
                && &o[col(&ho, "rotation-0.3")] == "0"
                && level < cap
                && level * (1.0 + tolerance) >= cap * (1.0 - 1e-12)
        });
        assert!(
            safe_below,
            "record {record}: no safe level within {tolerance} below {cap}"
        );
        below += 1;
    }
    assert_eq!(below, 6);
}

/// A study without stripes (IDA only) hands out no stripe runs to a distributed runner (a
/// cluster ran every one of them for nothing).
#[test]
fn a_study_without_stripes_has_no_stripe_runs() {
    let d = tmp("rb-fragility", "no-stripes");
    let study = fixture(&d, "\"housner\"", "");
    let text = std::fs::read_to_string(&study).unwrap();
    let load = || rockbench::fragility::study::load_study(&study).unwrap();
    assert_eq!(rockbench::fragility::stripe_specs(&load()).len(), 6 * 6);
    std::fs::write(
        &study,
        text.replace("tail = 3.0", "tail = 3.0\nstripes = false\n[ida]\n"),
    )
    .unwrap();
    assert!(rockbench::fragility::stripe_specs(&load()).is_empty());
}
