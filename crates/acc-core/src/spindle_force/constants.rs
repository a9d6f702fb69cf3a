//! The calibrated constants of the force estimators (seed 000, physics.md §2): what
//! [`super::estimate::SpindleEstimator`] needs every period. Fitting them from a calibration
//! cut, and the calibration file, are `acc_spindle::calibrate`.

use serde::{Deserialize, Serialize};

use super::estimate::Method;

/// Load-dependent efficiency of the power method: the extra input power of a cut is
/// `ΔP = a·ω·T_c + c·T_c²` — the cutting power over a light-load efficiency `1/a`, plus the
/// load losses that grow with the square of the torque (stator and rotor copper ∝ I² ∝ T²
/// at constant flux), independent of speed. The efficiency `ω·T_c/ΔP = 1/(a + c·T_c/ω)`
/// therefore changes with load (seed 000 §2.2, Fig. 4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowerEfficiency {
    /// `a`: input power per unit of cutting power at light load, − (≈ 1).
    pub gain: f64,
    /// `c`: load losses per squared cutting torque, W/(N·m)².
    pub loss_w_per_nm2: f64,
}

impl PowerEfficiency {
    /// Cutting torque from `ΔP` (W) at `ω` (rad/s): the root of `c·T² + a·ω·T − ΔP = 0`
    /// that is 0 at `ΔP = 0`, `T = 2ΔP / (a·ω + √((a·ω)² + 4c·ΔP))`.
    pub fn torque_nm(&self, dp_w: f64, omega: f64) -> f64 {
        let aw = self.gain * omega;
        let disc = (aw * aw + 4.0 * self.loss_w_per_nm2 * dp_w).max(0.0);
        2.0 * dp_w / (aw + disc.sqrt())
    }
}

/// Conventional torque constant (seed 000 eq. 6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurrentConstant {
    /// `Kt`, N·m/A.
    pub kt_nm_per_a: f64,
}

/// Motor characteristics (seed 000 method 2, reconstructed): `I² − I_air² = a·T + b·T²`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorCharacteristic {
    /// `a`, A²/(N·m).
    pub a_a2_per_nm: f64,
    /// `b`, A²/(N·m)².
    pub b_a2_per_nm2: f64,
}

impl MotorCharacteristic {
    /// Cutting torque from `d = I² − I_air²` (A²): the root of `b·T² + a·T − d = 0` that is
    /// 0 at `d = 0`, in the cancellation-free form `T = 2d / (a + √(a² + 4bd))`.
    pub fn torque_nm(&self, d: f64) -> f64 {
        let a = self.a_a2_per_nm;
        let disc = (a * a + 4.0 * self.b_a2_per_nm2 * d).max(0.0);
        2.0 * d / (a + disc.sqrt())
    }
}

/// All fitted constants (`None`: that method was not calibrated).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constants {
    /// Power method with efficiency correction.
    #[serde(default)]
    pub power_efficiency: Option<PowerEfficiency>,
    /// Conventional current method.
    #[serde(default)]
    pub current: Option<CurrentConstant>,
    /// Current method with motor characteristics.
    #[serde(default)]
    pub motor_characteristics: Option<MotorCharacteristic>,
}

impl Constants {
    /// `Some(())` if `method` can run with these constants (plain power always can).
    pub fn for_method(&self, method: Method) -> Option<()> {
        match method {
            Method::Power => Some(()),
            Method::PowerEfficiency => self.power_efficiency.map(|_| ()),
            Method::Current => self.current.map(|_| ()),
            Method::MotorCharacteristics => self.motor_characteristics.map(|_| ()),
        }
    }
}
