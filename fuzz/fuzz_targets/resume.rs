//! A checkpoint of this build changed at arbitrary bytes and sealed anew (a file written again by
//! hand), resumed: the run's outputs or one error line, never a panic. Each input picks one of
//! two stopped runs (`fixture::stopped_runs`: the two-block statue and the toppling 42-block
//! wall, written before the first input) and lists the bytes changed in its checkpoint
//! (`fixture::resume_changed`).
#![no_main]

mod fixture;

use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The two runs to their checkpoints, once, before the inputs are timed.
    init: {
        fixture::stopped_runs(fixture::folder());
    },
    |data: &[u8]| {
        if let Err(e) = fixture::resume_changed(fixture::folder(), data) {
            assert!(!e.contains('\n'), "multi-line error: {e}");
        }
    }
);
