//! The parameters of each candidate effect: keys, units, bounds, null values, fit
//! scales and the grids the fit starts from ([`ParamInfo`], one table per effect).

use acc_sim::config::{MotorEfficiency, NoloadDrift, Runout, SensorLowpass};
use acc_sim::process::WearSpec;

use super::ParamInfo;

pub(super) const TAU_GRID: &[f64] = &[0.0, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.4, 0.55, 0.7, 0.85];
pub(super) const DELAY_GRID: &[f64] = &[0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8];
pub(super) const PHASE_GRID: &[f64] = &[
    0.0,
    std::f64::consts::FRAC_PI_4,
    std::f64::consts::FRAC_PI_2,
    3.0 * std::f64::consts::FRAC_PI_4,
    std::f64::consts::PI,
    5.0 * std::f64::consts::FRAC_PI_4,
    3.0 * std::f64::consts::FRAC_PI_2,
    7.0 * std::f64::consts::FRAC_PI_4,
];
pub(super) const MEAS_DELAY_GRID: &[f64] = &[0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.45, 0.6, 0.8];
pub(super) const P_GAIN_DRIFT: [ParamInfo; 1] =
    [p("gain_per_min", "1/min", -0.5, 0.5, 0.002, None)];
pub(super) const P_MEAS_DELAY: [ParamInfo; 1] =
    [p("delay_s", "s", 0.0, 1.5, 0.02, Some(MEAS_DELAY_GRID))];
pub(super) const P_DEPTH_EXP: [ParamInfo; 1] = [p("delta_alpha", "1", -0.5, 0.5, 0.02, None)];
/// Boundary of a [`KsStep`] as a fraction of the cut path (see [`KsStep::boundary_frac`]).
pub(super) const KS_BOUNDARY_GRID: &[f64] = &[
    0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85,
    0.9, 0.95,
];
pub(super) const P_KS_STEP: [ParamInfo; 2] = [
    p("delta", "1", -0.6, 1.5, 0.02, None),
    ParamInfo {
        null: 0.5,
        ..p(
            "boundary_frac",
            "1",
            0.01,
            0.99,
            0.005,
            Some(KS_BOUNDARY_GRID),
        )
    },
];
/// Coarse grid of the second lag (each point is a full plant replay); LM refines.
pub(super) const TAU2_GRID: &[f64] = &[0.0, 0.05, 0.12, 0.25, 0.45];
pub(super) const P_TAU2: [ParamInfo; 1] = [p("tau2_s", "s", 0.0, 0.99, 0.02, Some(TAU2_GRID))];
/// Coarse grid of the inverse acceleration `1000/a` (a in mm/s²: ∞, 1000, 200, 100, 50,
/// 25, 12.5, 6.7 mm/s²); each point is a full plant replay, LM refines.
pub(super) const INV_ACCEL_GRID: &[f64] = &[0.0, 1.0, 5.0, 10.0, 20.0, 40.0, 80.0, 150.0];
pub(super) const P_ACCEL: [ParamInfo; 1] = [p(
    "inverse_accel_s2_per_m",
    "s²/m",
    0.0,
    200.0,
    0.5,
    Some(INV_ACCEL_GRID),
)];
pub(super) const THERMAL_GRID: &[f64] = &[20.0, 40.0, 80.0, 150.0, 300.0, 600.0, 1200.0, 2400.0];

pub(super) const fn p(
    key: &'static str,
    unit: &'static str,
    lo: f64,
    hi: f64,
    scale: f64,
    grid: Option<&'static [f64]>,
) -> ParamInfo {
    ParamInfo {
        key,
        unit,
        lo,
        hi,
        null: 0.0,
        scale,
        grid,
        fitted: true,
    }
}

pub(super) const WEAR_EXPONENT_GRID: &[f64] = &[0.5, 1.0, 2.0];
pub(super) const P_TOOL_WEAR: [ParamInfo; 2] = [
    p("ks_growth_per_cm3", "1/cm³", -0.5, 10.0, 0.002, None),
    ParamInfo {
        null: 1.0,
        ..p(
            "volume_exponent",
            "1",
            WearSpec::VOLUME_EXPONENT_RANGE.0,
            WearSpec::VOLUME_EXPONENT_RANGE.1,
            0.05,
            Some(WEAR_EXPONENT_GRID),
        )
    },
];
pub(super) const P_MOTOR: [ParamInfo; 1] = [p(
    "copper_loss_per_kw",
    "1/kW",
    MotorEfficiency::COPPER_LOSS_RANGE.0,
    MotorEfficiency::COPPER_LOSS_RANGE.1,
    0.02,
    None,
)];
pub(super) const P_LAG: [ParamInfo; 1] = [p("extra_tau_s", "s", 0.0, 0.99, 0.05, Some(TAU_GRID))];
pub(super) const P_LOWPASS: [ParamInfo; 1] = [p(
    "tau_s",
    "s",
    SensorLowpass::TAU_S_RANGE.0,
    SensorLowpass::TAU_S_RANGE.1,
    0.05,
    Some(TAU_GRID),
)];
pub(super) const P_DEAD: [ParamInfo; 1] =
    [p("extra_delay_s", "s", 0.0, 0.99, 0.05, Some(DELAY_GRID))];
pub(super) const P_BETA: [ParamInfo; 2] = [
    p("delta_beta", "1", -0.85, 0.9, 0.02, None),
    ParamInfo {
        fitted: false,
        ..p("feed_ref_mm_min", "mm/min", 1e-3, 1e6, 1.0, None)
    },
];
pub(super) const P_RUNOUT: [ParamInfo; 2] = [
    p(
        "amplitude",
        "1",
        Runout::AMPLITUDE_RANGE.0,
        Runout::AMPLITUDE_RANGE.1,
        0.01,
        None,
    ),
    p(
        "phase_rad",
        "rad",
        Runout::PHASE_RAD_RANGE.0,
        Runout::PHASE_RAD_RANGE.1,
        0.1,
        Some(PHASE_GRID),
    ),
];
pub(super) const P_DRIFT: [ParamInfo; 2] = [
    p(
        "delta_w",
        "W",
        NoloadDrift::DELTA_W_RANGE.0,
        NoloadDrift::DELTA_W_RANGE.1,
        5.0,
        None,
    ),
    p(
        "tau_s",
        "s",
        NoloadDrift::TAU_S_RANGE.0,
        NoloadDrift::TAU_S_RANGE.1,
        10.0,
        Some(THERMAL_GRID),
    ),
];
