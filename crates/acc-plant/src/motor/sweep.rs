//! The seed 000 experiment on the simulated motor: air cuts, the calibration cut of
//! Table 1 (1 100 rpm, 400–700 mm/min) and the feed sweep of Table 3 (1 500 rpm,
//! 20–300 mm/min in steps of 20, 350–1 000 in steps of 50), face cutter Ø80 with 6
//! inserts on S45C, axial depth 1 mm, lateral 64 mm. Used by `acc estimate-eval` and the
//! tests.

use std::path::{Path, PathBuf};

use acc_config::{check_range, resolve_relative, ConfigError};
use acc_core::spindle_force::{
    block_stats, AdaptRule, EstimatorConfig, Invalid, Method, NoLoadMode, NoLoadModel,
    SpindleError, SpindleEstimator,
};
use acc_spindle::calibrate::{calibrate, CalPoint, SpindleCalibration};
use acc_spindle::eval::{error_rate_pct, rms_error};
use serde::Deserialize;

use super::{MotorConfig, MotorSim, PowerSensor};
use crate::config::SensorLowpass;

/// `[tool]`: the face cutter.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaceMill {
    /// Cutter diameter D, mm.
    pub diameter_mm: f64,
    /// Number of inserts z.
    pub teeth: u32,
}

/// `[material]`: specific cutting force `k_c = k_c1.1 · h_m^(−m_c)` (Kienzle).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// `k_c1.1` at 1 mm chip thickness, N/mm².
    pub kc11_n_mm2: f64,
    /// Exponent `m_c`, −.
    pub mc: f64,
}

/// `[cut]`: engagement.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cut {
    /// Axial depth a_p, mm.
    pub axial_mm: f64,
    /// Lateral (radial) width a_e, mm.
    pub lateral_mm: f64,
}

/// `[calibration]`: air cuts and the calibration cut (seed 000 Table 1).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Speeds of the air cuts that teach the no-load model, rpm.
    pub air_rpm: Vec<f64>,
    /// Speed of the calibration cut, rpm.
    pub rpm: f64,
    /// Feeds of the calibration cut, mm/min.
    pub feeds_mm_min: Vec<f64>,
}

/// `[sweep]`: the evaluated load sweep (seed 000 Table 3).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// Feeds, mm/min.
    pub feeds_mm_min: Vec<f64>,
}

/// `[timing]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    /// Control period T, s.
    pub period_s: f64,
    /// Periods discarded after each change of condition.
    pub settle_periods: u32,
    /// Periods averaged per condition.
    pub measure_periods: u32,
}

/// A sweep file (`configs/calibration/seed000-sweep.toml`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepConfig {
    /// Motor file, relative to this file.
    pub motor: PathBuf,
    /// RNG seed of the motor's noise.
    pub seed: u64,
    /// Cutter.
    pub tool: FaceMill,
    /// Work material.
    pub material: Material,
    /// Engagement.
    pub cut: Cut,
    /// Air cuts and calibration cut.
    pub calibration: Calibration,
    /// The sweep.
    pub sweep: SweepSpec,
    /// Timing.
    pub timing: Timing,
}

impl SweepConfig {
    /// Read and validate a sweep file and the motor file it names.
    pub fn load(path: impl AsRef<Path>) -> Result<(Self, MotorConfig), ConfigError> {
        let path = path.as_ref();
        let cfg: Self = acc_config::load_toml(path)?;
        let f = path;
        check_range(f, "tool.diameter_mm", cfg.tool.diameter_mm, 1.0, 1000.0)?;
        check_range(f, "tool.teeth", f64::from(cfg.tool.teeth), 1.0, 100.0)?;
        check_range(
            f,
            "material.kc11_n_mm2",
            cfg.material.kc11_n_mm2,
            100.0,
            10_000.0,
        )?;
        check_range(f, "material.mc", cfg.material.mc, 0.0, 0.6)?;
        check_range(f, "cut.axial_mm", cfg.cut.axial_mm, 0.01, 100.0)?;
        check_range(
            f,
            "cut.lateral_mm",
            cfg.cut.lateral_mm,
            0.01,
            cfg.tool.diameter_mm,
        )?;
        check_range(f, "calibration.rpm", cfg.calibration.rpm, 10.0, 1e5)?;
        check_range(f, "sweep.rpm", cfg.sweep.rpm, 10.0, 1e5)?;
        check_range(f, "timing.period_s", cfg.timing.period_s, 1e-3, 10.0)?;
        check_range(
            f,
            "timing.measure_periods",
            f64::from(cfg.timing.measure_periods),
            1.0,
            1e5,
        )?;
        let lists: [(&str, &[f64], f64); 3] = [
            ("calibration.air_rpm", &cfg.calibration.air_rpm, 1e5),
            (
                "calibration.feeds_mm_min",
                &cfg.calibration.feeds_mm_min,
                1e5,
            ),
            ("sweep.feeds_mm_min", &cfg.sweep.feeds_mm_min, 1e5),
        ];
        for (key, list, hi) in lists {
            if list.is_empty() {
                return Err(ConfigError::Invalid {
                    file: f.to_path_buf(),
                    key: key.into(),
                    message: "must not be empty".into(),
                });
            }
            for (k, v) in list.iter().enumerate() {
                check_range(f, &format!("{key}[{k}]"), *v, 1e-3, hi)?;
            }
        }
        let motor = MotorConfig::load(resolve_relative(path, &cfg.motor))?;
        Ok((cfg, motor))
    }

    /// Mean tangential force of the face cutter, N: Kienzle `k_c = k_c1.1·h_m^(−m_c)`,
    /// mean chip thickness of a centred cut `h_m = f_z·180·a_e / (π·D·asin(a_e/D))`,
    /// cutting power `P_c = k_c·a_p·a_e·v_f`, force at the cutter radius
    /// `F_t = P_c / (ω·D/2)`.
    pub fn tangential_force_n(&self, feed_mm_min: f64, rpm: f64) -> f64 {
        let d = self.tool.diameter_mm;
        let ae = self.cut.lateral_mm;
        let fz = feed_mm_min / (f64::from(self.tool.teeth) * rpm);
        let half_angle_deg = (ae / d).min(1.0).asin().to_degrees();
        let hm = fz * 180.0 * ae / (std::f64::consts::PI * d * half_angle_deg);
        if hm <= 0.0 {
            return 0.0;
        }
        let kc = self.material.kc11_n_mm2 * hm.powf(-self.material.mc);
        let power_w = kc * self.cut.axial_mm * ae * feed_mm_min / 60_000.0;
        let omega = 2.0 * std::f64::consts::PI * rpm / 60.0;
        power_w / (omega * d / 2.0 * 1e-3)
    }

    /// Tool radius, mm.
    pub fn radius_mm(&self) -> f64 {
        self.tool.diameter_mm / 2.0
    }
}

/// One sweep point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepPoint {
    /// Feed, mm/min.
    pub feed_mm_min: f64,
    /// True mean tangential force at the motor (after the drive lag), N.
    pub true_n: f64,
    /// Mean estimate per method, in [`Method::ALL`] order, N.
    pub est_n: [f64; 4],
    /// Mean estimate of the plain power method with the no-load model off, N.
    pub power_no_load_off_n: f64,
}

/// Outcome of the sweep.
#[derive(Debug, Clone)]
pub struct SweepResult {
    /// The fitted calibration (no-load model + constants).
    pub calibration: SpindleCalibration,
    /// `Kt` of each calibration feed alone, N·m/A (seed 000 Table 2).
    pub kt_per_feed: Vec<(f64, f64)>,
    /// Sweep points.
    pub points: Vec<SweepPoint>,
    /// RMS error per method, N ([`Method::ALL`] order).
    pub rms_n: [f64; 4],
    /// Error rate per method, % (RMS / mean true force).
    pub rate_pct: [f64; 4],
    /// RMS error (N) and error rate (%) of the plain power method with the no-load
    /// model off.
    pub no_load_off: (f64, f64),
}

/// Sweep errors.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// Configuration.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Signal processing or calibration.
    #[error(transparent)]
    Spindle(#[from] SpindleError),
    /// A block the estimator refused.
    #[error("estimator refused a period at {feed_mm_min} mm/min: {reason}")]
    Invalid {
        /// Feed of the period.
        feed_mm_min: f64,
        /// Why.
        reason: Invalid,
    },
}

/// Air cuts and a calibration cut on the simulated motor, as on the machine with a
/// dynamometer: after `settle_periods`, each of `measure_periods` periods of air at every
/// speed in `air_rpm` teaches the no-load model; then each cutting torque in
/// `torques_nm` at `rpm` gives one [`CalPoint`] per period with the reference force
/// `torque · force_per_nm` (for a tangential reference, `1/r`). Points are grouped per
/// torque.
///
/// `lowpass`: the power transducer's low-pass (`[spindle.sensor_lowpass]`), present
/// during commissioning as in the run: every period's two-wattmeter power passes
/// through it before it is learned or becomes a point (the current does not; `None`:
/// the power as measured). Its state runs on across speeds and levels; the caller
/// settles long enough for the steady levels (see
/// [`super::SpindlePowerChannel::calibrated_for`]).
pub fn calibration_cut(
    sim: &mut MotorSim,
    air_rpm: &[f64],
    rpm: f64,
    torques_nm: &[f64],
    force_per_nm: f64,
    t: Timing,
    lowpass: Option<SensorLowpass>,
) -> Result<(NoLoadModel, Vec<Vec<CalPoint>>), SweepError> {
    let mut sensor = PowerSensor::new(lowpass);
    let mut nl = NoLoadModel::new(AdaptRule::default());
    for &n in air_rpm {
        for k in 0..(t.settle_periods + t.measure_periods) {
            let b = sim.run_period(n, &[0.0], t.period_s);
            let s = block_stats(&b.phase_block())?;
            let power_w = sensor.read(s.power_w, t.period_s);
            if k >= t.settle_periods {
                nl.learn(n, power_w, s.current_rms_a)?;
            }
        }
    }
    let mut groups = Vec::new();
    for &torque in torques_nm {
        let mut these = Vec::new();
        for k in 0..(t.settle_periods + t.measure_periods) {
            let b = sim.run_period(rpm, &[torque], t.period_s);
            let s = block_stats(&b.phase_block())?;
            let power_w = sensor.read(s.power_w, t.period_s);
            if k >= t.settle_periods {
                these.push(CalPoint {
                    rpm,
                    power_w,
                    current_a: s.current_rms_a,
                    force_ref_n: torque * force_per_nm,
                });
            }
        }
        groups.push(these);
    }
    Ok((nl, groups))
}

/// Run the experiment: learn the no-load model from the air cuts, calibrate every
/// method on the calibration cut, then estimate over the sweep.
pub fn run(cfg: &SweepConfig, motor: &MotorConfig) -> Result<SweepResult, SweepError> {
    let mut sim = MotorSim::new(motor.clone(), cfg.seed);
    let t = cfg.timing;
    let radius = cfg.radius_mm();
    let rpm_c = cfg.calibration.rpm;
    let torques: Vec<f64> = cfg
        .calibration
        .feeds_mm_min
        .iter()
        .map(|&f| cfg.tangential_force_n(f, rpm_c) * radius * 1e-3)
        .collect();
    let (nl, groups) = calibration_cut(
        &mut sim,
        &cfg.calibration.air_rpm,
        rpm_c,
        &torques,
        1.0 / (radius * 1e-3),
        t,
        None,
    )?;
    let mut kt_per_feed = Vec::new();
    for (feed, g) in cfg.calibration.feeds_mm_min.iter().zip(&groups) {
        let kt = acc_spindle::calibrate::fit_current(g, &nl, radius)?;
        kt_per_feed.push((*feed, kt.kt_nm_per_a));
    }
    let points: Vec<CalPoint> = groups.concat();
    let constants = calibrate(&points, &nl, radius)?;
    let calibration = SpindleCalibration::new(
        format!(
            "{}: simulated seed 000 calibration cut at {} rpm, feeds {:?} mm/min",
            motor.name, rpm_c, cfg.calibration.feeds_mm_min
        ),
        radius,
        &nl,
        constants,
    );
    // 3. The sweep, all four methods on the same blocks.
    let mut ests = Vec::new();
    for m in Method::ALL {
        let c = EstimatorConfig {
            method: m,
            tool_radius_mm: radius,
            no_load: NoLoadMode::Fixed,
            ..EstimatorConfig::default()
        };
        ests.push(SpindleEstimator::new(c, constants, nl.clone())?);
    }
    let mut off = SpindleEstimator::new(
        EstimatorConfig {
            method: Method::Power,
            tool_radius_mm: radius,
            no_load: NoLoadMode::Off,
            ..EstimatorConfig::default()
        },
        constants,
        nl.clone(),
    )?;
    let rpm = cfg.sweep.rpm;
    let mut out = Vec::new();
    for &feed in &cfg.sweep.feeds_mm_min {
        let torque = cfg.tangential_force_n(feed, rpm) * radius * 1e-3;
        let (mut sum_true, mut sums, mut sum_off) = (0.0, [0.0; 4], 0.0);
        for k in 0..(t.settle_periods + t.measure_periods) {
            let b = sim.run_period(rpm, &[torque], t.period_s);
            let s = block_stats(&b.phase_block())?;
            let truth = b.truth.cut_torque_nm / (radius * 1e-3);
            for (j, e) in ests.iter_mut().enumerate() {
                let r = e.estimate(rpm, Some(s.power_w), Some(s.current_rms_a));
                let f = r.map_err(|reason| SweepError::Invalid {
                    feed_mm_min: feed,
                    reason,
                })?;
                if k >= t.settle_periods {
                    sums[j] += f.force_n;
                }
            }
            let f_off =
                off.estimate(rpm, Some(s.power_w), None)
                    .map_err(|reason| SweepError::Invalid {
                        feed_mm_min: feed,
                        reason,
                    })?;
            if k >= t.settle_periods {
                sum_true += truth;
                sum_off += f_off.force_n;
            }
        }
        let n = f64::from(t.measure_periods);
        out.push(SweepPoint {
            feed_mm_min: feed,
            true_n: sum_true / n,
            est_n: sums.map(|x| x / n),
            power_no_load_off_n: sum_off / n,
        });
    }
    let truth: Vec<f64> = out.iter().map(|p| p.true_n).collect();
    let mut rms_n = [0.0; 4];
    let mut rate_pct = [0.0; 4];
    for j in 0..4 {
        let est: Vec<f64> = out.iter().map(|p| p.est_n[j]).collect();
        rms_n[j] = rms_error(&est, &truth);
        rate_pct[j] = error_rate_pct(&est, &truth);
    }
    let off: Vec<f64> = out.iter().map(|p| p.power_no_load_off_n).collect();
    Ok(SweepResult {
        calibration,
        kt_per_feed,
        points: out,
        rms_n,
        rate_pct,
        no_load_off: (rms_error(&off, &truth), error_rate_pct(&off, &truth)),
    })
}
