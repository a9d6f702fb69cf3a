//! The shop layer of the production loop: the tool table chosen by the board's
//! `TOOL_NUMBER`, and entry/exit control. It never writes the override and never touches
//! the law: once per period, before the fault policy steps the law, it returns
//! [`CommandLimits`] (a cap and a floor) that bound the law's command (in its one
//! quantization step, [`acc_core::OverrideSpec::place`]), and
//! on a tool change a [`ToolChange`] event that the loop applies to the law
//! ([`crate::ControlLoop::decide`]). Everything it does can only lower the command below
//! what the law asks, except the tool's minimum override while cutting (the setter's floor).
//!
//! **Tool selection.** Tool = `TOOL_NUMBER` on a v2 board, 0 (`[default]`) on a v1 board or
//! when the board reports 0. On a change (and at the first status) the event carries the
//! tool's `fr_n` as the law's new Fr, and the Kc_hat to restart from: the value this tool
//! had when it was last used in this run, else the tool's `kc_init`, else none (the
//! estimate carries over from the previous tool). A change
//! mid-run never raises the override at once: the cap starts at the last command and rises
//! by at most [`SWITCH_RAMP_PCT_PER_S`] (so the new tool's higher Fr is approached by
//! regulation, a lower Fr takes effect at once).
//!
//! **Entry and exit control** (`[entry] enabled = true`; docs/shop.md "Entry control").
//! It works with k = F / applied override, N/%: the force per percent of override this
//! period (the engagement and the material as the loop sees them). A command written now
//! is applied next period, at next period's engagement. States [`ShopState`]:
//! - `Air`: the cap is the tool's `air_override_pct`. Air → entry when the estimated force
//!   rises above `detect_pct` % of Fr (or above `air_pct` % in a period whose block number
//!   changed: the block change confirms an entry the force alone does not yet show).
//! - `Entry` for `settle_s`: the predictive limiter caps the command at
//!   Fr·(1 + `limit_pct`/100) / k_next, k_next = k + g·m with g the larger of the last two
//!   periods' growths of k, bounded by the learned full engagement, and m the learned
//!   margin of this (tool, block) (1 ..= [`MAX_ENTRY_MARGIN`]).
//! - `Cut`: a step-up guard, the cap limit / k (no growth); cut → air after 2 periods below
//!   `air_pct` % of Fr.
//! - In `Entry` and `Cut` (`limiter = true`) a force above the limit caps the command at
//!   once at applied × Fr / F.
//! - Learning at the exit: Fr / (the largest smoothed k of the cut) as the entry override of
//!   (tool, block of the entry) and of the tool, and the growth model's largest
//!   under-prediction at forces ≥ [`MARGIN_FROM`] Fr as the (tool, block)'s margin. With
//!   `limiter = false` the learned override caps the next entry until the force reaches
//!   [`ENTRY_REACHED`] of Fr; `entry_override_pct` does while nothing is learned.
//!
//! The learned entries live in memory for the run ([`ShopControl::learned_entry`]);
//! [`ShopControl::with_learned_from`] carries them into the next run.

use std::collections::BTreeMap;

use acc_config::{ToolLimits, ToolTable};
use acc_core::{ForceSample, OverrideLaw};
use acc_pmc::BoardStatus;

use crate::policy::CommandLimits;

/// After a tool change the cap on the command rises by at most this rate, percent/s.
pub const SWITCH_RAMP_PCT_PER_S: f64 = 50.0;

/// The entry override holds until the force reaches this share of Fr.
pub const ENTRY_REACHED: f64 = 0.95;

/// Smoothing of the force per percent of override learned over a cut (EMA weight per
/// period).
pub const K_EMA: f64 = 0.2;

/// The entry growth model's learned under-prediction is applied up to this factor.
pub const MAX_ENTRY_MARGIN: f64 = 1.5;

/// The growth model's under-prediction is learned from entry periods with a force of at
/// least this share of Fr (below, an under-prediction cannot overshoot).
pub const MARGIN_FROM: f64 = 0.8;

/// Entry-control state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShopState {
    /// Out of the cut (force below the air threshold).
    Air,
    /// Entered the cut less than `settle_s` ago.
    Entry,
    /// In the cut.
    Cut,
}

impl ShopState {
    /// Name for logs (`air`, `entry`, `cut`).
    pub fn name(self) -> &'static str {
        match self {
            ShopState::Air => "air",
            ShopState::Entry => "entry",
            ShopState::Cut => "cut",
        }
    }
}

/// What the shop layer did in one period (for the run log).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShopStep {
    /// Tool in use (0: the `[default]` entry).
    pub tool: u16,
    /// Force reference of the tool, N.
    pub fr_n: f64,
    /// State after this period.
    pub state: ShopState,
    /// The tool changed this period.
    pub tool_changed: bool,
    /// Air → cut this period.
    pub entered: bool,
    /// The force limiter capped the command this period.
    pub limited: bool,
    /// The limits handed to the policy.
    pub limits: CommandLimits,
}

/// A tool change for the law, from the shop layer to the loop, which applies it in one
/// place ([`crate::ControlLoop::decide`], through [`OverrideLaw`]) before the policy steps
/// the law. Also made for the first tool of a run (the first status).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolChange {
    /// The new tool (0: the `[default]` entry).
    pub tool: u16,
    /// The new tool's force reference Fr, N ([`OverrideLaw::set_force_ref_n`]).
    pub force_ref_n: f64,
    /// Kc_hat to restart the law's estimate from, N/(mm/min)
    /// ([`OverrideLaw::reset_kc_estimate`]): this tool's last estimate in this run, else its
    /// `kc_init`; `None`: the estimate carries over.
    pub kc_restart: Option<f64>,
}

impl ToolChange {
    /// Apply the change to `law`: its Fr, then its Kc_hat if a restart value is known.
    pub fn apply_to<L: OverrideLaw + ?Sized>(&self, law: &mut L) {
        law.set_force_ref_n(self.force_ref_n);
        if let Some(kc) = self.kc_restart {
            law.reset_kc_estimate(kc);
        }
    }
}

/// What the shop layer hands the loop once per period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ShopDecision {
    /// Limits on this period's command, for the policy ([`crate::FaultPolicy::set_command_limits`]).
    pub limits: CommandLimits,
    /// The tool changed (or was first seen) this period: for the law.
    pub tool_change: Option<ToolChange>,
    /// This period's shop state for the run log (`None` without a status).
    pub step: Option<ShopStep>,
}

/// The per-tool numbers the loop needs every period (no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
struct ToolParams {
    tool: u16,
    fr_n: f64,
    min_pct: u16,
    max_pct: u16,
    air_pct: u16,
    entry_pct: Option<u16>,
    kc_init: Option<f64>,
}

impl From<&ToolLimits> for ToolParams {
    fn from(t: &ToolLimits) -> Self {
        Self {
            tool: t.tool,
            fr_n: t.fr_n,
            min_pct: t.min_override_pct,
            max_pct: t.max_override_pct,
            air_pct: t.air_override_pct,
            entry_pct: t.entry_override_pct,
            kc_init: t.kc_init,
        }
    }
}

/// The shop layer's state: see the module docs.
#[derive(Debug, Clone)]
pub struct ShopControl {
    table: ToolTable,
    period_s: f64,
    tool: Option<u16>,
    params: ToolParams,
    state: ShopState,
    block: Option<u16>,
    entry_block: u16,
    entry_age: u32,
    k_ema: Option<f64>,
    k_max: f64,
    k_full: Option<f64>,
    k_pred: Option<f64>,
    r_max: f64,
    margin: f64,
    learned_margin: BTreeMap<(u16, u16), f64>,
    below_air: u32,
    k_prev: Option<f64>,
    k_prev2: Option<f64>,
    entry_cap: Option<f64>,
    switch_cap: Option<f64>,
    learned: BTreeMap<(u16, u16), u16>,
    learned_tool: BTreeMap<u16, u16>,
    kc_by_tool: BTreeMap<u16, f64>,
    last: Option<ShopStep>,
}

impl ShopControl {
    /// A shop layer on `table` for a loop of period `period_s`, s.
    pub fn new(table: ToolTable, period_s: f64) -> Self {
        let params = ToolParams::from(&table.default);
        Self {
            table,
            period_s,
            tool: None,
            params,
            state: ShopState::Air,
            block: None,
            entry_block: 0,
            entry_age: 0,
            k_ema: None,
            k_max: 0.0,
            k_full: None,
            k_pred: None,
            r_max: 1.0,
            margin: 1.0,
            learned_margin: BTreeMap::new(),
            below_air: 0,
            k_prev: None,
            k_prev2: None,
            entry_cap: None,
            switch_cap: None,
            learned: BTreeMap::new(),
            learned_tool: BTreeMap::new(),
            kc_by_tool: BTreeMap::new(),
            last: None,
        }
    }

    /// A fresh shop layer for a new run that starts from what `previous` learned (the
    /// entry overrides and the entry growth margins per (tool, block), the settled
    /// overrides per tool, the tools' last Kc): the next run's entries start from the
    /// last run's. The table and period are this one's.
    pub fn with_learned_from(mut self, previous: &ShopControl) -> Self {
        self.learned = previous.learned.clone();
        self.learned_tool = previous.learned_tool.clone();
        self.learned_margin = previous.learned_margin.clone();
        self.kc_by_tool = previous.kc_by_tool.clone();
        self
    }

    /// The entry growth model's learned under-prediction for (`tool`, `block`) (≥ 1; the
    /// next entry there multiplies its predicted engagement by it).
    pub fn learned_margin(&self, tool: u16, block: u16) -> Option<f64> {
        self.learned_margin.get(&(tool, block)).copied()
    }

    /// The tool table.
    pub fn table(&self) -> &ToolTable {
        &self.table
    }

    /// The tool in use (`None` before the first status).
    pub fn tool(&self) -> Option<u16> {
        self.tool
    }

    /// Force reference Fr of the tool in use, N (`None` before the first status).
    pub fn force_ref_n(&self) -> Option<f64> {
        self.tool.map(|_| self.params.fr_n)
    }

    /// The entry state.
    pub fn state(&self) -> ShopState {
        self.state
    }

    /// What the last period did.
    pub fn last(&self) -> Option<ShopStep> {
        self.last
    }

    /// The entry override learned for (`tool`, `block`) in this run, percent.
    pub fn learned_entry(&self, tool: u16, block: u16) -> Option<u16> {
        self.learned.get(&(tool, block)).copied()
    }

    /// The entry override the next entry of (`tool`, `block`) starts from, percent.
    pub fn entry_override(&self, tool: u16, block: u16) -> Option<u16> {
        self.learned_entry(tool, block)
            .or_else(|| self.learned_tool.get(&tool).copied())
            .or(self.params.entry_pct)
    }

    /// Before the policy steps: pick the tool, run entry detection, and return the limits
    /// for this period's command with the tool change for the law, if any. `last_cmd` is
    /// the policy's last written command, percent; `kc_hat` the law's current process-gain
    /// estimate, N/(mm/min) (kept for the tool in use when it changes).
    pub fn before(
        &mut self,
        status: Option<&BoardStatus>,
        force: &ForceSample,
        last_cmd: Option<u16>,
        kc_hat: Option<f64>,
    ) -> ShopDecision {
        let Some(s) = status else {
            self.last = None;
            return ShopDecision::default();
        };
        // 1. The tool.
        let tool = if s.is_v2() { s.tool_number } else { 0 };
        let tool_changed = self.tool.is_some_and(|t| t != tool);
        let mut tool_change = None;
        if self.tool != Some(tool) {
            if let (Some(old), Some(kc)) = (self.tool, kc_hat) {
                self.kc_by_tool.insert(old, kc);
            }
            self.params = ToolParams::from(self.table.get(tool));
            tool_change = Some(ToolChange {
                tool,
                force_ref_n: self.params.fr_n,
                kc_restart: self.kc_by_tool.get(&tool).copied().or(self.params.kc_init),
            });
            if tool_changed {
                self.switch_cap = last_cmd.map(f64::from);
                tracing::info!(
                    tool,
                    fr_n = self.params.fr_n,
                    "tool change: limits switched"
                );
            }
            self.tool = Some(tool);
        }
        let p = self.params;
        let mut cap = f64::from(p.max_pct);
        if let Some(c) = self.switch_cap {
            // Rises by regulation only, at a bounded rate; done once it clears the maximum.
            if !tool_changed {
                let c = c + SWITCH_RAMP_PCT_PER_S * self.period_s;
                self.switch_cap = (c < f64::from(p.max_pct)).then_some(c);
            }
            cap = cap.min(c);
        }
        let block = s.is_v2().then_some(s.block_number).filter(|b| *b != 0);
        let block_changed = block.is_some() && self.block.is_some() && block != self.block;
        if block.is_some() {
            self.block = block;
        }

        // 2. Entry and exit.
        let e = self.table.entry;
        let f = (force.valid && force.force_n.is_finite()).then_some(force.force_n);
        let applied = f64::from(s.override_applied_pct);
        // Force per percent of override this period, N/%: the engagement (and the
        // material) as the loop sees it; its growth from one period to the next is an entry.
        let k = f
            .filter(|_| applied > 0.0 && !s.feed_hold_active)
            .map(|f| f / applied);
        let mut entered = false;
        let mut limited = false;
        let mut floor = None;
        if e.enabled {
            let detect = e.detect_pct / 100.0 * p.fr_n;
            let air = e.air_pct / 100.0 * p.fr_n;
            let limit = p.fr_n * (1.0 + e.limit_pct / 100.0);
            match self.state {
                ShopState::Air => {
                    let rising = f.is_some_and(|f| f > detect || (block_changed && f > air));
                    if rising {
                        entered = true;
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
                    } else {
                        cap = cap.min(f64::from(p.air_pct));
                    }
                }
                ShopState::Entry | ShopState::Cut => {
                    if f.is_some_and(|f| f < air) {
                        self.below_air += 1;
                    } else if f.is_some() {
                        self.below_air = 0;
                    }
                    if self.below_air >= 2 {
                        // Cut -> air: learn the settled engagement of this cut.
                        self.learn(tool);
                        self.state = ShopState::Air;
                        self.k_full = None;
                        self.entry_cap = None;
                        cap = cap.min(f64::from(p.air_pct));
                    } else {
                        self.entry_age += 1;
                        if self.state == ShopState::Entry
                            && f64::from(self.entry_age) * self.period_s >= e.settle_s - 1e-9
                        {
                            self.state = ShopState::Cut;
                            self.entry_cap = None;
                        }
                    }
                }
            }
            if self.state != ShopState::Air {
                if p.min_pct > 0 {
                    floor = Some(p.min_pct);
                }
                if let Some(ov) = self.entry_cap {
                    if f.is_some_and(|f| f >= ENTRY_REACHED * p.fr_n) {
                        self.entry_cap = None;
                    } else {
                        cap = cap.min(ov);
                    }
                }
                if let Some(k) = k {
                    // Learning: the largest smoothed force per percent of the cut.
                    let ema = self.k_ema.map_or(k, |m| m + K_EMA * (k - m));
                    self.k_ema = Some(ema);
                    if self.entry_age * 2 >= self.settle_periods() {
                        self.k_max = self.k_max.max(ema);
                    }
                }
                if e.limiter {
                    // Reactive: above the limit, the override that gives Fr at this k.
                    if let Some(f) = f.filter(|f| *f > limit) {
                        let c = applied * p.fr_n / f;
                        if c < cap {
                            cap = c;
                            limited = true;
                        }
                    }
                    // Predictive, while the engagement grows: the command written now is
                    // applied in the next period, at the next period's engagement. Predict
                    // its force per percent by one period of growth (bounded by the
                    // learned full engagement) and keep the next force under the limit.
                    // In the cut (engagement settled) no growth is assumed: a step up
                    // of the override must not take the force above the limit.
                    if let Some(k) = k {
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
                            let near = f.is_some_and(|f| f >= MARGIN_FROM * p.fr_n);
                            if let Some(kp) = self.k_pred.filter(|kp| near && *kp > 0.0) {
                                self.r_max = self.r_max.max(k / kp);
                            }
                            self.k_pred = Some(k_next);
                            k_next *= self.margin;
                        } else {
                            self.k_pred = None;
                        }
                        if k_next > 0.0 {
                            let c = limit / k_next;
                            if c < cap {
                                cap = c;
                                limited = true;
                            }
                        }
                    }
                }
            }
        } else if p.min_pct > 0 && f.is_some_and(|f| f > 0.5 * p.fr_n) {
            floor = Some(p.min_pct);
        }
        if f.is_some() {
            self.k_prev2 = self.k_prev;
            self.k_prev = k;
        }
        let limits = CommandLimits {
            cap_pct: Some(cap.floor().clamp(0.0, 150.0) as u16),
            floor_pct: floor,
        };
        self.last = Some(ShopStep {
            tool,
            fr_n: p.fr_n,
            state: self.state,
            tool_changed,
            entered,
            limited,
            limits,
        });
        ShopDecision {
            limits,
            tool_change,
            step: self.last,
        }
    }

    fn settle_periods(&self) -> u32 {
        (self.table.entry.settle_s / self.period_s).round() as u32
    }

    /// The entry override learned for (`tool`, `block`), else for the tool in any block.
    fn learned_override(&self, tool: u16, block: u16) -> Option<u16> {
        self.learned_entry(tool, block)
            .or_else(|| self.learned_tool.get(&tool).copied())
    }

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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const TABLE: &str = "[entry]\nenabled = true\nlimit_pct = 8.0\n[default]\nfr_n = 800.0\n";

    fn status(applied: u16) -> BoardStatus {
        BoardStatus {
            override_applied_pct: applied,
            override_step_pct: 10,
            protocol_version: 2,
            tool_number: 1,
            block_number: 20,
            cycle_active: true,
            acc_active: true,
            ..BoardStatus::default()
        }
    }

    /// The shop layer on a plant whose force is k(i) × applied, the law asking 150 % every
    /// period and the command floored to the 10 % grid (as the policy does): the forces.
    fn entry(shop: &mut ShopControl, ks: &[f64]) -> Vec<f64> {
        let mut applied = 150u16;
        let mut forces = Vec::new();
        for &k in ks {
            let f = k * f64::from(applied);
            forces.push(f);
            let sample = ForceSample {
                force_n: f,
                power_w: None,
                valid: true,
            };
            let lim = shop.before(Some(&status(applied)), &sample, Some(applied), None);
            let cap = lim.limits.cap_pct.unwrap_or(150);
            applied = 150.min(cap / 10 * 10);
        }
        forces
    }

    fn shop() -> ShopControl {
        let table = ToolTable::parse("tools.toml", TABLE).expect("table");
        ShopControl::new(table, 0.1)
    }

    /// A decelerating engagement (growth per period non-increasing): air for 5 periods,
    /// then k = k_full (1 − (1 − i/n)^p) for i = 1 ..= n periods (p ≥ 1), then k_full.
    fn ramp(k_full: f64, n: u32, p: f64) -> Vec<f64> {
        let mut ks = vec![0.0; 5];
        for i in 1..=n {
            ks.push(k_full * (1.0 - (1.0 - f64::from(i) / f64::from(n)).powf(p)));
        }
        ks.resize(60, k_full);
        ks
    }

    #[test]
    fn entry_drops_the_override_as_the_predicted_force_reaches_the_limit() {
        // Like the interrupted cut's entry at 300 mm/min: k 0.85, 2.98, 4.77, 6.29 ... 12 N/%.
        let ks = ramp(12.0, 12, 2.0);
        let mut sh = shop();
        let f = entry(&mut sh, &ks);
        let peak = f.iter().copied().fold(0.0, f64::max);
        assert!(peak <= 864.0 + 1e-9, "peak {peak:.1} N");
        // It ran in at 150 % while the engagement was small, and ends near Fr.
        assert!(f[5] > 0.0 && f[6] > 1.5 * f[5], "{:?}", &f[..10]);
        assert!(*f.last().expect("f") > 700.0, "{:?}", f.last());
        assert_eq!(sh.state(), ShopState::Cut);
    }

    #[test]
    fn learning_at_the_exit_and_carried_into_the_next_run() {
        let mut ks = ramp(12.0, 12, 2.0);
        ks.extend([0.0; 4]);
        let mut sh = shop();
        entry(&mut sh, &ks);
        assert_eq!(sh.state(), ShopState::Air);
        // Fr / 12 N/% = 66.7 %, floored.
        assert_eq!(sh.learned_entry(1, 20), Some(66));
        assert_eq!(
            sh.entry_override(1, 30),
            Some(66),
            "the tool's, in another block"
        );
        let next = shop().with_learned_from(&sh);
        assert_eq!(next.learned_entry(1, 20), Some(66));
        assert_eq!(next.state(), ShopState::Air);
    }

    proptest! {
        /// On any decelerating engagement that completes within the entry window (`n` ≤
        /// 14 periods) and whose first period at the air override (150 %) stays under the
        /// limit (what `air_override_pct` is for), the predictive limiter keeps every
        /// period's force under Fr (1 + limit_pct/100).
        #[test]
        fn no_entry_overshoots_a_decelerating_engagement(
            k_full in 2.0f64..20.0,
            n in 2u32..=14,
            p in 1.0f64..4.0,
        ) {
            let ks = ramp(k_full, n, p);
            prop_assume!(ks[5] * 150.0 <= 864.0);
            let mut sh = shop();
            let f = entry(&mut sh, &ks);
            let peak = f.iter().copied().fold(0.0, f64::max);
            prop_assert!(peak <= 864.0 + 1e-6, "peak {} N", peak);
        }
    }
}
