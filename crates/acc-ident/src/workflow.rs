//! The discrepancy workflow: locate, fit candidates, select by held-out prediction,
//! check the sealed final part.

use crate::effects::EffectKind;
use crate::fit::{self, Free};
use crate::model::{Channel, Model};
use crate::replay::{replay, ForcePowerConsistency, Inputs, ReplayError};
use crate::report::{
    Ambiguity, CandidateResult, Encompassing, InputInfo, Locate, Metrics, Report, Round, Sealed,
    SignalCorrelation, Unexplained, Withheld, SCHEMA_VERSION,
};
use crate::runlog::RunLog;
use crate::segment::{label_rows, segment_biases, segments, Segment};
use crate::stats::{self, correlation, lag1, mean, n_eff, normal_quantile, Noise};

use acc_core::RangeError;

/// Workflow settings.
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
    /// Below this effect-to-noise ratio (RMS of the candidate's contribution to the
    /// prediction over the noise σ) a candidate is named only if no other candidate
    /// passes in its round. Default 0 (off); the twin's evaluation (`twin::run_case`, the
    /// whole library) uses 1. There a structure smaller than the noise is matched about
    /// equally by several effects' shapes (the tooth-level force replayed by the mean
    /// model — ENR 1–2 — passed as `tool_wear`, `sensor_gain_drift`, `depth_exponent` and
    /// `ks_step` at once, and the encompassing test picked one), so a name there is not a
    /// measurement. With the default eight candidates the encompassing test does separate
    /// the confusable dynamics at ENR 0.5 (`feed_drive_lag` 100 % exactly right, the
    /// sweep's 20 runs), which the rule would drop (5 %).
    pub min_effect_to_noise: f64,
    /// Fit the speed exponent γ with every candidate when the cutting speed varies.
    /// Default false.
    pub fit_speed_exponent: bool,
    /// Candidate effects. Default: [`EffectKind::DEFAULT`].
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
    /// Withhold a name when structure remains in the residual after its fit (a biased
    /// segment, variance above [`STRUCTURE_VARIANCE_RATIO`] × the noise's, a residual still
    /// following a signal), when the updated model leaves a biased stretch in the sealed
    /// part, or — for tool wear — when a `Ks` rising with cutting time fits within
    /// [`WEAR_TIME_SEPARATION`] residual variances of it (reported "ambiguous" with the
    /// test cut). `Some(true)`: on when the replay is exact — the simulator's plant on the
    /// workpiece (`workpiece` given, a log with the applied override) — where a correct
    /// model leaves only noise (the twin's evaluation, `twin::run_case`; `acc discrepancy
    /// --strict`). Default `None` = off: logged depths and real machines leave a model
    /// error, reported as "unexplained" next to the name, and the wear/time finding is a
    /// note in the conclusion.
    pub withhold_on_structure: Option<bool>,
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
            min_effect_to_noise: 0.0,
            fit_speed_exponent: false,
            candidates: EffectKind::DEFAULT.to_vec(),
            workpiece: None,
            anchor_to_log: false,
            withhold_on_structure: None,
        }
    }
}

/// The replay's inputs from `log` for `model`, with the engagement of `opts.workpiece`
/// (anchored to the log's first path position under `opts.anchor_to_log`).
fn inputs(model: &Model, log: &RunLog, opts: &Options) -> Result<Inputs, WorkflowError> {
    let mut inp = Inputs::from_log(log, model)?;
    if let Some((wp, x0)) = &opts.workpiece {
        let start = if opts.anchor_to_log {
            log.path_start_mm().unwrap_or(*x0)
        } else {
            *x0
        };
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

/// The nominal parameters every candidate is fitted with: `Ks` always, the no-load power
/// on the power channel, the speed exponent γ when the cutting speed varies by more than
/// 5 % (coefficient of variation over the cutting rows).
fn nuisance(inp: &Inputs, speed_exponent: bool) -> Vec<Free> {
    let mut v = vec![Free::KsScale];
    if inp.channel == Channel::Power {
        v.push(Free::Noload);
    }
    let s: Vec<f64> = (0..inp.len())
        .filter(|&i| inp.is_cut(i))
        .map(|i| inp.spindle_rpm[i])
        .collect();
    let m = mean(&s);
    if speed_exponent
        && m > 0.0
        && stats::rms(&s.iter().map(|x| x - m).collect::<Vec<_>>()) > 0.05 * m
    {
        v.push(Free::SpeedExponent);
    }
    v
}

fn effect_free(kind: EffectKind) -> Vec<Free> {
    kind.params()
        .iter()
        .enumerate()
        .filter(|(_, p)| p.fitted)
        .map(|(i, _)| Free::Effect(kind, i))
        .collect()
}

fn effect_grid(kind: EffectKind) -> Vec<Free> {
    kind.params()
        .iter()
        .enumerate()
        .filter(|(_, p)| p.fitted && p.grid.is_some())
        .map(|(i, _)| Free::Effect(kind, i))
        .collect()
}

/// Effects whose first parameter gets a profile-likelihood interval
/// ([`fit::Fit::profile`]) instead of the Jacobian one: tool wear (the growth per cm³
/// trades off against the curve's exponent; acceptance uses the delta-method interval of
/// [`WEAR_SIZE`]), the no-load drift (ΔP against τ), runout (amplitude against phase) and
/// the delays and time constants.
const PROFILED: [EffectKind; 7] = [
    EffectKind::MeasurementDelay,
    EffectKind::ToolWear,
    EffectKind::NoloadDrift,
    EffectKind::Runout,
    EffectKind::FeedDriveLag,
    EffectKind::SensorLowpass,
    EffectKind::OverrideDeadTime,
];

/// Name of the tool-wear size in reports.
pub const WEAR_SIZE: &str = "tool_wear.ks_growth_over_selection";

/// The size of a fitted tool-wear candidate: the extra relative `Ks` growth it puts on the
/// tool by the end of the selection part, `Δ = (g₀+g)·V_e^p − g₀·V_e^p₀` (`V_e` the removed
/// volume there, cm³; `g₀`, `p₀` the model's own wear law), with a delta-method interval.
/// Growth `g` and exponent `p` trade off against each other (the growth per cm³ is poorly
/// determined far from 1 cm³), while `Δ` is what the data measure; its interval is the one
/// the acceptance test (c) uses for tool wear. `None` for other effects.
fn wear_size(
    kind: EffectKind,
    f: &fit::Fit,
    inp: &Inputs,
    n_sel: usize,
) -> Option<fit::FittedParam> {
    if kind != EffectKind::ToolWear {
        return None;
    }
    let kg = f.free.iter().position(|x| *x == Free::Effect(kind, 0))?;
    let kp = f.free.iter().position(|x| *x == Free::Effect(kind, 1));
    let w = &f.model.tool.wear;
    let (g0, p0) = (w.growth_per_cm3, w.volume_exponent);
    let g = f.theta[kg];
    let p = kp.map_or(p0, |k| f.theta[k]);
    let ve = replay(&f.model, inp)
        .volume_mm3
        .get(n_sel.saturating_sub(1))
        .copied()
        .unwrap_or(0.0)
        / 1000.0;
    let vp = ve.max(1e-12).powf(p);
    let value = (g0 + g) * vp - g0 * ve.max(1e-12).powf(p0);
    let mut grad = vec![0.0; f.free.len()];
    grad[kg] = vp;
    if let Some(k) = kp {
        grad[k] = (g0 + g) * vp * ve.max(1e-12).ln();
    }
    Some(f.derived(WEAR_SIZE.into(), value, &grad, 0.0))
}

/// Prepare a model for fitting `kind`: switch it on at its null (and set the reference
/// feed of the feed exponent to the calibration feed so that it folds into `beta`).
fn with_null(model: &Model, kind: EffectKind) -> Model {
    let mut m = model.clone();
    for (i, p) in kind.params().iter().enumerate() {
        let v = match (kind, i) {
            (EffectKind::FeedExponent, 1) => model.tool.process.calib_feed_mm_min,
            (EffectKind::NoloadDrift, 1) => 300.0,
            (EffectKind::ToolWear, 1) => model.tool.wear.volume_exponent,
            _ => p.null,
        };
        m.effects.set(kind, i, v);
    }
    m
}

struct Ctx<'a> {
    inp: &'a Inputs,
    sel: Vec<usize>,
    folds: Vec<std::ops::Range<usize>>,
    /// The logged force against the estimator's output on the logged power over the
    /// selection rows ([`Prepared::force_vs_power`]).
    force_vs_power: Option<ForcePowerConsistency>,
}

impl Ctx<'_> {
    /// Held-out residuals over the selection rows: each fold predicted by the model
    /// refitted (warm start from `start`) on the other folds.
    fn cv_errors(&self, start: &Model, free: &[Free]) -> Vec<f64> {
        let mut e = vec![0.0; self.sel.len()];
        for fold in &self.folds {
            let train: Vec<usize> = self
                .sel
                .iter()
                .copied()
                .filter(|i| !fold.contains(i))
                .collect();
            let m = fit::refine(start, free, self.inp, &train);
            let r = replay(&m, self.inp);
            for i in fold.clone() {
                e[i] = self.inp.measured[i] - r.predicted[i];
            }
        }
        e
    }

    /// The encompassing test of [`Encompassing`] between `a` (fitted model `a_model`, the
    /// better-scoring one) and `b`, each with its held-out errors alone: `b` is added to
    /// `a`'s fit (grid over `b`'s delays and time constants, then LM on everything), and
    /// the pair's held-out errors are compared with each alone.
    fn encompass(
        &self,
        base_free: &[Free],
        a: (EffectKind, &[f64], &Model),
        b: (EffectKind, &[f64]),
        opts: &Options,
    ) -> Encompassing {
        let start = with_null(a.2, b.0);
        let mut free = base_free.to_vec();
        free.extend(effect_free(a.0));
        free.extend(effect_free(b.0));
        let f = fit::fit(&start, &free, &effect_grid(b.0), self.inp, &self.sel);
        let cv = self.cv_errors(&f.model, &free);
        let mse = |e: &[f64]| mean(&e.iter().map(|x| x * x).collect::<Vec<_>>());
        let gain = |alone: &[f64]| {
            let m0 = mse(alone);
            if m0 > 0.0 {
                100.0 * (m0 - mse(&cv)) / m0
            } else {
                0.0
            }
        };
        let p_a = chi2_sf(heldout_chi2(b.1, &cv), effect_free(a.0).len());
        let p_b = chi2_sf(heldout_chi2(a.1, &cv), effect_free(b.0).len());
        let (g_a, g_b) = (gain(b.1), gain(a.1));
        let adds = |p: f64, g: f64| p < opts.alpha && g >= opts.min_gain_pct;
        let outcome = match (adds(p_a, g_a), adds(p_b, g_b)) {
            (true, false) => "a",
            (false, true) => "b",
            (true, true) => "both",
            (false, false) => "ambiguous",
        };
        Encompassing {
            a: a.0.name().into(),
            b: b.0.name().into(),
            p_a_adds_to_b: p_a,
            p_b_adds_to_a: p_b,
            gain_a_over_b_pct: g_a,
            gain_b_over_a_pct: g_b,
            outcome: outcome.into(),
        }
    }

    fn residual(&self, m: &Model) -> Vec<f64> {
        let r = replay(m, self.inp);
        self.sel
            .iter()
            .map(|&i| self.inp.measured[i] - r.predicted[i])
            .collect()
    }
}

/// Noise from the differenced air and steady-cut stretches of `residual` (rows `0..n`);
/// falls back to 50-row chunks of the whole residual if there are none.
///
/// The result is floored at the resolution of the measured data (`floor`, the σ of
/// uniform quantization `q/√12`), so a quantized noise-free channel is not taken as
/// perfectly known.
fn noise_of(residual: &[f64], segs: &[Segment], n: usize, floor: f64) -> Noise {
    let mut nz = noise_raw(residual, segs, n);
    nz.sigma = nz.sigma.max(floor);
    nz
}

fn noise_raw(residual: &[f64], segs: &[Segment], n: usize) -> Noise {
    use crate::segment::Regime;
    let stretches: Vec<&[f64]> = segs
        .iter()
        .filter(|s| {
            matches!(
                s.regime,
                Regime::Air | Regime::SteadyCut | Regime::OverrideStep
            ) && s.end <= n
        })
        .filter(|s| s.end - s.start >= 8)
        .map(|s| &residual[s.start..s.end])
        .collect();
    let nz = stats::pooled_noise_variogram(&stretches);
    if nz.samples >= 30 && nz.sigma > 0.0 {
        return nz;
    }
    let chunks: Vec<&[f64]> = residual[..n].chunks(50).collect();
    stats::pooled_noise_diff(&chunks)
}

fn signals(inp: &Inputs, nominal: &crate::replay::Replay) -> Vec<(String, Vec<f64>)> {
    let n = inp.len();
    let cmd = inp.feed_cmd_mm_min.as_ref().unwrap_or(&inp.feed_mm_min);
    let diff = |v: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|i| if i == 0 { 0.0 } else { (v[i] - v[i - 1]).abs() })
            .collect()
    };
    let load = match inp.channel {
        Channel::Power => nominal.cut_power_w.clone(),
        Channel::Force => nominal.force_n.clone(),
    };
    let mut out = vec![
        ("time".to_string(), inp.t_s.clone()),
        ("load".to_string(), load),
        ("cut_volume".to_string(), nominal.volume_mm3.clone()),
        ("feed".to_string(), nominal.feed_mm_min.clone()),
        ("feed_change".to_string(), diff(cmd)),
        ("depth_change".to_string(), diff(&inp.radial_depth_mm)),
    ];
    if inp.runout_visibility() >= 0.05 {
        let a = &nominal.spindle_angle_rad;
        out.push((
            "spindle_angle_cos".into(),
            a.iter().map(|x| x.cos()).collect(),
        ));
        out.push((
            "spindle_angle_sin".into(),
            a.iter().map(|x| x.sin()).collect(),
        ));
    }
    out
}

fn correlate(
    residual: &[f64],
    sigs: &[(String, Vec<f64>)],
    rows: &[usize],
    alpha: f64,
) -> Vec<SignalCorrelation> {
    let m = sigs.len().max(1) as f64;
    sigs.iter()
        .map(|(name, v)| {
            let x: Vec<f64> = rows.iter().map(|&i| v[i]).collect();
            let (r, p) = correlation(&x, residual);
            SignalCorrelation {
                signal: name.clone(),
                r,
                p,
                significant: p < alpha / m,
            }
        })
        .collect()
}

fn metrics(
    inp: &Inputs,
    pred: &[f64],
    rows: std::ops::Range<usize>,
    segs: &[Segment],
    noise: Noise,
    min_len: usize,
) -> Metrics {
    let y = &inp.measured[rows.clone()];
    let e: Vec<f64> = rows.clone().map(|i| inp.measured[i] - pred[i]).collect();
    let ym = mean(y);
    let dev = y.iter().map(|v| (v - ym).powi(2)).sum::<f64>().sqrt();
    let en = e.iter().map(|v| v * v).sum::<f64>().sqrt();
    let full: Vec<f64> = (0..inp.len()).map(|i| inp.measured[i] - pred[i]).collect();
    let clipped: Vec<Segment> = segs
        .iter()
        .filter(|s| s.end > rows.start)
        .map(|s| Segment {
            start: s.start.max(rows.start),
            ..*s
        })
        .collect();
    Metrics {
        rms: stats::rms(&e),
        fit_pct: if dev > 0.0 {
            100.0 * (1.0 - en / dev)
        } else {
            0.0
        },
        bias: mean(&e),
        segments: segment_biases(&full, &clipped, &inp.t_s, noise, min_len),
    }
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
/// (split and locate), `Selection::nominal` (nominal refit), `Selection::run` (rounds of
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
    let p = Prepared::new(model, log, opts)?;
    let ctx = Ctx {
        inp: &p.inp,
        sel: p.sel.clone(),
        folds: p.folds.clone(),
        force_vs_power: p.force_vs_power,
    };
    let check = ResidualCheck {
        inp: &p.inp,
        segs: &p.sel_segs,
        n_sel: p.n_sel,
        q_floor: p.q_floor,
        min_len: p.min_len,
        alpha: opts.alpha,
        sigs: &p.sigs,
        sel: &p.sel,
    };
    let mut s = Selection::nominal(model, &p, opts);
    s.run(&p, &ctx, opts);

    // Unexplained?
    let upd_replay = replay(&s.base_model, &p.inp);
    let (noise_f, unexplained) = check.run(&s.base_model);

    let sealed = sealed_check(&p, &s.nominal_refit, &upd_replay.predicted, noise_f);
    let mut a = assemble(model, p, s, upd_replay, unexplained, sealed, opts);
    a.report.warnings.append(&mut warnings);
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
    /// Rows in the selection part (`0..n_sel`); the sealed part is `n_sel..n`.
    n_sel: usize,
    /// The selection rows.
    sel: Vec<usize>,
    /// Contiguous folds over the selection rows.
    folds: Vec<std::ops::Range<usize>>,
    /// Shortest segment tested for a bias, rows.
    min_len: usize,
    /// Segments over the whole log.
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

impl Prepared {
    /// Split the log (selection / sealed, folds) and locate the nominal discrepancy.
    fn new(model: &Model, log: &RunLog, opts: &Options) -> Result<Self, WorkflowError> {
        let mut inp = inputs(model, log, opts)?;
        let n = inp.len();
        let needed = 12 * opts.folds + 20;
        if n < needed {
            return Err(WorkflowError::TooShort {
                rows: n,
                needed,
                folds: opts.folds,
            });
        }
        let n_sel = ((1.0 - opts.sealed_fraction) * n as f64).round() as usize;
        let sel: Vec<usize> = (0..n_sel).collect();
        let fold_len = n_sel / opts.folds;
        let folds: Vec<std::ops::Range<usize>> = (0..opts.folds)
            .map(|k| {
                let a = k * fold_len;
                let b = if k + 1 == opts.folds {
                    n_sel
                } else {
                    a + fold_len
                };
                a..b
            })
            .collect();
        let min_len = ((opts.min_segment_s / inp.period_s.max(1e-9)).round() as usize).max(3);

        // 1. Locate.
        let labels = label_rows(&inp, opts.transient_s);
        let segs = segments(&labels);
        let sel_segs: Vec<Segment> = segs
            .iter()
            .filter(|s| s.start < n_sel)
            .map(|s| Segment {
                end: s.end.min(n_sel),
                ..*s
            })
            .collect();
        let nominal_replay = replay(model, &inp);
        let r0_full: Vec<f64> = (0..n)
            .map(|i| inp.measured[i] - nominal_replay.predicted[i])
            .collect();
        let q_floor = crate::stats::quantization_sigma(&inp.measured);
        let raw_sigma = noise_raw(&r0_full, &sel_segs, n_sel).sigma;
        let noise0 = noise_of(&r0_full, &sel_segs, n_sel, q_floor);
        let sigs = signals(&inp, &nominal_replay);
        inp.prior = Some(crate::fit::Prior::around(model, noise0.sigma.max(1e-9)));
        let locate = Locate {
            residual_rms: stats::rms(&r0_full[..n_sel]),
            segments: segment_biases(&r0_full, &sel_segs, &inp.t_s, noise0, min_len),
            correlations: correlate(&r0_full[..n_sel], &sigs, &sel, opts.alpha),
        };
        let force_vs_power = inp.force_from_power.as_ref().and_then(|(est, floor)| {
            let t0 = inp.t_s.first().copied().unwrap_or(0.0);
            ForcePowerConsistency::of(
                &inp.t_s[..n_sel],
                t0,
                &inp.measured[..n_sel],
                &est[..n_sel],
                *floor,
            )
        });
        Ok(Self {
            inp,
            n,
            n_sel,
            sel,
            folds,
            min_len,
            segs,
            sel_segs,
            nominal_replay,
            q_floor,
            raw_sigma,
            noise0,
            sigs,
            locate,
            force_vs_power,
        })
    }
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
    /// Unresolved ambiguous pairs.
    ambiguous: Vec<(EffectKind, EffectKind)>,
    /// The two fitted explanations of each ambiguous pair (for the separating test cut).
    ambiguous_models: Vec<AmbiguousFits>,
    /// The rounds, for the report.
    rounds: Vec<Round>,
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

impl Selection {
    /// The nominal parameters refitted (the base of round 1).
    fn nominal(model: &Model, p: &Prepared, opts: &Options) -> Self {
        let nuis = nuisance(&p.inp, opts.fit_speed_exponent);
        let base_fit = fit::fit(model, &nuis, &[], &p.inp, &p.sel);
        Self {
            base_model: base_fit.model.clone(),
            // Re-express the refitted model so its free parameters restart at their nulls.
            base_free: nuis.clone(),
            base_params: base_fit.params.clone(),
            nominal_refit: base_fit.model.clone(),
            params_start: model.clone(),
            accepted: Vec::new(),
            ambiguous: Vec::new(),
            ambiguous_models: Vec::new(),
            rounds: Vec::new(),
        }
    }

    /// 2–4. Forward selection: rounds until none passes or `max_effects` are in; an
    /// ambiguity is resolved when both members ended up accepted.
    fn run(&mut self, p: &Prepared, ctx: &Ctx<'_>, opts: &Options) {
        for round in 1..=opts.max_effects {
            if !self.round(round, p, ctx, opts) {
                break;
            }
        }
        let accepted = &self.accepted;
        self.ambiguous
            .retain(|(a, b)| !(accepted.contains(a) && accepted.contains(b)));
    }

    /// The accepted effects that are not part of an unresolved ambiguity.
    fn named(&self) -> Vec<String> {
        self.accepted
            .iter()
            .filter(|k| !self.ambiguous.iter().any(|(a, b)| a == *k || b == *k))
            .map(|k| k.name().to_string())
            .collect()
    }

    /// One round: screen every candidate not yet accepted, accept the best (if any passed).
    /// Returns `false` when none passed (selection stops).
    fn round(&mut self, round: usize, p: &Prepared, ctx: &Ctx<'_>, opts: &Options) -> bool {
        let inp = &p.inp;
        let zero_base = self.base_model.clone();
        let base_cv = ctx.cv_errors(&zero_base, &self.base_free);
        let base_res = ctx.residual(&self.base_model);
        let mse_base = mean(&base_cv.iter().map(|e| e * e).collect::<Vec<_>>());
        let noise = noise_of(
            &{
                let r = replay(&self.base_model, inp);
                (0..p.n)
                    .map(|i| inp.measured[i] - r.predicted[i])
                    .collect::<Vec<_>>()
            },
            &p.sel_segs,
            p.n_sel,
            p.q_floor,
        );
        let pool: Vec<EffectKind> = opts
            .candidates
            .iter()
            .copied()
            .filter(|k| !self.accepted.contains(k))
            .collect();
        let applicable = pool.iter().filter(|k| inp.applicable(**k).is_ok()).count();
        let base = RoundBase {
            zero_base: &zero_base,
            base_free: &self.base_free,
            base_cv: &base_cv,
            base_res: &base_res,
            mse_base,
            noise,
            m: applicable.max(1) as f64,
        };
        let mut results: Vec<CandidateResult> = Vec::new();
        let mut scored: Vec<Scored> = Vec::new();
        for &kind in &pool {
            let (result, passed) = screen_candidate(kind, &base, p, ctx, opts);
            results.push(result);
            scored.extend(passed);
        }
        // An effect below the noise is named only if it alone fits (see
        // `Options::min_effect_to_noise`).
        let passing: Vec<String> = results
            .iter()
            .filter(|r| r.passed)
            .map(|r| r.effect.clone())
            .collect();
        if passing.len() >= 2 {
            for r in results.iter_mut() {
                if r.passed && r.effect_to_noise < opts.min_effect_to_noise {
                    r.passed = false;
                    r.contested_by = passing
                        .iter()
                        .filter(|e| **e != r.effect)
                        .cloned()
                        .collect();
                    scored.retain(|sc| sc.0.name() != r.effect);
                }
            }
        }
        scored.sort_by(|a, b| a.3.total_cmp(&b.3));
        let base_names: Vec<String> = self.accepted.iter().map(|k| k.name().to_string()).collect();
        let Some((best, best_fit, verdict, encompassing)) = choose_best(
            &scored,
            &self.base_free,
            ctx,
            opts,
            &mut self.ambiguous,
            &mut self.ambiguous_models,
        ) else {
            self.rounds.push(Round {
                round,
                base: base_names,
                candidates: results,
                verdict: "none: no candidate passed every criterion".into(),
                added: None,
                encompassing: None,
            });
            return false;
        };
        // A drift of the logged force is ruled out when the force column is what the
        // estimator made of the logged power: the rise it fits is then in the process (or
        // the machine), where the library has no gain rising with time. Nothing is kept
        // (not even provisionally, which a later round could turn into a name).
        if let Some(c) = ctx
            .force_vs_power
            .filter(|c| best == EffectKind::SensorGainDrift && c.consistent())
        {
            let why = format!(
                "the logged force is the estimator's output on the logged power (RMS difference {:.3} N over {} cut rows, tolerance {:.3} N), so the logged force did not drift: the rise it fits is in the process or the machine, where the library holds no gain rising with time",
                c.difference_rms_n, c.rows, c.tolerance_n
            );
            for r in results.iter_mut().filter(|r| r.effect == best.name()) {
                r.passed = false;
                r.ruled_out = Some(why.clone());
            }
            let verdict = match self.ambiguous.last() {
                Some((a, b)) if verdict.starts_with("ambiguous") => {
                    let other = if *a == best { b } else { a };
                    format!(
                        "ambiguous between {} and a gain rising with time in the process: sensor_gain_drift fits as well, but {why}; nothing kept",
                        other.name()
                    )
                }
                _ => format!("none: sensor_gain_drift fits best, but {why}"),
            };
            self.rounds.push(Round {
                round,
                base: base_names,
                candidates: results,
                verdict,
                added: None,
                encompassing,
            });
            return false;
        }
        self.accepted.push(best);
        self.base_free.extend(effect_free(best));
        self.base_model = best_fit.model.clone();
        self.base_params = best_fit.params.clone();
        self.params_start = with_null(&zero_base, best);
        self.rounds.push(Round {
            round,
            base: base_names,
            candidates: results,
            verdict,
            added: Some(best.name().into()),
            encompassing,
        });
        true
    }
}

/// Screen one candidate against the round's base: fit it jointly with the base's free
/// parameters, score it by held-out prediction (folds improved, gain, Bonferroni-adjusted
/// χ² p-value), check its residual signature and its primary parameter's interval.
/// Returns the report row and, if it passed every criterion, its [`Scored`] entry.
fn screen_candidate(
    kind: EffectKind,
    base: &RoundBase<'_>,
    p: &Prepared,
    ctx: &Ctx<'_>,
    opts: &Options,
) -> (CandidateResult, Option<Scored>) {
    let (inp, sel, n_sel) = (&p.inp, &p.sel, p.n_sel);
    let mse_base = base.mse_base;
    if let Err(why) = inp.applicable(kind) {
        let skipped = CandidateResult {
            effect: kind.name().into(),
            applicable: false,
            skip_reason: Some(why.into()),
            params: Vec::new(),
            heldout_mse_base: mse_base,
            heldout_mse: mse_base,
            heldout_gain_pct: 0.0,
            folds_improved: 0,
            heldout_chi2: 0.0,
            dof: 0,
            p_adjusted: 1.0,
            ci_excludes_null: false,
            signature_r_before: 0.0,
            signature_r_after: 0.0,
            signature_ratio: f64::INFINITY,
            signature_gone: false,
            effect_to_noise: 0.0,
            contested_by: Vec::new(),
            ruled_out: None,
            passed: false,
        };
        return (skipped, None);
    }
    let start = with_null(base.zero_base, kind);
    let mut free = base.base_free.to_vec();
    free.extend(effect_free(kind));
    let f = fit::fit(&start, &free, &effect_grid(kind), inp, sel);
    let cv = ctx.cv_errors(&f.model, &free);
    // Held-out loss reduction per row, and per fold.
    let delta: Vec<f64> = base
        .base_cv
        .iter()
        .zip(&cv)
        .map(|(b, c)| b * b - c * c)
        .collect();
    let folds_improved = ctx
        .folds
        .iter()
        .filter(|r| delta[(*r).clone()].iter().sum::<f64>() > 0.0)
        .count();
    let dof = effect_free(kind).len();
    let chi2 = heldout_chi2(base.base_cv, &cv);
    let p_adj = (chi2_sf(chi2, dof) * base.m).min(1.0);
    let mut f = f;
    if let Some(size) = wear_size(kind, &f, inp, n_sel) {
        f.params.push(size);
    }
    let primary_name = match kind {
        EffectKind::ToolWear => WEAR_SIZE.to_string(),
        _ => Free::Effect(kind, 0).name(),
    };
    // Signature: the effect's own contribution at the fitted values.
    let mut off = f.model.clone();
    off.effects.remove(kind);
    let with = replay(&f.model, inp);
    let without = replay(&off, inp);
    let contrib: Vec<f64> = sel
        .iter()
        .map(|&i| with.predicted[i] - without.predicted[i])
        .collect();
    let after = ctx.residual(&f.model);
    let (r_before, _) = correlation(&contrib, base.base_res);
    let (r_after, p_after) = correlation(&contrib, &after);
    // Regression coefficient of the residual on the effect's contribution: about 1
    // before (the residual holds the effect), about 0 after if the effect took it.
    let coef = |r: &[f64]| {
        let cc: f64 = contrib.iter().map(|c| c * c).sum();
        if cc > 0.0 {
            r.iter().zip(&contrib).map(|(a, c)| a * c).sum::<f64>() / cc
        } else {
            0.0
        }
    };
    let (b_before, b_after) = (coef(base.base_res), coef(&after));
    let sig_ratio = if b_before.abs() > 1e-12 {
        (b_after / b_before).abs()
    } else {
        f64::INFINITY
    };
    let sig_gone = p_after > 0.01 || sig_ratio <= 0.25;
    // The effect's size against the noise. The base model's residual carries the effect
    // itself (a delayed override step is an override-step stretch), so its σ can be
    // inflated by it; the candidate's own residual, once it explains the log, is noise.
    let fit_sigma = noise_of(
        &(0..p.n)
            .map(|i| inp.measured[i] - with.predicted[i])
            .collect::<Vec<_>>(),
        &p.sel_segs,
        n_sel,
        p.q_floor,
    )
    .sigma;
    let sigma_ref = base.noise.sigma.min(fit_sigma);
    let enr = if sigma_ref > 0.0 {
        stats::rms(&contrib) / sigma_ref
    } else {
        0.0
    };
    let mse = mean(&cv.iter().map(|e| e * e).collect::<Vec<_>>());
    let gain_pct = if mse_base > 0.0 {
        100.0 * (mse_base - mse) / mse_base
    } else {
        0.0
    };
    let others_pass = folds_improved + 1 >= ctx.folds.len()
        && gain_pct >= opts.min_gain_pct
        && p_adj < opts.alpha
        && sig_gone;
    // The primary parameter's interval: profile likelihood for the parameters that
    // sit on a curved ridge with a partner or enter through a delay / time
    // constant (computed only when the other criteria pass: it costs ~20 fits).
    if others_pass && PROFILED.contains(&kind) {
        if let Some(k) = f.free.iter().position(|x| *x == Free::Effect(kind, 0)) {
            f.profile(k, inp, sel);
        }
    }
    let ci_ok = f
        .params
        .iter()
        .find(|p| p.name == primary_name)
        .map(|p| (p.ci_low > p.null || p.ci_high < p.null) && p.std_err.is_finite())
        .unwrap_or(false);
    // A parameter of the effect pinned at its fitting bound is not a measurement of it:
    // the data want more than the effect's law allows (an effect outside the library
    // borrowing this one's signature), so it is not named (issue 13).
    let prefix = format!("{}.", kind.name());
    let bound_ok = !f
        .params
        .iter()
        .any(|p| p.name.starts_with(&prefix) && p.at_bound);
    let passed = others_pass && ci_ok && bound_ok;
    let result = CandidateResult {
        effect: kind.name().into(),
        applicable: true,
        skip_reason: None,
        params: f.params.clone(),
        heldout_mse_base: mse_base,
        heldout_mse: mse,
        heldout_gain_pct: gain_pct,
        folds_improved,
        heldout_chi2: chi2,
        dof,
        p_adjusted: p_adj,
        ci_excludes_null: ci_ok,
        signature_r_before: r_before,
        signature_r_after: r_after,
        signature_ratio: sig_ratio,
        signature_gone: sig_gone,
        effect_to_noise: enr,
        contested_by: Vec::new(),
        ruled_out: None,
        passed,
    };
    (result, passed.then_some((kind, cv, f, mse)))
}

/// The round's pick among the passed candidates (sorted by held-out MSE): the best, unless
/// the runner-up predicts as well (non-nested held-out χ², one degree of freedom) — then
/// the encompassing test decides, and an undecided pair is recorded in `ambiguous`.
/// Returns the effect, its fit, the verdict and the encompassing test, or `None` when no
/// candidate passed.
fn choose_best(
    scored: &[Scored],
    base_free: &[Free],
    ctx: &Ctx<'_>,
    opts: &Options,
    ambiguous: &mut Vec<(EffectKind, EffectKind)>,
    ambiguous_models: &mut Vec<AmbiguousFits>,
) -> Option<(EffectKind, crate::fit::Fit, String, Option<Encompassing>)> {
    let (best, best_cv, best_fit, _) = scored.first().cloned()?;
    let (mut best, mut best_fit) = (best, best_fit);
    let mut verdict = format!("accepted {}", best.name());
    let mut encompassing = None;
    if let Some((second, second_cv, second_fit, _)) = scored.get(1).cloned() {
        // Non-nested comparison on the same held-out rows, one degree of freedom.
        if chi2_sf(heldout_chi2(&second_cv, &best_cv), 1) > opts.alpha {
            let e = ctx.encompass(
                base_free,
                (best, &best_cv, &best_fit.model),
                (second, &second_cv),
                opts,
            );
            let (a, b) = (best.name(), second.name());
            match e.outcome.as_str() {
                "a" => {
                    verdict = format!(
                        "accepted {a} ({b} predicts as well alone but adds nothing once {a} is in, while {a} adds to {b})"
                    )
                }
                "b" => {
                    verdict = format!(
                        "accepted {b} ({a} predicts as well alone but adds nothing once {b} is in, while {b} adds to {a})"
                    );
                    best = second;
                    best_fit = second_fit;
                }
                "both" => {
                    verdict = format!(
                        "accepted {a} ({b} predicts as well alone; each adds to the other, so {b} is tested again next round)"
                    )
                }
                _ => match force_drifts_against_power(
                    ctx.force_vs_power,
                    (best, &best_fit.model),
                    (second, &second_fit.model),
                ) {
                    // The log itself tells them apart: a process effect would have moved
                    // the power with the force.
                    Some(c) => {
                        let other = if best == EffectKind::SensorGainDrift { b } else { a };
                        verdict = format!(
                            "accepted sensor_gain_drift ({other} predicts the force as well, but the logged force drifts against the estimator's output on the logged power by {:+.4}/min, which explains {:.0} % of their difference over {} cut rows: the change is in the logged force, not in the process, which would have moved the power with it)",
                            c.drift_per_min,
                            100.0 * c.drift_explains,
                            c.rows
                        );
                        if best != EffectKind::SensorGainDrift {
                            best = second;
                            best_fit = second_fit;
                        }
                    }
                    None => {
                        ambiguous.push((best, second));
                        ambiguous_models.push(((best, second), best_fit.model.clone(), second_fit.model.clone()));
                        verdict = format!(
                            "ambiguous between {a} and {b} (neither adds to the other; {a} kept provisionally)"
                        );
                    }
                },
            }
            encompassing = Some(e);
        }
    }
    Some((best, best_fit, verdict, encompassing))
}

/// The comparison `c` of the logged force with the estimator's output on the logged power,
/// if it decides the pair `a`, `b` (each with its fitted model) for `sensor_gain_drift`:
/// the pair is that drift and an effect off the logging path (not `measurement_delay`),
/// the logged force drifts against the power
/// ([`crate::replay::ForcePowerConsistency::drifts`]), and the drift fitted to the
/// residual has the same sign and is within a factor of 2 of the one against the power.
fn force_drifts_against_power(
    c: Option<ForcePowerConsistency>,
    a: (EffectKind, &Model),
    b: (EffectKind, &Model),
) -> Option<ForcePowerConsistency> {
    let (drift, other) = match (a, b) {
        ((EffectKind::SensorGainDrift, m), (o, _)) | ((o, _), (EffectKind::SensorGainDrift, m)) => {
            (m.effects.sensor_gain_drift?.gain_per_min, o)
        }
        _ => return None,
    };
    c.filter(|c| {
        let ratio = drift / c.drift_per_min;
        other != EffectKind::MeasurementDelay && c.drifts() && (0.5..=2.0).contains(&ratio)
    })
}

/// The sealed part (stage 5; rows `n_sel..n`, never used in selection): the nominal
/// model, the nominal refit and the updated model (`updated`, its prediction) compared.
fn sealed_check(p: &Prepared, nominal_refit: &Model, updated: &[f64], noise_f: Noise) -> Sealed {
    let (inp, n, n_sel) = (&p.inp, p.n, p.n_sel);
    let sealed_rows = n_sel..n;
    let m_nom = metrics(
        inp,
        &p.nominal_replay.predicted,
        sealed_rows.clone(),
        &p.segs,
        noise_f,
        p.min_len,
    );
    let refit_pred = replay(nominal_refit, inp).predicted;
    let m_ref = metrics(
        inp,
        &refit_pred,
        sealed_rows.clone(),
        &p.segs,
        noise_f,
        p.min_len,
    );
    let m_upd = metrics(
        inp,
        updated,
        sealed_rows.clone(),
        &p.segs,
        noise_f,
        p.min_len,
    );
    let red = |a: f64, b: f64| if a > 0.0 { 100.0 * (a - b) / a } else { 0.0 };
    Sealed {
        from_s: inp.t_s[n_sel],
        to_s: inp.t_s[n - 1],
        rows: n - n_sel,
        rms_reduction_pct: red(m_nom.rms, m_upd.rms),
        rms_reduction_vs_refit_pct: red(m_ref.rms, m_upd.rms),
        nominal: m_nom,
        nominal_refit: m_ref,
        updated: m_upd,
    }
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
/// time grow together and the two laws are almost the same curve (issue 13: a `Ks` drift
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

impl WearOrTime {
    fn verdict(&self) -> WearTimeVerdict {
        let d = (self.sse_time - self.sse_wear) / self.scale;
        if d > WEAR_TIME_SEPARATION {
            WearTimeVerdict::WearFitsBetter
        } else if d < -WEAR_TIME_SEPARATION {
            WearTimeVerdict::TimeFitsBetter
        } else {
            WearTimeVerdict::Tie
        }
    }

    fn text(&self) -> String {
        format!(
            "a `Ks` rising linearly with cutting time ({:+.4}/min; e.g. the tool and the part heating up — not in the library) leaves a sum of squares of {:.0} over the selection rows against {:.0} for wear per removed volume, in residual variances of the wear fit: {}",
            self.growth_per_min,
            self.sse_time / self.scale,
            self.sse_wear / self.scale,
            match self.verdict() {
                WearTimeVerdict::WearFitsBetter => format!(
                    "more than {WEAR_TIME_SEPARATION:.0} apart, so the growth is not a drift linear in cutting time"
                ),
                WearTimeVerdict::TimeFitsBetter => format!(
                    "the drift in time fits better by more than {WEAR_TIME_SEPARATION:.0}"
                ),
                WearTimeVerdict::Tie => format!(
                    "within {WEAR_TIME_SEPARATION:.0} of each other — removed volume and cutting time grew together closely enough that this log does not tell wear from a drift in time"
                ),
            }
        )
    }
}

/// [`WearOrTime`] for `wear_model` (with `tool_wear` on, fitted with `free`) over the
/// selection rows; `None` without a rising wear, without cutting rows, or when a fit
/// does not give a finite sum of squares.
fn wear_or_time(p: &Prepared, wear_model: &Model, free: &[Free]) -> Option<WearOrTime> {
    let fx = &wear_model.effects;
    if !fx.is_on(EffectKind::ToolWear) {
        return None;
    }
    let (inp, rows) = (&p.inp, &p.sel);
    let last = *rows.last()?;
    let sse_of = |m: &Model| fit::sse(m, inp, rows);
    let r = replay(wear_model, inp);
    let sse_wear: f64 = rows
        .iter()
        .map(|&i| (inp.measured[i] - r.predicted[i]).powi(2))
        .sum();
    // The wear's relative Ks growth over the selection part and the cutting time it took:
    // where the time law starts.
    let cut_min: f64 = (0..=last)
        .filter(|&i| r.force_n[i] > 0.0)
        .map(|i| inp.dt_s[i] / 60.0)
        .sum();
    let v = r.volume_mm3[last] / 1000.0;
    let w = &wear_model.tool.wear;
    let g = w.growth_per_cm3 + fx.get(EffectKind::ToolWear, 0);
    let pw = fx.get(EffectKind::ToolWear, 1);
    let growth = g * v.max(0.0).powf(pw);
    // Only a rising Ks is set against a rising drift in time.
    if !(cut_min > 0.0 && growth.is_finite() && growth > 0.0 && sse_wear.is_finite()) {
        return None;
    }
    // The simulator's time law (`tool.wear.growth_per_min`, linear in cutting time) in
    // place of the wear, fitted with the calibration and the other named effects, from
    // the wear's mean rate and half of it.
    let mut base = wear_model.clone();
    base.effects.remove(EffectKind::ToolWear);
    // `free` always holds the nuisance parameters (`Ks` at least).
    let free_t: Vec<Free> = free
        .iter()
        .copied()
        .filter(|f| !matches!(f, Free::Effect(EffectKind::ToolWear, _)))
        .chain([Free::WearPerMinute])
        .collect();
    let g0 = base.tool.wear.growth_per_min;
    let mut best: Option<(f64, Model)> = None;
    for k in [1.0, 0.5] {
        let mut start = base.clone();
        start.tool.wear.growth_per_min = g0 + k * growth / cut_min;
        let m = fit::refine(&start, &free_t, inp, rows);
        let e = sse_of(&m);
        if e.is_finite() && best.as_ref().is_none_or(|(b, _)| e < *b) {
            best = Some((e, m));
        }
    }
    let (sse_time, time_model) = best?;
    let dof = rows.len().saturating_sub(free.len()).max(1) as f64;
    let scale = (sse_wear / dof).max(1e-18);
    Some(WearOrTime {
        sse_wear,
        sse_time,
        scale,
        growth_per_min: time_model.tool.wear.growth_per_min - g0,
        time_model,
    })
}

/// Assemble the report, the plot series and the updated model.
fn assemble(
    model: &Model,
    p: Prepared,
    s: Selection,
    upd_replay: crate::replay::Replay,
    unexplained: Option<Unexplained>,
    sealed: Sealed,
    opts: &Options,
) -> Analysis {
    let (inp, n, n_sel) = (&p.inp, p.n, p.n_sel);
    let unit = match inp.channel {
        Channel::Power => "W",
        Channel::Force => "N",
    };
    // An effect is named only when the model with it explains the log down to the noise:
    // structure left in the residual after its fit (a biased segment, a variance above the
    // noise, a residual still correlated with a signal) means the fit may be borrowing the
    // signature of something outside the library (issue 13).
    let passed = s.named();
    let exact = matches!(
        inp.plant.engagement,
        acc_sim::replay::ReplayEngagement::Workpiece { .. }
    );
    // Only asked for (the twin's evaluation): `acc run` logs replayed on the workpiece
    // still leave the board's wall-clock timing as structure (tests/e2e_twin_production.rs).
    let strict = opts.withhold_on_structure == Some(true) && exact;
    // The sealed part is the last word: a named fit that leaves a significantly biased
    // stretch there does not predict beyond the rows it was fitted on (a sensor zero shift
    // fitted as a Ks step over the cut, still visible in the air after it).
    let sealed_biased: Vec<String> = sealed
        .updated
        .segments
        .iter()
        .filter(|b| b.significant)
        .map(|b| {
            format!(
                "{} {:.1}–{:.1} s: {:+.3} {unit} (z {:.1})",
                b.regime.name(),
                b.t_start_s,
                b.t_end_s,
                b.bias,
                b.z
            )
        })
        .collect();
    let mut withheld: Vec<Withheld> = match &unexplained {
        Some(u) if strict && !passed.is_empty() && structure_remains(u) => passed
            .iter()
            .map(|e| Withheld {
                effect: e.clone(),
                reason: format!(
                    "structure remains after its fit ({}): the residual is not noise, so the fit may be borrowing the signature of an effect outside the library",
                    structure_text(u, unit)
                ),
            })
            .collect(),
        // A log rounded coarser than its noise: the residual after any fit is the
        // rounding (a bias per steady stretch that follows the level), not noise, so no
        // significance test holds.
        _ if !passed.is_empty() && p.q_floor > p.raw_sigma => passed
            .iter()
            .map(|e| Withheld {
                effect: e.clone(),
                reason: quantized_text(&p, unit),
            })
            .collect(),
        _ if strict && !passed.is_empty() && !sealed_biased.is_empty() => passed
            .iter()
            .map(|e| Withheld {
                effect: e.clone(),
                reason: format!(
                    "the updated model does not predict the sealed part ({}): the fit explains the rows it saw but not the ones it did not, so it may be borrowing the signature of an effect outside the library",
                    sealed_biased.join("; ")
                ),
            })
            .collect(),
        _ => Vec::new(),
    };
    let mut named: Vec<String> = passed
        .into_iter()
        .filter(|e| !withheld.iter().any(|w| &w.effect == e))
        .collect();
    // Withheld for the sealed part alone: that is where the structure remains.
    let unexplained = match unexplained {
        None if !withheld.is_empty() => Some(Unexplained {
            segments: sealed
                .updated
                .segments
                .iter()
                .filter(|b| b.significant)
                .cloned()
                .collect(),
            variance_ratio: if p.noise0.sigma > 0.0 {
                (sealed.updated.rms / p.noise0.sigma).powi(2)
            } else {
                1.0
            },
            variance_z: 0.0,
            correlations: Vec::new(),
        }),
        u => u,
    };
    // Tool wear against a `Ks` rising with cutting time: with the removal rate nearly
    // constant the two are the same curve. Where the replay is exact and the rule is asked
    // for, wear that a drift in time fits as well (or better) is not named and the pair is
    // reported ambiguous with the test cut; otherwise the name stands with a note.
    let wear_time = named
        .iter()
        .any(|e| e == EffectKind::ToolWear.name())
        .then(|| wear_or_time(&p, &s.base_model, &s.base_free))
        .flatten();
    let mut wear_time_ambiguity = None;
    let mut wear_time_note = String::new();
    if let Some(wt) = wear_time
        .as_ref()
        .filter(|wt| wt.verdict() != WearTimeVerdict::WearFitsBetter)
    {
        if strict {
            withheld.push(Withheld {
                effect: EffectKind::ToolWear.name().into(),
                reason: wt.text(),
            });
            named.retain(|e| e != EffectKind::ToolWear.name());
            wear_time_ambiguity = Some(Ambiguity {
                effects: [EffectKind::ToolWear.name().into(), KS_TIME_DRIFT.into()],
                experiment: WEAR_TIME_EXPERIMENT.into(),
                test_cut: Some(crate::testcut::run_named(
                    inp,
                    &s.base_model,
                    &wt.time_model,
                    (EffectKind::ToolWear.name(), "ks_time_drift"),
                    p.noise0.sigma,
                )),
            });
        } else {
            wear_time_note = format!(
                " Note: {}. To separate them run {}.",
                wt.text(),
                WEAR_TIME_EXPERIMENT
            );
        }
    }
    let mut conclusion =
        conclusion_with_notes(inp, &s, &named, unexplained.as_ref(), &sealed, unit);
    conclusion.push_str(&wear_time_note);
    if !withheld.is_empty() {
        let list: Vec<&str> = withheld.iter().map(|w| w.effect.as_str()).collect();
        conclusion = format!(
            "Not named: {} passed selection, but {}. {}",
            list.join(", "),
            withheld[0].reason,
            conclusion.replace(
                "No candidate effect is supported by held-out prediction. ",
                ""
            )
        );
    }
    // Nothing named because the best fit was ruled out by the logged power.
    if named.is_empty() && withheld.is_empty() {
        if let Some(why) = s
            .rounds
            .iter()
            .flat_map(|r| &r.candidates)
            .find_map(|c| c.ruled_out.as_ref().map(|w| (c.effect.as_str(), w)))
        {
            conclusion = conclusion.replace(
                "No candidate effect is supported by held-out prediction.",
                &format!("Not named: `{}` fits, but {}.", why.0, why.1),
            );
        }
    }
    // Nothing named although candidates predicted better: say when their effects were
    // only too small to name (the one criterion they failed), not "nothing supported".
    if named.is_empty() && withheld.is_empty() && s.ambiguous.is_empty() {
        if let Some(r) = s.rounds.first() {
            let mut small: Vec<&CandidateResult> = r
                .candidates
                .iter()
                .filter(|c| !c.contested_by.is_empty())
                .collect();
            small.sort_by(|a, b| b.effect_to_noise.total_cmp(&a.effect_to_noise));
            if let Some(top) = small.first() {
                let list: Vec<&str> = small.iter().map(|c| c.effect.as_str()).collect();
                conclusion = conclusion.replace(
                    "No candidate effect is supported by held-out prediction.",
                    &format!(
                        "Not named: {} each predict the held-out part better, but each one's \
                         effect is below the noise (largest: `{}` at {:.1}×; below {:.1}× a \
                         name needs to be the only fit): a structure this small fits several \
                         effects' shapes about equally.",
                        list.join(", "),
                        top.effect,
                        top.effect_to_noise,
                        opts.min_effect_to_noise
                    ),
                );
            }
        }
    }
    if named.is_empty() && withheld.is_empty() && p.q_floor > p.raw_sigma {
        conclusion = format!("Note: {}. {conclusion}", quantized_text(&p, unit));
    }
    if let Some(a) = &wear_time_ambiguity {
        let cut = a.test_cut.as_ref().map_or(String::new(), |c| {
            format!(
                " The simulator ran such a cut ({}) under both fits: their predictions differ by {:.3} {unit} RMS ({:.3} {unit} at most, noise σ {:.3} {unit}): {}.",
                c.description,
                c.rms_difference,
                c.max_difference,
                c.noise_sigma,
                if c.separates { "it separates them" } else { "that cut does not separate them" }
            )
        });
        let kept = match wear_time.as_ref().map(WearOrTime::verdict) {
            Some(WearTimeVerdict::TimeFitsBetter) => {
                "The updated model keeps the wear fit (the library has no drift in time); the drift fits this log better."
            }
            _ => "The updated model keeps the wear fit, which predicts this log as well as the drift does.",
        };
        conclusion.push_str(&format!(
            " Ambiguous between tool_wear and {KS_TIME_DRIFT}; to separate them run {}.{cut} {kept}",
            a.experiment
        ));
    }
    let series = plot_series(&p, &upd_replay, &sealed);
    let mut explanation = explain(&s, &named, &withheld, unexplained.as_ref(), opts);
    if let Some(c) = p.force_vs_power {
        explanation.insert(0, force_vs_power_text(&c));
    }
    if let Some(wt) = &wear_time {
        explanation.push(format!(
            "`tool_wear` against a `Ks` rising with cutting time: {}.",
            wt.text()
        ));
    }
    let report = Report {
        schema_version: SCHEMA_VERSION,
        input: InputInfo {
            rows: n,
            period_s: inp.period_s,
            channel: match inp.channel {
                Channel::Power => "power".into(),
                Channel::Force => "force".into(),
            },
            unit: unit.into(),
            feed_source: if inp.feed_cmd_mm_min.is_some() {
                "command".into()
            } else {
                "recorded".into()
            },
            selection_rows: n_sel,
            sealed_from_s: inp.t_s[n_sel],
            folds: opts.folds,
        },
        noise: p.noise0,
        locate: p.locate,
        rounds: s.rounds,
        accepted: named,
        ambiguous: s
            .ambiguous
            .iter()
            .map(|(a, b)| Ambiguity {
                effects: [a.name().into(), b.name().into()],
                experiment: a.separating_experiment(*b).into(),
                test_cut: s
                    .ambiguous_models
                    .iter()
                    .find(|(k, _, _)| *k == (*a, *b))
                    .map(|(_, ma, mb)| crate::testcut::run(inp, ma, mb, (*a, *b), p.noise0.sigma)),
            })
            .chain(wear_time_ambiguity)
            .collect(),
        withheld,
        explanation,
        unexplained,
        updated_params: absolute(s.base_params, &s.params_start, model),
        sealed,
        conclusion,
        warnings: Vec::new(),
    };
    Analysis {
        report,
        updated: s.base_model,
        series,
    }
}

/// [`conclude`], plus a note when a feed exponent is involved but the feed per revolution
/// is constant in the log.
fn conclusion_with_notes(
    inp: &Inputs,
    s: &Selection,
    named: &[String],
    unexplained: Option<&Unexplained>,
    sealed: &Sealed,
    unit: &str,
) -> String {
    let mut conclusion = conclude(named, &s.ambiguous, unexplained, sealed, unit);
    let beta_involved = s.accepted.contains(&EffectKind::FeedExponent)
        || s.ambiguous
            .iter()
            .any(|(a, b)| *a == EffectKind::FeedExponent || *b == EffectKind::FeedExponent);
    if let (true, Some((cv_rev, cv_feed))) = (beta_involved, feed_per_rev_spread(inp)) {
        conclusion.push_str(&format!(
            " Note: the feed per revolution is constant in this log (spread {:.1} % while the feed varies {:.1} %), so what `feed_exponent` measures here is the force's dependence on cutting speed.",
            100.0 * cv_rev,
            100.0 * cv_feed
        ));
    }
    conclusion
}

/// The series for plots: measured, nominal and updated predictions, the signal the
/// nominal residual correlates with most, flagged segments and the sealed-part biases.
fn plot_series(p: &Prepared, upd_replay: &crate::replay::Replay, sealed: &Sealed) -> Series {
    let inp = &p.inp;
    let strongest = p
        .locate
        .correlations
        .iter()
        .max_by(|a, b| a.r.abs().total_cmp(&b.r.abs()))
        .map(|c| c.signal.clone())
        .unwrap_or_else(|| "time".into());
    let signal = p
        .sigs
        .iter()
        .find(|(n, _)| *n == strongest)
        .map(|(_, v)| v.clone())
        .unwrap_or_default();
    let sealed_bias = sealed
        .nominal
        .segments
        .iter()
        .zip(&sealed.updated.segments)
        .map(|(a, b)| (0.5 * (a.t_start_s + a.t_end_s), a.bias, b.bias))
        .collect();
    Series {
        t_s: inp.t_s.clone(),
        measured: inp.measured.clone(),
        nominal: p.nominal_replay.predicted.clone(),
        updated: upd_replay.predicted.clone(),
        strongest_signal: strongest,
        signal,
        flagged: p
            .locate
            .segments
            .iter()
            .filter(|b| b.significant)
            .map(|b| (b.t_start_s, b.t_end_s))
            .collect(),
        sealed_from_s: sealed.from_s,
        sealed_bias,
    }
}

/// `Some((spread of feed/rpm, spread of feed))` (coefficients of variation over the cutting
/// rows) when the feed varies by more than 5 % but the feed per revolution by less than
/// 2 %: a feed exponent then cannot be told from a cutting-speed exponent.
fn feed_per_rev_spread(inp: &Inputs) -> Option<(f64, f64)> {
    let rows: Vec<usize> = (0..inp.len())
        .filter(|&i| inp.is_cut(i) && inp.spindle_rpm[i] > 0.0)
        .collect();
    let cv = |v: Vec<f64>| {
        let m = mean(&v);
        if m > 0.0 {
            stats::rms(&v.iter().map(|x| x - m).collect::<Vec<_>>()) / m
        } else {
            0.0
        }
    };
    let feed = cv(rows.iter().map(|&i| inp.feed_mm_min[i]).collect());
    let per_rev = cv(rows
        .iter()
        .map(|&i| inp.feed_mm_min[i] / inp.spindle_rpm[i])
        .collect());
    (rows.len() > 10 && feed > 0.05 && per_rev < 0.02).then_some((per_rev, feed))
}

/// The "unexplained" test of a model's residual over the selection part: segments whose
/// bias is significant (Bonferroni over segments, AR(1) standard error), or a residual
/// variance significantly above the noise (z > 2·z_{1−α/2} and more than 10 % above).
struct ResidualCheck<'a> {
    inp: &'a Inputs,
    segs: &'a [Segment],
    n_sel: usize,
    q_floor: f64,
    min_len: usize,
    alpha: f64,
    sigs: &'a [(String, Vec<f64>)],
    sel: &'a [usize],
}

impl ResidualCheck<'_> {
    fn run(&self, model: &Model) -> (Noise, Option<Unexplained>) {
        let r = replay(model, self.inp);
        let rf: Vec<f64> = (0..self.inp.len())
            .map(|i| self.inp.measured[i] - r.predicted[i])
            .collect();
        let noise = noise_of(&rf, self.segs, self.n_sel, self.q_floor);
        let flagged: Vec<_> = segment_biases(&rf, self.segs, &self.inp.t_s, noise, self.min_len)
            .into_iter()
            .filter(|b| b.significant)
            .collect();
        let var_ratio = if noise.sigma > 0.0 {
            (stats::rms(&rf[..self.n_sel]) / noise.sigma).powi(2)
        } else {
            1.0
        };
        let ne = n_eff(self.n_sel, noise.rho);
        let var_z = (var_ratio - 1.0) / (2.0 / ne).sqrt();
        let too_big = var_z > 2.0 * normal_quantile(1.0 - self.alpha / 2.0) && var_ratio > 1.1;
        let un = (!flagged.is_empty() || too_big).then(|| Unexplained {
            segments: flagged,
            variance_ratio: var_ratio,
            variance_z: var_z,
            correlations: correlate(&rf[..self.n_sel], self.sigs, self.sel, self.alpha),
        });
        (noise, un)
    }
}

/// Express the Ks multiplier and the no-load offset relative to the model as given
/// (they were fitted relative to `start`).
fn absolute(
    mut params: Vec<crate::fit::FittedParam>,
    start: &Model,
    given: &Model,
) -> Vec<crate::fit::FittedParam> {
    let k = start.tool.process.calib_force_n / given.tool.process.calib_force_n;
    let o = start.machine.spindle.no_load_power_w - given.machine.spindle.no_load_power_w;
    for p in &mut params {
        if p.name == Free::KsScale.name() {
            p.value *= k;
            p.std_err *= k;
            p.ci_low *= k;
            p.ci_high *= k;
        } else if p.name == Free::Noload.name() {
            p.value += o;
            p.ci_low += o;
            p.ci_high += o;
        }
    }
    params
}

/// Held-out likelihood-ratio statistic of a candidate against its base:
/// `(SSE_base − SSE_cand) / (σ̂²·(1 + ρ)/(1 − ρ))` over the held-out rows, with σ̂² and
/// the AR(1) ρ of the candidate's held-out errors (the variance inflation of an AR(1)
/// mean, see [`crate::stats`]). Under "no effect" it is ≤ 0 on average (the candidate
/// only adds estimation noise out of sample); with an effect it grows like χ² with the
/// effect's degrees of freedom (Wilks 1938).
fn heldout_chi2(base: &[f64], cand: &[f64]) -> f64 {
    let n = cand.len().max(1) as f64;
    let sse_b: f64 = base.iter().map(|e| e * e).sum();
    let sse_c: f64 = cand.iter().map(|e| e * e).sum();
    let rho = lag1(cand).clamp(0.0, 0.99);
    let s2 = sse_c / n * (1.0 + rho) / (1.0 - rho);
    if s2 <= 0.0 {
        return 0.0;
    }
    (sse_b - sse_c) / s2
}

/// Upper tail of χ² with `dof` degrees of freedom (1 for a non-positive statistic).
fn chi2_sf(x: f64, dof: usize) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if x <= 0.0 {
        return 1.0;
    }
    ChiSquared::new(dof.max(1) as f64)
        .map(|d| d.sf(x))
        .unwrap_or(1.0)
}

/// Structure that withholds a name: a segment still biased, a residual variance above
/// [`STRUCTURE_VARIANCE_RATIO`] × the noise's, or a residual still following a signal
/// (significant and |r| ≥ [`STRUCTURE_MIN_R`]). A variance ratio just above 1 alone is not
/// enough: the noise of a spindle-power channel is coloured beyond AR(1) (null logs from
/// `acc sim` replay with RMS ≈ 1.6 σ_diff, docs/twin.md).
fn structure_remains(u: &Unexplained) -> bool {
    !u.segments.is_empty()
        || u.variance_ratio > STRUCTURE_VARIANCE_RATIO
        || u.correlations
            .iter()
            .any(|c| c.significant && c.r.abs() >= STRUCTURE_MIN_R)
}

/// Residual variance over the noise's above which structure remains, −.
pub const STRUCTURE_VARIANCE_RATIO: f64 = 2.0;
/// Smallest correlation of the remaining residual with a signal that counts as structure.
pub const STRUCTURE_MIN_R: f64 = 0.3;

/// Where the structure of a residual lies, in words: the biased segments, the variance
/// ratio, the signals the residual still follows.
fn structure_text(u: &Unexplained, unit: &str) -> String {
    let mut parts: Vec<String> = u
        .segments
        .iter()
        .take(4)
        .map(|b| {
            format!(
                "{} {:.1}–{:.1} s bias {:.2} {unit}",
                b.regime.name(),
                b.t_start_s,
                b.t_end_s,
                b.bias
            )
        })
        .collect();
    if u.segments.len() > 4 {
        parts.push(format!("{} more biased segments", u.segments.len() - 4));
    }
    parts.push(format!("variance {:.2}× the noise's", u.variance_ratio));
    for c in u.correlations.iter().filter(|c| c.significant) {
        parts.push(format!("follows `{}` (r = {:.2})", c.signal, c.r));
    }
    parts.join("; ")
}

/// The note on a log rounded coarser than its noise.
fn quantized_text(p: &Prepared, unit: &str) -> String {
    format!(
        "the log is quantized in steps of {:.3} {unit} (rounding σ {:.3} {unit} above the noise {:.3} {unit}): the residual is rounding that follows the level, not noise, so no effect is named from it",
        p.q_floor * 12f64.sqrt(),
        p.q_floor,
        p.raw_sigma
    )
}

/// Why a candidate failed, in words (empty when it passed).
fn fail_reasons(c: &CandidateResult, folds: usize, opts: &Options) -> Vec<String> {
    let mut v = Vec::new();
    if c.folds_improved + 1 < folds {
        v.push(format!("improves {}/{folds} folds", c.folds_improved));
    }
    if c.heldout_gain_pct < opts.min_gain_pct {
        v.push(format!(
            "held-out gain {:.1} % < {:.0} %",
            c.heldout_gain_pct, opts.min_gain_pct
        ));
    }
    if !c.contested_by.is_empty() {
        v.push(format!(
            "its effect is {:.1}× the noise (below {:.1}× a name needs to be the only fit) and {} fit as well",
            c.effect_to_noise,
            opts.min_effect_to_noise,
            c.contested_by.join(", ")
        ));
    }
    if c.p_adjusted >= opts.alpha {
        v.push(format!("p {:.2} ≥ {}", c.p_adjusted, opts.alpha));
    }
    if let Some(why) = &c.ruled_out {
        v.push(format!("ruled out: {why}"));
    }
    if !c.signature_gone {
        v.push("its signature stays in the residual".into());
    }
    if !c.ci_excludes_null {
        v.push("its interval includes the null".into());
    }
    let prefix = format!("{}.", c.effect);
    if c.params
        .iter()
        .any(|p| p.name.starts_with(&prefix) && p.at_bound)
    {
        v.push("a parameter at its fitting bound".into());
    }
    v
}

/// The report's line on the logged force against the estimator's output on the logged
/// power ([`crate::replay::ForcePowerConsistency`]).
fn force_vs_power_text(c: &ForcePowerConsistency) -> String {
    let verdict = if c.consistent() {
        "consistent: the force column is what the estimator made of the power, so a change in the force is in the process or the machine, not in the logged force".to_string()
    } else if c.drifts() {
        format!(
            "the logged force drifts against the power by {:+.4}/min (the drift explains {:.0} % of the difference): the logged force itself changed",
            c.drift_per_min,
            100.0 * c.drift_explains
        )
    } else {
        format!(
            "they differ, but not as a drift in time (a drift explains {:.0} %): the logged force was altered on its way to the log",
            100.0 * c.drift_explains
        )
    };
    format!(
        "Logged force against the estimator's output on the logged power, {} cut rows: RMS difference {:.3} N ({:.2} % of the force); {verdict}.",
        c.rows,
        c.difference_rms_n,
        100.0 * c.difference_rms_n / c.force_rms_n.max(1e-9),
    )
}

/// The report's "what was done and why": per round the candidates tried with their fit
/// figures and why each failed, the verdict, and why effects were or were not named.
fn explain(
    s: &Selection,
    named: &[String],
    withheld: &[Withheld],
    unexplained: Option<&Unexplained>,
    opts: &Options,
) -> Vec<String> {
    let mut out = Vec::new();
    for r in &s.rounds {
        let tried: Vec<String> = r
            .candidates
            .iter()
            .map(|c| {
                if !c.applicable {
                    return format!(
                        "`{}` skipped ({})",
                        c.effect,
                        c.skip_reason.as_deref().unwrap_or("")
                    );
                }
                let why = fail_reasons(c, opts.folds, opts);
                format!(
                    "`{}` gain {:.1} %, p {:.2e}, ENR {:.1}: {}",
                    c.effect,
                    c.heldout_gain_pct,
                    c.p_adjusted,
                    c.effect_to_noise,
                    if c.passed {
                        "passed".to_string()
                    } else {
                        format!("failed ({})", why.join(", "))
                    }
                )
            })
            .collect();
        out.push(format!(
            "Round {}: candidates tried: {}. Verdict: {}.",
            r.round,
            tried.join("; "),
            r.verdict
        ));
    }
    for (a, b) in &s.ambiguous {
        out.push(format!(
            "`{}` and `{}` explain the same residual (each predicts as well alone and neither adds to the other): neither is named.",
            a.name(),
            b.name()
        ));
    }
    for w in withheld {
        out.push(format!("`{}` not named: {}.", w.effect, w.reason));
    }
    if named.is_empty() && withheld.is_empty() && s.ambiguous.is_empty() {
        out.push(match unexplained {
            Some(_) if s.rounds.iter().any(|r| r.candidates.iter().any(|c| c.ruled_out.is_some())) => "Nothing named: the candidate that fitted best was ruled out by the logged power (see the round's verdict), and structure remains in the residual (see Unexplained): something outside the library.".into(),
            Some(_) => "Nothing named: no candidate passed every criterion, and structure remains in the residual (see Unexplained): something outside the library, or an effect the log does not excite enough.".into(),
            None if s.rounds.iter().any(|r| r.candidates.iter().any(|c| c.ruled_out.is_some())) => "Nothing named: the candidate that fitted best was ruled out by the logged power (see the round's verdict), and what remains is at the noise's level.".into(),
            None if s.rounds.iter().any(|r| r.candidates.iter().any(|c| !c.contested_by.is_empty())) => "Nothing named: the candidates that passed every other criterion were each below the noise and not the only fit; what remains is at the noise's level.".into(),
            None => "Nothing named: no candidate passed every criterion and the nominal model explains the log down to the noise.".into(),
        });
    } else {
        for e in named {
            out.push(format!(
                "`{e}` named: it passed every criterion (held-out gain, folds, Bonferroni p, interval excluding the null, signature removed, no parameter at a bound), won its round, and the residual after it is noise."
            ));
        }
    }
    out
}

fn conclude(
    named: &[String],
    ambiguous: &[(EffectKind, EffectKind)],
    un: Option<&Unexplained>,
    sealed: &Sealed,
    unit: &str,
) -> String {
    let mut parts = Vec::new();
    if named.is_empty() && ambiguous.is_empty() {
        parts.push("No candidate effect is supported by held-out prediction.".to_string());
    }
    if !named.is_empty() {
        parts.push(format!("Named: {}.", named.join(", ")));
    }
    for (a, b) in ambiguous {
        parts.push(format!(
            "Ambiguous between {} and {}; to separate them run {}.",
            a.name(),
            b.name(),
            a.separating_experiment(*b)
        ));
    }
    if let Some(u) = un {
        let where_: Vec<String> = u
            .segments
            .iter()
            .take(5)
            .map(|b| format!("{} {:.1}–{:.1} s", b.regime.name(), b.t_start_s, b.t_end_s))
            .collect();
        parts.push(format!(
            "Unexplained: the remaining residual is {:.2}× the noise variance{}.",
            u.variance_ratio,
            if where_.is_empty() {
                String::new()
            } else {
                format!(", biased in {}", where_.join("; "))
            }
        ));
    }
    parts.push(format!(
        "Sealed part: RMS {:.3} → {:.3} {unit} (nominal → updated), fit {:.1} % → {:.1} %.",
        sealed.nominal.rms, sealed.updated.rms, sealed.nominal.fit_pct, sealed.updated.fit_pct
    ));
    parts.join(" ")
}
