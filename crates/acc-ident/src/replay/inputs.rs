//! The replay's inputs, prepared once per log: which logged columns drive the plant, the
//! compared channel, the estimator's no-load track, the board's samples, applicability of
//! each effect.

#[allow(unused_imports)]
use super::*;

/// A column's level in air counts as a reference for a gain when it is at least this
/// share of its mean over the cutting rows, − ([`Inputs::gain_drift_separable`]).
pub const GAIN_REFERENCE_SHARE: f64 = 0.05;
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
    /// The periods the board's `ACTUAL_FEED` placed on another override than the log's
    /// (writes that raced the board's tick, late ticks), re-timed in
    /// [`PlantInputs::override_applied_pct`] or [`PlantInputs::board_override_pct`]
    /// ([`super::raced`]).
    pub raced: super::raced::RaceCount,
    /// The last feed paths and unit forces (see [`replay`]); not part of the inputs.
    pub(super) cache: std::cell::RefCell<Vec<std::rc::Rc<PathCache>>>,
    /// The last replays and their models (see [`replay_shared`]); not part of the inputs.
    pub(super) replays: std::cell::RefCell<Vec<(Model, std::rc::Rc<Replay>)>>,
    /// Quadratic fits of the spindle motor's input power against torque, per speed.
    pub(super) motor_curves: std::cell::RefCell<Vec<(f64, [f64; 3])>>,
    /// The runout basis of the plant's drive, left by the first trace for the next ones
    /// (the drive is the rows', or the board's periods with [`Inputs::board_sample`]).
    pub(super) runout_basis: acc_sim::replay::RunoutBasis,
}

/// What drives the simulator's plant in a replay ([`acc_sim::replay::trace`]).
#[derive(Debug, Clone)]
pub struct PlantInputs {
    /// Which logged columns drive it.
    pub source: FeedSource,
    /// Override on the PMC inputs during each row's period (the sample it read), %: the
    /// logged `override_applied_pct`, with writes that raced the board's tick re-timed
    /// ([`super::raced`]).
    pub override_applied_pct: Vec<f64>,
    /// Override on the PMC inputs during each of the board's periods, %, when the replay
    /// runs on them ([`Inputs::board_sample`]) and the board's feed placed them
    /// ([`super::raced::retime`]); `None`: from the rows (`raced::board_periods`).
    pub board_override_pct: Option<Vec<f64>>,
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
        // Only for a board that samples once per control period (most rows moved by one):
        // a board sampling faster moves by several every row.
        let board_sample: Option<Vec<usize>> = log
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
            });
        let mut raced = super::raced::RaceCount::default();
        let mut board_override = None;
        let plant = match (source, &log.programmed_feed_mm_min, &log.override_cmd_pct) {
            (FeedSource::Applied, _, _) => {
                let (p, mut o) = applied.clone().ok_or(ReplayError::MissingApplied)?;
                if let Some(feed) = &log.board_feed_mm_min {
                    let m = &model.machine;
                    let share = super::raced::first_period_share(
                        m.override_path.delay_s,
                        m.feed_drive.tau_s,
                        m.feed_drive.tau2_s,
                        log.median_period_s(),
                    );
                    let (periods, count) =
                        super::raced::retime(&o, &p, feed, board_sample.as_deref(), share);
                    raced = count;
                    match board_sample {
                        None => o = periods,
                        Some(_) => board_override = Some(periods),
                    }
                }
                PlantInputs {
                    source,
                    override_applied_pct: o,
                    board_override_pct: board_override,
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
                    board_override_pct: None,
                    programmed_feed_mm_min: shift(p, p.first().copied().unwrap_or(0.0)),
                    spindle_rpm: Some(log.spindle_rpm.clone()),
                    engagement: logged_engagement(log),
                }
            }
            _ => PlantInputs {
                source: FeedSource::Recorded,
                override_applied_pct: vec![100.0; log.len()],
                board_override_pct: None,
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
            board_sample,
            raced,
            cache: Default::default(),
            replays: Default::default(),
            motor_curves: Default::default(),
            runout_basis: Default::default(),
        })
    }

    /// Replay the plant on `workpiece` (tool centre at `x0_mm` when the log began)
    /// instead of the logged depths: the engagement then changes inside each period as in
    /// the simulator, and material boundaries (`ks_factor`) are honoured. No effect
    /// without a plant replay (see [`Inputs::plant`]).
    pub fn use_workpiece(&mut self, workpiece: acc_sim::Workpiece, x0_mm: f64) {
        self.plant.engagement = acc_sim::replay::ReplayEngagement::Workpiece { workpiece, x0_mm };
        self.cache.borrow_mut().clear();
        self.replays.borrow_mut().clear();
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
            | EffectKind::FeedAccelLimit
                if self.feed_cmd_mm_min.is_none() =>
            {
                Err("needs the feed command (programmed_feed_mm_min, override_cmd_pct)")
            }
            EffectKind::Runout if self.runout_visibility() < 0.05 => {
                Err("not observable: the sampling averages whole spindle revolutions")
            }
            EffectKind::FeedDriveLag
            | EffectKind::OverrideDeadTime
            | EffectKind::SecondOrderDrive
            | EffectKind::FeedAccelLimit
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
            EffectKind::SensorGainDrift if !self.gain_drift_separable() => Err(
                "not separable from the process on this log: no second view of the force and no level in air for a gain to scale (a gain drifting in time is then the curve of the cutting force drifting in time)",
            ),
            EffectKind::FeedExponent if self.cut_feed_cv() < 0.02 => {
                Err("not excited: the feed hardly varies while cutting")
            }
            _ => Ok(()),
        }
    }

    /// Number of cutting rows.
    pub(super) fn cut_rows(&self) -> usize {
        (0..self.len()).filter(|&i| self.is_cut(i)).count()
    }

    /// Whether the cutting rows hold at least two radial depths: ≥ 10 rows within 5 % of
    /// the median cut depth and ≥ 10 rows further from it.
    pub(super) fn two_depths(&self) -> bool {
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
    pub(super) fn command_steps(&self) -> bool {
        self.feed_cmd_mm_min.as_ref().is_some_and(|c| {
            c.windows(2)
                .any(|w| (w[1] - w[0]).abs() > 0.01 * w[0].abs().max(w[1].abs()))
        })
    }

    /// Whether a gain drifting in log time (`sensor_gain_drift`) can be told from the
    /// process's own force drifting (wear, a `Ks` rising with cutting time) on this log. A
    /// gain multiplies the whole logged column; the process moves only its cutting part.
    /// They differ only where
    ///
    /// - the log carries a second view of the force (the estimator's output on the logged
    ///   power, [`Inputs::force_from_power`]: the force-against-power check decides), or
    /// - the column has a level in air, early and late (air rows in the log's first and
    ///   last third averaging at least [`GAIN_REFERENCE_SHARE`] of the cutting rows' mean:
    ///   spindle power's no-load power, which a gain scales and the process does not).
    ///
    /// A force sensor's column, zero in air, has neither (a turning tool's log): there a
    /// gain drift is the curve of a cutting coefficient drifting in time, and on one
    /// removal rate the curve of wear per removed volume too (docs/twin.md "Naming").
    pub fn gain_drift_separable(&self) -> bool {
        if self.force_from_power.is_some() {
            return true;
        }
        let n = self.len();
        if n < 3 {
            return false;
        }
        let (t0, t1) = (self.t_s[0], self.t_s[n - 1]);
        let third = (t1 - t0) / 3.0;
        let level = |cut: bool, from: f64, to: f64| {
            let v: Vec<f64> = (0..n)
                .filter(|&i| self.is_cut(i) == cut && self.t_s[i] >= from && self.t_s[i] <= to)
                .map(|i| self.measured[i])
                .collect();
            (!v.is_empty()).then(|| crate::stats::mean(&v).abs())
        };
        let Some(cutting) = level(true, t0, t1).filter(|l| *l > 0.0) else {
            return false;
        };
        let reference = |l: Option<f64>| l.is_some_and(|l| l >= GAIN_REFERENCE_SHARE * cutting);
        reference(level(false, t0, t0 + third)) && reference(level(false, t1 - third, t1))
    }

    /// Coefficient of variation of the recorded feed over the cutting rows.
    pub(super) fn cut_feed_cv(&self) -> f64 {
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
pub(super) fn logged_engagement(log: &RunLog) -> acc_sim::replay::ReplayEngagement {
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
pub(super) const MIN_SIDE_ROWS: usize = 10;

/// Least-squares quadratic of the motor's input power against cutting torque at `rpm`
/// (see [`Inputs::motor_curve`]); a zero curve when the motor cannot be loaded.
pub(super) fn motor_quadratic(motor: acc_sim::motor::BuiltinMotor, rpm: f64) -> [f64; 3] {
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
