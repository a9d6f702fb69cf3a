//! The verdict on the names that passed selection: which rule withholds them (with the
//! reason in full and in a few words), the sealed blocks they are kept despite, and —
//! when none is confirmed — the effect that best explains the log
//! ([`crate::report::MostLikely`]).

#[allow(unused_imports)]
use super::*;
use crate::report::{KeptBlock, MostLikely};
use crate::segment::SegmentBias;

/// What the rules after selection decided about the names that passed it.
pub(super) struct Decision {
    /// The names withheld, each with its reason.
    pub withheld: Vec<Withheld>,
    /// The rule that withheld them, in a few words (empty when none did).
    pub short: Option<String>,
    /// Sealed blocks biased beyond the noise or the model error that the names are kept
    /// despite.
    pub kept: Vec<KeptBlock>,
}

/// What the checks found, as the rules read them.
pub(super) struct Findings<'a> {
    /// Structure left in the selection part.
    pub unexplained: Option<&'a Unexplained>,
    /// The sealed part compared.
    pub sealed: &'a Sealed,
    /// The model error, where the replay is not exact.
    pub model_error: Option<&'a ModelError>,
    /// The strict rules apply (an exact replay under the default).
    pub strict: bool,
}

/// Every name in `passed` withheld for `reason`.
fn all_for(passed: &[String], reason: &str) -> Vec<Withheld> {
    passed
        .iter()
        .map(|e| Withheld {
            effect: e.clone(),
            reason: reason.to_string(),
        })
        .collect()
}

/// A sealed block in words.
fn block_text(b: &SegmentBias, unit: &str) -> String {
    format!(
        "{} {:.1}–{:.1} s: {:+.3} {unit} (z {:.1})",
        b.regime.name(),
        b.t_start_s,
        b.t_end_s,
        b.bias,
        b.z
    )
}

/// The rules in their order: structure left after the fit (exact replay), a log rounded
/// coarser than its noise, a sealed block large against what the names fixed (exact
/// replay, [`sealed_rule::judge_exact`]), the model error (otherwise).
pub(super) fn decide(p: &Prepared, passed: &[String], f: &Findings<'_>) -> Decision {
    let unit = p.inp.channel.unit();
    let none = |kept| Decision {
        withheld: Vec::new(),
        short: None,
        kept,
    };
    if passed.is_empty() {
        return none(Vec::new());
    }
    if let Some(u) = f.unexplained.filter(|u| f.strict && structure_remains(u)) {
        let reason = format!(
            "structure remains after its fit ({}): the residual is not noise, so the fit may be borrowing the signature of an effect outside the library",
            structure_text(u, unit)
        );
        return Decision {
            withheld: all_for(passed, &reason),
            short: Some("structure left unexplained after its fit".into()),
            kept: Vec::new(),
        };
    }
    // A log rounded coarser than its noise: the residual after any fit is the rounding
    // (a bias per steady stretch that follows the level), not noise.
    if p.q_floor > p.raw_sigma {
        return Decision {
            withheld: all_for(passed, &quantized_text(p, unit)),
            short: Some("the log is rounded coarser than its noise".into()),
            kept: Vec::new(),
        };
    }
    if f.strict {
        return decide_exact(passed, f.sealed, unit);
    }
    match f.model_error {
        Some(me) if me.withholds() => decide_model_error(passed, me, unit),
        Some(me) => none(kept_off_exact(me)),
        None => none(Vec::new()),
    }
}

/// An exact replay: the sealed blocks large against what the names fixed withhold them.
fn decide_exact(passed: &[String], sealed: &Sealed, unit: &str) -> Decision {
    let (withholding, kept) = sealed_rule::judge_exact(sealed);
    if withholding.is_empty() {
        return Decision {
            withheld: Vec::new(),
            short: None,
            kept,
        };
    }
    let list: Vec<String> = withholding.iter().map(|b| block_text(b, unit)).collect();
    let gain = sealed_rule::sealed_gain(sealed_rule::without_names(sealed).rms, sealed.updated.rms);
    let reason = format!(
        "the updated model does not predict the sealed part ({}; more than {:.0} % of the {:.3} {unit} of sealed RMS the names removed): the fit explains the rows it saw but not the ones it did not, so it may be borrowing the signature of an effect outside the library",
        list.join("; "),
        100.0 * SEALED_GAIN_SHARE,
        gain
    );
    let n = withholding.len();
    Decision {
        withheld: all_for(passed, &reason),
        short: Some(format!(
            "{n} sealed block{} biased beyond a tenth of what it fixed",
            if n == 1 { "" } else { "s" }
        )),
        kept,
    }
}

/// The sealed blocks beyond the model error that do not withhold the names.
fn kept_off_exact(me: &ModelError) -> Vec<KeptBlock> {
    me.sealed_beyond
        .iter()
        .filter(|b| !b.withholds)
        .map(|b| KeptBlock {
            block: b.block.clone(),
            bias_without: b.bias_without,
            gain: me.sealed_gain,
        })
        .collect()
}

/// Off an exact replay: the sealed part predicted worse, or blocks made materially worse.
fn decide_model_error(passed: &[String], me: &ModelError, unit: &str) -> Decision {
    let tau = me.segment_bias_sd;
    let list: Vec<String> = me
        .sealed_beyond
        .iter()
        .filter(|b| b.withholds)
        .map(|b| {
            format!(
                "{} {:.1}–{:.1} s: {:+.3} {unit} ({:+.3} {unit} without, {:.3} {unit} worse)",
                b.block.regime.name(),
                b.block.t_start_s,
                b.block.t_end_s,
                b.block.bias,
                b.bias_without,
                b.worse_by
            )
        })
        .collect();
    let mut why = Vec::new();
    let mut short = Vec::new();
    let e = &me.sealed_error;
    if e.worse {
        why.push(format!(
            "the updated model predicts the sealed part worse than the model without it (RMS {:.3} → {:.3} {unit}, t = {:.1} over {} blocks, beyond the noise)",
            e.mse_without.sqrt(),
            e.mse_with.sqrt(),
            e.t,
            e.blocks
        ));
        short.push("the sealed part predicted worse".to_string());
    }
    if !list.is_empty() {
        why.push(format!(
            "the updated model makes the sealed part materially worse beyond the model error it has where it was fitted (a spread of {tau:.3} {unit} in the selection part's block biases, and more than {:.0} % of the {:.3} {unit} of sealed RMS it removed): {}",
            100.0 * SEALED_GAIN_SHARE,
            me.sealed_gain,
            list.join("; ")
        ));
        short.push(format!(
            "{} sealed block{} made worse",
            list.len(),
            if list.len() == 1 { "" } else { "s" }
        ));
    }
    let reason = format!(
        "{}; the fit explains the rows it saw but not the ones it did not",
        why.join("; and ")
    );
    Decision {
        withheld: all_for(passed, &reason),
        short: Some(short.join(", ")),
        kept: kept_off_exact(me),
    }
}

/// When nothing is confirmed: the withheld names that predict the sealed part better than
/// the model without them, with both RMS and why they are not confirmed (`None` when they
/// do not, or when a name is confirmed).
pub(super) fn most_likely(
    named: &[String],
    decision: &Decision,
    extra: Option<&str>,
    sealed: &Sealed,
) -> Option<MostLikely> {
    let without = sealed_rule::without_names(sealed).rms;
    let short = decision.short.as_ref()?;
    (named.is_empty() && sealed.updated.rms < without).then(|| MostLikely {
        effects: decision.withheld.iter().map(|w| w.effect.clone()).collect(),
        sealed_rms_without: without,
        sealed_rms_with: sealed.updated.rms,
        not_confirmed: std::iter::once(short.clone())
            .chain(extra.map(str::to_string))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(rms: f64) -> Metrics {
        Metrics {
            rms,
            fit_pct: 0.0,
            bias: 0.0,
            segments: Vec::new(),
        }
    }

    fn sealed(nominal: f64, refit: f64, updated: f64) -> Sealed {
        Sealed {
            from_s: 0.0,
            to_s: 1.0,
            rows: 100,
            nominal: metrics(nominal),
            nominal_refit: metrics(refit),
            updated: metrics(updated),
            rms_reduction_pct: 0.0,
            rms_reduction_vs_refit_pct: 0.0,
        }
    }

    fn withheld_wear(short: &str) -> Decision {
        Decision {
            withheld: all_for(&["tool_wear".to_string()], "a long reason"),
            short: Some(short.into()),
            kept: Vec::new(),
        }
    }

    #[test]
    fn withheld_names_that_predict_the_sealed_part_are_the_most_likely() {
        // Issue 57's turning tool: sealed RMS 71.9 → 17.7 N, one block worse.
        let d = withheld_wear("1 sealed block made worse");
        let m = most_likely(
            &[],
            &d,
            Some("structure left unexplained"),
            &sealed(71.9, 80.0, 17.7),
        )
        .expect("most likely");
        assert_eq!(m.effects, ["tool_wear"]);
        assert_eq!((m.sealed_rms_without, m.sealed_rms_with), (71.9, 17.7));
        let t = m.text("N");
        assert!(
            t.starts_with("Most likely `tool_wear`: sealed RMS 71.900 → 17.700 N; not confirmed: 1 sealed block made worse; structure left unexplained"),
            "{t}"
        );
    }

    #[test]
    fn no_most_likely_beside_a_name_or_for_names_that_predict_worse() {
        let d = withheld_wear("the sealed part predicted worse");
        // The refit is the better model without the names: 10 N, worse with them.
        assert!(most_likely(&[], &d, None, &sealed(71.9, 10.0, 17.7)).is_none());
        assert!(most_likely(&["ks_step".into()], &d, None, &sealed(71.9, 80.0, 17.7)).is_none());
        let nothing = Decision {
            withheld: Vec::new(),
            short: None,
            kept: Vec::new(),
        };
        assert!(most_likely(&[], &nothing, None, &sealed(71.9, 80.0, 17.7)).is_none());
    }
}
