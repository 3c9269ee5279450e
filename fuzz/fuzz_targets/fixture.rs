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

/// The scenes a resumed checkpoint is fuzzed on: the two-block statue on the dense back-ends,
/// and the 42-block wall toppling under its pulse on the sparse one (islands, factors and
/// located impacts in its stepper's state), each stopped two steps before its end so that a
/// resumption costs its checkpoint's reading and two steps.
const RESUMED_SCENES: [(&str, &str, &[&str], u64); 2] = [
    (
        "two-block.toml",
        include_str!("../../validation/scenes/two-block-free-rocking.toml"),
        &["duration=0.102"],
        100,
    ),
    (
        "wall.toml",
        include_str!("../../validation/scenes/wall-in-motion-pulse.toml"),
        &["duration=0.262"],
        260,
    ),
];

/// A checkpoint of this build written after a run's step, its sealed content and samples.
pub struct Stopped {
    pub scene: rockbench::scene::Scene,
    pub content: Vec<u8>,
    pub samples: Vec<u8>,
}

/// The resumed scenes' checkpoints, written on first use in `dir`.
pub fn stopped_runs(dir: &Path) -> &'static [Stopped] {
    use rockbench::native::checkpoint::{Checkpointing, unseal};
    static RUNS: OnceLock<Vec<Stopped>> = OnceLock::new();
    RUNS.get_or_init(|| {
        RESUMED_SCENES
            .iter()
            .map(|&(name, text, sets, stop)| {
                let path = input(dir, name, text.as_bytes());
                let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
                let scene = rockbench::scene::load_scene_with_overrides(&path, &sets)
                    .expect("the scene of a resumed run");
                let ck = dir.join(format!("{name}.ckpt"));
                let checkpointing = Checkpointing {
                    path: ck.clone(),
                    interval: std::time::Duration::from_secs(3600),
                    stop_after_step: Some(stop),
                };
                let stopped = rockbench::engines::native::NativeEngine.run_checkpointed(
                    &scene,
                    &rockbench::engines::go_on,
                    Some(&checkpointing),
                );
                assert!(stopped.is_err(), "the run stops after step {stop}");
                let file = std::fs::read(&ck).expect("the checkpoint written");
                Stopped {
                    scene,
                    content: unseal(&file).expect("a sealed checkpoint"),
                    samples: std::fs::read(dir.join(format!("{name}.ckpt.samples")))
                        .expect("the samples written"),
                }
            })
            .collect()
    })
}

/// Resume one of the stopped runs from its checkpoint changed by `data`, sealed anew: the first
/// byte picks the run, each next five bytes put a byte (the fifth) at an offset (the first four,
/// little-endian, modulo the length) of the checkpoint's sealed content. Gives the run's end:
/// the outputs, or one error line.
pub fn resume_changed(dir: &Path, data: &[u8]) -> Result<(), String> {
    use rockbench::native::checkpoint::{Checkpointing, seal};
    let runs = stopped_runs(dir);
    let Some((&pick, changes)) = data.split_first() else {
        return Ok(());
    };
    let run = &runs[usize::from(pick) % runs.len()];
    let mut content = run.content.clone();
    for change in changes.chunks_exact(5) {
        let at = u32::from_le_bytes([change[0], change[1], change[2], change[3]]) as usize;
        let len = content.len();
        content[at % len] = change[4];
    }
    let ck = dir.join("resumed.ckpt");
    std::fs::write(&ck, seal(content)).expect("the checkpoint written");
    std::fs::write(dir.join("resumed.ckpt.samples"), &run.samples).expect("the samples written");
    let checkpointing = Checkpointing {
        path: ck,
        interval: std::time::Duration::from_secs(3600),
        stop_after_step: None,
    };
    rockbench::engines::native::NativeEngine
        .run_checkpointed(&run.scene, &rockbench::engines::go_on, Some(&checkpointing))
        .map(|_| ())
        .map_err(|e| e.to_string())
}
