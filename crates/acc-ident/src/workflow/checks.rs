//! Statistical checks of a replay: noise, signal correlations, residual structure,
//! held-out χ², the force against its power, the sealed part and wear against time.

#[allow(unused_imports)]
use super::*;

/// Noise from the differenced air and steady-cut stretches of `residual` (the stretches
/// `segs`, clipped to the selection part); falls back to 50-row chunks of the residual on
/// the selection rows `rows` if there are none.
///
/// The result is floored at the resolution of the measured data (`floor`, the σ of
/// uniform quantization `q/√12`), so a quantized noise-free channel is not taken as
/// perfectly known.
pub(super) fn noise_of(residual: &[f64], segs: &[Segment], rows: &[usize], floor: f64) -> Noise {
    let mut nz = noise_raw(residual, segs, rows);
    nz.sigma = nz.sigma.max(floor);
    nz
}

pub(super) fn noise_raw(residual: &[f64], segs: &[Segment], rows: &[usize]) -> Noise {
    let n = rows.last().map_or(0, |&i| i + 1);
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
    let on_rows = pick(residual, rows);
    let chunks: Vec<&[f64]> = on_rows.chunks(50).collect();
    stats::pooled_noise_diff(&chunks)
}

/// The practical floor of the segment-bias tests ([`PracticalSize`]): the rounding's bias
/// for a channel quantised to `q_floor·√12` whose noise before rounding is what the raw
/// noise `raw_sigma` leaves after the rounding's own `q_floor`, and
/// [`PRACTICAL_BIAS_SHARE`] of each segment's level.
pub(super) fn practical_size(q_floor: f64, raw_sigma: f64) -> PracticalSize {
    let before_rounding = (raw_sigma.powi(2) - q_floor.powi(2)).max(0.0).sqrt();
    PracticalSize {
        rounding: rounding_bias(q_floor * 12f64.sqrt(), before_rounding),
        share: PRACTICAL_BIAS_SHARE,
    }
}

pub(super) fn signals(inp: &Inputs, nominal: &crate::replay::Replay) -> Vec<(String, Vec<f64>)> {
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

pub(super) fn correlate(
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

/// `segs` from row `first` on (the ones ending before it dropped, the one across it cut).
pub(super) fn segments_from(segs: &[Segment], first: usize) -> Vec<Segment> {
    segs.iter()
        .filter(|s| s.end > first)
        .map(|s| Segment {
            start: s.start.max(first),
            ..*s
        })
        .collect()
}

pub(super) fn metrics(
    inp: &Inputs,
    pred: &[f64],
    rows: &[usize],
    segs: &[Segment],
    noise: Noise,
    min_len: usize,
    practical: PracticalSize,
) -> Metrics {
    let y = pick(&inp.measured, rows);
    let e: Vec<f64> = rows.iter().map(|&i| inp.measured[i] - pred[i]).collect();
    let first = rows.first().copied().unwrap_or(0);
    let ym = mean(&y);
    let dev = y.iter().map(|v| (v - ym).powi(2)).sum::<f64>().sqrt();
    let en = e.iter().map(|v| v * v).sum::<f64>().sqrt();
    let full: Vec<f64> = (0..inp.len()).map(|i| inp.measured[i] - pred[i]).collect();
    let clipped = segments_from(segs, first);
    Metrics {
        rms: stats::rms(&e),
        fit_pct: if dev > 0.0 {
            100.0 * (1.0 - en / dev)
        } else {
            0.0
        },
        bias: mean(&e),
        segments: segment_biases(
            &full,
            &inp.measured,
            &clipped,
            &inp.t_s,
            noise,
            min_len,
            practical,
        ),
    }
}

impl Prepared {
    /// Whether the replay is exact: the simulator's plant on the workpiece (`workpiece`
    /// given), where a correct model leaves only noise. On logged depths and real machines
    /// a model error remains.
    pub(super) fn replay_is_exact(&self) -> bool {
        matches!(
            self.inp.plant.engagement,
            acc_sim::replay::ReplayEngagement::Workpiece { .. }
        )
    }

    /// The practical floor of every segment-bias test on this log ([`practical_size`] of
    /// its rounding and raw noise).
    pub(super) fn practical(&self) -> PracticalSize {
        practical_size(self.q_floor, self.raw_sigma)
    }

    /// Split the log (selection / sealed, folds) and locate the nominal discrepancy.
    pub(super) fn new(model: &Model, log: &RunLog, opts: &Options) -> Result<Self, WorkflowError> {
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
        // Rows without a valid measurement are replayed (the plant integrates through
        // them) but never compared: not in selection, noise or the sealed part.
        let dead = log.dead_rows(inp.channel);
        let valid: Vec<usize> = (0..n).filter(|&i| dead[i].is_none()).collect();
        let excluded = Excluded::of(&dead);
        if valid.len() < needed {
            return Err(WorkflowError::TooFewValid {
                valid: valid.len(),
                rows: n,
                needed,
                folds: opts.folds,
                why: excluded.text(),
            });
        }
        // The sealed part is the last `sealed_fraction` of the valid rows; the selection
        // part (rows `0..n_sel`) ends where it begins. A log that ends in a long stretch of
        // air (a run logged on after its part was finished) would leave a sealed part
        // with no cutting row, which judges nothing (a force channel reads zero there):
        // then it starts where the last `sealed_fraction` of the valid cutting rows does.
        let mut k_sel = ((1.0 - opts.sealed_fraction) * valid.len() as f64).round() as usize;
        let cutting: Vec<usize> = (0..valid.len()).filter(|&k| inp.is_cut(valid[k])).collect();
        let mut sealed_moved = None;
        if !cutting.is_empty() && cutting.iter().all(|&k| k < k_sel) {
            let k_cut = ((1.0 - opts.sealed_fraction) * cutting.len() as f64).round() as usize;
            let k = cutting[k_cut.min(cutting.len() - 1)];
            if k >= needed.min(k_sel) {
                sealed_moved = Some((inp.t_s[valid[k_sel]], inp.t_s[valid[k]]));
                k_sel = k;
            }
        }
        let sel: Vec<usize> = valid[..k_sel].to_vec();
        let sealed_rows: Vec<usize> = valid[k_sel..].to_vec();
        let n_sel = sealed_rows[0];
        // Contiguous folds over the selection rows (positions in `sel`).
        let fold_len = k_sel / opts.folds;
        let folds: Vec<std::ops::Range<usize>> = (0..opts.folds)
            .map(|k| {
                let a = k * fold_len;
                let b = if k + 1 == opts.folds {
                    k_sel
                } else {
                    a + fold_len
                };
                a..b
            })
            .collect();
        let min_len = ((opts.min_segment_s / inp.period_s.max(1e-9)).round() as usize).max(3);

        // 1. Locate.
        let labels = label_rows(&inp, opts.transient_s);
        let segs = without_dead(&segments(&labels), &dead);
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
        let raw_sigma = noise_raw(&r0_full, &sel_segs, &sel).sigma;
        let noise0 = noise_of(&r0_full, &sel_segs, &sel, q_floor);
        let practical = practical_size(q_floor, raw_sigma);
        let sigs = signals(&inp, &nominal_replay);
        inp.prior = Some(crate::fit::Prior::around(model, noise0.sigma.max(1e-9)));
        let locate = Locate {
            residual_rms: stats::rms(&pick(&r0_full, &sel)),
            segments: segment_biases(
                &r0_full,
                &inp.measured,
                &sel_segs,
                &inp.t_s,
                noise0,
                min_len,
                practical,
            ),
            correlations: correlate(&pick(&r0_full, &sel), &sigs, &sel, opts.alpha),
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
            sealed_rows,
            excluded,
            sealed_moved,
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

/// The comparison `c` of the logged force with the estimator's output on the logged power,
/// if it decides the pair `a`, `b` (each with its fitted model) for `sensor_gain_drift`:
/// the pair is that drift and an effect off the logging path (not `measurement_delay`),
/// the logged force drifts against the power
/// ([`crate::replay::ForcePowerConsistency::drifts`]), and the drift fitted to the
/// residual has the same sign and is within a factor of 2 of the one against the power.
pub(super) fn force_drifts_against_power(
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

/// The sealed part (stage 5; the valid rows from `n_sel` on, never used in selection): the
/// nominal model, the nominal refit and the updated model (`updated`, its prediction)
/// compared.
pub(super) fn sealed_check(
    p: &Prepared,
    nominal_refit: &Model,
    updated: &[f64],
    noise_f: Noise,
) -> Sealed {
    let (inp, sealed_rows) = (&p.inp, &p.sealed_rows);
    let on_sealed = |pred: &[f64]| {
        metrics(
            inp,
            pred,
            sealed_rows,
            &p.segs,
            noise_f,
            p.min_len,
            p.practical(),
        )
    };
    let m_nom = on_sealed(&p.nominal_replay.predicted);
    let m_ref = on_sealed(&replay(nominal_refit, inp).predicted);
    let m_upd = on_sealed(updated);
    let red = |a: f64, b: f64| if a > 0.0 { 100.0 * (a - b) / a } else { 0.0 };
    Sealed {
        from_s: inp.t_s[sealed_rows[0]],
        to_s: inp.t_s[sealed_rows[sealed_rows.len() - 1]],
        rows: sealed_rows.len(),
        rms_reduction_pct: red(m_nom.rms, m_upd.rms),
        rms_reduction_vs_refit_pct: red(m_ref.rms, m_upd.rms),
        nominal: m_nom,
        nominal_refit: m_ref,
        updated: m_upd,
    }
}

impl WearOrTime {
    pub(super) fn verdict(&self) -> WearTimeVerdict {
        let d = (self.sse_time - self.sse_wear) / self.scale;
        if d > WEAR_TIME_SEPARATION {
            WearTimeVerdict::WearFitsBetter
        } else if d < -WEAR_TIME_SEPARATION {
            WearTimeVerdict::TimeFitsBetter
        } else {
            WearTimeVerdict::Tie
        }
    }

    pub(super) fn text(&self) -> String {
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
pub(super) fn wear_or_time(p: &Prepared, wear_model: &Model, free: &[Free]) -> Option<WearOrTime> {
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

impl ResidualCheck<'_> {
    pub(super) fn run(&self, model: &Model) -> (Noise, Option<Unexplained>) {
        let r = replay(model, self.inp);
        let rf: Vec<f64> = (0..self.inp.len())
            .map(|i| self.inp.measured[i] - r.predicted[i])
            .collect();
        let noise = noise_of(&rf, self.segs, self.sel, self.q_floor);
        let on_sel = pick(&rf, self.sel);
        let flagged: Vec<_> = segment_biases(
            &rf,
            &self.inp.measured,
            self.segs,
            &self.inp.t_s,
            noise,
            self.min_len,
            self.practical,
        )
        .into_iter()
        .filter(|b| b.significant)
        .collect();
        let var_ratio = if noise.sigma > 0.0 {
            (stats::rms(&on_sel) / noise.sigma).powi(2)
        } else {
            1.0
        };
        let ne = n_eff(self.sel.len(), noise.rho);
        let var_z = (var_ratio - 1.0) / (2.0 / ne).sqrt();
        let too_big = var_z > 2.0 * normal_quantile(1.0 - self.alpha / 2.0) && var_ratio > 1.1;
        let un = (!flagged.is_empty() || too_big).then(|| Unexplained {
            segments: flagged,
            variance_ratio: var_ratio,
            variance_z: var_z,
            correlations: correlate(&on_sel, self.sigs, self.sel, self.alpha),
        });
        (noise, un)
    }
}

/// Express the Ks multiplier and the no-load offset relative to the model as given
/// (they were fitted relative to `start`).
pub(super) fn absolute(
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
pub(super) fn heldout_chi2(base: &[f64], cand: &[f64]) -> f64 {
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
pub(super) fn chi2_sf(x: f64, dof: usize) -> f64 {
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
pub(super) fn structure_remains(u: &Unexplained) -> bool {
    !u.segments.is_empty()
        || u.variance_ratio > STRUCTURE_VARIANCE_RATIO
        || u.correlations
            .iter()
            .any(|c| c.significant && c.r.abs() >= STRUCTURE_MIN_R)
}
