//! The files a suite manifest or a study names: a scene, a two-column CSV record, a PEER .AT2
//! record and a valid suite of the two. The fuzz targets write their input beside them in a
//! folder of the process's own; tests/fuzz_regressions.rs replays in a temporary folder.
// Each target, and the replay, uses a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The scene a study names (`scene.toml`).
pub const SCENE: &str = include_str!("../seeds/scene_toml/two-block-free-rocking.toml");
/// The records a suite names (`a.csv`, `b.at2`).
pub const CSV_RECORD: &str = include_str!("../seeds/record_csv/a.csv");
pub const AT2_RECORD: &str = include_str!("../seeds/record_at2/new.at2");
/// A valid suite of the two records (`suite.toml`), the one a study names.
pub const SUITE: &str = include_str!("../seeds/suite_manifest/two-records.toml");

/// Write the four files into `dir` (`scene.toml`, `a.csv`, `b.at2`, `suite.toml`).
pub fn write_into(dir: &Path) {
    for (name, text) in [
        ("scene.toml", SCENE),
        ("a.csv", CSV_RECORD),
        ("b.at2", AT2_RECORD),
        ("suite.toml", SUITE),
    ] {
        std::fs::write(dir.join(name), text).expect("a fixture file");
    }
}

/// Write `text` as `name` in `dir`, and give its path.
pub fn input(dir: &Path, name: &str, text: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("the input written");
    p
}

/// The fuzzers' folder, made on first use: `rockbench-fuzz-<pid>` in the system's temporary
/// folder, left for the system to clear (a fuzzer ends by being stopped).
pub fn folder() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("rockbench-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temporary folder");
        write_into(&dir);
        dir
    })
}

/// A loader's refusal of `input`: one line, naming `input` as its file.
pub fn assert_one_line_naming(input: &Path, file: &str, line: &str) {
    assert!(!line.contains('\n'), "multi-line error: {line}");
    assert_eq!(
        file,
        input.display().to_string(),
        "names another file: {line}"
    );
}
