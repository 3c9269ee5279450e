//! Two-column CSV reader on arbitrary text: samples or an error line, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match rockbench::excitation::records::parse_two_column(
        &text,
        rockbench::excitation::records::Quantity::Acceleration,
    ) {
        Ok(s) => {
            assert_eq!(s.t.len(), s.v.len());
            assert!(s.t.len() >= 2);
            assert!(s.t.windows(2).all(|w| w[1] > w[0]), "times must increase");
            assert!(s.t.iter().chain(&s.v).all(|x| x.is_finite()));
        }
        Err(e) => assert!(!e.contains('\n'), "multi-line error: {e}"),
    }
});
