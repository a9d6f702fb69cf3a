//! Induction spindle motor: what a DAQ on the spindle cables samples.
//!
//! The spindle drive holds the commanded speed (speed loop, slip compensation): the
//! electrical frequency is `f_e = p·n/60 / (1 − s)` with `p` pole pairs and slip `s`. Per
//! phase, the steady-state equivalent circuit (seed 000 §2.2, Fig. 3; the textbook
//! T-circuit):
//!
//! ```text
//!   V ──R_s──jX_s──┬──────────┬──────────┐
//!                  │          │          │
//!                R_fe       jX_m     R_r/s + jX_r
//!                  │          │          │
//!   N ─────────────┴──────────┴──────────┘        E = air-gap EMF
//! ```
//!
//! * The drive holds the flux: `E ∝ f_e` up to base speed, `E` constant above it (field
//!   weakening). Reactances scale with `f_e`; `R_fe` with `f_e^(2−k)` so the iron loss
//!   `3E²/R_fe` grows as `f_e^k` (`iron_loss_exponent`, default 1.5).
//! * Air-gap power `P_ag = 3·|I_r|²·R_r/s`, electromagnetic torque
//!   `T_em = P_ag / ω_sync` with `ω_sync = 2π·f_e/p`; the slip is solved so that `T_em` equals
//!   the load: cutting torque plus friction and windage (`T_f = T_0 + B·n + windage`). In
//!   the stable region torque ∝ slip (seed 000 eq. 7).
//! * Losses: stator copper `3|I_s|²R_s` (∝ I²), iron `3E²/R_fe`, rotor copper `s·P_ag`,
//!   friction and windage. So the power factor, slip and efficiency change with load as on
//!   a real motor (seed 000 Figs. 2, 4): at light load the no-load losses dominate and the
//!   efficiency is low.
//!
//! The load torque reaches the motor through a first-order lag `torque_lag_s` (the drive's
//! speed loop and the rotor inertia; seed 004 reports ≈ 5 Hz for spindle current), plus a white
//! drive-side torque disturbance `torque_noise_nm` (not part of the cutting truth). The sampled
//! signals are the phase currents `i_U`, `i_V` and the line voltages `v_UW`, `v_VW` (as in
//! seed 000's test bed), with 5th/7th harmonics, seeded Gaussian noise (ChaCha8) and ADC
//! quantisation. Deterministic for a seed.

use std::f64::consts::PI;
use std::path::Path;

use acc_config::{check_range, ConfigError};
use acc_core::PhaseBlock;
use acc_spindle::power::PhaseSamples;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::config::{MotorEfficiency, NoloadDrift, SensorLowpass, SpindleSpec};

/// `[rated]` table: nameplate data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rated {
    /// Rated (maximum) output power, W.
    pub power_w: f64,
    /// Rated (maximum) torque, N·m.
    pub torque_nm: f64,
    /// Pole pairs `p`.
    pub pole_pairs: u32,
    /// Base speed: full flux up to here, field weakening above, rpm.
    pub base_speed_rpm: f64,
    /// Highest allowed speed, rpm.
    pub max_speed_rpm: f64,
    /// Line-to-line air-gap EMF `√3·E` held at base speed, V.
    pub emf_line_v: f64,
}

/// `[circuit]` table: per-phase equivalent circuit at the base frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Circuit {
    /// Stator resistance `R_s`, Ω.
    pub r_s_ohm: f64,
    /// Stator leakage reactance `X_s` at base frequency, Ω.
    pub x_s_ohm: f64,
    /// Rotor resistance referred to the stator `R_r`, Ω.
    pub r_r_ohm: f64,
    /// Rotor leakage reactance `X_r` at base frequency, Ω.
    pub x_r_ohm: f64,
    /// Magnetising reactance `X_m` at base frequency, Ω.
    pub x_m_ohm: f64,
    /// Iron-loss resistance `R_fe` at base frequency, Ω.
    pub r_fe_ohm: f64,
    /// Iron loss ∝ `f_e^k` at constant flux, `k`. Default 1.5.
    #[serde(default = "default_iron_exp")]
    pub iron_loss_exponent: f64,
}

fn default_iron_exp() -> f64 {
    1.5
}

/// `[friction]` table: bearing friction and windage, as a load torque.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Friction {
    /// Constant (Coulomb) friction torque, N·m.
    pub coulomb_nm: f64,
    /// Viscous friction torque per 1000 rpm, N·m.
    pub viscous_nm_per_krpm: f64,
    /// Windage power at base speed, W (∝ n³).
    pub windage_w_at_base: f64,
}

/// `[drive]` table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Drive {
    /// Time constant of the load torque reaching the motor current, s: the spindle
    /// drive's speed-loop response (≈ 16 Hz). Default 0.01. Seed 004 reports ≈ 5 Hz for
    /// its current-based estimate (≈ 0.03 s); with that lag the paper's fixed-gain loop no
    /// longer oscillates at 3 mm (the lag lowers the loop gain at the Nyquist frequency).
    pub torque_lag_s: f64,
    /// Load-torque disturbance of the drive (speed-loop ripple, bearing noise): σ of a
    /// white sequence, one value per torque slice, N·m. Default 0.1.
    pub torque_noise_nm: f64,
}

impl Default for Drive {
    fn default() -> Self {
        Self {
            torque_lag_s: 0.01,
            torque_noise_nm: 0.1,
        }
    }
}

/// `[sensors]` table: the DAQ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Sensors {
    /// Sampling rate, Hz. Default 10 000.
    pub sample_rate_hz: f64,
    /// Gaussian noise on each current channel (σ), A. Default 0.05.
    pub current_noise_a: f64,
    /// Gaussian noise on each voltage channel (σ), V. Default 0.2.
    pub voltage_noise_v: f64,
    /// ADC resolution, bits (1…32). Default 24 (NI-9247 / NI-9225 of seed 000).
    pub adc_bits: u32,
    /// Current input range ±, A. Default 200.
    pub current_range_a: f64,
    /// Voltage input range ±, V. Default 600.
    pub voltage_range_v: f64,
    /// 5th-harmonic voltage amplitude relative to the fundamental, −. Default 0.02.
    pub voltage_h5: f64,
    /// 7th-harmonic voltage amplitude relative to the fundamental, −. Default 0.01.
    pub voltage_h7: f64,
    /// 5th-harmonic current amplitude relative to the fundamental, −. Default 0.03.
    pub current_h5: f64,
    /// 7th-harmonic current amplitude relative to the fundamental, −. Default 0.015.
    pub current_h7: f64,
}

impl Default for Sensors {
    fn default() -> Self {
        Self {
            sample_rate_hz: 10_000.0,
            current_noise_a: 0.05,
            voltage_noise_v: 0.2,
            adc_bits: 24,
            current_range_a: 200.0,
            voltage_range_v: 600.0,
            voltage_h5: 0.02,
            voltage_h7: 0.01,
            current_h5: 0.03,
            current_h7: 0.015,
        }
    }
}

/// A spindle motor file (`configs/motors/*.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorConfig {
    /// Short name.
    pub name: String,
    /// What it models and where the numbers come from.
    #[serde(default)]
    pub description: String,
    /// Nameplate.
    pub rated: Rated,
    /// Equivalent circuit.
    pub circuit: Circuit,
    /// Friction and windage.
    pub friction: Friction,
    /// Drive dynamics.
    #[serde(default)]
    pub drive: Drive,
    /// DAQ.
    #[serde(default)]
    pub sensors: Sensors,
}

/// The motors compiled into the simulator (`configs/motors/`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BuiltinMotor {
    /// `seed000-dnm4500.toml`: 18.3 kW, 118 N·m (seed 000).
    Seed000Dnm4500,
    /// `seed002-small-mill.toml`: 5.5 kW, 35 N·m (the seed 002 machine).
    Seed002SmallMill,
}

impl BuiltinMotor {
    /// The motor's TOML text and its path for error messages.
    fn source(self) -> (&'static str, &'static str) {
        match self {
            BuiltinMotor::Seed000Dnm4500 => (
                "configs/motors/seed000-dnm4500.toml",
                include_str!("../../configs/motors/seed000-dnm4500.toml"),
            ),
            BuiltinMotor::Seed002SmallMill => (
                "configs/motors/seed002-small-mill.toml",
                include_str!("../../configs/motors/seed002-small-mill.toml"),
            ),
        }
    }

    /// The validated configuration.
    pub fn config(self) -> Result<MotorConfig, ConfigError> {
        let (path, text) = self.source();
        let cfg: MotorConfig = acc_config::parse_toml(path, text)?;
        cfg.validate(Path::new(path))?;
        Ok(cfg)
    }
}

impl MotorConfig {
    /// Read and validate a motor file; errors name the file, the key and the range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let cfg: Self = acc_config::load_toml(path)?;
        cfg.validate(path)?;
        Ok(cfg)
    }

    /// Range checks of every value.
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        let r = &self.rated;
        check_range(file, "rated.power_w", r.power_w, 10.0, 1e6)?;
        check_range(file, "rated.torque_nm", r.torque_nm, 0.01, 1e5)?;
        check_range(file, "rated.pole_pairs", f64::from(r.pole_pairs), 1.0, 12.0)?;
        check_range(file, "rated.base_speed_rpm", r.base_speed_rpm, 10.0, 1e5)?;
        check_range(
            file,
            "rated.max_speed_rpm",
            r.max_speed_rpm,
            r.base_speed_rpm,
            2e5,
        )?;
        check_range(file, "rated.emf_line_v", r.emf_line_v, 1.0, 2e4)?;
        let c = &self.circuit;
        for (key, v) in [
            ("circuit.r_s_ohm", c.r_s_ohm),
            ("circuit.x_s_ohm", c.x_s_ohm),
            ("circuit.r_r_ohm", c.r_r_ohm),
            ("circuit.x_r_ohm", c.x_r_ohm),
            ("circuit.x_m_ohm", c.x_m_ohm),
            ("circuit.r_fe_ohm", c.r_fe_ohm),
        ] {
            check_range(file, key, v, 1e-6, 1e6)?;
        }
        check_range(
            file,
            "circuit.iron_loss_exponent",
            c.iron_loss_exponent,
            1.0,
            2.0,
        )?;
        let f = &self.friction;
        check_range(file, "friction.coulomb_nm", f.coulomb_nm, 0.0, 1e4)?;
        check_range(
            file,
            "friction.viscous_nm_per_krpm",
            f.viscous_nm_per_krpm,
            0.0,
            1e4,
        )?;
        check_range(
            file,
            "friction.windage_w_at_base",
            f.windage_w_at_base,
            0.0,
            1e6,
        )?;
        check_range(
            file,
            "drive.torque_lag_s",
            self.drive.torque_lag_s,
            0.0,
            10.0,
        )?;
        check_range(
            file,
            "drive.torque_noise_nm",
            self.drive.torque_noise_nm,
            0.0,
            1e4,
        )?;
        let s = &self.sensors;
        check_range(file, "sensors.sample_rate_hz", s.sample_rate_hz, 100.0, 1e7)?;
        check_range(file, "sensors.current_noise_a", s.current_noise_a, 0.0, 1e3)?;
        check_range(file, "sensors.voltage_noise_v", s.voltage_noise_v, 0.0, 1e4)?;
        check_range(file, "sensors.adc_bits", f64::from(s.adc_bits), 1.0, 32.0)?;
        check_range(
            file,
            "sensors.current_range_a",
            s.current_range_a,
            1e-3,
            1e5,
        )?;
        check_range(
            file,
            "sensors.voltage_range_v",
            s.voltage_range_v,
            1e-3,
            1e5,
        )?;
        for (key, v) in [
            ("sensors.voltage_h5", s.voltage_h5),
            ("sensors.voltage_h7", s.voltage_h7),
            ("sensors.current_h5", s.current_h5),
            ("sensors.current_h7", s.current_h7),
        ] {
            check_range(file, key, v, 0.0, 0.5)?;
        }
        Ok(())
    }
}

/// Minimal complex number for the phasor algebra of one operating point (four operations;
/// kept local so the simulator's dependency list stays as its owner set it).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cx {
    re: f64,
    im: f64,
}

impl Cx {
    const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    fn add(self, o: Cx) -> Cx {
        Cx::new(self.re + o.re, self.im + o.im)
    }
    fn mul(self, o: Cx) -> Cx {
        Cx::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: Cx) -> Cx {
        let d = o.re * o.re + o.im * o.im;
        Cx::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    fn scale(self, k: f64) -> Cx {
        Cx::new(self.re * k, self.im * k)
    }
    fn norm(self) -> f64 {
        self.re.hypot(self.im)
    }
    fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
}

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
    voltage_angle: f64,
    /// Angle of the phase current relative to the EMF, rad.
    current_angle: f64,
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
    cfg: MotorConfig,
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
        let i_r = emf.scale(s).div(Cx::new(c.r_r_ohm, s * xr));
        let i_0 = Cx::new(e / rfe, -e / xm);
        let i_s = i_0.add(i_r);
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
            emf.add(i_s.mul(Cx::new(c.r_s_ohm + r_x, xs)))
        } else {
            emf.add(i_s.mul(Cx::new(c.r_s_ohm, xs)))
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

/// Means over one simulated period (the truth a test compares against).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PeriodTruth {
    /// Mean cutting torque at the motor (after the drive lag), N·m.
    pub cut_torque_nm: f64,
    /// Mean input power (noise-free), W.
    pub input_w: f64,
    /// Mean cutting power, W.
    pub cut_w: f64,
    /// RMS phase current (noise-free fundamental), A.
    pub current_a: f64,
    /// Mean slip, −.
    pub slip: f64,
    /// Last operating point of the period.
    pub last: OperatingPoint,
}

/// One period of sampled signals.
#[derive(Debug, Clone, Default)]
pub struct MotorBlock {
    /// The sampled channels `i_U`, `i_V` (A), `v_UW`, `v_VW` (V) at the DAQ rate.
    pub samples: PhaseSamples,
    /// Noise-free means of the period.
    pub truth: PeriodTruth,
}

impl MotorBlock {
    /// The block as the force sources take it.
    pub fn phase_block(&self) -> PhaseBlock<'_> {
        self.samples.block()
    }
}

/// The sampled motor: physics + drive lag + DAQ, seeded.
#[derive(Debug, Clone)]
pub struct MotorSim {
    motor: Motor,
    rng: ChaCha8Rng,
    theta: f64,
    lagged_torque_nm: f64,
    block: MotorBlock,
    effects: MotorEffects,
    /// Time since the simulation started (the spindle start of the drift), s.
    t_s: f64,
}

/// Quantise to the ADC grid and clip to the range.
fn adc(x: f64, range: f64, lsb: f64) -> f64 {
    // `exact::round` is `f64::round` bit for bit, without the library call.
    (crate::exact::round(x.clamp(-range, range) / lsb) * lsb).clamp(-range, range)
}

impl MotorSim {
    /// A motor at rest in phase, idle, with RNG `seed`.
    pub fn new(cfg: MotorConfig, seed: u64) -> Self {
        Self {
            motor: Motor::new(cfg),
            rng: ChaCha8Rng::seed_from_u64(seed),
            theta: 0.0,
            lagged_torque_nm: 0.0,
            block: MotorBlock::default(),
            effects: MotorEffects::default(),
            t_s: 0.0,
        }
    }

    /// The same motor with the machine file's extra losses `effects` (see
    /// [`MotorEffects`]).
    pub fn with_effects(mut self, effects: MotorEffects) -> Self {
        self.effects = effects;
        self
    }

    /// The extra losses it honours.
    pub fn effects(&self) -> &MotorEffects {
        &self.effects
    }

    /// Time since the simulation started, s.
    pub fn elapsed_s(&self) -> f64 {
        self.t_s
    }

    /// The motor physics.
    pub fn motor(&self) -> &Motor {
        &self.motor
    }

    /// Simulate one period of `period_s` at `rpm`. `torque_nm` holds the cutting torque over
    /// the period in equal time slices (one value = constant over the period; the
    /// simulator passes its internal samples). Returns the sampled block.
    pub fn run_period(&mut self, rpm: f64, torque_nm: &[f64], period_s: f64) -> &MotorBlock {
        self.run_period_tail(rpm, torque_nm, period_s, usize::MAX)
    }

    /// DAQ samples in a period of `period_s` (the block length of [`MotorSim::run_period`]).
    pub fn samples_in(&self, period_s: f64) -> usize {
        (period_s * self.motor.cfg.sensors.sample_rate_hz)
            .round()
            .max(0.0) as usize
    }

    /// [`MotorSim::run_period`] keeping only the last `keep` samples of the block (all of
    /// them if `keep` ≥ [`MotorSim::samples_in`]): the earlier ones are not synthesised,
    /// but their noise is still drawn, so the kept samples, the truth and every later
    /// period are bit for bit those of `run_period` (for a reader of a window at the end
    /// of the period, e.g. [`SpindlePowerChannel`]).
    pub fn run_period_tail(
        &mut self,
        rpm: f64,
        torque_nm: &[f64],
        period_s: f64,
        keep: usize,
    ) -> &MotorBlock {
        let s = self.motor.cfg.sensors;
        let fs = s.sample_rate_hz;
        let n = self.samples_in(period_s);
        let skip = n.saturating_sub(keep);
        let b = &mut self.block.samples;
        b.sample_rate_hz = fs;
        b.clear();
        for ch in [&mut b.i_u, &mut b.i_v, &mut b.v_uw, &mut b.v_vw] {
            ch.reserve(n - skip);
        }
        let slices = torque_nm.len().clamp(1, n.max(1));
        let lag = self.motor.cfg.drive.torque_lag_s;
        let mut truth = PeriodTruth::default();
        let full = 2f64.powi(s.adc_bits as i32 - 1);
        let (lsb_i, lsb_v) = (s.current_range_a / full, s.voltage_range_v / full);
        let (c3, s3) = ((2.0 * PI / 3.0).cos(), (2.0 * PI / 3.0).sin());
        // Harmonic k of a phase shifted by −2π/3: angle shift k·2π/3.
        let rot = |k: f64| ((k * 2.0 * PI / 3.0).cos(), (k * 2.0 * PI / 3.0).sin());
        let (r5, r7) = (rot(5.0), rot(7.0));
        let mut current_sq = 0.0;
        for j in 0..slices {
            let start = j * n / slices;
            let end = (j + 1) * n / slices;
            let t_cut = torque_nm.get(j).copied().unwrap_or(0.0);
            let dt = (end - start) as f64 / fs;
            self.lagged_torque_nm = if lag > 0.0 {
                t_cut + (self.lagged_torque_nm - t_cut) * (-dt / lag).exp()
            } else {
                t_cut
            };
            let disturbance = if self.motor.cfg.drive.torque_noise_nm > 0.0 {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                self.motor.cfg.drive.torque_noise_nm * z
            } else {
                0.0
            };
            self.t_s += dt;
            let omega = if rpm.is_finite() {
                2.0 * PI * rpm.abs() / 60.0
            } else {
                0.0
            };
            let extra = self.effects.losses(self.t_s, self.lagged_torque_nm * omega);
            let mut op =
                self.motor
                    .operating_point_with(rpm, self.lagged_torque_nm + disturbance, extra);
            // The disturbance is drive-side: the cutting truth is the lagged cutting torque.
            op.cut_torque_nm = self.lagged_torque_nm;
            op.cut_w = self.lagged_torque_nm * 2.0 * PI * op.rpm / 60.0;
            let w = (end - start) as f64 / n.max(1) as f64;
            truth.cut_torque_nm += w * op.cut_torque_nm;
            truth.input_w += w * op.input_w;
            truth.cut_w += w * op.cut_w;
            truth.slip += w * op.slip;
            current_sq += w * op.current_a * op.current_a;
            truth.last = op;
            let av = 2f64.sqrt() * op.line_voltage_v / 3f64.sqrt();
            let ai = 2f64.sqrt() * op.current_a;
            let dtheta = 2.0 * PI * op.freq_hz / fs;
            let (sva, cva) = op.voltage_angle.sin_cos();
            let (sia, cia) = op.current_angle.sin_cos();
            for idx in start..end {
                self.theta = crate::exact::rem_tau(self.theta + dtheta);
                if idx < skip {
                    // Not kept: draw the sample's noise (same order, same draws) only.
                    for sigma in [s.current_noise_a, s.current_noise_a] {
                        if sigma > 0.0 {
                            let _: f64 = StandardNormal.sample(&mut self.rng);
                        }
                    }
                    for sigma in [s.voltage_noise_v, s.voltage_noise_v] {
                        if sigma > 0.0 {
                            let _: f64 = StandardNormal.sample(&mut self.rng);
                        }
                    }
                    continue;
                }
                let (sn, cs) = self.theta.sin_cos();
                // Voltage phase U angle θ+α_v; V, W lag/lead by 2π/3.
                let (cv, sv) = (cs * cva - sn * sva, sn * cva + cs * sva);
                let (ci, si) = (cs * cia - sn * sia, sn * cia + cs * sia);
                let v_u = cv;
                let v_v = cv * c3 + sv * s3;
                let v_w = cv * c3 - sv * s3;
                let mut vu = av * v_u;
                let mut vv = av * v_v;
                let mut vw = av * v_w;
                let mut iu = ai * ci;
                let mut iv = ai * (ci * c3 + si * s3);
                for (k, hv, hi, (ck, sk)) in [
                    (5.0, s.voltage_h5, s.current_h5, r5),
                    (7.0, s.voltage_h7, s.current_h7, r7),
                ] {
                    if hv == 0.0 && hi == 0.0 {
                        continue;
                    }
                    let x = k * (self.theta + op.voltage_angle);
                    let (sx, cx) = x.sin_cos();
                    // Phase V: cos(x − k·2π/3); W: cos(x + k·2π/3).
                    vu += hv * av * cx;
                    vv += hv * av * (cx * ck + sx * sk);
                    vw += hv * av * (cx * ck - sx * sk);
                    // Current harmonic lags its voltage by π/2 (inductive): cos(y) = sin(x).
                    iu += hi * ai * sx;
                    iv += hi * ai * (sx * ck - cx * sk);
                }
                let mut noise = |sigma: f64| -> f64 {
                    if sigma > 0.0 {
                        let z: f64 = StandardNormal.sample(&mut self.rng);
                        sigma * z
                    } else {
                        0.0
                    }
                };
                let ni = s.current_noise_a;
                let nv = s.voltage_noise_v;
                let iu_n = iu + noise(ni);
                let iv_n = iv + noise(ni);
                let vuw_n = vu - vw + noise(nv);
                let vvw_n = vv - vw + noise(nv);
                b.i_u.push(adc(iu_n, s.current_range_a, lsb_i));
                b.i_v.push(adc(iv_n, s.current_range_a, lsb_i));
                b.v_uw.push(adc(vuw_n, s.voltage_range_v, lsb_v));
                b.v_vw.push(adc(vvw_n, s.voltage_range_v, lsb_v));
            }
        }
        truth.current_a = current_sq.sqrt();
        self.block.truth = truth;
        &self.block
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn seed000() -> MotorConfig {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../configs/motors/seed000-dnm4500.toml"
        );
        MotorConfig::load(path).unwrap()
    }

    #[test]
    fn power_balance_and_load_dependence() {
        let m = Motor::new(seed000());
        let mut prev: Option<OperatingPoint> = None;
        for t in [0.0, 5.0, 20.0, 60.0, 118.0] {
            let op = m.operating_point(1500.0, t);
            let losses =
                op.stator_copper_w + op.iron_w + op.rotor_copper_w + op.friction_w + op.cut_w;
            assert!(
                (op.input_w - losses).abs() < 1e-6 * op.input_w,
                "{t}: {op:?}"
            );
            assert!(!op.overloaded);
            if let Some(p) = prev {
                assert!(op.slip > p.slip && op.current_a > p.current_a);
                assert!(op.power_factor > p.power_factor, "PF rises with load");
            }
            prev = Some(op);
        }
        // Efficiency low at light load (iron loss dominates), high near rated.
        let light = m.operating_point(1500.0, 2.0).efficiency;
        let rated = m.operating_point(1500.0, 100.0).efficiency;
        assert!(light < 0.6 && rated > 0.85, "{light} {rated}");
        // Torque ∝ slip in the stable region: doubling the load doubles the slip ± 10 %.
        let s1 = m.operating_point(1500.0, 30.0).slip;
        let s2 = m.operating_point(1500.0, 60.0).slip;
        assert!((s2 / s1 - 2.0).abs() < 0.2, "{s1} {s2}");
    }

    /// The extra losses keep the power balance: the drift is friction (shaft), the load
    /// loss is stator copper at the same currents (input rises by exactly it; slip and
    /// current unchanged, voltage and power factor up).
    #[test]
    fn extra_losses_keep_the_power_balance() {
        let m = Motor::new(seed000());
        for (t, drift_w, load_loss_w) in
            [(0.0, 150.0, 0.0), (40.0, 150.0, 300.0), (40.0, -80.0, 0.0)]
        {
            let base = m.operating_point(1500.0, t);
            let op = m.operating_point_with(
                1500.0,
                t,
                ExtraLosses {
                    drift_w,
                    load_loss_w,
                },
            );
            let out = op.stator_copper_w
                + op.iron_w
                + op.rotor_copper_w
                + op.friction_w
                + op.cut_w
                + op.load_loss_w;
            assert!((op.input_w - out).abs() < 1e-6 * op.input_w, "{op:?}");
            assert!((op.drift_w - drift_w).abs() < 1e-9);
            assert!((op.friction_w - base.friction_w - drift_w).abs() < 1e-9);
            // The drift rises the input by itself plus the extra copper loss of its current.
            let rise = op.input_w - base.input_w - load_loss_w;
            assert!(
                rise / drift_w > 0.99 && rise / drift_w < 1.1,
                "{rise} for {drift_w}"
            );
            if load_loss_w > 0.0 {
                let no_ll = m.operating_point_with(
                    1500.0,
                    t,
                    ExtraLosses {
                        drift_w,
                        load_loss_w: 0.0,
                    },
                );
                assert!((op.input_w - no_ll.input_w - load_loss_w).abs() < 1e-9);
                assert_eq!(op.slip, no_ll.slip);
                assert_eq!(op.current_a, no_ll.current_a);
                assert!(op.line_voltage_v > no_ll.line_voltage_v);
                assert!(op.power_factor > no_ll.power_factor);
            }
        }
        // At rest there is no drift torque.
        let rest = m.operating_point_with(
            0.0,
            0.0,
            ExtraLosses {
                drift_w: 100.0,
                load_loss_w: 0.0,
            },
        );
        assert_eq!(rest, m.operating_point(0.0, 0.0));
    }

    #[test]
    fn tail_period_is_the_tail_of_the_full_period_bit_for_bit() {
        let mut full = MotorSim::new(seed000(), 3);
        let mut tail = MotorSim::new(seed000(), 3);
        let torques: Vec<f64> = (0..100).map(|k| 20.0 + 0.3 * f64::from(k)).collect();
        for (period, keep) in [(0, 500), (1, 1), (2, 0), (3, 1000), (4, 5000), (5, 499)] {
            let rpm = 1500.0 + f64::from(period);
            let a = full.run_period(rpm, &torques, 0.1).clone();
            let b = tail.run_period_tail(rpm, &torques, 0.1, keep);
            let n = a.samples.len();
            assert_eq!(n, 1000);
            let k = keep.min(n);
            for (x, y) in [
                (&a.samples.i_u, &b.samples.i_u),
                (&a.samples.i_v, &b.samples.i_v),
                (&a.samples.v_uw, &b.samples.v_uw),
                (&a.samples.v_vw, &b.samples.v_vw),
            ] {
                let x: Vec<u64> = x[n - k..].iter().map(|v| v.to_bits()).collect();
                let y: Vec<u64> = y.iter().map(|v| v.to_bits()).collect();
                assert_eq!(x, y, "period {period}, keep {keep}");
            }
            assert_eq!(a.truth, b.truth);
        }
    }

    #[test]
    fn sampled_power_matches_the_operating_point() {
        let mut sim = MotorSim::new(seed000(), 1);
        sim.run_period(1500.0, &[40.0], 1.0);
        let b = sim.run_period(1500.0, &[40.0], 0.1);
        let s = &b.samples;
        assert_eq!(s.i_u.len(), 1000);
        let p: f64 = (0..1000)
            .map(|k| s.i_u[k] * s.v_uw[k] + s.i_v[k] * s.v_vw[k])
            .sum::<f64>()
            / 1000.0;
        let t = b.truth;
        assert!(
            (p - t.input_w).abs() < 0.01 * t.input_w,
            "{p} vs {}",
            t.input_w
        );
        let again = MotorSim::new(seed000(), 1)
            .run_period(1500.0, &[40.0], 1.0)
            .samples
            .i_u[5];
        let mut s2 = MotorSim::new(seed000(), 1);
        assert_eq!(s2.run_period(1500.0, &[40.0], 1.0).samples.i_u[5], again);
    }

    #[test]
    fn bad_motor_file_names_the_key() {
        let dir = std::env::temp_dir().join(format!("acc-motor-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.toml");
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../configs/motors/seed000-dnm4500.toml"
        ))
        .unwrap()
        .replace("r_r_ohm = ", "r_r_ohm = -");
        std::fs::write(&path, text).unwrap();
        let e = MotorConfig::load(&path).unwrap_err().to_string();
        assert!(e.contains("circuit.r_r_ohm") && e.contains("m.toml"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Records what the channel hands a force source: the block's two-wattmeter power and
    /// RMS current, and the board's power value.
    #[derive(Default)]
    struct Recorder(Vec<(f64, f64, Option<f64>)>);

    impl acc_core::ForceSource for Recorder {
        fn name(&self) -> &str {
            "recorder"
        }

        fn estimate(&mut self, input: &acc_core::PeriodInput<'_>) -> acc_core::ForceSample {
            let s = acc_spindle::block_stats(&input.phases.unwrap()).unwrap();
            self.0.push((s.power_w, s.current_rms_a, input.power_w));
            acc_core::ForceSample::INVALID
        }
    }

    /// The sensor low-pass reaches the source both ways: the block's two-wattmeter power
    /// and the board value are the filtered power (`SensorLowpass::step` of the unfiltered
    /// channel's power), the block's currents are those of the unfiltered channel.
    #[test]
    fn sensor_lowpass_rescales_the_block_power_and_keeps_the_currents() {
        use crate::channel::MeasurementChannel;
        let lp = SensorLowpass { tau_s: 0.3 };
        let run = |lowpass: Option<SensorLowpass>| {
            let mut ch =
                SpindlePowerChannel::new(MotorSim::new(seed000(), 3), Recorder::default(), 0.05)
                    .with_sensor_lowpass(lowpass);
            for k in 0..12 {
                let torque = if k < 4 { 0.0 } else { 40.0 };
                let samples = [crate::machine::Sample {
                    torque_nm: torque,
                    ..Default::default()
                }];
                let rec = crate::machine::PeriodRecord {
                    t_end_s: 0.1 * f64::from(k + 1),
                    period_s: 0.1,
                    x_mm: 0.0,
                    radial_depth_mm: 0.0,
                    axial_depth_mm: 0.0,
                    spindle_rpm: 1500.0,
                    feed_mean_mm_min: 0.0,
                    force_mean_n: 0.0,
                    torque_mean_nm: torque,
                    power_mean_w: 0.0,
                    wear_factor: 1.0,
                    samples: &samples,
                    sample_dt_s: 0.1,
                };
                ch.measure(&rec);
            }
            ch.source.0
        };
        let raw = run(None);
        let filt = run(Some(lp));
        let mut state = None;
        for (k, (a, b)) in raw.iter().zip(&filt).enumerate() {
            let want = lp.step(&mut state, a.0, 0.1);
            assert!(
                (b.0 - want).abs() < 1e-9 * want,
                "period {k}: {} vs {want}",
                b.0
            );
            assert_eq!(b.2, Some(want.round()));
            assert_eq!(b.1, a.1, "period {k}: current");
        }
        // The step is there and the filter lags it.
        assert!(raw[11].0 > raw[3].0 + 1000.0);
        assert!(filt[4].0 < raw[3].0 + 0.5 * (raw[4].0 - raw[3].0));
    }
}

/// Feed-drive current of the axis along the feed, for the spindle + feed-drive fusion
/// (seed 004, physics.md §3): at constant speed `Kt·I = C + Kf·F_x`, i.e.
/// `I = friction_a + a_per_n·F_x`, seen through the drive's current-loop bandwidth
/// (first order, ≈ 60 Hz in seed 004) plus seeded Gaussian noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FeedDriveSpec {
    /// Current at no feed force (`C/Kt`: friction of guides and ball screw), A. Default 3.
    pub friction_a: f64,
    /// Current per newton of feed force (`Kf/Kt`), A/N. Default 0.01.
    pub a_per_n: f64,
    /// Bandwidth of the current response, Hz. Default 60.
    pub bandwidth_hz: f64,
    /// Noise σ per sample, A. Default 0.05.
    pub noise_a: f64,
}

impl Default for FeedDriveSpec {
    fn default() -> Self {
        Self {
            friction_a: 3.0,
            a_per_n: 0.01,
            bandwidth_hz: 60.0,
            noise_a: 0.05,
        }
    }
}

/// The feed-drive current model (see [`FeedDriveSpec`]).
#[derive(Debug, Clone)]
pub struct FeedDriveCurrent {
    spec: FeedDriveSpec,
    state_a: f64,
    rng: ChaCha8Rng,
}

impl FeedDriveCurrent {
    /// At rest (no feed force), RNG `seed`.
    pub fn new(spec: FeedDriveSpec, seed: u64) -> Self {
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
    pub method: acc_spindle::Method,
    /// Read the three-phase block (`false`) or only the power value, as from the board
    /// (`true`). Default `false`.
    pub board_power: bool,
    /// No-load handling. Default `adaptive`.
    pub no_load: acc_spindle::NoLoadMode,
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
            method: acc_spindle::Method::PowerEfficiency,
            board_power: false,
            no_load: acc_spindle::NoLoadMode::Adaptive,
            calibration_levels: [0.25, 0.5, 0.75, 1.0, 1.25, 1.5],
            window_s: 0.05,
        }
    }
}

impl SpindlePowerChannel<acc_spindle::SpindleSource> {
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
    /// bias it by 18 %: `tests/sim_motor_effects.rs`); only the learned σ of the air-cut
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
        let est_cfg = acc_spindle::EstimatorConfig {
            method: spec.method,
            tool_radius_mm,
            no_load: spec.no_load,
            ..acc_spindle::EstimatorConfig::default()
        };
        let est = acc_spindle::SpindleEstimator::new(est_cfg, constants, nl)?;
        let input = if spec.board_power {
            acc_spindle::SpindleInput::BoardPower
        } else {
            acc_spindle::SpindleInput::Phases
        };
        let source = acc_spindle::SpindleSource::new(input, est)?;
        let motor = MotorSim::new(cfg, seed).with_effects(effects);
        Ok(Self::new(motor, source, spec.window_s).with_sensor_lowpass(spindle.sensor_lowpass))
    }
}

/// The power transducer on the spindle cables: it reports each period's two-wattmeter
/// power through the machine file's `[spindle.sensor_lowpass]` — the same first-order
/// low-pass, discretised per control period, as the constant-speed spindle's reported
/// power ([`SensorLowpass::step`]: `y_k = a·y_(k−1) + (1 − a)·x_k`, `a = e^(−T/τ)`,
/// `y_0 = x_0`) — or as measured without it.
#[derive(Debug, Clone, Copy, Default)]
struct PowerSensor {
    lowpass: Option<SensorLowpass>,
    /// Last reported power, W (`None` before the first period).
    state: Option<f64>,
}

impl PowerSensor {
    fn new(lowpass: Option<SensorLowpass>) -> Self {
        Self {
            lowpass,
            state: None,
        }
    }

    /// The power reported for a period of `period_s` s whose measured power is `power_w` W.
    fn read(&mut self, power_w: f64, period_s: f64) -> f64 {
        match self.lowpass {
            Some(l) => l.step(&mut self.state, power_w, period_s),
            None => power_w,
        }
    }
}

/// Below this measured power, W (the board's resolution), the block is not rescaled to the
/// filtered power: the ratio would be meaningless (spindle stopped).
const MIN_RESCALE_POWER_W: f64 = 1.0;

/// The spindle-power measurement channel of the simulated machine: the period's cutting
/// torque (the machine's internal samples) drives [`MotorSim`], and a force source —
/// normally an [`acc_spindle::SpindleSource`] on the three-phase block — estimates the force
/// the controller sees. The true force reported next to it is the period's mean resultant
/// force, as the dynamometer channel reports it.
#[derive(Debug)]
pub struct SpindlePowerChannel<S> {
    motor: MotorSim,
    source: S,
    torques: Vec<f64>,
    last: PeriodTruth,
    window_s: f64,
    sensor: PowerSensor,
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
        let measured_w = acc_spindle::block_stats(&phases).ok().map(|s| s.power_w);
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
        let input = acc_core::PeriodInput {
            // The block handed over covers the window.
            period_s: w as f64 / block.samples.sample_rate_hz,
            spindle_rpm: period.spindle_rpm,
            feed_mm_min: period.feed_mean_mm_min,
            true_force_n: Some(truth),
            // What a power transducer on the same cables reports over the window (through
            // its low-pass when set), in whole watts as in the board's input registers 4–5
            // (`None` if the block is garbage).
            power_w: reported_w.map(|p| p.round().max(0.0)),
            phases: Some(phases),
        };
        crate::channel::Reading {
            sample: self.source.estimate(&input),
            true_force_n: truth,
        }
    }
}

/// The seed 000 experiment on the simulated motor: air cuts, the calibration cut of
/// Table 1 (1 100 rpm, 400–700 mm/min) and the feed sweep of Table 3 (1 500 rpm,
/// 20–300 mm/min in steps of 20, 350–1 000 in steps of 50), face cutter Ø80 with 6
/// inserts on S45C, axial depth 1 mm, lateral 64 mm. Used by `acc estimate-eval` and the
/// tests.
pub mod sweep {
    use std::path::{Path, PathBuf};

    use acc_config::{check_range, resolve_relative, ConfigError};
    use acc_spindle::calibrate::{calibrate, CalPoint, SpindleCalibration};
    use acc_spindle::estimate::{EstimatorConfig, Invalid, Method, NoLoadMode, SpindleEstimator};
    use acc_spindle::eval::{error_rate_pct, rms_error};
    use acc_spindle::noload::{AdaptRule, NoLoadModel};
    use acc_spindle::{block_stats, SpindleError};
    use serde::Deserialize;

    use super::{MotorConfig, MotorSim, PowerSensor, SensorLowpass};

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
                let f_off = off.estimate(rpm, Some(s.power_w), None).map_err(|reason| {
                    SweepError::Invalid {
                        feed_mm_min: feed,
                        reason,
                    }
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
}
