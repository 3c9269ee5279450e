//! A content-addressed store of run results: each entry is one JSON file named by the SHA-256
//! of what produced it (the run's inputs and the program that ran it), written whole or not at
//! all, and sealed with the SHA-256 of its own text, `{"sha256":"...","entry":ENTRY}`: an entry
//! whose bytes changed on the disk is no entry (the run is made again), never a result read
//! with a changed number. Fragility studies, spectra and stability maps keep their runs in one,
//! so that an interrupted study resumes where it stopped and an unchanged one costs nothing.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The running program's identity in keys: the source's content (the package's `src/` as
/// compiled, [`crate::build_info::SOURCE_HASH`]), so a changed engine never reuses an old
/// result.
pub fn program_id() -> &'static str {
    crate::build_info::SOURCE_HASH
}

/// The Python workers' sources (MuJoCo's and PyBullet's worker and Siconos' own) for the
/// engines they run, so a changed worker never reuses an old result; `None` for the engines of
/// this program. Hashed where the package's sources are, as the program starts (an edited
/// worker in a checkout, installed for development, runs as edited), else as compiled
/// (`RB_WORKER_HASH`).
pub fn worker_id(engine: &str) -> Option<&'static str> {
    static NOW: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ["mujoco", "pybullet", "siconos"]
        .contains(&engine)
        .then(|| {
            NOW.get_or_init(|| worker_hash_at(Path::new(env!("CARGO_MANIFEST_DIR"))))
                .as_str()
        })
}

/// The workers' sources' hash under the package directory `root`, or the compiled one where
/// `root` holds none.
fn worker_hash_at(root: &Path) -> String {
    use crate::worker_sources::{WORKER_FILES, fnv, worker_files};
    if root.join(WORKER_FILES[0]).is_file() {
        fnv(root, worker_files(root))
    } else {
        env!("RB_WORKER_HASH").to_string()
    }
}

/// The key of the result of `inputs` (everything that decides it, as JSON) run by this program
/// with `engine`'s worker and interpreter: the SHA-256 of them all, in hexadecimal.
pub fn key(engine: &str, inputs: serde_json::Value) -> String {
    let key = serde_json::json!({
        "inputs": inputs,
        "engine": engine,
        "rockbench": env!("CARGO_PKG_VERSION"),
        "build": program_id(),
        "worker": worker_id(engine),
        "python": crate::engines::external::interpreter_id(engine),
    });
    let text = serde_json::to_string(&key).expect("keys serialise");
    crate::digest::sha256_hex(text.as_bytes())
}

/// Whether `key` is a content hash: 64 hexadecimal digits.
pub fn is_key(key: &str) -> bool {
    key.len() == 64 && key.bytes().all(|b| b.is_ascii_hexdigit())
}

/// Where the entry of `key` ([`is_key`]) is kept in the store `dir`.
pub fn entry_path(dir: &Path, key: &str) -> PathBuf {
    dir.join(&key[..2]).join(format!("{key}.json"))
}

/// What comes before an entry's SHA-256 in its file, and between that and the entry.
const SEAL_HEAD: &str = "{\"sha256\":\"";
const SEAL_MIDDLE: &str = "\",\"entry\":";

/// The file's text of an entry's JSON text `entry`: the entry sealed with its SHA-256.
pub fn seal(entry: &str) -> String {
    format!(
        "{SEAL_HEAD}{}{SEAL_MIDDLE}{entry}}}",
        crate::digest::sha256_hex(entry.as_bytes())
    )
}

/// The entry's JSON text in a file's `text`, if it is sealed and its SHA-256 is the seal's.
fn unseal(text: &str) -> Option<&str> {
    let rest = text.strip_prefix(SEAL_HEAD)?;
    let (sha256, rest) = (rest.get(..64)?, rest.get(64..)?);
    let entry = rest.strip_prefix(SEAL_MIDDLE)?.strip_suffix('}')?;
    (crate::digest::sha256_hex(entry.as_bytes()) == sha256).then_some(entry)
}

/// The entry of `key`, if the store has a whole, undamaged one that reads as a `T` (none for a
/// string that is not a key).
pub fn load<T: DeserializeOwned>(dir: &Path, key: &str) -> Option<T> {
    if !is_key(key) {
        return None;
    }
    let text = std::fs::read_to_string(entry_path(dir, key)).ok()?;
    serde_json::from_str::<T>(unseal(&text)?).ok()
}

/// Store an entry: written to a temporary file unique to this process and thread, then renamed
/// over the entry. Renames are atomic: readers (other threads, processes or machines sharing the
/// folder) see no entry or a whole one, and two writers of the same run (the same content, as
/// runs are deterministic) leave one entry.
pub fn store<T: Serialize>(dir: &Path, key: &str, entry: &T) -> Result<(), String> {
    static SEQ: AtomicUsize = AtomicUsize::new(0);
    if !is_key(key) {
        return Err(format!("`{key}` is not a content hash"));
    }
    let path = entry_path(dir, key);
    let parent = path.parent().expect("entries are in a sub-folder");
    std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    // The host name tells apart writers on machines sharing the folder; only the characters
    // a file name can hold are kept.
    let host: String = std::env::var("HOSTNAME")
        .unwrap_or_default()
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_'))
        .collect();
    let tmp = path.with_extension(format!(
        "tmp-{host}-{}-{}",
        std::process::id(),
        SEQ.fetch_add(1, Ordering::Relaxed)
    ));
    let text = seal(&serde_json::to_string(entry).expect("entries serialise"));
    std::fs::write(&tmp, text).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: {e}", path.display())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The workers' hash is that of their files as they are: the compiled one while they are
    /// unchanged, another once one is edited (a copy of the package's worker files edited),
    /// and the compiled one where no sources are.
    #[test]
    fn the_workers_hash_follows_their_files() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(worker_hash_at(root), env!("RB_WORKER_HASH"));
        let copy = tempfile::tempdir().unwrap();
        for f in crate::worker_sources::worker_files(root) {
            std::fs::create_dir_all(copy.path().join(&f).parent().unwrap()).unwrap();
            std::fs::copy(root.join(&f), copy.path().join(&f)).unwrap();
        }
        assert_eq!(worker_hash_at(copy.path()), env!("RB_WORKER_HASH"));
        let engine = copy
            .path()
            .join("python/rockbench/engines/mujoco_engine.py");
        let mut text = std::fs::read_to_string(&engine).unwrap();
        text.push_str("\n# edited\n");
        std::fs::write(&engine, text).unwrap();
        assert_ne!(worker_hash_at(copy.path()), env!("RB_WORKER_HASH"));
        let empty = tempfile::tempdir().unwrap();
        assert_eq!(worker_hash_at(empty.path()), env!("RB_WORKER_HASH"));
    }

    #[test]
    fn an_entry_is_read_back_whole_and_a_changed_input_has_another_key() {
        let dir = std::env::temp_dir().join(format!("rb-run-store-{}", std::process::id()));
        let k = key(
            "native",
            serde_json::json!({"scene": "a", "amplitude": 1.5}),
        );
        assert!(is_key(&k));
        assert_ne!(
            k,
            key(
                "native",
                serde_json::json!({"scene": "a", "amplitude": 1.6})
            )
        );
        assert_ne!(
            k,
            key(
                "rapier",
                serde_json::json!({"scene": "a", "amplitude": 1.5})
            )
        );
        assert_eq!(load::<Vec<f64>>(&dir, &k), None);
        store(&dir, &k, &vec![1.0, 2.5]).unwrap();
        assert_eq!(load::<Vec<f64>>(&dir, &k), Some(vec![1.0, 2.5]));
        // An entry that does not read as the type asked for is no entry.
        assert_eq!(load::<String>(&dir, &k), None);
        // The file is the entry sealed with its SHA-256, itself JSON.
        let text = std::fs::read_to_string(entry_path(&dir, &k)).unwrap();
        let sealed: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(sealed["entry"], serde_json::json!([1.0, 2.5]));
        assert_eq!(sealed["sha256"], crate::digest::sha256_hex(b"[1.0,2.5]"));
        // A number changed on the disk (2.5 -> 2.4), with or without its seal, is no entry.
        std::fs::write(entry_path(&dir, &k), text.replace("2.5", "2.4")).unwrap();
        assert_eq!(load::<Vec<f64>>(&dir, &k), None);
        std::fs::write(entry_path(&dir, &k), "[1.0,2.4]").unwrap();
        assert_eq!(load::<Vec<f64>>(&dir, &k), None);
        // A truncated entry is no entry.
        std::fs::write(entry_path(&dir, &k), &text[..text.len() - 2]).unwrap();
        assert_eq!(load::<Vec<f64>>(&dir, &k), None);
        std::fs::write(entry_path(&dir, &k), &text).unwrap();
        assert_eq!(load::<Vec<f64>>(&dir, &k), Some(vec![1.0, 2.5]));
        assert!(store(&dir, "../escape", &1).is_err());
        assert_eq!(load::<i32>(&dir, "../escape"), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
