//! Look-ahead: the plan ([`crate::plan`]) read by the loop, one step of its decision path
//! ([`crate::ControlLoop::with_lookahead`]). Every period it answers: *where is the tool
//! on the plan, what is the lowest planned override the tool meets before the next
//! command can act, and does the measured force agree with the plan?*
//!
//! **Where the tool is.** The board has no path-position register
//! (`../shared/docs/pmc-board.md`): the position is the path the NC's `ACTUAL_FEED`
//! (protocol v2) covered since the start — in a period whose override applied is the one
//! of the read before and whose path stays in one plan row's feed, that row's programmed
//! feed × the override, exact where the register agrees with it to its rounding
//! (`LookAhead::period_path_mm`) — set on the plan by the block the board reports
//! (`BLOCK_NUMBER`). A new block number is looked up in the plan from the block the tool
//! was in (a program that loops meets a block again): the first visit of it that ends at or
//! after the position. The block began after the last read whose raw block number (before
//! the line guard's confirmation) was still the old one, each period since at most at the
//! top speed of the rows it can have crossed × the highest override in force in it: the
//! tool is at most that reach past the block's start ([`crate::block_start`]). A position
//! within the reach is kept and bounds the drift allowance; any other becomes the middle
//! of the reach, ± half of it (the uncertainty, kept until the next such correction).
//! Without that bound (the run's first block, a late period, more periods than
//! remembered) a position inside the visit is kept, and one outside becomes the block's
//! start plus half the path the register read since the old block was last read, ± that
//! much.
//!
//! **The cap.** The override written now acts after the board's override delay and the
//! feed drive's lag, and holds until the next period's command acts: about one period plus
//! the delay. The cap is the lowest `override_pct` of the plan's feed rows from the
//! position's uncertainty behind the tool to where it can be `horizon_s` ahead. The walk
//! is self-consistent: a row is crossed at its programmed feed × the higher of the override
//! in force now (`OVERRIDE_APPLIED`: the tool keeps it until the new command acts) and the
//! cap found so far (the command written now is at most that; a rapid at its rapid rate).
//! From air, where the override in force is the grid's maximum, the walk reaches as far as
//! the law could drive the tool; in a cut held at 30 % it looks 30 % as far. A row whose
//! force the plan gives as linear along it (`profile` rising or falling: one interval of
//! the planner, the engagement linear between the stock's knots) counts only the part the
//! tool can reach: its cap is the override that gives Fr at the largest force of that part
//! (so the tool enters a corner at the override of the engagement it meets, not of the
//! corner's deepest point); a `flat` row counts its planned override, and so does every
//! row while the measured force is above the plan's band (the plan under-predicts: its
//! shape is not trusted). The walk counts the commands written in the last two periods
//! with the override in force (the board may not apply a command at once), and where the
//! feed changed it starts the change of the period's path behind the position and reaches
//! that much farther: the position integrates `ACTUAL_FEED`, which an NC may report as an
//! instantaneous value rather than the period's mean. The cap only ever lowers the law's
//! command ([`crate::CommandLimits::cap_pct`], applied last in the law's bounds): the
//! plan never raises the override above what the feedback law and the tool limits allow.
//! The one exception is opt-in: the plan's lead ([`crate::plan_lead`],
//! [`LookAheadConfig::lead`]) sets the command while the measurement confirms the plan.
//!
//! **Disagreement.** The plan predicts the period's force at the period's `ACTUAL_FEED`
//! (`force_100_n · (f/f_prog)^β` of the rows the tool crossed in the period, ± the
//! uncertainty). A valid measured force above the band's top by more than `tolerance` ×
//! top + `tolerance_n` for `persist_periods` in a row is [`Disagreement::Above`] (the
//! plan under-predicts: more metal than planned); below the band's bottom likewise is
//! [`Disagreement::Below`] (the plan over-predicts). The measured force wins: the law
//! acts on it in both cases, and while the plan over-predicts its cap is lifted (it would
//! slow the tool for metal that is not there). The run log flags both
//! (`plan_disagree:above`, `plan_disagree:below`), the cap in force (`plan_cap:<pct>`),
//! and a block the plan does not know (`plan_lost`: no cap until a known block).

use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use crate::block_start::RecentPeriods;
use crate::plan::{Plan, PlanRow};
use crate::plan_lead::{highest_within, PlanLead, PlanScale, CUTTING, HIGH, WINDOW_SAMPLES};

/// Half the unit of `ACTUAL_FEED` (a whole number of mm/min): how far the register may be
/// from the period's path feed, mm/min.
const FEED_RESOLUTION_MM_MIN: f64 = 0.5;

/// Tuning of the look-ahead.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LookAheadConfig {
    /// How far ahead the cap looks, s of travel at the override in force or the cap found
    /// so far (default: two control periods, which covers the period, the override delay
    /// and the feed drive's lag of the shipped machines: 16 ms and 8 ms against T = 0.1 s).
    pub horizon_s: f64,
    /// Relative tolerance of the disagreement check, − (default 0.25).
    pub tolerance: f64,
    /// Absolute tolerance of the disagreement check, N (default 5 % of Fr).
    pub tolerance_n: f64,
    /// Periods in a row outside the band before a disagreement is declared (default 3).
    pub persist_periods: u32,
    /// The grid's maximum override, percent (the policy's `max_override_pct`).
    pub max_pct: u16,
    /// The loop's force reference Fr, N: inside a row whose force is linear along it, the
    /// cap is the override that gives Fr at the part the tool can reach.
    pub force_ref_n: f64,
    /// Time from writing a command to the feed following it, s: the board's override delay
    /// plus the feed drive's lag, with margin (default 0.3 T: 30 ms against the shipped
    /// machines' 16 ms + 8 ms at T = 0.1 s). The plan's lead ([`crate::plan_lead`]) judges
    /// every period that can start within it.
    pub command_delay_s: f64,
    /// The plan's lead ([`crate::plan_lead`]) sets the command while the tool cuts and the
    /// plan agrees with the measurement (`--plan-lead`); default `false`: the plan only caps
    /// the law's command.
    pub lead: bool,
}

impl LookAheadConfig {
    /// The defaults for control period `period_s` (s), force reference `force_ref_n` (N)
    /// and the grid's maximum override `max_pct` (%).
    pub fn new(period_s: f64, force_ref_n: f64, max_pct: u16) -> Self {
        LookAheadConfig {
            horizon_s: 2.0 * period_s,
            tolerance: 0.25,
            tolerance_n: 0.05 * force_ref_n,
            persist_periods: 3,
            max_pct,
            force_ref_n,
            command_delay_s: 0.3 * period_s,
            lead: false,
        }
    }
}

/// The measured force and the plan disagree (see the module docs).
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
    /// The plan's lead ([`crate::plan_lead`]), percent: while the tool cuts and the plan and
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
    plan: Plan,
    cfg: LookAheadConfig,
    /// For each row, the index of the last row of its block visit.
    visit_end: Vec<usize>,
    /// First row of the visit the tool is in.
    visit: Option<usize>,
    last_block: Option<u16>,
    /// The tool and program of the last period (`TOOL_NUMBER`, `PROGRAM_NUMBER`): the plan's
    /// scale is per tool and program.
    last_tool_program: Option<(u16, u16)>,
    x_mm: f64,
    unc_mm: f64,
    above: u32,
    below: u32,
    last: LookAheadStep,
    /// The commands written in the last two periods, percent (a command written may not
    /// be in `OVERRIDE_APPLIED` yet: the board's echo delay).
    written: [u16; 2],
    /// Path of the period before, mm.
    dx_prev_mm: f64,
    /// The plan's scale for the lead.
    scale: PlanScale,
    /// The lead's choice between two grid positions.
    lead: PlanLead,
    /// The line runs as designed ([`LookAhead::set_line_nominal`]).
    line_nominal: bool,
    /// `OVERRIDE_APPLIED` at the read before, percent (`None` after a missed read, a feed
    /// hold or a lost tool: the next period is not steady).
    applied_prev: Option<u16>,
    /// Bound on the drift of the integrated position since it was last set on a block's
    /// start, mm: half a unit of the register per period whose path is taken from it, a
    /// whole period's path per period the line was not as designed; at a block change at
    /// most the distance to the far end of the block start's reach.
    drift_mm: f64,
    /// `ACTUAL_FEED` has shown the new feed in the period an override change took effect
    /// in: the register is not the period's mean, and the window allows a whole period's
    /// path for the drift.
    instantaneous_feed: bool,
    /// The plan's scale last confirmed for the tool in force (an earlier cut's), −.
    tool_scale: Option<f64>,
    /// The last periods, for how far the tool can be past a block's start.
    recent: RecentPeriods,
    /// Periods since the last read whose raw block number was the block reported then.
    since_old: u32,
    /// This period's raw block number, before the line guard ([`LookAhead::set_raw_block`]).
    raw_block: Option<u16>,
    /// The line guard held this period's read (the status is the last accepted one).
    held: bool,
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
            scale: PlanScale::default(),
            lead: PlanLead::default(),
            line_nominal: true,
            applied_prev: None,
            drift_mm: 0.0,
            instantaneous_feed: false,
            tool_scale: None,
            recent: RecentPeriods::default(),
            since_old: 0,
            raw_block: None,
            held: false,
        }
    }

    /// A period passed without a status read (a failed read, or a period the driver
    /// skipped): the tool went on at about the last period's path, so the position moves
    /// by it and its uncertainty grows by it; the plan's scale starts again.
    pub fn missed(&mut self) {
        self.recent.push(None, 0.0, self.line_nominal);
        self.since_old = self.since_old.saturating_add(1);
        self.raw_block = None;
        self.applied_prev = None;
        self.x_mm += self.dx_prev_mm;
        self.unc_mm += self.dx_prev_mm;
        self.scale.clear();
        self.lead.reset();
    }

    /// Whether the line runs as designed this period (`false`: the loop measures a longer
    /// echo delay, late periods, a lagging sample sequence or a replayed line,
    /// [`crate::echo::DelayReading`]): the plan's lead only acts on a nominal line, since
    /// its window assumes the command acts within `command_delay_s`.
    pub fn set_line_nominal(&mut self, nominal: bool) {
        self.line_nominal = nominal;
    }

    /// Whether the line guard held this period's read ([`crate::guard`]: the status given
    /// to [`LookAhead::step`] is then the last accepted one, and a block change it was
    /// confirming waits a period longer).
    pub fn set_read_held(&mut self, held: bool) {
        self.held = held;
    }

    /// The block number of this period's raw read, before the line guard confirms a change
    /// ([`crate::guard`]): a new block began after the last read whose raw number was still
    /// the block reported then. Without it, the reported number is taken as the raw one.
    pub fn set_raw_block(&mut self, raw: u16) {
        self.raw_block = Some(raw);
    }

    /// The loop wrote `cmd_pct` (percent) this period: until the board applies it, the tool
    /// may move at it, so the walk ahead counts the last two commands written with the
    /// override in force.
    pub fn note_written(&mut self, cmd_pct: u16) {
        self.written = [cmd_pct, self.written[0]];
    }

    /// The force reference the law regulates to, N (the shop layer's tool Fr): the cap
    /// inside a profiled row targets it. Ignored unless finite and > 0.
    pub fn set_force_ref_n(&mut self, force_ref_n: f64) {
        if force_ref_n.is_finite() && force_ref_n > 0.0 {
            self.cfg.force_ref_n = force_ref_n;
        }
    }

    /// The plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The last step's decision.
    pub fn last(&self) -> LookAheadStep {
        self.last
    }

    /// One period: the status read (`None`: the read failed), the force sample, the
    /// control period `period_s` (s).
    pub fn step(
        &mut self,
        status: Option<&BoardStatus>,
        force: &ForceSample,
        period_s: f64,
    ) -> LookAheadStep {
        let Some(s) = status else {
            // Nothing read: keep the last cap (the policy holds the command anyway); the
            // tool went on at about the last period's path, which is now uncertain; the
            // plan's scale is not confirmed.
            self.missed();
            self.last.lead_pct = None;
            return self.last;
        };
        // The periods since the old block was last read raw (the reported number lags the
        // raw one while the line guard confirms a change). A read the guard held is suspect
        // (a stale frame may show the old block): it never restarts the count.
        let raw = Some(self.raw_block.take().unwrap_or(s.block_number)).filter(|_| !self.held);
        self.since_old = if raw.is_some() && raw == self.last_block {
            0
        } else {
            self.since_old.saturating_add(1)
        };
        // The plan's scale belongs to the tool that was measured in the program that ran: a
        // new tool or program starts again.
        if self.last_tool_program != Some((s.tool_number, s.program_number)) {
            self.last_tool_program = Some((s.tool_number, s.program_number));
            self.scale.clear();
            self.tool_scale = None;
        }
        if !s.is_v2() || s.block_number == 0 {
            self.recent.push(None, 0.0, self.line_nominal);
            self.scale.clear();
            self.applied_prev = None;
            self.visit = None;
            self.last_block = None;
            self.last = LookAheadStep {
                lost: true,
                ..LookAheadStep::default()
            };
            return self.last;
        }
        let v = f64::from(s.actual_feed_mm_min);
        // The highest override that may have been in force this period: the one applied at
        // both reads around it and the commands written that may have acted in it (not
        // known after a failed read or a feed hold, nor from a status the guard held).
        let top_pct = self.applied_prev.filter(|_| !self.held).map(|p| {
            p.max(s.override_applied_pct)
                .max(self.written[0])
                .max(self.written[1])
        });
        self.recent.push(top_pct, v, self.line_nominal);
        // The path the NC reports, whatever the block (the block report lags the feed by
        // the line guard's confirmation).
        let (dx, exact) = self.period_path_mm(s, v, period_s);
        self.x_mm += dx;
        if !self.line_nominal {
            // A late period or a lagging sample: the period's length is not the nominal one.
            self.drift_mm += dx;
        } else if !exact {
            self.drift_mm += FEED_RESOLUTION_MM_MIN * period_s / 60.0;
        }
        let prior = self.last_block;
        if prior != Some(s.block_number) || self.visit.is_none() {
            self.last_block = Some(s.block_number);
            self.visit = self.find_visit(s.block_number, self.visit, self.x_mm);
            if let Some(i) = self.visit {
                let changed = prior.is_some_and(|b| b != s.block_number);
                self.place_at_block_start(i, changed, dx, period_s);
            }
        }
        if raw == Some(s.block_number) {
            // The block reported now is the one read: the next change counts from here.
            self.since_old = 0;
        }
        if self.visit.is_none() {
            self.scale.clear();
            self.last = LookAheadStep {
                lost: true,
                ..LookAheadStep::default()
            };
            return self.last;
        }
        let x = self.x_mm.clamp(0.0, self.plan.length_mm());
        let (disagreement, drop_planned, band) = self.check(force, v, x, dx);
        // The tool may move at the override in force or a command written and not yet
        // applied. The position integrates a feed register that may be an instantaneous
        // value: where the feed changed, it may be off by up to the change of the period's
        // path, so the walk starts that much behind the position and reaches that much
        // farther.
        let in_force = s
            .override_applied_pct
            .max(self.written[0])
            .max(self.written[1]);
        let margin = (dx - self.dx_prev_mm).abs();
        if self.instantaneous_feed {
            // An instantaneous register misses the part of the period at the old feed: the
            // change of the period's path stays in the integrated position.
            self.drift_mm += margin;
        }
        self.dx_prev_mm = dx;
        // While the measurement shows more force than planned, the plan's shape inside a
        // row is not trusted: each row is read at its largest force.
        let shape = self.above == 0 && disagreement != Some(Disagreement::Above);
        let cap_pct = if disagreement == Some(Disagreement::Below) {
            None
        } else {
            self.cap(x, self.unc_mm + margin, in_force, shape)
        };
        let measured = (force.valid && force.force_n.is_finite()).then_some(force.force_n);
        let agree = shape && disagreement.is_none() && self.below == 0;
        // A cut's entry, before its scale is confirmed: the plan's period forces at the
        // tool's scale from its earlier cuts (confirmed where the lead could act) may lift
        // the cap. Entering (the measured force below the cutting share) or in a cut whose
        // scale has not yet disagreed, the force at most the lead's, at the highest of
        // that scale, 1 and every ratio this cut has shown.
        let fr = self.cfg.force_ref_n;
        let entering = measured.is_some_and(|f| f < CUTTING * fr) || self.scale.agrees();
        // (k, window, position) of the entry's cap, for its command below.
        let mut entry = None;
        let cap_pct = match (cap_pct, self.tool_scale) {
            (Some(c), Some(k))
                if self.cfg.lead
                    && self.line_nominal
                    && agree
                    && measured.is_some_and(|f| f <= HIGH * fr)
                    && entering
                    && !s.feed_hold_active
                    && !self.scale.confirmed() =>
            {
                let k = k.max(1.0).max(self.scale.max_ratio().unwrap_or(0.0));
                let (y0, y1, _) = self.window(x, dx, self.unc_mm + margin, in_force);
                let e = self.entry_cap(k, (y0, y1), s.override_step_pct, period_s);
                entry = Some((k, (y0, y1), e));
                Some(e.map_or(c, |e| e.max(c)))
            }
            (c, _) => c,
        };
        // The scale belongs to the cut it was measured in: out of the cut (a force below
        // the cutting share, unless the plan has the tool in the material wherever it can
        // be and the force is at least the band's lowest (> 0) less its relative tolerance;
        // or no valid force), and whenever plan and measurement disagree, it starts again.
        // Such a force (a slow override through light engagement) is the same cut: the
        // period is not judged, so the scale stays confirmed for at most `CONFIRM_PERIODS`.
        let same_cut = |f: f64| {
            f >= CUTTING * fr
                || (band.0 > 0.0
                    && f >= band.0 * (1.0 - self.cfg.tolerance)
                    && self.in_material(x, dx))
        };
        if agree && measured.is_some_and(same_cut) {
            self.scale.update(measured, band, fr);
        } else {
            self.scale.clear();
        }
        // The entry's position is the command (the law's may be low from the stretch
        // before: a corner, an engagement that fell below the cutting share) only once this
        // cut has shown a ratio, judged within the last periods, that agrees with the
        // tool's scale; in air and until then the law's command stands under the cap.
        // Its position is taken again at the highest of the cap's scale and this period's
        // ratio, which may be up to 15 % above the tool's.
        let entry_lead = entry
            .filter(|_| {
                self.tool_scale
                    .is_some_and(|k| self.scale.recent_ratio_agrees_with(k))
            })
            .and_then(|(k, window, e)| match self.scale.max_ratio() {
                Some(r) if r > k => self.entry_cap(r, window, s.override_step_pct, period_s),
                _ => e,
            });
        // The tool's scale for its next entries: confirmed in a period the lead could lead,
        // of a tool the board names (`TOOL_NUMBER` 0 is unknown: a tool change would not
        // show).
        if self.scale.confirmed() && measured.is_some_and(|f| f <= HIGH * fr) && s.tool_number != 0
        {
            self.tool_scale = self.scale.scale();
        }
        // The plan's lead, while the tool cuts and the plan and the measurement agree: the
        // command from the plan's force ahead, scaled by the measurement; it replaces the
        // cap (and the law's command) for the period.
        let lead = match (self.scale.scale(), measured) {
            (Some(k), Some(f))
                if self.cfg.lead
                    && self.line_nominal
                    && !s.feed_hold_active
                    && agree
                    && self.scale.confirmed()
                    && f <= HIGH * fr =>
            {
                self.lead_command(k, x, dx, self.unc_mm + margin, in_force, s, period_s)
            }
            _ => {
                self.lead.reset();
                entry_lead
            }
        };
        self.last = LookAheadStep {
            cap_pct,
            position_mm: Some(x),
            disagreement,
            lost: false,
            exit_planned: drop_planned,
            lead_pct: lead,
        };
        self.last
    }

    /// The window of period starts the command written now can govern, and where the
    /// next period starts, `(y0, y1, here)` in mm: the tool at `x` (mm) having moved `dx`
    /// (mm) this period, the position's uncertainty and feed-change margin `unc_mm` (mm),
    /// the highest override it may move at `in_force_pct` (%). The command acts within
    /// `command_delay_s`, at the override in force until then, and governs one period from
    /// there, so every such period's mean force counts. The position may be off by
    /// `unc_mm` and by the drift allowance of the path integrated from `ACTUAL_FEED`
    /// (`drift_mm`, [`LookAhead::period_path_mm`]; at least one period's path once the
    /// register has shown itself an instantaneous value) either way.
    fn window(&self, x: f64, dx: f64, unc_mm: f64, in_force_pct: u16) -> (f64, f64, f64) {
        let drift = self.drift_allowance(dx);
        let here = x - drift;
        let ahead = self.plan.advance(x, in_force_pct, self.cfg.command_delay_s);
        (here - unc_mm, ahead + unc_mm + drift, here)
    }

    /// The largest of the plan's period-mean forces at override `o` (%) of the periods
    /// starting in `y0 ..= y1` (mm), N: starts evenly over the window and at every row
    /// boundary in it (where a heavy stretch begins).
    fn worst_period_n(&self, y0: f64, y1: f64, o: u16, period_s: f64) -> f64 {
        let plan = &self.plan;
        let rows = &plan.rows[plan.row_at(y0)..=plan.row_at(y1)];
        (0..=WINDOW_SAMPLES)
            .map(|j| y0 + (y1 - y0) * f64::from(j) / f64::from(WINDOW_SAMPLES))
            .chain(rows.iter().map(|r| r.start_mm))
            .filter(|y| (y0..=y1).contains(y))
            .map(|y| plan.period_force_n(y, o, period_s))
            .fold(0.0f64, f64::max)
    }

    /// The plan's lead ([`crate::plan_lead`]) with scale `k` over the [`LookAhead::window`]
    /// of the tool at `x` (mm), on the board's grid from `s`.
    #[allow(clippy::too_many_arguments)]
    fn lead_command(
        &mut self,
        k: f64,
        x: f64,
        dx: f64,
        unc_mm: f64,
        in_force_pct: u16,
        s: &BoardStatus,
        period_s: f64,
    ) -> Option<u16> {
        let (y0, y1, here) = self.window(x, dx, unc_mm, in_force_pct);
        let worst = |o: u16| k * self.worst_period_n(y0, y1, o, period_s);
        let here = |o: u16| k * self.plan.period_force_n(here, o, period_s);
        let fr = self.cfg.force_ref_n;
        let mut lead = self.lead;
        let pick = lead.choose(self.cfg.max_pct, s.override_step_pct, fr, worst, here);
        self.lead = lead;
        pick
    }

    /// The entry's cap ([`crate::plan_lead`], "Entries"): the highest position of the
    /// board's grid of `step_pct` at which every period starting in `y0 ..= y1` (mm, the
    /// [`LookAhead::window`]) is predicted at most the ceiling with scale `k`.
    fn entry_cap(&self, k: f64, (y0, y1): (f64, f64), step_pct: u16, period_s: f64) -> Option<u16> {
        highest_within(self.cfg.max_pct, step_pct, self.cfg.force_ref_n, |o| {
            k * self.worst_period_n(y0, y1, o, period_s)
        })
    }

    /// The disagreement check of the period that ended at `x` (mm), at feed `v` (mm/min),
    /// having moved `dx` (mm).
    /// Also whether the plan explains a force drop this period: its band reaches air (a
    /// row without force), or the valid measured force is inside the band; and the band,
    /// `(lo, hi)` in N at the period's feed.
    fn check(
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

    /// The lowest planned override of the feed rows from `x − unc_mm` to where the tool can
    /// be `horizon_s` later, with `in_force_pct` the highest override the tool may move at
    /// now (in force or written), reading a profiled row's shape when `shape` (`None`:
    /// nothing below the grid's maximum).
    fn cap(&self, x: f64, unc_mm: f64, in_force_pct: u16, shape: bool) -> Option<u16> {
        let rows = &self.plan.rows;
        let mut i = self.plan.row_at(x - unc_mm);
        let mut at = (x - unc_mm).max(rows[i].start_mm);
        let mut left_s = self.cfg.horizon_s;
        let mut cap = u16::MAX;
        // The uncertainty ahead costs no time: the tool may already be there.
        let mut free_mm = 2.0 * unc_mm;
        loop {
            let r: &PlanRow = &rows[i];
            let len = (r.end_mm - at).max(0.0);
            let free = free_mm.min(len);
            // The tool crosses this row at most at the override in force or the cap so far
            // with this row's: `reach(c)` is how far into the row it gets at cap `c`, and
            // the time it spends in the row.
            let reach = |c: u16| {
                let pct = in_force_pct.max(cap.min(c).min(self.cfg.max_pct)).max(1);
                let speed = r.speed_mm_min(pct) / 60.0;
                let t = if speed > 0.0 {
                    (len - free) / speed
                } else {
                    f64::INFINITY
                };
                let to = if t >= left_s {
                    at + free + speed * left_s
                } else {
                    r.end_mm
                };
                (to, t)
            };
            // The row's cap over the part the tool can reach; the reach of the lowest
            // (whole-row) cap gives a first cap, and the reach at that cap the final one:
            // a command at most the final cap moves the tool no farther than was judged.
            let planned = r.cap_for_fr(self.cfg.force_ref_n);
            let (t, row_cap) = if r.rapid {
                (reach(u16::MAX).1, u16::MAX)
            } else if !shape {
                (reach(planned).1, planned)
            } else {
                let c1 = self.row_cap(r, planned, at, reach(planned).0);
                let (to, t1) = reach(c1);
                (t1, self.row_cap(r, planned, at, to))
            };
            cap = cap.min(row_cap);
            free_mm -= free;
            if t >= left_s || i + 1 >= rows.len() {
                break;
            }
            left_s -= t;
            i += 1;
            at = rows[i].start_mm;
        }
        (cap < self.cfg.max_pct).then_some(cap)
    }

    /// The cap of feed row `r` over its part `from_mm ..= to_mm`, percent: `planned`, the
    /// row's planned override for the loop's Fr ([`PlanRow::cap_for_fr`]), where the row's force is not
    /// known inside it (`flat`) or the part holds its largest force; else the override at
    /// which the part's largest force ([`PlanRow::force_100_over_n`]) is Fr,
    /// `100 · (Fr / F)^(1/β)` (seed 002 eq. 1 solved for the feed), at least the planned
    /// override and at most the grid's maximum. The tool's own override limits are the
    /// shop layer's (they join the cap, the lower wins).
    fn row_cap(&self, r: &PlanRow, planned: u16, from_mm: f64, to_mm: f64) -> u16 {
        let f = r.force_100_over_n(from_mm, to_mm);
        if !r.cuts() || f >= r.force_100_n {
            return planned;
        }
        let top = f64::from(self.cfg.max_pct);
        let o = match r.override_for_fr(f, self.cfg.force_ref_n) {
            Some(o) => o.min(top),
            None if f <= 0.0 && self.cfg.force_ref_n > 0.0 => top,
            None => return planned,
        };
        (o.floor() as u16).max(planned)
    }
}

#[path = "lookahead_position.rs"]
mod position;

#[cfg(test)]
#[path = "lookahead_tests.rs"]
mod tests;
