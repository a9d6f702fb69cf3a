//! Motor files: nameplate, equivalent circuit, friction, drive and DAQ sensor tables
//! ([`MotorConfig`]), and the built-in motors.

use std::path::Path;

use acc_config::{check_range, ConfigError};
use serde::{Deserialize, Serialize};

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
                include_str!("../../../../configs/motors/seed000-dnm4500.toml"),
            ),
            BuiltinMotor::Seed002SmallMill => (
                "configs/motors/seed002-small-mill.toml",
                include_str!("../../../../configs/motors/seed002-small-mill.toml"),
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
