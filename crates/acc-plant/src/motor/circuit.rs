//! The steady-state equivalent circuit (seed 000 §2.2): one operating point per load
//! ([`Motor::operating_point`]), and the loss and drift effects on it ([`MotorEffects`]).

use std::f64::consts::PI;

use super::config::MotorConfig;
use crate::config::{MotorEfficiency, NoloadDrift, SpindleSpec};

/// Phasors of one operating point.
type Cx = num_complex::Complex64;

/// Steady state of the motor at one speed and load.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OperatingPoint {
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// Cutting torque, N·m.
    pub cut_torque_nm: f64,
    /// Friction and windage torque (including the drift torque), N·m.
    pub friction_torque_nm: f64,
    /// Slip `s = (N_s − N)/N_s` (seed 000 eq. 2).
    pub slip: f64,
    /// Electrical frequency `f_e`, Hz.
    pub freq_hz: f64,
    /// RMS line voltage at the terminals, V.
    pub line_voltage_v: f64,
    /// RMS phase current, A.
    pub current_a: f64,
    /// Power factor (seed 000 eq. 1).
    pub power_factor: f64,
    /// Input power, W.
    pub input_w: f64,
    /// Stator copper loss, W.
    pub stator_copper_w: f64,
    /// Iron loss, W.
    pub iron_w: f64,
    /// Rotor copper loss, W.
    pub rotor_copper_w: f64,
    /// Friction and windage loss, W (including the drift [`OperatingPoint::drift_w`]).
    pub friction_w: f64,
    /// Share of `friction_w` from the thermal no-load drift (`[spindle.noload_drift]`), W.
    pub drift_w: f64,
    /// Load-dependent copper loss of the extra stator resistance
    /// (`[spindle.motor_efficiency]`), W; included in `input_w`, not in `stator_copper_w`.
    pub load_loss_w: f64,
    /// Cutting power `T_c·ω`, W.
    pub cut_w: f64,
    /// Shaft efficiency `T_em·ω / P_in`, −.
    pub efficiency: f64,
    /// `true` if the load exceeds the torque the motor can give at this speed.
    pub overloaded: bool,
    /// Angle of the terminal phase voltage relative to the EMF, rad.
    pub(super) voltage_angle: f64,
    /// Angle of the phase current relative to the EMF, rad.
    pub(super) current_angle: f64,
}

/// Losses of one operating point beyond the motor file, W: what the machine file's
/// `[spindle.noload_drift]` and `[spindle.motor_efficiency]` add (see [`MotorEffects`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtraLosses {
    /// Thermal drift of the no-load power, W: loads the shaft as bearing friction
    /// `T_d = P_drift/ω` (none at rest).
    pub drift_w: f64,
    /// Load-dependent loss, W: an extra stator series resistance `R_x = P_x/(3|I_s|²)` at
    /// the same currents, so the input power rises by exactly this much.
    pub load_loss_w: f64,
}

impl ExtraLosses {
    /// No extra losses: the motor file alone.
    pub const NONE: Self = Self {
        drift_w: 0.0,
        load_loss_w: 0.0,
    };
}

/// The machine file's spindle effects as the induction motor honours them (the same keys
/// and laws as [`SpindleSpec::input_power_w`] of the constant-speed spindle; physics.md §2:
/// input power = no-load power + cutting power over the efficiency, copper loss ∝ I²).
///
/// * `[spindle.noload_drift]`: `P_drift(t) = ΔP·(1 − e^(−t/τ))` ([`NoloadDrift::power_w`],
///   `t` since the motor simulation started) is a **bearing friction torque**
///   `T_d = P_drift/ω` added to the friction and windage of the motor file — the spindle
///   bearings' preload and grease change as they warm up, which is what drifts a spindle's
///   air-cut power. The motor must deliver it through the air gap, so the measured input
///   rises by `P_drift` times the motor's marginal input per shaft watt
///   `∂P_in/∂P_shaft = 1 + ∂(stator + rotor copper)/∂P_shaft` (≈ 1.01 in air at 600 rpm on
///   `seed002-small-mill`, ≈ 1.05 at 1 kW of cutting: see docs/sim.md).
/// * `[spindle.motor_efficiency]`: the load loss `P_x = c·P_c²/1000`
///   ([`MotorEfficiency::loss_w`], `P_c = T_c·ω` of the lagged cutting torque the motor
///   carries) is **copper loss** (∝ I² ∝ torque², seed 000) of an extra stator series
///   resistance `R_x = P_x/(3|I_s|²)` — a winding hotter (more resistive) the harder it
///   works. The drive holds the currents (flux and torque as before, same slip) and supplies
///   the extra drop `I_s·R_x`: the two-wattmeter power rises by exactly `c·P_c²/1000`, the
///   terminal voltage and power factor with it, and the phase currents — what the
///   current-based estimators read — are unchanged.
///
/// Null: both absent, `ΔP = 0` or `c = 0` leave every sample bit-identical to the motor
/// file alone (no extra arithmetic on the signal path, no extra random draws).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotorEffects {
    /// `[spindle.noload_drift]` (default: off).
    pub noload_drift: Option<NoloadDrift>,
    /// `[spindle.motor_efficiency]` (default: off).
    pub motor_efficiency: Option<MotorEfficiency>,
}

impl MotorEffects {
    /// The effects a machine file's `[spindle]` table sets.
    pub fn from_spindle(spindle: &SpindleSpec) -> Self {
        Self {
            noload_drift: spindle.noload_drift,
            motor_efficiency: spindle.motor_efficiency,
        }
    }

    /// Extra losses `t_s` seconds after start at the cutting power `cut_w` W.
    pub fn losses(&self, t_s: f64, cut_w: f64) -> ExtraLosses {
        ExtraLosses {
            drift_w: self.noload_drift.map_or(0.0, |d| d.power_w(t_s)),
            load_loss_w: self.motor_efficiency.map_or(0.0, |m| m.loss_w(cut_w)),
        }
    }
}

/// The motor's physics (no signals): operating points.
#[derive(Debug, Clone, PartialEq)]
pub struct Motor {
    pub(super) cfg: MotorConfig,
}

impl Motor {
    /// From a validated configuration.
    pub fn new(cfg: MotorConfig) -> Self {
        Self { cfg }
    }

    /// The configuration.
    pub fn config(&self) -> &MotorConfig {
        &self.cfg
    }

    /// Friction and windage torque at `rpm`, N·m.
    pub fn friction_torque_nm(&self, rpm: f64) -> f64 {
        let f = &self.cfg.friction;
        let n = rpm.abs();
        let wb = 2.0 * PI * self.cfg.rated.base_speed_rpm / 60.0;
        let windage = f.windage_w_at_base / wb * (n / self.cfg.rated.base_speed_rpm).powi(2);
        f.coulomb_nm + f.viscous_nm_per_krpm * n / 1000.0 + windage
    }

    /// Circuit values at electrical frequency `f` Hz: `(E_phase, X_s, X_r, X_m, R_fe)`.
    fn circuit_at(&self, f: f64) -> (f64, f64, f64, f64, f64) {
        let r = &self.cfg.rated;
        let c = &self.cfg.circuit;
        let fb = f64::from(r.pole_pairs) * r.base_speed_rpm / 60.0;
        let k = f / fb;
        let e = r.emf_line_v / 3f64.sqrt() * k.min(1.0);
        (
            e,
            c.x_s_ohm * k,
            c.x_r_ohm * k,
            c.x_m_ohm * k,
            c.r_fe_ohm * k.powf(2.0 - c.iron_loss_exponent),
        )
    }

    fn freq(&self, rpm: f64, slip: f64) -> f64 {
        (f64::from(self.cfg.rated.pole_pairs) * rpm / 60.0 / (1.0 - slip)).max(0.5)
    }

    /// Electromagnetic torque at slip `s`, N·m: `3E²·s·R_r / ((R_r² + s²X_r²)·ω_sync)`.
    fn torque_at(&self, rpm: f64, s: f64) -> f64 {
        let f = self.freq(rpm, s);
        let (e, _, xr, _, _) = self.circuit_at(f);
        let rr = self.cfg.circuit.r_r_ohm;
        let w_sync = 2.0 * PI * f / f64::from(self.cfg.rated.pole_pairs);
        3.0 * e * e * s * rr / ((rr * rr + s * s * xr * xr) * w_sync)
    }

    /// Steady state at `rpm` (≥ 0) with cutting torque `cut_torque_nm` and no extra losses
    /// ([`Motor::operating_point_with`] with [`ExtraLosses::NONE`]).
    pub fn operating_point(&self, rpm: f64, cut_torque_nm: f64) -> OperatingPoint {
        self.operating_point_with(rpm, cut_torque_nm, ExtraLosses::NONE)
    }

    /// Steady state at `rpm` (≥ 0) with cutting torque `cut_torque_nm` and the machine
    /// file's extra losses `extra` (see [`ExtraLosses`]): the drift power loads the shaft
    /// as bearing friction `P_drift/ω`, the load loss is the copper loss of an extra stator
    /// series resistance at the same currents. With `ExtraLosses::NONE` the arithmetic is
    /// that of the motor file alone (bit for bit).
    pub fn operating_point_with(
        &self,
        rpm: f64,
        cut_torque_nm: f64,
        extra: ExtraLosses,
    ) -> OperatingPoint {
        let rpm = if rpm.is_finite() { rpm.abs() } else { 0.0 };
        let cut = if cut_torque_nm.is_finite() {
            cut_torque_nm
        } else {
            0.0
        };
        let omega = 2.0 * PI * rpm / 60.0;
        let mut t_f = self.friction_torque_nm(rpm);
        // Thermal drift as bearing friction: T_d = P_drift/ω (none with the spindle at rest).
        let drift_nm = if extra.drift_w != 0.0 && extra.drift_w.is_finite() && omega > 1e-6 {
            extra.drift_w / omega
        } else {
            0.0
        };
        if drift_nm != 0.0 {
            t_f += drift_nm;
        }
        let load = cut + t_f;
        // Slip at breakdown ≈ R_r / X_r: search the stable region on both sides of 0.
        let (_, _, xr_b, _, _) = self.circuit_at(self.freq(rpm, 0.0));
        let s_bd = 0.9 * self.cfg.circuit.r_r_ohm / xr_b.max(1e-9);
        let s_bd = s_bd.min(0.5);
        let (mut lo, mut hi) = (-s_bd, s_bd);
        let overloaded = load > self.torque_at(rpm, hi) || load < self.torque_at(rpm, lo);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.torque_at(rpm, mid) < load {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let s = 0.5 * (lo + hi);
        let f = self.freq(rpm, s);
        let (e, xs, xr, xm, rfe) = self.circuit_at(f);
        let c = &self.cfg.circuit;
        let emf = Cx::new(e, 0.0);
        // Rotor branch admittance s/(R_r + j·s·X_r): no singularity at s = 0.
        let i_r = emf * s / Cx::new(c.r_r_ohm, s * xr);
        let i_0 = Cx::new(e / rfe, -e / xm);
        let i_s = i_0 + i_r;
        let i_sq = i_s.re * i_s.re + i_s.im * i_s.im;
        // Load loss as an extra series resistance R_x = P_x/(3|I_s|²) in the stator: the
        // drive holds the currents (same flux, same torque, same slip) and supplies the
        // extra drop I_s·R_x, so the input rises by exactly 3|I_s|²R_x = P_x.
        let r_x = if extra.load_loss_w != 0.0 && extra.load_loss_w.is_finite() && i_sq > 0.0 {
            extra.load_loss_w / (3.0 * i_sq)
        } else {
            0.0
        };
        let v = if r_x != 0.0 {
            emf + i_s * Cx::new(c.r_s_ohm + r_x, xs)
        } else {
            emf + i_s * Cx::new(c.r_s_ohm, xs)
        };
        let i_mag = i_s.norm();
        let input_w = 3.0 * (v.re * i_s.re + v.im * i_s.im);
        let p_ag = 3.0 * e * e * s * c.r_r_ohm / (c.r_r_ohm.powi(2) + (s * xr).powi(2));
        let w_sync = 2.0 * PI * f / f64::from(self.cfg.rated.pole_pairs);
        let t_em = p_ag / w_sync;
        let apparent = 3.0 * v.norm() * i_mag;
        OperatingPoint {
            rpm,
            cut_torque_nm: cut,
            friction_torque_nm: t_f,
            slip: s,
            freq_hz: f,
            line_voltage_v: 3f64.sqrt() * v.norm(),
            current_a: i_mag,
            power_factor: if apparent > 0.0 {
                input_w / apparent
            } else {
                0.0
            },
            input_w,
            stator_copper_w: 3.0 * i_mag * i_mag * c.r_s_ohm,
            iron_w: 3.0 * e * e / rfe,
            rotor_copper_w: s * p_ag,
            friction_w: t_f * omega,
            drift_w: drift_nm * omega,
            load_loss_w: 3.0 * i_sq * r_x,
            cut_w: cut * omega,
            efficiency: if input_w > 0.0 {
                t_em * omega / input_w
            } else {
                0.0
            },
            overloaded,
            voltage_angle: v.arg(),
            current_angle: i_s.arg(),
        }
    }
}
