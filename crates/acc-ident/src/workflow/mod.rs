//! The discrepancy workflow: locate, fit candidates, select by held-out prediction,
//! check the sealed final part.
//!
//! Files: [`spindle`] (the spindle's power law calibrated from the log before effects are
//! judged), [`selection`] (fits and rounds), [`checks`] (statistics of a replay),
//! [`report`] (assembly) and [`explain`] (the text).

mod checks;
mod explain;
mod extra;
mod model_error;
pub mod path_shift;
mod report;
mod rows;
mod sealed_rule;
mod selection;
mod spindle;
mod verdict;

use checks::*;
use explain::*;
use extra::*;
pub use model_error::MODEL_ERROR_MIN_SEGMENTS;
pub use path_shift::estimate_path_shift;
use report::*;
use rows::*;
pub use sealed_rule::{
    block_withholds, made_materially_worse, sealed_gain, worse_by, SEALED_GAIN_SHARE,
};
pub use selection::WEAR_SIZE;
use selection::*;
use verdict::*;

use crate::effects::EffectKind;
use crate::fit::{self, Free};
use crate::model::{Channel, Model};
use crate::replay::{replay, ForcePowerConsistency, Inputs, ReplayError};
use crate::report::{
    Ambiguity, CandidateResult, Encompassing, InputInfo, Locate, Metrics, ModelError, Report,
    Round, Sealed, SignalCorrelation, Unexplained, Withheld, SCHEMA_VERSION,
};
use crate::runlog::RunLog;
use crate::segment::{label_rows, rounding_bias, segment_biases, segments, PracticalSize, Segment};
use crate::stats::{self, correlation, lag1, mean, n_eff, normal_quantile, Noise};

use acc_core::RangeError;

/// Workflow settings. The default is the configuration the twin's evaluation measures
/// (docs/twin.md: its false discoveries, recovery and coverage): the whole library, the
/// effect-to-noise floor, the strict rules where the replay is exact.
#[derive(Debug, Clone)]
pub struct Options {
    /// Contiguous cross-validation folds over the selection part. Default 5.
    pub folds: usize,
    /// Fraction of the log (at its end) sealed away from selection. Default 0.2.
    pub sealed_fraction: f64,
    /// Family-wise significance level. Default 0.05.
    pub alpha: f64,
    /// At most this many effects are added (greedy forward selection). Default 3.
    pub max_effects: usize,
    /// Length of the entry / depth-change / override-step regimes, s. Default 1.0.
    pub transient_s: f64,
    /// Segments shorter than this are not bias-tested, s. Default 1.0.
    pub min_segment_s: f64,
    /// Smallest held-out MSE reduction that counts, % of the base model's. Default 5.
    pub min_gain_pct: f64,
    /// Below this effect-to-noise ratio ([`crate::report::CandidateResult::effect_to_noise`]:
    /// the change the candidate makes to the prediction against the noise, the log's
    /// rounding and the model error it leaves) a candidate is named only if no other
    /// candidate passes in its round and no effect is in the model yet (a second name
    /// must exceed it); where the replay is not exact and `withhold_on_structure` is
    /// `Some(true)`, not at all. Default [`MIN_EFFECT_TO_NOISE`] (1). Below the noise a structure is
    /// matched about equally by several effects' shapes (the tooth-level force replayed by
    /// the mean model — ENR 1–2 — passed as `tool_wear`, `sensor_gain_drift`,
    /// `depth_exponent` and `ks_step` at once, and the encompassing test picked one), so a
    /// name there is not a measurement.
    pub min_effect_to_noise: f64,
    /// Fit the speed exponent γ with every candidate when the cutting speed varies.
    /// Default false.
    pub fit_speed_exponent: bool,
    /// Candidate effects. Default: the whole library, [`EffectKind::ALL`] (a candidate the
    /// log cannot separate is skipped with the reason, e.g. a gain drift on a log without
    /// air early and late).
    pub candidates: Vec<EffectKind>,
    /// The workpiece the log was cut on and the tool-centre position when it began, mm:
    /// a plant replay ([`crate::replay::Inputs::plant`]) then takes the engagement from
    /// the simulator's workpiece inside each period instead of the logged depths.
    /// Default none.
    pub workpiece: Option<(acc_sim::Workpiece, f64)>,
    /// With `workpiece`: start the replayed tool where the log says its first period began
    /// ([`crate::runlog::RunLog::path_start_mm`]: the first row's position less its travel — for a
    /// production log read with `--x0-mm`, a period of feed before it; for a simulator's
    /// log its true start) instead of at the given position. Default off.
    pub anchor_to_log: bool,
    /// With `workpiece`: estimate where the replayed tool started from the log's entries
    /// and depth changes (the [`estimate_path_shift`] search around the start given above)
    /// and analyse the log moved there when the estimate fits clearly better
    /// ([`crate::report::Report::path_shift`] says what was found and whether it was
    /// used). For a production log whose `--x0-mm` is not known to a tenth of a
    /// millimetre. Default off.
    pub estimate_path_start: bool,
    /// Withhold a name when structure remains in the residual after its fit (a biased
    /// segment, variance above [`STRUCTURE_VARIANCE_RATIO`] × the noise's, a residual still
    /// following a signal), when the updated model leaves a biased stretch in the sealed
    /// part, or — for tool wear — when a `Ks` rising with cutting time fits within
    /// [`WEAR_TIME_SEPARATION`] residual variances of it (reported "ambiguous" with the
    /// test cut). `Some(true)` (the default): on where the replay is exact — the
    /// simulator's plant on the workpiece (`workpiece` given, a log with the applied
    /// override) — where a correct model leaves only noise. Elsewhere (logged depths, real
    /// machines: a model error remains) the yardstick is that model error: a name is
    /// withheld when the updated model leaves a sealed segment biased beyond the spread of
    /// the selection part's segment biases (`model_error`, [`crate::report::ModelError`]);
    /// structure in the selection part is reported as "unexplained" next to the name, and
    /// the wear/time finding is a note in the conclusion (on real turning logs, whose
    /// removal rate is constant, it would withhold the wear that the measured flank wear
    /// confirms). `None`: none of these rules (the library's tests of other rules).
    pub withhold_on_structure: Option<bool>,
    /// Calibrate the spindle's power law (no-load power, efficiency, copper loss, power
    /// window) from the selection part before effects are judged, on the power channel of
    /// a model without a motor curve (`spindle` calibration, see its module). Default true.
    pub calibrate_spindle: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            folds: 5,
            sealed_fraction: 0.2,
            alpha: 0.05,
            max_effects: 3,
            transient_s: 1.0,
            min_segment_s: 1.0,
            min_gain_pct: 5.0,
            min_effect_to_noise: MIN_EFFECT_TO_NOISE,
            fit_speed_exponent: false,
            candidates: EffectKind::ALL.to_vec(),
            workpiece: None,
            anchor_to_log: false,
            estimate_path_start: false,
            withhold_on_structure: Some(true),
            calibrate_spindle: true,
        }
    }
}

/// The effect-to-noise floor of [`Options::default`], −.
pub const MIN_EFFECT_TO_NOISE: f64 = 1.0;

/// The replay's inputs from `log` for `model`, with the engagement of `opts.workpiece`
/// (anchored to the log's first path position under `opts.anchor_to_log`).
fn inputs(model: &Model, log: &RunLog, opts: &Options) -> Result<Inputs, WorkflowError> {
    let mut inp = Inputs::from_log(log, model)?;
    if let (Some((wp, _)), Some(start)) = (&opts.workpiece, path_shift::given_start_mm(log, opts)) {
        inp.use_workpiece(wp.clone(), start);
    }
    Ok(inp)
}

/// The residual (measured − predicted, every row) of `model` with its calibration — the
/// nuisance parameters every analysis refits (`Ks` scale, on the power channel the no-load
/// offset) — refitted on the whole log: the part of a discrepancy that a recalibration
/// cannot absorb. The twin's evaluation sizes hidden effects by it
/// ([`crate::twin::calibrated_effect_to_noise`]).
pub fn calibrated_residual(
    model: &Model,
    log: &RunLog,
    opts: &Options,
) -> Result<Vec<f64>, WorkflowError> {
    let inp = inputs(model, log, opts)?;
    let rows: Vec<usize> = (0..inp.len()).collect();
    let nuis = nuisance(&inp, opts.fit_speed_exponent);
    let f = fit::fit(model, &nuis, &[], &inp, &rows);
    let r = replay(&f.model, &inp);
    Ok(rows
        .iter()
        .map(|&i| inp.measured[i] - r.predicted[i])
        .collect())
}

/// Errors of the workflow.
#[derive(Debug, thiserror::Error)]
pub enum WorkflowError {
    /// Inputs could not be prepared.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// The log is too short for the folds and the sealed part.
    #[error(
        "the log has {rows} rows; at least {needed} are needed for {folds} folds and a sealed part"
    )]
    TooShort {
        /// Rows in the log.
        rows: usize,
        /// Rows needed.
        needed: usize,
        /// Folds asked for.
        folds: usize,
    },
    /// Too few rows with a valid measurement on the compared channel.
    #[error(
        "the log has {valid} rows with a valid measurement of {rows}; at least {needed} are needed for {folds} folds and a sealed part (rows left out: {why})"
    )]
    TooFewValid {
        /// Rows with a valid measurement.
        valid: usize,
        /// Rows in the log.
        rows: usize,
        /// Rows needed.
        needed: usize,
        /// Folds asked for.
        folds: usize,
        /// The rows left out, per reason with their lines.
        why: String,
    },
    /// An option is out of range (the key is the [`Options`] field).
    #[error("{0}")]
    BadOption(acc_core::RangeError),
    /// The log's values cannot be analysed (non-finite, a dead channel, time order).
    #[error(transparent)]
    BadLog(#[from] crate::runlog::RunLogError),
}

/// Time series for plots.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Measured channel.
    pub measured: Vec<f64>,
    /// Nominal model (as given).
    pub nominal: Vec<f64>,
    /// Updated model.
    pub updated: Vec<f64>,
    /// Name of the signal the nominal residual correlates with most.
    pub strongest_signal: String,
    /// That signal.
    pub signal: Vec<f64>,
    /// Flagged (significantly biased) stretches of the nominal model, (start, end) s.
    pub flagged: Vec<(f64, f64)>,
    /// Start of the sealed part, s.
    pub sealed_from_s: f64,
    /// Per-segment sealed-part bias, nominal and updated: (mid time s, nominal, updated).
    pub sealed_bias: Vec<(f64, f64, f64)>,
}

/// Result of [`analyse`].
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The report (`report.json`).
    pub report: Report,
    /// The updated model with effects as fitted deltas (use [`Model::folded`] to write it).
    pub updated: Model,
    /// Series for plots.
    pub series: Series,
}

struct Ctx<'a> {
    inp: &'a Inputs,
    sel: Vec<usize>,
    folds: Vec<std::ops::Range<usize>>,
    /// The logged force against the estimator's output on the logged power over the
    /// selection rows ([`Prepared::force_vs_power`]).
    force_vs_power: Option<ForcePowerConsistency>,
}

/// Run the whole workflow on one log: replay, residuals, candidate effects, selection, sealed check, report.
///
/// Locate (nominal residual, noise, segments, correlations) → for each round of greedy
/// forward selection, fit every applicable candidate jointly with the nominal parameters
/// it can be confused with (`Ks`, and the no-load power on the power channel), score it by
/// contiguous-fold held-out prediction, and accept the best one that (a) improves at least
/// `folds − 1` folds, (b) is significant after a Bonferroni correction over the
/// candidates, (c) has a 95 % interval excluding its null, and (d) removes its residual
/// signature → unexplained check → sealed-part comparison.
///
/// The stages are the private functions below, in order: `check_options`, `Prepared::new`
/// (split and locate), `spindle::calibrate` (on the power channel of a model without a
/// motor curve: no-load power, efficiency, copper loss and power window from the selection
/// part, then `Prepared::new` again on the calibrated model, adopted when the model's
/// spindle inflates the noise), `Selection::nominal` (nominal refit), `Selection::run` (rounds of
/// `screen_candidate` and `choose_best`), `ResidualCheck::run` (unexplained),
/// `sealed_check` and `assemble` (report).
pub fn analyse(model: &Model, log: &RunLog, opts: &Options) -> Result<Analysis, WorkflowError> {
    check_options(opts)?;
    log.validate(std::path::Path::new("log"))?;
    let mut warnings = log.unit_warnings();
    // Split at gaps longer than two periods and analyse the longest piece: a run is never
    // joined across a gap (the plant state, the wear clock and the noise are not
    // continuous there).
    let gaps = log.gaps(2.0);
    if !gaps.is_empty() {
        let mut cuts = vec![0];
        cuts.extend(gaps.iter().map(|g| g.0));
        cuts.push(log.len());
        let (a, b) = cuts
            .windows(2)
            .map(|w| (w[0], w[1]))
            .max_by_key(|(a, b)| b - a)
            .unwrap_or((0, log.len()));
        let list: Vec<String> = gaps
            .iter()
            .map(|(i, g)| {
                format!(
                    "line {} (`t_s` {} after {}: a gap of {g:.3} s)",
                    i + 2,
                    log.t_s[*i],
                    log.t_s[*i - 1]
                )
            })
            .collect();
        let mut o = opts.clone();
        if a > 0 {
            // The plant replay starts at the piece: its engagement comes from the logged
            // depths (the workpiece position at the gap is not known).
            o.workpiece = None;
        }
        let mut an = analyse(model, &log.slice(a..b), &o)?;
        an.report.warnings.insert(
            0,
            format!(
                "time gaps longer than 2 periods at {}: the log was split there and only \
                 lines {}..={} (the longest piece, {} rows) were analysed; pieces are never \
                 joined across a gap",
                list.join(", "),
                a + 2,
                b + 1,
                b - a
            ),
        );
        return Ok(an);
    }
    // Where the tool started, when the log's start is not known to a tenth of a mm.
    let start_shift = match (&opts.workpiece, opts.estimate_path_start) {
        (Some(_), true) => estimate_path_shift(model, log, opts)?,
        _ => None,
    };
    let moved;
    let log = match (&start_shift, &opts.workpiece) {
        (Some(s), Some((wp, _))) if s.adopted => {
            moved = path_shift::shifted(log, s.shift_mm, wp, 0.5 * model.tool.diameter_mm);
            &moved
        }
        _ => log,
    };
    let mut p = Prepared::new(model, log, opts)?;
    // The spindle calibrated from the selection part before effects are judged.
    let calibrated = opts
        .calibrate_spindle
        .then(|| spindle::calibrate(model, &p.inp, &p.nominal_replay, &p.sel))
        .flatten();
    let cal_model;
    let (model, spindle_calibration) = match calibrated {
        Some((m, mut c)) => {
            let pc = Prepared::new(&m, log, opts)?;
            c.noise_sigma = (p.noise0.sigma, pc.noise0.sigma);
            if spindle::inflates_noise(&c) {
                p = pc;
                cal_model = m;
                (&cal_model, Some(c))
            } else {
                (model, None)
            }
        }
        None => (model, None),
    };
    let ctx = Ctx {
        inp: &p.inp,
        sel: p.sel.clone(),
        folds: p.folds.clone(),
        force_vs_power: p.force_vs_power,
    };
    let check = ResidualCheck {
        inp: &p.inp,
        segs: &p.sel_segs,
        q_floor: p.q_floor,
        practical: p.practical(),
        min_len: p.min_len,
        alpha: opts.alpha,
        sigs: &p.sigs,
        sel: &p.sel,
    };
    let mut s = Selection::nominal(model, &p, opts);
    s.run(&p, &ctx, opts);
    withhold_extra_names(&mut s, &p, opts.alpha);

    // Unexplained?
    let upd_replay = replay(&s.base_model, &p.inp);
    let (noise_f, unexplained) = check.run(&s.base_model);

    let sealed = sealed_check(&p, &s.nominal_refit, &upd_replay.predicted, noise_f);
    // Where the replay is not exact, the yardstick of a name is the model error.
    let model_error =
        (opts.withhold_on_structure == Some(true) && !p.replay_is_exact()).then(|| {
            model_error::judge(
                &p,
                &upd_replay.predicted,
                &replay(&s.nominal_refit, &p.inp).predicted,
                noise_f,
                opts.alpha,
            )
        });
    let found = ResidualFindings {
        unexplained,
        sealed,
        model_error,
        noise: noise_f,
    };
    let mut a = assemble(model, p, s, upd_replay, found, opts);
    a.report.warnings.append(&mut warnings);
    a.report.spindle_calibration = spindle_calibration;
    a.report.path_shift = start_shift;
    Ok(a)
}

/// The options [`analyse`] accepts: 2 ..= 20 folds, a sealed fraction in 0.05 ..= 0.5.
fn check_options(opts: &Options) -> Result<(), WorkflowError> {
    if opts.folds < 2 || opts.folds > 20 {
        return Err(WorkflowError::BadOption(RangeError::new(
            "folds",
            opts.folds as f64,
            "2 ..= 20",
        )));
    }
    if !(0.05..=0.5).contains(&opts.sealed_fraction) {
        return Err(WorkflowError::BadOption(RangeError::new(
            "sealed_fraction",
            opts.sealed_fraction,
            "0.05 ..= 0.5",
        )));
    }
    if !(0.0..=10.0).contains(&opts.min_effect_to_noise) {
        return Err(WorkflowError::BadOption(RangeError::new(
            "min_effect_to_noise",
            opts.min_effect_to_noise,
            "0 ..= 10",
        )));
    }
    Ok(())
}

/// The log prepared for selection: inputs, the selection / sealed split, contiguous folds,
/// segments, the nominal replay and its residual, noise and the "locate" part of the report.
struct Prepared {
    /// Model inputs (with the fit prior set around the nominal model).
    inp: Inputs,
    /// Rows in the log.
    n: usize,
    /// End of the selection part (rows `0..n_sel`); the sealed part begins there.
    n_sel: usize,
    /// The selection rows: the valid rows of `0..n_sel`.
    sel: Vec<usize>,
    /// The sealed rows: the valid rows from `n_sel` on.
    sealed_rows: Vec<usize>,
    /// Rows without a valid measurement (in neither part), per reason.
    excluded: Excluded,
    /// (where the last `sealed_fraction` of the rows began, where the sealed part begins),
    /// s: moved back when those rows held no cutting row.
    sealed_moved: Option<(f64, f64)>,
    /// Contiguous folds over the selection rows (ranges of positions in `sel`).
    folds: Vec<std::ops::Range<usize>>,
    /// Shortest segment tested for a bias, rows.
    min_len: usize,
    /// Segments over the whole log, without the rows that have no valid measurement.
    segs: Vec<Segment>,
    /// Segments clipped to the selection part.
    sel_segs: Vec<Segment>,
    /// The nominal model's replay.
    nominal_replay: crate::replay::Replay,
    /// Quantization floor of the noise σ.
    q_floor: f64,
    /// The noise σ measured from the data before the quantization floor; below
    /// `q_floor` the log's rounding, not its noise, sets the residual.
    raw_sigma: f64,
    /// Noise of the nominal residual over the selection part.
    noise0: Noise,
    /// Candidate signals the residual is correlated with.
    sigs: Vec<(String, Vec<f64>)>,
    /// Nominal residual RMS, segment biases and correlations (report section 1).
    locate: Locate,
    /// The logged force against the estimator's output on the logged power over the
    /// selection rows (a force channel estimated from spindle power with `power_w`
    /// logged; the sealed part is not looked at).
    force_vs_power: Option<ForcePowerConsistency>,
}

/// An ambiguous pair and each member's fitted model.
type AmbiguousFits = ((EffectKind, EffectKind), Model, Model);

/// A candidate that passed every criterion: its kind, held-out errors, fit and held-out MSE.
type Scored = (EffectKind, Vec<f64>, crate::fit::Fit, f64);

/// The state of greedy forward selection: the current base model and what was accepted.
struct Selection {
    /// The current base model (nominal refit plus the accepted effects).
    base_model: Model,
    /// Its free parameters.
    base_free: Vec<Free>,
    /// Its fitted parameters.
    base_params: Vec<crate::fit::FittedParam>,
    /// The nominal parameters refitted without effects (the base of round 1).
    nominal_refit: Model,
    /// The model the reported nuisance parameters are relative to.
    params_start: Model,
    /// Accepted effects, in order.
    accepted: Vec<EffectKind>,
    /// The selection's state before each accepted effect was added (fitted without it),
    /// in the same order.
    before: Vec<SelectionState>,
    /// Names after the first withheld because they did not improve the sealed part
    /// ([`extra`]), with the reason.
    withheld_extra: Vec<crate::report::Withheld>,
    /// Unresolved ambiguous pairs.
    ambiguous: Vec<(EffectKind, EffectKind)>,
    /// The two fitted explanations of each ambiguous pair (for the separating test cut).
    ambiguous_models: Vec<AmbiguousFits>,
    /// The rounds, for the report.
    rounds: Vec<Round>,
}

/// The fitted state of a selection between rounds.
#[derive(Clone)]
struct SelectionState {
    model: Model,
    free: Vec<Free>,
    params: Vec<crate::fit::FittedParam>,
    params_start: Model,
}

/// What a selection round compares every candidate with.
struct RoundBase<'a> {
    /// The base model every candidate starts from.
    zero_base: &'a Model,
    /// The base model's free parameters.
    base_free: &'a [Free],
    /// The base model's held-out errors.
    base_cv: &'a [f64],
    /// The base model's residual over the selection rows.
    base_res: &'a [f64],
    /// The base model's held-out MSE.
    mse_base: f64,
    /// Noise of the base model's residual.
    noise: Noise,
    /// Applicable candidates (the Bonferroni factor).
    m: f64,
}

/// The name of the explanation [`wear_or_time`] sets against tool wear in
/// [`crate::report::Ambiguity::effects`] (not an [`EffectKind`]: it is not in the library).
pub const KS_TIME_DRIFT: &str = "ks_time_drift (Ks rising with cutting time, not in the library)";

/// Tool wear is told from a drift linear in cutting time when the time law's sum of
/// squares over the selection rows exceeds the wear's by more than this many residual
/// variances of the wear fit.
pub const WEAR_TIME_SEPARATION: f64 = 25.0;

/// What tells tool wear per removed volume from a `Ks` rising with cutting time.
pub const WEAR_TIME_EXPERIMENT: &str = "a cut whose removal rate changes while it runs — the same feed at two radial depths, or the override held low and then high — so that removed volume and cutting time no longer grow together: wear then grows more slowly per minute where less is removed, a drift in time does not";

/// Tool wear (growth with the removed volume) set against a `Ks` that rises with cutting
/// time instead — e.g. the tool and the part heating up, a coating wearing through: the
/// simulator's `tool.wear.growth_per_min`, not a library effect. In a closed loop that
/// holds the force, the removal rate is nearly constant, so removed volume and cutting
/// time grow together and the two laws are almost the same curve (a `Ks` drift
/// in time was named `tool_wear` on the power channel).
struct WearOrTime {
    /// Sum of squares of the wear model over the selection rows, channel unit².
    sse_wear: f64,
    /// The same for the time law (growth per minute, calibration and the other named
    /// effects refitted).
    sse_time: f64,
    /// The unit the two are compared in: the residual variance of the wear fit,
    /// `sse_wear / (rows − free parameters)`, channel unit².
    scale: f64,
    /// The time law's fitted growth, 1/min of cutting.
    growth_per_min: f64,
    /// The time law's model (for the test cut).
    time_model: Model,
}

/// How the time law compares with the wear ([`WearOrTime::verdict`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum WearTimeVerdict {
    /// The time law leaves more than [`WEAR_TIME_SEPARATION`] residual variances more.
    WearFitsBetter,
    /// Within [`WEAR_TIME_SEPARATION`] of each other.
    Tie,
    /// The time law leaves more than [`WEAR_TIME_SEPARATION`] residual variances less.
    TimeFitsBetter,
}

/// The "unexplained" test of a model's residual over the selection part: segments whose
/// bias is significant (Bonferroni over segments, AR(1) standard error), or a residual
/// variance significantly above the noise (z > 2·z_{1−α/2} and more than 10 % above).
struct ResidualCheck<'a> {
    inp: &'a Inputs,
    segs: &'a [Segment],
    q_floor: f64,
    practical: PracticalSize,
    min_len: usize,
    alpha: f64,
    sigs: &'a [(String, Vec<f64>)],
    sel: &'a [usize],
}

/// Share of a segment's level below which its bias is not of practical size, −: a fifth of
/// what the finest override step (1 %) moves the force by. A model that is off by less
/// changes no decision of the loop or of a plan, however significant the bias is on a long
/// log ([`PracticalSize`]).
pub const PRACTICAL_BIAS_SHARE: f64 = 0.002;

/// Residual variance over the noise's above which structure remains, −.
pub const STRUCTURE_VARIANCE_RATIO: f64 = 2.0;

/// Smallest correlation of the remaining residual with a signal that counts as structure.
pub const STRUCTURE_MIN_R: f64 = 0.3;
