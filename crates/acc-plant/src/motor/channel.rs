//! The measurement channels built on the motor: the feed-drive current
//! ([`FeedDriveCurrent`]) and the spindle-power channel ([`SpindlePowerChannel`]).

use std::f64::consts::PI;

use acc_core::spindle_force;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::{
    circuit::MotorEffects,
    config::BuiltinMotor,
    signals::{MotorSim, PeriodTruth},
    sweep,
};
use crate::config::{SensorLowpass, SpindleSpec};

/// Feed-drive current of the axis along the feed, for the spindle + feed-drive fusion
/// (seed 004, physics.md §3): at constant speed `Kt·I = C + Kf·F_x`, i.e.
/// `I = friction_a + a_per_n·F_x`, seen through the drive's current-loop bandwidth
/// (first order, ≈ 60 Hz in seed 004) plus seeded Gaussian noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FeedDriveCurrentSpec {
    /// Current at no feed force (`C/Kt`: friction of guides and ball screw), A. Default 3.
    pub friction_a: f64,
    /// Current per newton of feed force (`Kf/Kt`), A/N. Default 0.01.
    pub a_per_n: f64,
    /// Bandwidth of the current response, Hz. Default 60.
    pub bandwidth_hz: f64,
    /// Noise σ per sample, A. Default 0.05.
    pub noise_a: f64,
}

impl Default for FeedDriveCurrentSpec {
    fn default() -> Self {
        Self {
            friction_a: 3.0,
            a_per_n: 0.01,
            bandwidth_hz: 60.0,
            noise_a: 0.05,
        }
    }
}

/// The feed-drive current model (see [`FeedDriveCurrentSpec`]).
#[derive(Debug, Clone)]
pub struct FeedDriveCurrent {
    spec: FeedDriveCurrentSpec,
    state_a: f64,
    rng: ChaCha8Rng,
}

impl FeedDriveCurrent {
    /// At rest (no feed force), RNG `seed`.
    pub fn new(spec: FeedDriveCurrentSpec, seed: u64) -> Self {
        Self {
            spec,
            state_a: spec.friction_a,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// Advance `dt_s` under the feed force `feed_force_n`; returns the sampled current, A.
    pub fn step(&mut self, feed_force_n: f64, dt_s: f64) -> f64 {
        let target = self.spec.friction_a + self.spec.a_per_n * feed_force_n;
        let a = (-2.0 * PI * self.spec.bandwidth_hz * dt_s).exp();
        self.state_a = target + (self.state_a - target) * a;
        let z: f64 = StandardNormal.sample(&mut self.rng);
        self.state_a + self.spec.noise_a * z
    }
}

/// `[measurement] kind = "spindle-power"` keys: the channel's motor, estimator and
/// calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpindlePowerSpec {
    /// Built-in motor. Default `seed002-small-mill`.
    pub motor: BuiltinMotor,
    /// Estimator. Default `power-efficiency`.
    pub method: spindle_force::Method,
    /// Where the force is estimated. `true` (the default): the simulated board publishes
    /// the measured spindle power in its `POWER` registers and the production loop's
    /// spindle source estimates the force from the status read, as `acc run` does (power
    /// methods only: the board has no current register). `false`: the channel's
    /// estimator reads the three-phase block (a data-acquisition card on the spindle
    /// cables; the current methods need it) and hands the loop its estimate.
    pub board_power: bool,
    /// No-load handling. Default `adaptive`.
    pub no_load: spindle_force::NoLoadMode,
    /// Calibration cut forces as multiples of the force reference, −. Default
    /// `[0.25, 0.5, 0.75, 1.0, 1.25, 1.5]`.
    pub calibration_levels: [f64; 6],
    /// Estimate over the last `window_s` of each period, s (0 = whole period). Default
    /// 0.05, the dynamometer channel's window.
    pub window_s: f64,
}

impl Default for SpindlePowerSpec {
    fn default() -> Self {
        Self {
            motor: BuiltinMotor::Seed002SmallMill,
            method: spindle_force::Method::PowerEfficiency,
            board_power: true,
            no_load: spindle_force::NoLoadMode::Adaptive,
            calibration_levels: [0.25, 0.5, 0.75, 1.0, 1.25, 1.5],
            window_s: 0.05,
        }
    }
}

impl SpindlePowerChannel<spindle_force::SpindleSource> {
    /// Build the channel as it would be commissioned on a machine: an air cut and a
    /// calibration cut at `rpm` against a dynamometer (the reference force is the resultant
    /// force the controller regulates; `torque_per_n` converts it to spindle torque, e.g.
    /// `ForceLaw::torque_nm(1.0, R)`), then the estimator of `spec`. The motor's noise
    /// is seeded with `seed`; the calibration uses a different stream (`seed ^ 0xCA1`).
    /// The motor has no extra losses; [`SpindlePowerChannel::calibrated_for`] takes them
    /// from the machine file.
    pub fn calibrated(
        spec: &SpindlePowerSpec,
        seed: u64,
        rpm: f64,
        torque_per_n: f64,
        force_ref_n: f64,
        tool_radius_mm: f64,
        period_s: f64,
    ) -> Result<Self, sweep::SweepError> {
        // Only the speed of the spindle table is read; the motor file has its own losses.
        let spindle = SpindleSpec::new(rpm, 0.0, 1.0);
        Self::calibrated_for(
            spec,
            &spindle,
            seed,
            torque_per_n,
            force_ref_n,
            tool_radius_mm,
            period_s,
        )
    }

    /// [`SpindlePowerChannel::calibrated`] at the speed `spindle.rpm` of a machine file's
    /// `[spindle]` table, on a motor that honours its `[spindle.noload_drift]` and
    /// `[spindle.motor_efficiency]` ([`MotorEffects`]), read through its
    /// `[spindle.sensor_lowpass]` ([`SpindlePowerChannel::with_sensor_lowpass`]). The
    /// calibration cut runs on the same lossy motor (a machine is commissioned as it is),
    /// from its own start, so the drift has barely begun there when `τ` is long; the run's
    /// motor starts at `t = 0`.
    ///
    /// The calibration cut reads the power through the same low-pass (the transducer is on
    /// the cables during commissioning too), and each air speed and torque level settles
    /// for `max(10, ⌈τ·ln 1000 / T⌉)` periods, until the remainder `e^(−t/τ)` of the step
    /// from the previous level is below 0.1 %: the levels it measures are the steady
    /// ones, so the calibrated force curve and the learned no-load power are those of the
    /// unfiltered cut within its own seed-to-seed noise (≤ 0.7 % of force for τ ≤ 3 s
    /// against a 0.9 % spread; with only the 10 default settle periods τ = 1.5 s would
    /// bias it by 18 %: `tests/sim/motor_effects.rs`); only the learned σ of the air-cut
    /// power is smaller, as the filtered sensor's is. With the key absent or `τ = 0` the
    /// cut is that of the unfiltered channel, bit for bit.
    pub fn calibrated_for(
        spec: &SpindlePowerSpec,
        spindle: &SpindleSpec,
        seed: u64,
        torque_per_n: f64,
        force_ref_n: f64,
        tool_radius_mm: f64,
        period_s: f64,
    ) -> Result<Self, sweep::SweepError> {
        let rpm = spindle.rpm;
        let effects = MotorEffects::from_spindle(spindle);
        let cfg = spec.motor.config()?;
        let mut cal_sim = MotorSim::new(cfg.clone(), seed ^ 0xCA1).with_effects(effects);
        let torques: Vec<f64> = spec
            .calibration_levels
            .iter()
            .map(|k| k * force_ref_n * torque_per_n)
            .collect();
        // Through the low-pass, settle until the previous level's remainder is < 0.1 %.
        let lowpass_settle = match spindle.sensor_lowpass {
            Some(l) if period_s > 0.0 => (l.tau_s * 1e3f64.ln() / period_s).ceil().min(1e5),
            _ => 0.0,
        };
        let timing = sweep::Timing {
            period_s,
            settle_periods: 10.max(lowpass_settle as u32),
            measure_periods: 20,
        };
        let (nl, groups) = sweep::calibration_cut(
            &mut cal_sim,
            &[rpm],
            rpm,
            &torques,
            1.0 / torque_per_n,
            timing,
            spindle.sensor_lowpass,
        )?;
        let constants = acc_spindle::calibrate::calibrate(&groups.concat(), &nl, tool_radius_mm)?;
        let est_cfg = spindle_force::EstimatorConfig {
            method: spec.method,
            tool_radius_mm,
            no_load: spec.no_load,
            ..spindle_force::EstimatorConfig::default()
        };
        let est = spindle_force::SpindleEstimator::new(est_cfg, constants, nl)?;
        let input = if spec.board_power {
            spindle_force::SpindleInput::BoardPower
        } else {
            spindle_force::SpindleInput::Phases
        };
        let source = spindle_force::SpindleSource::new(input, est)?;
        let motor = MotorSim::new(cfg, seed).with_effects(effects);
        let mut channel =
            Self::new(motor, source, spec.window_s).with_sensor_lowpass(spindle.sensor_lowpass);
        if spec.board_power {
            channel.board = BoardEstimate::Offered(Box::new(channel.source.clone()));
        }
        Ok(channel)
    }
}

/// The power transducer on the spindle cables: it reports each period's two-wattmeter
/// power through the machine file's `[spindle.sensor_lowpass]` — the same first-order
/// low-pass, discretised per control period, as the constant-speed spindle's reported
/// power ([`SensorLowpass::step`]: `y_k = a·y_(k−1) + (1 − a)·x_k`, `a = e^(−T/τ)`,
/// `y_0 = x_0`) — or as measured without it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PowerSensor {
    lowpass: Option<SensorLowpass>,
    /// Last reported power, W (`None` before the first period).
    state: Option<f64>,
}

impl PowerSensor {
    pub(super) fn new(lowpass: Option<SensorLowpass>) -> Self {
        Self {
            lowpass,
            state: None,
        }
    }

    /// The power reported for a period of `period_s` s whose measured power is `power_w` W.
    pub(super) fn read(&mut self, power_w: f64, period_s: f64) -> f64 {
        match self.lowpass {
            Some(l) => l.step(&mut self.state, power_w, period_s),
            None => power_w,
        }
    }
}

/// Who estimates the force of a [`SpindlePowerChannel`].
#[derive(Debug, Clone, Default)]
enum BoardEstimate {
    /// The channel's own source (the three-phase block, or a source built in code).
    #[default]
    Channel,
    /// The channel's source until the production loop takes this board-power source
    /// ([`crate::channel::MeasurementChannel::take_board_source`]).
    Offered(Box<spindle_force::SpindleSource>),
    /// The loop estimates from the board's power register; the channel only measures.
    Loop,
}

/// Below this measured power, W (the board's resolution), the block is not rescaled to the
/// filtered power: the ratio would be meaningless (spindle stopped).
const MIN_RESCALE_POWER_W: f64 = 1.0;

/// The spindle-power measurement channel of the simulated machine: the period's cutting
/// torque (the machine's internal samples) drives [`MotorSim`], and a force source —
/// normally an [`acc_core::spindle_force::SpindleSource`] on the three-phase block —
/// estimates the force the controller sees. The true force reported next to it is the period's mean resultant
/// force, as the dynamometer channel reports it.
#[derive(Debug)]
pub struct SpindlePowerChannel<S> {
    motor: MotorSim,
    pub(super) source: S,
    torques: Vec<f64>,
    last: PeriodTruth,
    window_s: f64,
    sensor: PowerSensor,
    board: BoardEstimate,
    /// The window's line voltages rescaled to the filtered power, V (scratch).
    scaled_v_uw: Vec<f64>,
    scaled_v_vw: Vec<f64>,
}

impl<S: acc_core::ForceSource> SpindlePowerChannel<S> {
    /// A channel over `motor` read by `source`, estimating over the last `window_s` of
    /// each period (0 = the whole period), like the dynamometer channel's window.
    pub fn new(motor: MotorSim, source: S, window_s: f64) -> Self {
        Self {
            motor,
            source,
            torques: Vec::new(),
            last: PeriodTruth::default(),
            window_s,
            sensor: PowerSensor::default(),
            board: BoardEstimate::Channel,
            scaled_v_uw: Vec::new(),
            scaled_v_vw: Vec::new(),
        }
    }

    /// The same channel with the power transducer's first-order low-pass `lowpass`
    /// (`[spindle.sensor_lowpass]`; `None` or `τ = 0`: off, every output bit-identical).
    ///
    /// Each period the window's two-wattmeter power `P` (seed 000 eqs. 12–13) passes
    /// through it ([`SensorLowpass::step`] with the period length, as the constant-speed
    /// spindle's reported power does) to `P_lp`. The force source gets `P_lp` both ways:
    /// as `PeriodInput::power_w` (whole watts, the board's value) and in the three-phase
    /// block, whose line voltages are scaled by `P_lp/P` so that the block's
    /// two-wattmeter power is `P_lp` while the phase currents — what current-based
    /// methods read — are untouched (the low-pass is the power channel's). The run log's
    /// `power_w` is therefore the filtered power. The block is passed unscaled when
    /// `|P| < 1 W` (spindle stopped).
    pub fn with_sensor_lowpass(mut self, lowpass: Option<SensorLowpass>) -> Self {
        self.sensor = PowerSensor::new(lowpass);
        self
    }

    /// The force source (e.g. to read its last estimate).
    pub fn source(&self) -> &S {
        &self.source
    }

    /// Noise-free motor means of the last period.
    pub fn last_truth(&self) -> &PeriodTruth {
        &self.last
    }
}

impl<S: acc_core::ForceSource> crate::channel::MeasurementChannel for SpindlePowerChannel<S> {
    fn name(&self) -> &str {
        self.source.name()
    }

    fn measure(&mut self, period: &crate::machine::PeriodRecord<'_>) -> crate::channel::Reading {
        self.torques.clear();
        self.torques
            .extend(period.samples.iter().map(|s| s.torque_nm));
        let n = self.motor.samples_in(period.period_s);
        let fs = self.motor.motor().config().sensors.sample_rate_hz;
        let w = if self.window_s > 0.0 && self.window_s < period.period_s {
            ((self.window_s * fs).round() as usize).clamp(1, n.max(1))
        } else {
            n
        };
        // Only the window is read: the samples before it are not synthesised (their noise
        // is drawn, so the stream and the window are bit for bit those of the full block).
        let block =
            self.motor
                .run_period_tail(period.spindle_rpm, &self.torques, period.period_s, w);
        self.last = block.truth;
        let mut phases = block.samples.tail_block(w);
        let measured_w = spindle_force::block_stats(&phases).ok().map(|s| s.power_w);
        let reported_w = measured_w.map(|p| self.sensor.read(p, period.period_s));
        if let (Some(p), Some(p_lp)) = (measured_w, reported_w) {
            if p_lp != p && p.abs() >= MIN_RESCALE_POWER_W {
                // The block's two-wattmeter power becomes the filtered one, currents stay.
                let r = p_lp / p;
                self.scaled_v_uw.clear();
                self.scaled_v_uw.extend(phases.v_uw.iter().map(|v| v * r));
                self.scaled_v_vw.clear();
                self.scaled_v_vw.extend(phases.v_vw.iter().map(|v| v * r));
                phases.v_uw = &self.scaled_v_uw;
                phases.v_vw = &self.scaled_v_vw;
            }
        }
        let truth = period.force_window_mean_n(self.window_s);
        // What a power transducer on the same cables reports over the window (through its
        // low-pass when set), in whole watts as in the board's input registers 4–5 (`None`
        // if the block is garbage).
        let board_power_w = reported_w.map(|p| p.round().max(0.0));
        if matches!(self.board, BoardEstimate::Loop) {
            return crate::channel::Reading {
                sample: acc_core::ForceSample {
                    power_w: board_power_w,
                    ..acc_core::ForceSample::INVALID
                },
                true_force_n: truth,
                board_power_w,
            };
        }
        let input = acc_core::PeriodInput {
            // The block handed over covers the window.
            period_s: w as f64 / block.samples.sample_rate_hz,
            spindle_rpm: period.spindle_rpm,
            feed_mm_min: period.feed_mean_mm_min,
            true_force_n: Some(truth),
            power_w: board_power_w,
            phases: Some(phases),
        };
        crate::channel::Reading {
            sample: self.source.estimate(&input),
            true_force_n: truth,
            board_power_w,
        }
    }

    fn take_board_source(&mut self) -> Option<Box<dyn acc_core::ForceSource>> {
        match std::mem::take(&mut self.board) {
            BoardEstimate::Offered(source) => {
                self.board = BoardEstimate::Loop;
                Some(source)
            }
            other => {
                self.board = other;
                None
            }
        }
    }
}
