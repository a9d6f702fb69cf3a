//! Scenario files (`configs/scenarios/*.toml`): machine, tool, workpiece, controller preset,
//! measurement channel and seed, with every path relative to the scenario file.

use std::path::{Path, PathBuf};

use acc_config::{check_range, load_toml, resolve_relative, ConfigError};
use acc_core::{Controller, ControllerConfig, ModeConfig, OverrideLaw, OverrideSpec};
use serde::Deserialize;

use crate::baselines::{ConstantFeed, Proportional, RateLimited};
use crate::board::SimBoard;
use crate::channel::{Dynamometer, MeasurementChannel, WindowedChannel};
use crate::config::{MachineSpec, ToolSpec};
use crate::machine::{ForceModel, Machine};
use crate::process::WearSpec;
use crate::workpiece::Workpiece;
use crate::SimError;

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

fn default_noise() -> f64 {
    5.0
}

fn default_window() -> f64 {
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

fn default_settle() -> f64 {
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

fn default_tool_number() -> i64 {
    i64::from(crate::board::NcContext::default().tool_number)
}

fn default_program_number() -> i64 {
    i64::from(crate::board::NcContext::default().program_number)
}

fn default_block_step() -> i64 {
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

fn default_breakage_factor() -> f64 {
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

fn default_max_time() -> f64 {
    600.0
}

/// A file named by scenario key `key` could not be read: say which key named it. Errors
/// inside the named file already name that file and its key, and pass through unchanged.
fn named(scenario: &Path, key: &str, e: ConfigError) -> ConfigError {
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
struct ModelTables {
    machine: MachineSpec,
    tool: ToolSpec,
}

/// Prefix the key of a validation error with the model-file table it came from.
fn in_table(table: &str, e: ConfigError) -> ConfigError {
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
fn machine_and_tool(
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

/// A loaded, validated scenario.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Scenario file.
    pub path: PathBuf,
    /// Name.
    pub name: String,
    /// Machine.
    pub machine: MachineSpec,
    /// Tool.
    pub tool: ToolSpec,
    /// Wear in effect.
    pub wear: WearSpec,
    /// Workpiece.
    pub workpiece: Workpiece,
    /// Controller configuration (the scenario's "ours").
    pub controller: ControllerConfig,
    /// Seed.
    pub seed: u64,
    /// Programmed feed, mm/min.
    pub programmed_feed_mm_min: f64,
    /// Force model.
    pub force_model: ForceModel,
    /// Time limit, s.
    pub max_time_s: f64,
    /// Measurement channel.
    pub measurement: MeasurementSpec,
    /// Settling time for the summary, s.
    pub settle_s: f64,
    /// Fault policy the production loop runs with (validated).
    pub policy: acc_runtime::PolicyConfig,
    /// NC context the simulated board reports (`[nc]`, validated).
    pub nc: crate::board::NcContext,
    /// The shop tool table (`[tools] file`), if any.
    pub tools: Option<acc_config::ToolTable>,
    /// `[tools] baselines`: the baselines of `acc compare` run with the tool table's entry
    /// control too.
    pub tools_for_baselines: bool,
    /// Tool breakage event (`[breakage]`, validated), if any.
    pub breakage: Option<BreakageSpec>,
    /// Wear and breakage limits the fault policy runs with (`[watch]`, validated).
    pub watch: acc_runtime::watch::WatchLimits,
}

/// The laws `acc compare` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LawKind {
    /// The scenario's controller preset.
    Ours,
    /// 100 % throughout.
    ConstantFeed,
    /// The constant override that keeps the deepest, hardest section at Fr with the tool
    /// as it starts ([`Scenario::safe_override_pct`]): what a programmer without ACC runs.
    ConstantSafeFeed,
    /// The paper's fixed-gain PI (Ki = 2.5, Kp = 0.05) with the scenario's T, Fr and board.
    FixedGainPi,
    /// Haas-Autofeed-like rate-limited law.
    RateLimited,
    /// ToolScope-like proportional law.
    Proportional,
}

impl LawKind {
    /// All laws in table order (ours last).
    pub const ALL: [LawKind; 6] = [
        LawKind::ConstantFeed,
        LawKind::ConstantSafeFeed,
        LawKind::FixedGainPi,
        LawKind::RateLimited,
        LawKind::Proportional,
        LawKind::Ours,
    ];
}

/// The preset's override step must be a multiple of the machine's board step; the error
/// names `file` and `key`.
fn check_board_step(
    file: &Path,
    key: &str,
    controller: &ControllerConfig,
    machine: &MachineSpec,
) -> Result<(), ConfigError> {
    let board_step = machine.override_path.step_pct;
    if !controller.override_spec.step_pct.is_multiple_of(board_step) {
        return Err(ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.into(),
            message: format!(
                "the preset's override step {} % is not a multiple of the machine's board step {} % (override_path.step_pct)",
                controller.override_spec.step_pct, board_step
            ),
        });
    }
    Ok(())
}

impl Scenario {
    /// Load a scenario and everything it names (controller presets through
    /// `acc_config::load_controller`). Every error names the file and key.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        Self::load_with(path, |p| acc_config::load_controller(p))
    }

    /// Load a scenario and everything it names, using `load_preset` for the controller
    /// preset. Every error names the file and key.
    pub fn load_with(
        path: impl AsRef<Path>,
        load_preset: impl Fn(&Path) -> Result<ControllerConfig, ConfigError>,
    ) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let file: ScenarioFile = load_toml(path)?;
        check_range(
            path,
            "programmed_feed_mm_min",
            file.programmed_feed_mm_min,
            1.0,
            60_000.0,
        )?;
        check_range(path, "max_time_s", file.max_time_s, 0.1, 86_400.0)?;
        check_range(path, "summary.settle_s", file.summary.settle_s, 0.0, 600.0)?;
        file.measurement.validate(path)?;
        let (machine, tool) = machine_and_tool(path, &file)?;
        let wp_path = resolve_relative(path, &file.workpiece);
        let workpiece = Workpiece::load(&wp_path).map_err(|e| named(path, "workpiece", e))?;
        workpiece.check_tool(&wp_path, tool.diameter_mm)?;
        let wear = match file.wear {
            Some(w) => {
                w.validate(path, "wear")?;
                w
            }
            None => tool.wear,
        };
        let controller = load_preset(&resolve_relative(path, &file.controller))
            .map_err(|e| named(path, "controller", e))?;
        check_board_step(path, "controller", &controller, &machine)?;
        file.measurement.check_period(path, controller.period_s)?;
        let policy = file.policy.resolve_in(path, &controller)?;
        let nc = file.nc.resolve(path)?;
        let tools = match &file.tools {
            Some(t) => {
                let p = resolve_relative(path, &t.file);
                Some(
                    acc_config::ToolTable::load(&p)
                        .map_err(|e| acc_config::referenced(path, "tools.file", &t.file, e))?,
                )
            }
            None => None,
        };
        let tools_for_baselines = file.tools.as_ref().is_some_and(|t| t.baselines);
        if let Some(b) = &file.breakage {
            b.validate(path)?;
        }
        Ok(Scenario {
            path: path.to_path_buf(),
            name: file.name,
            machine,
            tool,
            wear,
            workpiece,
            controller,
            seed: file.seed,
            programmed_feed_mm_min: file.programmed_feed_mm_min,
            force_model: match file.force_model {
                ForceModelSpec::Mean => ForceModel::Mean,
                ForceModelSpec::Tooth => ForceModel::Tooth,
            },
            max_time_s: file.max_time_s,
            measurement: file.measurement,
            settle_s: file.summary.settle_s,
            policy,
            nc,
            tools,
            tools_for_baselines,
            breakage: file.breakage,
            watch: file.watch.resolve(path)?,
        })
    }

    /// Replace the machine and tool by those of the model file `model` (`acc sim --model`):
    /// the model's tool wear replaces the scenario's `[wear]` too, so an updated model runs
    /// as identified. Errors name the model file and key.
    pub fn use_model(&mut self, model: impl AsRef<Path>) -> Result<(), ConfigError> {
        let model = model.as_ref();
        let (machine, tool) = load_model(model)?;
        if let Err(e) = self.workpiece.check_tool(&self.path, tool.diameter_mm) {
            return Err(ConfigError::Invalid {
                file: model.to_path_buf(),
                key: "tool.diameter_mm".into(),
                message: format!("too small for the scenario's workpiece: {e}"),
            });
        }
        check_board_step(
            model,
            "machine.override_path.step_pct",
            &self.controller,
            &machine,
        )?;
        self.wear = tool.wear;
        self.machine = machine;
        self.tool = tool;
        Ok(())
    }

    /// The largest override (a multiple of the board step, at least one step) at which the
    /// mean force (eq. 1) stays at or below Fr in the deepest, hardest section, with the
    /// tool's initial wear factor and the commanded spindle speed: the feed an NC
    /// programmer without ACC would choose from the same cutting data.
    pub fn safe_override_pct(&self) -> u16 {
        let law = crate::process::ForceLaw::new(self.tool.process);
        let ks_max = self
            .workpiece
            .segments
            .iter()
            .filter(|s| s.is_cut())
            .map(|s| s.ks_factor)
            .fold(0.0, f64::max);
        let spec = self.controller.override_spec;
        let step = spec.step_pct.max(1);
        let force_at = |pct: u16| {
            law.mean_force_n(
                self.workpiece.max_depth_mm().min(self.tool.diameter_mm),
                self.workpiece.axial_depth_mm,
                self.programmed_feed_mm_min * f64::from(pct) / 100.0,
                self.machine.spindle.rpm,
                ks_max * self.wear.initial_factor,
            )
        };
        let mut pct = spec.max_pct - spec.max_pct % step;
        while pct > step && force_at(pct) > self.controller.force_ref_n {
            pct -= step;
        }
        pct.max(step)
    }

    /// The board's override spec as the controller sees it.
    pub fn override_spec(&self) -> OverrideSpec {
        self.controller.override_spec
    }

    /// A fresh simulated board (protocol v2) with the machine behind it.
    pub fn build_board(&self) -> SimBoard {
        self.build_board_with(acc_pmc::emu::EmulatedProtocol::V2)
    }

    /// A fresh simulated board speaking `protocol` with the machine behind it.
    pub fn build_board_with(&self, protocol: acc_pmc::emu::EmulatedProtocol) -> SimBoard {
        let mut machine = Machine::new(
            &self.machine,
            &self.tool,
            self.wear,
            self.workpiece.clone(),
            self.force_model,
            self.programmed_feed_mm_min,
        );
        if let Some(b) = self.breakage {
            machine.set_breakage(b.at_s, b.force_factor);
        }
        let mut board =
            SimBoard::with_protocol(machine, self.machine.override_path.step_pct, protocol);
        board.set_nc_context(self.nc);
        board
    }

    /// A fresh measurement channel seeded with the scenario's seed (a spindle-power
    /// channel is calibrated here, as it would be commissioned).
    pub fn build_channel(&self) -> Result<Box<dyn MeasurementChannel>, SimError> {
        Ok(match self.measurement {
            MeasurementSpec::Dynamometer {
                noise_n,
                lowpass_hz,
                window_s,
            } => Box::new(WindowedChannel::new(
                Dynamometer::new(noise_n, lowpass_hz, self.seed),
                window_s,
            )),
            MeasurementSpec::SpindlePower(spec) => {
                let law = crate::process::ForceLaw::new(self.tool.process);
                let channel = crate::motor::SpindlePowerChannel::calibrated_for(
                    &spec,
                    &self.machine.spindle,
                    self.seed,
                    law.torque_nm(1.0, self.tool.radius_mm()),
                    self.controller.force_ref_n,
                    self.tool.radius_mm(),
                    self.controller.period_s,
                )
                .map_err(|e| SimError::Channel(e.to_string()))?;
                Box::new(channel)
            }
        })
    }

    /// Build one of the laws on this scenario's period, reference and board.
    pub fn build_law(&self, kind: LawKind) -> Result<Box<dyn OverrideLaw>, SimError> {
        let c = &self.controller;
        Ok(match kind {
            LawKind::Ours => Box::new(Controller::new(*c)?),
            LawKind::FixedGainPi => Box::new(Controller::new(ControllerConfig {
                mode: ModeConfig::FixedPi { kp: 0.05, ki: 2.5 },
                ..*c
            })?),
            LawKind::ConstantFeed => Box::new(ConstantFeed::new(c.override_spec, c.force_ref_n)),
            LawKind::ConstantSafeFeed => Box::new(ConstantFeed::at(
                c.override_spec,
                c.force_ref_n,
                self.safe_override_pct(),
                "constant-safe",
            )),
            LawKind::RateLimited => {
                Box::new(RateLimited::new(c.override_spec, c.force_ref_n, c.period_s))
            }
            LawKind::Proportional => Box::new(Proportional::new(c.override_spec, c.force_ref_n)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Write `tool_wear.toml` with its `machine`/`tool` lines replaced by `keys` into a temp
    /// dir next to absolute paths of the other files; returns the dir and the scenario path.
    fn scenario_with(keys: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = crate::run::configs_dir();
        let c = |rel: &str| cfg.join(rel).display().to_string();
        let text = format!(
            "name = \"t\"\n{keys}\nworkpiece = '{}'\ncontroller = '{}'\nseed = 1\nprogrammed_feed_mm_min = 200.0\n",
            c("workpieces/long_cut.toml"),
            c("presets/case3.toml")
        );
        let path = dir.path().join("s.toml");
        std::fs::write(&path, text).expect("write scenario");
        (dir, path)
    }

    fn key_of(e: &ConfigError) -> &str {
        match e {
            ConfigError::Invalid { key, .. }
            | ConfigError::OutOfRange(acc_config::RangeError { key, .. }) => key,
            other => panic!("expected a keyed error, got {other}"),
        }
    }

    #[test]
    fn model_key_gives_the_same_machine_and_tool_as_the_two_files() {
        let cfg = crate::run::configs_dir();
        let (_d1, files) = scenario_with(&format!(
            "machine = '{}'\ntool = '{}'",
            cfg.join("machines/paper_vmc.toml").display(),
            cfg.join("machines/tools/hss_endmill_16_4f.toml").display()
        ));
        let (_d2, model) = scenario_with(&format!(
            "model = '{}'",
            cfg.join("models/paper_vmc.toml").display()
        ));
        let a = Scenario::load(&files).expect("machine + tool load");
        let b = Scenario::load(&model).expect("model loads");
        assert_eq!(a.machine.spindle, b.machine.spindle);
        assert_eq!(a.machine.feed_drive, b.machine.feed_drive);
        assert_eq!(a.machine.override_path, b.machine.override_path);
        assert_eq!(a.tool.process, b.tool.process);
        assert_eq!(a.tool.diameter_mm, b.tool.diameter_mm);
        assert_eq!(b.wear, b.tool.wear);
    }

    #[test]
    fn both_forms_neither_or_half_are_errors_naming_the_key() {
        let cfg = crate::run::configs_dir();
        let m = cfg.join("machines/paper_vmc.toml").display().to_string();
        let t = cfg
            .join("machines/tools/hss_endmill_16_4f.toml")
            .display()
            .to_string();
        let md = cfg.join("models/paper_vmc.toml").display().to_string();
        let cases = [
            (
                format!("machine = '{m}'\ntool = '{t}'\nmodel = '{md}'"),
                "model",
                "not both",
            ),
            (format!("model = '{md}'\ntool = '{t}'"), "model", "not both"),
            (String::new(), "machine", "`model`"),
            (format!("tool = '{t}'"), "machine", "missing"),
            (format!("machine = '{m}'"), "tool", "missing"),
        ];
        for (keys, key, words) in cases {
            let (_d, path) = scenario_with(&keys);
            let e = Scenario::load(&path).expect_err(&keys);
            assert_eq!(key_of(&e), key, "{keys}: {e}");
            let text = e.to_string();
            assert!(
                text.contains("s.toml") && text.contains(words),
                "{keys}: {text}"
            );
        }
    }

    #[test]
    fn missing_or_bad_model_file_names_the_file_and_key() {
        let (dir, path) = scenario_with("model = 'no_such_model.toml'");
        let e = Scenario::load(&path).expect_err("missing model file");
        assert_eq!(key_of(&e), "model");
        assert!(e.to_string().contains("no_such_model.toml"), "{e}");

        // A value out of range inside the model file: the model file and the dotted key.
        let good = std::fs::read_to_string(crate::run::configs_dir().join("models/paper_vmc.toml"))
            .expect("model file");
        let bad = good.replace("tau_s = 0.008", "tau_s = 5.0");
        assert_ne!(bad, good);
        std::fs::write(dir.path().join("no_such_model.toml"), bad).expect("write model");
        let e = Scenario::load(&path).expect_err("bad model file");
        assert_eq!(key_of(&e), "machine.feed_drive.tau_s", "{e}");
        assert!(e.to_string().contains("no_such_model.toml"), "{e}");
    }

    #[test]
    fn use_model_replaces_machine_tool_and_wear() {
        let cfg = crate::run::configs_dir();
        let mut sc = Scenario::load(cfg.join("scenarios/tool_wear.toml")).expect("scenario");
        assert!(sc.wear.growth_per_cm3 > 0.0, "the scenario's [wear] is on");
        let model = cfg.join("models/paper_vmc.toml");
        sc.use_model(&model).expect("model applies");
        assert_eq!(
            sc.wear.growth_per_cm3, 0.0,
            "the model's (wear-free) tool wins"
        );
        assert_eq!(sc.machine.feed_drive.tau_s, 0.008);

        let dir = tempfile::tempdir().expect("temp dir");
        let small = dir.path().join("m.toml");
        let text = std::fs::read_to_string(&model)
            .expect("model file")
            .replace("diameter_mm = 16.0", "diameter_mm = 2.0");
        std::fs::write(&small, text).expect("write model");
        let e = sc.use_model(&small).expect_err("tool smaller than the cut");
        assert_eq!(key_of(&e), "tool.diameter_mm", "{e}");
    }
}
