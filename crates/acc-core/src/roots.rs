//! Roots of a real polynomial: the Aberth–Ehrlich simultaneous iteration.
//!
//! The delay margin's characteristic polynomial `P_d(z)` (degree `d + 2`, up to 18,
//! [`crate::delay`]) has mostly zero middle coefficients. The companion matrix of such a
//! polynomial can make an unshifted-restart Francis QR loop for ever: nalgebra 0.34's
//! `complex_eigenvalues` (its `Schur::new` sets no iteration limit) never returned on
//! `kp = 0.44695751216291235, ki = 1.6955463248368243, Km·Kc = 5.898629814432838,
//! 7 extra periods` (nalgebra issue #611 reports the same for a sparse companion matrix).
//! The iteration here always ends: after [`MAX_SWEEPS`] sweeps at most, and each sweep
//! is one pass over the roots.
//!
//! Aberth, *Iteration methods for finding all zeros of a polynomial simultaneously*,
//! Math. Comp. 27 (1973) 339–344; Ehrlich, Comm. ACM 10 (1967) 107–108. Each estimate
//! `z_k` moves by `w_k = N_k / (1 − N_k·Σ_{j≠k} 1/(z_k − z_j))` with the Newton step
//! `N_k = p(z_k)/p'(z_k)`: Newton's method on `p` with the other roots' poles removed,
//! cubically convergent at simple roots. The starting points lie on a circle of the
//! Fujiwara bound's radius, which encloses every root.

use nalgebra::Complex;

/// A complex root.
pub type Root = Complex<f64>;

/// Most sweeps over all roots before the iteration stops; simple roots converge in a few
/// tens, a double root (linear convergence) in about a hundred.
pub const MAX_SWEEPS: usize = 500;

/// Relative step below which a root counts as converged.
const TOLERANCE: f64 = 1e-15;

/// The roots of `c[0]·z^n + c[1]·z^(n−1) + … + c[n]` (leading coefficient first), with
/// multiplicity; leading zero coefficients are dropped, trailing zeros are roots at 0.
/// Empty for a constant or a polynomial with a non-finite coefficient.
///
/// ```
/// use acc_core::roots::polynomial_roots;
/// // (z − 0.5)(z² + 0.25) = z³ − 0.5 z² + 0.25 z − 0.125
/// let r = polynomial_roots(&[1.0, -0.5, 0.25, -0.125]);
/// assert_eq!(r.len(), 3);
/// for z in &r {
///     let real = (z.re - 0.5).abs() < 1e-12 && z.im.abs() < 1e-12;
///     let imag = z.re.abs() < 1e-12 && (z.im.abs() - 0.5).abs() < 1e-12;
///     assert!(real || imag, "{z}");
/// }
/// ```
pub fn polynomial_roots(c: &[f64]) -> Vec<Root> {
    if c.iter().any(|x| !x.is_finite()) {
        return Vec::new();
    }
    let first = c.iter().position(|&x| x != 0.0).unwrap_or(c.len());
    let c = &c[first..];
    let zeros_at_origin = c.iter().rev().take_while(|&&x| x == 0.0).count();
    let c = &c[..c.len().saturating_sub(zeros_at_origin)];
    let mut roots = vec![Root::new(0.0, 0.0); zeros_at_origin];
    if c.len() < 2 {
        return roots;
    }
    // Monic, leading first.
    let a: Vec<f64> = c.iter().map(|x| x / c[0]).collect();
    let n = a.len() - 1;
    let mut z = starting_points(&a);
    for _ in 0..MAX_SWEEPS {
        let mut largest_step: f64 = 0.0;
        for k in 0..n {
            let (p, dp) = value_and_slope(&a, z[k]);
            if p == Root::new(0.0, 0.0) {
                continue;
            }
            let newton = p / dp;
            let repulsion: Root = (0..n)
                .filter(|&j| j != k)
                .map(|j| (z[k] - z[j]).inv())
                .sum();
            let w = newton / (Root::new(1.0, 0.0) - newton * repulsion);
            if w.re.is_finite() && w.im.is_finite() {
                z[k] -= w;
                largest_step = largest_step.max(w.norm() / z[k].norm().max(1.0));
            }
        }
        if largest_step <= TOLERANCE {
            break;
        }
    }
    roots.extend(z);
    roots
}

/// `p(z)` and `p'(z)` of the monic polynomial `a` (leading first) by Horner's scheme.
fn value_and_slope(a: &[f64], z: Root) -> (Root, Root) {
    let mut p = Root::new(a[0], 0.0);
    let mut dp = Root::new(0.0, 0.0);
    for &ai in &a[1..] {
        dp = dp * z + p;
        p = p * z + ai;
    }
    (p, dp)
}

/// `n` points on a circle of twice the Fujiwara bound `max_i |a_i|^(1/i)` (every root lies
/// within it), at angles offset from the real axis so that no start is real (the roots of
/// a real polynomial are symmetric about it and a real start could not leave it).
fn starting_points(a: &[f64]) -> Vec<Root> {
    let n = a.len() - 1;
    let radius = (1..=n)
        .map(|i| a[i].abs().powf(1.0 / i as f64))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE)
        * 2.0;
    (0..n)
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / n as f64 + 0.4;
            Root::from_polar(radius, angle)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Coefficients (leading first) of the monic polynomial with the given roots.
    fn from_roots(roots: &[Root]) -> Vec<f64> {
        let mut c = vec![Root::new(1.0, 0.0)];
        for &r in roots {
            let mut next = vec![Root::new(0.0, 0.0); c.len() + 1];
            for (i, &ci) in c.iter().enumerate() {
                next[i] += ci;
                next[i + 1] -= ci * r;
            }
            c = next;
        }
        c.iter().map(|x| x.re).collect()
    }

    /// Every expected root has a found root within `tol`, one to one.
    fn matches(found: &[Root], expected: &[Root], tol: f64) -> bool {
        let mut left: Vec<Root> = found.to_vec();
        expected.iter().all(|e| {
            let best = left
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1 - e).norm().total_cmp(&(b.1 - e).norm()));
            match best {
                Some((i, f)) if (f - e).norm() <= tol => {
                    left.swap_remove(i);
                    true
                }
                _ => false,
            }
        })
    }

    #[test]
    fn the_companion_matrix_that_hung_nalgebra_has_its_roots_found() {
        // P_7(z) of the delay module at the inputs on which nalgebra's Schur never ended.
        let (kp, ki, g, t) = (
            0.446_957_512_162_912_35,
            1.695_546_324_836_824_3,
            5.898_629_814_432_838,
            0.1,
        );
        let mut c = vec![0.0; 10];
        c[0] = 1.0;
        c[1] = -1.0;
        c[8] += g * (kp + ki * t);
        c[9] -= g * kp;
        let r = polynomial_roots(&c);
        assert_eq!(r.len(), 9);
        for z in &r {
            let (p, _) = value_and_slope(&c, *z);
            assert!(p.norm() < 1e-9, "|P({z})| = {}", p.norm());
        }
    }

    #[test]
    fn zeros_and_degenerate_input() {
        assert!(polynomial_roots(&[]).is_empty());
        assert!(polynomial_roots(&[3.0]).is_empty());
        assert!(polynomial_roots(&[1.0, f64::NAN]).is_empty());
        let r = polynomial_roots(&[0.0, 2.0, -1.0, 0.0, 0.0]);
        assert_eq!(r.len(), 3);
        assert_eq!(r.iter().filter(|z| z.norm() == 0.0).count(), 2);
        assert!(r.iter().any(|z| (z - Root::new(0.5, 0.0)).norm() < 1e-14));
        // A root of multiplicity 3 (linear convergence) still to 1e-5.
        let r = polynomial_roots(&[1.0, -2.7, 2.43, -0.729]);
        assert!(matches(&r, &[Root::new(0.9, 0.0); 3], 1e-4), "{r:?}");
    }

    proptest! {
        /// Polynomials built from known roots (real ones and conjugate pairs inside radius
        /// 2, up to degree 12) give those roots back, each with a backward error (`|p(z)|`
        /// against `Σ|a_i|·|z|^(n−i)`) at the rounding of the coefficients.
        #[test]
        fn built_roots_come_back(
            reals in proptest::collection::vec(-2.0f64..2.0, 1..5),
            pairs in proptest::collection::vec((0.05f64..2.0, 0.1f64..3.0), 0..5),
        ) {
            let mut roots: Vec<Root> = reals.iter().map(|&x| Root::new(x, 0.0)).collect();
            for &(r, a) in &pairs {
                roots.push(Root::from_polar(r, a));
                roots.push(Root::from_polar(r, -a));
            }
            // Clustered roots are ill-conditioned: ask for accuracy relative to the
            // closest pair's separation.
            let sep = roots.iter().enumerate().flat_map(|(i, a)| {
                roots[i + 1..].iter().map(move |b| (a - b).norm())
            }).fold(f64::INFINITY, f64::min);
            prop_assume!(sep > 0.1);
            let c = from_roots(&roots);
            let found = polynomial_roots(&c);
            prop_assert_eq!(found.len(), roots.len());
            for z in &found {
                let (p, _) = value_and_slope(&c, *z);
                let size: f64 = c.iter().rev().enumerate()
                    .map(|(i, a)| a.abs() * z.norm().powi(i as i32)).sum();
                prop_assert!(p.norm() <= 1e-12 * size, "backward error {} at {}", p.norm() / size, z);
            }
            prop_assert!(matches(&found, &roots, 1e-6), "{:?} vs {:?}", found, roots);
        }
    }
}
