//! Gate file reader on arbitrary text, beside a scene and a suite of two records: checked
//! gates, or one error line naming a file of the folder (the input or one it includes), never
//! a panic.
#![no_main]

mod fixture;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = fixture::input(fixture::folder(), "fuzzed-gates.toml", data);
    match rockbench::gates::load_gates(&path) {
        Ok(gates) => {
            assert!(!gates.is_empty());
            for (k, g) in gates.iter().enumerate() {
                assert!(!g.name.trim().is_empty(), "gate {k} unnamed");
                assert!(
                    g.tolerance.is_finite() && g.tolerance >= 0.0,
                    "gate {}",
                    g.name
                );
                assert!(
                    gates[..k].iter().all(|o| o.name.trim() != g.name.trim()),
                    "{} twice",
                    g.name
                );
            }
        }
        Err(e) => {
            assert!(!e.to_string().contains('\n'), "multi-line error: {e}");
            assert!(
                e.file.starts_with(&fixture::folder().display().to_string()),
                "names another file: {e}"
            );
        }
    }
});
