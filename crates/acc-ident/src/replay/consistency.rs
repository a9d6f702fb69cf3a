//! The logged force of a spindle-power estimator against the estimator's output on the
//! logged power.

#[allow(unused_imports)]
use super::*;

/// The logged force of a spindle-power estimator against the estimator's output on the
/// logged power, over the rows where either is positive (the cut): a process effect (wear,
/// a harder material, `Ks` rising with time) changes the power and the force together, so
/// the force column stays what the estimator made of the power; only a change of the logged
/// force itself (its logging path) makes them differ. The difference
/// `d = F_logged − F_est(P_logged)` is fitted by a gain drift in time from the log's first
/// row (as [`crate::effects::SensorGainDrift::apply`]), `d = r·F_est·(t − t₀)/60`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcePowerConsistency {
    /// Rows compared (finite, either positive).
    pub rows: usize,
    /// RMS of the logged force over those rows, N.
    pub force_rms_n: f64,
    /// RMS of the difference, N.
    pub difference_rms_n: f64,
    /// Fitted gain drift of the logged force against the power, 1/min.
    pub drift_per_min: f64,
    /// Share of the difference's sum of squares the drift explains, −.
    pub drift_explains: f64,
    /// RMS of the difference left after the drift, N.
    pub after_drift_rms_n: f64,
    /// What counts as equal, N: 0.05 N + 0.1 % of the force RMS + the σ of the logs'
    /// number formatting (the force column's step, the power column's step in newtons).
    pub tolerance_n: f64,
}

impl ForcePowerConsistency {
    /// Rows needed to judge, −.
    pub const MIN_ROWS: usize = 20;

    /// Compare the logged force `force` with the estimator's output `est` (both N) at the
    /// times `t_s` (s, the drift counted from `t0_s`), the formatting σ `format_sigma_n`
    /// (N); `None` with fewer than [`Self::MIN_ROWS`] comparable rows.
    pub fn of(
        t_s: &[f64],
        t0_s: f64,
        force: &[f64],
        est: &[f64],
        format_sigma_n: f64,
    ) -> Option<ForcePowerConsistency> {
        let rows: Vec<(f64, f64, f64)> = (0..t_s.len().min(force.len()).min(est.len()))
            .filter(|&i| force[i].is_finite() && est[i].is_finite())
            .filter(|&i| force[i] > 0.0 || est[i] > 0.0)
            .map(|i| ((t_s[i] - t0_s) / 60.0, force[i], est[i]))
            .collect();
        if rows.len() < Self::MIN_ROWS {
            return None;
        }
        let n = rows.len() as f64;
        let ss0: f64 = rows.iter().map(|(_, f, e)| (f - e).powi(2)).sum();
        let (num, den) = rows.iter().fold((0.0, 0.0), |(a, b), (tm, f, e)| {
            (a + (f - e) * e * tm, b + (e * tm).powi(2))
        });
        let r = if den > 0.0 { num / den } else { 0.0 };
        let ss1: f64 = rows
            .iter()
            .map(|(tm, f, e)| (f - e - r * e * tm).powi(2))
            .sum();
        let force_rms_n = (rows.iter().map(|(_, f, _)| f * f).sum::<f64>() / n).sqrt();
        Some(ForcePowerConsistency {
            rows: rows.len(),
            force_rms_n,
            difference_rms_n: (ss0 / n).sqrt(),
            drift_per_min: r,
            drift_explains: if ss0 > 0.0 { 1.0 - ss1 / ss0 } else { 0.0 },
            after_drift_rms_n: (ss1 / n).sqrt(),
            tolerance_n: 0.05 + 1e-3 * force_rms_n + format_sigma_n.max(0.0),
        })
    }

    /// The force column is the estimator's output on the power: RMS difference within
    /// [`Self::tolerance_n`].
    pub fn consistent(&self) -> bool {
        self.difference_rms_n <= self.tolerance_n
    }

    /// The logged force is the estimator's output times `1 + r·(t − t₀)/60` and nothing
    /// else: inconsistent, and within [`Self::tolerance_n`] once the drift is taken out (a
    /// constant gain or offset, an estimator other than the model's, stale or clipped
    /// samples leave more).
    pub fn drifts(&self) -> bool {
        !self.consistent() && self.after_drift_rms_n <= self.tolerance_n
    }
}

#[cfg(test)]
mod force_power_tests {
    use super::ForcePowerConsistency;
    use proptest::prelude::*;

    /// A cut at 600–900 N logged every 0.1 s for 60 s, and the estimator's output.
    fn cut() -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (1..=600).map(|i| 0.1 * f64::from(i)).collect();
        let est = t.iter().map(|t| 750.0 + 150.0 * (0.3 * t).sin()).collect();
        (t, est)
    }

    fn round_to(x: &[f64], step: f64) -> Vec<f64> {
        x.iter().map(|v| (v / step).round() * step).collect()
    }

    #[test]
    fn a_force_column_made_from_the_power_is_consistent_at_its_formatting() {
        let (t, est) = cut();
        for step in [1e-3, 0.1, 1.0] {
            // The column written with 3, 1 and 0 decimals; its formatting σ given.
            let f = round_to(&est, step);
            let sigma = crate::stats::quantization_sigma(&f);
            let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, sigma).expect("rows");
            assert_eq!(c.rows, 600);
            assert!(c.consistent() && !c.drifts(), "step {step}: {c:?}");
        }
    }

    #[test]
    fn too_few_cut_rows_are_not_judged_and_a_dead_force_column_is_not_consistent() {
        let (t, est) = cut();
        let dead = vec![0.0; est.len()];
        let z = vec![0.0; est.len()];
        assert_eq!(ForcePowerConsistency::of(&t, 0.1, &z, &dead, 0.0), None);
        // The force stays 0 while the power says the tool cuts: compared, not consistent.
        let c = ForcePowerConsistency::of(&t, 0.1, &dead, &est, 0.0).expect("rows");
        assert!(!c.consistent() && !c.drifts(), "{c:?}");
        // A NaN row is left out.
        let mut f = est.clone();
        f[3] = f64::NAN;
        let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, 0.0).expect("rows");
        assert_eq!(c.rows, 599);
        assert!(c.consistent(), "{c:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// A gain drift of the logged force is found with its rate; a constant gain error,
        /// a step offset or stale samples differ from the power but are not a drift.
        #[test]
        fn a_logged_drift_is_measured_and_other_differences_are_not_a_drift(
            r in prop_oneof![-0.1f64..-0.005, 0.005f64..0.1],
            k in 1usize..7,
            g in prop_oneof![-0.05f64..-0.005, 0.005f64..0.05],
        ) {
            let (t, est) = cut();
            let f: Vec<f64> = t.iter().zip(&est).map(|(t, e)| e * (1.0 + r * (t - 0.1) / 60.0)).collect();
            let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, 0.0).expect("rows");
            prop_assert!(c.drifts(), "{c:?}");
            prop_assert!((c.drift_per_min - r).abs() < 1e-9, "{c:?}");
            // Every 7th sample (from phase k) repeats the one before it.
            let mut stale = est.clone();
            for i in (k..stale.len()).step_by(7) {
                stale[i] = stale[i - 1];
            }
            // A constant gain error; a step offset half-way.
            let gain: Vec<f64> = est.iter().map(|e| e * (1.0 + g)).collect();
            let step: Vec<f64> = est
                .iter()
                .enumerate()
                .map(|(i, e)| if i >= 300 { e + 750.0 * g } else { *e })
                .collect();
            for (what, col) in [("stale", &stale), ("gain", &gain), ("step", &step)] {
                let c = ForcePowerConsistency::of(&t, 0.1, col, &est, 0.0).expect("rows");
                prop_assert!(!c.consistent() && !c.drifts(), "{what}: {c:?}");
            }
        }
    }
}
