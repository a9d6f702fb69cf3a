//! Machine and tool files (`configs/machines/*.toml`, `configs/machines/tools/*.toml`).

use std::path::Path;

use acc_config::{check_range, load_toml, ConfigError};
use serde::Deserialize;

use crate::process::{ProcessSpec, ToothSpec, WearSpec};

/// `[spindle]` table of a machine file.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpindleSpec {
    /// Commanded spindle speed, rpm (paper: 600).
    pub rpm: f64,
    /// Spindle input power while turning in air, W (iron, friction and fan losses).
    pub no_load_power_w: f64,
    /// Efficiency from electrical input to cutting power, 0…1.
    pub efficiency: f64,
}

/// `[feed_drive]` table.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FeedDriveSpec {
    /// Time constant τ of the feed drive's first-order lag, s (seed 002, eq. 5; the paper
    /// assumes T ≫ τ, eq. 6).
    pub tau_s: f64,
}

/// `[override_path]` table: from the board's register to the interpolator.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OverridePathSpec {
    /// Dead time from writing `OVERRIDE_CMD` to the feed starting to change, s (PMC ladder
    /// scan + board output + interpolator pick-up).
    pub delay_s: f64,
    /// Override resolution of the board, percent: 10 (4-bit board) or 1 (byte board).
    pub step_pct: u16,
}

/// `[sim]` table: internal integration rates.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SimRates {
    /// Internal rate of the mean-force model, Hz (default 1000).
    #[serde(default = "default_mean_rate")]
    pub mean_rate_hz: f64,
    /// Internal rate of the tooth-level model, Hz (default 10 000: 250 samples per tooth
    /// pass at 600 rpm with 4 flutes).
    #[serde(default = "default_tooth_rate")]
    pub tooth_rate_hz: f64,
}

impl Default for SimRates {
    fn default() -> Self {
        SimRates {
            mean_rate_hz: default_mean_rate(),
            tooth_rate_hz: default_tooth_rate(),
        }
    }
}

fn default_mean_rate() -> f64 {
    1000.0
}

fn default_tooth_rate() -> f64 {
    10_000.0
}

/// A machine file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MachineSpec {
    /// Name.
    pub name: String,
    /// Spindle.
    pub spindle: SpindleSpec,
    /// Feed drive.
    pub feed_drive: FeedDriveSpec,
    /// Override path.
    pub override_path: OverridePathSpec,
    /// Internal rates.
    #[serde(default)]
    pub sim: SimRates,
}

impl MachineSpec {
    /// Load and validate; errors name the file, the key and the allowed range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let spec: MachineSpec = load_toml(path)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Validate every value.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        check_range(f, "spindle.rpm", self.spindle.rpm, 1.0, 60_000.0)?;
        check_range(
            f,
            "spindle.no_load_power_w",
            self.spindle.no_load_power_w,
            0.0,
            1e6,
        )?;
        check_range(f, "spindle.efficiency", self.spindle.efficiency, 0.05, 1.0)?;
        check_range(f, "feed_drive.tau_s", self.feed_drive.tau_s, 0.0, 1.0)?;
        check_range(
            f,
            "override_path.delay_s",
            self.override_path.delay_s,
            0.0,
            1.0,
        )?;
        if !matches!(self.override_path.step_pct, 1 | 10) {
            return Err(ConfigError::OutOfRange {
                file: f.to_path_buf(),
                key: "override_path.step_pct".into(),
                value: self.override_path.step_pct.to_string(),
                allowed: "1 or 10".into(),
            });
        }
        check_range(f, "sim.mean_rate_hz", self.sim.mean_rate_hz, 10.0, 1e5)?;
        check_range(f, "sim.tooth_rate_hz", self.sim.tooth_rate_hz, 100.0, 1e6)?;
        Ok(())
    }
}

/// A tool file: geometry, the calibrated force law, wear and tooth-level geometry.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    /// Name.
    pub name: String,
    /// Diameter D, mm (paper: 16).
    pub diameter_mm: f64,
    /// Number of flutes N (paper: 4).
    pub flutes: usize,
    /// Mean-force law (eq. 1).
    pub process: ProcessSpec,
    /// Wear law (default: no wear).
    #[serde(default)]
    pub wear: WearSpec,
    /// Tooth-level geometry.
    pub tooth: ToothSpec,
}

impl ToolSpec {
    /// Load and validate; errors name the file, the key and the allowed range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let spec: ToolSpec = load_toml(path)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Validate every value.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        check_range(f, "diameter_mm", self.diameter_mm, 0.1, 500.0)?;
        check_range(f, "flutes", self.flutes as f64, 1.0, 32.0)?;
        self.process.validate(f)?;
        self.wear.validate(f, "wear")?;
        check_range(f, "tooth.helix_deg", self.tooth.helix_deg, 0.0, 60.0)?;
        check_range(
            f,
            "tooth.axial_slices",
            self.tooth.axial_slices as f64,
            1.0,
            256.0,
        )?;
        Ok(())
    }

    /// Tool radius R, mm.
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }
}
