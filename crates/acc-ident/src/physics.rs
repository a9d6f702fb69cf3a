//! The nominal physics the replay uses, taken from the simulator (`acc-sim`) so that the
//! discrepancy workflow compares against the simulated machine, not a second copy.
//!
//! Seed 002 eq. (1): `F = Ks·ks_factor·a_p·d^α·f^β·s^γ`, `Ks` from the calibration point;
//! seed 004: cutting torque `T = R·F/√(1 + r1²)`; seed 000 (physics.md §2): spindle input
//! power `P = P_air + ω·T / η`.

use crate::model::{Process, Spindle};

/// `Ks` solved from the calibration point (seed 002 eq. 1), N / (mm·mm^α·(mm/min)^β·rpm^γ).
pub fn ks(p: &Process) -> f64 {
    p.calib_force_n
        / (p.calib_axial_mm
            * p.calib_radial_mm.powf(p.alpha)
            * p.calib_feed_mm_min.powf(p.beta)
            * p.calib_rpm.powf(p.gamma))
}

/// Mean resultant cutting force, N (seed 002 eq. 1); 0 without engagement, feed or speed.
pub fn mean_force_n(
    p: &Process,
    ks: f64,
    radial_mm: f64,
    axial_mm: f64,
    feed_mm_min: f64,
    rpm: f64,
    ks_factor: f64,
) -> f64 {
    if radial_mm <= 0.0 || axial_mm <= 0.0 || feed_mm_min <= 0.0 || rpm <= 0.0 {
        return 0.0;
    }
    ks * ks_factor
        * axial_mm
        * radial_mm.powf(p.alpha)
        * feed_mm_min.powf(p.beta)
        * rpm.powf(p.gamma)
}

/// Cutting torque, N·m (seed 004): `T = R·F/√(1 + r1²)`.
pub fn torque_nm(p: &Process, force_n: f64, radius_mm: f64) -> f64 {
    radius_mm * 1e-3 * force_n / (1.0 + p.radial_ratio.powi(2)).sqrt()
}

/// Cutting power at the spindle shaft, W: `ω·T`.
pub fn cut_power_w(p: &Process, force_n: f64, radius_mm: f64, rpm: f64) -> f64 {
    rpm * 2.0 * std::f64::consts::PI / 60.0 * torque_nm(p, force_n, radius_mm)
}

/// Spindle input power, W (physics.md §2): `P_air + P_cut / η` while the spindle turns.
pub fn input_power_w(s: &Spindle, cut_power_w: f64, rpm: f64) -> f64 {
    if rpm > 0.0 {
        s.no_load_power_w + cut_power_w / s.efficiency
    } else {
        0.0
    }
}
