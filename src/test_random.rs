//! Reproducible pseudo-random numbers for unit tests: Knuth's MMIX linear congruential
//! generator, its top 53 bits as a double.

/// Uniform on `[0, 1)`, the same sequence for the same seed on every machine.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed;
    move || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Uniform on `[-1, 1)`: `2 u - 1` for `u` of [`uniform`] (exact: a power-of-two scaling).
pub(crate) fn signed(seed: u64) -> impl FnMut() -> f64 {
    let mut u = uniform(seed);
    move || 2.0 * u() - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sequences_stay_in_their_intervals_and_repeat_for_a_seed() {
        let (mut a, mut b, mut s) = (uniform(3), uniform(3), signed(3));
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for _ in 0..10_000 {
            let (x, y, z) = (a(), b(), s());
            assert_eq!(x, y);
            assert!((0.0..1.0).contains(&x));
            assert_eq!(z, 2.0 * x - 1.0);
            lo = lo.min(x);
            hi = hi.max(x);
        }
        assert!(lo < 1e-3 && hi > 1.0 - 1e-3, "[{lo}, {hi}]");
    }
}
