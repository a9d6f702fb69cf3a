//! Breakage judge: *did the tool break?* The wear and breakage watch's
//! [`BreakageDetector`] stepped with every valid force sample once the law has a force
//! reference: a sample far below (tool gone) or far above (spike) the median of the tool's
//! own recent steady-cut history, while the NC says the cut continues (cycle on, same tool
//! and block, no feed hold), is a breakage: feed hold in the same period, release, latch.

use acc_pmc::BoardStatus;

use crate::watch::{Breakage, BreakageDetector, BreakageSample, WatchLimits};

/// The detector and the force reference it judges against.
#[derive(Debug, Clone)]
pub(crate) struct BreakageJudge {
    /// The breakage watch (fixed size, no allocation).
    pub(crate) detector: BreakageDetector,
    /// Fr of the law's last step, N (the breakage watch's cut threshold).
    pub(crate) force_ref_n: Option<f64>,
}

impl BreakageJudge {
    /// A judge with `limits` and no force reference yet.
    pub(crate) fn new(limits: WatchLimits) -> Self {
        Self {
            detector: BreakageDetector::new(limits),
            force_ref_n: None,
        }
    }

    /// Judge the valid force sample `force_n`, N, of status `s` (`feed_hold`: the policy
    /// requests feed hold; `block_settled`: no block or tool change waits for the line
    /// guard's confirmation). `None` before the law's first step (no Fr yet).
    pub(crate) fn judge(
        &mut self,
        force_n: f64,
        s: &BoardStatus,
        feed_hold: bool,
        block_settled: bool,
    ) -> Option<Breakage> {
        let force_ref_n = self.force_ref_n?;
        let v2 = s.is_v2();
        self.detector.observe(&BreakageSample {
            force_n,
            force_ref_n,
            cycle_active: s.cycle_active,
            feed_hold_active: s.feed_hold_active || feed_hold,
            tool: if v2 { s.tool_number } else { 0 },
            block: if v2 { s.block_number } else { 0 },
            block_settled,
            override_pct: s.override_applied_pct,
        })
    }
}
