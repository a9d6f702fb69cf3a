//! Calibration: fit each method's constants from a calibration cut with a reference force
//! (a dynamometer), and keep them, with the no-load model, in a TOML file.
//!
//! A calibration cut is a few periods at known loads (seed 000 Table 1: 1 100 rpm, feeds
//! 400–700 mm/min, face cutter Ø80). Each [`CalPoint`] holds what the spindle sensors saw
//! and the reference force; the no-load model (learned from air cuts first) gives `P_air`
//! and `I_air` at the point's speed. The fits are linear least squares (nalgebra SVD):
//!
//! * power with efficiency: `F_ref·ω·r = g·ΔP + q·ΔP·|ΔP|` → `g`, `q`;
//! * conventional current: `F_ref·r = Kt·(I − I_air)` → `Kt` (through the origin, as the
//!   paper averages `Kt` over its basic experiments, Table 2);
//! * motor characteristics: `I² − I_air² = a·T + b·T²` with `T = F_ref·r` → `a`, `b`.
//!
//! The plain power method (eq. 14) has no constant to fit.
//!
//! File format (`configs/calibration/*.toml`):
//!
//! ```toml
//! description = "seed 000 spindle, simulated basic experiment"
//! tool_radius_mm = 40.0
//!
//! [[no_load]]
//! rpm = 1500.0
//! power_w = 812.0
//! current_a = 24.1
//! sigma_power_w = 2.0
//! sigma_current_a = 0.01
//! periods = 20
//!
//! [constants.power_efficiency]
//! gain = 1.002
//! loss_w_per_nm2 = 0.55
//!
//! [constants.current]
//! kt_nm_per_a = 2.4
//!
//! [constants.motor_characteristics]
//! a_a2_per_nm = 3.1
//! b_a2_per_nm2 = 0.9
//! ```

use std::path::Path;

use acc_config::{check_range, ConfigError};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use acc_core::spindle_force::{
    AdaptRule, Constants, CurrentConstant, EstimatorConfig, MotorCharacteristic, NoLoadModel,
    NoLoadPoint, PowerEfficiency, SpindleError, SpindleEstimator,
};

/// One calibration period: what the spindle sensors saw and the reference force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalPoint {
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// Mean input power, W.
    pub power_w: f64,
    /// RMS current, A.
    pub current_a: f64,
    /// Reference tangential cutting force (dynamometer), N.
    pub force_ref_n: f64,
}

/// Per-point quantities the fits use.
struct Prepared {
    dp: f64,
    di: f64,
    di2: f64,
    torque: f64,
    cut_power: f64,
}

fn prepare(
    points: &[CalPoint],
    no_load: &NoLoadModel,
    tool_radius_mm: f64,
    method: &'static str,
) -> Result<Vec<Prepared>, SpindleError> {
    let r = tool_radius_mm * 1e-3;
    points
        .iter()
        .map(|p| {
            let nl = no_load.lookup(p.rpm).ok_or_else(|| SpindleError::Fit {
                method,
                reason: format!("no no-load value at {} rpm: learn an air cut first", p.rpm),
            })?;
            let omega = 2.0 * std::f64::consts::PI * p.rpm / 60.0;
            let vals = [p.rpm, p.power_w, p.current_a, p.force_ref_n];
            if vals.iter().any(|v| !v.is_finite()) {
                return Err(SpindleError::Fit {
                    method,
                    reason: format!("non-finite calibration point {p:?}"),
                });
            }
            Ok(Prepared {
                dp: p.power_w - nl.power_w,
                di: p.current_a - nl.current_a,
                di2: p.current_a.powi(2) - nl.current_a.powi(2),
                torque: p.force_ref_n * r,
                cut_power: p.force_ref_n * r * omega,
            })
        })
        .collect()
}

/// Most QR sweeps the least-squares SVD may take; a handful of columns converge in tens.
const SVD_MAX_ITERATIONS: usize = 10_000;

/// Least squares `A·x ≈ b` for the columns given per row; needs more rows than columns
/// and a well-conditioned `A`.
pub(crate) fn least_squares<const K: usize>(
    rows: &[([f64; K], f64)],
    method: &'static str,
) -> Result<[f64; K], SpindleError> {
    if rows.len() < K {
        return Err(SpindleError::Fit {
            method,
            reason: format!("{} points, need at least {K}", rows.len()),
        });
    }
    if let Some(i) = rows
        .iter()
        .position(|(x, y)| !y.is_finite() || x.iter().any(|v| !v.is_finite()))
    {
        return Err(SpindleError::Fit {
            method,
            reason: format!("point {} is not a finite number", i + 1),
        });
    }
    let a = DMatrix::from_fn(rows.len(), K, |i, j| rows[i].0[j]);
    let b = DVector::from_fn(rows.len(), |i, _| rows[i].1);
    // A bounded iteration: nalgebra's `svd()` sets no limit and can loop for ever on
    // pathological matrices (the delay module's companion-matrix QR did, acc-core roots.rs).
    let svd = nalgebra::SVD::try_new(a, true, true, 5.0 * f64::EPSILON, SVD_MAX_ITERATIONS)
        .ok_or_else(|| SpindleError::Fit {
            method,
            reason: format!(
                "the least-squares SVD did not converge in {SVD_MAX_ITERATIONS} iterations"
            ),
        })?;
    let (smax, smin) = svd
        .singular_values
        .iter()
        .fold((0.0f64, f64::INFINITY), |(hi, lo), &s| {
            (hi.max(s), lo.min(s))
        });
    if smin.is_nan() || smin <= 1e-9 * smax {
        return Err(SpindleError::Fit {
            method,
            reason: "the calibration loads do not vary enough (degenerate fit)".into(),
        });
    }
    let x = svd.solve(&b, 0.0).map_err(|e| SpindleError::Fit {
        method,
        reason: e.to_string(),
    })?;
    let mut out = [0.0; K];
    for (o, v) in out.iter_mut().zip(x.iter()) {
        *o = *v;
    }
    Ok(out)
}

/// Fit `g`, `q` of the power method's efficiency correction.
pub fn fit_power_efficiency(
    points: &[CalPoint],
    no_load: &NoLoadModel,
    tool_radius_mm: f64,
) -> Result<PowerEfficiency, SpindleError> {
    const M: &str = "power-efficiency";
    let rows: Vec<([f64; 2], f64)> = prepare(points, no_load, tool_radius_mm, M)?
        .iter()
        .map(|p| ([p.cut_power, p.torque * p.torque], p.dp))
        .collect();
    let [gain, loss_w_per_nm2] = least_squares(&rows, M)?;
    if !(gain > 0.5 && gain < 2.0) {
        return Err(SpindleError::Fit {
            method: M,
            reason: format!("fitted gain {gain} is not a plausible 1/efficiency (0.5, 2)"),
        });
    }
    Ok(PowerEfficiency {
        gain,
        loss_w_per_nm2,
    })
}

/// Fit the conventional torque constant `Kt`.
pub fn fit_current(
    points: &[CalPoint],
    no_load: &NoLoadModel,
    tool_radius_mm: f64,
) -> Result<CurrentConstant, SpindleError> {
    const M: &str = "current";
    let rows: Vec<([f64; 1], f64)> = prepare(points, no_load, tool_radius_mm, M)?
        .iter()
        .map(|p| ([p.di], p.torque))
        .collect();
    let [kt_nm_per_a] = least_squares(&rows, M)?;
    if kt_nm_per_a.is_nan() || kt_nm_per_a <= 0.0 {
        return Err(SpindleError::Fit {
            method: M,
            reason: format!("fitted Kt {kt_nm_per_a} N·m/A is not positive"),
        });
    }
    Ok(CurrentConstant { kt_nm_per_a })
}

/// Fit `a`, `b` of the motor-characteristics method.
pub fn fit_motor_characteristics(
    points: &[CalPoint],
    no_load: &NoLoadModel,
    tool_radius_mm: f64,
) -> Result<MotorCharacteristic, SpindleError> {
    const M: &str = "motor-characteristics";
    let rows: Vec<([f64; 2], f64)> = prepare(points, no_load, tool_radius_mm, M)?
        .iter()
        .map(|p| ([p.torque, p.torque * p.torque], p.di2))
        .collect();
    let [a, b] = least_squares(&rows, M)?;
    if a.is_nan() || a <= 0.0 {
        return Err(SpindleError::Fit {
            method: M,
            reason: format!("fitted a = {a} A²/(N·m) is not positive"),
        });
    }
    Ok(MotorCharacteristic {
        a_a2_per_nm: a,
        b_a2_per_nm2: b,
    })
}

/// Fit every method's constants.
pub fn calibrate(
    points: &[CalPoint],
    no_load: &NoLoadModel,
    tool_radius_mm: f64,
) -> Result<Constants, SpindleError> {
    Ok(Constants {
        power_efficiency: Some(fit_power_efficiency(points, no_load, tool_radius_mm)?),
        current: Some(fit_current(points, no_load, tool_radius_mm)?),
        motor_characteristics: Some(fit_motor_characteristics(points, no_load, tool_radius_mm)?),
    })
}

/// Calibrate from a recording of periods: learn the no-load model from the air-cut
/// periods `air` (`rpm`, `power_w`, `current_a`), then fit every method on the cutting
/// periods `cut` (with their reference force).
pub fn calibrate_recording(
    air: &[(f64, f64, f64)],
    cut: &[CalPoint],
    tool_radius_mm: f64,
    rule: AdaptRule,
    description: impl Into<String>,
) -> Result<SpindleCalibration, SpindleError> {
    let mut nl = NoLoadModel::new(rule);
    for &(rpm, p, i) in air {
        nl.learn(rpm, p, i)?;
    }
    let constants = calibrate(cut, &nl, tool_radius_mm)?;
    Ok(SpindleCalibration::new(
        description,
        tool_radius_mm,
        &nl,
        constants,
    ))
}

/// A calibration file: no-load model, adaptation rule and fitted constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleCalibration {
    /// Free text: motor, machine, how and when it was calibrated.
    #[serde(default)]
    pub description: String,
    /// Tool radius of the calibration cut, mm (the constants are in torque units and do
    /// not depend on it; kept for the record).
    pub tool_radius_mm: f64,
    /// No-load adaptation rule.
    #[serde(default)]
    pub adapt: AdaptRule,
    /// Learned no-load points.
    pub no_load: Vec<NoLoadPoint>,
    /// Fitted constants.
    #[serde(default)]
    pub constants: Constants,
}

impl SpindleCalibration {
    /// Collect a calibration from a learned model and fitted constants.
    pub fn new(
        description: impl Into<String>,
        tool_radius_mm: f64,
        no_load: &NoLoadModel,
        constants: Constants,
    ) -> Self {
        Self {
            description: description.into(),
            tool_radius_mm,
            adapt: *no_load.rule(),
            no_load: no_load.points().collect(),
            constants,
        }
    }

    /// The no-load model of this calibration.
    pub fn no_load_model(&self) -> Result<NoLoadModel, SpindleError> {
        NoLoadModel::from_points(&self.no_load, self.adapt)
    }

    /// An estimator with `cfg` on this calibration (its no-load model, rule and constants).
    pub fn estimator(&self, cfg: EstimatorConfig) -> Result<SpindleEstimator, SpindleError> {
        SpindleEstimator::new(cfg, self.constants, self.no_load_model()?)
    }

    /// Read and validate a calibration file; errors name the file, the key and the range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let cal: Self = acc_config::load_toml(path)?;
        cal.validate(path)?;
        Ok(cal)
    }

    /// Range checks of every value.
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        check_range(file, "tool_radius_mm", self.tool_radius_mm, 0.1, 1000.0)?;
        let a = &self.adapt;
        check_range(file, "adapt.speed_tolerance", a.speed_tolerance, 0.0, 0.5)?;
        check_range(file, "adapt.band_sigma", a.band_sigma, 0.0, 100.0)?;
        check_range(file, "adapt.min_band_frac", a.min_band_frac, 0.0, 1.0)?;
        check_range(file, "adapt.rate", a.rate, 0.0, 1.0)?;
        check_range(file, "adapt.max_drift_frac", a.max_drift_frac, 0.0, 1.0)?;
        check_range(file, "adapt.extrapolate_frac", a.extrapolate_frac, 0.0, 1.0)?;
        if self.no_load.is_empty() {
            return Err(ConfigError::Invalid {
                file: file.to_path_buf(),
                key: "no_load".into(),
                message: "at least one no-load point is required".into(),
            });
        }
        for (k, p) in self.no_load.iter().enumerate() {
            let key = |f: &str| format!("no_load[{k}].{f}");
            check_range(file, &key("rpm"), p.rpm, 1.0, 1e5)?;
            check_range(file, &key("power_w"), p.power_w, 0.0, 1e6)?;
            check_range(file, &key("current_a"), p.current_a, 0.0, 1e4)?;
            check_range(file, &key("sigma_power_w"), p.sigma_power_w, 0.0, 1e6)?;
            check_range(file, &key("sigma_current_a"), p.sigma_current_a, 0.0, 1e4)?;
        }
        let c = &self.constants;
        if let Some(pe) = c.power_efficiency {
            check_range(file, "constants.power_efficiency.gain", pe.gain, 0.5, 2.0)?;
            check_range(
                file,
                "constants.power_efficiency.loss_w_per_nm2",
                pe.loss_w_per_nm2,
                -1e6,
                1e6,
            )?;
        }
        if let Some(cc) = c.current {
            check_range(
                file,
                "constants.current.kt_nm_per_a",
                cc.kt_nm_per_a,
                1e-6,
                1e4,
            )?;
        }
        if let Some(m) = c.motor_characteristics {
            check_range(
                file,
                "constants.motor_characteristics.a_a2_per_nm",
                m.a_a2_per_nm,
                1e-9,
                1e6,
            )?;
            check_range(
                file,
                "constants.motor_characteristics.b_a2_per_nm2",
                m.b_a2_per_nm2,
                -1e6,
                1e6,
            )?;
        }
        self.no_load_model().map_err(|e| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: "no_load".into(),
            message: e.to_string(),
        })?;
        Ok(())
    }

    /// Write as TOML.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), ConfigError> {
        let path = path.as_ref();
        let text = toml::to_string_pretty(self).map_err(|e| ConfigError::Invalid {
            file: path.to_path_buf(),
            key: String::new(),
            message: e.to_string(),
        })?;
        std::fs::write(path, text).map_err(|e| ConfigError::Io {
            file: path.to_path_buf(),
            reason: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic motor that follows the model exactly: the fits must recover it.
    fn synthetic() -> (Vec<CalPoint>, NoLoadModel) {
        let mut nl = NoLoadModel::new(AdaptRule::default());
        nl.learn(1100.0, 500.0, 20.0).unwrap();
        let r = 0.04;
        let omega = 2.0 * std::f64::consts::PI * 1100.0 / 60.0;
        let pts = [50.0, 100.0, 150.0, 200.0]
            .iter()
            .map(|&f: &f64| {
                let t = f * r;
                // ΔP = 1.02·ω·T + 3·T² (copper losses ∝ T²).
                let dp = 1.02 * omega * t + 3.0 * t * t;
                let i = (400.0 + 3.0 * t + 0.5 * t * t).sqrt();
                CalPoint {
                    rpm: 1100.0,
                    power_w: 500.0 + dp,
                    current_a: i,
                    force_ref_n: f,
                }
            })
            .collect();
        (pts, nl)
    }

    #[test]
    fn a_non_finite_point_is_refused_by_number_not_iterated_on() {
        let rows = [([1.0, 0.0], 1.0), ([0.0, 1.0], 2.0), ([1.0, f64::NAN], 3.0)];
        let e = least_squares(&rows, "test").unwrap_err().to_string();
        assert!(e.contains("point 3 is not a finite number"), "{e}");
        let x = least_squares(&rows[..2], "test").unwrap();
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn fits_recover_the_model() {
        let (pts, nl) = synthetic();
        let c = calibrate(&pts, &nl, 40.0).unwrap();
        let pe = c.power_efficiency.unwrap();
        assert!((pe.gain - 1.02).abs() < 1e-9 && (pe.loss_w_per_nm2 - 3.0).abs() < 1e-9);
        let omega = 2.0 * std::f64::consts::PI * 1500.0 / 60.0;
        let dp = 1.02 * omega * 6.0 + 3.0 * 36.0;
        assert!((pe.torque_nm(dp, omega) - 6.0).abs() < 1e-9);
        let m = c.motor_characteristics.unwrap();
        assert!((m.a_a2_per_nm - 3.0).abs() < 1e-9 && (m.b_a2_per_nm2 - 0.5).abs() < 1e-9);
        assert!((m.torque_nm(3.0 * 4.0 + 0.5 * 16.0) - 4.0).abs() < 1e-12);
        assert!(c.current.unwrap().kt_nm_per_a > 0.0);
    }

    #[test]
    fn degenerate_calibration_is_an_error() {
        let (pts, nl) = synthetic();
        let same = vec![pts[0]; 4];
        let e = fit_power_efficiency(&same, &nl, 40.0).unwrap_err();
        assert!(e.to_string().contains("do not vary enough"), "{e}");
        let e = fit_current(&[], &nl, 40.0).unwrap_err();
        assert!(e.to_string().contains("need at least 1"), "{e}");
        let mut far = pts.clone();
        far[0].rpm = 3000.0;
        let e = calibrate(&far, &nl, 40.0).unwrap_err();
        assert!(e.to_string().contains("3000 rpm"), "{e}");
    }

    #[test]
    fn toml_round_trip_and_errors_name_the_key() {
        let (pts, nl) = synthetic();
        let c = calibrate(&pts, &nl, 40.0).unwrap();
        let cal = SpindleCalibration::new("test", 40.0, &nl, c);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cal.toml");
        cal.save(&path).unwrap();
        let back = SpindleCalibration::load(&path).unwrap();
        assert_eq!(back, cal);
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("rpm = 1100.0", "rpm = -5.0");
        std::fs::write(&path, text).unwrap();
        let e = SpindleCalibration::load(&path).unwrap_err().to_string();
        assert!(
            e.contains("no_load[0].rpm") && e.contains("cal.toml"),
            "{e}"
        );
        std::fs::write(&path, "tool_radius_mm = 40.0\nno_load = []\nbogus = 1\n").unwrap();
        let e = SpindleCalibration::load(&path).unwrap_err().to_string();
        assert!(e.contains("bogus"), "{e}");
    }
}
