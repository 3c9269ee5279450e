//! Checkpoint reader on arbitrary bytes: a checkpoint of this build for the scene, or one error
//! line naming the file, never a panic. An odd first byte seals the rest as the checkpoint
//! (a file whose SHA-256 holds), so that the reader of the checkpoint inside is reached too.
//! The seeds (fuzz/seeds/checkpoint: `file`, the byte 0 and a checkpoint file; `sealed-content`,
//! the byte 1 and the CBOR sealed in that file) are a run's checkpoint written by an earlier
//! build: refused as another build's, they give the fuzzer the format. When the format changes
//! (tests/fuzz_regressions.rs says so), write them again from
//! `rockbench run fuzz/seeds/scene_toml/two-block-free-rocking.toml --checkpoint run.ckpt
//! --stop-after-step 3 --out o`.
#![no_main]

mod fixture;

use libfuzzer_sys::fuzz_target;
use rockbench::native::checkpoint::{Checkpoint, seal};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let file = if mode % 2 == 1 {
        seal(rest.to_vec())
    } else {
        rest.to_vec()
    };
    let path = fixture::input(fixture::folder(), "fuzzed.ckpt", &file);
    match Checkpoint::read(&path, fixture::SCENE) {
        Ok(c) => assert_eq!(c.scene, fixture::SCENE),
        Err(e) => {
            assert!(!e.contains('\n'), "multi-line error: {e}");
            assert!(
                e.starts_with(&format!("{}: ", path.display())),
                "names another file: {e}"
            );
        }
    }
});
