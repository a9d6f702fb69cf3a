//! Explanation: the English text of the report (why a candidate was named, withheld or
//! rejected, and the conclusion).

#[allow(unused_imports)]
use super::*;

/// [`conclude`], plus a note when a feed exponent is involved but the feed per revolution
/// is constant in the log.
pub(super) fn conclusion_with_notes(
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

/// Where the structure of a residual lies, in words: the biased segments, the variance
/// ratio, the signals the residual still follows.
pub(super) fn structure_text(u: &Unexplained, unit: &str) -> String {
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
pub(super) fn quantized_text(p: &Prepared, unit: &str) -> String {
    format!(
        "the log is quantized in steps of {:.3} {unit} (rounding σ {:.3} {unit} above the noise {:.3} {unit}): the residual is rounding that follows the level, not noise, so no effect is named from it",
        p.q_floor * 12f64.sqrt(),
        p.q_floor,
        p.raw_sigma
    )
}

/// Why a candidate failed, in words (empty when it passed).
pub(super) fn fail_reasons(c: &CandidateResult, folds: usize, opts: &Options) -> Vec<String> {
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
            "its effect is {:.1}× the noise (below {:.1}× a name needs to be the only fit and the first) and {} fit as well or are in the model already",
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
pub(super) fn force_vs_power_text(c: &ForcePowerConsistency) -> String {
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
pub(super) fn explain(
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
            Some(_) if s.rounds.iter().any(|r| r.candidates.iter().any(|c| c.ruled_out.is_some())) => "Nothing named: the candidate that fitted best was ruled out (see its round), and structure remains in the residual (see Unexplained): something outside the library.".into(),
            Some(_) => "Nothing named: no candidate passed every criterion, and structure remains in the residual (see Unexplained): something outside the library, or an effect the log does not excite enough.".into(),
            None if s.rounds.iter().any(|r| r.candidates.iter().any(|c| c.ruled_out.is_some())) => "Nothing named: the candidate that fitted best was ruled out (see its round), and what remains is at the noise's level.".into(),
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

pub(super) fn conclude(
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
