//! Scenario files (`configs/scenarios/*.toml`): machine, tool, workpiece, controller preset,
//! measurement channel and seed, with every path relative to the scenario file.
//!
//! [`file`] holds the file's tables and their validation; this module loads a scenario,
//! resolves its files and builds its board, channel and laws.

use std::path::{Path, PathBuf};

use acc_config::{check_range, load_toml, resolve_relative, ConfigError};
use acc_core::{Controller, ControllerConfig, ModeConfig, OverrideLaw, OverrideSpec};

use crate::baselines::{ConstantFeed, Proportional, RateLimited};
use crate::board::SimBoard;
use crate::channel::{Dynamometer, MeasurementChannel, WindowedChannel};
use crate::config::{MachineSpec, ToolSpec};
use crate::machine::{ForceModel, Machine};
use crate::process::WearSpec;
use crate::workpiece::Workpiece;
use crate::SimError;

pub mod file;
pub use file::*;
use file::{machine_and_tool, named};

#[cfg(test)]
mod tests;

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
        self.use_machine_and_tool(model, machine, tool)
    }

    /// Replace the machine, the tool and the wear by `machine` and `tool` (its `[wear]`),
    /// read from the model file `model` (named in errors): the tool must fit the scenario's
    /// workpiece and the machine's override step the controller's grid.
    pub fn use_machine_and_tool(
        &mut self,
        model: &Path,
        machine: MachineSpec,
        tool: ToolSpec,
    ) -> Result<(), ConfigError> {
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

    /// The fresh simulated machine behind this scenario's board: machine, tool, wear,
    /// workpiece, force model, programmed feed and the `[breakage]` event.
    pub fn build_machine(&self) -> Machine {
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
        machine
    }

    /// A fresh simulated board (protocol v2) with the machine behind it.
    pub fn build_board(&self) -> SimBoard {
        self.build_board_with(acc_pmc::emu::EmulatedProtocol::V2)
    }

    /// A fresh simulated board speaking `protocol` with the machine behind it.
    pub fn build_board_with(&self, protocol: acc_pmc::emu::EmulatedProtocol) -> SimBoard {
        let machine = self.build_machine();
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
