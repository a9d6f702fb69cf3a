//! How far a run's measured force was from its plan: the plan's force error over the
//! cutting periods of a run log (`acc plan --measured run.csv`).
//!
//! Per period of the log, the plan's force band is the one the look-ahead checks the
//! measured force against ([`crate::lookahead`]): the smallest and largest predicted force
//! of the plan rows the tool crossed during the period (from the path position at the
//! period's start to its end), each at the period's actual feed,
//! `F₁₀₀ · (f / f_prog)^β` (seed 002 eq. 1, [`PlanRow::force_at_feed_n`]). The period's
//! error is how far the measured force lies outside that band: `F − top` above it,
//! `F − bottom` (negative) below it, 0 inside. A cutting period is one with a valid
//! measured force, a feed, no feed hold, and plan rows that all cut and are not rapids
//! (entries and exits, where the tool goes from air to metal within the period, are left
//! out). The path position is the simulator's true one (`x_true_mm`) when the log has it,
//! else the loop's `x_mm`.

use crate::plan::{Plan, PlanRow};
use crate::record::RunRecord;

/// The plan's force error over the cutting periods of a run log.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlanForceError {
    /// Cutting periods compared.
    pub periods: usize,
    /// Periods whose measured force was above the band.
    pub above: usize,
    /// Periods whose measured force was below the band.
    pub below: usize,
    /// Root mean square of the error, N.
    pub rms_n: f64,
    /// Mean of the error (positive: the plan predicts too little force), N.
    pub mean_n: f64,
}

/// The rows of `plan` that hold the path from `x0` to `x1` (mm, `x0 ≤ x1`).
fn crossed(plan: &Plan, x0: f64, x1: f64) -> &[PlanRow] {
    let rows = &plan.rows;
    let first = rows.partition_point(|r| r.end_mm < x0);
    let last = rows.partition_point(|r| r.start_mm <= x1);
    if first >= last {
        return &[];
    }
    &rows[first..last]
}

/// The plan's force error of the run `log` (see the module docs).
pub fn plan_force_error(plan: &Plan, log: &[RunRecord]) -> PlanForceError {
    let mut errs: Vec<f64> = Vec::new();
    let mut out = PlanForceError::default();
    let mut t_prev: Option<f64> = None;
    for r in log {
        let dt = t_prev.map_or(r.t_s, |t| r.t_s - t);
        t_prev = Some(r.t_s);
        let (Some(x), Some(v), Some(f)) = (r.x_true_mm.or(r.x_mm), r.feed_mm_min, r.force_n) else {
            continue;
        };
        if !(r.force_valid && f.is_finite() && v > 0.0 && dt > 0.0) || r.feed_hold {
            continue;
        }
        let rows = crossed(plan, x - v * dt / 60.0, x);
        if rows.is_empty() || rows.iter().any(|p| p.rapid || !p.cuts()) {
            continue;
        }
        let (lo, hi) = rows
            .iter()
            .map(|p| (p.force_min_at_feed_n(v), p.force_at_feed_n(v)))
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), b| {
                (lo.min(b.0), hi.max(b.1))
            });
        let e = if f > hi {
            out.above += 1;
            f - hi
        } else if f < lo {
            out.below += 1;
            f - lo
        } else {
            0.0
        };
        errs.push(e);
    }
    out.periods = errs.len();
    if out.periods > 0 {
        let n = out.periods as f64;
        out.rms_n = (errs.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        out.mean_n = errs.iter().sum::<f64>() / n;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::test_row;

    fn rec(t: f64, x: f64, feed: f64, force: f64) -> RunRecord {
        RunRecord {
            t_s: t,
            x_mm: Some(x),
            feed_mm_min: Some(feed),
            force_n: Some(force),
            force_valid: true,
            ..RunRecord::default()
        }
    }

    #[test]
    fn error_is_the_distance_outside_the_band_at_the_logged_feed() {
        // Air to 10 mm, then 800 N at 200 mm/min (β = 1) to 30 mm, 600..800 N to 50 mm.
        let mut band = test_row(3, 30.0, 50.0, 200.0, 800.0, 100);
        band.force_min_100_n = 600.0;
        let plan = Plan {
            rows: vec![
                test_row(1, 0.0, 10.0, 200.0, 0.0, 150),
                test_row(2, 10.0, 30.0, 200.0, 800.0, 100),
                band,
            ],
        };
        // A period of 0.1 s at 100 mm/min moves 0.167 mm.
        let log = vec![
            rec(0.1, 5.0, 100.0, 0.0),    // air: not a cutting period
            rec(0.2, 10.1, 100.0, 50.0),  // crossed the entry: left out
            rec(0.3, 20.0, 100.0, 440.0), // 400 N predicted at half the feed: +40
            rec(0.4, 21.0, 200.0, 760.0), // −40
            rec(0.5, 40.0, 200.0, 700.0), // inside 600..800: 0
            rec(0.6, 45.0, 200.0, 500.0), // −100
        ];
        let e = plan_force_error(&plan, &log);
        assert_eq!((e.periods, e.above, e.below), (4, 1, 2));
        let want = ((40.0f64.powi(2) + 40.0f64.powi(2) + 100.0f64.powi(2)) / 4.0).sqrt();
        assert!((e.rms_n - want).abs() < 1e-9, "{} vs {want}", e.rms_n);
        assert!((e.mean_n - (40.0 - 40.0 - 100.0) / 4.0).abs() < 1e-9);
        // The true position wins over the loop's.
        let mut moved = log.clone();
        moved[2].x_true_mm = Some(5.0);
        assert_eq!(plan_force_error(&plan, &moved).periods, 3);
    }
}
