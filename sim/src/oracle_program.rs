//! The oracle ([`crate::oracle`]) on an NC program: the same search, on the plant that runs
//! the program (the scenario's machine with the program's [`ProgramPath`] as its
//! engagement source), with the program summary's attribution of rows to cuts and its
//! figures ([`summarize_program`]).
//!
//! What differs from a 1-D scenario:
//!
//! - **Which rows count.** A program's path has no segments that say where the cuts are;
//!   its summary counts a row as cutting when its force is above 5 % of Fr
//!   ([`is_cutting`]), and the oracle's figures are read through that same summary. In the
//!   search a period counts when its row at the grid's top override is cutting, whatever
//!   override is chosen: a rule on the chosen row's own force would let the search make a
//!   period "air" by slowing until the force drops under 5 % of Fr.
//! - **The constant safe feed** (the peak figure's time budget) is the program's own, from
//!   its plan ([`ProgramPath::safe_override_pct`]), as `acc sim --law constant-safe` runs it.
//! - **What the plant copies cost.** Every trial copies the plant; the program's path,
//!   engagement steps and stock picture are shared behind an `Arc`, so a copy is the
//!   machine's own state (`cargo bench -p acc-sim --bench program_copy`).

use acc_runtime::RunRecord;

use crate::machine::Machine;
use crate::oracle::{oracle_on, Oracle, OracleError, OraclePlant};
use crate::program::ProgramPath;
use crate::program_summary::{is_cutting, summarize_program, ProgramSummary};
use crate::run::RunResult;
use crate::scenario::Scenario;

/// A program run as the oracle summarises it.
#[derive(Debug, Clone)]
pub struct ProgramRun {
    /// The program summary of the run's rows.
    pub summary: ProgramSummary,
    /// Whether the run reached the end of the program.
    pub finished: bool,
}

/// An NC program on the scenario's machine, as the oracle's plant.
pub struct ProgramPlant {
    scenario: Scenario,
    path: ProgramPath,
    safe_pct: u16,
}

impl ProgramPlant {
    /// `path` on `scenario`'s machine, tool and grid (set up as the program runs:
    /// [`ProgramPath::scenario_for`]).
    pub fn new(scenario: &Scenario, path: &ProgramPath) -> Self {
        let scenario = path.scenario_for(scenario);
        let safe_pct = path.safe_override_pct(&scenario);
        ProgramPlant {
            scenario,
            path: path.clone(),
            safe_pct,
        }
    }

    /// The program's constant safe feed, percent (the peak figure's time budget).
    pub fn safe_pct(&self) -> u16 {
        self.safe_pct
    }
}

impl OraclePlant for ProgramPlant {
    type Summary = ProgramRun;

    fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    fn build_machine(&self) -> Machine {
        let mut m = self.scenario.build_machine();
        m.set_engagement_source(Some(Box::new(self.path.clone())));
        m
    }

    fn in_cut(&self, _row: &RunRecord, fastest: &RunRecord) -> bool {
        is_cutting(fastest, self.scenario.controller.force_ref_n)
    }

    fn summarize(&self, run: &RunResult) -> ProgramRun {
        ProgramRun {
            summary: summarize_program(
                &run.rows,
                self.scenario.controller.force_ref_n,
                self.scenario.controller.period_s,
            ),
            finished: run.finished,
        }
    }

    fn rms_n(summary: &ProgramRun) -> f64 {
        summary.summary.rms_error_n
    }

    fn cycle_s(summary: &ProgramRun) -> Option<f64> {
        summary.finished.then_some(summary.summary.cycle_s)
    }

    fn safe_override_pct(&self) -> u16 {
        self.safe_pct
    }
}

/// The oracle of `plant` with its scenario's Fr.
pub fn program_oracle(plant: &ProgramPlant) -> Result<Oracle<ProgramRun>, OracleError> {
    oracle_on(plant, plant.scenario.controller.force_ref_n)
}

/// The highest force of a program summary's rows, N (the largest per-tool peak).
pub fn peak_n(summary: &ProgramSummary) -> f64 {
    summary
        .tools
        .iter()
        .map(|t| t.peak_force_n)
        .fold(0.0, f64::max)
}

/// The oracle's RMS run on `plant` for a grid law whose period force never exceeds
/// `ceiling` × Fr, and with `per_override` no override's force over a whole period either
/// ([`crate::oracle::rms_within_on`]).
pub fn program_rms_within(
    plant: &ProgramPlant,
    ceiling: f64,
    per_override: bool,
) -> Result<ProgramRun, OracleError> {
    let fr = plant.scenario.controller.force_ref_n;
    crate::oracle::rms_within_on(plant, fr, ceiling * fr, per_override)
}

/// The runs of [`program_rms_within`] on `plant`, period by period: the per-period run,
/// then `steps` Dinkelbach steps ([`crate::oracle::rms_within_runs_on`]).
pub fn program_rms_within_runs(
    plant: &ProgramPlant,
    ceiling: f64,
    steps: usize,
    per_override: bool,
) -> Result<Vec<RunResult>, OracleError> {
    let fr = plant.scenario.controller.force_ref_n;
    crate::oracle::rms_within_runs_on(plant, fr, ceiling * fr, steps, per_override)
}

/// A figure's ratio to the oracle's, two decimals, or `-` where either side has none.
pub fn ratio(v: Option<f64>, o: Option<f64>) -> String {
    match (v, o) {
        (Some(v), Some(o)) if o > 0.0 => format!("{:.2}", v / o),
        _ => "-".into(),
    }
}

/// The oracle's figures and a run's ratio to each, as `acc sim --program … --oracle`
/// prints them (`run`: the run's summary, `finished`: whether it reached the end;
/// `within`: the ceiling, × Fr, with [`program_rms_within`]'s run without and with
/// `per_override`).
pub fn report(
    o: &Oracle<ProgramRun>,
    safe_pct: u16,
    run: &ProgramSummary,
    finished: bool,
    within: Option<(f64, &ProgramRun, &ProgramRun)>,
) -> String {
    let o_cycle = ProgramPlant::cycle_s(&o.safe);
    let mut s = format!(
        "oracle force RMS error {:.1} N (a grid law that knows the engagement ahead, noise-free plant; docs/programs.md){}\n",
        o.rms.summary.rms_error_n,
        if o.rms.finished {
            ""
        } else {
            "; its run does not reach the end of the program within the time limit"
        }
    );
    if let Some((ceiling, w, h)) = within {
        let unfinished = |r: &ProgramRun| {
            if r.finished {
                ""
            } else {
                "; its run does not reach the end of the program"
            }
        };
        s += &format!(
            "oracle force RMS error within {ceiling:.2} Fr {:.1} N (the same search, each period at or below {ceiling:.2} Fr where the lowest override allows it){}; RMS/oracle within {ceiling:.2} Fr {}\n",
            w.summary.rms_error_n,
            unfinished(w),
            ratio(Some(run.rms_error_n), Some(w.summary.rms_error_n)),
        );
        s += &format!(
            "oracle force RMS error within {ceiling:.2} Fr per override {:.1} N (the same, and no override whose force over a whole period is above {ceiling:.2} Fr){}; RMS/oracle within {ceiling:.2} Fr per override {}\n",
            h.summary.rms_error_n,
            unfinished(h),
            ratio(Some(run.rms_error_n), Some(h.summary.rms_error_n)),
        );
    }
    s += &match o.peak_n {
        Some(p) => format!(
            "oracle peak {p:.1} N (a grid law no slower than the constant safe feed {safe_pct} %, {:.1} s)\n",
            o.peak_budget_s
        ),
        None => format!(
            "oracle peak -: the constant safe feed {safe_pct} % does not finish within the time limit\n"
        ),
    };
    s += &match o_cycle {
        Some(c) => format!("oracle cycle {c:.1} s (no row above Fr)\n"),
        None => "oracle cycle -: no run with every row at or below Fr finishes\n".into(),
    };
    s += &format!(
        "RMS/oracle {}; peak/oracle {}; cycle/oracle {}\n",
        ratio(Some(run.rms_error_n), Some(o.rms.summary.rms_error_n)),
        ratio(Some(peak_n(run)), o.peak_n),
        ratio(finished.then_some(run.cycle_s), o_cycle),
    );
    s
}

/// Run `law` on the program `path` on `scenario` (already set up for the program:
/// [`ProgramPath::scenario_for`]) on the stepped clock, measuring through the scenario's
/// channel, with the plan's look-ahead when `plan` is given: the runs `acc compare
/// --program` sets against the oracle.
pub fn run_program(
    scenario: &Scenario,
    path: &ProgramPath,
    law: &mut dyn acc_core::OverrideLaw,
    plan: Option<acc_runtime::Plan>,
) -> Result<RunResult, crate::SimError> {
    let lookahead = plan.map(|p| {
        acc_runtime::LookAhead::new(
            p,
            acc_runtime::LookAheadConfig::new(
                scenario.controller.period_s,
                scenario.controller.force_ref_n,
                scenario.policy.max_override_pct,
            ),
        )
    });
    run_program_ahead(scenario, path, law, lookahead)
}

/// [`run_program`] with a look-ahead configured by the caller (the plan's lead, a horizon).
pub fn run_program_ahead(
    scenario: &Scenario,
    path: &ProgramPath,
    law: &mut dyn acc_core::OverrideLaw,
    lookahead: Option<acc_runtime::LookAhead>,
) -> Result<RunResult, crate::SimError> {
    let setup = crate::run::RunSetup {
        shop: crate::run::ShopLayer::Off,
        prepare: Some(&mut |b| b.set_engagement_source(Some(Box::new(path.clone())))),
        lookahead,
        ..crate::run::RunSetup::default()
    };
    crate::run::run(scenario, law, setup)
}
