//! Settings of the commands that run series of engines (`bench`, `converge`, `stress`): an
//! engine name the registry does not know, a step size that no run can take, a list of known
//! violations that is not there. Each is one line naming the option, exit 1, before anything
//! runs and with nothing written.

mod common;

use common::{bin, root};
use std::path::Path;

/// Run `args` with `--out out` from the project's root: it must exit 1 with one line on stderr,
/// which is returned.
fn refused(args: &[&str], out: &Path) -> String {
    let o = bin()
        .args(args)
        .args(["--out", out.to_str().unwrap()])
        .current_dir(root())
        .output()
        .unwrap();
    let se = String::from_utf8_lossy(&o.stderr).trim().to_string();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {se}");
    assert_eq!(se.lines().count(), 1, "{args:?}: {se}");
    se
}

#[test]
fn bad_engine_names_and_steps_are_one_line_naming_the_option() {
    let dir = common::tmp("rb-settings", "series");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let scene = scene.to_str().unwrap();
    let known = rockbench::engines::registry::names().join(", ");
    let bogus = format!("--engines: unknown engine `bogus` (known: {known})");
    let cases: Vec<(Vec<&str>, String)> = vec![
        (
            vec!["bench", scene, "--engines", "native,bogus", "--dt", "1e-3"],
            bogus.clone(),
        ),
        (
            vec![
                "bench",
                scene,
                "--engines",
                "native",
                "--dt",
                "1e-3",
                "--dt",
                "10",
            ],
            "--dt: 10 s is longer than the scene's run, 4 s".into(),
        ),
        // A step longer than the block's time scale 1/p (p = sqrt(3 g / 4R), R = 1.3463 m):
        // milliseconds given as seconds ran 4 steps and answered (the first impact at 0.76 s
        // where Housner's is at 0.47 s).
        (
            vec!["bench", scene, "--engines", "native", "--dt", "1e-3,1"],
            "--dt: 1 s is longer than the time scale 1/p = 0.4278 s of block `block`".into(),
        ),
        (
            vec!["run", scene, "--set", "native.dt=0.5"],
            "housner-slender.toml: native.dt: 0.5 s is longer than the time scale 1/p = 0.4278 s of block `block` (p = sqrt(3 g / 4R)): a step would step over its motion (ms given for s?)".into(),
        ),
        (
            vec!["run", scene, "--engine", "rapier", "--set", "rapier.dt=0.05", "--set", "blocks[0].width=0.01", "--set", "blocks[0].height=0.025"],
            "rapier.dt: 0.05 s is longer than the time scale 1/p = 0.04278 s of block `block`".into(),
        ),
        // Steps too short for any engine: every cell failed, exit 0, outputs written.
        (
            vec!["bench", scene, "--engines", "native", "--dt", "1e-300"],
            "--dt: 1e-300 s makes 3.9999999999999996e300 steps of the scene's 4 s; at most 1e9"
                .into(),
        ),
        (
            vec![
                "converge",
                scene,
                "--engines",
                "native",
                "--dt",
                "2e-3,1e-300",
            ],
            "--dt: 1e-300 s makes".into(),
        ),
        (
            vec![
                "bench",
                scene,
                "--engines",
                "native",
                "--dt",
                "1e-3",
                "--repeat",
                "4294967297",
            ],
            "--repeat: from 1 to 1000 (got 4294967297)".into(),
        ),
        (
            vec!["converge", scene, "--engines", "bogus", "--dt", "1e-3,5e-4"],
            bogus.clone(),
        ),
        (
            vec![
                "converge",
                scene,
                "--engines",
                "native",
                "--dt",
                "1e-3,1e-3",
            ],
            "--dt: 0.001 s is given twice".into(),
        ),
        (
            vec!["compare", scene, "--engines", "native", "--jobs", "100000"],
            "--jobs: at most 256 (got 100000)".into(),
        ),
        (
            vec!["validate", "validation/suite.toml", "--jobs", "0"],
            "--jobs: at least 1 (got 0)".into(),
        ),
        (
            vec!["stress", "--quick", "--engines", "bogus"],
            bogus.clone(),
        ),
        (
            vec![
                "stress",
                "--quick",
                "--engines",
                "native",
                "--known",
                "nowhere.toml",
            ],
            "nowhere.toml: cannot read".into(),
        ),
        // Overrides a series replaces in every run (they were dropped without a word), and a
        // key given twice (the last one won).
        (
            vec![
                "bench",
                scene,
                "--engines",
                "native",
                "--dt",
                "1e-3",
                "--set",
                "native.dt=5e-4",
            ],
            "--set native.dt=5e-4: the series sets native.dt in every run (from --dt)".into(),
        ),
        (
            vec![
                "bench",
                scene,
                "--engines",
                "native",
                "--dt",
                "1e-3",
                "--set",
                "native.solver=\"clarabel\"",
            ],
            "the series sets native.solver in every run (native runs every solver and stepper)"
                .into(),
        ),
        (
            vec![
                "converge",
                scene,
                "--engines",
                "rapier",
                "--dt",
                "2e-3,1e-3",
                "--set",
                "rapier={dt=5e-4}",
            ],
            "--set rapier={dt=5e-4}: the series sets rapier.dt in every run (from --dt)".into(),
        ),
        (
            vec!["run", scene, "--set", "duration=1", "--set", " duration=2"],
            "--set: `duration` is given twice".into(),
        ),
        // An engine named twice (its runs were fitted as twice the points, with a standard
        // error of zero), a misspelled engine in a contract (ignored), an impact count twice.
        (
            vec![
                "converge",
                scene,
                "--engines",
                "native,native",
                "--dt",
                "2e-3,1e-3",
            ],
            "--engines: native is given twice".into(),
        ),
        (
            vec!["bench", scene, "--engines", "rapier,rapier", "--dt", "1e-3"],
            "--engines: rapier is given twice".into(),
        ),
        (
            vec!["stress", "--quick", "--engines", "housner,housner"],
            "--engines: housner is given twice".into(),
        ),
        (
            vec![
                "stress",
                "--quick",
                "--engines",
                "rapier",
                "--contract",
                "rapeir.standing=1e-9",
            ],
            "--contract rapeir.standing=1e-9: unknown engine `rapeir`".into(),
        ),
        (
            vec![
                "compare",
                scene,
                "--engines",
                "native",
                "--up-to-impacts",
                "3,1,3",
            ],
            "--up-to-impacts: 3 is given twice".into(),
        ),
    ];
    for (k, (args, message)) in cases.iter().enumerate() {
        let out = dir.join(format!("o{k}"));
        let se = refused(args, &out);
        assert!(
            se.contains(message.as_str()),
            "{args:?}: want {message}: {se}"
        );
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}

/// `--out` naming a file, or a folder that cannot be made (under /proc): refused in one line
/// before anything runs, by every command that writes a directory (a spectrum found out when it
/// wrote its outputs, after every run).
#[test]
fn an_out_that_is_a_file_is_refused_before_any_run() {
    let dir = common::tmp("rb-settings", "out-file");
    let file = dir.join("taken");
    std::fs::write(&file, "a file\n").unwrap();
    let scene = root().join("validation/scenes/housner-slender.toml");
    let scene = scene.to_str().unwrap();
    let study = root().join("validation/studies/statue-demo.toml");
    let study = study.to_str().unwrap();
    for args in [
        vec!["run", scene],
        vec![
            "compare",
            scene,
            "--engines",
            "native",
            "--reference",
            "housner",
        ],
        vec!["bench", scene, "--engines", "native", "--dt", "1e-3"],
        vec![
            "converge",
            scene,
            "--engines",
            "native",
            "--dt",
            "2e-3,1e-3",
        ],
        vec!["spectrum", "0.2x4", "--ratios", "2", "--engines", "housner"],
        vec!["stress", "--quick", "--engines", "housner"],
        vec!["sensitivity", scene, "--perturb", "initial.tilt=0.1"],
        vec!["validate", "validation/suite.toml"],
        vec!["fragility", study],
    ] {
        let se = refused(&args, &file);
        assert_eq!(
            se,
            format!(
                "error: --out: {} is a file, not a directory",
                file.display()
            ),
            "{args:?}"
        );
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "a file\n");
        let unmakeable = Path::new("/proc/rockbench/out");
        let se = refused(&args, unmakeable);
        assert!(
            se.starts_with("error: --out: /proc/rockbench/out: cannot write in /proc ("),
            "{args:?}: {se}"
        );
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "something else was written"
    );
}

/// A flag's seconds beyond some 30 years (`--progress-interval`, `--checkpoint-interval`,
/// `stress --timeout`) are one line naming the flag, not a panic converting them to a duration;
/// so is `spectrum --friction` above the largest friction a scene may give, and a stop after
/// step 0 (it was ignored: the whole run was made).
#[test]
fn seconds_and_friction_out_of_range_are_one_line_naming_the_flag() {
    let dir = common::tmp("rb-settings", "seconds");
    let scene = root().join("validation/scenes/housner-slender.toml");
    let scene = scene.to_str().unwrap();
    let checkpoint = dir.join("run.ckpt");
    let checkpoint = checkpoint.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["run", scene, "--progress-interval", "1e300"],
            "--progress-interval: must be a number of seconds >= 0 and at most 1e9 (got 1e300)",
        ),
        (
            vec![
                "run",
                scene,
                "--checkpoint",
                checkpoint,
                "--checkpoint-interval",
                "2e9",
            ],
            "--checkpoint-interval: must be a number of seconds >= 0 and at most 1e9 (got 2000000000)",
        ),
        (
            vec![
                "run",
                scene,
                "--checkpoint",
                checkpoint,
                "--stop-after-step",
                "0",
            ],
            "--stop-after-step: steps are counted from 1 (got 0)",
        ),
        (
            vec!["stress", "--quick", "--timeout", "1e300"],
            "--timeout: must be a number of seconds > 0 and at most 1e9 (got 1e300)",
        ),
        (
            vec!["stress", "--quick", "--timeout", "0"],
            "--timeout: must be a number of seconds > 0",
        ),
        (
            vec!["spectrum", "0.2x1", "--friction", "2e4"],
            "--friction 20000 is above 1e4",
        ),
    ];
    for (k, (args, expected)) in cases.iter().enumerate() {
        let out = dir.join(format!("out{k}"));
        let line = refused(args, &out);
        assert!(line.contains(expected), "{args:?}: {line}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    assert!(!Path::new(checkpoint).exists());
}

/// A command line clap cannot parse (an unknown flag, a number that is not one, an unknown
/// subcommand) is one line on stderr naming what is wrong (and the command's usage where clap
/// gives it), exit 2, as every other refusal is one line.
#[test]
fn a_command_line_that_does_not_parse_is_one_line() {
    let cases: [(&[&str], &str); 3] = [
        (
            &["run", "--dt", "1e-3", "s.toml"],
            "unexpected argument '--dt'",
        ),
        (
            &["stress", "--quick", "--timeout", "soon"],
            "invalid value 'soon' for '--timeout",
        ),
        (&["bogus"], "unrecognized subcommand 'bogus'"),
    ];
    for (args, says) in cases {
        let o = bin().args(args).current_dir(root()).output().unwrap();
        let se = String::from_utf8_lossy(&o.stderr).trim().to_string();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {se}");
        assert_eq!(se.lines().count(), 1, "{args:?}: {se}");
        assert!(
            se.starts_with("error: ") && se.contains(says),
            "{args:?}: {se}"
        );
        assert!(se.ends_with("see --help)"), "{args:?}: {se}");
        assert!(o.stdout.is_empty(), "{args:?}");
    }
    // No subcommand at all: the help, as clap prints it, and a failure.
    let o = bin().current_dir(root()).output().unwrap();
    let se = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{se}");
    assert!(
        se.lines().count() > 10 && se.contains("Commands:\n"),
        "{se}"
    );
}

/// A stability map written where an earlier one was: the earlier map's pages of engines this
/// one does not run are removed (they stood beside an index that no longer named them); other
/// files stay.
#[test]
fn a_stability_map_written_again_removes_other_engines_pages() {
    let dir = common::tmp("rb-settings", "stress-again");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    for f in ["rapier.csv", "rapier.html", "notes.txt"] {
        std::fs::write(out.join(f), "earlier").unwrap();
    }
    let o = bin()
        .current_dir(root())
        .args([
            "stress",
            "--quick",
            "--engines",
            "housner",
            "--factors",
            "dt",
        ])
        .args(["--no-cache", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{o:?}");
    assert!(out.join("housner.csv").is_file() && out.join("housner.html").is_file());
    assert!(!out.join("rapier.csv").exists() && !out.join("rapier.html").exists());
    assert!(out.join("notes.txt").is_file());
}
