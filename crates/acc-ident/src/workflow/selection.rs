//! Candidate selection: the parameters each candidate is fitted with, the fit of every
//! candidate against the nominal model, rounds of held-out comparison and the choice of
//! the best (or an ambiguity) per round.

#[allow(unused_imports)]
use super::*;

/// The nominal parameters every candidate is fitted with: `Ks` always, the no-load power
/// on the power channel, the speed exponent γ when the cutting speed varies by more than
/// 5 % (coefficient of variation over the cutting rows).
pub(super) fn nuisance(inp: &Inputs, speed_exponent: bool) -> Vec<Free> {
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

pub(super) fn effect_free(kind: EffectKind) -> Vec<Free> {
    kind.params()
        .iter()
        .enumerate()
        .filter(|(_, p)| p.fitted)
        .map(|(i, _)| Free::Effect(kind, i))
        .collect()
}

pub(super) fn effect_grid(kind: EffectKind) -> Vec<Free> {
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
pub(super) const PROFILE_LIKELIHOOD_EFFECTS: [EffectKind; 7] = [
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
pub(super) fn wear_size(
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
pub(super) fn with_null(model: &Model, kind: EffectKind) -> Model {
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

impl Ctx<'_> {
    /// Held-out residuals over the selection rows (in the order of `sel`): each fold
    /// predicted by the model refitted (warm start from `start`) on the other folds.
    pub(super) fn cv_errors(&self, start: &Model, free: &[Free]) -> Vec<f64> {
        let mut e = vec![0.0; self.sel.len()];
        for fold in &self.folds {
            let train: Vec<usize> = self
                .sel
                .iter()
                .enumerate()
                .filter(|(k, _)| !fold.contains(k))
                .map(|(_, &i)| i)
                .collect();
            let m = fit::refine(start, free, self.inp, &train);
            let r = crate::replay::replay_shared(&m, self.inp);
            for k in fold.clone() {
                let i = self.sel[k];
                e[k] = self.inp.measured[i] - r.predicted[i];
            }
        }
        e
    }

    /// The encompassing test of [`Encompassing`] between `a` (fitted model `a_model`, the
    /// better-scoring one) and `b`, each with its held-out errors alone: `b` is added to
    /// `a`'s fit (grid over `b`'s delays and time constants, then LM on everything), and
    /// the pair's held-out errors are compared with each alone.
    pub(super) fn encompass(
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

    pub(super) fn residual(&self, m: &Model) -> Vec<f64> {
        let r = crate::replay::replay_shared(m, self.inp);
        self.sel
            .iter()
            .map(|&i| self.inp.measured[i] - r.predicted[i])
            .collect()
    }
}

impl Selection {
    /// The nominal parameters refitted (the base of round 1).
    pub(super) fn nominal(model: &Model, p: &Prepared, opts: &Options) -> Self {
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
            before: Vec::new(),
            withheld_extra: Vec::new(),
            ambiguous: Vec::new(),
            ambiguous_models: Vec::new(),
            rounds: Vec::new(),
        }
    }

    /// 2–4. Forward selection: rounds until none passes or `max_effects` are in; an
    /// ambiguity is resolved when both members ended up accepted.
    pub(super) fn run(&mut self, p: &Prepared, ctx: &Ctx<'_>, opts: &Options) {
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
    pub(super) fn named(&self) -> Vec<String> {
        self.accepted
            .iter()
            .filter(|k| !self.ambiguous.iter().any(|(a, b)| a == *k || b == *k))
            .map(|k| k.name().to_string())
            .collect()
    }

    /// One round: screen every candidate not yet accepted, accept the best (if any passed).
    /// Returns `false` when none passed (selection stops).
    pub(super) fn round(
        &mut self,
        round: usize,
        p: &Prepared,
        ctx: &Ctx<'_>,
        opts: &Options,
    ) -> bool {
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
            &p.sel,
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
        // An effect below the noise is named only if it alone fits and is the first name
        // (see `Options::min_effect_to_noise`): the others passing in its round, and the
        // effects already in the model, are its rivals. Where the replay is not exact it
        // is not named at all.
        let passing: Vec<String> = results
            .iter()
            .filter(|r| r.passed)
            .map(|r| r.effect.clone())
            .collect();
        for r in results.iter_mut() {
            if !(r.passed && r.effect_to_noise < opts.min_effect_to_noise) {
                continue;
            }
            let rivals: Vec<String> = passing
                .iter()
                .filter(|e| **e != r.effect)
                .cloned()
                .chain(self.accepted.iter().map(|k| k.name().to_string()))
                .collect();
            if rivals.is_empty() {
                // On a replay that is not exact the model error itself leaves structures
                // of this size: being the only fit is not enough there.
                if opts.withhold_on_structure != Some(true) || p.replay_is_exact() {
                    continue;
                }
                r.ruled_out = Some(format!(
                    "its effect is {:.1}× the noise, and the replay is not exact (logged depths): the model error leaves structures below {:.1}× the noise that several effects fit, so being the only fit does not name it",
                    r.effect_to_noise, opts.min_effect_to_noise
                ));
            } else {
                r.contested_by = rivals;
            }
            r.passed = false;
            scored.retain(|sc| sc.0.name() != r.effect);
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
        self.before.push(SelectionState {
            model: zero_base.clone(),
            free: self.base_free.clone(),
            params: self.base_params.clone(),
            params_start: self.params_start.clone(),
        });
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

/// What a candidate's effect is judged against ([`CandidateResult::effect_to_noise`]), in
/// the channel's unit: the noise σ (`sigma_ref`), the log's rounding (`q_sigma` = q/√12 of
/// its smallest step: on a steady stretch the rounding error is a constant bias that the
/// residual's differences do not see, and across stretches it is uniform over ±q/2) and
/// the model error the candidate leaves — the variance of its residual `after` (selection
/// rows) above its own noise σ `fit_sigma`, structure the model with it still cannot
/// represent — added in quadrature. A candidate that explains the log leaves noise, and
/// the last term is 0; one that borrows part of a structure outside the library (the
/// tooth-level force replayed by the mean-force model) is judged against what it leaves.
pub(super) fn judged_sigma(sigma_ref: f64, q_sigma: f64, fit_sigma: f64, after: &[f64]) -> f64 {
    let left = mean(&after.iter().map(|e| e * e).collect::<Vec<_>>());
    let model_error = (left - fit_sigma * fit_sigma).max(0.0);
    (sigma_ref * sigma_ref + q_sigma * q_sigma + model_error).sqrt()
}

/// Screen one candidate against the round's base: fit it jointly with the base's free
/// parameters, score it by held-out prediction (folds improved, gain, Bonferroni-adjusted
/// χ² p-value), check its residual signature and its primary parameter's interval.
/// Returns the report row and, if it passed every criterion, its [`Scored`] entry.
pub(super) fn screen_candidate(
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
        sel,
        p.q_floor,
    )
    .sigma;
    let sigma_ref = base.noise.sigma.min(fit_sigma);
    let sigma_judge = judged_sigma(sigma_ref, p.q_floor, fit_sigma, &after);
    let net: Vec<f64> = base
        .base_res
        .iter()
        .zip(&after)
        .map(|(b, a)| b - a)
        .collect();
    let enr = if sigma_judge > 0.0 {
        stats::rms(&net) / sigma_judge
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
    if others_pass && PROFILE_LIKELIHOOD_EFFECTS.contains(&kind) {
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
    // borrowing this one's signature), so it is not named.
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
pub(super) fn choose_best(
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

#[cfg(test)]
mod tests {
    use super::judged_sigma;

    #[test]
    fn a_name_is_judged_against_noise_rounding_and_the_model_error_it_leaves() {
        // A residual of pure noise (RMS = its σ): noise and rounding only.
        let noise: Vec<f64> = (0..400)
            .map(|i| if i % 2 == 0 { 0.5 } else { -0.5 })
            .collect();
        let s = judged_sigma(0.5, 1.0 / 12f64.sqrt(), 0.5, &noise);
        assert!((s - (0.25f64 + 1.0 / 12.0).sqrt()).abs() < 1e-12, "{s}");
        // The same noise on a structure of 0.8 RMS the candidate left: it counts.
        let left: Vec<f64> = noise
            .iter()
            .enumerate()
            .map(|(i, e)| e + if (i / 50) % 2 == 0 { 0.8 } else { -0.8 })
            .collect();
        let s2 = judged_sigma(0.5, 0.0, 0.5, &left);
        assert!((s2 - (0.25f64 + 0.64).sqrt()).abs() < 1e-9, "{s2}");
    }
}
