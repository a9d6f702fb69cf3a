//! The oracle row of `acc compare`: what an override law on the board's grid could reach
//! with full knowledge of the engagement ahead — the yardstick for every law's force RMS
//! error, peak force and cycle time.
//!
//! The oracle runs the simulator's own plant ([`Machine`]: override-path delay, feed-drive
//! lag, the process force law of eq. (1) with wear, runout and the tooth model where the
//! scenario has them, the workpiece's engagement, the scenario's breakage event),
//! noise-free, and chooses the override of every control period `T` from the scenario's
//! override grid (`step_pct`, `min_pct ..= max_pct` of its override spec) by trying the
//! candidates on copies of the plant ([`Machine::try_clone`]). It sees the true period-mean
//! force, not a measurement: no sensor noise, no estimator lag. Its rows go through the
//! summary's own code ([`summarize`]: the same attribution of rows to cuts, the same RMS,
//! peak and cycle time). Three figures:
//!
//! - **RMS** ([`Oracle::rms`]): the RMS of `F − Fr` over the rows in cut. Per period the
//!   override that minimises the period's squared error `(F_k − Fr)²`; then, because the
//!   metric is a mean over rows and a law that dwells on well-tracked rows dilutes the
//!   bad ones, up to three Dinkelbach steps (Dinkelbach 1967: `min Σe²/N` through
//!   `min Σ(e² − λ)` with `λ` the last ratio): per period the override minimising
//!   `(e_k² − λ)/Δx_k`, the cost per millimetre of path (`e` in N, `Δx` in mm); the
//!   lowest finished run.
//! - **cycle** ([`Oracle::safe`]): the shortest cycle time with no row above Fr — the
//!   fastest safe feed. Per period the largest grid override whose period-mean force stays
//!   at or below Fr, and from which the grid's lowest override keeps the next period at
//!   or below Fr too (the override delay carries a decision into the next period). Where
//!   even the lowest override exceeds Fr it runs the lowest.
//! - **peak** ([`Oracle::peak_n`]): the lowest peak force of any grid law that is no slower
//!   than the constant safe feed (the feed a programmer without ACC would choose,
//!   [`Scenario::safe_override_pct`]): the smallest level `L` whose fastest `L`-safe run
//!   (the cycle oracle with Fr replaced by `L`) finishes within the constant safe feed's
//!   cycle time, by bisection on `L`. Without the time constraint the lowest peak would be
//!   the grid's lowest step throughout, which says nothing about a law.
//!
//! In what sense it is a bound: every figure is that of an actual override sequence on
//! the grid (it is reachable, by a law that knows the engagement and the plant exactly),
//! optimal period by period on the true plant with the override delay and the feed lag
//! known; it is not proven globally optimal over all sequences (a sequence that gives up
//! one period to gain over several could do better; with the shipped machines' delay
//! 16 ms and lag 8 ms against T = 0.1 s a period's override decides almost all of that
//! period's force). A law measures the force with noise, which on average only adds to
//! its RMS error (`E[(F + n − Fr)²] = (F − Fr)² + σ²`) and to its peak. The cycle figure
//! bounds the laws whose peak stays at or below Fr; a law that exceeds Fr can be faster.
//! What it does not cover: the fault policy (the oracle never trips it), the shop layer's
//! per-tool limits (one Fr for the run, the summary's), the spindle's speed dynamics (the
//! machine's constant-speed spindle). The search assumes the period's force rises with the
//! override (the crossing of Fr is found by bisection, warm-started at the last period's
//! choice); below the crossing a Dinkelbach step tries every position on the 10 % grid, and
//! on the 1 % grid the ten below the crossing and every tenth below them.
//!
//! One search serves every plant ([`OraclePlant`]): a 1-D scenario ([`oracle`], rows
//! attributed to cuts by the workpiece's segments) and an NC program on a stock
//! ([`crate::oracle_program`], rows attributed by force as the program summary does).

use acc_runtime::RunRecord;

use crate::machine::Machine;
use crate::run::RunResult;
use crate::scenario::Scenario;
use crate::summary::{summarize, Attribution, Summary};

/// What the oracle searches on: the plant, which periods count in the RMS, and the
/// summary its runs go through (the same code as the laws' runs).
pub trait OraclePlant: Sync {
    /// The summary of one run.
    type Summary: Send;
    /// The scenario: override grid, control period, time limit.
    fn scenario(&self) -> &Scenario;
    /// A fresh plant at the start of the run.
    fn build_machine(&self) -> Machine;
    /// Whether a period counts in the RMS: `row` is the candidate override's row, `fastest`
    /// the row of the same period at the grid's top override.
    fn in_cut(&self, row: &RunRecord, fastest: &RunRecord) -> bool;
    /// The summary of a run.
    fn summarize(&self, run: &RunResult) -> Self::Summary;
    /// A summary's force RMS error while cutting, N.
    fn rms_n(summary: &Self::Summary) -> f64;
    /// A summary's cycle time, s (`None`: the run did not finish).
    fn cycle_s(summary: &Self::Summary) -> Option<f64>;
    /// The constant safe feed (the peak figure's time budget runs at it), percent.
    fn safe_override_pct(&self) -> u16;
}

/// A 1-D scenario as the oracle's plant: rows attributed to cuts by the workpiece's
/// segments ([`Attribution`]), the per-segment [`Summary`].
struct ScenarioPlant<'a> {
    scenario: &'a Scenario,
    attribution: Attribution,
}

impl OraclePlant for ScenarioPlant<'_> {
    type Summary = Summary;

    fn scenario(&self) -> &Scenario {
        self.scenario
    }

    fn build_machine(&self) -> Machine {
        self.scenario.build_machine()
    }

    fn in_cut(&self, row: &RunRecord, _fastest: &RunRecord) -> bool {
        let i = self.attribution.segment(row.x_true_mm.unwrap_or(0.0));
        self.scenario.workpiece.segments[i].is_cut()
    }

    fn summarize(&self, run: &RunResult) -> Summary {
        summarize(run, self.scenario)
    }

    fn rms_n(summary: &Summary) -> f64 {
        summary.rms_error_cut_n
    }

    fn cycle_s(summary: &Summary) -> Option<f64> {
        summary.cycle_time_s
    }

    fn safe_override_pct(&self) -> u16 {
        self.scenario.safe_override_pct()
    }
}

/// The three oracle figures of a plant, each with the run that reaches it (`S`: the
/// plant's summary, [`OraclePlant::Summary`]).
#[derive(Debug, Clone)]
pub struct Oracle<S = Summary> {
    /// The lowest-RMS run (its RMS error is the RMS figure).
    pub rms: S,
    /// The fastest run with no row above Fr (its cycle time is the cycle figure).
    pub safe: S,
    /// The lowest peak force of a grid law no slower than the constant safe feed, N
    /// (`None`: the constant safe feed does not finish within the scenario's time limit).
    pub peak_n: Option<f64>,
    /// The constant safe feed's cycle time on the noise-free plant (the peak figure's time
    /// budget), s.
    pub peak_budget_s: f64,
    /// The force reference the figures use (the summaries' Fr), N.
    pub force_ref_n: f64,
}

/// Errors of the oracle.
#[derive(Debug, thiserror::Error)]
pub enum OracleError {
    /// The scenario's plant cannot be copied (a spindle model or engagement source without
    /// `boxed_clone`).
    #[error("the scenario's plant cannot be copied for the oracle")]
    NotClonable,
    /// A search thread panicked.
    #[error("an oracle search thread panicked")]
    Panicked,
}

/// Bisections of the peak level (resolution `max(Fr, constant-safe peak)/2⁸`, ≈ 3 N at
/// Fr = 800 N).
const BISECTIONS: usize = 8;

/// Most Dinkelbach steps of the RMS figure (it stops when a step gains less than 0.1 %).
const DINKELBACH_STEPS: usize = 3;

/// The row of a noise-free period `rec` run at override `pct` (percent), with force
/// reference `fr` (N) and state `state`: the true force is the measured one.
pub(crate) fn noise_free_row(
    rec: &crate::PeriodRecord<'_>,
    fr: f64,
    pct: u16,
    state: &str,
) -> RunRecord {
    RunRecord {
        t_s: rec.t_end_s,
        x_true_mm: Some(rec.x_mm),
        radial_depth_mm: Some(rec.radial_depth_mm),
        axial_depth_mm: Some(rec.axial_depth_mm),
        force_n: Some(rec.force_mean_n),
        force_true_n: Some(rec.force_mean_n),
        feed_true_mm_min: Some(rec.feed_mean_mm_min),
        force_ref_n: Some(fr),
        override_cmd_pct: Some(pct),
        override_applied_pct: Some(pct),
        state: state.into(),
        // A program's block and tool at the period's end, 16 bits as the board reports.
        block: rec.path_point.map(|p| (p.block & 0xFFFF) as u16),
        tool: rec.path_point.map(|p| (p.tool & 0xFFFF) as u16),
        ..RunRecord::default()
    }
}

/// Write noise-free rows (the oracle's, the plan follower's) to `path` as CSV, one line
/// per period: `t_s, block, x_true_mm, override_pct, force_n, radial_depth_mm,
/// axial_depth_mm` (the force the period's true mean), to be set against a run's `run.csv`
/// block by block.
pub fn write_trace_csv(rows: &[RunRecord], path: &std::path::Path) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "t_s,block,x_true_mm,override_pct,force_n,radial_depth_mm,axial_depth_mm"
    )?;
    for r in rows {
        writeln!(
            f,
            "{:.3},{},{:.4},{},{:.2},{:.4},{:.4}",
            r.t_s,
            r.block.unwrap_or(0),
            r.x_true_mm.unwrap_or(0.0),
            r.override_cmd_pct.unwrap_or(0),
            r.force_true_n.unwrap_or(0.0),
            r.radial_depth_mm.unwrap_or(0.0),
            r.axial_depth_mm.unwrap_or(0.0)
        )?;
    }
    f.flush()
}

/// One period of the plant with a held override: the copy after it and what the row sees.
struct Trial {
    machine: Machine,
    row: RunRecord,
    /// Path advanced in the period, mm.
    dx_mm: f64,
}

/// The plant, the grid and the metric's bookkeeping.
struct Search<'a, P: OraclePlant> {
    plant: &'a P,
    grid: Vec<u16>,
    period_s: f64,
    fr: f64,
    /// The RMS figure's force ceiling, N: no position above the highest whose row stays at
    /// or below it with the next row at the lowest position too (infinite: no ceiling).
    ceiling_n: f64,
    /// Under the ceiling, also the position held for the period after stays at or below it
    /// (no override whose force over a whole period is above the ceiling: the period mean
    /// of a change, which carries the old override for the command's delay, is not enough).
    per_override: bool,
    max_periods: usize,
}

impl<'a, P: OraclePlant> Search<'a, P> {
    fn new(plant: &'a P, force_ref_n: f64) -> Self {
        let scenario = plant.scenario();
        let spec = scenario.controller.override_spec;
        let step = spec.step_pct.max(1);
        let lo = spec.min_pct.div_ceil(step) * step;
        let grid: Vec<u16> = (lo..=spec.max_pct).step_by(usize::from(step)).collect();
        let period_s = scenario.controller.period_s;
        Search {
            plant,
            grid: if grid.is_empty() { vec![lo] } else { grid },
            period_s,
            fr: force_ref_n,
            ceiling_n: f64::INFINITY,
            per_override: false,
            max_periods: (scenario.max_time_s / period_s).ceil() as usize,
        }
    }

    /// Run one period of a copy of `m` at `pct`.
    fn trial(&self, m: &Machine, pct: u16) -> Result<Trial, OracleError> {
        let mut machine = m.try_clone().ok_or(OracleError::NotClonable)?;
        let x0 = machine.x_mm();
        machine.set_override_input_pct(pct);
        let rec = machine.advance(self.period_s);
        let row = noise_free_row(&rec, self.fr, pct, "oracle");
        let dx_mm = rec.x_mm - x0;
        Ok(Trial {
            machine,
            row,
            dx_mm,
        })
    }

    /// A run from a fresh plant, choosing each period's override with `choose` (given the
    /// plant before the period and the grid index chosen for the period before, returns
    /// the period's trial and its grid index), for at most `max_periods` periods and the
    /// scenario's time limit.
    fn run(
        &self,
        law: &str,
        max_periods: usize,
        mut choose: impl FnMut(&Machine, usize) -> Result<(Trial, usize), OracleError>,
    ) -> Result<RunResult, OracleError> {
        let mut m = self.plant.build_machine();
        let mut rows = Vec::new();
        let mut prev = self.grid.len() - 1;
        while !m.finished() && rows.len() < max_periods.min(self.max_periods) {
            let (t, i) = choose(&m, prev)?;
            rows.push(t.row);
            m = t.machine;
            prev = i;
        }
        Ok(RunResult {
            law: law.into(),
            rows,
            finished: m.finished(),
            volume_mm3: m.volume_mm3(),
            ended_in_feed_hold: false,
        })
    }

    /// The largest grid index whose trial passes `ok` (`None` if none does), assuming
    /// `ok` holds below some index and fails above it (the period's force rises with the
    /// override): galloping from `guess` (the last period's choice), then bisection.
    fn largest_passing(
        &self,
        guess: usize,
        mut ok: impl FnMut(usize) -> Result<bool, OracleError>,
    ) -> Result<Option<usize>, OracleError> {
        let top = self.grid.len() - 1;
        let g = guess.min(top);
        // Bracket: `lo` passes (or is −1), `hi` fails (or is top + 1).
        let (mut lo, mut hi): (isize, isize);
        if ok(g)? {
            lo = g as isize;
            let mut step = 1;
            loop {
                let j = lo + step;
                if j > top as isize {
                    if lo == top as isize || ok(top)? {
                        return Ok(Some(top));
                    }
                    hi = top as isize;
                    break;
                }
                if ok(j as usize)? {
                    lo = j;
                    step *= 2;
                } else {
                    hi = j;
                    break;
                }
            }
        } else {
            hi = g as isize;
            let mut step = 1;
            loop {
                let j = hi - step;
                if j < 0 {
                    lo = -1;
                    break;
                }
                if ok(j as usize)? {
                    lo = j;
                    break;
                }
                hi = j;
                step *= 2;
            }
        }
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if ok(mid as usize)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok((lo >= 0).then_some(lo as usize))
    }

    /// The RMS run: per period the override minimising the squared error of the period's
    /// row (`lambda` `None`), or `(e² − λ)/Δx` (a Dinkelbach step); rows outside the cut
    /// cost 0 (and the fastest override wins the tie). The candidates are the two grid
    /// positions around the crossing of Fr (the largest override with the row at or below
    /// Fr and the next) and the top, and for a Dinkelbach step the slower positions below
    /// the crossing.
    fn rms_run(&self, lambda: Option<f64>) -> Result<RunResult, OracleError> {
        let n = self.grid.len();
        self.run("oracle-rms", usize::MAX, |m, prev| {
            let mut trials: Vec<Option<Trial>> = (0..n).map(|_| None).collect();
            let eval = |i: usize, trials: &mut Vec<Option<Trial>>| -> Result<(), OracleError> {
                if trials[i].is_none() {
                    trials[i] = Some(self.trial(m, self.grid[i])?);
                }
                Ok(())
            };
            eval(n - 1, &mut trials)?;
            let fastest = trials[n - 1]
                .as_ref()
                .map(|t| t.row.clone())
                .ok_or(OracleError::NotClonable)?;
            // Under a ceiling: the highest position whose row stays at or below it and after
            // which the lowest keeps the next row there too (as the cycle figure's run), so
            // that the run slows before an entry it could not otherwise meet.
            let top = if self.ceiling_n.is_finite() {
                let limit = self.largest_passing(prev, |i| {
                    let t = self.trial(m, self.grid[i])?;
                    if t.row.force_n.unwrap_or(0.0) > self.ceiling_n {
                        return Ok(false);
                    }
                    if self.per_override {
                        let held = self.trial(&t.machine, self.grid[i])?;
                        if held.row.force_n.unwrap_or(0.0) > self.ceiling_n {
                            return Ok(false);
                        }
                    }
                    let next = self.trial(&t.machine, self.grid[0])?;
                    Ok(next.row.force_n.unwrap_or(0.0) <= self.ceiling_n)
                })?;
                limit.unwrap_or(0)
            } else {
                n - 1
            };
            if let Some(t) = &trials[n - 1] {
                if !self.plant.in_cut(&t.row, &fastest) {
                    eval(top, &mut trials)?;
                    let t = trials[top].take().ok_or(OracleError::NotClonable)?;
                    return Ok((t, top));
                }
            }
            let cross = self.largest_passing(prev, |i| {
                eval(i, &mut trials)?;
                Ok(trials[i]
                    .as_ref()
                    .is_some_and(|t| t.row.force_n.unwrap_or(0.0) <= self.fr))
            })?;
            let c = cross.unwrap_or(0).min(top);
            let mut best = (f64::INFINITY, top);
            let consider = |i: usize,
                            trials: &mut Vec<Option<Trial>>,
                            best: &mut (f64, usize)|
             -> Result<f64, OracleError> {
                eval(i, trials)?;
                let Some(t) = trials[i].as_ref() else {
                    return Ok(f64::INFINITY);
                };
                let (cost, e2) = if self.plant.in_cut(&t.row, &fastest) {
                    let e2 = (t.row.force_n.unwrap_or(0.0) - self.fr).powi(2);
                    let cost = match lambda {
                        None => e2,
                        Some(l) => (e2 - l) / t.dx_mm.max(1e-9),
                    };
                    (cost, e2)
                } else {
                    (0.0, 0.0)
                };
                if cost < best.0 || (cost == best.0 && i > best.1) {
                    *best = (cost, i);
                }
                Ok(e2)
            };
            for i in [top, (c + 1).min(top), c] {
                consider(i, &mut trials, &mut best)?;
            }
            if lambda.is_some() {
                // Slower rows dilute the rest of the mean: every grid position below the
                // crossing (on a grid finer than 10 %, every 10 % and the ten positions
                // below the crossing).
                let stride = n.div_ceil(16).max(1);
                let mut i = c;
                while i > 0 {
                    i -= 1;
                    if i + stride > c || i % stride == 0 {
                        consider(i, &mut trials, &mut best)?;
                    }
                }
            }
            let t = trials[best.1].take().ok_or(OracleError::NotClonable)?;
            Ok((t, best.1))
        })
    }

    /// The fastest run with no row above `level` (N): per period the largest grid
    /// override whose row stays at or below `level` and after which the lowest override
    /// keeps the next row there too; the lowest override where none does
    /// ([`Search::largest_passing`]: the period's force rises with the override); at most
    /// `max_periods` periods.
    fn safe_run(&self, level: f64, max_periods: usize) -> Result<RunResult, OracleError> {
        let n = self.grid.len();
        self.run("oracle-safe", max_periods, |m, prev| {
            let mut trials: Vec<Option<Trial>> = (0..n).map(|_| None).collect();
            let found = self.largest_passing(prev, |i| {
                let t = self.trial(m, self.grid[i])?;
                if t.row.force_n.unwrap_or(0.0) > level {
                    return Ok(false);
                }
                let next = self.trial(&t.machine, self.grid[0])?;
                let ok = next.row.force_n.unwrap_or(0.0) <= level;
                trials[i] = Some(t);
                Ok(ok)
            })?;
            match found {
                Some(i) => {
                    let t = trials[i].take().ok_or(OracleError::NotClonable)?;
                    Ok((t, i))
                }
                None => Ok((self.trial(m, self.grid[0])?, 0)),
            }
        })
    }
}

/// Compute the oracle of `scenario` with the force reference `force_ref_n` (the summaries'
/// Fr, N).
pub fn oracle(scenario: &Scenario, force_ref_n: f64) -> Result<Oracle, OracleError> {
    let plant = ScenarioPlant {
        scenario,
        attribution: Attribution::new(&scenario.workpiece, scenario.tool.diameter_mm),
    };
    let mut o = oracle_on(&plant, force_ref_n)?;
    o.rms.law = "oracle".into();
    o.safe.law = "oracle".into();
    Ok(o)
}

/// Compute the oracle on `plant` with the force reference `force_ref_n` (the summaries'
/// Fr, N).
pub fn oracle_on<P: OraclePlant>(
    plant: &P,
    force_ref_n: f64,
) -> Result<Oracle<P::Summary>, OracleError> {
    let s = Search::new(plant, force_ref_n);
    // The RMS figure on one thread, the cycle and peak figures on another.
    let (rms, rest) = std::thread::scope(|scope| {
        let rms = scope.spawn(|| rms_figure(&s));
        let rest = safe_and_peak(&s, force_ref_n);
        (rms.join(), rest)
    });
    let rms = rms.map_err(|_| OracleError::Panicked)??;
    let (safe, best_peak, budget) = rest?;
    Ok(Oracle {
        rms,
        safe,
        peak_n: budget.is_finite().then_some(best_peak),
        peak_budget_s: budget,
        force_ref_n,
    })
}

/// The RMS figure of a law whose period force never exceeds `ceiling_n` (N): the same
/// search as [`Oracle::rms`], each period among the positions no higher than the highest
/// whose row stays at or below the ceiling and after which the lowest position keeps the
/// next row there too (the cycle figure's rule, so the run slows before an entry); where
/// even the lowest position exceeds it, the lowest. The free oracle may run the grid step
/// above Fr wherever it is nearer to Fr than the step below; a law held to a peak target
/// (≤ 1.05 Fr at entries and corners) is compared with this figure.
///
/// `per_override`: also every override within the ceiling over a whole period — a
/// position is allowed only where the period after it, at the same position, stays at or
/// below `ceiling_n` too, the rule of a law that never commands an override whose force is
/// above the ceiling (the plan's lead, docs/plan.md). Without it the search may alternate
/// two positions whose upper one is above the ceiling once its period is whole, each
/// period's mean kept under it by the command's delay. Like every figure of the search it
/// is optimal period by period, not a bound over all sequences.
pub fn rms_within_on<P: OraclePlant>(
    plant: &P,
    force_ref_n: f64,
    ceiling_n: f64,
    per_override: bool,
) -> Result<P::Summary, OracleError> {
    let mut s = Search::new(plant, force_ref_n);
    s.ceiling_n = ceiling_n;
    s.per_override = per_override;
    rms_figure(&s)
}

/// The RMS figure: the per-row optimum, then Dinkelbach steps on the ratio `Σe²/N`.
fn rms_figure<P: OraclePlant>(s: &Search<'_, P>) -> Result<P::Summary, OracleError> {
    let mut rms = s.plant.summarize(&s.rms_run(None)?);
    for _ in 0..DINKELBACH_STEPS {
        let lambda = P::rms_n(&rms).powi(2);
        let next = s.plant.summarize(&s.rms_run(Some(lambda))?);
        // A run that stalls (dwells in air before a cut) does not cut the part: not a law.
        if P::cycle_s(&next).is_some() && P::rms_n(&next) < P::rms_n(&rms) * (1.0 - 1e-3) {
            rms = next;
        } else {
            break;
        }
    }
    Ok(rms)
}

/// The cycle figure (the fastest run with no row above Fr) and the peak figure with its
/// time budget (the constant safe feed's cycle on the same plant), s.
fn safe_and_peak<P: OraclePlant>(
    s: &Search<'_, P>,
    force_ref_n: f64,
) -> Result<(P::Summary, f64, f64), OracleError> {
    let safe_run = s.safe_run(force_ref_n, usize::MAX)?;
    let safe = s.plant.summarize(&safe_run);
    // Peak: the constant safe feed's cycle on the same plant is the time budget.
    let pct = s.plant.safe_override_pct();
    let constant = s.run("constant-safe", usize::MAX, |m, _| {
        Ok((s.trial(m, pct)?, 0))
    })?;
    let budget = if constant.finished {
        constant.rows.last().map_or(f64::INFINITY, |r| r.t_s)
    } else {
        f64::INFINITY
    };
    let peak_of = |r: &RunResult| {
        r.rows
            .iter()
            .filter_map(|x| x.force_n)
            .fold(0.0f64, f64::max)
    };
    let cycle_of = |r: &RunResult| {
        if r.finished {
            r.rows.last().map_or(0.0, |x| x.t_s)
        } else {
            f64::INFINITY
        }
    };
    // Bisection on the level L: the fastest L-safe run finishes within the budget at `hi`.
    let mut hi = peak_of(&constant).max(force_ref_n);
    let mut best_peak = peak_of(&constant);
    if cycle_of(&safe_run) <= budget + 1e-9 {
        hi = force_ref_n;
        best_peak = best_peak.min(peak_of(&safe_run));
    }
    if !budget.is_finite() {
        return Ok((safe, f64::NAN, budget));
    }
    let mut lo = 0.0;
    // A run past the budget has failed: stop it there.
    let cap = if budget.is_finite() {
        (budget / s.period_s).ceil() as usize + 1
    } else {
        usize::MAX
    };
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        let r = s.safe_run(mid, cap)?;
        if cycle_of(&r) <= budget + 1e-9 {
            hi = mid;
            best_peak = best_peak.min(peak_of(&r));
        } else {
            lo = mid;
        }
    }
    Ok((safe, best_peak, budget))
}

/// The runs behind [`rms_within_on`]'s figure, for a look period by period (the oracle's
/// override, force and engagement in every row): first the run that minimises each
/// period's squared error under the ceiling `ceiling_n` (N), then the run of each of
/// `steps` Dinkelbach steps, each from the RMS of the run before it, whether or not it
/// lowered the RMS; `per_override` as in [`rms_within_on`].
pub fn rms_within_runs_on<P: OraclePlant>(
    plant: &P,
    force_ref_n: f64,
    ceiling_n: f64,
    steps: usize,
    per_override: bool,
) -> Result<Vec<RunResult>, OracleError> {
    let mut s = Search::new(plant, force_ref_n);
    s.ceiling_n = ceiling_n;
    s.per_override = per_override;
    let mut runs = vec![s.rms_run(None)?];
    for _ in 0..steps {
        let last = runs.last().map(|r| plant.summarize(r));
        let lambda = last.map_or(0.0, |l| P::rms_n(&l).powi(2));
        runs.push(s.rms_run(Some(lambda))?);
    }
    Ok(runs)
}
