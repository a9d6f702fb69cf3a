//! Delay margin of the PI loop: how many extra periods of pure dead time between the
//! override command and the force it causes the closed loop tolerates.
//!
//! The design model (physics.md §1, eq. 6) has the force of period k answer the feed
//! commanded one period earlier: `F[k] = g·U[k−1]`, `g = Km·Kc`. A line that delivers the
//! board's replies `d` periods late (a buffering gateway, a slow converter) makes it
//! `F[k] = g·U[k−1−d]`. With the incremental PI law (eq. 4)
//! `U[k] − U[k−1] = Kp·(E[k] − E[k−1]) + Ki·T·E[k]`, `E = Fr − F`, the characteristic
//! polynomial becomes
//!
//! ```text
//! P_d(z) = z^(d+2) − z^(d+1) + g·(Kp + Ki·T)·z − g·Kp
//! ```
//!
//! (`d = 0` is the polynomial of [`crate::stability`]). For adaptive gains placed at poles
//! `z1, z2` on `Kc_hat = Kc`, `g·(Kp + Ki·T) = 1 − (z1 + z2)` and `g·Kp = −z1·z2`, so the
//! margin depends only on the poles: paper case III (0.001/−0.001, practically a dead-beat
//! integrator) tolerates no extra period at all (`z³ − z² + z` has roots on the unit
//! circle), case I (0.2/−0.05) tolerates one (largest pole 0.92), case II (0.1/−0.6) none.
//!
//! "Stable" here means every pole inside [`DECAY_RADIUS`] = 0.95, not merely inside the unit
//! circle. Stability is decided by the Schur–Cohn step-down recursion on a fixed-size array (no
//! allocation, so the runtime may call it every period); the tests cross-check it against
//! the polynomial's roots ([`delay_poles`]).
//!
//! ```
//! use acc_core::delay::{delay_margin_periods, stable_with_delay};
//! // Case III gains at Kc_hat = Kc (g = 1): Kp·g = 1e-6, Ki·T·g = 1 − 1e-6.
//! let (g, kp, ki, t) = (1.0, 1e-6, (1.0 - 1e-6) / 0.1, 0.1);
//! assert!(stable_with_delay(kp, ki, g, t, 0));
//! assert!(!stable_with_delay(kp, ki, g, t, 1));
//! assert_eq!(delay_margin_periods(kp, ki, g, t), Some(0));
//! ```

/// Largest pole magnitude a loop may have to count as stable here: every mode must decay
/// by at least 5 % per period (a mode at 0.95 halves in 14 periods, 1.4 s at T = 0.1 s). A
/// loop merely inside the unit circle can ring for seconds: case III with one extra
/// period has poles at 0.99999…, an oscillation that never settles in practice.
pub const DECAY_RADIUS: f64 = 0.95;

/// Largest extra delay, periods, the functions here examine.
pub const MAX_EXTRA_DELAY: u32 = 16;

const N: usize = MAX_EXTRA_DELAY as usize + 3;

/// Coefficients (leading first) of `P_d(z)` in a fixed array; the first `d + 3` entries are
/// used.
fn coefficients(kp: f64, ki: f64, km_kc: f64, period_s: f64, extra: u32) -> ([f64; N], usize) {
    coefficients_scaled(kp, ki, km_kc, period_s, extra, 1.0)
}

/// The coefficients of `P_d(ρ·w)/ρ^deg`: its roots are those of `P_d` divided by `ρ`.
fn coefficients_scaled(
    kp: f64,
    ki: f64,
    km_kc: f64,
    period_s: f64,
    extra: u32,
    rho: f64,
) -> ([f64; N], usize) {
    let d = extra.min(MAX_EXTRA_DELAY) as usize;
    let mut c = [0.0; N];
    let deg = d + 2;
    c[0] = 1.0;
    c[1] = -1.0;
    c[deg - 1] += km_kc * (kp + ki * period_s);
    c[deg] += -km_kc * kp;
    let mut scale = 1.0;
    for x in c.iter_mut().take(deg + 1) {
        *x /= scale;
        scale *= rho;
    }
    (c, deg)
}

/// Whether all roots of the polynomial `c[0]·z^deg + … + c[deg]` lie strictly inside the
/// unit circle (Schur–Cohn step-down; `c[0] ≠ 0`).
fn schur_stable(mut c: [f64; N], mut deg: usize) -> bool {
    if !c.iter().take(deg + 1).all(|x| x.is_finite()) || c[0] == 0.0 {
        return false;
    }
    while deg > 0 {
        let lead = c[0];
        for x in c.iter_mut().take(deg + 1) {
            *x /= lead;
        }
        let k = c[deg];
        if k.abs() >= 1.0 {
            return false;
        }
        let den = 1.0 - k * k;
        let mut next = [0.0; N];
        for i in 0..deg {
            next[i] = (c[i] - k * c[deg - i]) / den;
        }
        c = next;
        deg -= 1;
    }
    true
}

/// Whether the PI loop with gains `kp` ((mm/min)/N), `ki` ((mm/min)/(N·s)), plant gain
/// `km_kc` (Km·Kc, N/(mm/min)) and period `period_s` (s) is stable, every pole inside
/// [`DECAY_RADIUS`], with `extra` periods of dead time beyond the model's one (at most
/// [`MAX_EXTRA_DELAY`]). Non-finite inputs are not stable.
pub fn stable_with_delay(kp: f64, ki: f64, km_kc: f64, period_s: f64, extra: u32) -> bool {
    let (c, deg) = coefficients_scaled(kp, ki, km_kc, period_s, extra, DECAY_RADIUS);
    schur_stable(c, deg)
}

/// The delay margin: the largest number of extra periods of dead time (0 ..=
/// [`MAX_EXTRA_DELAY`]) with which the loop is still stable in the sense of
/// [`stable_with_delay`], scanning up from 0; `None` when it is not even without extra
/// delay.
pub fn delay_margin_periods(kp: f64, ki: f64, km_kc: f64, period_s: f64) -> Option<u32> {
    if !stable_with_delay(kp, ki, km_kc, period_s, 0) {
        return None;
    }
    let mut margin = 0;
    for d in 1..=MAX_EXTRA_DELAY {
        if !stable_with_delay(kp, ki, km_kc, period_s, d) {
            break;
        }
        margin = d;
    }
    Some(margin)
}

/// Roots of `P_d(z)` ([`crate::roots::polynomial_roots`], an iteration that always ends;
/// a QR iteration on the companion matrix of this sparse polynomial can loop for ever).
/// For the tables of `acc stability` and for cross-checking [`stable_with_delay`];
/// allocates.
pub fn delay_poles(
    kp: f64,
    ki: f64,
    km_kc: f64,
    period_s: f64,
    extra: u32,
) -> Vec<crate::stability::Pole> {
    let (c, deg) = coefficients(kp, ki, km_kc, period_s, extra);
    crate::roots::polynomial_roots(&c[..=deg])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stability::{pi_poles, spectral_radius};
    use proptest::prelude::*;

    #[test]
    fn no_extra_delay_is_the_pi_loop_of_the_stability_module() {
        for (kp, ki, g) in [(0.05, 2.5, 4.0), (0.05, 2.5, 6.0), (0.01, 1.0, 3.0)] {
            let a = spectral_radius(&pi_poles(kp, ki, g, 0.1));
            let b = spectral_radius(&delay_poles(kp, ki, g, 0.1, 0));
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
            assert_eq!(stable_with_delay(kp, ki, g, 0.1, 0), a < DECAY_RADIUS);
        }
    }

    #[test]
    fn paper_cases_margins() {
        // Adaptive gains at Kc_hat = Kc: g·Kp = −z1·z2, g·Ki·T = 1 − (z1+z2) + z1·z2.
        let margin = |z1: f64, z2: f64| {
            let (s, p) = (z1 + z2, z1 * z2);
            delay_margin_periods(-p, (1.0 - s + p) / 0.1, 1.0, 0.1)
        };
        assert_eq!(margin(0.001, -0.001), Some(0), "case III");
        assert_eq!(margin(0.2, -0.05), Some(1), "case I");
        assert_eq!(margin(0.1, -0.6), Some(0), "case II");
        // A slow integrator tolerates several periods.
        assert!(margin(0.8, 0.0).unwrap() >= 3);
    }

    #[test]
    fn the_poles_are_found_where_a_companion_qr_never_ended() {
        // nalgebra 0.34's `complex_eigenvalues` looped for ever on these inputs (found by
        // this module's property test, which then hung the suite).
        let (kp, ki, g) = (
            0.446_957_512_162_912_35,
            1.695_546_324_836_824_3,
            5.898_629_814_432_838,
        );
        let poles = delay_poles(kp, ki, g, 0.1, 7);
        assert_eq!(poles.len(), 9);
        let r = spectral_radius(&poles);
        assert_eq!(
            stable_with_delay(kp, ki, g, 0.1, 7),
            r < DECAY_RADIUS,
            "radius {r}"
        );
    }

    proptest! {
        #[test]
        fn schur_cohn_agrees_with_the_roots(
            kp in -0.5f64..0.5,
            ki in 0.01f64..20.0,
            g in 0.01f64..10.0,
            extra in 0u32..8,
        ) {
            let r = spectral_radius(&delay_poles(kp, ki, g, 0.1, extra));
            // Away from the boundary the two must agree.
            prop_assume!((r - DECAY_RADIUS).abs() > 1e-6);
            prop_assert_eq!(stable_with_delay(kp, ki, g, 0.1, extra), r < DECAY_RADIUS);
        }

        #[test]
        fn the_margin_is_the_last_stable_delay(
            z1 in -0.9f64..0.9,
            z2 in -0.9f64..0.9,
        ) {
            let (s, p) = (z1 + z2, z1 * z2);
            let (kp, ki) = (-p, (1.0 - s + p) / 0.1);
            let m = delay_margin_periods(kp, ki, 1.0, 0.1)
                .expect("poles placed inside 0.9 are inside the decay radius");
            for d in 0..=m {
                prop_assert!(stable_with_delay(kp, ki, 1.0, 0.1, d));
            }
            if m < MAX_EXTRA_DELAY {
                prop_assert!(!stable_with_delay(kp, ki, 1.0, 0.1, m + 1));
            }
        }
    }
}
