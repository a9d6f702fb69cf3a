//! The run configuration of `acc run` (`configs/runtime/*.toml`): board link, controller
//! preset, force source, fault policy and runtime options, read once and validated before
//! anything is opened or sent. Every error names the file, the key and the allowed range.

use std::path::{Path, PathBuf};

use acc_config::{
    check_range, from_table, load_toml_with, referenced, resolve_relative, ConfigError, KeyRange,
};
use acc_core::spindle_force::{EstimatorConfig, SpindleEstimator, SpindleInput, SpindleSource};
use acc_core::ControllerConfig;
use acc_pmc::can::{CanConfig, CanLinkConfig};
use acc_pmc::regs::FallbackMode;
use acc_pmc::serial::{RtuConfig, RtuSettings};
use acc_spindle::calibrate::SpindleCalibration;
use serde::Deserialize;

use crate::policy::PolicyConfig;

mod telemetry;

pub use telemetry::{
    parse_shdr_addr, MqttSection, MqttSettings, TelemetryConfig, TelemetrySection,
};

/// `[force]`: spindle power from the board → cutting force (acc-core's `spindle_force`
/// estimator on `POWER_HI:POWER_LO`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ForceSection {
    /// Spindle calibration file (no-load model and constants), relative to the run config.
    pub calibration: PathBuf,
    /// Estimator settings (`method`, `tool_radius_mm`, `no_load`, …;
    /// `acc_core::spindle_force::EstimatorConfig`, defaults there).
    #[serde(default)]
    pub estimator: EstimatorConfig,
}

/// `[policy]`: fault policy and operator priority; every key optional (defaults in
/// [`PolicyConfig`]).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct PolicySection {
    /// See [`PolicyConfig::min_override_pct`].
    pub min_override_pct: Option<u16>,
    /// See [`PolicyConfig::max_override_pct`].
    pub max_override_pct: Option<u16>,
    /// See [`PolicyConfig::link_hold_periods`].
    pub link_hold_periods: Option<u32>,
    /// See [`PolicyConfig::invalid_power_periods`].
    pub invalid_power_periods: Option<u32>,
    /// See [`PolicyConfig::stale_seq_periods`].
    pub stale_seq_periods: Option<u32>,
    /// See [`PolicyConfig::ack_periods`].
    pub ack_periods: Option<u32>,
    /// See [`PolicyConfig::overload_force_n`].
    pub overload_force_n: Option<f64>,
    /// See [`PolicyConfig::overload_time_s`].
    pub overload_time_s: Option<f64>,
    /// See [`PolicyConfig::operator_handback_pct`].
    pub operator_handback_pct: Option<u16>,
    /// See [`PolicyConfig::max_power_w`].
    pub max_power_w: Option<f64>,
    /// See [`PolicyConfig::nominal_feed_mm_min`].
    pub nominal_feed_mm_min: Option<f64>,
    /// See [`PolicyConfig::hold_on_raising_release`].
    pub hold_on_raising_release: Option<bool>,
    /// See [`PolicyConfig::debounce_reads`].
    pub debounce_reads: Option<u32>,
    /// See [`PolicyConfig::max_power_step_w`].
    pub max_power_step_w: Option<f64>,
    /// See [`PolicyConfig::max_rpm_step`].
    pub max_rpm_step: Option<f64>,
}

impl PolicySection {
    /// The policy for `controller`: every key not given takes its default, except the
    /// override range (the preset's `[override]` range), the overload limit (2 × Fr) and the
    /// period (the preset's T). Validate the result with [`PolicyConfig::validate`].
    pub fn resolve(&self, controller: &acc_core::ControllerConfig) -> PolicyConfig {
        let p = self;
        let d = PolicyConfig::default();
        PolicyConfig {
            period_s: controller.period_s,
            min_override_pct: p
                .min_override_pct
                .unwrap_or(controller.override_spec.min_pct),
            max_override_pct: p
                .max_override_pct
                .unwrap_or(controller.override_spec.max_pct),
            link_hold_periods: p.link_hold_periods.unwrap_or(d.link_hold_periods),
            invalid_power_periods: p.invalid_power_periods.unwrap_or(d.invalid_power_periods),
            stale_seq_periods: p.stale_seq_periods.unwrap_or(d.stale_seq_periods),
            ack_periods: p.ack_periods.unwrap_or(d.ack_periods),
            overload_force_n: p.overload_force_n.unwrap_or(2.0 * controller.force_ref_n),
            overload_time_s: p.overload_time_s.unwrap_or(d.overload_time_s),
            operator_handback_pct: p.operator_handback_pct.unwrap_or(d.operator_handback_pct),
            max_power_w: p.max_power_w.unwrap_or(d.max_power_w),
            nominal_feed_mm_min: p.nominal_feed_mm_min.unwrap_or(d.nominal_feed_mm_min),
            hold_on_raising_release: p
                .hold_on_raising_release
                .unwrap_or(d.hold_on_raising_release),
            debounce_reads: p.debounce_reads.unwrap_or(d.debounce_reads),
            max_power_step_w: p.max_power_step_w.unwrap_or(d.max_power_step_w),
            max_rpm_step: p.max_rpm_step.unwrap_or(d.max_rpm_step),
        }
    }
}

impl PolicySection {
    /// [`PolicySection::resolve`] and validate; an error names `file`, the key under
    /// `policy.` and the allowed range.
    pub fn resolve_in(
        &self,
        file: &Path,
        controller: &acc_core::ControllerConfig,
    ) -> Result<PolicyConfig, ConfigError> {
        let policy = self.resolve(controller);
        policy
            .validate()
            .map_err(|e| ConfigError::OutOfRange(e.prefixed("policy").in_file(file)))?;
        Ok(policy)
    }
}

/// `[shutdown]`: what Ctrl-C / SIGTERM does in the middle of a cut (all keys optional).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ShutdownSection {
    /// Longest drain after a stop request, s of machine time, 0 ..= 600 (default 10).
    pub drain_s: Option<f64>,
    /// Consecutive periods out of the cut that end the drain, 1 ..= 1000 (default 5).
    pub air_periods: Option<u32>,
    /// A valid force sample below this is out of the cut, N, 0 ..= Fr (default 0.2·Fr).
    pub air_force_n: Option<f64>,
}

/// The resolved `[shutdown]` settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShutdownConfig {
    /// Longest drain, s of machine time.
    pub drain_s: f64,
    /// Consecutive periods out of the cut that end the drain.
    pub air_periods: u32,
    /// Air threshold on the force estimate, N.
    pub air_force_n: f64,
}

/// `[runtime]`: loop options.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RuntimeSection {
    /// Machine seconds per wall second, 0.1 ..= 100 (default 1). Above 1 only against an
    /// emulator running at the same scale (`acc board-sim --time-scale`): the ticker runs
    /// at `T / time_scale` while the controller keeps its `T`.
    pub time_scale: f64,
    /// Records the run logger may fall behind before the loop holds the feed, 1 ..=
    /// 1 000 000 (default 6000: ten minutes at T = 0.1 s). No record is ever dropped: see
    /// [`crate::runner`].
    pub log_buffer: usize,
    /// What a vanished board device (serial port gone, CAN interface down) does: `"exit"`
    /// (default: end after 20 periods, exit code 4) or `"reconnect"` (keep logging, reopen
    /// every period, re-arm at the last command; give up after `reconnect_timeout_s`).
    pub on_device_lost: DeviceLostAction,
    /// With `on_device_lost = "reconnect"`: longest time without the device, s of machine
    /// time, 0.1 ..= 600 (default 10).
    pub reconnect_timeout_s: f64,
}

/// `[runtime] on_device_lost`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum DeviceLostAction {
    /// End the run (exit code 4).
    #[default]
    Exit,
    /// Reopen the device every period until `reconnect_timeout_s`.
    Reconnect,
}

impl Default for RuntimeSection {
    fn default() -> Self {
        Self {
            time_scale: 1.0,
            log_buffer: 6000,
            on_device_lost: DeviceLostAction::Exit,
            reconnect_timeout_s: 10.0,
        }
    }
}

/// The allowed range of every numeric key of a run config (what the validation checks),
/// shown also when a value does not deserialize at all (`link_hold_periods = -1`,
/// `time_scale = "fast"`). `tests/paper/configs_load.rs` checks that every numeric key of the
/// shipped run configs is listed and that the limits agree with the validation.
pub const RUN_KEY_RANGES: &[KeyRange] = &[
    KeyRange::new(
        "board.baud",
        "one of [1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200]",
    ),
    KeyRange::new("board.data_bits", "8"),
    KeyRange::new("board.stop_bits", "1 or 2"),
    KeyRange::new("board.slave", "1 ..= 247"),
    KeyRange::new("board.timeout_ms", "5 ..= 2000"),
    KeyRange::new("board.retries", "0 ..= 5"),
    KeyRange::new("board.budget_ms", "timeout_ms ..= 5000"),
    KeyRange::new("board.watchdog_ms", "100 ..= 5000"),
    KeyRange::new("can.node", "1 ..= 127"),
    KeyRange::new("can.timeout_ms", "5 ..= 2000"),
    KeyRange::new("force.estimator.tool_radius_mm", "0.1 ..= 1000"),
    KeyRange::new("force.estimator.noise_floor_sigma", "0 ..= 100"),
    KeyRange::new("force.estimator.max_speed_change", "0 ..= 1"),
    KeyRange::new("force.estimator.min_rpm", "0 ..= 1e6"),
    KeyRange::new("force.estimator.negative_sigma", "0 ..= 1000"),
    KeyRange::new("policy.min_override_pct", "0 ..= max_override_pct"),
    KeyRange::new("policy.max_override_pct", "1 ..= 150"),
    KeyRange::new("policy.link_hold_periods", "1 ..= 1000"),
    KeyRange::new("policy.invalid_power_periods", "1 ..= 1000"),
    KeyRange::new("policy.stale_seq_periods", "1 ..= 1000"),
    KeyRange::new("policy.ack_periods", "1 ..= 1000"),
    KeyRange::new("policy.overload_force_n", "> 0"),
    KeyRange::new("policy.overload_time_s", ">= 0"),
    KeyRange::new("policy.operator_handback_pct", "0 ..= 150"),
    KeyRange::new("policy.max_power_w", "> 0"),
    KeyRange::new("policy.nominal_feed_mm_min", "> 0"),
    KeyRange::new("policy.debounce_reads", "1 ..= 10"),
    KeyRange::new("policy.max_power_step_w", "0 < x <= max_power_w"),
    KeyRange::new("policy.max_rpm_step", "> 0"),
    KeyRange::new("shutdown.drain_s", "0 ..= 600"),
    KeyRange::new("shutdown.air_periods", "1 ..= 1000"),
    KeyRange::new(
        "shutdown.air_force_n",
        "0 ..= Fr (the preset's force_ref_n)",
    ),
    KeyRange::new("runtime.time_scale", "0.1 ..= 100"),
    KeyRange::new("runtime.log_buffer", "1 ..= 1000000"),
    KeyRange::new("watch.history", "a file path (string)"),
    KeyRange::new("watch.breakage", "true or false"),
    KeyRange::new("watch.wear_warn_pct", "0 < x <= 1000"),
    KeyRange::new("watch.wear_limit_pct", "wear_warn_pct <= x <= 1000"),
    KeyRange::new("watch.breakage_drop_pct", "0 < x < 100"),
    KeyRange::new("watch.breakage_spike_factor", "1 < x <= 100"),
    KeyRange::new("watch.breakage_history_periods", "3 ..= 32"),
    KeyRange::new("watch.cut_force_fraction", "0 < x < 1"),
    KeyRange::new("watch.steady_band_pct", "0 < x <= 100"),
    KeyRange::new("watch.wear_window_periods", "1 ..= 10000"),
    KeyRange::new("telemetry.mqtt.qos", "0 or 1"),
];

/// The run config as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunFile {
    /// Name for logs.
    pub name: String,
    /// Controller preset, relative to this file.
    pub controller: PathBuf,
    /// Serial link to the board (acc-pmc's `RtuConfig` keys); `port` may come from `--port`.
    pub board: Option<toml::Table>,
    /// CAN link to a CAN board (acc-pmc's `CanConfig` keys); used with `--can <iface>`.
    pub can: Option<toml::Table>,
    /// Force source.
    pub force: ForceSection,
    /// Fault policy.
    #[serde(default)]
    pub policy: PolicySection,
    /// Stop on a signal in the middle of a cut.
    #[serde(default)]
    pub shutdown: ShutdownSection,
    /// Loop options.
    #[serde(default)]
    pub runtime: RuntimeSection,
    /// Wear and breakage watch, tool history (`[watch]`, all keys optional).
    #[serde(default)]
    pub watch: crate::watch::WatchSection,
    /// Shop tool table (`[tools] file = "..."`, relative to this file): per-tool limits
    /// chosen by the board's `TOOL_NUMBER` and entry control (docs/shop.md).
    pub tools: Option<ToolsRef>,
    /// Telemetry: MTConnect SHDR and MQTT (docs/telemetry.md).
    #[serde(default)]
    pub telemetry: TelemetrySection,
}

/// `[tools]` of a run config.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolsRef {
    /// Tool table file, relative to the run config (see `configs/tooltable.toml`).
    pub file: PathBuf,
}

/// Which link drives the board.
#[derive(Debug, Clone)]
pub enum LinkSettings {
    /// Modbus RTU over a serial port (`[board]`, `--port`).
    Rtu(RtuSettings),
    /// CAN over SocketCAN (`[can]`, `--can`).
    Can {
        /// Interface, e.g. `can0`.
        iface: String,
        /// Link parameters.
        link: CanLinkConfig,
    },
    /// LinuxCNC's HAL (`--hal [COMPONENT]`): acc is the userspace HAL component
    /// `component` (crate `acc-linuxcnc`); no `[board]` key is read but `fallback_mode`.
    Hal {
        /// The HAL component's name (its pins are `<component>.<pin>`), e.g. `acc`.
        component: String,
    },
}

/// The link the command line chose: `--port` (or none: `board.port`), `--can`, `--hal`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkFlag<'a> {
    /// Modbus RTU; `Some(device)` (from `--port`) replaces `board.port`.
    Serial(Option<&'a str>),
    /// CAN on this interface (`--can <iface>`), the `[can]` table's other keys.
    Can(&'a str),
    /// LinuxCNC's HAL as this component (`--hal [COMPONENT]`); the run is in real time:
    /// `runtime.time_scale` must be 1.
    Hal(&'a str),
}

/// A loaded, validated run config.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// The file.
    pub path: PathBuf,
    /// Name.
    pub name: String,
    /// Controller parameters (from the preset).
    pub controller: ControllerConfig,
    /// The link to the board (validated, not opened).
    pub link: LinkSettings,
    /// Spindle calibration.
    pub calibration: SpindleCalibration,
    /// Estimator settings.
    pub estimator: EstimatorConfig,
    /// Fault policy (period from the controller preset).
    pub policy: PolicyConfig,
    /// Shutdown drain.
    pub shutdown: ShutdownConfig,
    /// Loop options.
    pub runtime: RuntimeSection,
    /// `[board] fallback_mode`: written to a v2 board's `FALLBACK_MODE` once at start
    /// (`"clamp"` or `"clamp_and_feed_hold"`, default the latter; not written to a v1 board).
    pub fallback_mode: FallbackMode,
    /// The shop tool table (`[tools] file`), if any: loaded and validated with the config.
    pub tools: Option<acc_config::ToolTable>,
    /// Wear and breakage limits (`[watch]`, validated; defaults of
    /// [`crate::watch::WatchLimits`]).
    pub watch: crate::watch::WatchLimits,
    /// `[watch] history`: the tool-history file, relative paths resolved against the config
    /// file (`None`: `acc-history.sqlite` beside the run log).
    pub history: Option<PathBuf>,
    /// `[telemetry]`: SHDR and MQTT destinations (validated).
    pub telemetry: TelemetryConfig,
}

/// Parse `[board] fallback_mode` (`"clamp"` | `"clamp_and_feed_hold"`).
fn fallback_mode(path: &Path, value: &toml::Value) -> Result<FallbackMode, ConfigError> {
    match value.as_str() {
        Some("clamp") => Ok(FallbackMode::ClampOnly),
        Some("clamp_and_feed_hold") => Ok(FallbackMode::ClampAndFeedHold),
        _ => Err(ConfigError::Invalid {
            file: path.to_path_buf(),
            key: "board.fallback_mode".into(),
            message: format!(
                "= {value} is not allowed: one of \"clamp\" (a watchdog trip only clamps the override) or \"clamp_and_feed_hold\" (clamp and feed hold, the default)"
            ),
        }),
    }
}

impl RunConfig {
    /// Load and validate `path` for the serial link; `port` (from `--port`) replaces
    /// `board.port`.
    pub fn load(path: impl AsRef<Path>, port: Option<&str>) -> Result<Self, ConfigError> {
        Self::load_for(path, port, None)
    }

    /// Load and validate `path`; with `can` (from `--can <iface>`) the CAN link (`[can]`
    /// table, `iface` replaced) is used, otherwise the serial link with `port` replacing
    /// `board.port`.
    pub fn load_for(
        path: impl AsRef<Path>,
        port: Option<&str>,
        can: Option<&str>,
    ) -> Result<Self, ConfigError> {
        Self::load_with(path, serial_or_can(port, can))
    }

    /// Load and validate `path` for the link `link` chose on the command line.
    pub fn load_with(path: impl AsRef<Path>, link: LinkFlag<'_>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let file: RunFile = load_toml_with(path, RUN_KEY_RANGES)?;
        Self::from_file_with(path, file, link)
    }

    /// Validate a parsed run file that came from `path` (see [`RunConfig::load_for`]).
    pub fn from_file(
        path: &Path,
        file: RunFile,
        port: Option<&str>,
        can: Option<&str>,
    ) -> Result<Self, ConfigError> {
        Self::from_file_with(path, file, serial_or_can(port, can))
    }

    /// Validate a parsed run file that came from `path` for `link` (see
    /// [`RunConfig::load_with`]).
    pub fn from_file_with(
        path: &Path,
        file: RunFile,
        link: LinkFlag<'_>,
    ) -> Result<Self, ConfigError> {
        let invalid = |key: &str, message: String| ConfigError::Invalid {
            file: path.to_path_buf(),
            key: key.to_string(),
            message,
        };
        let controller = acc_config::load_controller(resolve_relative(path, &file.controller))
            .map_err(|e| referenced(path, "controller", &file.controller, e))?;

        // [board] fallback_mode (not a link key: taken out before the link is parsed)
        let mut board_table = file.board.unwrap_or_default();
        let fallback_mode = match board_table.remove("fallback_mode") {
            Some(v) => fallback_mode(path, &v)?,
            None => FallbackMode::default(),
        };

        // [board] or [can], or HAL
        let hal = matches!(link, LinkFlag::Hal(_));
        let link = match link {
            LinkFlag::Hal(component) => LinkSettings::Hal {
                component: component.to_string(),
            },
            LinkFlag::Can(iface) => {
                let mut table = file.can.unwrap_or_default();
                table.insert("iface".into(), toml::Value::String(iface.to_string()));
                let c: CanConfig = from_table(path, "can", table, RUN_KEY_RANGES)?;
                LinkSettings::Can {
                    iface: iface.to_string(),
                    link: c.validate(path, "can")?,
                }
            }
            LinkFlag::Serial(port) => {
                let mut table = board_table;
                if let Some(p) = port {
                    table.insert("port".into(), toml::Value::String(p.to_string()));
                }
                if !table.contains_key("port") {
                    return Err(invalid(
                        "board.port",
                        "missing: give --port <device> or set board.port".into(),
                    ));
                }
                let rtu: RtuConfig = from_table(path, "board", table, RUN_KEY_RANGES)?;
                LinkSettings::Rtu(rtu.validate(path, "board")?)
            }
        };

        // [force]
        let cal_path = resolve_relative(path, &file.force.calibration);
        let calibration = SpindleCalibration::load(&cal_path)
            .map_err(|e| referenced(path, "force.calibration", &file.force.calibration, e))?;
        let estimator = file.force.estimator;
        build_source(&calibration, estimator).map_err(|e| estimator_error(path, e))?;

        // [policy]
        let policy = file.policy.resolve_in(path, &controller)?;

        // [shutdown]
        let sd = file.shutdown;
        let shutdown = ShutdownConfig {
            drain_s: sd.drain_s.unwrap_or(10.0),
            air_periods: sd.air_periods.unwrap_or(5),
            air_force_n: sd.air_force_n.unwrap_or(0.2 * controller.force_ref_n),
        };
        check_range(path, "shutdown.drain_s", shutdown.drain_s, 0.0, 600.0)?;
        check_range(
            path,
            "shutdown.air_periods",
            f64::from(shutdown.air_periods),
            1.0,
            1000.0,
        )?;
        check_range(
            path,
            "shutdown.air_force_n",
            shutdown.air_force_n,
            0.0,
            controller.force_ref_n,
        )?;

        // [runtime]
        let rt = file.runtime;
        check_range(path, "runtime.time_scale", rt.time_scale, 0.1, 100.0)?;
        if hal && rt.time_scale != 1.0 {
            return Err(invalid(
                "runtime.time_scale",
                format!(
                    "= {} with --hal: LinuxCNC runs in real time; allowed 1",
                    rt.time_scale
                ),
            ));
        }
        check_range(
            path,
            "runtime.log_buffer",
            rt.log_buffer as f64,
            1.0,
            1_000_000.0,
        )?;
        check_range(
            path,
            "runtime.reconnect_timeout_s",
            rt.reconnect_timeout_s,
            0.1,
            600.0,
        )?;

        // [tools]
        let tools = match &file.tools {
            Some(t) => Some(
                acc_config::ToolTable::load(resolve_relative(path, &t.file))
                    .map_err(|e| referenced(path, "tools.file", &t.file, e))?,
            ),
            None => None,
        };

        // [telemetry]
        let telemetry = file.telemetry.resolve_in(path)?;

        Ok(Self {
            path: path.to_path_buf(),
            name: file.name,
            controller,
            link,
            calibration,
            estimator,
            policy,
            shutdown,
            runtime: rt,
            fallback_mode,
            tools,
            watch: file.watch.resolve(path)?,
            history: file
                .watch
                .history
                .as_ref()
                .map(|h| resolve_relative(path, h)),
            telemetry,
        })
    }

    /// The force source: the spindle estimator on the board's power register.
    pub fn force_source(&self) -> Result<SpindleSource, ConfigError> {
        build_source(&self.calibration, self.estimator).map_err(|e| estimator_error(&self.path, e))
    }

    /// Wall-clock period of the ticker: `T / time_scale`.
    pub fn tick_period(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(self.controller.period_s / self.runtime.time_scale)
    }
}

/// The link of `--port` / `--can`: CAN when `can` names an interface, else the serial
/// link with `port` replacing `board.port`.
fn serial_or_can<'a>(port: Option<&'a str>, can: Option<&'a str>) -> LinkFlag<'a> {
    match can {
        Some(iface) => LinkFlag::Can(iface),
        None => LinkFlag::Serial(port),
    }
}

/// An estimator error of the run config `file`: a range error names
/// `force.estimator.<key>`, anything else `force.estimator`.
fn estimator_error(file: &Path, e: acc_core::spindle_force::SpindleError) -> ConfigError {
    match e {
        acc_core::spindle_force::SpindleError::OutOfRange(r) => {
            ConfigError::OutOfRange(r.prefixed("force.estimator").in_file(file))
        }
        other => ConfigError::Invalid {
            file: file.to_path_buf(),
            key: "force.estimator".into(),
            message: other.to_string(),
        },
    }
}

fn build_source(
    cal: &SpindleCalibration,
    est: EstimatorConfig,
) -> Result<SpindleSource, acc_core::spindle_force::SpindleError> {
    let no_load = cal.no_load_model()?;
    let e = SpindleEstimator::new(est, cal.constants, no_load)?;
    SpindleSource::new(SpindleInput::BoardPower, e)
}

#[cfg(test)]
mod hal_link_tests {
    use super::*;

    /// `configs/linuxcnc/acc.toml`, the run config the LinuxCNC templates ship.
    fn shipped() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/linuxcnc/acc.toml")
    }

    #[test]
    fn hal_needs_no_board_port_and_refuses_a_time_scale_other_than_1() {
        let cfg = RunConfig::load_with(shipped(), LinkFlag::Hal("acc")).expect("loads");
        assert!(
            matches!(&cfg.link, LinkSettings::Hal { component } if component == "acc"),
            "{:?}",
            cfg.link
        );
        // The same file on the serial link wants a port.
        let e = RunConfig::load_for(shipped(), None, None).expect_err("no board.port");
        assert!(e.to_string().contains("board.port"), "{e}");

        // The same file at time scale 4, its paths made absolute, in a temporary folder.
        let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
        let abs = |rel: &str| format!("{:?}", configs.join(rel).display().to_string());
        let text = std::fs::read_to_string(shipped())
            .expect("read")
            .replace("time_scale = 1.0", "time_scale = 4.0")
            .replace("\"../presets/case3.toml\"", &abs("presets/case3.toml"))
            .replace(
                "\"../runtime/paper_vmc_power.toml\"",
                &abs("runtime/paper_vmc_power.toml"),
            );
        let path = std::env::temp_dir().join(format!("acc-hal-link-{}.toml", std::process::id()));
        std::fs::write(&path, text).expect("write");
        let e = RunConfig::load_with(&path, LinkFlag::Hal("acc")).expect_err("scale 4");
        let _ = std::fs::remove_file(&path);
        let e = e.to_string();
        assert!(
            e.contains("runtime.time_scale") && e.contains("--hal") && e.contains("allowed 1"),
            "{e}"
        );
    }
}
