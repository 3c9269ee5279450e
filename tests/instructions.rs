//! Instructions counted by callgrind in an engine's steps (`rockbench::instructions`), through
//! the `rockbench run` binary: the count the walls benchmark reports with `--instructions`.

use rockbench::instructions::{collected, step_function, under_callgrind};
use std::path::Path;

/// A slender block released from a tilt, rocking freely for `duration` s (its first impact
/// is at 0.47 s): every step the same kind of work.
fn rocking_block(dir: &Path, duration: f64) -> std::path::PathBuf {
    let path = dir.join(format!("rocking-{duration}.toml"));
    let text = format!(
        "name = \"rocking\"\nduration = {duration}\n\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n\n[initial]\ntilt = 0.15\n\n[contact]\nfriction = 0.7\n"
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// `rockbench run` of `engine` on `scene` under callgrind, counting `function`'s instructions
/// into `counts`.
fn run_counted(engine: &str, function: &str, scene: &Path, counts: &Path, out: &Path) {
    let status = under_callgrind(Path::new(env!("CARGO_BIN_EXE_rockbench")), function, counts)
        .arg("run")
        .arg(scene)
        .args(["--engine", engine, "--out"])
        .arg(out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .expect("valgrind runs (Debian's package valgrind)");
    assert!(status.success(), "{engine} under callgrind: {status}");
}

/// The instructions `engine`'s steps execute on `scene`.
fn counted(engine: &str, scene: &Path, dir: &Path, tag: &str) -> u64 {
    let function = step_function(engine).unwrap();
    let counts = dir.join(format!("{engine}-{tag}.out"));
    let out = dir.join(format!("run-{engine}-{tag}"));
    run_counted(engine, function, scene, &counts, &out);
    collected(&counts, function).unwrap()
}

#[test]
fn a_steps_count_is_repeatable_and_grows_with_the_steps() {
    let dir = tempfile::tempdir().unwrap();
    let short = rocking_block(dir.path(), 0.1);
    let long = rocking_block(dir.path(), 0.2);
    let engines: &[&str] = if cfg!(feature = "rapier") {
        &["native", "rapier"]
    } else {
        &["native"]
    };
    for &engine in engines {
        // The two runs' arguments have the same lengths: a step's count moves with the process's
        // memory layout, which the arguments' lengths shift (glibc's copies take paths by their
        // buffers' alignment; measured, an output path one character longer moved the count of
        // this run by 2-600 instructions in 1.4 million, at some lengths and not others).
        let once = counted(engine, &short, dir.path(), "first");
        let again = counted(engine, &short, dir.path(), "again");
        let twice_the_steps = counted(engine, &long, dir.path(), "long");
        // 100 steps of dt 1e-3: at least a step's worth of arithmetic each.
        assert!(once > 100 * 1000, "{engine}: {once} instructions");
        assert_eq!(once, again, "{engine}: the same run counted twice");
        let ratio = twice_the_steps as f64 / once as f64;
        assert!(
            (1.9..=2.1).contains(&ratio),
            "{engine}: 200 steps counted {ratio} times 100 steps"
        );
    }
}

#[test]
fn a_function_never_called_counts_nothing_and_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = rocking_block(dir.path(), 0.01);
    // The native engine's run never enters rapier's step.
    let function = step_function("rapier").unwrap();
    let counts = dir.path().join("native.out");
    run_counted("native", function, &scene, &counts, &dir.path().join("run"));
    let err = collected(&counts, function).unwrap_err();
    assert!(
        err.contains("no instruction counted in rockbench::engines::rapier::RapierSim::step"),
        "{err}"
    );
}
