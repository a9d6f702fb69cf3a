//! Entry and exit control (`[entry] enabled = true`): the states air → entry → cut → air
//! from the force, the learning at the exit, and in the cut the floor, the entry override
//! and the force limiter's caps (see the module docs of [`super`]).

use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use super::{ShopControl, ShopState, ENTRY_REACHED, K_EMA, MARGIN_FROM, MAX_ENTRY_MARGIN};

/// This period's force as entry control reads it.
#[derive(Debug, Clone, Copy)]
pub(super) struct PeriodForce {
    /// The estimated force, N (`None`: not valid or not finite).
    pub f: Option<f64>,
    /// The override applied, percent.
    pub applied: f64,
    /// Force per percent of override, N/%: the engagement (and the material) as the loop
    /// sees it; its growth from one period to the next is an entry. `None` without a force,
    /// at 0 % or in a feed hold.
    pub k: Option<f64>,
}

impl PeriodForce {
    /// The force of `force` at the override `s` reports applied.
    pub(super) fn of(s: &BoardStatus, force: &ForceSample) -> Self {
        let f = (force.valid && force.force_n.is_finite()).then_some(force.force_n);
        let applied = f64::from(s.override_applied_pct);
        let k = f
            .filter(|_| applied > 0.0 && !s.feed_hold_active)
            .map(|f| f / applied);
        Self { f, applied, k }
    }
}

/// The limits on this period's command as the shop layer builds them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Limiting {
    /// Cap, percent (not yet floored).
    pub cap: f64,
    /// Floor, percent.
    pub floor: Option<u16>,
    /// The force limiter lowered the cap.
    pub limited: bool,
}

impl Limiting {
    /// No floor, the cap at `cap`, percent.
    pub(super) fn under(cap: f64) -> Self {
        Self {
            cap,
            floor: None,
            limited: false,
        }
    }

    /// A rule of the state (air override, entry override) caps at `c`, percent.
    fn lower(&mut self, c: f64) {
        self.cap = self.cap.min(c);
    }

    /// The force limiter caps at `c`, percent (limited when it lowers the cap).
    fn limit(&mut self, c: f64) {
        if c < self.cap {
            self.cap = c;
            self.limited = true;
        }
    }
}

impl ShopControl {
    /// The entry state from this period's force: air → entry above `detect_pct` % of Fr
    /// (or `air_pct` % in a period whose block changed); entry or cut → air after 2 periods
    /// below `air_pct` % (learning the cut); entry → cut after `settle_s`. In air the cap
    /// is the tool's air override. Whether the cut was entered this period.
    pub(super) fn step_entry_state(
        &mut self,
        tool: u16,
        pf: &PeriodForce,
        block_changed: bool,
        lim: &mut Limiting,
    ) -> bool {
        let (p, e) = (self.params, self.table.entry);
        let detect = e.detect_pct / 100.0 * p.fr_n;
        let air = e.air_pct / 100.0 * p.fr_n;
        match self.state {
            ShopState::Air => {
                if pf
                    .f
                    .is_some_and(|f| f > detect || (block_changed && f > air))
                {
                    self.begin_entry(tool);
                    return true;
                }
                lim.lower(f64::from(p.air_pct));
            }
            ShopState::Entry | ShopState::Cut => {
                if pf.f.is_some_and(|f| f < air) {
                    self.below_air += 1;
                } else if pf.f.is_some() {
                    self.below_air = 0;
                }
                if self.below_air >= 2 {
                    // Cut -> air: learn the settled engagement of this cut.
                    self.learn(tool);
                    self.state = ShopState::Air;
                    self.k_full = None;
                    self.entry_cap = None;
                    lim.lower(f64::from(p.air_pct));
                } else {
                    self.age_entry();
                }
            }
        }
        false
    }

    /// Air → entry: the entry's block, its counters and learned figures (the full
    /// engagement's force per percent and the growth margin of this (tool, block)), and the
    /// entry cap (the tool table's entry override while nothing is learned; without the
    /// predictive limiter, the learned override).
    fn begin_entry(&mut self, tool: u16) {
        let (p, e) = (self.params, self.table.entry);
        self.state = ShopState::Entry;
        self.entry_block = self.block.unwrap_or(0);
        self.entry_age = 0;
        self.below_air = 0;
        self.k_ema = None;
        self.k_max = 0.0;
        let learned = self.learned_override(tool, self.entry_block);
        // The full engagement's force per percent, N/%, from the override
        // learned at the last entry (it gave Fr there).
        self.k_full = learned.map(|ov| p.fr_n / f64::from(ov.max(1)));
        self.k_pred = None;
        self.r_max = 1.0;
        self.margin = self
            .learned_margin
            .get(&(tool, self.entry_block))
            .copied()
            .unwrap_or(1.0);
        // The entry cap: the tool table's entry override while nothing is
        // learned; without the predictive limiter, the learned override
        // (the next entry starts from the last one's settled override).
        self.entry_cap = if e.limiter {
            p.entry_pct.filter(|_| learned.is_none())
        } else {
            learned.or(p.entry_pct)
        }
        .map(f64::from);
    }

    /// One more period in the cut; an entry older than `settle_s` is the cut (its entry
    /// cap ends).
    fn age_entry(&mut self) {
        self.entry_age += 1;
        if self.state == ShopState::Entry
            && f64::from(self.entry_age) * self.period_s >= self.table.entry.settle_s - 1e-9
        {
            self.state = ShopState::Cut;
            self.entry_cap = None;
        }
    }

    /// In the cut (entry or cut): the tool's minimum override as the floor, the entry cap
    /// until the force reaches [`ENTRY_REACHED`] of Fr, the learning of the force per
    /// percent, and with `limiter` the reactive and the predictive caps.
    pub(super) fn limit_in_cut(&mut self, pf: &PeriodForce, lim: &mut Limiting) {
        let (p, e) = (self.params, self.table.entry);
        if p.min_pct > 0 {
            lim.floor = Some(p.min_pct);
        }
        if let Some(ov) = self.entry_cap {
            if pf.f.is_some_and(|f| f >= ENTRY_REACHED * p.fr_n) {
                self.entry_cap = None;
            } else {
                lim.lower(ov);
            }
        }
        if let Some(k) = pf.k {
            self.learn_k(k);
        }
        if e.limiter {
            let limit = p.fr_n * (1.0 + e.limit_pct / 100.0);
            // Reactive: above the limit, the override that gives Fr at this k.
            if let Some(f) = pf.f.filter(|f| *f > limit) {
                lim.limit(pf.applied * p.fr_n / f);
            }
            if let Some(k) = pf.k {
                let k_next = self.next_k(pf, k);
                if k_next > 0.0 {
                    lim.limit(limit / k_next);
                }
            }
        }
    }

    /// Learning over the cut: the force per percent `k` smoothed ([`K_EMA`]), its largest
    /// value from half the settle time on.
    fn learn_k(&mut self, k: f64) {
        let ema = self.k_ema.map_or(k, |m| m + K_EMA * (k - m));
        self.k_ema = Some(ema);
        if self.entry_age * 2 >= self.settle_periods() {
            self.k_max = self.k_max.max(ema);
        }
    }

    /// The predictive limiter's force per percent for the next period, N/%: the command
    /// written now is applied in the next period, at the next period's engagement. While
    /// entering, `k` grows by the larger of the last two periods' growths (bounded by the
    /// learned full engagement) times the learned margin; in the cut (engagement settled)
    /// no growth is assumed, so a step up of the override cannot take the force above the
    /// limit. Also tracks this entry's under-prediction near Fr for the next entry.
    fn next_k(&mut self, pf: &PeriodForce, k: f64) -> f64 {
        let entering = self.state == ShopState::Entry;
        // Growth per period: the larger of the last two (a period whose
        // override stepped down can hide one period's growth).
        let grow = if entering {
            let k1 = self.k_prev.unwrap_or(0.0);
            let g_prev = self.k_prev2.map_or(0.0, |k2| k1 - k2);
            (k - k1).max(g_prev).max(0.0)
        } else {
            0.0
        };
        let mut k_next = k + grow;
        if let Some(kf) = self.k_full {
            k_next = k_next.min(kf.max(k));
        }
        if entering {
            // How far the growth model under-predicted this entry so far
            // (learned for the next entry of this (tool, block)).
            // Counted where it matters: at forces near Fr.
            let near = pf.f.is_some_and(|f| f >= MARGIN_FROM * self.params.fr_n);
            if let Some(kp) = self.k_pred.filter(|kp| near && *kp > 0.0) {
                self.r_max = self.r_max.max(k / kp);
            }
            self.k_pred = Some(k_next);
            k_next *= self.margin;
        } else {
            self.k_pred = None;
        }
        k_next
    }

    /// Entry control's settle time in periods.
    pub(super) fn settle_periods(&self) -> u32 {
        (self.table.entry.settle_s / self.period_s).round() as u32
    }

    /// The entry override learned for (`tool`, `block`), else for the tool in any block.
    fn learned_override(&self, tool: u16, block: u16) -> Option<u16> {
        self.learned_entry(tool, block)
            .or_else(|| self.learned_tool.get(&tool).copied())
    }

    /// At the exit of a settled cut: Fr / (the largest smoothed k) as the entry override of
    /// (`tool`, the entry's block) and of the tool, and the growth model's largest
    /// under-prediction as the (tool, block)'s margin (1 ..= [`MAX_ENTRY_MARGIN`]).
    fn learn(&mut self, tool: u16) {
        if self.k_max <= 0.0 || self.entry_age < self.settle_periods() {
            return;
        }
        let ov = (self.params.fr_n / self.k_max).floor().clamp(1.0, 150.0) as u16;
        self.learned.insert((tool, self.entry_block), ov);
        self.learned_margin.insert(
            (tool, self.entry_block),
            self.r_max.clamp(1.0, MAX_ENTRY_MARGIN),
        );
        self.learned_tool.insert(tool, ov);
        tracing::debug!(tool, block = self.entry_block, ov, "entry override learned");
    }
}
