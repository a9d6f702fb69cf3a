//! Open-loop replay of a model on the inputs recorded in a run log: the recorded
//! engagement, spindle speed and feed (or feed command) drive the model; nothing is fed
//! back, so the prediction is compared with the measurement like for like.

use acc_core::filter::FirstOrderLag;

use crate::effects::EffectKind;
use crate::model::{Channel, FeedInput, Model};
use crate::physics;
use crate::runlog::RunLog;

/// The model inputs taken from a run log, prepared once per log.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Period ending at each row, s (the first row uses the median period).
    pub dt_s: Vec<f64>,
    /// Radial depth, mm.
    pub radial_depth_mm: Vec<f64>,
    /// Axial depth, mm.
    pub axial_depth_mm: Vec<f64>,
    /// Spindle speed, rpm.
    pub spindle_rpm: Vec<f64>,
    /// Recorded feed, mm/min.
    pub feed_mm_min: Vec<f64>,
    /// Feed command `programmed · override_cmd / 100`, mm/min, when both columns exist.
    pub feed_cmd_mm_min: Option<Vec<f64>>,
    /// Feed command in force before the first logged command, mm/min (from
    /// `override_applied_pct` of the first row when logged).
    pub feed_cmd_initial_mm_min: f64,
    /// Measured channel value (W or N).
    pub measured: Vec<f64>,
    /// Channel compared.
    pub channel: Channel,
    /// Median period, s.
    pub period_s: f64,
    /// Weak prior on the nominal parameters used by [`crate::fit`] (None: plain least
    /// squares).
    pub prior: Option<crate::fit::Prior>,
    /// The last feed path and unit forces (see [`replay`]); not part of the inputs.
    cache: std::cell::RefCell<Option<std::rc::Rc<PathCache>>>,
}

/// Errors preparing replay inputs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReplayError {
    /// The model's channel is not in the log.
    #[error("the model compares `{0}` but the log has no such column")]
    MissingChannel(&'static str),
    /// `feed_input = "command"` but the command columns are missing.
    #[error("measurement.feed_input = \"command\" needs `programmed_feed_mm_min` and `override_cmd_pct` in the log")]
    MissingCommand,
}

impl Inputs {
    /// Prepare the inputs of `log` for `model`'s channel and feed source.
    pub fn from_log(log: &RunLog, model: &Model) -> Result<Inputs, ReplayError> {
        let channel = model.measurement.channel;
        let measured = match channel {
            Channel::Power => log
                .power_w
                .clone()
                .ok_or(ReplayError::MissingChannel("power_w"))?,
            Channel::Force => log
                .force_n
                .clone()
                .ok_or(ReplayError::MissingChannel("force_n"))?,
        };
        let cmd = match (&log.programmed_feed_mm_min, &log.override_cmd_pct) {
            (Some(p), Some(o)) => Some(
                p.iter()
                    .zip(o)
                    .map(|(p, o)| p * o / 100.0)
                    .collect::<Vec<f64>>(),
            ),
            _ => None,
        };
        let feed_cmd_mm_min = match model.measurement.feed_input {
            FeedInput::Recorded => None,
            FeedInput::Auto => cmd,
            FeedInput::Command => Some(cmd.ok_or(ReplayError::MissingCommand)?),
        };
        let feed_cmd_initial_mm_min = match (
            &log.programmed_feed_mm_min,
            &log.override_applied_pct,
            &feed_cmd_mm_min,
        ) {
            (Some(p), Some(o), _) if !p.is_empty() => p[0] * o[0] / 100.0,
            (_, _, Some(c)) if !c.is_empty() => c[0],
            _ => log.feed_mm_min.first().copied().unwrap_or(0.0),
        };
        let period_s = log.median_period_s();
        let mut dt_s = vec![period_s; log.len()];
        for (d, w) in dt_s.iter_mut().skip(1).zip(log.t_s.windows(2)) {
            *d = w[1] - w[0];
        }
        Ok(Inputs {
            t_s: log.t_s.clone(),
            dt_s,
            radial_depth_mm: log.radial_depth_mm.clone(),
            axial_depth_mm: log.axial_depth_mm.clone(),
            spindle_rpm: log.spindle_rpm.clone(),
            feed_mm_min: log.feed_mm_min.clone(),
            feed_cmd_mm_min,
            feed_cmd_initial_mm_min,
            measured,
            channel,
            period_s,
            prior: None,
            cache: Default::default(),
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// `true` when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Whether row `i` is cutting (both depths and the spindle speed above zero).
    pub fn is_cut(&self, i: usize) -> bool {
        self.radial_depth_mm[i] > 0.0 && self.axial_depth_mm[i] > 0.0 && self.spindle_rpm[i] > 0.0
    }

    /// Whether an effect can act on these inputs at all (channel, command path, sampling).
    pub fn applicable(&self, kind: EffectKind) -> Result<(), &'static str> {
        if kind.power_only() && self.channel != Channel::Power {
            return Err("acts on spindle power only; the compared channel is force");
        }
        match kind {
            EffectKind::FeedDriveLag | EffectKind::OverrideDeadTime
                if self.feed_cmd_mm_min.is_none() =>
            {
                Err("needs the feed command (programmed_feed_mm_min, override_cmd_pct)")
            }
            EffectKind::Runout if self.runout_visibility() < 0.05 => {
                Err("not observable: the sampling averages whole spindle revolutions")
            }
            EffectKind::FeedDriveLag | EffectKind::OverrideDeadTime if !self.command_steps() => {
                Err("not excited: the feed command never changes")
            }
            EffectKind::FeedExponent if self.cut_feed_cv() < 0.02 => {
                Err("not excited: the feed hardly varies while cutting")
            }
            _ => Ok(()),
        }
    }

    /// Whether the feed command steps by more than 1 % anywhere.
    fn command_steps(&self) -> bool {
        self.feed_cmd_mm_min.as_ref().is_some_and(|c| {
            c.windows(2)
                .any(|w| (w[1] - w[0]).abs() > 0.01 * w[0].abs().max(w[1].abs()))
        })
    }

    /// Coefficient of variation of the recorded feed over the cutting rows.
    fn cut_feed_cv(&self) -> f64 {
        let f: Vec<f64> = (0..self.len())
            .filter(|&i| self.is_cut(i))
            .map(|i| self.feed_mm_min[i])
            .collect();
        let m = crate::stats::mean(&f);
        if m <= 0.0 {
            return 0.0;
        }
        crate::stats::rms(&f.iter().map(|x| x - m).collect::<Vec<_>>()) / m
    }

    /// Mean gain of a period-averaging channel for a once-per-revolution ripple,
    /// |sin(Δθ/2) / (Δθ/2)| with Δθ the spindle angle swept in one period (0 … 1).
    pub fn runout_visibility(&self) -> f64 {
        let mut s = 0.0;
        let mut n = 0.0;
        for i in 0..self.len() {
            if self.is_cut(i) {
                let h = std::f64::consts::PI * self.spindle_rpm[i] / 60.0 * self.dt_s[i];
                s += if h < 1e-9 { 1.0 } else { (h.sin() / h).abs() };
                n += 1.0;
            }
        }
        if n > 0.0 {
            s / n
        } else {
            0.0
        }
    }
}

/// Sub-steps per period of the replayed feed path.
const SUBSTEPS: usize = 10;

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
}

/// The replayed feed (period mean and force-window mean), mm/min.
fn feed_path(inp: &Inputs, delay_s: f64, tau: f64, window: f64) -> (Vec<f64>, Vec<f64>) {
    let n = inp.len();
    let mut feed = vec![0.0; n];
    let mut window_feed = vec![0.0; n];
    // Feed path, integrated in SUBSTEPS sub-steps per period: the command logged in row
    // k (issued at the end of its period, t_k) acts from t_k + delay; the drive lag is
    // discretised exactly per sub-step (physics.md eq. (5), as the simulator does).
    match &inp.feed_cmd_mm_min {
        Some(cmd) if n > 0 => {
            let mut f = inp.feed_cmd_initial_mm_min;
            let mut k = 0usize;
            for i in 0..n {
                let h = inp.dt_s[i] / SUBSTEPS as f64;
                let alpha = FirstOrderLag::new(tau).alpha(h);
                let t_start = inp.t_s[i] - inp.dt_s[i];
                let (mut sum, mut sum_w, mut n_w) = (0.0, 0.0, 0usize);
                for j in 0..SUBSTEPS {
                    // Mean command over the sub-step, in delayed time [lo, hi): the command
                    // is piecewise constant, switching at the logged row times.
                    let lo = t_start + j as f64 * h - delay_s;
                    let hi = lo + h;
                    while k + 1 < n && inp.t_s[k + 1] <= lo {
                        k += 1;
                    }
                    let mut u = 0.0;
                    let mut from = lo;
                    let mut kk = k;
                    while from < hi {
                        let val = if inp.t_s[kk] <= from {
                            cmd[kk]
                        } else {
                            inp.feed_cmd_initial_mm_min
                        };
                        let (to, next) = if inp.t_s[kk] > from {
                            (inp.t_s[kk].min(hi), kk)
                        } else if kk + 1 < n {
                            (inp.t_s[kk + 1].min(hi), kk + 1)
                        } else {
                            (hi, kk)
                        };
                        u += val * (to - from);
                        from = to;
                        kk = next;
                    }
                    let u = u / h;
                    f = FirstOrderLag::advance(f, u, alpha);
                    sum += f;
                    if window <= 0.0 || (j as f64 + 0.5) * h >= inp.dt_s[i] - window {
                        sum_w += f;
                        n_w += 1;
                    }
                }
                feed[i] = sum / SUBSTEPS as f64;
                window_feed[i] = if n_w > 0 { sum_w / n_w as f64 } else { feed[i] };
            }
        }
        _ => {
            feed.copy_from_slice(&inp.feed_mm_min);
            window_feed.copy_from_slice(&inp.feed_mm_min);
        }
    }
    (feed, window_feed)
}

/// What does not change while only loads, losses and the sensor are fitted: the feed path
/// and the force per unit calibration force (`Ks·a_p·d^α·f^β·s^γ / calib_force_n`).
#[derive(Debug, Clone, PartialEq)]
struct PathKey {
    delay_s: f64,
    tau_s: f64,
    window_s: f64,
    process: [f64; 8],
}

/// Cached feed path and unit forces of one [`PathKey`].
#[derive(Debug, Clone)]
struct PathCache {
    key: PathKey,
    feed: Vec<f64>,
    window_feed: Vec<f64>,
    unit_force: Vec<f64>,
    unit_window_force: Vec<f64>,
}

fn path(model: &Model, inp: &Inputs) -> std::rc::Rc<PathCache> {
    let fx = &model.effects;
    let p = &model.tool.process;
    let key = PathKey {
        delay_s: model.machine.override_path.delay_s
            + fx.get(EffectKind::OverrideDeadTime, 0).max(0.0),
        tau_s: model.machine.feed_drive.tau_s + fx.get(EffectKind::FeedDriveLag, 0).max(0.0),
        window_s: model.measurement.force_window_s,
        process: [
            p.calib_radial_mm,
            p.calib_feed_mm_min,
            p.calib_rpm,
            p.calib_axial_mm,
            p.alpha,
            p.beta,
            p.gamma,
            p.radial_ratio,
        ],
    };
    if let Some(c) = inp.cache.borrow().as_ref() {
        if c.key == key {
            return c.clone();
        }
    }
    let (feed, window_feed) = feed_path(inp, key.delay_s, key.tau_s, key.window_s);
    let mut unit = *p;
    unit.calib_force_n = 1.0;
    let law = physics::force_law(&unit);
    let n = inp.len();
    let force = |i: usize, f: f64| {
        let (d, a) = (inp.radial_depth_mm[i], inp.axial_depth_mm[i]);
        if a > 0.0 {
            law.mean_force_n(d, a, f, inp.spindle_rpm[i], 1.0)
        } else {
            0.0
        }
    };
    let unit_force: Vec<f64> = (0..n).map(|i| force(i, feed[i])).collect();
    let unit_window_force: Vec<f64> = (0..n).map(|i| force(i, window_feed[i])).collect();
    let c = std::rc::Rc::new(PathCache {
        key,
        feed,
        window_feed,
        unit_force,
        unit_window_force,
    });
    *inp.cache.borrow_mut() = Some(c.clone());
    c
}

/// Replay `model` on `inp` (open loop).
///
/// Feed: command delayed by the override path (nominal + dead-time effect; the command
/// of row i acts from row i+1, physics.md eq. (5) `z⁻¹`) then a first-order drive lag
/// `f_i = a·f_{i−1} + (1−a)·u_i`, `a = e^(−T/τ)` (eq. (5)). Force: eq. (1) through
/// [`crate::physics`] with the simulator's wear factor, times the feed-exponent and runout
/// effects. Power: the simulator's spindle law `P_air(t) + ω·T/η + c·(ω·T)²/1000`
/// (machine keys) plus the candidate drift and losses. Finally the machine's power-sensor
/// low-pass and the candidate sensor low-pass.
// The loops advance several aligned per-row series at once; indexing reads clearer here.
#[allow(clippy::needless_range_loop)]
pub fn replay(model: &Model, inp: &Inputs) -> Replay {
    let n = inp.len();
    let fx = &model.effects;
    let mut out = Replay {
        predicted: vec![0.0; n],
        feed_mm_min: vec![0.0; n],
        window_feed_mm_min: vec![0.0; n],
        force_n: vec![0.0; n],
        volume_mm3: vec![0.0; n],
        cut_power_w: vec![0.0; n],
        spindle_angle_rad: vec![0.0; n],
    };
    let cached = path(model, inp);
    out.feed_mm_min.copy_from_slice(&cached.feed);
    out.window_feed_mm_min.copy_from_slice(&cached.window_feed);
    // Process force, volume and wear (the simulator's wear law, extra growth added).
    let law = physics::force_law(&model.tool.process);
    let calib_force = model.tool.process.calib_force_n;
    let w = &model.tool.wear;
    // The candidate adds growth and replaces the curve's exponent (null: the tool's own).
    let wear = acc_sim::process::WearSpec {
        growth_per_cm3: w.growth_per_cm3 + fx.get(EffectKind::ToolWear, 0),
        volume_exponent: fx
            .tool_wear
            .map_or(w.volume_exponent, |e| e.volume_exponent),
        ..*w
    };
    let dbeta = fx.get(EffectKind::FeedExponent, 0);
    let fref = fx.get(EffectKind::FeedExponent, 1).max(1e-9);
    let windowed = inp.channel == Channel::Force && model.measurement.force_window_s > 0.0;
    let mut chan_force = vec![0.0; n];
    let mut vol = 0.0;
    let mut cut_min = 0.0;
    let mut theta = 0.0;
    for i in 0..n {
        let s = inp.spindle_rpm[i];
        let dth = 2.0 * std::f64::consts::PI * s / 60.0 * inp.dt_s[i];
        let th0 = theta;
        theta += dth;
        out.spindle_angle_rad[i] = theta;
        let f = out.feed_mm_min[i];
        let (d, a) = (inp.radial_depth_mm[i], inp.axial_depth_mm[i]);
        let factor = wear.factor(vol / 1000.0, cut_min);
        let force_at = |f: f64, unit: f64| -> f64 {
            let mut force = calib_force * factor * unit;
            if force > 0.0 {
                if dbeta != 0.0 {
                    force *= (f / fref).powf(dbeta);
                }
                // The tool's runout and the candidate's, both the simulator's mean factor.
                for r in [model.tool.runout, fx.runout].into_iter().flatten() {
                    force *= r.mean_factor(th0, theta);
                }
            }
            force
        };
        let force = force_at(f, cached.unit_force[i]);
        if force > 0.0 {
            vol += d * a * f / 60.0 * inp.dt_s[i];
            cut_min += inp.dt_s[i] / 60.0;
        }
        out.force_n[i] = force;
        chan_force[i] = if windowed {
            force_at(out.window_feed_mm_min[i], cached.unit_window_force[i])
        } else {
            force
        };
        out.volume_mm3[i] = vol;
    }
    // Channel: the simulator's spindle power law (with the machine's own drift and
    // losses), plus the candidate drift and losses through the simulator's same functions.
    let t0 = inp.t_s.first().copied().unwrap_or(0.0);
    let radius = 0.5 * model.tool.diameter_mm;
    for i in 0..n {
        let s = inp.spindle_rpm[i];
        let torque = law.torque_nm(out.force_n[i], radius);
        let pc = torque * s * 2.0 * std::f64::consts::PI / 60.0;
        out.cut_power_w[i] = pc;
        out.predicted[i] = match inp.channel {
            Channel::Force => chan_force[i],
            Channel::Power if s > 0.0 => {
                let t = inp.t_s[i] - t0;
                physics::input_power_w(&model.machine.spindle, torque, s, t)
                    + fx.noload_drift.map_or(0.0, |d| d.power_w(t))
                    + fx.motor_efficiency.map_or(0.0, |m| m.loss_w(pc))
            }
            Channel::Power => 0.0,
        };
    }
    // Sensor: the machine's power-sensor low-pass (power channel only), then the
    // candidate low-pass, both the simulator's filter.
    if let (Channel::Power, Some(l)) = (inp.channel, model.machine.spindle.sensor_lowpass) {
        l.filter(&mut out.predicted, &inp.dt_s);
    }
    if let Some(l) = fx.sensor_lowpass {
        l.filter(&mut out.predicted, &inp.dt_s);
    }
    out
}
