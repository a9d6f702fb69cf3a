//! The plan follower: what a law that reads the engagement ahead from the plan could reach
//! with the information the board does not give — the tool's exact path position and the
//! plan's scale known in advance. It separates, in the look-ahead's gap to the oracle
//! ([`crate::oracle`]), what the plan cannot predict from what the loop does not know
//! (docs/plan.md, "What the loop does not know").
//!
//! It runs the program's plant (the scenario's machine with the program's [`ProgramPath`],
//! noise-free, as the oracle does) and chooses every period's override as the plan's lead
//! does ([`acc_runtime::lookahead::lead`]), but from the true position:
//!
//! - **The period's force** is the plan's, scaled by `k`: the override in force for the
//!   override path's delay and the feed drive's lag (`delay_s`), then the candidate for the
//!   rest of the period, each stretch path-weighted over the plan rows it crosses at
//!   `force_100 · (o/100)^β` ([`Plan::period_force_n`], seed 002 eq. 1), time-weighted
//!   between the two.
//! - **The ceiling**: the highest grid position whose period force is at most
//!   `ceiling × Fr`; then that position or the one below, whichever brings the running sum
//!   of predicted errors nearer zero (a σ-Δ modulator in force, as the lead), the one below
//!   only within the ceiling too. Where the plan predicts less than 5 % of Fr at the
//!   ceiling's position (air), the grid's top.
//!
//! Its rows go through the program summary ([`summarize_program`]) as the oracle's do: the
//! RMS error is over the rows above 5 % of Fr, on the true force.

use acc_runtime::plan::Plan;
use acc_runtime::RunRecord;

use crate::oracle::noise_free_row;
use crate::program::ProgramPath;
use crate::program_summary::{summarize_program, ProgramSummary};
use crate::scenario::Scenario;

/// What the follower knows and aims at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FollowerConfig {
    /// No period is predicted above this × Fr, −.
    pub ceiling: f64,
    /// The plan's scale `k` (measured force over planned), known in advance, −.
    pub scale: f64,
    /// The override in force acts this long into a period before the new one, s (the
    /// override path's delay plus the feed drive's lag).
    pub delay_s: f64,
}

impl FollowerConfig {
    /// The lead's ceiling (1.03 Fr,
    /// [`acc_runtime::LookAheadConfig::DEFAULT_LEAD_CEILING_SHARE_OF_FR`]), scale `scale`,
    /// the delay of `scenario`'s machine (its override path's delay plus its feed drive's
    /// lag).
    pub fn of(scenario: &Scenario, scale: f64) -> Self {
        let m = &scenario.machine;
        FollowerConfig {
            ceiling: acc_runtime::LookAheadConfig::DEFAULT_LEAD_CEILING_SHARE_OF_FR,
            scale,
            delay_s: m.override_path.delay_s + m.feed_drive.tau_s + m.feed_drive.tau2_s,
        }
    }
}

/// A run of the follower.
#[derive(Debug, Clone)]
pub struct FollowerRun {
    /// The rows (true force, override, position, engagement).
    pub rows: Vec<RunRecord>,
    /// The program summary of the rows.
    pub summary: ProgramSummary,
    /// Whether the run reached the end of the program.
    pub finished: bool,
}

impl FollowerRun {
    /// The highest period-mean true force of the run, N.
    pub fn peak_n(&self) -> f64 {
        self.rows
            .iter()
            .filter_map(|r| r.force_true_n)
            .fold(0.0, f64::max)
    }
}

/// Run `path` on `scenario` (set up as the program runs: [`ProgramPath::scenario_for`]),
/// following `plan` with `cfg`.
pub fn follow_plan(
    scenario: &Scenario,
    path: &ProgramPath,
    plan: &Plan,
    cfg: FollowerConfig,
) -> FollowerRun {
    let sc = path.scenario_for(scenario);
    let fr = sc.controller.force_ref_n;
    let t = sc.controller.period_s;
    let spec = sc.controller.override_spec;
    let step = spec.step_pct.max(1);
    let lowest = spec.min_pct.div_ceil(step).max(1) * step;
    let top_pct = spec.max_pct - spec.max_pct % step;
    let delay = cfg.delay_s.clamp(0.0, t);
    let mut m = sc.build_machine();
    m.set_engagement_source(Some(Box::new(path.clone())));
    let max_periods = (sc.max_time_s / t).ceil() as usize;
    let (mut rows, mut in_force, mut error_sum) = (Vec::new(), top_pct, 0.0);
    while !m.finished() && rows.len() < max_periods {
        let x = m.x_mm();
        let x1 = plan.advance(x, in_force, delay);
        let f_delay = plan.period_force_n(x, in_force, delay);
        let force = |o: u16| {
            cfg.scale * (delay * f_delay + (t - delay) * plan.period_force_n(x1, o, t - delay)) / t
        };
        let mut top = top_pct;
        while top > lowest && force(top) > cfg.ceiling * fr {
            top -= step;
        }
        let pick = if force(top) < 0.05 * fr {
            error_sum = 0.0;
            top_pct
        } else {
            let below = top.saturating_sub(step).max(lowest);
            let e_top = error_sum + force(top) - fr;
            let e_below = error_sum + force(below) - fr;
            let (pick, e) = if force(below) > cfg.ceiling * fr || e_top.abs() <= e_below.abs() {
                (top, e_top)
            } else {
                (below, e_below)
            };
            error_sum = e.clamp(-fr, fr);
            pick
        };
        m.set_override_input_pct(pick);
        in_force = pick;
        let rec = m.advance(t);
        rows.push(noise_free_row(&rec, fr, pick, "plan-follower"));
    }
    let summary = summarize_program(&rows, fr, t);
    FollowerRun {
        rows,
        summary,
        finished: m.finished(),
    }
}
