//! Report assembly: the [`crate::report::Report`] of an analysis and its plotted series.

#[allow(unused_imports)]
use super::*;

/// The channel's name in text (`power`, `force`).
fn unit_channel(c: Channel) -> &'static str {
    match c {
        Channel::Power => "power",
        Channel::Force => "force",
    }
}

/// What the checks after selection found about the updated model's residual.
pub(super) struct ResidualFindings {
    /// Structure left in the selection part (`ResidualCheck::run`).
    pub unexplained: Option<Unexplained>,
    /// The sealed part compared ([`sealed_check`]).
    pub sealed: Sealed,
    /// The model error the names are judged against where the replay is not exact.
    pub model_error: Option<ModelError>,
    /// The updated model's noise over the selection part (the sealed blocks' yardstick).
    pub noise: Noise,
}

/// Assemble the report, the plot series and the updated model.
pub(super) fn assemble(
    model: &Model,
    p: Prepared,
    s: Selection,
    upd_replay: crate::replay::Replay,
    found: ResidualFindings,
    opts: &Options,
) -> Analysis {
    let ResidualFindings {
        unexplained,
        sealed,
        model_error,
        noise: noise_f,
    } = found;
    let (inp, n, n_sel) = (&p.inp, p.n, p.n_sel);
    let unit = inp.channel.unit();
    // An effect is named only when the model with it explains the log down to the noise:
    // structure left in the residual after its fit (a biased segment, a variance above the
    // noise, a residual still correlated with a signal) means the fit may be borrowing the
    // signature of something outside the library.
    let passed = s.named();
    // Strict where a correct model leaves only noise; elsewhere the names are judged
    // against the model error (`model_error`).
    let strict = opts.withhold_on_structure == Some(true) && p.replay_is_exact();
    // The rules after selection (`verdict`): structure left, rounding, the sealed part
    // (blocks large against what the names fixed), the model error.
    let findings = Findings {
        unexplained: unexplained.as_ref(),
        sealed: &sealed,
        model_error: model_error.as_ref(),
        strict,
    };
    let decision = decide(&p, &passed, &findings);
    let mut withheld = decision.withheld.clone();
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
            variance_ratio: if noise_f.sigma > 0.0 {
                (sealed.updated.rms / noise_f.sigma).powi(2)
            } else {
                1.0
            },
            variance_z: 0.0,
            correlations: Vec::new(),
        }),
        u => u,
    };
    // Names after the first that did not improve the sealed part (`extra`): the model
    // went back to the one they were added to.
    withheld.extend(s.withheld_extra.iter().cloned());
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
    let excluded_note = (p.excluded.total() > 0).then(|| {
        format!(
            "{} of {n} rows have no valid measurement on the {} channel or no engagement the replay can place and were left out of selection, noise and the sealed part (the replay runs through them): {}",
            p.excluded.total(),
            unit_channel(inp.channel),
            p.excluded.text()
        )
    });
    let sealed_moved_note = p.sealed_moved.map(|(rows_from, from)| {
        format!(
            "the last {:.0} % of the rows (from {rows_from:.1} s) hold no cutting row, so the sealed part starts at {from:.1} s, where the last {:.0} % of the cutting rows begin",
            100.0 * opts.sealed_fraction,
            100.0 * opts.sealed_fraction
        )
    });
    if let Some(t) = &sealed_moved_note {
        conclusion.push_str(&format!(" Note: {t}."));
    }
    if let Some(t) = &excluded_note {
        conclusion.push_str(&format!(" {t}."));
    }
    if let Some(t) = inp.raced.text() {
        conclusion.push_str(&format!(" Note: {t}."));
    }
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
    let left = (!strict && unexplained.is_some()).then_some("structure left unexplained");
    let most_likely = most_likely(&named, &decision, left, &sealed);
    if let Some(m) = &most_likely {
        conclusion = format!("{} {conclusion}", m.text(unit));
    }
    if !named.is_empty() && !decision.kept.is_empty() {
        let list: Vec<String> = decision.kept.iter().map(|k| k.text(unit)).collect();
        conclusion.push_str(&format!(
            " Named despite {} biased sealed block{} (each under {:.0} % of what the names fixed there): {}.",
            list.len(),
            if list.len() == 1 { "" } else { "s" },
            100.0 * SEALED_GAIN_SHARE,
            list.join("; ")
        ));
    }
    // Nothing named because the best fit was ruled out (by the logged power, or below the
    // noise on a replay that is not exact).
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
    let mut small: Vec<&CandidateResult> = s
        .rounds
        .iter()
        .flat_map(|r| r.candidates.iter())
        .filter(|c| !c.contested_by.is_empty())
        .collect();
    small.sort_by(|a, b| b.effect_to_noise.total_cmp(&a.effect_to_noise));
    small.dedup_by(|a, b| a.effect == b.effect);
    if !named.is_empty() && !small.is_empty() {
        let list: Vec<String> = small
            .iter()
            .map(|c| format!("`{}` ({:.1}×)", c.effect, c.effect_to_noise))
            .collect();
        conclusion.push_str(&format!(
            " Not named beside it: {} — below {:.1}× the noise a second name adds nothing the noise could not.",
            list.join(", "),
            opts.min_effect_to_noise
        ));
    }
    if named.is_empty() && withheld.is_empty() && s.ambiguous.is_empty() {
        {
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
    let kept_despite = if named.is_empty() {
        Vec::new()
    } else {
        decision.kept
    };
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
            channel: unit_channel(inp.channel).into(),
            unit: unit.into(),
            feed_source: if inp.feed_cmd_mm_min.is_some() {
                "command".into()
            } else {
                "recorded".into()
            },
            selection_rows: p.sel.len(),
            sealed_from_s: inp.t_s[n_sel],
            folds: opts.folds,
            excluded_rows: p.excluded.report(),
            retimed: inp.raced,
        },
        spindle_calibration: None,
        path_shift: None,
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
        most_likely,
        kept_despite,
        explanation,
        unexplained,
        model_error,
        updated_params: absolute(s.base_params, &s.params_start, model),
        sealed,
        conclusion,
        warnings: excluded_note.into_iter().chain(sealed_moved_note).collect(),
    };
    Analysis {
        report,
        updated: s.base_model,
        series,
    }
}

/// The series for plots: measured, nominal and updated predictions, the signal the
/// nominal residual correlates with most, flagged segments and the sealed-part biases.
pub(super) fn plot_series(
    p: &Prepared,
    upd_replay: &crate::replay::Replay,
    sealed: &Sealed,
) -> Series {
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
pub(super) fn feed_per_rev_spread(inp: &Inputs) -> Option<(f64, f64)> {
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
