//! The plan's force band for the period and the disagreement check (docs/plan.md,
//! "Disagreement"): the rows the tool crossed, each at `force_100_n · (f/f_prog)^β`
//! (seed 002 eq. 1) at the period's `ACTUAL_FEED`, against the measured force.

use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use super::position::Located;
use super::{Disagreement, LookAhead};

/// The plan against the measurement this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Judged {
    /// A persistent disagreement.
    pub(super) disagreement: Option<Disagreement>,
    /// The plan explains a force drop ([`super::LookAheadStep::exit_planned`]).
    pub(super) exit_planned: bool,
    /// The plan's band `(lo, hi)` at the period's feed, N.
    pub(super) band: (f64, f64),
    /// The plan's shape inside a row is trusted: the measurement has not shown more force
    /// than planned (else each row is read at its largest force).
    pub(super) shape: bool,
    /// The plan and the measurement agree (no disagreement, none pending).
    pub(super) agree: bool,
    /// The valid measured force, N (`None`: not valid).
    pub(super) measured: Option<f64>,
}

impl LookAhead {
    /// The period's band and disagreement at the tool's place `at`, from the force sample
    /// `force` and the feed `s` reports.
    pub(super) fn judge(&mut self, force: &ForceSample, s: &BoardStatus, at: &Located) -> Judged {
        let v = f64::from(s.actual_feed_mm_min);
        let (disagreement, exit_planned, band) = self.check(force, v, at.x, at.dx);
        let shape = self.above == 0 && disagreement != Some(Disagreement::Above);
        Judged {
            disagreement,
            exit_planned,
            band,
            shape,
            agree: shape && disagreement.is_none() && self.below == 0,
            measured: (force.valid && force.force_n.is_finite()).then_some(force.force_n),
        }
    }

    /// The disagreement check of the period that ended at `x` (mm), at feed `v` (mm/min),
    /// having moved `dx` (mm).
    /// Also whether the plan explains a force drop this period: its band reaches air (a
    /// row without force), or the valid measured force is inside the band; and the band,
    /// `(lo, hi)` in N at the period's feed.
    pub(super) fn check(
        &mut self,
        force: &ForceSample,
        v: f64,
        x: f64,
        dx: f64,
    ) -> (Option<Disagreement>, bool, (f64, f64)) {
        let (a, b) = (
            self.plan.row_at(x - dx - self.unc_mm),
            self.plan.row_at(x + self.unc_mm),
        );
        let rows = &self.plan.rows[a..=b];
        let air = rows.iter().any(|r| !r.cuts());
        let band = rows
            .iter()
            .map(|r| (r.force_min_at_feed_n(v), r.force_at_feed_n(v)))
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), f| {
                (lo.min(f.0), hi.max(f.1))
            });
        if !(force.valid && force.force_n.is_finite()) {
            return (None, air, band);
        }
        let f = force.force_n;
        let tol = self.cfg.tolerance;
        let above = f > band.1 * (1.0 + tol) + self.cfg.tolerance_n;
        let below = f < band.0 * (1.0 - tol) - self.cfg.tolerance_n;
        self.above = if above { self.above + 1 } else { 0 };
        self.below = if below { self.below + 1 } else { 0 };
        let n = self.cfg.persist_periods.max(1);
        let d = if self.above >= n {
            Some(Disagreement::Above)
        } else if self.below >= n {
            Some(Disagreement::Below)
        } else {
            None
        };
        (d, self.above == 0 && (air || !(above || below)), band)
    }
}
