//! Suite manifest reader on arbitrary text, beside a CSV and an AT2 record: a suite of checked
//! records, or one error line naming the manifest, never a panic.
#![no_main]

mod fixture;

use libfuzzer_sys::fuzz_target;
use std::collections::BTreeSet;

fuzz_target!(|data: &[u8]| {
    let path = fixture::input(fixture::folder(), "fuzzed-suite.toml", data);
    match rockbench::excitation::suite::load_suite(&path) {
        Ok(s) => {
            assert!(!s.records.is_empty());
            let ids: BTreeSet<&str> = s.records.iter().map(|r| r.id.trim()).collect();
            assert_eq!(ids.len(), s.records.len(), "ids repeated");
            for r in &s.records {
                assert!(!r.id.trim().is_empty());
                assert!(
                    r.npts >= 2 && r.dt > 0.0 && r.dt.is_finite(),
                    "record {}",
                    r.id
                );
                assert!(r.pga > 0.0 && r.pga.is_finite(), "record {}", r.id);
                assert!(r.pgv >= 0.0 && r.pgv.is_finite(), "record {}", r.id);
                assert!(
                    r.duration > 0.0 && r.duration.is_finite(),
                    "record {}",
                    r.id
                );
                assert_eq!(r.sha256.len(), 64);
            }
        }
        Err(e) => fixture::assert_one_line_naming(&path, &e.file, &e.to_string()),
    }
});
