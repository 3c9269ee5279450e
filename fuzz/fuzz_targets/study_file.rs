//! Fragility study reader on arbitrary text, beside a scene and a suite of two records: a
//! checked study, or one error line naming the study file, never a panic.
#![no_main]

mod fixture;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = fixture::input(fixture::folder(), "fuzzed-study.toml", data);
    match rockbench::fragility::study::load_study(&path) {
        Ok(s) => {
            assert!(!s.scenes.is_empty() && !s.file.engines.is_empty());
            assert!(!s.suite.records.is_empty() && !s.limit_states.is_empty());
            let levels = &s.file.intensity.levels;
            assert!(!levels.is_empty() && levels.iter().all(|l| l.is_finite() && *l > 0.0));
            assert!(s.file.tail.is_finite() && s.file.tail >= 0.0);
        }
        Err(e) => fixture::assert_one_line_naming(&path, &e.file, &e.to_string()),
    }
});
