//! The breakage detector the fault policy steps with every valid force sample: a sudden
//! drop (tool gone) or spike against the tool's own recent history (one concern of
//! [`crate::watch`]).

use super::WatchLimits;

/// What the breakage detector saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Breakage {
    /// The force fell below `(1 − breakage_drop_pct/100)` × the recent median (tool gone).
    Drop {
        /// The sample, N.
        force_n: f64,
        /// Median of the recent history, N.
        reference_n: f64,
    },
    /// The force rose above `breakage_spike_factor` × the recent median and at least
    /// doubled within two periods (a force that climbs over many periods, the engagement
    /// growing along the path, is no spike; a jam after a small rise is one).
    Spike {
        /// The sample, N.
        force_n: f64,
        /// Median of the recent history, N.
        reference_n: f64,
    },
}

impl Breakage {
    /// `drop` or `spike`.
    pub fn kind(&self) -> &'static str {
        match self {
            Breakage::Drop { .. } => "drop",
            Breakage::Spike { .. } => "spike",
        }
    }
}

/// One period as the breakage detector sees it (the policy builds it from the status and
/// the force sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BreakageSample {
    /// Valid force sample of the period, N.
    pub force_n: f64,
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// The NC runs the program (`CYCLE_ACTIVE`).
    pub cycle_active: bool,
    /// The axes are held (`FEED_HOLD_ACTIVE`): a falling force is expected then.
    pub feed_hold_active: bool,
    /// `TOOL_NUMBER` (0: unknown).
    pub tool: u16,
    /// `BLOCK_NUMBER` (0: unknown). A drop is judged only while the board reports the block
    /// (the NC says the cut continues in the same block); a spike always.
    pub block: u16,
    /// No block or tool change waits for the line guard's confirmation: `block` is the
    /// block the NC runs. A drop seen while a change waits is reported once the block is
    /// settled again on the same block (the change was a bad frame) or after
    /// [`BreakageDetector::MAX_PENDING_PERIODS`], not if the change is confirmed first (a
    /// cut that ended with its block) or the cycle stops or holds
    /// ([`BreakageDetector::observe`]).
    pub block_settled: bool,
    /// Override in force (`OVERRIDE_APPLIED`), percent. A drop is judged only when it is at
    /// least 0.8 × its value two periods back (the feed was not cut: an operator turning the
    /// knob down is no breakage), a spike only when it is at most 1.25 × that + 10 %.
    pub override_pct: u16,
}

/// Breakage detector: a ring of the last [`WatchLimits::breakage_history_periods`] force
/// samples of the current (tool, block), judged against their median. Fixed size, no
/// allocation (it runs inside the policy's step).
#[derive(Debug, Clone)]
pub struct BreakageDetector {
    limits: WatchLimits,
    ring: [f64; BreakageDetector::CAPACITY],
    len: usize,
    head: usize,
    context: Option<(u16, u16)>,
    /// A drop seen while a block or tool change waited for confirmation, and the periods
    /// it has waited.
    pending_drop: Option<(Breakage, usize)>,
    /// [`BreakageDetector::set_pending_limit`].
    pending_limit: usize,
    /// Applied override of the last [`BreakageDetector::LAG_PERIODS`] periods (newest last),
    /// percent.
    overrides: [u16; BreakageDetector::LAG_PERIODS],
}

impl BreakageDetector {
    /// Largest history, periods.
    pub const CAPACITY: usize = 32;

    /// How far back an override change can still explain a change of force, periods
    /// (0.6 s at T = 0.1 s: the feed drive's lag and the NC's override delay). A drop is a
    /// breakage only if the applied override was not lowered by more than 20 % anywhere in
    /// this window, a spike only if it was not raised by more than 25 %: a loop that
    /// oscillates through a slow feed path (override cut, force falls three periods later)
    /// is not a broken tool.
    pub const LAG_PERIODS: usize = 6;

    /// Longest wait of a drop seen while a block or tool change waits for the line guard's
    /// confirmation, judged samples, by default (at least the guard's `debounce_reads`:
    /// [`BreakageDetector::set_pending_limit`]): blocks shorter than a period (air pieces
    /// at the air feed) keep the board's block number changing for a few reads after a
    /// cut's exit; a drop still unexplained after this is reported.
    pub const MAX_PENDING_PERIODS: usize = 3;

    /// The longest wait of a held drop, judged samples: at least
    /// [`BreakageDetector::MAX_PENDING_PERIODS`] and the line guard's `debounce_reads` (a
    /// change is confirmed after that many agreeing reads).
    pub fn set_pending_limit(&mut self, debounce_reads: usize) {
        self.pending_limit = debounce_reads.max(Self::MAX_PENDING_PERIODS);
    }

    /// A detector with an empty history.
    pub fn new(limits: WatchLimits) -> Self {
        BreakageDetector {
            limits,
            ring: [0.0; Self::CAPACITY],
            len: 0,
            head: 0,
            context: None,
            pending_drop: None,
            pending_limit: Self::MAX_PENDING_PERIODS,
            overrides: [0; Self::LAG_PERIODS],
        }
    }

    /// The limits in use.
    pub fn limits(&self) -> &WatchLimits {
        &self.limits
    }

    /// New limits (a tool change through the tool table); the history is kept.
    pub fn set_limits(&mut self, limits: WatchLimits) {
        self.limits = limits;
    }

    /// Forget the history (air, a new block or tool, a feed hold) and any held drop.
    pub fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
        self.pending_drop = None;
    }

    fn history_len(&self) -> usize {
        (self.limits.breakage_history_periods as usize).clamp(3, Self::CAPACITY)
    }

    /// Ring size: the reference plus the last two samples.
    fn ring_len(&self) -> usize {
        self.history_len() + 2
    }

    fn push(&mut self, f: f64) {
        let n = self.ring_len();
        self.ring[self.head % n] = f;
        self.head = (self.head + 1) % n;
        self.len = (self.len + 1).min(n);
    }

    /// The sample `back` periods before the newest (0: newest).
    fn back(&self, back: usize) -> f64 {
        let n = self.ring_len();
        self.ring[(self.head + n - 1 - back) % n]
    }

    /// Median and minimum of the reference (the ring without its two newest samples; full
    /// ring only), and the sample two periods back from the one being judged.
    fn median_min(&self) -> Option<(f64, f64, f64)> {
        let n = self.history_len();
        if self.len < self.ring_len() {
            return None;
        }
        let mut buf = [0.0f64; Self::CAPACITY];
        for (i, slot) in buf.iter_mut().enumerate().take(n) {
            *slot = self.back(2 + i);
        }
        let s = &mut buf[..n];
        s.sort_by(f64::total_cmp);
        let med = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Some((med, s[0], self.back(1)))
    }

    /// Judge one valid sample against the history, then add it. `None`: nothing unusual.
    pub fn observe(&mut self, s: &BreakageSample) -> Option<Breakage> {
        if !self.limits.breakage_enabled {
            self.pending_drop = None;
            return None;
        }
        let ctx = (s.tool, s.block);
        // A drop held back while a block or tool change waited: confirmed now (another
        // block or tool), or the cycle stopped or held, the cut ended with its block; the
        // same block settled again (the change was a bad frame), or waiting too long, the
        // drop was a breakage; a change still waiting, it waits on.
        if let Some((p, waited)) = self.pending_drop.take() {
            if self.context == Some(ctx) && s.cycle_active && !s.feed_hold_active {
                if s.block_settled || waited >= self.pending_limit {
                    self.reset();
                    return Some(p);
                }
                self.pending_drop = Some((p, waited + 1));
                return None;
            }
        }
        if self.context != Some(ctx) {
            self.context = Some(ctx);
            self.reset();
        }
        let cut_n = self.limits.cut_force_fraction * s.force_ref_n;
        self.overrides.rotate_left(1);
        self.overrides[Self::LAG_PERIODS - 1] = s.override_pct;
        let ov_now = u32::from(s.override_pct);
        let ov_max = self.overrides.iter().copied().max().map_or(0, u32::from);
        let ov_min = self.overrides.iter().copied().min().map_or(0, u32::from);
        let feed_kept = ov_now * 5 >= ov_max * 4;
        let feed_not_raised = ov_now * 4 <= ov_min * 5 + 40;
        if !s.cycle_active || s.feed_hold_active || !s.force_n.is_finite() {
            self.reset();
            return None;
        }
        let mut verdict = None;
        if let Some((med, min, two_back)) = self.median_min() {
            // Judge only against a history of steady cutting.
            if min >= cut_n && med > 0.0 {
                if s.block != 0
                    && feed_kept
                    && s.force_n < med * (1.0 - self.limits.breakage_drop_pct / 100.0)
                    && two_back >= 0.8 * med
                {
                    let drop = Breakage::Drop {
                        force_n: s.force_n,
                        reference_n: med,
                    };
                    if !s.block_settled {
                        // Judged next period; the history is kept until then.
                        self.pending_drop = Some((drop, 1));
                        return None;
                    }
                    verdict = Some(drop);
                } else if feed_not_raised
                    && s.force_n > med * self.limits.breakage_spike_factor
                    && s.force_n >= 2.0 * two_back
                {
                    verdict = Some(Breakage::Spike {
                        force_n: s.force_n,
                        reference_n: med,
                    });
                }
            }
        }
        if verdict.is_some() {
            self.reset();
        } else if s.force_n >= cut_n {
            self.push(s.force_n);
        } else {
            self.reset();
        }
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(f: f64, block: u16) -> BreakageSample {
        BreakageSample {
            force_n: f,
            force_ref_n: 800.0,
            cycle_active: true,
            feed_hold_active: false,
            tool: 1,
            block,
            block_settled: true,
            override_pct: 60,
        }
    }

    #[test]
    fn drop_and_spike_against_history() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for i in 0..12 {
            assert_eq!(d.observe(&s(800.0 + f64::from(i), 10)), None);
        }
        assert_eq!(d.observe(&s(700.0, 10)), None, "a 12 % dip is no breakage");
        assert!(matches!(
            d.observe(&s(2500.0, 10)),
            Some(Breakage::Spike { .. })
        ));
        // After a verdict the history starts again.
        assert_eq!(d.observe(&s(50.0, 10)), None);
    }

    #[test]
    fn a_climb_over_many_periods_is_no_spike_but_a_two_period_jump_is() {
        // The engagement grows along an arc at 150 %: 50 N to 930 N over 17 periods (the
        // last sample above 3 × the median of the history).
        let climb = [
            49.0, 100.0, 168.0, 199.0, 264.0, 260.0, 277.0, 293.0, 287.0, 316.0, 325.0, 366.0,
            459.0, 523.0, 690.0, 854.0, 928.0,
        ];
        let mut d = BreakageDetector::new(WatchLimits::default());
        for f in climb {
            assert_eq!(d.observe(&s(f, 17)), None, "{f}");
        }
        // From a steady 300 N (14 periods): none of `before`, then a spike at `last`.
        let spike_after = |before: &[f64], last: f64| {
            let mut d = BreakageDetector::new(WatchLimits::default());
            for f in std::iter::repeat_n(300.0, 14).chain(before.iter().copied()) {
                assert_eq!(d.observe(&s(f, 17)), None, "{f}");
            }
            matches!(d.observe(&s(last, 17)), Some(Breakage::Spike { .. }))
        };
        // The force jumps to 930 N within two periods.
        assert!(spike_after(&[600.0], 930.0), "the jump inside the period");
        // A small rise, then a jam: 300 → 400 → 400 → 1200 N within a period.
        assert!(spike_after(&[400.0, 400.0], 1200.0));
        // Three periods of rise to more than 3 × the median, doubled within two.
        assert!(spike_after(&[450.0, 600.0], 960.0));
    }

    #[test]
    fn a_gradual_exit_is_no_breakage_but_a_two_period_fall_is() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        // The tool leaves the workpiece over 8 periods.
        for f in [760.0, 700.0, 620.0, 530.0, 430.0, 330.0, 240.0, 150.0] {
            assert_eq!(d.observe(&s(f, 40)), None, "{f}");
        }
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        assert_eq!(
            d.observe(&s(450.0, 40)),
            None,
            "the break inside the period"
        );
        assert!(matches!(
            d.observe(&s(40.0, 40)),
            Some(Breakage::Drop { .. })
        ));
    }

    #[test]
    fn the_operator_cutting_the_feed_is_no_breakage() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        // Knob from 60 % to 20 %: the force follows within a period.
        let knob = |f: f64| BreakageSample {
            override_pct: 20,
            ..s(f, 40)
        };
        for f in [260.0, 250.0, 255.0, 262.0] {
            assert_eq!(d.observe(&knob(f)), None, "{f}");
        }
    }

    #[test]
    fn no_verdict_without_steady_history_or_block() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        // Entry: air then cut in a new block; the history is not steady yet.
        for f in [0.0, 5.0, 300.0, 900.0, 1000.0] {
            assert_eq!(d.observe(&s(f, 20)), None);
        }
        // Unknown block: a drop is not judged (the cut may have ended).
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 0));
        }
        assert_eq!(d.observe(&s(10.0, 0)), None);
        // A drop while a block change waits for confirmation is judged next period: the
        // change confirmed (block 20), the cut ended with its block; still block 10 (the
        // change was a bad frame, or is held longer), a breakage; the same drop with the
        // block settled is one at once.
        let steady = || {
            let mut d = BreakageDetector::new(WatchLimits::default());
            for _ in 0..12 {
                d.observe(&s(800.0, 10));
            }
            d
        };
        let pending = |f: f64| BreakageSample {
            block_settled: false,
            ..s(f, 10)
        };
        let is_drop = |b: Option<Breakage>| matches!(b, Some(Breakage::Drop { .. }));
        let mut d = steady();
        assert_eq!(d.observe(&pending(10.0)), None);
        assert_eq!(d.observe(&s(10.0, 20)), None);
        let mut d = steady();
        assert_eq!(d.observe(&pending(10.0)), None);
        assert!(is_drop(d.observe(&s(10.0, 10))));
        // The board's block number still changing (short blocks after the exit): the drop
        // waits, at most three periods, then it is reported; the change confirmed within
        // them, it is not.
        let mut d = steady();
        for _ in 0..BreakageDetector::MAX_PENDING_PERIODS {
            assert_eq!(d.observe(&pending(10.0)), None);
        }
        assert!(is_drop(d.observe(&pending(10.0))));
        let mut d = steady();
        for _ in 0..BreakageDetector::MAX_PENDING_PERIODS {
            assert_eq!(d.observe(&pending(0.0)), None);
        }
        assert_eq!(d.observe(&s(0.0, 30)), None);
        // A guard that confirms after 5 reads: the drop waits as long.
        let mut d = steady();
        d.set_pending_limit(5);
        for _ in 0..5 {
            assert_eq!(d.observe(&pending(10.0)), None);
        }
        assert!(is_drop(d.observe(&pending(10.0))));
        // A new tool or the cycle's end lets a held drop go.
        let mut d = steady();
        assert_eq!(d.observe(&pending(10.0)), None);
        assert_eq!(
            d.observe(&BreakageSample {
                tool: 2,
                ..s(10.0, 10)
            }),
            None
        );
        let mut d = steady();
        assert_eq!(d.observe(&pending(10.0)), None);
        let end = BreakageSample {
            cycle_active: false,
            ..s(0.0, 10)
        };
        assert_eq!(d.observe(&end), None);
        assert_eq!(d.observe(&s(10.0, 10)), None);
        let mut d = steady();
        assert!(is_drop(d.observe(&s(10.0, 10))));
        // A block change resets the history.
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 10));
        }
        assert_eq!(d.observe(&s(10.0, 20)), None);
    }

    #[test]
    fn a_force_fall_explained_by_an_override_cut_a_few_periods_back_is_no_breakage() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        let at = |f: f64, ov: u16| BreakageSample {
            override_pct: ov,
            ..s(f, 10)
        };
        for i in 0..12 {
            assert_eq!(d.observe(&at(800.0 + f64::from(i), 90)), None);
        }
        // The loop cuts the override hard; the force follows three periods later (a slow
        // feed path), and falls by 80 % while the override is already low and kept.
        for (f, ov) in [
            (1200.0, 50),
            (1200.0, 20),
            (1200.0, 10),
            (731.0, 10),
            (407.0, 20),
        ] {
            assert_eq!(d.observe(&at(f, ov)), None);
        }
        assert_eq!(d.observe(&at(165.0, 20)), None);
    }
}
