//! The nominal physics of the replay, taken from the simulator (`acc-sim`) so that the
//! discrepancy workflow compares against the simulated machine, not a second copy:
//! [`acc_sim::process::ForceLaw`] (seed 002 eq. (1), `F = Ks·ks_factor·a_p·d^α·f^β·s^γ`
//! with `Ks` from the calibration point; seed 004 torque `T = R·F/√(1 + r1²)`) and
//! [`acc_sim::config::SpindleSpec::input_power_w`] (input power
//! `P = P_air(t) + T·ω/η + c·(T·ω)²/1000`, physics.md §2, the drift and load-dependent
//! losses of the machine file's `spindle.noload_drift` / `spindle.motor_efficiency`).

use acc_sim::config::SpindleSpec;
use acc_sim::process::{ForceLaw, ProcessSpec};

/// The simulator's force law for a model's `[tool.process]`.
pub fn force_law(p: &ProcessSpec) -> ForceLaw {
    ForceLaw::new(*p)
}

/// Spindle input power, W, for a cutting torque at a logged speed, `t_s` after spindle
/// start: the simulator's spindle power law ([`SpindleSpec::input_power_w`]); 0 with the
/// spindle stopped.
pub fn input_power_w(s: &SpindleSpec, torque_nm: f64, rpm: f64, t_s: f64) -> f64 {
    s.input_power_w(torque_nm, rpm, t_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calibration_point_gives_the_calibration_force() {
        let p = ProcessSpec::paper();
        let law = force_law(&p);
        assert!((law.mean_force_n(2.0, 16.0, 200.0, 600.0, 1.0) - 800.0).abs() < 1e-9);
        let s = SpindleSpec::new(600.0, 700.0, 0.8);
        // 1 N·m at 600 rpm: 62.83 W of cutting power, 78.54 W of input at η = 0.8.
        assert!((input_power_w(&s, 1.0, 600.0, 10.0) - 700.0 - 78.539_816).abs() < 1e-5);
        assert_eq!(input_power_w(&s, 1.0, 0.0, 10.0), 0.0);
    }
}
