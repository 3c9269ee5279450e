//! `rockbench converge` through the run cache: a study run again reads every run back and
//! writes the same orders; `--no-cache` runs them again.

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
