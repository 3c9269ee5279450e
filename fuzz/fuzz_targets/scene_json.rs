//! Scene parser and checks on arbitrary JSON text: every input gives a scene or a one-line
//! error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let is_json = true;
    // Format only.
    if let Err(e) = rockbench::scene::parse_scene_str(text, is_json, "fuzz", &[]) {
        assert!(!e.to_string().contains('\n'), "multi-line error: {e}");
    }
    // Format and every check (record files are looked up in an empty directory).
    let base = std::path::Path::new("/nonexistent-rockbench-fuzz");
    if let Err(e) = rockbench::engines::registry::check_scene_str(text, is_json, "fuzz", &[], base)
    {
        assert!(!e.to_string().contains('\n'), "multi-line error: {e}");
    }
});
