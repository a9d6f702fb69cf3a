//! `report.json` (stable schema, [`SCHEMA_VERSION`]) and `report.md`.

use std::fmt::Write as _;

use serde::Serialize;

use crate::fit::FittedParam;
use crate::segment::SegmentBias;
use crate::stats::Noise;

pub use crate::report_model_error::{ModelError, SealedBlock, SealedError};
pub use crate::report_verdict::{KeptBlock, MostLikely};

/// Version of the `report.json` schema; bumped on any incompatible change.
pub const SCHEMA_VERSION: u32 = 1;

/// What was analysed.
#[derive(Debug, Clone, Serialize)]
pub struct InputInfo {
    /// Rows in the log.
    pub rows: usize,
    /// Median sampling period, s.
    pub period_s: f64,
    /// Compared channel (`power` or `force`).
    pub channel: String,
    /// Unit of the channel (`W` or `N`).
    pub unit: String,
    /// `command` when the feed was replayed from the override command, else `recorded`.
    pub feed_source: String,
    /// Rows used for selection (the first part of the log).
    pub selection_rows: usize,
    /// Time where the sealed final part starts, s.
    pub sealed_from_s: f64,
    /// Number of contiguous cross-validation folds.
    pub folds: usize,
    /// Rows without a valid measurement on the channel, per reason: replayed, but in
    /// neither the selection nor the sealed part, nor in the noise.
    pub excluded_rows: Vec<ExcludedRows>,
    /// Override steps the board's `ACTUAL_FEED` placed a period off the log's reads
    /// (`acc run` logs of a v2 board; [`crate::replay::raced`]).
    pub retimed: crate::replay::raced::RaceCount,
}

/// Rows left out of an analysis for one reason ([`crate::dead::DeadReason`]).
#[derive(Debug, Clone, Serialize)]
pub struct ExcludedRows {
    /// The reason (`link_lost`, `skipped`, `implausible`, `no_sample`, `feed_hold_in_air`,
    /// `axial_depth_change`).
    pub reason: String,
    /// Rows left out for it.
    pub rows: usize,
    /// First such row's 1-based line in the log file (the header is line 1).
    pub first_line: usize,
    /// Last such row's line.
    pub last_line: usize,
}

/// Correlation of the nominal residual with a candidate signal.
#[derive(Debug, Clone, Serialize)]
pub struct SignalCorrelation {
    /// Signal name (`time`, `load`, `cut_volume`, `feed`, `feed_change`, `depth_change`,
    /// `spindle_angle_cos`, `spindle_angle_sin`).
    pub signal: String,
    /// Pearson correlation.
    pub r: f64,
    /// Two-sided p-value with the AR(1) effective sample size.
    pub p: f64,
    /// Significant after Bonferroni correction over the signals.
    pub significant: bool,
}

/// Step 1, locate: where and under which conditions model and measurement disagree.
#[derive(Debug, Clone, Serialize)]
pub struct Locate {
    /// RMS of the nominal residual over the selection part, channel unit.
    pub residual_rms: f64,
    /// Per-segment bias of the nominal model.
    pub segments: Vec<SegmentBias>,
    /// Correlations of the residual with candidate signals.
    pub correlations: Vec<SignalCorrelation>,
}

/// One candidate in one round of forward selection.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateResult {
    /// Effect name.
    pub effect: String,
    /// `false` when the effect cannot act on this log (reason in `skip_reason`).
    pub applicable: bool,
    /// Why it was skipped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub skip_reason: Option<String>,
    /// Fitted parameters (effect and the nominal ones fitted with it), 95 % intervals.
    pub params: Vec<FittedParam>,
    /// Held-out mean squared error of the base model, channel unit².
    pub heldout_mse_base: f64,
    /// Held-out mean squared error with the candidate.
    pub heldout_mse: f64,
    /// Relative held-out improvement, % of the base MSE.
    pub heldout_gain_pct: f64,
    /// Folds where the candidate predicted better.
    pub folds_improved: usize,
    /// Held-out likelihood-ratio statistic `(SSE_base − SSE)/(σ̂²·(1+ρ)/(1−ρ))`.
    pub heldout_chi2: f64,
    /// Degrees of freedom of the statistic (the effect's fitted parameters).
    pub dof: usize,
    /// χ² upper-tail p-value times the number of candidates (Bonferroni), capped at 1.
    pub p_adjusted: f64,
    /// The primary parameter's 95 % interval excludes its null value.
    pub ci_excludes_null: bool,
    /// Correlation of the base residual with the effect's signature.
    pub signature_r_before: f64,
    /// Same after adding the effect.
    pub signature_r_after: f64,
    /// Regression coefficient of the residual on the effect's contribution, after over
    /// before (0: the effect took all of its signature; 1: none).
    pub signature_ratio: f64,
    /// The signature is gone: its correlation with the residual is not significant
    /// (p > 0.01) after adding the effect, or the ratio above is at most 0.25.
    pub signature_gone: bool,
    /// Effect-to-noise ratio: RMS of the change the candidate makes to the prediction over
    /// the selection rows (its fit's prediction less the base model's) over what it is
    /// judged against — the noise σ, the log's rounding q/√12 and the variance its own
    /// residual leaves above its noise, in quadrature.
    pub effect_to_noise: f64,
    /// Other candidates that passed in the same round while this one's effect is below
    /// [`crate::workflow::Options::min_effect_to_noise`]: it is then not named (empty
    /// otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contested_by: Vec<String>,
    /// Why a candidate that fitted was ruled out by other evidence in the log (a drift of
    /// a logged force that matches the estimator's output on the logged power); `None`
    /// otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ruled_out: Option<String>,
    /// All criteria met.
    pub passed: bool,
}

/// One round of greedy forward selection.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// 1-based round number.
    pub round: usize,
    /// Effects already in the model at the start of the round.
    pub base: Vec<String>,
    /// Every candidate's result.
    pub candidates: Vec<CandidateResult>,
    /// `accepted`, `ambiguous` or `none`.
    pub verdict: String,
    /// The effect added in this round, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub added: Option<String>,
    /// The encompassing test between the two best candidates when their held-out
    /// predictions could not be told apart (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub encompassing: Option<Encompassing>,
}

/// Encompassing test between two candidates `a` and `b` whose held-out predictions are
/// statistically equal: both are fitted together, and each is asked whether it still
/// improves held-out prediction when the other is already in the model (held-out χ²
/// with the added effect's degrees of freedom). An effect that adds to its rival while
/// the rival adds nothing to it explains the rival's signature and is preferred (Mizon and
/// Richard 1986; Davidson and MacKinnon 1981).
#[derive(Debug, Clone, Serialize)]
pub struct Encompassing {
    /// The better-scoring candidate alone.
    pub a: String,
    /// The runner-up.
    pub b: String,
    /// p-value of adding `a` to a model that has `b` (small: `a` carries information `b` lacks).
    pub p_a_adds_to_b: f64,
    /// p-value of adding `b` to a model that has `a`.
    pub p_b_adds_to_a: f64,
    /// Held-out MSE gain of `a + b` over `b` alone, %.
    pub gain_a_over_b_pct: f64,
    /// Held-out MSE gain of `a + b` over `a` alone, %.
    pub gain_b_over_a_pct: f64,
    /// `a`, `b`, `both` (each adds to the other) or `ambiguous` (neither does).
    pub outcome: String,
}

/// Two effects the data cannot tell apart.
#[derive(Debug, Clone, Serialize)]
pub struct Ambiguity {
    /// The two effects (the better-scoring first; it is in the updated model). Library
    /// effects by their [`crate::EffectKind::name`]; the second may be
    /// [`crate::workflow::KS_TIME_DRIFT`], an explanation outside the library.
    pub effects: [String; 2],
    /// The experiment that would separate them.
    pub experiment: String,
    /// That experiment run by the simulator's plant with each explanation fitted (absent
    /// when the pair's fitted models were not available).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test_cut: Option<TestCut>,
}

/// A separating test cut replayed by the simulator's plant ([`acc_sim::replay`]) under the
/// two fitted explanations of an ambiguous pair: how far apart their predictions are.
#[derive(Debug, Clone, Serialize)]
pub struct TestCut {
    /// What the cut is (depths, feeds, override steps, pauses).
    pub description: String,
    /// Rows of the cut (one per control period).
    pub rows: usize,
    /// RMS difference of the two predictions over the cut, channel unit.
    pub rms_difference: f64,
    /// Largest absolute difference, channel unit.
    pub max_difference: f64,
    /// The log's noise σ, channel unit.
    pub noise_sigma: f64,
    /// Whether the cut separates them: the summed squared difference over the cut
    /// exceeds 25 σ² (a 5σ likelihood-ratio test on one such cut).
    pub separates: bool,
}

/// An effect that passed the selection criteria but is not named, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Withheld {
    /// The effect.
    pub effect: String,
    /// Why it is not named (structure remaining after its fit, a sealed part it does not
    /// predict, tool wear that a drift in cutting time fits as well, a quantized log).
    pub reason: String,
}

/// The residual that no candidate explains.
#[derive(Debug, Clone, Serialize)]
pub struct Unexplained {
    /// Segments whose bias stays significant with the updated model.
    pub segments: Vec<SegmentBias>,
    /// Residual variance over the noise variance (selection part; the sealed part when
    /// only the sealed part is biased).
    pub variance_ratio: f64,
    /// z of the variance ratio against 1.
    pub variance_z: f64,
    /// Signals the remaining residual still correlates with.
    pub correlations: Vec<SignalCorrelation>,
}

/// Accuracy of one model on the sealed part.
#[derive(Debug, Clone, Serialize)]
pub struct Metrics {
    /// RMS error, channel unit.
    pub rms: f64,
    /// Fit %, `100·(1 − ‖y − ŷ‖ / ‖y − ȳ‖)`.
    pub fit_pct: f64,
    /// Mean error (bias), channel unit.
    pub bias: f64,
    /// Per-segment bias.
    pub segments: Vec<SegmentBias>,
}

/// Step 5: the sealed final part that selection never saw.
#[derive(Debug, Clone, Serialize)]
pub struct Sealed {
    /// Start, s.
    pub from_s: f64,
    /// End, s.
    pub to_s: f64,
    /// Rows.
    pub rows: usize,
    /// The model as given.
    pub nominal: Metrics,
    /// The nominal model with its nominal parameters refitted on the selection part.
    pub nominal_refit: Metrics,
    /// The updated model.
    pub updated: Metrics,
    /// RMS reduction of the updated model against the model as given, %.
    pub rms_reduction_pct: f64,
    /// RMS reduction against the refitted nominal model, %.
    pub rms_reduction_vs_refit_pct: f64,
}

/// The spindle's power law calibrated from the log's selection part before effects are
/// judged (`acc_ident::workflow`'s spindle calibration; report section "Spindle
/// calibration").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpindleCalibration {
    /// No-load power before (the model's) and after, W.
    pub no_load_power_w: (f64, f64),
    /// Efficiency `η` before and after, −.
    pub efficiency: (f64, f64),
    /// Copper-loss coefficient `c` before and after, 1/kW (`None`: not fitted, too few
    /// load levels; the model's kept).
    pub copper_loss_per_kw: (f64, Option<f64>),
    /// Averaging window of the power channel before and after, s (0: the whole period).
    pub power_window_s: (f64, f64),
    /// Air-cut rows the no-load power was taken from (0: kept the model's).
    pub air_rows: usize,
    /// Cutting rows the curve was fitted on.
    pub cut_rows: usize,
    /// RMS of the logged power less the model's over the rows used, before and after, W.
    pub residual_rms_w: (f64, f64),
    /// The same with the `Ks` growth per removed volume fitted beside the curve (and left
    /// out of it, for the effect search to name), W.
    pub residual_rms_with_wear_w: f64,
    /// Noise σ measured on the nominal residual with the model's spindle and with the
    /// calibrated one, W (the calibration is adopted only when the first is above
    /// `acc_ident::workflow`'s `NOISE_RATIO` times the second).
    pub noise_sigma: (f64, f64),
}

impl SpindleCalibration {
    /// The report section "Spindle calibration".
    fn write_markdown(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "## Spindle calibration (from the selection part, before the effects)
"
        );
        let _ = writeln!(s, "| parameter | model | calibrated |");
        let _ = writeln!(s, "| --- | ---: | ---: |");
        let air = match self.air_rows {
            0 => "kept: too few air-cut rows".to_string(),
            n => format!("{n} air-cut rows"),
        };
        let _ = writeln!(
            s,
            "| no-load power (W; {air}) | {:.1} | {:.1} |",
            self.no_load_power_w.0, self.no_load_power_w.1
        );
        let _ = writeln!(
            s,
            "| efficiency η (−) | {:.4} | {:.4} |",
            self.efficiency.0, self.efficiency.1
        );
        let c = self
            .copper_loss_per_kw
            .1
            .map_or("kept: too few load levels".to_string(), |c| {
                format!("{c:.4}")
            });
        let _ = writeln!(
            s,
            "| copper loss c (1/kW) | {:.4} | {c} |",
            self.copper_loss_per_kw.0
        );
        let _ = writeln!(
            s,
            "| power window (s, 0 = whole period) | {:.3} | {:.3} |",
            self.power_window_s.0, self.power_window_s.1
        );
        let _ = writeln!(
            s,
            "\nFitted on {} cutting rows with `Ks` at the model's value: `P − P_air = P_c/η + c·P_c²/1000`; residual RMS {:.2} W with the model's spindle, {:.2} W calibrated ({:.2} W with a `Ks` growth per removed volume fitted beside the curve and left out of it, for the effect search). The noise σ is {:.2} W with the model's spindle and {:.2} W calibrated. The effects below are judged against the calibrated spindle, which the updated model carries.\n",
            self.cut_rows,
            self.residual_rms_w.0,
            self.residual_rms_w.1,
            self.residual_rms_with_wear_w,
            self.noise_sigma.0,
            self.noise_sigma.1
        );
    }
}

/// Where the replay's tool started against the start the log was given (`acc discrepancy
/// --workpiece` without `--x0-mm`; `acc_ident::workflow`'s path-start estimate, report
/// line "Path start").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathShift {
    /// The replay's start as given: the workpiece coordinate of the tool centre when the
    /// log's first period began, mm.
    pub given_start_mm: f64,
    /// The estimate's distance from it along the path, mm (positive: the tool was farther
    /// along than given).
    pub shift_mm: f64,
    /// Sum of squares of the high-passed residual (first differences between valid rows)
    /// at the given start, unit².
    pub sse_given: f64,
    /// The same at the estimate, unit².
    pub sse_estimated: f64,
    /// Rows (from the log's beginning) the estimate was made on.
    pub rows: usize,
    /// The analysis used the estimate (it cut the sum of squares enough and is not at the
    /// search's bound).
    pub adopted: bool,
    /// The best start lies at the search's bound: the given start may be farther off than
    /// the search reaches.
    pub at_bound: bool,
}

impl PathShift {
    /// The report line.
    pub fn text(&self) -> String {
        let ratio = if self.sse_given > 0.0 {
            self.sse_estimated / self.sse_given
        } else {
            1.0
        };
        let verdict = if self.adopted {
            "used"
        } else if self.at_bound {
            "not used: it lies at the search's bound, so the given start (`--x0-mm`) may be farther off than the search reaches; check it"
        } else {
            "not used: the given start fits as well"
        };
        format!(
            "Path start: the tool's start along the workpiece, estimated from the log's first {} rows, is {:+.3} mm from the given one ({:.3} mm), which leaves {:.3}× the high-passed residual's sum of squares; {verdict}.",
            self.rows,
            self.shift_mm,
            self.given_start_mm,
            ratio
        )
    }
}

/// The whole report.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Input description.
    pub input: InputInfo,
    /// The spindle calibrated from the log before effects were judged (power channel, a
    /// model without a motor curve); the effects are judged against it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spindle_calibration: Option<SpindleCalibration>,
    /// The replay's start along the workpiece estimated from the log (a production log
    /// analysed on a workpiece without `--x0-mm`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path_shift: Option<PathShift>,
    /// Noise of the channel (differenced air and steady-cut stretches, AR(1)).
    pub noise: Noise,
    /// Locate step.
    pub locate: Locate,
    /// Forward-selection rounds.
    pub rounds: Vec<Round>,
    /// Effects named with confidence.
    pub accepted: Vec<String>,
    /// Pairs that cannot be told apart.
    pub ambiguous: Vec<Ambiguity>,
    /// Effects that passed selection but are not named, with the reason.
    #[serde(default)]
    pub withheld: Vec<Withheld>,
    /// When nothing is confirmed: the withheld effects that best explain the log and by
    /// how much (never a confirmed name).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub most_likely: Option<MostLikely>,
    /// Sealed blocks biased beyond the noise or the model error that the names are kept
    /// despite (small against what they fixed on the sealed part).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub kept_despite: Vec<KeptBlock>,
    /// What the workflow did and why: the candidates tried, why the named effect won,
    /// or why nothing was named.
    #[serde(default)]
    pub explanation: Vec<String>,
    /// Residual left unexplained, and where.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unexplained: Option<Unexplained>,
    /// The model error names were judged against (a log whose replay is not exact, under
    /// the default rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_error: Option<ModelError>,
    /// Parameters of the updated model (nominal refits and effects) with intervals.
    pub updated_params: Vec<FittedParam>,
    /// Sealed-part comparison.
    pub sealed: Sealed,
    /// One-paragraph conclusion.
    pub conclusion: String,
    /// What the input checks found (gaps the log was split at, suspicious units); each
    /// names the column, row and value.
    #[serde(default)]
    pub warnings: Vec<String>,
}

impl Report {
    /// `report.json` text (pretty-printed).
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }

    /// Render `report.md`.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let u = &self.input.unit;
        let _ = writeln!(s, "# Model discrepancy report\n");
        let _ = writeln!(s, "{}\n", self.conclusion);
        if !self.explanation.is_empty() {
            let _ = writeln!(s, "## What was done and why\n");
            for e in &self.explanation {
                let _ = writeln!(s, "- {e}");
            }
            let _ = writeln!(s);
        }
        for w in &self.warnings {
            let _ = writeln!(s, "- **Warning**: {w}");
        }
        if !self.warnings.is_empty() {
            let _ = writeln!(s);
        }
        let _ = writeln!(
            s,
            "Log: {} rows, period {:.3} s, channel `{}` ({u}), feed from {}; selection on the first {} rows, sealed part from {:.1} s; {} contiguous folds.\n",
            self.input.rows,
            self.input.period_s,
            self.input.channel,
            self.input.feed_source,
            self.input.selection_rows,
            self.input.sealed_from_s,
            self.input.folds
        );
        let _ = writeln!(
            s,
            "Noise (differenced air and steady-cut stretches, AR(1)): σ = {:.4} {u}, AR(1) ρ = {:.3}, {} samples.\n",
            self.noise.sigma, self.noise.rho, self.noise.samples
        );
        if let Some(p) = &self.path_shift {
            let _ = writeln!(s, "{}\n", p.text());
        }
        if let Some(c) = &self.spindle_calibration {
            c.write_markdown(&mut s);
        }
        let _ = writeln!(s, "## Sealed final part (never seen by selection)\n");
        let _ = writeln!(s, "| model | RMS ({u}) | fit % | bias ({u}) |");
        let _ = writeln!(s, "| --- | ---: | ---: | ---: |");
        for (name, m) in [
            ("nominal (as given)", &self.sealed.nominal),
            ("nominal, refitted", &self.sealed.nominal_refit),
            ("updated", &self.sealed.updated),
        ] {
            let _ = writeln!(
                s,
                "| {name} | {:.4} | {:.1} | {:.4} |",
                m.rms, m.fit_pct, m.bias
            );
        }
        let _ = writeln!(
            s,
            "\nRMS reduction: {:.1} % against the model as given, {:.1} % against the refitted nominal model.\n",
            self.sealed.rms_reduction_pct, self.sealed.rms_reduction_vs_refit_pct
        );
        let _ = writeln!(s, "## Where the nominal model disagrees\n");
        let _ = writeln!(
            s,
            "A stretch is flagged when its bias is significant (Bonferroni over the stretches) and larger than its practical floor: the channel's rounding, or {:.1} % of the stretch's level.\n",
            100.0 * crate::workflow::PRACTICAL_BIAS_SHARE
        );
        let _ = writeln!(
            s,
            "| regime | from (s) | to (s) | rows | bias ({u}) | z | floor ({u}) | flagged |"
        );
        let _ = writeln!(
            s,
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | :---: |"
        );
        for b in self
            .locate
            .segments
            .iter()
            .filter(|b| b.significant)
            .take(30)
        {
            let _ = writeln!(
                s,
                "| {} | {:.1} | {:.1} | {} | {:.3} | {:.1} | {:.3} | yes |",
                b.regime.name(),
                b.t_start_s,
                b.t_end_s,
                b.samples,
                b.bias,
                b.z,
                b.floor
            );
        }
        let _ = writeln!(s, "\n| signal | r | p | significant |");
        let _ = writeln!(s, "| --- | ---: | ---: | :---: |");
        for c in &self.locate.correlations {
            let _ = writeln!(
                s,
                "| {} | {:.3} | {:.2e} | {} |",
                c.signal,
                c.r,
                c.p,
                if c.significant { "yes" } else { "no" }
            );
        }
        for r in &self.rounds {
            let _ = writeln!(
                s,
                "\n## Round {} (base: {})\n",
                r.round,
                if r.base.is_empty() {
                    "nominal".to_string()
                } else {
                    r.base.join(", ")
                }
            );
            let _ = writeln!(
                s,
                "| effect | held-out gain % | folds | held-out χ² | p (Bonferroni) | CI excl. null | signature r before → after | ENR | passed |"
            );
            let _ = writeln!(
                s,
                "| --- | ---: | ---: | ---: | ---: | :---: | --- | ---: | :---: |"
            );
            for c in &r.candidates {
                if !c.applicable {
                    let _ = writeln!(
                        s,
                        "| {} | — | — | — | — | — | skipped: {} | — | — |",
                        c.effect,
                        c.skip_reason.as_deref().unwrap_or("")
                    );
                    continue;
                }
                let _ = writeln!(
                    s,
                    "| {} | {:.2} | {}/{} | {:.1} | {:.2e} | {} | {:.2} → {:.2} | {:.1} | {} |",
                    c.effect,
                    c.heldout_gain_pct,
                    c.folds_improved,
                    self.input.folds,
                    c.heldout_chi2,
                    c.p_adjusted,
                    if c.ci_excludes_null { "yes" } else { "no" },
                    c.signature_r_before,
                    c.signature_r_after,
                    c.effect_to_noise,
                    if c.passed { "**yes**" } else { "no" }
                );
            }
            if let Some(e) = &r.encompassing {
                let _ = writeln!(
                    s,
                    "\nEncompassing test (`{a}` and `{b}` predict equally well alone): adding `{a}` to `{b}` gains {:.1} % (p {:.2e}); adding `{b}` to `{a}` gains {:.1} % (p {:.2e}) → {}.",
                    e.gain_a_over_b_pct,
                    e.p_a_adds_to_b,
                    e.gain_b_over_a_pct,
                    e.p_b_adds_to_a,
                    e.outcome,
                    a = e.a,
                    b = e.b,
                );
            }
            let _ = writeln!(s, "\nVerdict: {}.", r.verdict);
        }
        if !self.ambiguous.is_empty() {
            let _ = writeln!(s, "\n## Ambiguous\n");
            for a in &self.ambiguous {
                let _ = writeln!(
                    s,
                    "- ambiguous between `{}` and `{}`: {}",
                    a.effects[0], a.effects[1], a.experiment
                );
                if let Some(c) = &a.test_cut {
                    let _ = writeln!(
                        s,
                        "  - simulated test cut ({}; {} rows): the two fitted explanations differ by {:.3} {u} RMS, {:.3} {u} at most (noise σ {:.3} {u}) → {}",
                        c.description,
                        c.rows,
                        c.rms_difference,
                        c.max_difference,
                        c.noise_sigma,
                        if c.separates { "it separates them" } else { "it does not separate them" }
                    );
                }
            }
        }
        if !self.withheld.is_empty() {
            let _ = writeln!(s, "\n## Passed selection but not named\n");
            if let Some(m) = &self.most_likely {
                let _ = writeln!(s, "{}\n", m.text(u));
            }
            for w in &self.withheld {
                let _ = writeln!(s, "- `{}`: {}", w.effect, w.reason);
            }
        }
        if !self.kept_despite.is_empty() {
            let _ = writeln!(s, "\n## Named despite a biased sealed block\n");
            for k in &self.kept_despite {
                let _ = writeln!(s, "- {}", k.text(u));
            }
        }
        if let Some(un) = &self.unexplained {
            let _ = writeln!(s, "\n## Unexplained\n");
            let _ = writeln!(
                s,
                "Residual variance / noise variance = {:.2} (z = {:.1}).\n",
                un.variance_ratio, un.variance_z
            );
            for b in &un.segments {
                let _ = writeln!(
                    s,
                    "- {} {:.1}–{:.1} s: bias {:.3} {u} (z = {:.1}, floor {:.3} {u})",
                    b.regime.name(),
                    b.t_start_s,
                    b.t_end_s,
                    b.bias,
                    b.z,
                    b.floor
                );
            }
            for c in un.correlations.iter().filter(|c| c.significant) {
                let _ = writeln!(s, "- still correlates with `{}` (r = {:.2})", c.signal, c.r);
            }
        }
        if let Some(me) = &self.model_error {
            let _ = writeln!(s, "\n## Model error\n");
            if me.judged {
                let _ = writeln!(
                    s,
                    "The replay is not exact here: names are judged against the model error of the selection part, a spread of {:.3} {u} beyond their noise in the biases of its {} blocks of {} rows; the sealed part is judged in blocks of the same length.",
                    me.segment_bias_sd, me.selection_segments, me.block_rows
                );
            } else {
                let _ = writeln!(
                    s,
                    "The replay is not exact here, and the selection part has {} blocks of {} rows: too few to measure the model error, so no block was judged against it.",
                    me.selection_segments, me.block_rows
                );
            }
            let e = &me.sealed_error;
            let _ = writeln!(
                s,
                "\nSealed part with the names against without them: RMS {:.3} → {:.3} {u} (t = {:.1} over {} blocks){}",
                e.mse_without.sqrt(),
                e.mse_with.sqrt(),
                e.t,
                e.blocks,
                if e.worse && !(self.accepted.is_empty() && self.withheld.is_empty()) {
                    " — worse beyond the noise: the names are withheld"
                } else {
                    ""
                }
            );
            for b in &me.sealed_beyond {
                let _ = writeln!(
                    s,
                    "- sealed {} {:.1}–{:.1} s: bias {:.3} {u} ({:.3} {u} without the names), beyond the model error — {}",
                    b.block.regime.name(),
                    b.block.t_start_s,
                    b.block.t_end_s,
                    b.block.bias,
                    b.bias_without,
                    if self.accepted.is_empty() && self.withheld.is_empty() {
                        "nothing is named: the model is further off there than where it was fitted"
                    } else if b.withholds {
                        "the names made it materially worse: they are withheld"
                    } else if b.under_corrected {
                        "the names moved it toward the measurement: the effect is larger there than its law"
                    } else {
                        "the names made it worse or overshot it, but by little against the model error and what they fixed: they are kept"
                    }
                );
            }
        }
        let _ = writeln!(s, "\n## Updated parameters (95 % intervals)\n");
        let _ = writeln!(s, "| parameter | value | interval | null |");
        let _ = writeln!(s, "| --- | ---: | --- | ---: |");
        for p in &self.updated_params {
            let _ = writeln!(
                s,
                "| {} | {:.5} | [{:.5}, {:.5}]{} | {} |",
                p.name,
                p.value,
                p.ci_low,
                p.ci_high,
                if p.at_bound { " (at bound)" } else { "" },
                p.null
            );
        }
        s
    }
}
