//! Small statistics helpers: AR(1) noise, effective sample size, correlation tests.
//!
//! Correlated noise is handled with the AR(1) effective sample size
//! `n_eff = n·(1 − ρ)/(1 + ρ)` (Bartlett 1946; von Storch & Zwiers, *Statistical Analysis
//! in Climate Research*, eq. 6.17), and for a correlation between two AR(1) series
//! `n_eff = n·(1 − ρx·ρy)/(1 + ρx·ρy)` (Bretherton et al. 1999, J. Climate 12, eq. 31).

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// Solve the 3×3 system `a·x = b` (Gaussian elimination, partial pivoting); `None` when
/// singular.
#[allow(clippy::needless_range_loop)]
pub fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    for c in 0..3 {
        let p = (c..3).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..3 {
            let f = a[r][c] / a[c][c];
            for k in c..3 {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; 3];
    for r in (0..3).rev() {
        let s: f64 = (r + 1..3).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// σ of the quantization of `y`: the smallest non-zero step between consecutive values
/// over √12.
pub fn quantization_sigma(y: &[f64]) -> f64 {
    let q = y
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-12)
        .fold(f64::INFINITY, f64::min);
    if q.is_finite() {
        q / 12f64.sqrt()
    } else {
        0.0
    }
}

/// Mean (0 for an empty slice).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

/// Root mean square (0 for an empty slice): [`acc_core::stats::rms`] on a slice.
pub fn rms(x: &[f64]) -> f64 {
    acc_core::stats::rms(x.iter().copied())
}

/// Lag-1 autocorrelation of `x` about its mean, clamped to [−0.95, 0.99].
pub fn lag1(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    let m = mean(x);
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..x.len() {
        let d = x[i] - m;
        den += d * d;
        if i > 0 {
            num += d * (x[i - 1] - m);
        }
    }
    if den <= 0.0 {
        0.0
    } else {
        (num / den).clamp(-0.95, 0.99)
    }
}

/// AR(1) effective sample size `n·(1 − ρ)/(1 + ρ)` for ρ ≥ 0 (ρ < 0 is treated as 0).
pub fn n_eff(n: usize, rho: f64) -> f64 {
    let r = rho.clamp(0.0, 0.99);
    (n as f64 * (1.0 - r) / (1.0 + r)).max(1.0)
}

/// Standard normal upper-tail probability `P(Z > z)`.
pub fn normal_sf(z: f64) -> f64 {
    Normal::standard().sf(z)
}

/// Standard normal quantile.
pub fn normal_quantile(p: f64) -> f64 {
    Normal::standard().inverse_cdf(p.clamp(1e-300, 1.0 - 1e-16))
}

/// Two-sided Student-t critical value for confidence `level` and `dof` degrees of freedom.
pub fn t_critical(level: f64, dof: f64) -> f64 {
    match StudentsT::new(0.0, 1.0, dof.max(1.0)) {
        Ok(t) => t.inverse_cdf(0.5 + level / 2.0),
        Err(_) => normal_quantile(0.5 + level / 2.0),
    }
}

/// Noise estimate: standard deviation and lag-1 correlation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Noise {
    /// Standard deviation, channel unit.
    pub sigma: f64,
    /// AR(1) lag-1 correlation.
    pub rho: f64,
    /// Number of samples used.
    pub samples: usize,
}

/// Pooled AR(1) noise from first differences of several stretches: for a stationary
/// AR(1) series `e`, `d_t = e_t − e_{t−1}` has variance `2σ²(1 − ρ)` and lag-1
/// autocorrelation `−(1 − ρ)/2`, so `ρ = 1 + 2·r_d` and `σ² = var(d) / (2(1 − ρ))`.
/// Differencing removes each stretch's level and almost all of a slow trend without the
/// downward bias of detrending short stretches (Kendall 1954). ρ is clamped to
/// [−0.9, 0.95].
pub fn pooled_noise_diff(stretches: &[&[f64]]) -> Noise {
    // Robust to spikes and steps the regimes did not catch: differences beyond 4.5 robust
    // σ (1.4826·MAD of all differences) are left out, and so is every pair touching one.
    let mut all: Vec<f64> = stretches
        .iter()
        .filter(|s| s.len() >= 4)
        .flat_map(|s| s.windows(2).map(|w| (w[1] - w[0]).abs()))
        .collect();
    let limit = if all.is_empty() {
        f64::INFINITY
    } else {
        let mid = all.len() / 2;
        let (_, m, _) = all.select_nth_unstable_by(mid, f64::total_cmp);
        let mad = *m;
        if mad > 0.0 {
            4.5 * 1.4826 * mad
        } else {
            f64::INFINITY
        }
    };
    let (mut s0, mut s1, mut nd, mut n1, mut count) = (0.0, 0.0, 0usize, 0usize, 0usize);
    for s in stretches {
        if s.len() < 4 {
            continue;
        }
        let d: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
        s0 += d
            .iter()
            .filter(|v| v.abs() <= limit)
            .map(|v| v * v)
            .sum::<f64>();
        nd += d.iter().filter(|v| v.abs() <= limit).count();
        for w in d.windows(2) {
            if w[0].abs() <= limit && w[1].abs() <= limit {
                s1 += w[0] * w[1];
                n1 += 1;
            }
        }
        count += s.len();
    }
    if nd == 0 || s0 <= 0.0 {
        return Noise {
            sigma: 0.0,
            rho: 0.0,
            samples: count,
        };
    }
    let v0 = s0 / nd as f64;
    let r_d = if n1 > 0 { s1 / n1 as f64 / v0 } else { 0.0 };
    let rho = (1.0 + 2.0 * r_d).clamp(-0.9, 0.95);
    Noise {
        sigma: (v0 / (2.0 * (1.0 - rho))).sqrt(),
        rho,
        samples: count,
    }
}

/// Lags over which [`pooled_noise_variogram`] averages the semivariogram, rows.
pub const PLATEAU_LAGS: std::ops::RangeInclusive<usize> = 4..=10;

/// Pooled noise from the semivariogram's plateau: `γ(k) = ½·E[(e_{t+k} − e_t)²]` within
/// each stretch, averaged over the lags [`PLATEAU_LAGS`], is `σ²(1 − ρ_k)` → `σ²` once the
/// lags are past the noise's correlation. Unlike the lag-1 AR(1) correction of
/// [`pooled_noise_diff`] it holds for noise that is coloured beyond AR(1) — the
/// spindle-power channel's residual wanders with a period of ≈ 8 rows (lag-4
/// autocorrelation ≈ −0.6, lag-8 ≈ +0.6), which the AR(1) estimate puts at ≈ 0.6× its
/// variance (docs/twin.md). Within each stretch differences remove its level; per lag,
/// differences beyond 4.5 robust σ (1.4826·MAD) are left out (spikes). The result is the
/// larger of this and [`pooled_noise_diff`]; ρ is `1 − γ(1)/σ²` (the lag-1 correlation
/// the segment tests use). Stretches shorter than 12 rows only enter the lag-1 estimate.
pub fn pooled_noise_variogram(stretches: &[&[f64]]) -> Noise {
    let base = pooled_noise_diff(stretches);
    let long: Vec<&[f64]> = stretches
        .iter()
        .copied()
        .filter(|s| s.len() >= 12)
        .collect();
    let mut gammas = Vec::new();
    let mut g1 = None;
    for k in std::iter::once(1).chain(PLATEAU_LAGS) {
        let mut d: Vec<f64> = long
            .iter()
            .flat_map(|s| (k..s.len()).map(move |i| s[i] - s[i - k]))
            .collect();
        if d.len() < 30 {
            continue;
        }
        let mut a: Vec<f64> = d.iter().map(|v| v.abs()).collect();
        let mid = a.len() / 2;
        let (_, m, _) = a.select_nth_unstable_by(mid, f64::total_cmp);
        let limit = if *m > 0.0 {
            4.5 * 1.4826 * *m
        } else {
            f64::INFINITY
        };
        d.retain(|v| v.abs() <= limit);
        if d.is_empty() {
            continue;
        }
        let g = 0.5 * d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64;
        if k == 1 {
            g1 = Some(g);
        } else {
            gammas.push(g);
        }
    }
    if gammas.is_empty() {
        return base;
    }
    let plateau = gammas.iter().sum::<f64>() / gammas.len() as f64;
    let s2 = plateau.max(base.sigma * base.sigma);
    if s2 <= 0.0 {
        return base;
    }
    let rho = g1.map_or(base.rho, |g| (1.0 - g / s2).clamp(-0.9, 0.95));
    Noise {
        sigma: s2.sqrt(),
        rho,
        samples: base.samples,
    }
}

/// Pearson correlation of `x` and `y` and its two-sided p-value, with the effective
/// sample size of two AR(1) series (Bretherton et al. 1999, eq. 31).
pub fn correlation(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len().min(y.len());
    if n < 5 {
        return (0.0, 1.0);
    }
    let (mx, my) = (mean(&x[..n]), mean(&y[..n]));
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (a, b) = (x[i] - mx, y[i] - my);
        sxy += a * b;
        sxx += a * a;
        syy += b * b;
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return (0.0, 1.0);
    }
    let r = sxy / (sxx * syy).sqrt();
    let rr = (lag1(&x[..n]) * lag1(&y[..n])).max(0.0);
    let ne = (n as f64 * (1.0 - rr) / (1.0 + rr)).max(3.0);
    let t = r * ((ne - 2.0) / (1.0 - r * r).max(1e-12)).sqrt();
    let p = match StudentsT::new(0.0, 1.0, ne - 2.0) {
        Ok(d) => 2.0 * d.sf(t.abs()),
        Err(_) => 2.0 * normal_sf(t.abs()),
    };
    (r, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn n_eff_shrinks_with_correlation() {
        assert_eq!(n_eff(100, 0.0), 100.0);
        assert!((n_eff(100, 0.5) - 100.0 / 3.0).abs() < 1e-9);
    }

    #[test]
    fn differenced_noise_recovers_ar1_parameters() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let e = crate::synth::ar1_noise(20_000, 8.0, 0.6, &mut rng);
        let chunks: Vec<&[f64]> = e.chunks(25).collect();
        let nz = pooled_noise_diff(&chunks);
        assert!((nz.sigma - 8.0).abs() < 0.4, "sigma {}", nz.sigma);
        assert!((nz.rho - 0.6).abs() < 0.05, "rho {}", nz.rho);
    }

    #[test]
    fn correlation_of_a_line_with_itself_is_one() {
        let x: Vec<f64> = (0..50).map(|i| (i as f64 * 0.7).sin()).collect();
        let (r, p) = correlation(&x, &x);
        assert!((r - 1.0).abs() < 1e-9 && p < 1e-6);
    }

    #[test]
    fn quantiles_match_tables() {
        assert!((normal_quantile(0.975) - 1.959964).abs() < 1e-5);
        assert!((t_critical(0.95, 10.0) - 2.228139).abs() < 1e-5);
    }
}
