//! The scenario file's tables (`configs/scenarios/*.toml`): `[measurement]`, `[nc]`,
//! `[tools]`, `[summary]`, `[breakage]` and the file itself, each with its validation, and
//! the model file's `[machine]` and `[tool]` ([`load_model`]).

use std::path::{Path, PathBuf};

use acc_config::{check_range, load_toml, resolve_relative, ConfigError};
use serde::Deserialize;

use crate::config::{MachineSpec, ToolSpec};
use crate::process::WearSpec;

/// `[measurement]` table: which channel the controller reads, selected by `kind`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum MeasurementSpec {
    /// A dynamometer: true mean force over the last `window_s` of each period, plus
    /// seeded Gaussian noise, optionally low-passed.
    Dynamometer {
        /// Noise standard deviation, N (default 5).
        #[serde(default = "default_noise")]
        noise_n: f64,
        /// First-order low-pass corner on the period means, Hz (default 0 = off).
        #[serde(default)]
        lowpass_hz: f64,
        /// Averaging window at the end of each period, s (default 0.05 = two tooth passes
        /// at 600 rpm with 4 flutes; 0 = the whole period).
        #[serde(default = "default_window")]
        window_s: f64,
    },
    /// Spindle power: the induction-motor model's three-phase signals (or the board's power
    /// value) read by a spindle force estimator calibrated against a simulated dynamometer
    /// cut at start-up (`crate::motor::SpindlePowerChannel::calibrated_for`, on a motor that
    /// honours the machine file's `[spindle.noload_drift]` and `[spindle.motor_efficiency]`,
    /// its power read through `[spindle.sensor_lowpass]`).
    SpindlePower(crate::motor::SpindlePowerSpec),
}

pub(super) fn default_noise() -> f64 {
    5.0
}

pub(super) fn default_window() -> f64 {
    0.05
}

/// A scenario without a `[measurement]` section measures the force from spindle power
/// (the spindle-power channel is the default; the dynamometer stays for comparison).
impl Default for MeasurementSpec {
    fn default() -> Self {
        MeasurementSpec::SpindlePower(crate::motor::SpindlePowerSpec::default())
    }
}

impl MeasurementSpec {
    /// Validate the channel's keys; errors name `measurement.<key>`.
    pub fn validate(&self, path: &Path) -> Result<(), ConfigError> {
        match *self {
            MeasurementSpec::Dynamometer {
                noise_n,
                lowpass_hz,
                window_s,
            } => {
                check_range(path, "measurement.noise_n", noise_n, 0.0, 1e5)?;
                check_range(path, "measurement.lowpass_hz", lowpass_hz, 0.0, 1e4)?;
                check_range(path, "measurement.window_s", window_s, 0.0, 10.0)?;
            }
            MeasurementSpec::SpindlePower(spec) => {
                check_range(path, "measurement.window_s", spec.window_s, 0.0, 10.0)?;
                for (i, l) in spec.calibration_levels.iter().enumerate() {
                    check_range(
                        path,
                        &format!("measurement.calibration_levels[{i}]"),
                        *l,
                        0.01,
                        10.0,
                    )?;
                }
            }
        }
        Ok(())
    }

    /// Check keys that depend on the controller period `period_s`.
    pub fn check_period(&self, path: &Path, period_s: f64) -> Result<(), ConfigError> {
        match *self {
            MeasurementSpec::Dynamometer { window_s, .. } => {
                check_range(path, "measurement.window_s", window_s, 0.0, period_s)?;
            }
            MeasurementSpec::SpindlePower(spec) => {
                check_range(path, "measurement.window_s", spec.window_s, 0.0, period_s)?;
            }
        }
        Ok(())
    }
}

/// `force_model` key.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ForceModelSpec {
    /// Mean force (eq. 1).
    #[default]
    Mean,
    /// Tooth-level force (seed 004).
    Tooth,
}

/// `[summary]` table.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SummarySpec {
    /// Time after entering a segment before its statistics count as settled, s
    /// (default 1.5).
    #[serde(default = "default_settle")]
    pub settle_s: f64,
}

pub(super) fn default_settle() -> f64 {
    1.5
}

/// `[nc]` table: the NC context the simulated board reports in its v2 registers
/// (`TOOL_NUMBER`, `PROGRAM_NUMBER`, `BLOCK_NUMBER`). All keys optional; numbers are read
/// wide so that a negative or too large value gets a range error naming the key.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NcSpec {
    /// Active tool (T word), 0…65535 (default 1).
    #[serde(default = "default_tool_number")]
    pub tool_number: i64,
    /// Running program (O number), 0…65535 (default 1000).
    #[serde(default = "default_program_number")]
    pub program_number: i64,
    /// N-word step between the workpiece's segments: segment `i` (0-based) runs as block
    /// `block_step × (i + 1)`, 1…1000 (default 10).
    #[serde(default = "default_block_step")]
    pub block_step: i64,
    /// Tool changes along the path, `[[nc.tool_change]]` with `x_mm` (tool-centre position,
    /// mm, -1e5..=1e5, increasing) and `tool` (0…65535); at most 16.
    #[serde(default)]
    pub tool_change: Vec<ToolChangeSpec>,
}

/// One `[[nc.tool_change]]` entry.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToolChangeSpec {
    /// Tool-centre position from which `tool` is reported, mm.
    pub x_mm: f64,
    /// Tool number reported from there on.
    pub tool: i64,
}

/// `[tools]` table: the shop tool table the production loop runs with.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToolsSpec {
    /// Tool table file, relative to the scenario (see `configs/tooltable.toml`).
    pub file: PathBuf,
    /// Whether `acc compare`'s baselines run with the tool table's entry control too
    /// (default false: only "ours"; the tool table's Fr applies to every law either way).
    #[serde(default)]
    pub baselines: bool,
}

pub(super) fn default_tool_number() -> i64 {
    i64::from(crate::board::NcContext::default().tool_number)
}

pub(super) fn default_program_number() -> i64 {
    i64::from(crate::board::NcContext::default().program_number)
}

pub(super) fn default_block_step() -> i64 {
    i64::from(crate::board::NcContext::default().block_step)
}

impl Default for NcSpec {
    fn default() -> Self {
        NcSpec {
            tool_number: default_tool_number(),
            program_number: default_program_number(),
            block_step: default_block_step(),
            tool_change: Vec::new(),
        }
    }
}

impl NcSpec {
    /// Check the ranges (errors name `file` and `nc.<key>`) and convert.
    pub fn resolve(&self, file: &Path) -> Result<crate::board::NcContext, ConfigError> {
        let get = |key: &str, v: i64, lo: u16, hi: u16| -> Result<u16, ConfigError> {
            // i64 → f64 is exact for every value in range; outside it the error shows it.
            check_range(file, key, v as f64, f64::from(lo), f64::from(hi))?;
            Ok(u16::try_from(v).unwrap_or(hi))
        };
        let max = crate::board::NcContext::MAX_TOOL_CHANGES;
        if self.tool_change.len() > max {
            return Err(ConfigError::Invalid {
                file: file.to_path_buf(),
                key: "nc.tool_change".into(),
                message: format!("{} entries: allowed at most {max}", self.tool_change.len()),
            });
        }
        let mut tool_changes = [None; crate::board::NcContext::MAX_TOOL_CHANGES];
        let mut prev = f64::NEG_INFINITY;
        for (i, c) in self.tool_change.iter().enumerate() {
            let lo = if prev.is_finite() { prev } else { -1e5 };
            let x = check_range(file, &format!("nc.tool_change[{i}].x_mm"), c.x_mm, lo, 1e5)?;
            prev = x;
            tool_changes[i] = Some(crate::board::ToolChange {
                x_um: (x * 1000.0).round() as i64,
                tool: get(&format!("nc.tool_change[{i}].tool"), c.tool, 0, u16::MAX)?,
            });
        }
        Ok(crate::board::NcContext {
            tool_number: get("nc.tool_number", self.tool_number, 0, u16::MAX)?,
            program_number: get("nc.program_number", self.program_number, 0, u16::MAX)?,
            block_step: get("nc.block_step", self.block_step, 1, 1000)?,
            tool_changes,
        })
    }
}

impl Default for SummarySpec {
    fn default() -> Self {
        SummarySpec {
            settle_s: default_settle(),
        }
    }
}

/// A scenario file as written.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// Name for summaries and plots.
    pub name: String,
    /// Machine file, relative to the scenario (with `tool`; or `model` instead of both).
    #[serde(default)]
    pub machine: Option<PathBuf>,
    /// Tool file, relative to the scenario (with `machine`).
    #[serde(default)]
    pub tool: Option<PathBuf>,
    /// Model file (`acc discrepancy`'s `model.updated.toml`), relative to the scenario: its
    /// `[machine]` and `[tool]` tables stand for the machine and tool files.
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// Workpiece file, relative to the scenario.
    pub workpiece: PathBuf,
    /// Controller preset, relative to the scenario.
    pub controller: PathBuf,
    /// RNG seed of the measurement noise.
    pub seed: u64,
    /// Programmed feed of the NC block, mm/min (paper: 200).
    pub programmed_feed_mm_min: f64,
    /// Force model (default `mean`).
    #[serde(default)]
    pub force_model: ForceModelSpec,
    /// Stop after this much simulated time even if the path is not finished, s
    /// (default 600).
    #[serde(default = "default_max_time")]
    pub max_time_s: f64,
    /// Measurement channel (default: dynamometer).
    #[serde(default)]
    pub measurement: MeasurementSpec,
    /// Tool wear, replacing the tool file's `[wear]` (default: the tool's).
    #[serde(default)]
    pub wear: Option<WearSpec>,
    /// Summary settings.
    #[serde(default)]
    pub summary: SummarySpec,
    /// Fault policy of the production loop (`acc run`'s `[policy]` keys, all optional; the
    /// overload limit defaults to 2 × Fr, the override range to the preset's).
    #[serde(default)]
    pub policy: acc_runtime::config::PolicySection,
    /// NC context of the simulated board (tool, program, block numbering).
    #[serde(default)]
    pub nc: NcSpec,
    /// Shop tool table (`[tools] file = "..."`): per-tool limits by `TOOL_NUMBER` and entry
    /// control in the production loop (default: none, the preset's Fr for every tool).
    #[serde(default)]
    pub tools: Option<ToolsSpec>,
    /// A tool breakage event (`[breakage] at_s`, `force_factor`), default none.
    #[serde(default)]
    pub breakage: Option<BreakageSpec>,
    /// Wear and breakage watch limits (`[watch]`, acc run's keys; `history` is ignored
    /// here: `acc sim --history`).
    #[serde(default)]
    pub watch: acc_runtime::watch::WatchSection,
}

/// `[breakage]` table of a scenario: the tool breaks at `at_s` and the cutting force is
/// multiplied by `force_factor` from then on (wear and breakage watch, docs/shop.md).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BreakageSpec {
    /// Machine time of the break, s (0..=86400).
    pub at_s: f64,
    /// Force multiplier after the break, 1 (0..=10; default 0.05: the tool is gone and only
    /// rubs; above 1: a spike).
    #[serde(default = "default_breakage_factor")]
    pub force_factor: f64,
}

pub(super) fn default_breakage_factor() -> f64 {
    0.05
}

impl BreakageSpec {
    /// Check the ranges (errors name `file` and `breakage.<key>`).
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        check_range(file, "breakage.at_s", self.at_s, 0.0, 86_400.0)?;
        check_range(file, "breakage.force_factor", self.force_factor, 0.0, 10.0)?;
        Ok(())
    }
}

pub(super) fn default_max_time() -> f64 {
    600.0
}

/// A file named by scenario key `key` could not be read: say which key named it. Errors
/// inside the named file already name that file and its key, and pass through unchanged.
pub(super) fn named(scenario: &Path, key: &str, e: ConfigError) -> ConfigError {
    match e {
        ConfigError::Io { .. } => ConfigError::Invalid {
            file: scenario.to_path_buf(),
            key: key.to_string(),
            message: e.to_string(),
        },
        other => other,
    }
}

/// The `[machine]` and `[tool]` tables of a model file (`configs/models/*.toml`,
/// `model.updated.toml`), which are the simulator's machine and tool files key for key.
/// Its other tables (`name`, `[measurement]`, `[effects.*]`) belong to `acc discrepancy`
/// and are ignored here: effects the simulator has no key for are not simulated.
#[derive(Debug, Clone, Deserialize)]
pub(super) struct ModelTables {
    machine: MachineSpec,
    tool: ToolSpec,
}

/// Prefix the key of a validation error with the model-file table it came from.
pub(super) fn in_table(table: &str, e: ConfigError) -> ConfigError {
    match e {
        ConfigError::OutOfRange(e) => ConfigError::OutOfRange(e.prefixed(table)),
        ConfigError::Invalid { file, key, message } => ConfigError::Invalid {
            file,
            key: format!("{table}.{key}"),
            message,
        },
        other => other,
    }
}

/// Load the machine (`[machine]`) and tool (`[tool]`) of a model file and validate them
/// as the simulator's machine and tool files; errors name the model file and the dotted
/// key (`machine.spindle.rpm`, `tool.wear.growth_per_cm3`, ...). The model's other tables
/// are not read.
pub fn load_model(path: impl AsRef<Path>) -> Result<(MachineSpec, ToolSpec), ConfigError> {
    let path = path.as_ref();
    let m: ModelTables = load_toml(path)?;
    m.machine
        .validate(path)
        .map_err(|e| in_table("machine", e))?;
    m.tool.validate(path).map_err(|e| in_table("tool", e))?;
    Ok((m.machine, m.tool))
}

/// The machine and tool of a scenario file: from `machine` + `tool`, or from `model`
/// (exactly one of the two forms).
pub(super) fn machine_and_tool(
    path: &Path,
    file: &ScenarioFile,
) -> Result<(MachineSpec, ToolSpec), ConfigError> {
    let invalid = |key: &str, message: &str| ConfigError::Invalid {
        file: path.to_path_buf(),
        key: key.to_string(),
        message: message.to_string(),
    };
    match (&file.machine, &file.tool, &file.model) {
        (Some(m), Some(t), None) => {
            let machine =
                MachineSpec::load(resolve_relative(path, m)).map_err(|e| named(path, "machine", e))?;
            let tool = ToolSpec::load(resolve_relative(path, t)).map_err(|e| named(path, "tool", e))?;
            Ok((machine, tool))
        }
        (None, None, Some(model)) => {
            load_model(resolve_relative(path, model)).map_err(|e| named(path, "model", e))
        }
        (_, _, Some(_)) => Err(invalid(
            "model",
            "give either `model` (a model file with [machine] and [tool]) or `machine` and `tool`, not both",
        )),
        (None, None, None) => Err(invalid(
            "machine",
            "missing: give `machine` and `tool` (machine and tool files) or `model` (a model file with [machine] and [tool])",
        )),
        (None, Some(_), None) => Err(invalid(
            "machine",
            "missing: `tool` needs `machine` (or give `model` instead of both)",
        )),
        (Some(_), None, None) => Err(invalid(
            "tool",
            "missing: `machine` needs `tool` (or give `model` instead of both)",
        )),
    }
}
