//! Open-loop replay of a model on the inputs recorded in a run log: the recorded
//! engagement, spindle speed and feed commands drive the simulator's plant
//! ([`acc_sim::replay`]); nothing is fed back, so the prediction is compared with the
//! measurement like for like. This module prepares the plant's inputs from the log and
//! scales its unit-force trace by the model's `Ks`, wear, runout and candidate effects;
//! the override path, feed drive, engagement and force law are the simulator's.
//!
//! Files: [`inputs`] (the logged columns the plant runs on), [`path`] (the plant's trace
//! under a model, shared between models), [`consistency`] (force
//! against power), [`ks_step`] (the material-step candidate), [`raced`] (writes that raced
//! the board's tick, re-timed by the board's feed).

mod consistency;
mod inputs;
mod ks_step;
mod path;
pub mod raced;

pub use consistency::ForcePowerConsistency;
pub use inputs::{FeedSource, Inputs, PlantInputs, ReplayError};
use ks_step::*;
pub(crate) use path::machine_inv_accel;
use path::{path, PathCache};

use crate::effects::EffectKind;
use crate::model::{Channel, FeedInput, Model};
use crate::physics;
use crate::runlog::RunLog;

/// One replay: the predicted channel and the internal signals that explain it.
#[derive(Debug, Clone, Default)]
pub struct Replay {
    /// Predicted measured channel (W or N).
    pub predicted: Vec<f64>,
    /// Replayed feed, mean over each period, mm/min.
    pub feed_mm_min: Vec<f64>,
    /// Replayed feed, mean over the force channel's averaging window, mm/min.
    pub window_feed_mm_min: Vec<f64>,
    /// Replayed mean cutting force, N.
    pub force_n: Vec<f64>,
    /// Removed volume since the start of the log, mm³.
    pub volume_mm3: Vec<f64>,
    /// Cutting power `F · v`, W.
    pub cut_power_w: Vec<f64>,
    /// Spindle angle at the end of each period, rad.
    pub spindle_angle_rad: Vec<f64>,
    /// Position of the `ks_step` candidate's boundary on the replayed tool path (the
    /// workpiece's x when the replay runs on a workpiece, else the path length from the
    /// log's start), mm; `None` without the candidate or without cutting rows.
    pub ks_step_boundary_mm: Option<f64>,
}

/// The window the compared channel averages at the end of each period, s.
fn channel_window_s(model: &Model, inp: &Inputs) -> f64 {
    match inp.channel {
        Channel::Force => model.measurement.force_window_s,
        Channel::Power => model.measurement.power_window_s,
    }
}

/// Replays kept per [`Inputs`] by [`replay_shared`].
const REPLAY_CACHE: usize = 8;

/// [`replay`], shared: the last [`REPLAY_CACHE`] replays on `inp` are kept with their
/// models, and a model equal to one of them gets that replay back instead of a new one
/// (a fit's Jacobian starts at the point whose residual it has just computed; each
/// cross-validation fold starts at the same model). The replay is a function of the model
/// and the inputs only, so the result is the same as [`replay`]'s.
pub fn replay_shared(model: &Model, inp: &Inputs) -> std::rc::Rc<Replay> {
    let mut v = inp.replays.borrow_mut();
    if let Some(k) = v.iter().position(|(m, _)| m == model) {
        let hit = v.remove(k);
        let r = hit.1.clone();
        v.push(hit);
        return r;
    }
    drop(v);
    let r = std::rc::Rc::new(replay(model, inp));
    let mut v = inp.replays.borrow_mut();
    if v.len() >= REPLAY_CACHE {
        v.remove(0);
    }
    v.push((model.clone(), r.clone()));
    r
}

/// Replay `model` on `inp` (open loop) through the simulator's plant
/// ([`acc_sim::replay::trace`]: override path, feed drive, engagement, force law), then
/// the scales, spindle power, sensor and measurement chain of [`replay_plant`].
pub fn replay(model: &Model, inp: &Inputs) -> Replay {
    let n = inp.len();
    let mut out = Replay {
        predicted: vec![0.0; n],
        feed_mm_min: vec![0.0; n],
        window_feed_mm_min: vec![0.0; n],
        force_n: vec![0.0; n],
        volume_mm3: vec![0.0; n],
        cut_power_w: vec![0.0; n],
        spindle_angle_rad: vec![0.0; n],
        ks_step_boundary_mm: None,
    };
    let plant = path(model, inp);
    replay_plant(model, inp, &plant, &mut out);
    measurement_chain(model, inp, &mut out.predicted);
    out
}

/// An optional effect as a flag and a value (`off` when absent), taken out of its
/// `Option` before a loop over the rows. A `map_or` on the `Option` inside the loop is
/// compiled to evaluate the term on the absent value's bytes as well and choose after —
/// undefined bytes that can read as a subnormal number, a hundred cycles a multiplication
/// on every row; a defined value costs nothing. The result is the same.
fn present<T: Copy>(o: Option<T>, off: T) -> (bool, T) {
    (o.is_some(), o.unwrap_or(off))
}

/// The candidate measurement-chain effects on the logged column: a pure delay, then a
/// gain drift.
fn measurement_chain(model: &Model, inp: &Inputs, y: &mut [f64]) {
    if let Some(d) = model.effects.measurement_delay {
        d.apply(y, &inp.t_s);
    }
    if let Some(g) = model.effects.sensor_gain_drift {
        g.apply(y, &inp.t_s);
    }
}

/// [`replay`] on the simulator's plant trace: the trace is at unit force scale, so `Ks`
/// (`calib_force_n`), the wear factor (the simulator's law on the replayed volume), the
/// feed exponent and the runout (its step means, through the trace's basis) scale it here;
/// the power is the spindle law of the model (constant-speed spindle, or the motor's
/// input-power curve at the logged speed through the window's mean and mean-square torque)
/// plus the machine's and the candidates' drift and losses, then the sensor low-passes.
#[allow(clippy::needless_range_loop)]
fn replay_plant(
    model: &Model,
    inp: &Inputs,
    tr: &[acc_sim::replay::PeriodTrace],
    out: &mut Replay,
) {
    let n = inp.len();
    let fx = &model.effects;
    let calib = model.tool.process.calib_force_n;
    let w = &model.tool.wear;
    let wear = acc_sim::process::WearSpec {
        growth_per_cm3: w.growth_per_cm3 + fx.get(EffectKind::ToolWear, 0),
        volume_exponent: fx
            .tool_wear
            .map_or(w.volume_exponent, |e| e.volume_exponent),
        ..*w
    };
    let dbeta = fx.get(EffectKind::FeedExponent, 0);
    let fref = fx.get(EffectKind::FeedExponent, 1).max(1e-9);
    let runouts: Vec<acc_sim::config::Runout> = [model.tool.runout, fx.runout]
        .into_iter()
        .flatten()
        .collect();
    let runout_gain = |unit: f64, basis: [f64; 2]| -> f64 {
        if unit <= 0.0 {
            return 1.0;
        }
        let mut g = 1.0;
        for r in &runouts {
            let (s, c) = r.phase_rad.sin_cos();
            g *= 1.0 + r.amplitude * (c * basis[0] + s * basis[1]) / unit;
        }
        g
    };
    // The force of a spindle-power estimator is replayed through the power it reads.
    let estimator = match (inp.channel, &inp.estimator_no_load) {
        (Channel::Force, Some(nl)) => model.measurement.force_estimator.map(|e| (e, nl)),
        _ => None,
    };
    let power_chan = inp.channel == Channel::Power || estimator.is_some();
    let motor = if power_chan {
        model.measurement.spindle_motor
    } else {
        None
    };
    let t0 = inp.t_s.first().copied().unwrap_or(0.0) - inp.dt_s.first().copied().unwrap_or(0.0);
    // The material step: per-row factors from the plant's tool-centre positions.
    let window_s = channel_window_s(model, inp);
    let steps = fx.ks_step.and_then(|_| {
        let x_end: Vec<f64> = tr.iter().map(|t| t.x_mm).collect();
        let x_start: Vec<f64> = (0..n)
            .map(|i| match i {
                0 => x_end[0] - tr[0].feed_mean_mm_min * inp.dt_s[0] / 60.0,
                _ => x_end[i - 1],
            })
            .collect();
        let cut: Vec<bool> = tr.iter().map(|t| t.unit_force_mean > 0.0).collect();
        let wf: Vec<f64> = inp
            .dt_s
            .iter()
            .map(|d| {
                if window_s > 0.0 && *d > 0.0 {
                    window_s / d
                } else {
                    1.0
                }
            })
            .collect();
        let r = model.tool.radius_mm();
        let shape = match &inp.plant.engagement {
            acc_sim::replay::ReplayEngagement::Workpiece { workpiece, .. } => {
                KsStepShape::Workpiece(workpiece, r)
            }
            _ => KsStepShape::Logged(&inp.radial_depth_mm, r),
        };
        ks_step_factors(fx.ks_step, &x_start, &x_end, &cut, &wf, &shape)
    });
    out.ks_step_boundary_mm = steps.as_ref().map(|s| s.0);
    // The optional terms as plain values before the row loop (see [`present`]).
    let sp = &model.machine.spindle;
    let no_drift = acc_sim::config::NoloadDrift {
        delta_w: 0.0,
        tau_s: 1.0,
    };
    let no_loss = acc_sim::config::MotorEfficiency {
        copper_loss_per_kw: 0.0,
    };
    let (sp_drift_on, sp_drift) = present(sp.noload_drift, no_drift);
    let (fx_drift_on, fx_drift) = present(fx.noload_drift, no_drift);
    let (sp_loss_on, sp_loss) = present(sp.motor_efficiency, no_loss);
    let (fx_loss_on, fx_loss) = present(fx.motor_efficiency, no_loss);
    let mut cut_min = 0.0;
    let mut theta = 0.0;
    for i in 0..n {
        let t = &tr[i];
        let (ks_mean, ks_win) = steps.as_ref().map_or((1.0, 1.0), |s| (s.1[i], s.2[i]));
        let s = inp.spindle_rpm[i];
        theta += 2.0 * std::f64::consts::PI * s / 60.0 * inp.dt_s[i];
        out.spindle_angle_rad[i] = theta;
        out.feed_mm_min[i] = t.feed_mean_mm_min;
        out.window_feed_mm_min[i] = t.feed_window_mm_min;
        out.volume_mm3[i] = t.volume_mm3;
        // The wear of the volume removed before the period (the period-based replay's
        // convention).
        let v_before = if i == 0 { 0.0 } else { tr[i - 1].volume_mm3 };
        let factor = wear.factor(v_before / 1000.0, cut_min);
        if t.unit_force_mean > 0.0 {
            cut_min += inp.dt_s[i] / 60.0;
        }
        let fb = |f: f64| {
            if dbeta != 0.0 && f > 0.0 {
                (f / fref).powf(dbeta)
            } else {
                1.0
            }
        };
        let k_mean = calib * factor * ks_mean * fb(t.feed_mean_mm_min);
        let k_win = calib * factor * ks_win * fb(t.feed_window_mm_min);
        out.force_n[i] = k_mean * t.unit_force_mean * runout_gain(t.unit_force_mean, t.runout_mean);
        let g_win = runout_gain(t.unit_force_window, t.runout_window);
        let chan_force = k_win * t.unit_force_window * g_win;
        // Torque seen by the power channel (window, after the drive's torque lag).
        let torque = k_win * g_win * t.unit_torque_window;
        let omega = s * 2.0 * std::f64::consts::PI / 60.0;
        let pc = torque * omega;
        out.cut_power_w[i] = pc;
        let tt = inp.t_s[i] - t0;
        out.predicted[i] = match power_chan {
            false => chan_force,
            true if s > 0.0 => {
                let fx_drift_w = if fx_drift_on {
                    fx_drift.power_w(tt)
                } else {
                    0.0
                };
                let drift_w = if sp_drift_on {
                    sp_drift.power_w(tt)
                } else {
                    0.0
                } + fx_drift_w;
                match motor {
                    Some(m) => {
                        let c = inp.motor_curve(m, s);
                        let kk = k_win * g_win;
                        // The simulator's motor carries the drift as bearing friction
                        // T_d = P_drift/ω on the shaft (`acc_sim::motor::MotorEffects`):
                        // the input rises by P_in(T + T_d) − P_in(T), more under load
                        // (copper loss), not by P_drift alone.
                        let td = if omega > 1e-6 { drift_w / omega } else { 0.0 };
                        let pc_rms = omega * kk * t.unit_torque_sq_window.max(0.0).sqrt();
                        sp.no_load_power_w
                            + c[1] * (torque + td)
                            + c[2]
                                * (kk * kk * t.unit_torque_sq_window + 2.0 * torque * td + td * td)
                            // The copper loss of the simulator's motor is taken sample by
                            // sample on the instantaneous torque: its mean is c·⟨P_c²⟩, the
                            // tooth ripple's mean square included, not c·⟨P_c⟩².
                            + if sp_loss_on { sp_loss.loss_w(pc_rms) } else { 0.0 }
                            + if fx_loss_on { fx_loss.loss_w(pc_rms) } else { 0.0 }
                    }
                    None => {
                        physics::input_power_w(sp, torque, s, tt)
                            + fx_drift_w
                            + if fx_loss_on { fx_loss.loss_w(pc) } else { 0.0 }
                    }
                }
            }
            true => 0.0,
        };
    }
    if let (true, Some(l)) = (power_chan, model.machine.spindle.sensor_lowpass) {
        l.filter(&mut out.predicted, &inp.dt_s);
    }
    if let Some(l) = fx.sensor_lowpass {
        l.filter(&mut out.predicted, &inp.dt_s);
    }
    // The estimator on the replayed power: its no-load (as it adapted on the logged
    // power), efficiency curve and dead band.
    if let Some((e, nl)) = estimator {
        for i in 0..n {
            out.predicted[i] = e.force_n(out.predicted[i], inp.spindle_rpm[i], nl[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The configs directory, paper case III with the dynamometer, and its closed-loop run.
    fn case3_dynamometer_run() -> (std::path::PathBuf, acc_sim::Scenario, acc_sim::RunResult) {
        let cfg = acc_sim::run::configs_dir();
        let sc = acc_sim::Scenario::load(cfg.join("scenarios/paper_case3_dynamometer.toml"))
            .expect("scenario");
        let mut law = sc.build_law(acc_sim::LawKind::Ours).expect("law");
        let res = acc_sim::run(&sc, law.as_mut(), acc_sim::RunSetup::default()).expect("run");
        (cfg, sc, res)
    }

    /// A gain drift is told from the process only with a reference the process does not
    /// move: a dynamometer's force (zero in air) has none; spindle power has its no-load
    /// level in the air before and after the cut, and loses it when the log is cut to the
    /// cutting rows.
    #[test]
    fn a_gain_drift_needs_a_level_in_air_early_and_late() {
        let (cfg, _, res) = case3_dynamometer_run();
        let model = Model::load(&cfg.join("models/paper_vmc.toml")).expect("model");
        let mut power = model.clone();
        power.measurement.channel = Channel::Power;
        let log =
            crate::runlog::from_records(&res.rows, std::path::Path::new("g.csv")).expect("log");
        let force = Inputs::from_log(&log, &model).expect("inputs");
        assert!(force.force_from_power.is_none());
        assert!(!force.gain_drift_separable());
        assert!(force.applicable(EffectKind::SensorGainDrift).is_err());
        assert!(Inputs::from_log(&log, &power)
            .expect("inputs")
            .gain_drift_separable());
        // From the first cutting row to the last: no air left in either third.
        let cutting = |r: &acc_runtime::RunRecord| r.radial_depth_mm.unwrap_or(0.0) > 0.0;
        let first = res.rows.iter().position(cutting).expect("a cut");
        let last = res.rows.iter().rposition(cutting).expect("a cut");
        let cut =
            crate::runlog::from_records(&res.rows[first..=last], std::path::Path::new("cut.csv"))
                .expect("log");
        let inp = Inputs::from_log(&cut, &power).expect("inputs");
        assert!(!inp.gain_drift_separable());
        assert!(inp
            .applicable(EffectKind::SensorGainDrift)
            .is_err_and(|w| w.contains("not separable from the process")));
    }

    /// A shared replay is the replay of the same model; an equal model gets the kept one
    /// back, another model a new one.
    #[test]
    fn a_shared_replay_is_the_replay_and_is_kept_per_model() {
        let (cfg, _, res) = case3_dynamometer_run();
        let log = crate::runlog::from_records(&res.rows, std::path::Path::new("shared.csv"))
            .expect("log");
        let model = Model::load(&cfg.join("models/paper_vmc.toml")).expect("model");
        let inp = Inputs::from_log(&log, &model).expect("inputs");
        let a = replay_shared(&model, &inp);
        assert_eq!(a.predicted, replay(&model, &inp).predicted);
        assert!(std::rc::Rc::ptr_eq(
            &a,
            &replay_shared(&model.clone(), &inp)
        ));
        let mut worn = model.clone();
        worn.effects.set(EffectKind::ToolWear, 0, 0.01);
        let b = replay_shared(&worn, &inp);
        assert!(!std::rc::Rc::ptr_eq(&a, &b));
        assert_eq!(b.predicted, replay(&worn, &inp).predicted);
        assert_ne!(a.predicted, b.predicted, "wear changes the replay");
    }

    /// A log whose board skipped a sample (a `seq_skip:2` row: one board period no row
    /// read) replays on its logged engagement, one prediction per row, still in step with
    /// the measured force after the skip.
    #[test]
    fn a_skipped_board_sample_keeps_the_logged_engagement_in_step() {
        let (cfg, sc, res) = case3_dynamometer_run();
        let mut rows = res.rows;
        let skip = rows.len() / 3;
        rows[skip].flags = "seq_skip:2".into();
        let log =
            crate::runlog::from_records(&rows, std::path::Path::new("skip.csv")).expect("log");
        let model = Model::load(&cfg.join("models/paper_vmc.toml")).expect("model");
        let inp = Inputs::from_log(&log, &model).expect("inputs");
        assert!(
            inp.board_sample.is_some(),
            "the board's period grid is used"
        );
        let r = replay(&model, &inp);
        assert_eq!(r.predicted.len(), rows.len());
        // After the skip the replayed force follows the measured one (the paper tool wears
        // a little, the model's does not: within 5 % of Fr on average).
        let after: Vec<f64> = rows[skip..]
            .iter()
            .zip(&r.predicted[skip..])
            .filter(|(x, _)| x.force_valid)
            .filter_map(|(x, p)| x.force_n.map(|f| (f - p).abs()))
            .collect();
        let mean = after.iter().sum::<f64>() / after.len().max(1) as f64;
        assert!(
            after.len() > 100 && mean < 0.05 * sc.controller.force_ref_n,
            "{} rows, mean |residual| {mean} N",
            after.len()
        );
    }
}
