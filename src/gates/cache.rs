//! The run cache of the gates: one directory per run, named by a content hash. An entry's
//! files are served only as they were stored: `contents.sha256` (the format of `sha256sum`)
//! holds the SHA-256 of the trajectory, the summary and the exact impacts, and an entry one of
//! whose files was cut or changed is run again.

use crate::compare::{EngineRun, Status, run_engine_reporting};
use crate::digest::sha256_hex;
use crate::engines::RunOutput;
use crate::scene::Scene;
use crate::summary::Summary;
use crate::trajectory::Trajectory;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bumped when the layout of a cache entry changes.
const CACHE_FORMAT: u32 = 3;

pub struct RunCache {
    dir: Option<PathBuf>,
    hits: AtomicUsize,
    runs: AtomicUsize,
}

/// Hash of the running executable (computed once).
fn build_id() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map(|b| sha256_hex(&b))
            .unwrap_or_else(|_| "unknown".into())
    })
}

/// The inputs that determine a run, as hashed (also written to `key.json` in the entry).
pub fn key_json(engine: &str, scene: &Scene) -> serde_json::Value {
    serde_json::json!({
        "format": CACHE_FORMAT,
        "engine": engine,
        "scene": scene.to_json(),
        "record_files": scene.record_hashes(),
        "rockbench_version": env!("CARGO_PKG_VERSION"),
        "rockbench_build": build_id(),
        "python": crate::engines::external::interpreter_id(engine),
    })
}

/// The content hash of a run.
pub fn run_key(engine: &str, scene: &Scene) -> String {
    let text = serde_json::to_string(&key_json(engine, scene)).expect("keys serialise");
    sha256_hex(text.as_bytes())
}

impl RunCache {
    pub fn new(dir: Option<PathBuf>) -> Self {
        RunCache {
            dir,
            hits: AtomicUsize::new(0),
            runs: AtomicUsize::new(0),
        }
    }

    pub fn stats(&self) -> super::CacheStats {
        super::CacheStats {
            hits: self.hits.load(Ordering::Relaxed),
            runs: self.runs.load(Ordering::Relaxed),
        }
    }

    /// Serve a run from the cache, or run the engine and store the result. Only successful
    /// runs are stored (a failure may come from the environment and is retried). Once a Ctrl-C
    /// has come ([`crate::interrupt`]) no run starts and the runs under way stop, as failures
    /// that are not stored; the command then reports the interruption, not them.
    pub fn run(&self, engine: &str, scene: &Scene) -> EngineRun {
        let make = || {
            if crate::interrupt::requested() {
                return EngineRun {
                    engine: engine.to_string(),
                    status: Status::Failed("not run: the command was interrupted".into()),
                    output: None,
                    summary: None,
                    cached: false,
                };
            }
            self.runs.fetch_add(1, Ordering::Relaxed);
            run_engine_reporting(engine, scene, &crate::interrupt::go_on_unless_interrupted)
        };
        let Some(dir) = &self.dir else {
            return make();
        };
        let key = run_key(engine, scene);
        let entry = dir.join(&key);
        if let Some(r) = load(&entry, engine) {
            self.hits.fetch_add(1, Ordering::Relaxed);
            return r;
        }
        let r = make();
        if r.status == Status::Ok {
            // A cache that cannot be written only costs a re-run next time.
            let _ = store(&entry, engine, scene, &r);
        }
        r
    }
}

/// The files of an entry that `contents.sha256` seals, in its order.
const SEALED: [&str; 3] = ["trajectory.csv", "summary.json", "exact_impacts.json"];

/// `contents.sha256` of an entry's files' bytes (in [`SEALED`]'s order).
fn contents_sha256(files: &[&[u8]; 3]) -> String {
    SEALED
        .iter()
        .zip(files)
        .map(|(name, bytes)| format!("{}  {name}\n", sha256_hex(bytes)))
        .collect()
}

fn load(entry: &Path, engine: &str) -> Option<EngineRun> {
    // The files as they were stored, to the byte (a cut or altered file is not served).
    let [csv, summary, impacts] = SEALED.map(|f| std::fs::read(entry.join(f)).ok());
    let (csv, summary, impacts) = (csv?, summary?, impacts?);
    let sealed = std::fs::read_to_string(entry.join("contents.sha256")).ok()?;
    if sealed != contents_sha256(&[&csv, &summary, &impacts]) {
        return None;
    }
    let summary: Summary = serde_json::from_slice(&summary).ok()?;
    let trajectory = Trajectory::parse_csv(std::str::from_utf8(&csv).ok()?).ok()?;
    let exact_impacts: Option<Vec<Vec<f64>>> = serde_json::from_slice(&impacts).ok()?;
    Some(EngineRun {
        engine: engine.to_string(),
        status: Status::Ok,
        output: Some(RunOutput {
            trajectory,
            settings: summary.settings.clone(),
            engine_version: summary.engine_version.clone(),
            steps: summary.steps,
            solver_iterations: summary.solver_iterations,
            exact_impacts,
            notes: summary.notes.clone(),
            valid_until: summary.model_valid_until,
        }),
        summary: Some(summary),
        cached: true,
    })
}

fn store(entry: &Path, engine: &str, scene: &Scene, r: &EngineRun) -> std::io::Result<()> {
    let (Some(out), Some(summary)) = (&r.output, &r.summary) else {
        return Ok(());
    };
    let parent = entry.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)?;
    let tmp = parent.join(format!(
        ".tmp-{}-{}",
        std::process::id(),
        entry.file_name().unwrap_or_default().to_string_lossy()
    ));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp)?;
    let mut csv = Vec::new();
    out.trajectory.write_csv_to(&mut csv)?;
    let summary = serde_json::to_string_pretty(summary).expect("summaries serialise");
    let impacts = serde_json::to_string(&out.exact_impacts).expect("impacts serialise");
    let files: [&[u8]; 3] = [&csv, summary.as_bytes(), impacts.as_bytes()];
    for (name, bytes) in SEALED.iter().zip(files) {
        std::fs::write(tmp.join(name), bytes)?;
    }
    std::fs::write(tmp.join("contents.sha256"), contents_sha256(&files))?;
    std::fs::write(
        tmp.join("key.json"),
        serde_json::to_string_pretty(&key_json(engine, scene)).expect("keys serialise"),
    )?;
    // An entry here that cannot be loaded (cut, altered) is replaced.
    if entry.is_dir() && load(entry, engine).is_none() {
        let _ = std::fs::remove_dir_all(entry);
    }
    match std::fs::rename(&tmp, entry) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            if entry.is_dir() { Ok(()) } else { Err(e) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    const SCENE: &str =
        "name = \"k\"\nduration = 1.0\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 2.0\n";

    #[test]
    fn the_key_changes_with_scene_settings_and_engine_only() {
        let s = |o: &[String]| parse_scene_str(SCENE, false, "k.toml", o).unwrap();
        let base = run_key("native", &s(&[]));
        assert_eq!(base, run_key("native", &s(&[])));
        assert_eq!(base.len(), 64);
        assert_ne!(base, run_key("housner", &s(&[])));
        assert_ne!(base, run_key("native", &s(&["native.dt=5e-4".into()])));
        assert_ne!(base, run_key("native", &s(&["initial.tilt=0.1".into()])));
        // A comment or the file name does not change what is run.
        let c = parse_scene_str(&format!("# note\n{SCENE}"), false, "other.toml", &[]).unwrap();
        assert_eq!(base, run_key("native", &c));
    }

    #[test]
    fn a_stored_run_is_served_back_identically() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path().join("cache");
        let scene = parse_scene_str(
            &SCENE.replace("[[blocks]]", "[initial]\ntilt = 0.1\n[[blocks]]"),
            false,
            "k.toml",
            &[],
        )
        .unwrap();
        let cache = RunCache::new(Some(dir.clone()));
        let first = cache.run("housner", &scene);
        assert_eq!(first.status, Status::Ok);
        assert!(!first.cached);
        let again = cache.run("housner", &scene);
        assert!(again.cached);
        assert_eq!(cache.stats(), crate::gates::CacheStats { hits: 1, runs: 1 });
        let (a, b) = (first.output.unwrap(), again.output.unwrap());
        assert_eq!(a.trajectory, b.trajectory);
        assert_eq!(a.exact_impacts, b.exact_impacts);
        assert_eq!(first.summary, again.summary);

        // A stored trajectory cut short, or with a value changed, is run again.
        let entry = dir.join(run_key("housner", &scene));
        let csv = entry.join("trajectory.csv");
        let text = std::fs::read_to_string(&csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let cut = lines[..lines.len() / 2].join("\n") + "\n";
        let mut fields: Vec<&str> = lines[3].split(',').collect();
        fields[1] = "nan";
        let nan = text.replacen(lines[3], &fields.join(","), 1);
        for (k, damaged) in [cut, nan].into_iter().enumerate() {
            assert_ne!(damaged, text);
            std::fs::write(&csv, damaged).unwrap();
            let r = cache.run("housner", &scene);
            assert!(!r.cached, "damage {k} was served from the cache");
            assert_eq!(r.output.unwrap().trajectory, b.trajectory);
            assert_eq!(std::fs::read_to_string(&csv).unwrap(), text, "not replaced");
        }
        // So is an entry whose exact impact instants or summary changed by one digit, or
        // whose seal is gone.
        let impacts = entry.join("exact_impacts.json");
        let stored = std::fs::read_to_string(&impacts).unwrap();
        let digit = stored
            .find(|c: char| c.is_ascii_digit() && c != '0')
            .unwrap();
        let mut changed = stored.clone();
        changed.replace_range(digit..digit + 1, "0");
        std::fs::write(&impacts, &changed).unwrap();
        let r = cache.run("housner", &scene);
        assert!(
            !r.cached,
            "a changed impact instant was served from the cache"
        );
        assert_eq!(r.output.unwrap().exact_impacts, b.exact_impacts);
        assert_eq!(std::fs::read_to_string(&impacts).unwrap(), stored);
        let summary = entry.join("summary.json");
        let stored = std::fs::read_to_string(&summary).unwrap();
        std::fs::write(&summary, stored.replacen("\"steps\": ", "\"steps\": 1", 1)).unwrap();
        assert!(
            !cache.run("housner", &scene).cached,
            "a changed summary was served"
        );
        // Replaced by the new run's (its wall time aside).
        let without_wall = |text: &str| {
            let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
            v.as_object_mut().unwrap().remove("wall_time_s");
            v
        };
        let now = std::fs::read_to_string(&summary).unwrap();
        assert_eq!(without_wall(&now), without_wall(&stored));
        std::fs::remove_file(entry.join("contents.sha256")).unwrap();
        assert!(
            !cache.run("housner", &scene).cached,
            "an unsealed entry was served"
        );
        assert!(cache.run("housner", &scene).cached);
    }
}
