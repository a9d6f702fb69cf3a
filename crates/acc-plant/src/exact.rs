//! Cheaper forms of a few floating-point operations on the simulator's per-sample paths that
//! return **bit for bit** what the plain operation returns (the run log must not change):
//! each takes a fast path only where its result is provably identical and falls back to
//! the plain operation otherwise. See the tests for the edge cases.

use std::f64::consts::TAU;

/// `x % (2π)` (`fmod`, the angle wrap of the simulator's phase accumulators).
///
/// For `0 ≤ x < 2π` the remainder is `x` itself; for `2π ≤ x < 4π` it is `x − 2π`, which
/// the subtraction computes exactly (Sterbenz: `y/2 ≤ x ≤ 2y`). Anything else (negative,
/// larger, NaN) goes to `%`.
#[inline]
pub(crate) fn rem_tau(x: f64) -> f64 {
    if (0.0..TAU).contains(&x) {
        x
    } else if (TAU..2.0 * TAU).contains(&x) {
        x - TAU
    } else {
        x % TAU
    }
}

/// `x.round()` (ties away from zero) without the library call for `|x| < 2⁵²`.
///
/// `t = trunc(x)` through the integer conversion is exact there, `x − t` is exact (the
/// fractional bits of `x`), `t ± 1` is exact, and the sign of a zero result is `x`'s, as
/// `round` gives it (`round(−0.3) = −0.0`).
#[inline]
pub(crate) fn round(x: f64) -> f64 {
    const LIMIT: f64 = 4_503_599_627_370_496.0; // 2^52
    if x.abs() < LIMIT {
        let t = x as i64 as f64;
        let d = x - t;
        let r = if d >= 0.5 {
            t + 1.0
        } else if d <= -0.5 {
            t - 1.0
        } else {
            t
        };
        r.copysign(x)
    } else {
        x.round()
    }
}

/// `x.powf(e)` remembered for the last argument pair: the simulator raises slowly varying
/// quantities (speed, engaged depth, feed in steady state) to fixed exponents at every
/// internal step; an unchanged argument (bitwise) returns the remembered power. The
/// exponent 1 (the force law's usual depth and feed exponents) returns `x` itself, which
/// is what `powf` returns for it (IEEE 754 `pow(x, 1) = x`, NaN and signed zeros included).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PowMemo {
    last: Option<(u64, u64, f64)>,
}

impl PowMemo {
    /// `x.powf(e)`.
    #[inline]
    pub(crate) fn powf(&mut self, x: f64, e: f64) -> f64 {
        if e == 1.0 {
            return x;
        }
        let key = (x.to_bits(), e.to_bits());
        match self.last {
            Some((kx, ke, y)) if (kx, ke) == key => y,
            _ => {
                let y = x.powf(e);
                self.last = Some((key.0, key.1, y));
                y
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn edge_cases() -> Vec<f64> {
        let mut v = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
            0.5000000000000001,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9_007_199_254_740_993.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1e-310,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            TAU,
            -TAU,
            2.0 * TAU,
            TAU - f64::EPSILON,
            2.0 * TAU - 1e-15,
            3.0 * TAU,
            1e6,
            -1e6,
        ];
        for k in -10..10 {
            v.push(f64::from(k) + 0.5);
            v.push((f64::from(k) + 0.5).next_up());
            v.push((f64::from(k) + 0.5).next_down());
            v.push(TAU.next_up() * f64::from(k));
            v.push(TAU.next_down() * f64::from(k));
        }
        v
    }

    #[test]
    fn round_is_bit_identical() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut xs = edge_cases();
        for _ in 0..200_000 {
            let scale = 10f64.powi(rng.random_range(-3..17));
            xs.push(rng.random_range(-1.0..1.0) * scale);
            xs.push(f64::from_bits(rng.random::<u64>()));
        }
        for x in xs {
            assert!(
                same(round(x), x.round()),
                "{x:e}: {} vs {}",
                round(x),
                x.round()
            );
        }
    }

    #[test]
    fn rem_tau_is_bit_identical() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let mut xs = edge_cases();
        for _ in 0..200_000 {
            xs.push(rng.random_range(-1.0..5.0) * TAU);
            xs.push(rng.random_range(0.0..TAU) + rng.random_range(0.0..1.0));
            xs.push(f64::from_bits(rng.random::<u64>()));
        }
        for x in xs {
            assert!(same(rem_tau(x), x % TAU), "{x:e}");
        }
    }

    #[test]
    fn pow_memo_is_bit_identical() {
        let mut m = PowMemo::default();
        for (x, e) in [
            (2.0, 0.5),
            (2.0, 0.5),
            (2.0, 0.7),
            (3.0, 0.7),
            (-0.0, 0.5),
            (0.0, 0.5),
            (f64::NAN, 1.0),
            (f64::NAN, 1.0),
            (-0.0, 1.0),
            (f64::INFINITY, 1.0),
            (f64::NEG_INFINITY, 1.0),
        ] {
            assert!(same(m.powf(x, e), x.powf(e)));
        }
        // The exponent 1 over every magnitude and sign: x itself, as powf gives.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..100_000 {
            let x = f64::from_bits(rng.random::<u64>());
            assert!(same(m.powf(x, 1.0), x.powf(1.0)), "{x:e}");
        }
    }
}
