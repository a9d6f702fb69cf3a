//! Open-loop replay of a model on the inputs recorded in a run log: the recorded
//! engagement, spindle speed and feed commands drive the simulator's plant
//! ([`acc_sim::replay`]); nothing is fed back, so the prediction is compared with the
//! measurement like for like. This module prepares the plant's inputs from the log and
//! scales its unit-force trace by the model's `Ks`, wear, runout and candidate effects;
//! the override path, feed drive, engagement and force law are the simulator's.

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
    /// Measured channel value (W or N).
    pub measured: Vec<f64>,
    /// Channel compared.
    pub channel: Channel,
    /// Median period, s.
    pub period_s: f64,
    /// Weak prior on the nominal parameters used by [`crate::fit`] (None: plain least
    /// squares).
    pub prior: Option<crate::fit::Prior>,
    /// What drives the simulator's plant in the replay.
    pub plant: PlantInputs,
    /// The force estimator's no-load power and its σ per row, W, when the compared force
    /// is a spindle-power estimate ([`crate::model::Measurement::force_estimator`]): the
    /// estimator's adaptation replayed on the logged `power_w`.
    pub estimator_no_load: Option<Vec<(f64, f64)>>,
    /// The estimator's output on the logged power per row, N, and the σ the logs' number
    /// formatting leaves between it and the logged force, N (a force channel estimated
    /// from spindle power, with `power_w` logged): compared with the logged force by
    /// [`ForcePowerConsistency`].
    pub force_from_power: Option<(Vec<f64>, f64)>,
    /// The window the compared channel averages at the end of each period, s (0: the
    /// whole period): the model's `force_window_s` or `power_window_s`.
    pub window_s: f64,
    /// The board's sample each row read, counted from the first row's (from
    /// [`crate::runlog::RunLog::sample_advance`], `acc run`'s `seq_repeat` /
    /// `seq_skip:<n>` flags), when some row did not read the next sample. The plant replay
    /// then runs on the board's periods and gives each row the sample it read: a repeated
    /// read the same sample again, a late read the newer one, a missed period driven by
    /// the override the row before or the row after it found applied (see `plant_trace`).
    /// `None`: row `k` read sample `k` — or the board samples faster than the control
    /// period (most rows moved by more than one sample), where the periods are the rows'.
    pub board_sample: Option<Vec<usize>>,
    /// The last feed path and unit forces (see [`replay`]); not part of the inputs.
    cache: std::cell::RefCell<Vec<std::rc::Rc<PathCache>>>,
    /// Quadratic fits of the spindle motor's input power against torque, per speed.
    motor_curves: std::cell::RefCell<Vec<(f64, [f64; 3])>>,
}

/// What drives the simulator's plant in a replay ([`acc_sim::replay::trace`]).
#[derive(Debug, Clone)]
pub struct PlantInputs {
    /// Which logged columns drive it.
    pub source: FeedSource,
    /// Override on the PMC inputs during each row's period, %.
    pub override_applied_pct: Vec<f64>,
    /// Programmed feed, mm/min.
    pub programmed_feed_mm_min: Vec<f64>,
    /// Spindle speed per row, rpm (`None`: the model machine's `spindle.rpm`).
    pub spindle_rpm: Option<Vec<f64>>,
    /// Engagement: as logged, or from the workpiece (`Inputs::use_workpiece`).
    pub engagement: acc_sim::replay::ReplayEngagement,
}

/// The logged columns that drive the plant (`measurement.feed_input`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedSource {
    /// The override the board applied (`override_applied_pct`, on the PMC inputs during
    /// the row's period) and the programmed feed; the machine starts at rest, as the
    /// simulator does.
    Applied,
    /// The controller's command (`override_cmd_pct`, written at the end of the row's
    /// period, so on the PMC inputs during the next one) and the programmed feed; before
    /// the first row the drive has settled on the first override the log shows (the
    /// applied one when logged).
    Command,
    /// The recorded feed as the programmed feed at 100 %, on an instantaneous override
    /// path and feed drive: the plant's feed is the logged one.
    Recorded,
}

/// The logged force of a spindle-power estimator against the estimator's output on the
/// logged power, over the rows where either is positive (the cut): a process effect (wear,
/// a harder material, `Ks` rising with time) changes the power and the force together, so
/// the force column stays what the estimator made of the power; only a change of the logged
/// force itself (its logging path) makes them differ. The difference
/// `d = F_logged − F_est(P_logged)` is fitted by a gain drift in time from the log's first
/// row (as [`crate::effects::SensorGainDrift::apply`]), `d = r·F_est·(t − t₀)/60`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcePowerConsistency {
    /// Rows compared (finite, either positive).
    pub rows: usize,
    /// RMS of the logged force over those rows, N.
    pub force_rms_n: f64,
    /// RMS of the difference, N.
    pub difference_rms_n: f64,
    /// Fitted gain drift of the logged force against the power, 1/min.
    pub drift_per_min: f64,
    /// Share of the difference's sum of squares the drift explains, −.
    pub drift_explains: f64,
    /// RMS of the difference left after the drift, N.
    pub after_drift_rms_n: f64,
    /// What counts as equal, N: 0.05 N + 0.1 % of the force RMS + the σ of the logs'
    /// number formatting (the force column's step, the power column's step in newtons).
    pub tolerance_n: f64,
}

impl ForcePowerConsistency {
    /// Rows needed to judge, −.
    pub const MIN_ROWS: usize = 20;

    /// Compare the logged force `force` with the estimator's output `est` (both N) at the
    /// times `t_s` (s, the drift counted from `t0_s`), the formatting σ `format_sigma_n`
    /// (N); `None` with fewer than [`Self::MIN_ROWS`] comparable rows.
    pub fn of(
        t_s: &[f64],
        t0_s: f64,
        force: &[f64],
        est: &[f64],
        format_sigma_n: f64,
    ) -> Option<ForcePowerConsistency> {
        let rows: Vec<(f64, f64, f64)> = (0..t_s.len().min(force.len()).min(est.len()))
            .filter(|&i| force[i].is_finite() && est[i].is_finite())
            .filter(|&i| force[i] > 0.0 || est[i] > 0.0)
            .map(|i| ((t_s[i] - t0_s) / 60.0, force[i], est[i]))
            .collect();
        if rows.len() < Self::MIN_ROWS {
            return None;
        }
        let n = rows.len() as f64;
        let ss0: f64 = rows.iter().map(|(_, f, e)| (f - e).powi(2)).sum();
        let (num, den) = rows.iter().fold((0.0, 0.0), |(a, b), (tm, f, e)| {
            (a + (f - e) * e * tm, b + (e * tm).powi(2))
        });
        let r = if den > 0.0 { num / den } else { 0.0 };
        let ss1: f64 = rows
            .iter()
            .map(|(tm, f, e)| (f - e - r * e * tm).powi(2))
            .sum();
        let force_rms_n = (rows.iter().map(|(_, f, _)| f * f).sum::<f64>() / n).sqrt();
        Some(ForcePowerConsistency {
            rows: rows.len(),
            force_rms_n,
            difference_rms_n: (ss0 / n).sqrt(),
            drift_per_min: r,
            drift_explains: if ss0 > 0.0 { 1.0 - ss1 / ss0 } else { 0.0 },
            after_drift_rms_n: (ss1 / n).sqrt(),
            tolerance_n: 0.05 + 1e-3 * force_rms_n + format_sigma_n.max(0.0),
        })
    }

    /// The force column is the estimator's output on the power: RMS difference within
    /// [`Self::tolerance_n`].
    pub fn consistent(&self) -> bool {
        self.difference_rms_n <= self.tolerance_n
    }

    /// The logged force is the estimator's output times `1 + r·(t − t₀)/60` and nothing
    /// else: inconsistent, and within [`Self::tolerance_n`] once the drift is taken out (a
    /// constant gain or offset, an estimator other than the model's, stale or clipped
    /// samples leave more).
    pub fn drifts(&self) -> bool {
        !self.consistent() && self.after_drift_rms_n <= self.tolerance_n
    }
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
    /// `feed_input = "plant"` but the applied override or programmed feed is missing.
    #[error("measurement.feed_input = \"plant\" needs `programmed_feed_mm_min` and `override_applied_pct` in the log")]
    MissingApplied,
    /// The model names a spindle motor the simulator cannot load.
    #[error("measurement.spindle_motor: {0}")]
    Motor(String),
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
        let applied = match (&log.programmed_feed_mm_min, &log.override_applied_pct) {
            (Some(p), Some(o)) => Some((p.clone(), o.clone())),
            _ => None,
        };
        let source = match (model.measurement.feed_input, &applied, &cmd) {
            (FeedInput::Plant, None, _) => return Err(ReplayError::MissingApplied),
            (FeedInput::Command, _, None) => return Err(ReplayError::MissingCommand),
            (FeedInput::Plant | FeedInput::Auto, Some(_), _) => FeedSource::Applied,
            (FeedInput::Command | FeedInput::Auto, _, Some(_)) => FeedSource::Command,
            _ => FeedSource::Recorded,
        };
        let plant = match (source, &log.programmed_feed_mm_min, &log.override_cmd_pct) {
            (FeedSource::Applied, _, _) => {
                let (p, o) = applied.clone().ok_or(ReplayError::MissingApplied)?;
                PlantInputs {
                    source,
                    override_applied_pct: o,
                    programmed_feed_mm_min: p,
                    spindle_rpm: None,
                    engagement: logged_engagement(log),
                }
            }
            (FeedSource::Command, Some(p), Some(o)) => {
                // Row k's command is on the PMC inputs during row k + 1; row 0 runs on the
                // override in force before the log (the applied one when logged).
                let o0 = log
                    .override_applied_pct
                    .as_ref()
                    .and_then(|a| a.first())
                    .or(o.first())
                    .copied()
                    .unwrap_or(100.0);
                let shift = |v: &[f64], first: f64| -> Vec<f64> {
                    std::iter::once(first)
                        .chain(v.iter().copied())
                        .take(v.len())
                        .collect()
                };
                PlantInputs {
                    source,
                    override_applied_pct: shift(o, o0),
                    programmed_feed_mm_min: shift(p, p.first().copied().unwrap_or(0.0)),
                    spindle_rpm: Some(log.spindle_rpm.clone()),
                    engagement: logged_engagement(log),
                }
            }
            _ => PlantInputs {
                source: FeedSource::Recorded,
                override_applied_pct: vec![100.0; log.len()],
                programmed_feed_mm_min: log.feed_mm_min.clone(),
                spindle_rpm: Some(log.spindle_rpm.clone()),
                engagement: logged_engagement(log),
            },
        };
        if let Some(m) = model.measurement.spindle_motor {
            m.config().map_err(|e| ReplayError::Motor(e.to_string()))?;
        }
        let feed_cmd_mm_min = match source {
            FeedSource::Recorded => None,
            FeedSource::Applied | FeedSource::Command => cmd,
        };
        let estimator_no_load = match (channel, model.measurement.force_estimator) {
            (Channel::Force, Some(e)) => {
                let p = log
                    .power_w
                    .as_ref()
                    .ok_or(ReplayError::MissingChannel("power_w"))?;
                Some(e.no_load_track(&log.spindle_rpm, p))
            }
            _ => None,
        };
        let force_from_power = match (
            &estimator_no_load,
            model.measurement.force_estimator,
            &log.power_w,
        ) {
            (Some(nl), Some(e), Some(p)) => {
                let est: Vec<f64> = (0..log.len())
                    .map(|i| e.force_n(p[i], log.spindle_rpm[i], nl[i]))
                    .collect();
                // The power's rounding in newtons: the estimator's slope at the most
                // loaded row.
                let slope = (0..log.len())
                    .max_by(|&a, &b| est[a].total_cmp(&est[b]))
                    .map_or(0.0, |i| {
                        e.force_n(p[i] + 1.0, log.spindle_rpm[i], nl[i]) - est[i]
                    });
                let floor = crate::stats::quantization_sigma(&measured)
                    .hypot(crate::stats::quantization_sigma(p) * slope.abs());
                Some((est, floor))
            }
            _ => None,
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
            measured,
            channel,
            period_s,
            prior: None,
            plant,
            estimator_no_load,
            force_from_power,
            window_s: match channel {
                Channel::Force => model.measurement.force_window_s,
                Channel::Power => model.measurement.power_window_s,
            },
            // Only for a board that samples once per control period (most rows moved by
            // one): a board sampling faster moves by several every row.
            board_sample: log
                .sample_advance
                .as_ref()
                .filter(|adv| 2 * adv.iter().filter(|&&a| a == 1).count() > adv.len())
                .map(|adv| {
                    // The first row's advance counts from before the log: not a period.
                    let mut s = 0usize;
                    std::iter::once(0)
                        .chain(adv.iter().skip(1).map(|&a| {
                            s += a as usize;
                            s
                        }))
                        .collect()
                }),
            cache: Default::default(),
            motor_curves: Default::default(),
        })
    }

    /// Replay the plant on `workpiece` (tool centre at `x0_mm` when the log began)
    /// instead of the logged depths: the engagement then changes inside each period as in
    /// the simulator, and material boundaries (`ks_factor`) are honoured. No effect
    /// without a plant replay (see [`Inputs::plant`]).
    pub fn use_workpiece(&mut self, workpiece: acc_sim::Workpiece, x0_mm: f64) {
        self.plant.engagement = acc_sim::replay::ReplayEngagement::Workpiece { workpiece, x0_mm };
        self.cache.borrow_mut().clear();
    }

    /// Input power of `motor` at `rpm` as a quadratic in the cutting torque,
    /// `[a, b, c]` of `a + b·T + c·T²` (W, W/(N·m), W/(N·m)²), fitted by least squares to
    /// the simulator's operating points ([`acc_sim::motor::Motor::operating_point`]) from
    /// 0 to the motor's rated torque; cached per speed.
    pub fn motor_curve(&self, motor: acc_sim::motor::BuiltinMotor, rpm: f64) -> [f64; 3] {
        let key = (rpm * 10.0).round() / 10.0;
        if let Some((_, c)) = self.motor_curves.borrow().iter().find(|(r, _)| *r == key) {
            return *c;
        }
        let c = motor_quadratic(motor, key);
        self.motor_curves.borrow_mut().push((key, c));
        c
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
        if kind.power_only() && self.channel != Channel::Power && self.estimator_no_load.is_none() {
            return Err("acts on spindle power only; the compared channel is a force sensor");
        }
        match kind {
            EffectKind::FeedDriveLag
            | EffectKind::OverrideDeadTime
            | EffectKind::SecondOrderDrive
                if self.feed_cmd_mm_min.is_none() =>
            {
                Err("needs the feed command (programmed_feed_mm_min, override_cmd_pct)")
            }
            EffectKind::Runout if self.runout_visibility() < 0.05 => {
                Err("not observable: the sampling averages whole spindle revolutions")
            }
            EffectKind::FeedDriveLag | EffectKind::OverrideDeadTime | EffectKind::SecondOrderDrive
                if !self.command_steps() =>
            {
                Err("not excited: the feed command never changes")
            }
            EffectKind::DepthExponent if !self.two_depths() => {
                Err("not excited: the cut rows hold one radial depth (needs at least two, ≥ 10 rows each)")
            }
            EffectKind::KsStep if self.cut_rows() < 2 * MIN_SIDE_ROWS => {
                Err("too few cutting rows to place a material boundary with cut rows on both sides")
            }
            EffectKind::FeedExponent if self.cut_feed_cv() < 0.02 => {
                Err("not excited: the feed hardly varies while cutting")
            }
            _ => Ok(()),
        }
    }

    /// Number of cutting rows.
    fn cut_rows(&self) -> usize {
        (0..self.len()).filter(|&i| self.is_cut(i)).count()
    }

    /// Whether the cutting rows hold at least two radial depths: ≥ 10 rows within 5 % of
    /// the median cut depth and ≥ 10 rows further from it.
    fn two_depths(&self) -> bool {
        let mut d: Vec<f64> = (0..self.len())
            .filter(|&i| self.is_cut(i))
            .map(|i| self.radial_depth_mm[i])
            .collect();
        if d.len() < 2 * MIN_SIDE_ROWS {
            return false;
        }
        d.sort_by(f64::total_cmp);
        let med = d[d.len() / 2];
        let near = d.iter().filter(|x| (*x - med).abs() <= 0.05 * med).count();
        near >= MIN_SIDE_ROWS && d.len() - near >= MIN_SIDE_ROWS
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

    /// Mean gain of the channel's averaging for a once-per-revolution ripple,
    /// |sin(Δθ/2) / (Δθ/2)| with Δθ the spindle angle swept in the window the channel
    /// averages ([`Inputs::window_s`], or the whole period) (0 … 1). A 0.05 s window at
    /// 600 rpm sees half a revolution (0.64) where the whole 0.1 s period sees none.
    pub fn runout_visibility(&self) -> f64 {
        let mut s = 0.0;
        let mut n = 0.0;
        for i in 0..self.len() {
            if self.is_cut(i) {
                let w = if self.window_s > 0.0 && self.window_s < self.dt_s[i] {
                    self.window_s
                } else {
                    self.dt_s[i]
                };
                let h = std::f64::consts::PI * self.spindle_rpm[i] / 60.0 * w;
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

/// The engagement the log records per row (its depths, `Ks` factor 1).
fn logged_engagement(log: &RunLog) -> acc_sim::replay::ReplayEngagement {
    acc_sim::replay::ReplayEngagement::Logged(
        log.radial_depth_mm
            .iter()
            .zip(&log.axial_depth_mm)
            .map(|(&radial_mm, &axial_mm)| acc_sim::engagement::Engagement {
                radial_mm,
                axial_mm,
                ks_factor: 1.0,
            })
            .collect(),
    )
}

/// Cutting rows needed on each side of a contrast (two depths, a material boundary).
const MIN_SIDE_ROWS: usize = 10;

/// Least-squares quadratic of the motor's input power against cutting torque at `rpm`
/// (see [`Inputs::motor_curve`]); a zero curve when the motor cannot be loaded.
fn motor_quadratic(motor: acc_sim::motor::BuiltinMotor, rpm: f64) -> [f64; 3] {
    let Ok(cfg) = motor.config() else {
        return [0.0; 3];
    };
    let t_max = cfg.rated.torque_nm.max(1.0);
    let m = acc_sim::motor::Motor::new(cfg);
    let pts: Vec<(f64, f64)> = (0..=60)
        .map(|k| {
            let t = t_max * k as f64 / 60.0;
            (t, m.operating_point(rpm, t).input_w)
        })
        .collect();
    // Normal equations of [1, T, T²] (scaled by t_max for conditioning).
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for &(t, p) in &pts {
        let x = t / t_max;
        let v = [1.0, x, x * x];
        for i in 0..3 {
            b[i] += v[i] * p;
            for j in 0..3 {
                a[i][j] += v[i] * v[j];
            }
        }
    }
    let c = crate::stats::solve3(a, b).unwrap_or([0.0; 3]);
    [c[0], c[1] / t_max, c[2] / (t_max * t_max)]
}

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

/// The `ks_step` candidate's `Ks` factors per row over the period and over the channel's
/// window (the last `win_frac` of the period), with the tool centre moving from
/// `x_start[i]` to `x_end[i]` (mm) in row `i`; the boundary (mm) is placed on the path from
/// where the first cutting row (`cut`) begins to where the last one ends. The factor at a
/// tool-centre position is `at(x, b)` (the simulator's engagement-weighted `Ks` factor,
/// see [`KsStepShape`]), averaged over [`KS_SUB`] positions per period. `None`: no
/// candidate or no cutting row.
fn ks_step_factors(
    step: Option<crate::effects::KsStep>,
    x_start: &[f64],
    x_end: &[f64],
    cut: &[bool],
    win_frac: &[f64],
    shape: &KsStepShape<'_>,
) -> Option<(f64, Vec<f64>, Vec<f64>)> {
    let step = step?;
    let first = cut.iter().position(|c| *c)?;
    let last = cut.iter().rposition(|c| *c)?;
    let b = step.boundary_mm(x_start[first], x_end[last]);
    let stepped = shape.stepped(b, step.delta);
    let n = x_end.len();
    let mut mean = vec![1.0; n];
    let mut win = vec![1.0; n];
    for i in 0..n {
        let (x0, x1) = (x_start[i], x_end[i]);
        let w = win_frac[i].clamp(0.0, 1.0);
        let (mut s, mut sw, mut nw) = (0.0, 0.0, 0usize);
        for j in 0..KS_SUB {
            let u = (j as f64 + 0.5) / KS_SUB as f64;
            let g = shape.factor(stepped.as_ref(), x0 + u * (x1 - x0), b, step.delta, i);
            s += g;
            if u >= 1.0 - w {
                sw += g;
                nw += 1;
            }
        }
        mean[i] = s / KS_SUB as f64;
        win[i] = if nw > 0 { sw / nw as f64 } else { mean[i] };
    }
    Some((b, mean, win))
}

/// Positions per period at which the `ks_step` factor is evaluated.
const KS_SUB: usize = 8;

/// How a material boundary meets the tool: the simulator's engagement over the tool's
/// arc ([`acc_sim::Workpiece::engagement`], the `Ks` factor weighted by lateral extent)
/// when the replay runs on the workpiece, else the same arc geometry with the logged
/// radial depth of the row.
enum KsStepShape<'a> {
    /// The workpiece the replay runs on.
    Workpiece(&'a acc_sim::Workpiece, f64),
    /// Logged radial depths per row, mm, and the tool radius, mm.
    Logged(&'a [f64], f64),
}

impl KsStepShape<'_> {
    /// The workpiece with the material from `b` on (mm) at `Ks × (1 + δ)`.
    fn stepped(&self, b: f64, delta: f64) -> Option<acc_sim::Workpiece> {
        let KsStepShape::Workpiece(wp, _) = self else {
            return None;
        };
        let mut out = (*wp).clone();
        out.segments.clear();
        for g in &wp.segments {
            if g.end_mm <= b {
                out.segments.push(*g);
            } else if g.start_mm >= b {
                out.segments.push(acc_sim::workpiece::Segment {
                    ks_factor: g.ks_factor * (1.0 + delta),
                    ..*g
                });
            } else {
                let d = g.depth_at(b);
                out.segments.push(acc_sim::workpiece::Segment {
                    end_mm: b,
                    depth_end_mm: d,
                    ..*g
                });
                out.segments.push(acc_sim::workpiece::Segment {
                    start_mm: b,
                    depth_start_mm: d,
                    ks_factor: g.ks_factor * (1.0 + delta),
                    ..*g
                });
            }
        }
        Some(out)
    }

    /// Factor on the replayed force with the tool centre at `x` (row `i`), boundary `b`.
    fn factor(
        &self,
        stepped: Option<&acc_sim::Workpiece>,
        x: f64,
        b: f64,
        delta: f64,
        i: usize,
    ) -> f64 {
        let r = match self {
            KsStepShape::Workpiece(_, r) | KsStepShape::Logged(_, r) => *r,
        };
        // The engaged arc lies ahead of the tool centre, within one radius.
        if x >= b {
            return 1.0 + delta;
        }
        if x + r <= b {
            return 1.0;
        }
        match (self, stepped) {
            (KsStepShape::Workpiece(wp, _), Some(st)) => {
                let e0 = wp.engagement(x, r);
                let e1 = st.engagement(x, r);
                if e0.radial_mm > 0.0 && e0.ks_factor > 0.0 {
                    e1.ks_factor / e0.ks_factor
                } else {
                    1.0
                }
            }
            (KsStepShape::Logged(depth, _), _) => {
                // Lateral extent y of the arc sits (r² − (r − y)²)^½ ahead of the centre:
                // past the boundary for y > r − (r² − (b − x)²)^½.
                let d = depth.get(i).copied().unwrap_or(0.0);
                if d <= 0.0 {
                    return 1.0;
                }
                let off = b - x;
                let y = r - (r * r - off * off).max(0.0).sqrt();
                1.0 + delta * ((d - y) / d).clamp(0.0, 1.0)
            }
            _ => 1.0,
        }
    }
}

/// What does not change while only loads, losses and the sensor are fitted: the plant's
/// feed path and its force per unit calibration force (`Ks·a_p·d^α·f^β·s^γ /
/// calib_force_n`).
#[derive(Debug, Clone, PartialEq)]
struct PathKey {
    delay_s: f64,
    tau_s: f64,
    /// Second lag of the feed drive, s (0: first-order drive).
    tau2_s: f64,
    window_s: f64,
    process: [f64; 8],
}

/// The simulator's plant trace of one [`PathKey`].
#[derive(Debug, Clone)]
struct PathCache {
    key: PathKey,
    plant: Vec<acc_sim::replay::PeriodTrace>,
}

/// The window the compared channel averages at the end of each period, s.
fn channel_window_s(model: &Model, inp: &Inputs) -> f64 {
    match inp.channel {
        Channel::Force => model.measurement.force_window_s,
        Channel::Power => model.measurement.power_window_s,
    }
}

/// Replay the simulator's plant for the path key (see [`acc_sim::replay::trace`]).
fn plant_trace(
    model: &Model,
    inp: &Inputs,
    plant: &PlantInputs,
    key: &PathKey,
) -> Vec<acc_sim::replay::PeriodTrace> {
    let mut machine = model.machine.clone();
    // The recorded feed is the feed: no override path, no drive lag.
    let instant = plant.source == FeedSource::Recorded;
    machine.override_path.delay_s = if instant { 0.0 } else { key.delay_s };
    machine.feed_drive.tau_s = if instant { 0.0 } else { key.tau_s };
    machine.feed_drive.tau2_s = if instant { 0.0 } else { key.tau2_s };
    // The process constants of the key (the depth-exponent candidate changes α).
    let mut tool = model.tool.clone();
    tool.process.alpha = key.process[4];
    // The motor channel: the power, or the power a spindle-power force estimator reads.
    let power_read = inp.channel == Channel::Power || inp.estimator_no_load.is_some();
    let motor = match (power_read, model.measurement.spindle_motor) {
        (true, Some(m)) => m.config().ok(),
        _ => None,
    };
    let channel = acc_sim::replay::ReplayChannel {
        window_s: key.window_s,
        torque_lag_s: motor.as_ref().map_or(0.0, |c| c.drive.torque_lag_s),
        daq_rate_hz: motor.as_ref().map_or(0.0, |c| c.sensors.sample_rate_hz),
    };
    let run = |drive: &acc_sim::replay::ReplayDrive<'_>| {
        acc_sim::replay::trace(
            &machine,
            &tool,
            model.measurement.force_model.sim(),
            &plant.engagement,
            drive,
            &channel,
        )
    };
    let settled = plant.source == FeedSource::Command;
    let Some(sample) = inp.board_sample.as_ref().filter(|s| s.len() == inp.len()) else {
        return run(&acc_sim::replay::ReplayDrive {
            period_s: &inp.dt_s,
            override_applied_pct: &plant.override_applied_pct,
            programmed_feed_mm_min: &plant.programmed_feed_mm_min,
            feed_hold: None,
            spindle_rpm: plant.spindle_rpm.as_deref(),
            settled,
        });
    };
    // On the board's periods. The override register a row reads is the one that drove the
    // sample it reads (the board takes a period at its tick, with the register as it is
    // then; the write of the row before landed well before that tick). A period no row
    // read lies between row k−1 and row k: if row k−1 read the same sample as the row
    // before it, the board's tick was late and fired just after row k−1's read — most
    // likely before that row's write landed, so the period ran on what row k−1 read; if
    // not, row k read late, and the period ran on what row k reads.
    let periods = sample.last().map_or(0, |&s| s + 1);
    let mut ov = Vec::with_capacity(periods);
    let mut prog = Vec::with_capacity(periods);
    let mut rpm = Vec::with_capacity(periods);
    let mut row = 0;
    for s in 0..periods {
        while sample[row] < s {
            row += 1;
        }
        let late_tick = row >= 2 && sample[row] > s && sample[row - 1] == sample[row - 2];
        let from = if late_tick { row - 1 } else { row };
        ov.push(plant.override_applied_pct[from]);
        prog.push(plant.programmed_feed_mm_min[from]);
        if let Some(r) = &plant.spindle_rpm {
            rpm.push(r[from]);
        }
    }
    let grid = run(&acc_sim::replay::ReplayDrive {
        period_s: &vec![inp.period_s; periods],
        override_applied_pct: &ov,
        programmed_feed_mm_min: &prog,
        feed_hold: None,
        spindle_rpm: plant.spindle_rpm.as_ref().map(|_| rpm.as_slice()),
        settled,
    });
    sample.iter().map(|&s| grid[s]).collect()
}

/// Paths kept per [`Inputs`].
const PATH_CACHE: usize = 24;

fn remember(inp: &Inputs, c: std::rc::Rc<PathCache>) {
    let mut v = inp.cache.borrow_mut();
    if v.len() >= PATH_CACHE {
        v.remove(0);
    }
    v.push(c);
}

fn path(model: &Model, inp: &Inputs) -> std::rc::Rc<PathCache> {
    let fx = &model.effects;
    let mut proc = model.tool.process;
    proc.alpha += fx.get(EffectKind::DepthExponent, 0);
    let p = &proc;
    let key = PathKey {
        delay_s: model.machine.override_path.delay_s
            + fx.get(EffectKind::OverrideDeadTime, 0).max(0.0),
        tau_s: model.machine.feed_drive.tau_s + fx.get(EffectKind::FeedDriveLag, 0).max(0.0),
        tau2_s: model.machine.feed_drive.tau2_s + fx.get(EffectKind::SecondOrderDrive, 0).max(0.0),
        window_s: channel_window_s(model, inp),
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
    // The last few paths: a fit's numerical derivatives and cross-validation folds
    // alternate between nearby delays and time constants, each a full plant replay.
    if let Some(c) = inp.cache.borrow().iter().find(|c| c.key == key) {
        return c.clone();
    }
    let plant = plant_trace(model, inp, &inp.plant, &key);
    let c = std::rc::Rc::new(PathCache { key, plant });
    remember(inp, c.clone());
    c
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
    let cached = path(model, inp);
    replay_plant(model, inp, &cached.plant, &mut out);
    measurement_chain(model, inp, &mut out.predicted);
    out
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
                let sp = &model.machine.spindle;
                let drift_w = sp.noload_drift.map_or(0.0, |d| d.power_w(tt))
                    + fx.noload_drift.map_or(0.0, |d| d.power_w(tt));
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
                            + sp.motor_efficiency.map_or(0.0, |m| m.loss_w(pc_rms))
                            + fx.motor_efficiency.map_or(0.0, |m| m.loss_w(pc_rms))
                    }
                    None => {
                        physics::input_power_w(sp, torque, s, tt)
                            + fx.noload_drift.map_or(0.0, |d| d.power_w(tt))
                            + fx.motor_efficiency.map_or(0.0, |m| m.loss_w(pc))
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
mod force_power_tests {
    use super::ForcePowerConsistency;
    use proptest::prelude::*;

    /// A cut at 600–900 N logged every 0.1 s for 60 s, and the estimator's output.
    fn cut() -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (1..=600).map(|i| 0.1 * f64::from(i)).collect();
        let est = t.iter().map(|t| 750.0 + 150.0 * (0.3 * t).sin()).collect();
        (t, est)
    }

    fn round_to(x: &[f64], step: f64) -> Vec<f64> {
        x.iter().map(|v| (v / step).round() * step).collect()
    }

    #[test]
    fn a_force_column_made_from_the_power_is_consistent_at_its_formatting() {
        let (t, est) = cut();
        for step in [1e-3, 0.1, 1.0] {
            // The column written with 3, 1 and 0 decimals; its formatting σ given.
            let f = round_to(&est, step);
            let sigma = crate::stats::quantization_sigma(&f);
            let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, sigma).expect("rows");
            assert_eq!(c.rows, 600);
            assert!(c.consistent() && !c.drifts(), "step {step}: {c:?}");
        }
    }

    #[test]
    fn too_few_cut_rows_are_not_judged_and_a_dead_force_column_is_not_consistent() {
        let (t, est) = cut();
        let dead = vec![0.0; est.len()];
        let z = vec![0.0; est.len()];
        assert_eq!(ForcePowerConsistency::of(&t, 0.1, &z, &dead, 0.0), None);
        // The force stays 0 while the power says the tool cuts: compared, not consistent.
        let c = ForcePowerConsistency::of(&t, 0.1, &dead, &est, 0.0).expect("rows");
        assert!(!c.consistent() && !c.drifts(), "{c:?}");
        // A NaN row is left out.
        let mut f = est.clone();
        f[3] = f64::NAN;
        let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, 0.0).expect("rows");
        assert_eq!(c.rows, 599);
        assert!(c.consistent(), "{c:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// A gain drift of the logged force is found with its rate; a constant gain error,
        /// a step offset or stale samples differ from the power but are not a drift.
        #[test]
        fn a_logged_drift_is_measured_and_other_differences_are_not_a_drift(
            r in prop_oneof![-0.1f64..-0.005, 0.005f64..0.1],
            k in 1usize..7,
            g in prop_oneof![-0.05f64..-0.005, 0.005f64..0.05],
        ) {
            let (t, est) = cut();
            let f: Vec<f64> = t.iter().zip(&est).map(|(t, e)| e * (1.0 + r * (t - 0.1) / 60.0)).collect();
            let c = ForcePowerConsistency::of(&t, 0.1, &f, &est, 0.0).expect("rows");
            prop_assert!(c.drifts(), "{c:?}");
            prop_assert!((c.drift_per_min - r).abs() < 1e-9, "{c:?}");
            // Every 7th sample (from phase k) repeats the one before it.
            let mut stale = est.clone();
            for i in (k..stale.len()).step_by(7) {
                stale[i] = stale[i - 1];
            }
            // A constant gain error; a step offset half-way.
            let gain: Vec<f64> = est.iter().map(|e| e * (1.0 + g)).collect();
            let step: Vec<f64> = est
                .iter()
                .enumerate()
                .map(|(i, e)| if i >= 300 { e + 750.0 * g } else { *e })
                .collect();
            for (what, col) in [("stale", &stale), ("gain", &gain), ("step", &step)] {
                let c = ForcePowerConsistency::of(&t, 0.1, col, &est, 0.0).expect("rows");
                prop_assert!(!c.consistent() && !c.drifts(), "{what}: {c:?}");
            }
        }
    }
}
