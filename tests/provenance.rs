//! Every output names the program that wrote it (its version, the commit it was built from and
//! the hash of its sources), wherever it runs: not the git repository of the directory it is
//! run in.

mod common;

use common::{bin, root, run_ok};
use rockbench::build_info::{GIT_COMMIT, LONG_VERSION, SOURCE_HASH};
use std::path::Path;
use std::process::Command;

fn git(dir: &Path, args: &[&str]) -> String {
    let out = Command::new("git")
        .args(["-c", "user.name=t", "-c", "user.email=t@t"])
        .args(args)
        .current_dir(dir)
        .output()
        .expect("git runs");
    assert!(out.status.success(), "git {args:?}: {out:?}");
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn outputs_name_the_program_not_the_repository_they_are_run_in() {
    // A user's project under git, with a commit of its own, as the working directory.
    let project = common::tmp("rb-provenance", "project");
    git(&project, &["init", "-q"]);
    git(
        &project,
        &["commit", "-q", "--allow-empty", "-m", "a user's project"],
    );
    let theirs = git(&project, &["rev-parse", "HEAD"]);
    assert_ne!(GIT_COMMIT.split(' ').next(), Some(theirs.as_str()));

    let scene = root().join("validation/scenes/housner-slender.toml");
    run_ok(
        bin()
            .current_dir(&project)
            .args(["run", "--engine", "housner", "--out", "run"])
            .arg(&scene),
    );
    let summary = json(&project.join("run/summary.json"));
    assert_eq!(summary["rockbench_git_commit"], GIT_COMMIT);
    assert_eq!(summary["rockbench_source_hash"], SOURCE_HASH);

    run_ok(bin().current_dir(&project).args([
        "spectrum",
        "0.2x4",
        "--ratios",
        "2",
        "--amplitudes",
        "none",
        "--engines",
        "housner",
        "--out",
        "spectrum",
    ]));
    let provenance = &json(&project.join("spectrum/spectrum.json"))["provenance"];
    assert_eq!(provenance["git_commit"], GIT_COMMIT);
    assert_eq!(provenance["source_hash"], SOURCE_HASH);

    let version = run_ok(bin().arg("--version"));
    assert_eq!(version.trim(), format!("rockbench {LONG_VERSION}"));
}
