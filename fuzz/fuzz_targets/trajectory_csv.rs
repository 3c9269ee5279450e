//! Trajectory CSV reader on arbitrary text: a trajectory that writes back to itself, or an
//! error line, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rockbench::trajectory::Trajectory;

/// The same value as written and read back: bit for bit, a NaN for a NaN (its sign and
/// payload are not kept by the text).
fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Trajectory::parse_csv(&text) {
        Ok(tr) => {
            assert!(!tr.t.is_empty() && !tr.blocks.is_empty());
            for b in &tr.blocks {
                for c in [&b.x, &b.z, &b.phi, &b.vx, &b.vz, &b.omega] {
                    assert_eq!(c.len(), tr.t.len(), "block {}", b.name);
                }
            }
            let mut out = Vec::new();
            tr.write_csv_to(&mut out).expect("written to memory");
            let back = Trajectory::parse_csv(std::str::from_utf8(&out).expect("UTF-8"))
                .unwrap_or_else(|e| panic!("its own output refused: {e}"));
            assert_eq!(back.t.len(), tr.t.len());
            let names =
                |t: &Trajectory| t.blocks.iter().map(|b| b.name.clone()).collect::<Vec<_>>();
            assert_eq!(names(&back), names(&tr));
            let values = |t: &Trajectory| {
                let mut v = t.t.clone();
                for b in &t.blocks {
                    for c in [&b.x, &b.z, &b.phi, &b.vx, &b.vz, &b.omega] {
                        v.extend_from_slice(c);
                    }
                }
                v
            };
            assert!(
                values(&back)
                    .iter()
                    .zip(&values(&tr))
                    .all(|(a, b)| same(*a, *b))
            );
        }
        Err(e) => assert!(!e.contains('\n'), "multi-line error: {e}"),
    }
});
