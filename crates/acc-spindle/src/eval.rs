//! Error metrics and the evaluations on real data used by `acc estimate-eval` and the
//! tests.
//!
//! * [`rms_error`], [`error_rate_pct`] (seed 000's "error rate": RMS error over the mean
//!   true force), [`mape_pct`];
//! * [`min_median_max`] of a list of errors (the turning models are in
//!   [`crate::turning`]);
//! * [`wax_check`]: the estimator on the wax-milling logs, where a correct estimator
//!   reports no cutting load above its noise floor.

use std::collections::BTreeMap;

use acc_core::spindle_force::{
    AdaptRule, Constants, EstimatorConfig, Invalid, Method, NoLoadMode, NoLoadModel, SpindleError,
    SpindleEstimator,
};

use crate::datasets::MillRow;

/// RMS of `est − truth`.
pub fn rms_error(est: &[f64], truth: &[f64]) -> f64 {
    if est.is_empty() || truth.is_empty() {
        return f64::NAN;
    }
    acc_core::stats::rms(est.iter().zip(truth).map(|(e, t)| e - t))
}

/// Error rate, %: RMS error divided by the mean true value (seed 000 §3.3 reports both).
pub fn error_rate_pct(est: &[f64], truth: &[f64]) -> f64 {
    let n = truth.len();
    if n == 0 {
        return f64::NAN;
    }
    let mean = truth.iter().sum::<f64>() / n as f64;
    100.0 * rms_error(est, truth) / mean
}

/// Mean absolute percentage error, %.
pub fn mape_pct(est: &[f64], truth: &[f64]) -> f64 {
    let n = est.len().min(truth.len());
    if n == 0 {
        return f64::NAN;
    }
    let s: f64 = est
        .iter()
        .zip(truth)
        .map(|(e, t)| ((e - t) / t).abs())
        .sum();
    100.0 * s / n as f64
}

/// Minimum, median and maximum of a list.
pub fn min_median_max(v: &[f64]) -> (f64, f64, f64) {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    s.sort_by(f64::total_cmp);
    let m = s.len();
    let med = if m % 2 == 1 {
        s[m / 2]
    } else {
        0.5 * (s[m / 2 - 1] + s[m / 2])
    };
    (s[0], med, s[m - 1])
}

/// Assumptions used to turn the wax log into estimator input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaxSetup {
    /// rpm per unit of `S1_ActualVelocity` (the unit is undocumented; 60 assumes rev/s).
    pub rpm_per_unit: f64,
    /// Tool radius, mm (the tool is undocumented; 3.175 assumes a ¼" end mill). Only the
    /// force scale depends on it, not whether a load is above the noise floor.
    pub tool_radius_mm: f64,
    /// Lowest `S1_ActualVelocity` of a running spindle.
    pub min_velocity: f64,
}

impl Default for WaxSetup {
    fn default() -> Self {
        Self {
            rpm_per_unit: 60.0,
            tool_radius_mm: 3.175,
            min_velocity: 50.0,
        }
    }
}

/// Result of [`wax_check`].
#[derive(Debug, Clone, PartialEq)]
pub struct WaxResult {
    /// Air periods used to learn the no-load model.
    pub air_periods: usize,
    /// Learned no-load power, W, and its period-to-period σ, W.
    pub no_load_power_w: f64,
    /// σ of the air-cut power, W.
    pub sigma_power_w: f64,
    /// Cutting periods with a valid estimate.
    pub valid_cut_periods: usize,
    /// Cutting periods flagged invalid, by reason.
    pub invalid: BTreeMap<&'static str, usize>,
    /// Valid cutting periods whose force is above the noise floor.
    pub above_floor: usize,
    /// Noise floor, N.
    pub noise_floor_n: f64,
    /// Mean estimated force over the valid cutting periods, N.
    pub mean_force_n: f64,
    /// Mean cutting power `P − P_air` over the valid cutting periods, W.
    pub mean_cut_power_w: f64,
}

/// The power estimator on the wax logs: learn the no-load model from the rows where the
/// spindle runs steadily outside the cutting layers (`Prep`, `Repositioning`, `End`),
/// then estimate every cutting row as the board-power source would (power and speed only).
pub fn wax_check(experiments: &[Vec<MillRow>], setup: WaxSetup) -> Result<WaxResult, SpindleError> {
    let mut nl = NoLoadModel::new(AdaptRule {
        speed_tolerance: 0.02,
        ..AdaptRule::default()
    });
    let mut air = 0;
    for exp in experiments {
        // Steady spindle: running and within 1 % of the previous row's speed (the logged
        // acceleration is too noisy to use).
        for w in exp.windows(2) {
            let (prev, r) = (&w[0], &w[1]);
            let steady = r.spindle_velocity > setup.min_velocity
                && (r.spindle_velocity - prev.spindle_velocity).abs() <= 0.01 * r.spindle_velocity;
            if steady && !r.is_cutting() && !prev.is_cutting() {
                nl.learn(
                    r.spindle_velocity * setup.rpm_per_unit,
                    r.spindle_power_w,
                    0.0,
                )?;
                air += 1;
            }
        }
    }
    let cfg = EstimatorConfig {
        method: Method::Power,
        tool_radius_mm: setup.tool_radius_mm,
        no_load: NoLoadMode::Fixed,
        ..Default::default()
    };
    let (mut valid, mut above, mut sum_f, mut sum_p, mut floor) = (0, 0, 0.0, 0.0, 0.0);
    let mut invalid: BTreeMap<&'static str, usize> = BTreeMap::new();
    for exp in experiments {
        let mut est = SpindleEstimator::new(cfg, Constants::default(), nl.clone())?;
        for r in exp {
            let rpm = r.spindle_velocity * setup.rpm_per_unit;
            let e = est.estimate(rpm, Some(r.spindle_power_w), None);
            if !r.is_cutting() {
                continue;
            }
            match e {
                Ok(e) => {
                    valid += 1;
                    above += usize::from(e.above_floor);
                    sum_f += e.force_n;
                    sum_p += r.spindle_power_w - e.no_load_power_w;
                    floor = e.noise_floor_n;
                }
                Err(i) => *invalid.entry(Invalid::as_str(i)).or_default() += 1,
            }
        }
    }
    let nl_pt = nl.points().next();
    Ok(WaxResult {
        air_periods: air,
        no_load_power_w: nl_pt.map_or(f64::NAN, |p| p.power_w),
        sigma_power_w: nl_pt.map_or(f64::NAN, |p| p.sigma_power_w),
        valid_cut_periods: valid,
        invalid,
        above_floor: above,
        noise_floor_n: floor,
        mean_force_n: sum_f / valid.max(1) as f64,
        mean_cut_power_w: sum_p / valid.max(1) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics() {
        let t = [100.0, 200.0];
        let e = [110.0, 180.0];
        assert!((rms_error(&e, &t) - (250.0f64).sqrt()).abs() < 1e-12);
        assert!((error_rate_pct(&e, &t) - 100.0 * (250.0f64).sqrt() / 150.0).abs() < 1e-12);
        assert!((mape_pct(&e, &t) - 10.0).abs() < 1e-12);
        assert_eq!(min_median_max(&[3.0, 1.0, 2.0, 10.0]), (1.0, 2.5, 10.0));
    }
}
