//! Cutting-force estimators from spindle power or current (seed 000, physics.md §2).
//!
//! All four give the mean **tangential** cutting force `F = T_c / r` at the tool radius
//! `r` from the cutting torque `T_c`, with the no-load part removed first:
//!
//! | [`Method`] | equation |
//! | --- | --- |
//! | `Power` | `F = (P − P_air) / (ω·r)` — seed 000 eq. 14, no fitted constant |
//! | `PowerEfficiency` | `ΔP = P − P_air = a·ω·T_c + c·T_c²`, solved for `T_c`; `F = T_c / r`: eq. 14 with a load-dependent efficiency `η = 1/(a + c·T_c/ω)` (seed 000 §2.2, Fig. 4: η changes with load; the `c·T²` term is the copper loss ∝ I²) |
//! | `Current` | `F = Kt·(I − I_air) / r` — seed 000 eq. 6, conventional |
//! | `MotorCharacteristics` | `I² − I_air² = a·T_c + b·T_c²`, solved for `T_c`; `F = T_c / r` — seed 000 method 2 *(reconstructed, see below)* |
//!
//! `ω` is the spindle angular speed `2π·n/60` (rad/s), `P` the Blondel input power,
//! `I` the three-phase RMS current.
//!
//! **Method 2, reconstructed.** Seed 000 eqs. 7–11 were lost from its text. The idea it
//! states: in the stable region torque ∝ slip (eq. 7) and the rotor current is
//! `I_r = sE/√(R² + (sX)²)` (eq. 3), so the rotor current grows with torque; the stator
//! current is the phasor sum of that rotor current and the no-load current, which is
//! mostly magnetising (in quadrature) plus an iron-loss part (in phase). Then
//! `|I|² = I_air² + 2·I_fe·I_r + I_r²(1 + …)` with `I_r ∝ T_c`: a quadratic in the cutting
//! torque, `I² − I_air² = a·T_c + b·T_c²`, with the motor constants lumped into `a` and `b`
//! (fitted by `acc_spindle::calibrate`). Subtracting `I_air` linearly, as the conventional
//! method does, ignores the quadrature and is why its `Kt` drifts with load (seed 000
//! Table 2).
//!
//! # Validity
//! A period gives [`Invalid`] — never a force — when: the spindle is stopped or slower than
//! `min_rpm`; the speed changed by more than `max_speed_change` since the last period
//! (acceleration power is not cutting power); an input the method needs is missing or not
//! finite; the input power is negative (regeneration, swapped channels); the no-load model
//! does not cover the speed; or the load is implausibly negative (`ΔP` below
//! `−negative_sigma·σ` and below −5 % of `P_air`: a sensor or model fault).

use serde::{Deserialize, Serialize};

use super::constants::Constants;
use super::noload::{AdaptOutcome, NoLoad, NoLoadModel};
use super::SpindleError;
use crate::RangeError;

/// Which estimator turns power/current into force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// `F = (P − P_air)/(ω·r)` (seed 000 eq. 14).
    Power,
    /// Eq. 14 with a load-dependent efficiency correction.
    PowerEfficiency,
    /// `F = Kt·(I − I_air)/r` (seed 000 eq. 6).
    Current,
    /// Torque–slip relation on the stator current (seed 000 method 2, reconstructed).
    MotorCharacteristics,
}

impl Method {
    /// All methods, in the order of the tables.
    pub const ALL: [Method; 4] = [
        Method::Current,
        Method::MotorCharacteristics,
        Method::Power,
        Method::PowerEfficiency,
    ];

    /// The name used in configuration files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Method::Power => "power",
            Method::PowerEfficiency => "power-efficiency",
            Method::Current => "current",
            Method::MotorCharacteristics => "motor-characteristics",
        }
    }

    /// `true` for the methods that need the input power.
    pub fn needs_power(self) -> bool {
        matches!(self, Method::Power | Method::PowerEfficiency)
    }
}

/// How the no-load part is handled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NoLoadMode {
    /// Nothing is subtracted (`P_air = I_air = 0`): for comparison only.
    Off,
    /// The learned model, never adapted while running.
    Fixed,
    /// The learned model, adapted while running ([`super::noload`] rule).
    Adaptive,
}

/// Estimator settings. TOML keys are the field names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Estimator. Default `power-efficiency`.
    pub method: Method,
    /// Tool radius `r` at which the tangential force acts, mm. Default 40 (face cutter
    /// Ø80 of seed 000).
    pub tool_radius_mm: f64,
    /// No-load handling. Default `adaptive`.
    pub no_load: NoLoadMode,
    /// Noise floor as a multiple of the air-cut σ, −. Default 3.
    pub noise_floor_sigma: f64,
    /// Largest relative speed change per period still treated as steady, −. Default 0.02.
    pub max_speed_change: f64,
    /// Lowest speed at which an estimate is made, rpm. Default 50.
    pub min_rpm: f64,
    /// A load below `−negative_sigma·σ` (and below −5 % of `P_air`) is a fault, −.
    /// Default 6.
    pub negative_sigma: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            method: Method::PowerEfficiency,
            tool_radius_mm: 40.0,
            no_load: NoLoadMode::Adaptive,
            noise_floor_sigma: 3.0,
            max_speed_change: 0.02,
            min_rpm: 50.0,
            negative_sigma: 6.0,
        }
    }
}

impl EstimatorConfig {
    /// Range checks; the error names the key and the allowed range.
    pub fn validate(&self) -> Result<(), SpindleError> {
        let checks: [(&'static str, f64, f64, f64, &'static str); 5] = [
            (
                "tool_radius_mm",
                self.tool_radius_mm,
                0.1,
                1000.0,
                "0.1 ..= 1000",
            ),
            (
                "noise_floor_sigma",
                self.noise_floor_sigma,
                0.0,
                100.0,
                "0 ..= 100",
            ),
            (
                "max_speed_change",
                self.max_speed_change,
                0.0,
                1.0,
                "0 ..= 1",
            ),
            ("min_rpm", self.min_rpm, 0.0, 1e6, "0 ..= 1e6"),
            (
                "negative_sigma",
                self.negative_sigma,
                0.0,
                1e3,
                "0 ..= 1000",
            ),
        ];
        for (key, value, lo, hi, allowed) in checks {
            if !(value.is_finite() && value >= lo && value <= hi) {
                return Err(SpindleError::OutOfRange(RangeError::new(
                    key, value, allowed,
                )));
            }
        }
        Ok(())
    }
}

/// Why a period gave no force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Invalid {
    /// Speed below `min_rpm` or not finite.
    SpindleStopped,
    /// Speed changed by more than `max_speed_change` since the last period.
    SpeedTransient,
    /// The method needs the input power but none was given.
    MissingPower,
    /// The method needs the RMS current but none was given.
    MissingCurrent,
    /// An input is NaN or infinite.
    NonFinite,
    /// The input power is negative.
    NegativePower,
    /// The no-load model does not cover this speed.
    NoLoadUnknown,
    /// The method's constants were never calibrated.
    NotCalibrated,
    /// The load is implausibly negative.
    ImplausibleLoad,
    /// The block has the wrong number of channels or samples.
    BadBlock,
    /// The sample stream ended or broke mid-period.
    Truncated,
}

impl Invalid {
    /// Short text for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Invalid::SpindleStopped => "spindle stopped",
            Invalid::SpeedTransient => "speed transient",
            Invalid::MissingPower => "no power input",
            Invalid::MissingCurrent => "no current input",
            Invalid::NonFinite => "non-finite input",
            Invalid::NegativePower => "negative power",
            Invalid::NoLoadUnknown => "no-load model does not cover this speed",
            Invalid::NotCalibrated => "method not calibrated",
            Invalid::ImplausibleLoad => "implausible negative load",
            Invalid::BadBlock => "bad sample block",
            Invalid::Truncated => "truncated sample stream",
        }
    }
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A force estimate for one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Tangential cutting force `F`, N (may be slightly negative within the noise floor).
    pub force_n: f64,
    /// Cutting torque `T_c = F·r`, N·m.
    pub torque_nm: f64,
    /// Input power, W, if known.
    pub power_w: Option<f64>,
    /// No-load power subtracted, W (0 with the model off).
    pub no_load_power_w: f64,
    /// Noise floor of `force_n`, N: `noise_floor_sigma` × the air-cut σ mapped to force.
    pub noise_floor_n: f64,
    /// `force_n > noise_floor_n`: a measurable cutting load.
    pub above_floor: bool,
    /// What the no-load adaptation did with this period.
    pub adapt: AdaptOutcome,
}

/// The estimator: configuration, calibrated constants, no-load model, speed history.
#[derive(Debug, Clone)]
pub struct SpindleEstimator {
    cfg: EstimatorConfig,
    constants: Constants,
    no_load: NoLoadModel,
    last_rpm: f64,
}

impl SpindleEstimator {
    /// Build; checks the configuration and that the method's constants are calibrated.
    pub fn new(
        cfg: EstimatorConfig,
        constants: Constants,
        mut no_load: NoLoadModel,
    ) -> Result<Self, SpindleError> {
        cfg.validate()?;
        if constants.for_method(cfg.method).is_none() {
            return Err(SpindleError::Fit {
                method: cfg.method.name(),
                reason: "the calibration has no constants for this method".into(),
            });
        }
        no_load.set_adapt(cfg.no_load == NoLoadMode::Adaptive && no_load.rule().enabled);
        Ok(Self {
            cfg,
            constants,
            no_load,
            last_rpm: f64::NAN,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EstimatorConfig {
        &self.cfg
    }

    /// The no-load model (with any adaptation so far).
    pub fn no_load(&self) -> &NoLoadModel {
        &self.no_load
    }

    /// Mutable no-load model: e.g. to [`NoLoadModel::learn`] a known air cut.
    pub fn no_load_mut(&mut self) -> &mut NoLoadModel {
        &mut self.no_load
    }

    /// The calibrated constants.
    pub fn constants(&self) -> &Constants {
        &self.constants
    }

    /// Estimate the period's force from the speed (rpm), the mean input power (W) and the
    /// RMS current (A); give what the installation has, the method says what it needs.
    pub fn estimate(
        &mut self,
        rpm: f64,
        power_w: Option<f64>,
        current_a: Option<f64>,
    ) -> Result<Estimate, Invalid> {
        let last = self.last_rpm;
        self.last_rpm = rpm;
        if !rpm.is_finite() || rpm < self.cfg.min_rpm.max(f64::MIN_POSITIVE) {
            return Err(Invalid::SpindleStopped);
        }
        if last.is_finite() && (rpm - last).abs() > self.cfg.max_speed_change * rpm {
            return Err(Invalid::SpeedTransient);
        }
        let method = self.cfg.method;
        if power_w.is_some_and(|p| !p.is_finite()) || current_a.is_some_and(|i| !i.is_finite()) {
            return Err(Invalid::NonFinite);
        }
        if power_w.is_some_and(|p| p < 0.0) {
            return Err(Invalid::NegativePower);
        }
        if current_a.is_some_and(|i| i < 0.0) {
            return Err(Invalid::NonFinite);
        }
        let p = match (method.needs_power(), power_w) {
            (true, None) => return Err(Invalid::MissingPower),
            (_, p) => p,
        };
        let i = match (method.needs_power(), current_a) {
            (false, None) => return Err(Invalid::MissingCurrent),
            (_, i) => i,
        };
        let nl = match self.cfg.no_load {
            NoLoadMode::Off => NoLoad {
                power_w: 0.0,
                current_a: 0.0,
                sigma_power_w: 0.0,
                sigma_current_a: 0.0,
                extrapolated: false,
            },
            _ => self.no_load.lookup(rpm).ok_or(Invalid::NoLoadUnknown)?,
        };
        let omega = 2.0 * std::f64::consts::PI * rpm / 60.0;
        let r_m = self.cfg.tool_radius_mm * 1e-3;
        let k = self.cfg.noise_floor_sigma;
        let c = &self.constants;
        // Cutting torque and its noise floor (torque units), per method.
        let (torque_nm, floor_nm) = match method {
            Method::Power | Method::PowerEfficiency => {
                let p = p.ok_or(Invalid::MissingPower)?;
                let dp = p - nl.power_w;
                let limit = (self.cfg.negative_sigma * nl.sigma_power_w).max(0.05 * nl.power_w);
                if dp < -limit {
                    return Err(Invalid::ImplausibleLoad);
                }
                if method == Method::Power {
                    (dp / omega, k * nl.sigma_power_w / omega)
                } else {
                    let pe = c.power_efficiency.ok_or(Invalid::NotCalibrated)?;
                    (
                        pe.torque_nm(dp, omega),
                        k * nl.sigma_power_w / (pe.gain * omega),
                    )
                }
            }
            Method::Current => {
                let i = i.ok_or(Invalid::MissingCurrent)?;
                let kt = c.current.ok_or(Invalid::NotCalibrated)?.kt_nm_per_a;
                let di = i - nl.current_a;
                if di < -(self.cfg.negative_sigma * nl.sigma_current_a).max(0.05 * nl.current_a) {
                    return Err(Invalid::ImplausibleLoad);
                }
                (kt * di, k * kt * nl.sigma_current_a)
            }
            Method::MotorCharacteristics => {
                let i = i.ok_or(Invalid::MissingCurrent)?;
                let m = c.motor_characteristics.ok_or(Invalid::NotCalibrated)?;
                let d = i * i - nl.current_a * nl.current_a;
                let sigma_d = 2.0 * nl.current_a * nl.sigma_current_a;
                let limit = (self.cfg.negative_sigma * sigma_d).max(0.1 * nl.current_a.powi(2));
                if d < -limit {
                    return Err(Invalid::ImplausibleLoad);
                }
                (m.torque_nm(d), k * sigma_d / m.a_a2_per_nm)
            }
        };
        let adapt = match (self.cfg.no_load, p) {
            (NoLoadMode::Adaptive, Some(p)) => self.no_load.observe(rpm, p, i.unwrap_or(f64::NAN)),
            _ => AdaptOutcome::Disabled,
        };
        let force_n = torque_nm / r_m;
        let noise_floor_n = floor_nm / r_m;
        Ok(Estimate {
            force_n,
            torque_nm,
            power_w: p,
            no_load_power_w: nl.power_w,
            noise_floor_n,
            above_floor: force_n > noise_floor_n,
            adapt,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spindle_force::constants::{CurrentConstant, MotorCharacteristic, PowerEfficiency};
    use crate::spindle_force::noload::AdaptRule;

    fn est(method: Method) -> SpindleEstimator {
        let mut nl = NoLoadModel::new(AdaptRule::default());
        nl.learn(1500.0, 600.0, 25.0).unwrap();
        nl.learn(1500.0, 610.0, 25.1).unwrap();
        let c = Constants {
            power_efficiency: Some(PowerEfficiency {
                gain: 1.0 / 0.9,
                loss_w_per_nm2: 0.0,
            }),
            current: Some(CurrentConstant { kt_nm_per_a: 2.0 }),
            motor_characteristics: Some(MotorCharacteristic {
                a_a2_per_nm: 5.0,
                b_a2_per_nm2: 0.0,
            }),
        };
        let cfg = EstimatorConfig {
            method,
            tool_radius_mm: 40.0,
            no_load: NoLoadMode::Fixed,
            ..Default::default()
        };
        SpindleEstimator::new(cfg, c, nl).unwrap()
    }

    #[test]
    fn each_method_uses_its_equation() {
        let w = 2.0 * std::f64::consts::PI * 25.0;
        let f = est(Method::Power)
            .estimate(1500.0, Some(1605.0), Some(26.0))
            .unwrap()
            .force_n;
        assert!((f - 1000.0 / w / 0.04).abs() < 1e-9);
        let f = est(Method::PowerEfficiency)
            .estimate(1500.0, Some(1605.0), None)
            .unwrap()
            .force_n;
        assert!((f - 900.0 / w / 0.04).abs() < 1e-9);
        let f = est(Method::Current)
            .estimate(1500.0, None, Some(26.05))
            .unwrap()
            .force_n;
        assert!((f - 2.0 * 1.0 / 0.04).abs() < 1e-9);
        let i: f64 = (25.05f64.powi(2) + 50.0).sqrt();
        let f = est(Method::MotorCharacteristics)
            .estimate(1500.0, None, Some(i))
            .unwrap()
            .force_n;
        assert!((f - 10.0 / 0.04).abs() < 1e-9);
    }

    #[test]
    fn garbage_is_invalid() {
        let mut e = est(Method::Power);
        assert_eq!(
            e.estimate(1500.0, Some(f64::NAN), None),
            Err(Invalid::NonFinite)
        );
        assert_eq!(
            e.estimate(1500.0, Some(-50.0), None),
            Err(Invalid::NegativePower)
        );
        assert_eq!(
            e.estimate(1500.0, None, Some(3.0)),
            Err(Invalid::MissingPower)
        );
        assert_eq!(
            e.estimate(1500.0, Some(100.0), None),
            Err(Invalid::ImplausibleLoad)
        );
        assert_eq!(
            e.estimate(0.0, Some(700.0), None),
            Err(Invalid::SpindleStopped)
        );
        assert_eq!(
            e.estimate(3000.0, Some(700.0), None),
            Err(Invalid::SpeedTransient)
        );
        assert_eq!(
            e.estimate(3000.0, Some(700.0), None),
            Err(Invalid::NoLoadUnknown)
        );
        let mut e = est(Method::Current);
        assert_eq!(
            e.estimate(1500.0, Some(700.0), None),
            Err(Invalid::MissingCurrent)
        );
    }
}
