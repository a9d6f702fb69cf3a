//! The look-ahead's one input per period ([`LookAheadInput`]), what it decides
//! ([`LookAheadStep`]), its state between periods and the order of one period
//! ([`LookAhead::step`]); each callee lives in the file that decides it (see `mod.rs`).

use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use super::block_start::RecentPeriods;
use super::entry::Entry;
use super::lead::PlanLead;
use super::plan::Plan;
use super::scale::PlanScale;
use super::LookAheadConfig;

/// Everything the look-ahead reads in one period, handed to [`super::LookAhead::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LookAheadInput {
    /// The status the loop accepted this period (the line guard's), `None`: the read
    /// failed.
    pub status: Option<BoardStatus>,
    /// The block number of this period's raw read, before the line guard confirms a
    /// change ([`crate::guard`]); `None`: no read, or no guard (the reported number stands
    /// for it). A new block began after the last read whose raw number was still the block
    /// reported then.
    pub raw_block: Option<u16>,
    /// The line guard held this period's read: `status` is the last accepted one, and a
    /// block change it was confirming waits a period longer.
    pub read_held: bool,
    /// The line runs as designed this period (`false`: a longer echo delay, a late period,
    /// a lagging sample sequence or a replayed line, [`crate::echo::DelayReading`]). The
    /// lead acts only on a nominal line: its window assumes the command acts within
    /// [`super::LookAheadConfig::command_delay_s`].
    pub line_nominal: bool,
    /// The period's force sample.
    pub force: ForceSample,
    /// The force reference the law regulates to, N (the shop layer's tool Fr; `None`: the
    /// one in force stays). The cap inside a profiled row targets it. Ignored unless finite
    /// and > 0.
    pub force_ref_n: Option<f64>,
    /// The control period T, s.
    pub period_s: f64,
}

impl LookAheadInput {
    /// The input of a period that read `status` (`None`: the read failed) with force
    /// sample `force`, period `period_s` (s): no guard, a nominal line, the Fr in force.
    pub fn new(status: Option<BoardStatus>, force: ForceSample, period_s: f64) -> Self {
        LookAheadInput {
            status,
            raw_block: None,
            read_held: false,
            line_nominal: true,
            force,
            force_ref_n: None,
            period_s,
        }
    }
}

/// The measured force and the plan disagree (docs/plan.md, "Disagreement").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Disagreement {
    /// Measured above the plan's band: more engagement than planned.
    Above,
    /// Measured below the plan's band: less engagement than planned.
    Below,
}

/// What the look-ahead decided in one period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LookAheadStep {
    /// The cap on the command from the plan, percent (`None`: no cap).
    pub cap_pct: Option<u16>,
    /// Estimated path position on the plan, mm (`None`: not located).
    pub position_mm: Option<f64>,
    /// A persistent disagreement between the plan and the measured force.
    pub disagreement: Option<Disagreement>,
    /// The board's block is not in the plan (or the board reports none).
    pub lost: bool,
    /// The plan explains a force drop this period: its force band reaches air (the tool may
    /// be leaving the material) or the measured force is inside it, and the measured force
    /// has not been above the plan. The breakage watch does not judge such a period
    /// ([`crate::FaultPolicy::set_exit_planned`]): a broken tool's force falls below the
    /// plan's band, a spike rises above it.
    pub exit_planned: bool,
    /// The plan's lead ([`super::lead`]), percent: while the tool cuts and the plan and
    /// the measurement agree, the period's command (it replaces the cap and the law's
    /// command; the shop layer's limits still bound it).
    pub lead_pct: Option<u16>,
}

impl LookAheadStep {
    /// Add this step's run-log flags to `r`: `plan_cap:<pct>` (the look-ahead's cap; not in
    /// force in a period with a lead), `plan_lead:<pct>` (the plan's lead: the command),
    /// `plan_disagree:above` / `plan_disagree:below`, `plan_lost`.
    pub fn flag_onto(&self, r: &mut crate::record::RunRecord) {
        if let Some(c) = self.cap_pct {
            r.flag(&format!("plan_cap:{c}"));
        }
        if let Some(l) = self.lead_pct {
            r.flag(&format!("plan_lead:{l}"));
        }
        match self.disagreement {
            Some(Disagreement::Above) => r.flag("plan_disagree:above"),
            Some(Disagreement::Below) => r.flag("plan_disagree:below"),
            None => {}
        }
        if self.lost {
            r.flag("plan_lost");
        }
    }
}

/// The look-ahead state between periods.
#[derive(Debug, Clone)]
pub struct LookAhead {
    /// The cutting plan the tool follows.
    pub(super) plan: Plan,
    /// The tuning (Fr follows the tool's: [`LookAheadInput::force_ref_n`]).
    pub(super) cfg: LookAheadConfig,
    /// For each row, the index of the last row of its block visit.
    pub(super) visit_end: Vec<usize>,
    /// First row of the visit the tool is in.
    pub(super) visit: Option<usize>,
    /// The block reported last (`None`: none yet, or a v1 board).
    pub(super) last_block: Option<u16>,
    /// The tool and program of the last period (`TOOL_NUMBER`, `PROGRAM_NUMBER`): the plan's
    /// scale is per tool and program.
    pub(super) last_tool_program: Option<(u16, u16)>,
    /// Estimated path position on the plan, mm.
    pub(super) x_mm: f64,
    /// The position's uncertainty, ± mm (set at a block's start).
    pub(super) unc_mm: f64,
    /// Periods in a row the measured force was above the plan's band.
    pub(super) above: u32,
    /// Periods in a row the measured force was below the plan's band.
    pub(super) below: u32,
    /// The last period's decision.
    pub(super) last: LookAheadStep,
    /// The commands written in the last two periods, percent (a command written may not
    /// be in `OVERRIDE_APPLIED` yet: the board's echo delay).
    pub(super) written: [u16; 2],
    /// Path of the period before, mm.
    pub(super) dx_prev_mm: f64,
    /// The plan's scale for the lead.
    pub(super) scale: PlanScale,
    /// The lead's choice between two grid positions.
    pub(super) lead: PlanLead,
    /// The line runs as designed ([`LookAheadInput::line_nominal`] of the last period).
    pub(super) line_nominal: bool,
    /// `OVERRIDE_APPLIED` at the read before, percent (`None` after a missed read, a feed
    /// hold or a lost tool: the next period is not steady).
    pub(super) applied_prev: Option<u16>,
    /// Bound on the drift of the integrated position since it was last set on a block's
    /// start, mm: half a unit of the register per period whose path is taken from it, a
    /// whole period's path per period the line was not as designed; at a block change at
    /// most the distance to the far end of the block start's reach.
    pub(super) drift_mm: f64,
    /// `ACTUAL_FEED` has shown the new feed in the period an override change took effect
    /// in: the register is not the period's mean, and the window allows a whole period's
    /// path for the drift.
    pub(super) instantaneous_feed: bool,
    /// The plan's scale last confirmed for the tool in force (an earlier cut's), −.
    pub(super) tool_scale: Option<f64>,
    /// The last periods, for how far the tool can be past a block's start.
    pub(super) recent: RecentPeriods,
    /// Periods since the last read whose raw block number was the block reported then.
    pub(super) since_old: u32,
    /// The line guard held this period's read ([`LookAheadInput::read_held`]).
    pub(super) held: bool,
}

impl LookAhead {
    /// A look-ahead on `plan` (at least one row: [`Plan::load`] refuses an empty one).
    pub fn new(plan: Plan, cfg: LookAheadConfig) -> Self {
        let n = plan.rows.len();
        let mut visit_end = vec![0; n];
        for i in (0..n).rev() {
            visit_end[i] = if i + 1 < n && plan.rows[i + 1].block == plan.rows[i].block {
                visit_end[i + 1]
            } else {
                i
            };
        }
        let scale = PlanScale::new(&cfg);
        LookAhead {
            plan,
            cfg,
            visit_end,
            visit: None,
            last_block: None,
            last_tool_program: None,
            x_mm: 0.0,
            unc_mm: 0.0,
            above: 0,
            below: 0,
            last: LookAheadStep::default(),
            written: [0; 2],
            dx_prev_mm: 0.0,
            scale,
            lead: PlanLead::default(),
            line_nominal: true,
            applied_prev: None,
            drift_mm: 0.0,
            instantaneous_feed: false,
            tool_scale: None,
            recent: RecentPeriods::default(),
            since_old: 0,
            held: false,
        }
    }

    /// A period passed without a status read (a failed read, or a period the driver
    /// skipped): the tool went on at about the last period's path, so the position moves
    /// by it and its uncertainty grows by it; the plan's scale starts again.
    pub fn missed(&mut self) {
        self.recent.push(None, 0.0, self.line_nominal);
        self.since_old = self.since_old.saturating_add(1);
        self.applied_prev = None;
        self.x_mm += self.dx_prev_mm;
        self.unc_mm += self.dx_prev_mm;
        self.scale.clear();
        self.lead.reset();
    }

    /// The loop wrote `cmd_pct` (percent) this period: until the board applies it, the tool
    /// may move at it, so the walk ahead counts the last two commands written with the
    /// override in force.
    pub fn note_written(&mut self, cmd_pct: u16) {
        self.written = [cmd_pct, self.written[0]];
    }

    /// The plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The last step's decision.
    pub fn last(&self) -> LookAheadStep {
        self.last
    }

    /// One period (docs/plan.md, "The look-ahead"): where the tool is on the plan, whether
    /// the measured force agrees with the plan, the lowest planned override ahead (the
    /// cap), and, with the lead, the command from the plan's force ahead.
    pub fn step(&mut self, input: &LookAheadInput) -> LookAheadStep {
        self.take_line_state(input);
        let Some(s) = input.status.as_ref() else {
            return self.read_failed();
        };
        let raw = self.count_since_old_block(s, input.raw_block);
        self.forget_scale_of_another_tool(s);
        if !s.is_v2() || s.block_number == 0 {
            return self.no_block_reported();
        }
        self.remember_period(s);
        let dx = self.advance_position(s, input.period_s);
        self.locate_block(s, raw, dx, input.period_s);
        if self.visit.is_none() {
            return self.block_not_in_plan();
        }
        let at = self.located(s, dx);
        let judged = self.judge(&input.force, s, &at);
        let cap_pct = self.plan_cap(&at, &judged);
        let entry = self.entry(cap_pct, &at, &judged, s, input.period_s);
        let cap_pct = Entry::lift(cap_pct, entry);
        self.update_scale(&at, &judged);
        let entry_lead = self.entry_lead(entry, s, input.period_s);
        self.remember_tool_scale(&judged, s);
        let lead_pct = self.lead_or_entry(&at, &judged, s, entry_lead, input.period_s);
        self.last = LookAheadStep {
            cap_pct,
            position_mm: Some(at.x),
            disagreement: judged.disagreement,
            lost: false,
            exit_planned: judged.exit_planned,
            lead_pct,
        };
        self.last
    }

    /// The line's state this period from `input`: whether it runs as designed, whether the
    /// guard held the read, and the tool's Fr (kept while none is given).
    fn take_line_state(&mut self, input: &LookAheadInput) {
        self.line_nominal = input.line_nominal;
        self.held = input.read_held;
        if let Some(fr) = input.force_ref_n.filter(|f| f.is_finite() && *f > 0.0) {
            self.cfg.force_ref_n = fr;
        }
    }

    /// Nothing read: the last cap stays (the policy holds the command anyway), the tool
    /// went on at about the last period's path, now uncertain ([`LookAhead::missed`]), and
    /// no lead.
    fn read_failed(&mut self) -> LookAheadStep {
        self.missed();
        self.last.lead_pct = None;
        self.last
    }

    /// A v1 board or block number 0: no block to locate the tool by. The tool is lost and
    /// the next period is not steady.
    fn no_block_reported(&mut self) -> LookAheadStep {
        self.recent.push(None, 0.0, self.line_nominal);
        self.scale.clear();
        self.applied_prev = None;
        self.visit = None;
        self.last_block = None;
        self.last = LookAheadStep {
            lost: true,
            ..LookAheadStep::default()
        };
        self.last
    }

    /// The block reported is not in the plan: lost, no cap until a known block.
    fn block_not_in_plan(&mut self) -> LookAheadStep {
        self.scale.clear();
        self.last = LookAheadStep {
            lost: true,
            ..LookAheadStep::default()
        };
        self.last
    }
}
