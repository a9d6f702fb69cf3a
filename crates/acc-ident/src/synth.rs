//! Synthetic measured logs with hidden effects, for the recovery tests, the sweep and the
//! benchmark.
//!
//! The inputs are an open-loop run of the paper machine (seed 002: 600 rpm, 200 mm/min
//! programmed, Ø16 mm 4-flute end mill, 16 mm axial depth): repeating 40 s blocks with an
//! air-cut pause and radial depths 2, 3, 4 mm, and a seeded override schedule (60–150 % in
//! 10 % steps, held around depth steps so that depth steps happen at constant feed). The
//! "measurement" is the replay of the truth model (nominal + hidden effects, the
//! simulator's physics through [`crate::physics`]) plus white or AR(1) noise.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::effects::EffectKind;
use crate::fit::{self, Free};
use crate::model::{
    Channel, FeedDrive, FeedInput, Machine, Measurement, Model, OverridePath, Process, Spindle,
    Tool, Wear,
};
use crate::replay::{replay, Inputs};
use crate::runlog::RunLog;

/// A synthetic experiment.
#[derive(Debug, Clone)]
pub struct Case {
    /// Log length, s. Default 240.
    pub duration_s: f64,
    /// Sampling period T, s. Default 0.1.
    pub period_s: f64,
    /// Spindle speed, rpm. Default 600 (runout then invisible in period means).
    pub rpm: f64,
    /// Programmed feed, mm/min. Default 200.
    pub programmed_feed_mm_min: f64,
    /// Compared channel. Default power.
    pub channel: Channel,
    /// Noise standard deviation, channel unit. Default 8 (W).
    pub noise_sigma: f64,
    /// AR(1) correlation of the noise (0 = white). Default 0.
    pub noise_rho: f64,
    /// A poorly exciting run instead: one continuous 3 mm cut after 3 s of air, override
    /// fixed at 100 % (no pauses, no steps). Default false.
    pub continuous: bool,
}

impl Default for Case {
    fn default() -> Self {
        Case {
            duration_s: 240.0,
            period_s: 0.1,
            rpm: 600.0,
            programmed_feed_mm_min: 200.0,
            channel: Channel::Power,
            noise_sigma: 8.0,
            noise_rho: 0.0,
            continuous: false,
        }
    }
}

/// A hidden effect: kind and its primary parameter (the others at [`secondary`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hidden {
    /// Effect.
    pub kind: EffectKind,
    /// Value of its primary parameter.
    pub value: f64,
}

/// Fixed values of the non-primary parameters used when hiding an effect.
pub fn secondary(kind: EffectKind, model: &Model) -> Vec<(usize, f64)> {
    match kind {
        EffectKind::FeedExponent => vec![(1, model.tool.process.calib_feed_mm_min)],
        EffectKind::Runout => vec![(1, 1.0)],
        EffectKind::NoloadDrift => vec![(1, 150.0)],
        _ => vec![],
    }
}

/// Sign of the primary parameter when hiding an effect (the feed exponent is hidden as a
/// smaller β, as for steel, physics.md eq. (3)).
pub fn sign(kind: EffectKind) -> f64 {
    if kind == EffectKind::FeedExponent {
        -1.0
    } else {
        1.0
    }
}

/// The nominal model of the synthetic machine (the paper's, physics.md §1).
pub fn nominal_model(case: &Case) -> Model {
    Model {
        name: "paper machine (synthetic)".into(),
        measurement: Measurement {
            channel: case.channel,
            // The synthetic log's override columns follow the command-path convention (a
            // row's command acts after the override delay), not the board's applied value.
            feed_input: FeedInput::Command,
            force_window_s: 0.0,
            ..Default::default()
        },
        machine: Machine {
            name: "paper VMC".into(),
            spindle: Spindle::new(case.rpm, 500.0, 0.85),
            feed_drive: FeedDrive {
                tau_s: 0.05,
                tau2_s: 0.0,
                accel_mm_s2: 0.0,
                rapid_mm_min: 10_000.0,
            },
            override_path: OverridePath {
                delay_s: 0.1,
                step_pct: 10,
                nc_max_pct: None,
            },
            sim: Default::default(),
            travel: None,
        },
        tool: Tool {
            name: "HSS end mill D16 z4".into(),
            diameter_mm: 16.0,
            flutes: 4,
            process: Process {
                alpha: 0.8,
                gamma: 0.0,
                ..Process::paper()
            },
            wear: Wear::default(),
            tooth: Default::default(),
            runout: None,
        },
        effects: Default::default(),
    }
}

/// The input part of a synthetic log (no measured channel yet).
pub fn inputs(case: &Case, seed: u64) -> RunLog {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_1de7);
    let n = (case.duration_s / case.period_s).round() as usize;
    let mut log = RunLog {
        x_mm: Some(Vec::with_capacity(n)),
        programmed_feed_mm_min: Some(Vec::with_capacity(n)),
        override_cmd_pct: Some(Vec::with_capacity(n)),
        ..RunLog::default()
    };
    let block = 40.0;
    let continuous = case.continuous;
    let depth_at = |t: f64| -> f64 {
        if continuous {
            return if t < 3.0 { 0.0 } else { 3.0 };
        }
        let tb = t % block;
        if tb < 3.0 {
            0.0
        } else if tb < 15.0 {
            2.0
        } else if tb < 27.0 {
            3.0
        } else {
            4.0
        }
    };
    let mut ovr = 100.0;
    let mut next_change = 2.0;
    for i in 0..n {
        let t = (i + 1) as f64 * case.period_s;
        if t >= next_change && !continuous {
            // Hold the override 1.5 s around depth changes (they then happen at constant feed).
            let tb = t % block;
            let near = [0.0, 3.0, 15.0, 27.0, 40.0]
                .iter()
                .any(|e| (tb - e).abs() < 1.5);
            if !near {
                ovr = 60.0 + 10.0 * rng.random_range(0..10) as f64;
            }
            next_change = t + rng.random_range(2.0..5.0);
        }
        let d = depth_at(t);
        log.t_s.push(t);
        log.radial_depth_mm.push(d);
        log.axial_depth_mm.push(if d > 0.0 { 16.0 } else { 0.0 });
        log.spindle_rpm.push(case.rpm);
        if let Some(v) = log.programmed_feed_mm_min.as_mut() {
            v.push(case.programmed_feed_mm_min);
        }
        if let Some(v) = log.override_cmd_pct.as_mut() {
            v.push(ovr);
        }
        log.feed_mm_min
            .push(case.programmed_feed_mm_min * ovr / 100.0);
    }
    log
}

/// Truth model: `nominal` with the hidden effects switched on.
pub fn truth_model(nominal: &Model, hidden: &[Hidden]) -> Model {
    let mut m = nominal.clone();
    for h in hidden {
        m.effects.set(h.kind, 0, h.value);
        for (i, v) in secondary(h.kind, nominal) {
            m.effects.set(h.kind, i, v);
        }
    }
    m
}

/// Stationary AR(1) noise of standard deviation `sigma`.
pub fn ar1_noise(n: usize, sigma: f64, rho: f64, rng: &mut impl Rng) -> Vec<f64> {
    let s = sigma * (1.0 - rho * rho).max(0.0).sqrt();
    let z0: f64 = StandardNormal.sample(rng);
    let mut e = sigma * z0;
    (0..n)
        .map(|i| {
            if i > 0 {
                let w: f64 = StandardNormal.sample(rng);
                e = rho * e + s * w;
            }
            e
        })
        .collect()
}

/// Fill the measured columns of `log` from `truth` plus noise; returns the noise-free
/// truth of the compared channel.
fn measure(case: &Case, truth: &Model, log: &mut RunLog, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = log.len();
    // Inputs::from_log needs a measured column; start from zeros.
    log.power_w = Some(vec![0.0; n]);
    log.force_n = Some(vec![0.0; n]);
    let mut pm = truth.clone();
    pm.measurement.channel = Channel::Power;
    let mut fm = truth.clone();
    fm.measurement.channel = Channel::Force;
    let (Ok(ip), Ok(iff)) = (Inputs::from_log(log, &pm), Inputs::from_log(log, &fm)) else {
        return vec![0.0; n];
    };
    let rp = replay(&pm, &ip);
    let rf = replay(&fm, &iff);
    log.feed_mm_min.clone_from(&rp.feed_mm_min);
    log.x_mm = Some(
        rp.feed_mm_min
            .iter()
            .scan(0.0, |x, f| {
                *x += f / 60.0 * case.period_s;
                Some(*x)
            })
            .collect(),
    );
    log.override_applied_pct = log.override_cmd_pct.clone();
    let noise = ar1_noise(n, case.noise_sigma, case.noise_rho, &mut rng);
    let (clean, other) = match case.channel {
        Channel::Power => (rp.predicted, rf.predicted),
        Channel::Force => (rf.predicted, rp.predicted),
    };
    let noisy: Vec<f64> = clean.iter().zip(&noise).map(|(c, e)| c + e).collect();
    match case.channel {
        Channel::Power => {
            log.power_w = Some(noisy);
            log.force_n = Some(other);
        }
        Channel::Force => {
            log.force_n = Some(noisy);
            log.power_w = Some(other);
        }
    }
    clean
}

/// Generate `(nominal model, measured log, noise-free truth of the channel)` for `hidden`
/// effects and a seed.
pub fn generate(case: &Case, hidden: &[Hidden], seed: u64) -> (Model, RunLog, Vec<f64>) {
    let nominal = nominal_model(case);
    let truth = truth_model(&nominal, hidden);
    let mut log = inputs(case, seed);
    let clean = measure(
        case,
        &truth,
        &mut log,
        seed.wrapping_mul(7919).wrapping_add(1),
    );
    (nominal, log, clean)
}

/// Effect-to-noise ratio of a hidden effect: RMS of what the nominal model cannot absorb
/// (the noise-free truth minus the nominal model with `Ks` and the no-load power refitted
/// to it) over the noise σ, on the first 80 % of the log.
pub fn effect_to_noise(case: &Case, hidden: &[Hidden], seed: u64) -> f64 {
    let (nominal, mut log, clean) = generate(case, hidden, seed);
    let n = log.len();
    let n_sel = (0.8 * n as f64) as usize;
    match case.channel {
        Channel::Power => log.power_w = Some(clean),
        Channel::Force => log.force_n = Some(clean),
    }
    let Ok(inp) = Inputs::from_log(&log, &nominal) else {
        return 0.0;
    };
    let free = match case.channel {
        Channel::Power => vec![Free::KsScale, Free::Noload],
        Channel::Force => vec![Free::KsScale],
    };
    let rows: Vec<usize> = (0..n_sel).collect();
    let m = fit::refine(&nominal, &free, &inp, &rows);
    let sse = fit::sse(&m, &inp, &rows);
    (sse / n_sel as f64).sqrt() / case.noise_sigma.max(1e-12)
}

/// The primary-parameter value of `kind` that gives effect-to-noise ratio `enr`
/// (bisection between the null and the parameter's bound).
pub fn value_for_enr(case: &Case, kind: EffectKind, enr: f64, seed: u64) -> f64 {
    let p = kind.params()[0];
    let sgn = sign(kind);
    // Stay inside 90 % of the fitting range so the truth is not on a bound.
    let hi0 = 0.9 * if sgn > 0.0 { p.hi } else { -p.lo };
    let (mut lo, mut hi) = (
        0.0,
        hi0.min(match kind {
            EffectKind::ToolWear => 0.2,
            EffectKind::MotorEfficiency => 2.0,
            EffectKind::NoloadDrift => 500.0,
            _ => hi0,
        }),
    );
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        let h = Hidden {
            kind,
            value: sgn * mid,
        };
        if effect_to_noise(case, &[h], seed) < enr {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    sgn * 0.5 * (lo + hi)
}

/// What one synthetic run gave, judged against its hidden truth.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Effects named (accepted, not ambiguous).
    pub named: Vec<EffectKind>,
    /// Ambiguous pairs.
    pub ambiguous: Vec<(EffectKind, EffectKind)>,
    /// An unexplained residual was reported.
    pub unexplained: bool,
    /// Exactly the hidden effects were named, nothing else, no ambiguity.
    pub exact: bool,
    /// For each hidden effect: its 95 % interval covers the true value (None: not named).
    pub covered: Vec<Option<bool>>,
    /// Sealed-part RMS of the nominal model, the updated model and the true model.
    pub rms_nominal: f64,
    /// Updated model's sealed RMS.
    pub rms_updated: f64,
    /// True model's sealed RMS (the noise).
    pub rms_true: f64,
    /// `(nominal − updated)/(nominal − true)` on the sealed part (1 = as good as the truth).
    pub gap_closed: f64,
}

/// Generate a log with `hidden`, run the workflow, judge the result.
pub fn evaluate(
    case: &Case,
    hidden: &[Hidden],
    seed: u64,
    opts: &crate::workflow::Options,
) -> Result<Outcome, crate::workflow::WorkflowError> {
    let (model, log, clean) = generate(case, hidden, seed);
    let a = crate::workflow::analyse(&model, &log, opts)?;
    let r = &a.report;
    let named: Vec<EffectKind> = r
        .accepted
        .iter()
        .filter_map(|n| EffectKind::from_name(n))
        .collect();
    let ambiguous: Vec<(EffectKind, EffectKind)> = r
        .ambiguous
        .iter()
        .filter_map(|p| {
            Some((
                EffectKind::from_name(&p.effects[0])?,
                EffectKind::from_name(&p.effects[1])?,
            ))
        })
        .collect();
    let mut want: Vec<EffectKind> = hidden.iter().map(|h| h.kind).collect();
    want.sort();
    let mut got = named.clone();
    got.sort();
    let exact = got == want && ambiguous.is_empty();
    let covered = hidden
        .iter()
        .map(|h| {
            let key = format!("{}.{}", h.kind.name(), h.kind.params()[0].key);
            r.updated_params
                .iter()
                .find(|p| p.name == key && named.contains(&h.kind))
                .map(|p| p.ci_low <= h.value && h.value <= p.ci_high)
        })
        .collect();
    let measured = match case.channel {
        Channel::Power => log.power_w.unwrap_or_default(),
        Channel::Force => log.force_n.unwrap_or_default(),
    };
    let from = r.input.selection_rows;
    let e: Vec<f64> = (from..measured.len())
        .map(|i| measured[i] - clean[i])
        .collect();
    let rms_true = crate::stats::rms(&e);
    let (rn, ru) = (r.sealed.nominal.rms, r.sealed.updated.rms);
    let gap_closed = if rn - rms_true > 1e-12 {
        (rn - ru) / (rn - rms_true)
    } else {
        1.0
    };
    Ok(Outcome {
        named,
        ambiguous,
        unexplained: r.unexplained.is_some(),
        exact,
        covered,
        rms_nominal: rn,
        rms_updated: ru,
        rms_true,
        gap_closed,
    })
}
