//! The honest twin: logs from the production path (`acc sim`'s closed loop, the same
//! [`acc_runtime::ControlLoop`] `acc run` drives) replayed by the simulator's own plant
//! ([`acc_sim::replay`]), and the model that describes a scenario's machine as the
//! discrepancy workflow sees it ([`model_for_scenario`]).

mod hidden;
pub use hidden::*;
use std::path::Path;

use acc_sim::scenario::{MeasurementSpec, Scenario};

use crate::effects::Effects;
use crate::model::{Channel, FeedInput, Measurement, Model, PlantForceModel};
use crate::replay::{replay, Inputs, ReplayError};
use crate::runlog::RunLog;

/// The model of `scenario`'s machine, tool and wear, compared on `channel`, replayed by
/// the simulator's plant (`feed_input = "plant"`) with the scenario's force model and the
/// window and spindle motor of its measurement channel. On the power channel of a
/// spindle-power scenario the model's `no_load_power_w` is the motor's air-cut input
/// power at the spindle speed.
pub fn model_for_scenario(scenario: &Scenario, channel: Channel) -> Model {
    let mut machine = scenario.machine.clone();
    let mut tool = scenario.tool.clone();
    tool.wear = scenario.wear;
    let (force_window_s, power_window_s, motor) = match scenario.measurement {
        MeasurementSpec::Dynamometer { window_s, .. } => (window_s, 0.0, None),
        MeasurementSpec::SpindlePower(spec) => (spec.window_s, spec.window_s, Some(spec.motor)),
    };
    // The force of a spindle-power channel is the estimator's: the replay then runs the
    // motor's power through it, so the motor is needed on both channels.
    let force_estimator = match channel {
        Channel::Force => estimator_of(scenario),
        Channel::Power => None,
    };
    let motor = if channel == Channel::Power || force_estimator.is_some() {
        motor
    } else {
        None
    };
    if let Some(m) = motor {
        if let Ok(cfg) = m.config() {
            machine.spindle.no_load_power_w = acc_sim::motor::Motor::new(cfg)
                .operating_point(machine.spindle.rpm, 0.0)
                .input_w;
        }
    }
    Model {
        name: format!("{} (twin of the scenario)", scenario.name),
        measurement: Measurement {
            channel,
            feed_input: FeedInput::Plant,
            force_window_s,
            force_model: match scenario.force_model {
                acc_sim::ForceModel::Mean => PlantForceModel::Mean,
                acc_sim::ForceModel::Tooth => PlantForceModel::Tooth,
            },
            spindle_motor: motor,
            power_window_s: if motor.is_some() { power_window_s } else { 0.0 },
            force_estimator,
        },
        machine,
        tool,
        effects: Effects::default(),
    }
}

/// The force estimator of `scenario`'s spindle-power channel as commissioned (the
/// calibration cut of [`acc_sim::motor::SpindlePowerChannel::calibrated_for`] with the
/// scenario's seed: the installation's calibration file); `None` for a dynamometer or a
/// current-based method.
pub fn estimator_of(scenario: &Scenario) -> Option<crate::model::ForceEstimator> {
    let MeasurementSpec::SpindlePower(spec) = scenario.measurement else {
        return None;
    };
    let law = acc_sim::process::ForceLaw::new(scenario.tool.process);
    let ch = acc_sim::motor::SpindlePowerChannel::calibrated_for(
        &spec,
        &scenario.machine.spindle,
        scenario.seed,
        law.torque_nm(1.0, scenario.tool.radius_mm()),
        scenario.controller.force_ref_n,
        scenario.tool.radius_mm(),
        scenario.controller.period_s,
    )
    .ok()?;
    crate::model::ForceEstimator::from_estimator(ch.source().estimator())
}

/// Run `scenario` with its adaptive law through `acc sim`'s production loop and return the
/// run log as the workflow reads it.
pub fn simulate(scenario: &Scenario) -> Result<RunLog, String> {
    let mut law = scenario
        .build_law(acc_sim::LawKind::Ours)
        .map_err(|e| e.to_string())?;
    let res = acc_sim::run(scenario, law.as_mut(), acc_sim::RunSetup::default())
        .map_err(|e| e.to_string())?;
    crate::runlog::from_records(&res.rows, Path::new(&scenario.name)).map_err(|e| e.to_string())
}

/// Residual of the replay of `model` on `log` (measured − replayed), with the
/// engagement from `workpiece` when given (tool centre at `x0_mm` when the log began).
pub fn replay_residual(
    model: &Model,
    log: &RunLog,
    workpiece: Option<(&acc_sim::Workpiece, f64)>,
) -> Result<Vec<f64>, ReplayError> {
    let mut inp = Inputs::from_log(log, model)?;
    if let Some((wp, x0)) = workpiece {
        inp.use_workpiece(wp.clone(), x0);
    }
    residual_of(model, &inp)
}

/// [`replay_residual`] of a log read with its workpiece ([`crate::runlog::read_csv_with`])
/// on that workpiece, placed as `acc discrepancy --workpiece` places it: the replayed tool
/// starts where the log says its first period began ([`RunLog::path_start_mm`]).
pub fn replay_residual_on_path(
    model: &Model,
    log: &RunLog,
    workpiece: &acc_sim::Workpiece,
) -> Result<Vec<f64>, ReplayError> {
    let mut inp = Inputs::from_log(log, model)?;
    inp.use_workpiece(workpiece.clone(), log.path_start_mm().unwrap_or(0.0));
    residual_of(model, &inp)
}

/// Measured − replayed on every row of `inp`.
fn residual_of(model: &Model, inp: &Inputs) -> Result<Vec<f64>, ReplayError> {
    let r = replay(model, inp);
    Ok(inp
        .measured
        .iter()
        .zip(&r.predicted)
        .map(|(m, p)| m - p)
        .collect())
}

/// One evaluation case: the scenario with the hidden effect in the simulated machine, the
/// nominal model and the workpiece the replay uses.
pub fn hidden_case(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
) -> (Scenario, Model, acc_sim::Workpiece) {
    let model = model_for_scenario(base, channel);
    let mut sc = base.clone();
    let mut wp_model = base.workpiece.clone();
    match hidden {
        Hidden::Null => {}
        Hidden::ToolWear(g) => sc.wear.growth_per_cm3 += g,
        Hidden::FeedDriveLag(t) => sc.machine.feed_drive.tau_s += t,
        Hidden::OverrideDeadTime(t) => sc.machine.override_path.delay_s += t,
        Hidden::CopperLoss(c) => {
            sc.machine.spindle.motor_efficiency = Some(acc_sim::config::MotorEfficiency {
                copper_loss_per_kw: c,
            })
        }
        Hidden::NoloadDrift(d) => {
            sc.machine.spindle.noload_drift = Some(acc_sim::config::NoloadDrift {
                delta_w: d,
                tau_s: 60.0,
            })
        }
        Hidden::SensorLowpass(t) => {
            sc.machine.spindle.sensor_lowpass = Some(acc_sim::config::SensorLowpass { tau_s: t })
        }
        Hidden::Runout(a) => {
            sc.tool.runout = Some(acc_sim::config::Runout {
                amplitude: a,
                phase_rad: 0.7,
            })
        }
        Hidden::DepthExponent(a) => sc.tool.process.alpha = a,
        Hidden::KsStep(k) => {
            // The material changes half-way along the cut; the model's workpiece does not
            // know it.
            let mut cut: Vec<usize> = (0..sc.workpiece.segments.len())
                .filter(|&i| sc.workpiece.segments[i].is_cut())
                .collect();
            // One cut segment (the ramp): the boundary is at its middle, not before it (a
            // factor on the whole cut is a calibration, which the refit absorbs).
            if let [i] = cut[..] {
                let g = sc.workpiece.segments[i];
                let mid = 0.5 * (g.start_mm + g.end_mm);
                let d = g.depth_at(mid);
                let mut second = g;
                second.start_mm = mid;
                second.depth_start_mm = d;
                let first = &mut sc.workpiece.segments[i];
                first.end_mm = mid;
                first.depth_end_mm = d;
                sc.workpiece.segments.insert(i + 1, second);
                cut = vec![i, i + 1];
            }
            let half = cut.len() / 2;
            for &i in &cut[half..] {
                sc.workpiece.segments[i].ks_factor *= k;
            }
            wp_model = base.workpiece.clone();
        }
        Hidden::ToothModel => sc.force_model = acc_sim::ForceModel::Tooth,
        Hidden::NcOverrideCap(p) => sc.machine.override_path.nc_max_pct = Some(p),
        Hidden::WearAndNoloadDrift(g) => {
            sc.wear.growth_per_cm3 += g;
            sc.machine.spindle.noload_drift = Some(acc_sim::config::NoloadDrift {
                delta_w: PAIR_NOLOAD_DRIFT_W,
                tau_s: 60.0,
            });
        }
        Hidden::WearAndFeedDriveLag(g) => {
            sc.wear.growth_per_cm3 += g;
            sc.machine.feed_drive.tau_s += PAIR_FEED_LAG_S;
        }
        Hidden::DepthScale(k) => {
            for g in sc.workpiece.segments.iter_mut() {
                g.depth_start_mm *= k;
                g.depth_end_mm *= k;
            }
        }
        Hidden::PositionOffset(dx) => {
            for g in sc.workpiece.segments.iter_mut() {
                g.start_mm += dx;
                g.end_mm += dx;
            }
        }
        Hidden::HardBands(k) => {
            let mut out = Vec::new();
            for g in &sc.workpiece.segments {
                if !g.is_cut() {
                    out.push(*g);
                    continue;
                }
                let mut a = g.start_mm;
                while a < g.end_mm - 1e-9 {
                    let b = (a + 10.0).min(g.end_mm);
                    let band = ((a - g.start_mm) / 10.0).round() as i64;
                    out.push(acc_sim::workpiece::Segment {
                        start_mm: a,
                        end_mm: b,
                        depth_start_mm: g.depth_at(a),
                        depth_end_mm: g.depth_at(b),
                        ks_factor: g.ks_factor * if band % 2 == 1 { k } else { 1.0 },
                        ..*g
                    });
                    a = b;
                }
            }
            sc.workpiece.segments = out;
        }
        Hidden::EntryChamfer(len) => {
            let mut out: Vec<acc_sim::workpiece::Segment> = Vec::new();
            for g in &sc.workpiece.segments {
                let after_air = out.last().is_none_or(|p| !p.is_cut());
                if g.is_cut() && after_air && g.end_mm - g.start_mm > 2.0 * len {
                    let m = g.start_mm + len;
                    out.push(acc_sim::workpiece::Segment {
                        end_mm: m,
                        depth_start_mm: 0.0,
                        depth_end_mm: g.depth_at(m),
                        ..*g
                    });
                    out.push(acc_sim::workpiece::Segment {
                        start_mm: m,
                        depth_start_mm: g.depth_at(m),
                        ..*g
                    });
                } else {
                    out.push(*g);
                }
            }
            sc.workpiece.segments = out;
        }
        Hidden::KsTimeDrift(g) => sc.wear.growth_per_min += g,
        Hidden::DepthThreshold(k) => {
            let d0 = DEPTH_THRESHOLD_MM;
            let mut out = Vec::new();
            for g in &sc.workpiece.segments {
                let ramp = (g.depth_end_mm - g.depth_start_mm).abs() > 1e-9;
                if !g.is_cut() || g.depth_start_mm.max(g.depth_end_mm) <= d0 {
                    out.push(*g);
                    continue;
                }
                let step = if ramp { 2.0 } else { g.end_mm - g.start_mm };
                let mut a = g.start_mm;
                while a < g.end_mm - 1e-9 {
                    let b = (a + step).min(g.end_mm);
                    let d = g.depth_at(0.5 * (a + b));
                    let f = if d > d0 { 1.0 + k * (d - d0) / d0 } else { 1.0 };
                    out.push(acc_sim::workpiece::Segment {
                        start_mm: a,
                        end_mm: b,
                        depth_start_mm: g.depth_at(a),
                        depth_end_mm: g.depth_at(b),
                        ks_factor: g.ks_factor * f,
                        ..*g
                    });
                    a = b;
                }
            }
            sc.workpiece.segments = out;
        }
        Hidden::SecondOrderDrive(t) => sc.machine.feed_drive.tau2_s = t,
        // The logging-path effects act on the logged column after the run
        // (`apply_logging_path`).
        h => debug_assert!(h.on_logging_path(), "{h:?} is not set in the machine"),
    }
    (sc, model, wp_model)
}

/// What the workflow said on one case.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Named effects.
    pub named: Vec<crate::EffectKind>,
    /// Ambiguous pairs reported.
    pub ambiguous: bool,
    /// "Unexplained" reported.
    pub unexplained: bool,
    /// Whether the named effect's primary interval covers `truth` (in-library only).
    pub covered: Option<bool>,
    /// Effects that passed selection but were withheld (structure remained, the sealed
    /// part was not predicted, or tool wear could not be told from a drift in time).
    pub withheld: Vec<String>,
    /// The report's conclusion.
    pub conclusion: String,
    /// The report's "what was done and why" (`report.explanation`).
    pub explanation: Vec<String>,
    /// The case's effect-to-noise ratio ([`effect_to_noise`]), − (0 for a null case).
    pub enr: f64,
    /// The same after calibration ([`calibrated_effect_to_noise`]), − (0 for a null case).
    pub enr_calibrated: f64,
}

/// The logging-path effects ([`Hidden::LogGainDrift`], [`Hidden::LogDelay`],
/// [`Hidden::LogSpikes`], [`Hidden::LogZeroShift`], [`Hidden::LogZeroDrift`],
/// [`Hidden::LogInterference`],
/// [`Hidden::LogClip`], [`Hidden::LogQuantize`], [`Hidden::LogStale`]) on the logged
/// measured column of `channel`, after the run.
pub fn apply_logging_path(hidden: Hidden, channel: Channel, log: &mut RunLog) {
    let t_s = log.t_s.clone();
    let col = match channel {
        Channel::Power => log.power_w.as_mut(),
        Channel::Force => log.force_n.as_mut(),
    };
    if let Some(col) = col {
        match hidden {
            Hidden::LogGainDrift(g) => {
                for (v, t) in col.iter_mut().zip(&t_s) {
                    *v *= 1.0 + g * t / 60.0;
                }
            }
            Hidden::LogDelay(k) if k > 0 && col.len() > k => {
                let orig = col.clone();
                for i in 0..col.len() {
                    col[i] = orig[i.saturating_sub(k)];
                }
            }
            Hidden::LogSpikes(a) => {
                // 2 % of the rows, alternating sign, a fraction `a` of the median |value|.
                let mut m: Vec<f64> = col.iter().map(|v| v.abs()).collect();
                m.sort_by(f64::total_cmp);
                let med = m.get(m.len() / 2).copied().unwrap_or(0.0);
                let mut sign = 1.0;
                for i in (17..col.len()).step_by(50) {
                    col[i] += sign * a * med;
                    sign = -sign;
                }
            }
            Hidden::LogZeroShift(a) => {
                let med = median_abs(col);
                let t_mid = 0.5 * (t_s.first().unwrap_or(&0.0) + t_s.last().unwrap_or(&0.0));
                for (v, t) in col.iter_mut().zip(&t_s) {
                    if *t >= t_mid {
                        *v += a * med;
                    }
                }
            }
            Hidden::LogZeroDrift(a) => {
                let med = median_abs(col);
                let t0 = t_s.first().copied().unwrap_or(0.0);
                let span = (t_s.last().copied().unwrap_or(0.0) - t0).max(1e-9);
                for (v, t) in col.iter_mut().zip(&t_s) {
                    *v += a * med * (t - t0) / span;
                }
            }
            Hidden::LogInterference(a) => {
                let med = median_abs(col);
                for (v, t) in col.iter_mut().zip(&t_s) {
                    *v += a * med * (2.0 * std::f64::consts::PI * 0.3 * t).sin();
                }
            }
            Hidden::LogClip(a) => {
                let top = a * col.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                for v in col.iter_mut() {
                    *v = v.min(top);
                }
            }
            Hidden::LogQuantize(a) => {
                let q = a * median_abs(col);
                if q > 0.0 {
                    for v in col.iter_mut() {
                        *v = (*v / q).round() * q;
                    }
                }
            }
            Hidden::LogStale(a) if a > 0.0 => {
                // Every k-th row (k = 1/a, from row 11) repeats the row before it.
                let k = (1.0 / a).round().max(1.0) as usize;
                for i in (11..col.len()).step_by(k) {
                    col[i] = col[i - 1];
                }
            }
            _ => {}
        }
    }
}

/// Median of |v| over `col` (0 when empty).
fn median_abs(col: &[f64]) -> f64 {
    let mut m: Vec<f64> = col.iter().map(|v| v.abs()).collect();
    m.sort_by(f64::total_cmp);
    m.get(m.len() / 2).copied().unwrap_or(0.0)
}

/// The log of one case (the scenario with `hidden` in the simulated machine, run with
/// `seed` through the production loop, the logging-path effect applied), the nominal
/// model with the installation's estimator, and the workpiece the replay uses.
pub fn case_log(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
) -> Result<(RunLog, Model, acc_sim::Workpiece), String> {
    let (mut sc, mut model, wp) = hidden_case(base, hidden, channel);
    sc.seed = seed;
    if model.measurement.force_estimator.is_some() {
        // The installation's calibration file: the channel as commissioned on this
        // machine (seed) — what the estimator in the log used.
        model.measurement.force_estimator = estimator_of(&sc);
    }
    let mut log = simulate(&sc)?;
    apply_logging_path(hidden, channel, &mut log);
    Ok((log, model, wp))
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// Noise σ of a residual from its first differences (1.4826·MAD/√2) over the rows where
/// it is not exactly 0 (air rows of a dynamometer channel), in the residual's unit.
pub fn difference_sigma(r: &[f64]) -> f64 {
    let live: Vec<f64> = r.iter().copied().filter(|x| *x != 0.0).collect();
    let mut d: Vec<f64> = live.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0) / 0.6745 / 2f64.sqrt()
}

/// Effect-to-noise ratio of a case from the nominal replay's residuals on the log with
/// the hidden effect (`with`, RMS `r_h`) and on the null log of the same scenario,
/// workpiece and seed (`without`, RMS `r_0`, difference σ `σ_0`):
/// `ENR = √max(0, r_h² − r_0²) / σ_0`, − (the part of the residual the effect adds, in
/// noise σ).
pub fn enr_of_residuals(with: &[f64], without: &[f64]) -> f64 {
    let (a, b) = (rms(with), rms(without));
    let s = difference_sigma(without).max(1e-9);
    (a * a - b * b).max(0.0).sqrt() / s
}

/// Effect-to-noise ratio of one case ([`enr_of_residuals`]): the case's log and the null
/// log of the same workpiece and seed, both replayed by the nominal model on the
/// workpiece; 0 for [`Hidden::Null`].
pub fn effect_to_noise(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
) -> Result<f64, String> {
    let (log, model, wp) = case_log(base, hidden, channel, seed)?;
    Ok(enrs_for_log(base, hidden, channel, seed, &log, &model, &wp, false)?.0)
}

/// Effect-to-noise ratio after calibration: [`enr_of_residuals`] of the case's log and
/// the null log (same workpiece and seed), each replayed by the nominal model with its
/// calibration (`Ks` scale, no-load offset) refitted to that log
/// ([`crate::workflow::calibrated_residual`]): the size of what a recalibration cannot
/// absorb — a runout at one spindle revolution per period is mostly a constant gain on the
/// force, which the refitted `Ks` takes. 0 for [`Hidden::Null`].
pub fn calibrated_effect_to_noise(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
) -> Result<f64, String> {
    let (log, model, wp) = case_log(base, hidden, channel, seed)?;
    Ok(enrs_for_log(base, hidden, channel, seed, &log, &model, &wp, true)?.1)
}

/// The case's [`effect_to_noise`] and, with `calibrated`, its
/// [`calibrated_effect_to_noise`] (else 0), on the case's log already made: the null log
/// is simulated once for both.
#[allow(clippy::too_many_arguments)]
fn enrs_for_log(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
    log: &RunLog,
    model: &Model,
    wp: &acc_sim::Workpiece,
    calibrated: bool,
) -> Result<(f64, f64), String> {
    if hidden == Hidden::Null {
        return Ok((0.0, 0.0));
    }
    let (log0, model0, wp0) = case_log(base, Hidden::Null, channel, seed)?;
    let rh = replay_residual(model, log, Some((wp, 0.0))).map_err(|e| e.to_string())?;
    let r0 = replay_residual(&model0, &log0, Some((&wp0, 0.0))).map_err(|e| e.to_string())?;
    let enr = enr_of_residuals(&rh, &r0);
    if !calibrated {
        return Ok((enr, 0.0));
    }
    let cal = |m: &Model, l: &RunLog, w: &acc_sim::Workpiece| {
        let opts = crate::workflow::Options {
            workpiece: Some((w.clone(), 0.0)),
            ..crate::workflow::Options::default()
        };
        crate::workflow::calibrated_residual(m, l, &opts).map_err(|e| e.to_string())
    };
    Ok((
        enr,
        enr_of_residuals(&cal(model, log, wp)?, &cal(&model0, &log0, &wp0)?),
    ))
}

/// The amplitude of `hidden` in its library effect's first parameter (what the named
/// effect's interval should cover), if it is a library effect with one.
pub fn truth_of(base: &Scenario, hidden: Hidden) -> Option<f64> {
    match hidden {
        Hidden::ToolWear(v)
        | Hidden::FeedDriveLag(v)
        | Hidden::OverrideDeadTime(v)
        | Hidden::CopperLoss(v)
        | Hidden::NoloadDrift(v)
        | Hidden::SensorLowpass(v)
        | Hidden::Runout(v)
        | Hidden::LogGainDrift(v)
        | Hidden::SecondOrderDrive(v) => Some(v),
        Hidden::LogDelay(k) => Some(k as f64 * base.controller.period_s),
        Hidden::DepthExponent(a) => Some(a - base.tool.process.alpha),
        Hidden::KsStep(k) => Some(k - 1.0),
        _ => None,
    }
}

/// Run one case end to end: simulate through the production loop, analyse; the verdict
/// carries the case's effect-to-noise ratio ([`effect_to_noise`]).
pub fn run_case(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
) -> Result<Verdict, String> {
    run_case_with(base, hidden, channel, seed, CaseAnalysis::default())
}

/// How [`run_case_with`] analyses a case's log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CaseAnalysis {
    /// Replay on the workpiece (exact: the default) or on the log's own depths, held over
    /// each row (not exact: a model error remains, as on a real machine's log).
    pub on_workpiece: bool,
    /// [`crate::workflow::Options::withhold_on_structure`] (`Some(true)`: the default).
    pub withhold_on_structure: Option<bool>,
}

impl Default for CaseAnalysis {
    fn default() -> Self {
        CaseAnalysis {
            on_workpiece: true,
            withhold_on_structure: crate::workflow::Options::default().withhold_on_structure,
        }
    }
}

/// [`run_case`] with the log analysed as `how` says.
pub fn run_case_with(
    base: &Scenario,
    hidden: Hidden,
    channel: Channel,
    seed: u64,
    how: CaseAnalysis,
) -> Result<Verdict, String> {
    let (log, model, wp) = case_log(base, hidden, channel, seed)?;
    let (enr, enr_calibrated) = enrs_for_log(base, hidden, channel, seed, &log, &model, &wp, true)?;
    // The configuration `acc discrepancy` runs by default (on the workpiece when asked).
    let opts = crate::workflow::Options {
        workpiece: how.on_workpiece.then_some((wp, 0.0)),
        withhold_on_structure: how.withhold_on_structure,
        ..crate::workflow::Options::default()
    };
    let a = crate::workflow::analyse(&model, &log, &opts).map_err(|e| e.to_string())?;
    let named: Vec<crate::EffectKind> = a
        .report
        .accepted
        .iter()
        .filter_map(|n| crate::EffectKind::from_name(n))
        .collect();
    let truth = truth_of(base, hidden);
    let covered = match (hidden.library(), truth) {
        (Some(k), Some(v)) if named.contains(&k) => a
            .report
            .updated_params
            .iter()
            .find(|p| p.name == format!("{}.{}", k.name(), k.params()[0].key))
            .map(|p| p.ci_low <= v && v <= p.ci_high),
        _ => None,
    };
    Ok(Verdict {
        named,
        ambiguous: !a.report.ambiguous.is_empty(),
        unexplained: a.report.unexplained.is_some(),
        covered,
        withheld: a.report.withheld.iter().map(|w| w.effect.clone()).collect(),
        conclusion: a.report.conclusion.clone(),
        explanation: a.report.explanation.clone(),
        enr,
        enr_calibrated,
    })
}
