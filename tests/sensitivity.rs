//! `rockbench sensitivity`: a scene run as ensembles, resumed, and refused where it should be.

mod common;

use common::{bin, root, tmp};
use rockbench::build_info::{GIT_COMMIT, SOURCE_HASH};
use std::path::Path;
use std::process::Output;

/// The study of a slender block overturned by a rectangular pulse, by the native engine at two
/// steps, two members, 3 s, with the options of `over` in place of these.
fn study(out: &Path, over: &[&str]) -> Output {
    let scene = root().join("validation/scenes/pulse-rectangular-pt0p5-above.toml");
    let mut options = vec![
        (
            "--perturb",
            "excitation.horizontal.amplitude=2.544058691052",
        ),
        ("--configs", "native,native:native.dt=5e-4"),
        ("--members", "2"),
        ("--set", "duration=3.0"),
    ];
    for pair in over.chunks(2) {
        match options.iter_mut().find(|(k, _)| *k == pair[0]) {
            Some(o) => o.1 = pair[1],
            None => options.push((pair[0], pair[1])),
        }
    }
    let mut cmd = bin();
    cmd.args([
        "sensitivity",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    for (k, v) in options {
        cmd.args([k, v]);
    }
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// The `(spread, largest spread)` cells of a configuration's row, mm.
fn spread_of(md: &str, config: &str) -> (f64, f64) {
    let row = md
        .lines()
        .find(|l| l.starts_with(&format!("| `{config}` |")))
        .unwrap_or_else(|| panic!("no row for {config} in\n{md}"));
    let cell = row.split('|').nth(6).unwrap().trim();
    let (a, b) = cell.split_once(" (").unwrap();
    (a.parse().unwrap(), b.trim_end_matches(')').parse().unwrap())
}

/// The report without the wall-time cells (ms a step, s a run) of its first table.
fn without_timings(md: &str) -> String {
    md.lines()
        .map(|l| {
            let cells: Vec<&str> = l.split('|').collect();
            if l.starts_with("| `") && cells.len() > 8 {
                [&cells[..3], &cells[5..]].concat().join("|")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_study_runs_its_members_resumes_and_compares_its_configurations() {
    let dir = tmp("rb-sensitivity", "study");
    let out = dir.join("study");
    // Members 1e-6 apart, so that they surely differ.
    let first = study(&out, &["--epsilon", "1e-6"]);
    assert!(first.status.success(), "{}", stderr(&first));
    let progress = stderr(&first);
    assert_eq!(progress.matches("member").count(), 4, "{progress}");
    let runs = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 2 + 4, "{runs}");
    assert!(runs.starts_with("# sensitivity: scene "));
    assert!(
        runs.lines()
            .next()
            .unwrap()
            .ends_with(&format!("(sources {SOURCE_HASH})"))
    );
    let md = std::fs::read_to_string(out.join("sensitivity.md")).unwrap();
    let (spread, largest) = spread_of(&md, "native");
    assert!(spread > 0.0 && largest >= spread, "{md}");
    assert!(
        md.contains("| `native:native.dt=5e-4` | `native` |"),
        "the pair's row: {md}"
    );
    // The block overturns in every member.
    assert!(md.contains("| 1 / 1 | - |"), "{md}");
    assert!(
        md.contains(&format!("(commit {GIT_COMMIT}, sources {SOURCE_HASH}) on ")),
        "{md}"
    );

    // Run again: every run is there, none is run, the tables are the same.
    let again = study(&out, &["--epsilon", "1e-6"]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert_eq!(
        stderr(&again).matches("member").count(),
        0,
        "{}",
        stderr(&again)
    );
    assert_eq!(
        std::fs::read_to_string(out.join("sensitivity.md")).unwrap(),
        md
    );

    // A run interrupted while its line was written: the unfinished line is cut and its run
    // made again, to the same line.
    let last = runs.lines().last().unwrap();
    let cut = &runs[..runs.len() - last.len() / 2 - 1];
    std::fs::write(out.join("runs.csv"), cut).unwrap();
    let resumed = study(&out, &["--epsilon", "1e-6"]);
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert_eq!(
        stderr(&resumed).matches("member").count(),
        1,
        "{}",
        stderr(&resumed)
    );
    let rerun = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    let fields = |l: &str| {
        let f: Vec<String> = l.split(',').map(String::from).collect();
        [&f[..2], &f[3..]].concat()
    };
    assert_eq!(rerun.lines().count(), runs.lines().count(), "{rerun}");
    assert_eq!(fields(rerun.lines().last().unwrap()), fields(last));

    // A run of a member the study does not ask for (a study of more members in the same
    // folder) stays in the file and out of the ensembles.
    let two = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    let wild = two
        .lines()
        .nth(2)
        .unwrap()
        .replacen("native,0,", "native,5,", 1);
    let (head, _) = wild.rsplit_once(',').unwrap();
    let more = format!("{two}{head},-0.5\n");
    std::fs::write(out.join("runs.csv"), &more).unwrap();
    let o = study(&out, &["--epsilon", "1e-6"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same tables but for the wall times, which the run made again changed.
    assert_eq!(
        without_timings(&std::fs::read_to_string(out.join("sensitivity.md")).unwrap()),
        without_timings(&md)
    );
    assert_eq!(std::fs::read_to_string(out.join("runs.csv")).unwrap(), more);

    // A run given twice is one line naming it; nothing is rewritten.
    let doubled = format!("{two}{}\n", two.lines().nth(2).unwrap());
    std::fs::write(out.join("runs.csv"), &doubled).unwrap();
    let o = study(&out, &["--epsilon", "1e-6"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("line 7: a second run of native, member 0"),
        "{e}"
    );
    assert_eq!(e.trim().lines().count(), 1, "one line: {e}");
    assert_eq!(
        std::fs::read_to_string(out.join("runs.csv")).unwrap(),
        doubled
    );
    std::fs::write(out.join("runs.csv"), &two).unwrap();
    let runs = two;

    // Another study in the same directory is refused, and the runs stay as they were.
    let other = study(&out, &["--epsilon", "1e-9"]);
    assert!(!other.status.success());
    let e = stderr(&other);
    assert!(e.contains("runs.csv") && e.contains("another study"), "{e}");
    assert_eq!(e.trim().lines().count(), 1, "one line: {e}");
    assert_eq!(std::fs::read_to_string(out.join("runs.csv")).unwrap(), runs);

    // The same study's runs made by other sources are not resumed.
    let older = runs.replacen(
        &format!("sources {SOURCE_HASH}"),
        "sources 0123456789abcdef",
        1,
    );
    assert_ne!(older, runs);
    std::fs::write(out.join("runs.csv"), &older).unwrap();
    let rebuilt = study(&out, &["--epsilon", "1e-6"]);
    assert!(!rebuilt.status.success());
    let e = stderr(&rebuilt);
    assert!(
        e.contains("another build") && e.contains("0123456789abcdef"),
        "{e}"
    );
    assert_eq!(e.trim().lines().count(), 1, "one line: {e}");
    assert_eq!(
        std::fs::read_to_string(out.join("runs.csv")).unwrap(),
        older
    );
}

#[test]
fn bad_studies_say_what_is_wrong_and_write_nothing() {
    let dir = tmp("rb-sensitivity", "bad");
    for (extra, expected) in [
        (&["--configs", "native:native.dtt=1"][..], "dtt"),
        (&["--configs", "bogus"][..], "unknown engine"),
        (&["--members", "1"][..], "--members"),
        (&["--epsilon", "0.1"][..], "--epsilon"),
        // Members that would run for ever, or all be the same scene.
        (
            &["--members", "4294967297"][..],
            "--members: from 2 to 1000 (got 4294967297)",
        ),
        (&["--epsilon", "1e-300"][..], "(got 1e-300)"),
        (
            &["--perturb", "excitation.horizontal.amplitud=4.9"][..],
            "amplitud",
        ),
        (&["--perturb", "amplitude"][..], "KEY=VALUE"),
        (
            &[
                "--configs",
                "native,native:excitation.horizontal.amplitude=3",
            ][..],
            "sets excitation.horizontal.amplitude, the perturbed value",
        ),
        // The same, written as a table (it passed, and its members were all one scene).
        (
            &[
                "--perturb",
                "initial.tilt=0.01",
                "--configs",
                "native,native:initial={tilt=0.02}",
            ][..],
            "sets initial.tilt, the perturbed value",
        ),
        // A --set of the perturbed value, which the perturbation replaced without a word.
        (
            &["--set", "excitation.horizontal.amplitude=3"][..],
            "--set excitation.horizontal.amplitude=3: sets excitation.horizontal.amplitude",
        ),
        // Two configurations that make the same runs.
        (
            &["--configs", "native,native:"][..],
            "\"native:\" makes the same runs as \"native\"",
        ),
        // The same, their values written apart (both ran).
        (
            &["--configs", "native:native.dt=5e-4,native:native.dt=0.0005"][..],
            "\"native:native.dt=0.0005\" makes the same runs as \"native:native.dt=5e-4\"",
        ),
        // A key given twice in one configuration (the last one won without a word).
        (
            &["--configs", "native:native.dt=1e-3;native.dt=2e-3"][..],
            "`native.dt` is given twice",
        ),
        // A setting of another engine, which the configuration's engine does not read.
        (
            &["--configs", "native,housner:native.dt=5e-4"][..],
            "native.dt=5e-4 is a setting of engine `native`, not of `housner`",
        ),
        (
            &["--perturb", "native.dt=1e-3", "--configs", "housner"][..],
            "--perturb: native.dt is a setting of engine `native`, which configuration \"housner\"",
        ),
        // A value whose members round to one (it was blamed on a configuration).
        (
            &["--perturb", "initial.tilt=1e-320", "--configs", "native"][..],
            "round to the same scene",
        ),
    ] {
        let out = dir.join(expected.replace(['-', ' '], "_"));
        let o = study(&out, extra);
        assert!(!o.status.success(), "{extra:?} passed");
        let e = stderr(&o);
        assert!(e.contains(expected), "{extra:?}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{extra:?}: one line: {e}");
        assert!(!out.join("runs.csv").exists(), "{extra:?} wrote its runs");
    }
}

/// A study resumed after its record file changed is refused as another study's runs (the
/// runs made before kept the old record, and the ensemble mixed two loadings).
#[test]
fn a_changed_record_file_makes_another_study() {
    let dir = tmp("rb-sensitivity", "record");
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        "name = \"s\"\nduration = 0.2\n[[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1.0\n\
         [excitation.horizontal]\nkind = \"record\"\nfile = \"gm.csv\"\n",
    )
    .unwrap();
    let out = dir.join("out");
    let run = |members: &str| {
        bin()
            .args([
                "sensitivity",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .args(["--perturb", "blocks[0].width=0.4", "--configs", "native"])
            .args(["--members", members])
            .output()
            .unwrap()
    };
    std::fs::write(dir.join("gm.csv"), "0,0\n0.1,3\n0.2,0\n").unwrap();
    let o = run("2");
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(dir.join("gm.csv"), "0,0\n0.1,-9\n0.2,0\n").unwrap();
    let o = run("3");
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("holds the runs of another study"), "{e}");
    assert_eq!(e.trim().lines().count(), 1, "{e}");
}

/// A study resumed with another engine version than its runs were made with (an upgraded
/// package between an interruption and the resumption) is refused before it mixes the two in
/// one ensemble.
#[test]
fn a_resumed_study_keeps_one_engine_version_a_configuration() {
    let out = tmp("rb-sensitivity", "version");
    let o = study(&out, &["--configs", "native"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let runs = out.join("runs.csv");
    let text = std::fs::read_to_string(&runs).unwrap();
    let version = text
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .nth(4)
        .unwrap()
        .to_string();
    let edited = text.replacen(&format!(",{version},"), ",rockbench 9.9.9,", 1);
    assert_ne!(edited, text);
    std::fs::write(&runs, &edited).unwrap();
    let o = study(&out, &["--configs", "native", "--members", "3"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert_eq!(e.trim().lines().count(), 1, "{e}");
    assert!(
        e.contains("configuration \"native\"'s runs were made with native rockbench 9.9.9")
            && e.contains(&format!("member 2 now with {version}")),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(&runs).unwrap(), edited);
}
