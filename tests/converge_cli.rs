//! `rockbench converge` through the run cache: a study run again reads every run back and
//! writes the same orders; `--no-cache` runs them again. A study or benchmark written where an
//! earlier one was leaves none of that one's outputs it does not write itself.

mod common;

use common::{bin, root};

fn converge(out: &std::path::Path, cache: &std::path::Path, extra: &[&str]) -> String {
    let mut cmd = bin();
    cmd.current_dir(root()).args([
        "converge",
        "validation/scenes/housner-slender.toml",
        "--engines",
        "native",
        "--dt",
        "2e-3,1e-3,5e-4",
        "--reference",
        "housner",
        "--set",
        "duration=0.6",
        "--out",
        out.to_str().unwrap(),
        "--cache-dir",
        cache.to_str().unwrap(),
    ]);
    cmd.args(extra);
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{o:?}");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_converge_study_run_again_reads_its_runs_from_the_cache() {
    let dir = common::tmp("rb-converge", "cache");
    let cache = dir.join("cache");
    let (first, second, third) = (dir.join("a"), dir.join("b"), dir.join("c"));
    let made = converge(&first, &cache, &[]);
    // Three engine runs and the reference (engines built in every build): four entries, none
    // read back the first time.
    assert_eq!(made.matches(": ok ").count(), 3, "{made}");
    assert!(!made.contains("(cached)"), "{made}");
    assert_eq!(std::fs::read_dir(&cache).unwrap().count(), 4);
    let again = converge(&second, &cache, &[]);
    assert_eq!(again.matches("(cached)").count(), 3, "{again}");
    let read = |d: &std::path::Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    for f in ["converge.csv", "orders.csv"] {
        assert_eq!(read(&first, f), read(&second, f), "{f}");
    }
    let runs: serde_json::Value = serde_json::from_str(&read(&second, "converge.json")).unwrap();
    let runs = runs["convergence"]["runs"].as_array().unwrap();
    assert!(
        runs.len() == 3 && runs.iter().all(|r| r["cached"] == true),
        "{runs:?}"
    );
    assert_eq!(
        read(&second, "converge.md").matches(" (cached) |").count(),
        3
    );
    // Run again without the cache: the same errors, nothing read back.
    let fresh = converge(&third, &cache, &["--no-cache"]);
    assert!(!fresh.contains("(cached)"), "{fresh}");
    assert_eq!(read(&first, "converge.csv"), read(&third, "converge.csv"));
}

/// A study written where an earlier one was: the earlier one's figures of quantities this one
/// does not plot, and its paper when none is asked for, are removed; other files stay, and so
/// does a folder no study wrote.
#[test]
fn a_converge_study_written_again_removes_what_it_does_not_write() {
    let dir = common::tmp("rb-converge", "again");
    let (cache, out) = (dir.join("cache"), dir.join("out"));
    std::fs::create_dir_all(out.join("paper")).unwrap();
    std::fs::write(out.join("paper/orders.tex"), "earlier").unwrap();
    std::fs::write(out.join("keep.txt"), "mine").unwrap();
    // No converge.csv yet: not a study's folder, nothing removed.
    converge(&out, &cache, &[]);
    assert!(out.join("paper/orders.tex").is_file());
    std::fs::write(out.join("converge-old_quantity.svg"), "earlier").unwrap();
    converge(&out, &cache, &[]);
    assert!(!out.join("paper").exists());
    assert!(!out.join("converge-old_quantity.svg").exists());
    assert!(out.join("keep.txt").is_file() && out.join("converge.csv").is_file());
    let svgs = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            let n = e.as_ref().unwrap().file_name();
            let n = n.to_string_lossy();
            n.starts_with("converge-") && n.ends_with(".svg")
        })
        .count();
    assert!(svgs > 0, "the study's own figures are written");
}

/// The same for `rockbench bench`: an earlier benchmark's paper is removed when none is asked.
#[test]
fn a_benchmark_written_again_removes_an_earlier_paper() {
    let dir = common::tmp("rb-bench", "again");
    let out = dir.join("out");
    let bench = || {
        let o = bin()
            .current_dir(root())
            .args(["bench", "validation/scenes/housner-slender.toml"])
            .args(["--engines", "native", "--dt", "2e-3", "--repeat", "1"])
            .args(["--reference", "housner", "--set", "duration=0.3", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{o:?}");
    };
    std::fs::create_dir_all(out.join("paper")).unwrap();
    std::fs::write(out.join("paper/work_precision.tex"), "earlier").unwrap();
    bench();
    assert!(
        out.join("paper").exists(),
        "no work_precision.csv: not a benchmark's folder"
    );
    bench();
    assert!(!out.join("paper").exists());
    assert!(out.join("work_precision.csv").is_file());
}

/// A reference engine that is also studied, with a step: its run at the scene's step is no
/// reference for its own steps (native against native gave order 0.99 where it is 2.0). One
/// line, nothing written.
#[test]
fn a_studied_engine_is_no_reference_for_its_own_steps() {
    let out = common::tmp("rb-converge", "self-reference");
    let o = common::bin()
        .args(["converge"])
        .arg(common::root().join("validation/scenes/housner-slender.toml"))
        .args([
            "--engines",
            "native",
            "--dt",
            "2e-3,1e-3,5e-4",
            "--reference",
            "native",
        ])
        .args(["--no-cache", "--out"])
        .arg(out.join("c"))
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(
        err.contains("--reference native: one of the engines studied"),
        "{err}"
    );
    assert!(err.contains("or `self`"), "{err}");
    assert!(!out.join("c").exists());
}

/// Steps coarser than the scene's output interval sample the run at each step: its errors are
/// measured at those samples, not on a 1 ms grid that interpolates them linearly (whose error
/// outweighed the engine's and made the native stepper converge at "third order", 2.99 +-
/// 0.53). The slender block against Housner up to its first impact: second order.
#[test]
fn steps_coarser_than_the_output_are_measured_at_their_own_samples() {
    let dir = common::tmp("rb-converge", "coarse");
    let out = dir.join("out");
    let o = bin()
        .current_dir(root())
        .args([
            "converge",
            "validation/scenes/housner-slender.toml",
            "--engines",
            "native",
            "--dt",
            "4e-3,2e-3,1e-3,5e-4",
            "--reference",
            "housner",
            "--set",
            "duration=1.5",
            "--no-cache",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{o:?}");
    let orders = std::fs::read_to_string(out.join("orders.csv")).unwrap();
    let row = orders
        .lines()
        .find(|l| l.contains(",rotation_rms_error_to_impact_1,"))
        .unwrap_or_else(|| panic!("{orders}"));
    let cells: Vec<&str> = row.split(',').collect();
    let header: Vec<&str> = orders.lines().next().unwrap().split(',').collect();
    let col = |name: &str| cells[header.iter().position(|h| *h == name).unwrap()];
    let order: f64 = col("order").parse().unwrap();
    let (lo, hi): (f64, f64) = (
        col("local_min").parse().unwrap(),
        col("local_max").parse().unwrap(),
    );
    assert!((order - 2.0).abs() < 0.05, "{row}");
    assert!(lo > 1.9 && hi < 2.1, "{row}");
}
