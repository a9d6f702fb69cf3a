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
//!
//! [`ShopControl::before`] runs the period: the tool (here), then the entry and exit
//! control and its limiter (`entry.rs`).

use std::collections::BTreeMap;

use acc_config::{ToolLimits, ToolTable};
use acc_core::{ForceSample, OverrideLaw};
use acc_pmc::BoardStatus;

use crate::policy::CommandLimits;

mod entry;
#[cfg(test)]
mod tests;

use entry::{Limiting, PeriodForce};

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
        let tool = if s.is_v2() { s.tool_number } else { 0 };
        let tool_changed = self.tool.is_some_and(|t| t != tool);
        let tool_change = self.select_tool(tool, tool_changed, last_cmd, kc_hat);
        let mut lim = Limiting::under(self.switch_cap(tool_changed));
        let block_changed = self.track_block(s);
        let pf = PeriodForce::of(s, force);
        let mut entered = false;
        if self.table.entry.enabled {
            entered = self.step_entry_state(tool, &pf, block_changed, &mut lim);
            if self.state != ShopState::Air {
                self.limit_in_cut(&pf, &mut lim);
            }
        } else {
            lim.floor = self.floor_without_entry(&pf);
        }
        self.remember_k(&pf);
        let step = self.record_step(tool, tool_changed, entered, &lim);
        ShopDecision {
            limits: step.limits,
            tool_change,
            step: Some(step),
        }
    }

    /// The tool from the board's `TOOL_NUMBER` (0 on a v1 board): on a change, and at the
    /// first status, the old tool's Kc_hat is kept, the new tool's limits are loaded and the
    /// law gets its Fr and the Kc_hat to restart from; a change mid-run starts the switch
    /// ramp at the last command.
    fn select_tool(
        &mut self,
        tool: u16,
        tool_changed: bool,
        last_cmd: Option<u16>,
        kc_hat: Option<f64>,
    ) -> Option<ToolChange> {
        if self.tool == Some(tool) {
            return None;
        }
        if let (Some(old), Some(kc)) = (self.tool, kc_hat) {
            self.kc_by_tool.insert(old, kc);
        }
        self.params = ToolParams::from(self.table.get(tool));
        let change = ToolChange {
            tool,
            force_ref_n: self.params.fr_n,
            kc_restart: self.kc_by_tool.get(&tool).copied().or(self.params.kc_init),
        };
        if tool_changed {
            self.switch_cap = last_cmd.map(f64::from);
            tracing::info!(
                tool,
                fr_n = self.params.fr_n,
                "tool change: limits switched"
            );
        }
        self.tool = Some(tool);
        Some(change)
    }

    /// The cap the period starts from, percent: the tool's maximum, and after a tool change
    /// the switch ramp (from the last command, up by [`SWITCH_RAMP_PCT_PER_S`], done once it
    /// clears the maximum).
    fn switch_cap(&mut self, tool_changed: bool) -> f64 {
        let max = f64::from(self.params.max_pct);
        let Some(c) = self.switch_cap else {
            return max;
        };
        // Rises by regulation only, at a bounded rate; done once it clears the maximum.
        if !tool_changed {
            let c = c + SWITCH_RAMP_PCT_PER_S * self.period_s;
            self.switch_cap = (c < max).then_some(c);
        }
        max.min(c)
    }

    /// The block the board reports (v2, nonzero): whether it changed since the last one
    /// seen.
    fn track_block(&mut self, s: &BoardStatus) -> bool {
        let block = s.is_v2().then_some(s.block_number).filter(|b| *b != 0);
        let block_changed = block.is_some() && self.block.is_some() && block != self.block;
        if block.is_some() {
            self.block = block;
        }
        block_changed
    }

    /// Without entry control: the tool's minimum override as the floor while the force is
    /// above half of Fr (the cut).
    fn floor_without_entry(&self, pf: &PeriodForce) -> Option<u16> {
        let p = self.params;
        (p.min_pct > 0 && pf.f.is_some_and(|f| f > 0.5 * p.fr_n)).then_some(p.min_pct)
    }

    /// The period's force per percent of override, kept for the next two periods' growth
    /// (a period without a force keeps the last ones).
    fn remember_k(&mut self, pf: &PeriodForce) {
        if pf.f.is_some() {
            self.k_prev2 = self.k_prev;
            self.k_prev = pf.k;
        }
    }

    /// The limits for the policy (the cap floored onto whole percent within 0..=150) and
    /// the period's record, kept as [`ShopControl::last`].
    fn record_step(
        &mut self,
        tool: u16,
        tool_changed: bool,
        entered: bool,
        lim: &Limiting,
    ) -> ShopStep {
        let limits = CommandLimits {
            cap_pct: Some(lim.cap.floor().clamp(0.0, 150.0) as u16),
            floor_pct: lim.floor,
        };
        let step = ShopStep {
            tool,
            fr_n: self.params.fr_n,
            state: self.state,
            tool_changed,
            entered,
            limited: lim.limited,
            limits,
        };
        self.last = Some(step);
        step
    }
}
