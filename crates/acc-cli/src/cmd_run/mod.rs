//! `acc run --config <run.toml> --port <device>`: the production loop against the PMC
//! interface board (Modbus RTU, CAN with `--can`, or LinuxCNC's HAL with `--hal`; the links
//! in [`link`]), with the run log written continuously.
//!
//! Order of events: the whole config and the options are loaded and validated and the run
//! log is created (no port touched); the port is opened and its framing verified (nothing sent); the first transaction writes
//! `WATCHDOG_MS`; the status is read and printed with the board's resolution and protocol (a
//! v1 board is announced once, on stderr, with what it cannot do; a v2 board gets
//! `[board] fallback_mode` written to `FALLBACK_MODE`); the threaded
//! loop runs until Ctrl-C (or `--duration-s`); then `ACC_REQUEST` is cleared, the run log
//! flushed, a summary printed, and the exit code says which way the run ended
//! ([`crate::exit::RunExit`]: 2 for anything wrong before the first byte was sent).

use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

use acc_core::{Controller, OverrideSpec};
use acc_pmc::{Board, BoardProtocol, BoardStatus};
use acc_runtime::config::{DeviceLostAction, LinkFlag, LinkSettings, RunConfig};
use acc_runtime::policy::FaultPolicy;
use acc_runtime::record::{RunLogError, RunLogWriter};
use acc_runtime::shutdown::{init_tracing, install_stop_signals, LogFormat};
use acc_runtime::{
    history::WatchSink, ControlLoop, Drain, Hooks, LogSink, OnDeviceLost, Reopen, RunOptions,
    RunRecord, SystemClock,
};
use anyhow::Context;

use crate::exit::{ExitAs, RunExit};
use link::OpenLink;

mod ending;
mod link;

/// Arguments of `acc run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Run config (TOML), e.g. `configs/runtime/paper_vmc_run.toml`.
    #[arg(long)]
    pub config: PathBuf,
    /// Serial device of the board (replaces `board.port`), e.g. `/dev/ttyUSB0` or the pty
    /// `acc board-sim` prints.
    #[arg(long, conflicts_with_all = ["can", "hal"])]
    pub port: Option<String>,
    /// CAN interface of a CAN board, e.g. `can0`.
    #[arg(long, conflicts_with = "hal")]
    pub can: Option<String>,
    /// LinuxCNC's HAL: acc is the userspace HAL component COMPONENT (default `acc`; load it
    /// with `loadusr -Wn acc acc run --hal …`, pins in docs/linuxcnc.md). The run is in real
    /// time (`runtime.time_scale` = 1).
    #[arg(long, value_name = "COMPONENT", num_args = 0..=1, default_missing_value = "acc")]
    pub hal: Option<String>,
    /// Run-log CSV (same schema as `acc sim`), flushed every period.
    #[arg(long, default_value = "out/run.csv")]
    pub log: PathBuf,
    /// Follow the plan `acc plan` wrote for the program (`plan.csv`): the loop lowers the
    /// override ahead of every engagement change the plan names (board protocol v2:
    /// `BLOCK_NUMBER` and `ACTUAL_FEED`; docs/plan.md).
    #[arg(long, value_name = "plan.csv")]
    pub plan: Option<PathBuf>,
    /// With `--plan`: while the tool cuts and the measurement confirms the plan, the plan's
    /// lead sets the command from the force ahead instead of only capping the law's command
    /// (docs/plan.md, "The plan's lead").
    #[arg(long, requires = "plan")]
    pub plan_lead: bool,
    /// Stop after this much machine time, s, skipped periods included (default: run until
    /// Ctrl-C).
    #[arg(long, allow_hyphen_values = true)]
    pub duration_s: Option<f64>,
    /// Tool-history database (SQLite): cuts, Kc trend per tool and alarms, kept across runs
    /// (default: `[watch] history` of the config, else `acc-history.sqlite` beside the log).
    #[arg(long, value_name = "FILE")]
    pub history: Option<PathBuf>,
    /// Events as JSON lines on stderr (filter: `ACC_LOG`, e.g. `ACC_LOG=debug`).
    #[arg(long)]
    pub json: bool,
    /// Telemetry (`--shdr`, `--mqtt`; over the config's `[telemetry]`).
    #[command(flatten)]
    pub telemetry: crate::telemetry::TelemetryArgs,
    /// The fleet store (`--fleet`, `--machine`).
    #[command(flatten)]
    pub fleet: crate::fleet_cli::FleetArgs,
}

/// One-line description of a status block.
pub fn describe_status(s: &BoardStatus) -> String {
    let on = |b: bool| if b { "on" } else { "off" };
    format!(
        "ACC switch {}, ACC active {}, cycle {}, feed hold {}, watchdog {}, override locked {}, CNC alarm {}; override applied {} %, operator {} %; spindle {} rpm, {} W (seq {}); programmed feed {} mm/min",
        on(s.acc_switch),
        on(s.acc_active),
        on(s.cycle_active),
        on(s.feed_hold_active),
        if s.watchdog_tripped { "TRIPPED" } else { "ok" },
        on(s.override_locked),
        on(s.cnc_alarm),
        s.override_applied_pct,
        s.operator_override_pct,
        s.spindle_rpm,
        s.spindle_power_w,
        s.sample_seq,
        s.programmed_feed_mm_min,
    )
}

/// Run-log / summary name of a protocol (`v1`, `v2`, `unknown`).
pub fn protocol_name(p: Option<BoardProtocol>) -> &'static str {
    match p {
        Some(BoardProtocol::V1) => "v1",
        Some(BoardProtocol::V2) => "v2",
        None => "unknown",
    }
}

/// The one-time announcement of a v1 board: one warning line on stderr and a
/// `tracing::warn!`, naming [`BoardProtocol::limitations`]. Returns whether it was made.
pub fn announce_v1(protocol: Option<BoardProtocol>, device: &str) -> bool {
    if protocol != Some(BoardProtocol::V1) {
        return false;
    }
    let what = BoardProtocol::V1.limitations();
    eprintln!("warning: the board on {device} speaks protocol v1 — {what}");
    tracing::warn!(device, limitations = what, "board protocol v1");
    true
}

/// Writes the runtime's [`RunRecord`]s to the run-log CSV (schema v2, the same writer and
/// columns as `acc sim`), flushing every row. The simulator-only columns stay empty.
pub struct RunLogSink {
    writer: RunLogWriter<BufWriter<File>>,
}

impl RunLogSink {
    /// A sink writing to `writer`.
    pub fn new(writer: RunLogWriter<BufWriter<File>>) -> Self {
        Self { writer }
    }
}

impl LogSink for RunLogSink {
    type Error = RunLogError;

    fn write(&mut self, rec: &RunRecord) -> Result<(), RunLogError> {
        self.writer.write(rec)
    }

    fn flush(&mut self) -> Result<(), RunLogError> {
        Ok(())
    }
}

/// The controller's override resolution on this board ([`OverrideSpec::for_board`]): the
/// preset's step if it is a multiple of the board's, otherwise the board's (commands must be
/// multiples of `OVERRIDE_STEP` or the board answers exception 03). A preset hysteresis
/// larger than half the replacing step is refused with a message naming both steps.
fn spec_for_board(spec: OverrideSpec, board_step: u16) -> anyhow::Result<OverrideSpec> {
    spec.for_board(board_step).map_err(|e| {
        anyhow::anyhow!(
            "preset `[override] hysteresis_pct` = {} exceeds half the board's override step: the board steps {board_step} %, which replaces the preset's {} % (not a multiple of it); allowed 0 ..= {} ({e})",
            spec.hysteresis_pct,
            spec.step_pct,
            f64::from(board_step) / 2.0
        )
    })
}

/// `acc run`.
pub fn run_cmd(args: &RunArgs) -> anyhow::Result<()> {
    init_tracing(
        if args.json {
            LogFormat::Json
        } else {
            LogFormat::Text
        },
        "info",
    );
    // 1. Everything validated before the port is touched.
    let flag = match (&args.hal, &args.can) {
        (Some(component), _) => LinkFlag::Hal(component),
        (None, Some(iface)) => LinkFlag::Can(iface),
        (None, None) => LinkFlag::Serial(args.port.as_deref()),
    };
    let cfg = RunConfig::load_with(&args.config, flag).exit_as(RunExit::Usage)?;
    // The plan is checked here, before the port is touched (run_production_loop reads it again).
    if let Some(p) = &args.plan {
        acc_runtime::Plan::load(p).exit_as(RunExit::Usage)?;
    }
    if let Some(d) = args.duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(anyhow::anyhow!(
                "--duration-s {d}: must be a positive number of seconds: allowed > 0 (machine time)"
            ))
            .exit_as(RunExit::Usage);
        }
    }
    // The run log too: a path that cannot be written fails here, before the first byte goes
    // to the board.
    if let Some(dir) = args.log.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--log {}: cannot create its folder", args.log.display()))
            .exit_as(RunExit::Usage)?;
    }
    let file = File::create(&args.log)
        .with_context(|| format!("--log {}: cannot create the run log", args.log.display()))
        .exit_as(RunExit::Usage)?;
    let writer = RunLogWriter::new(BufWriter::new(file))
        .with_context(|| format!("--log {}: cannot write the run log", args.log.display()))
        .exit_as(RunExit::Usage)?;
    // The tool history likewise (a newer schema version is refused here).
    let history = crate::watch_cli::history_path(
        args.history.as_deref().or(cfg.history.as_deref()),
        &args.log,
    );
    let (watch, history_writer) = crate::watch_cli::open_live(
        &history,
        &format!("acc run {}", cfg.name),
        cfg.watch,
        cfg.tools.as_ref(),
        cfg.controller.period_s,
    )
    .with_context(|| "the tool history (--history or [watch] history)".to_string())
    .exit_as(RunExit::Usage)?;
    // The fleet store likewise (its cuts from a copy of the same watch).
    let fleet = args
        .fleet
        .open(crate::fleet_cli::now_us())
        .exit_as(RunExit::Usage)?
        .map(|f| f.feed(watch.clone()));
    let sinks = RunSinks {
        log: writer,
        history,
        watch,
        history_writer,
        fleet,
    };
    match &cfg.link {
        LinkSettings::Rtu(rtu) => run_on_link(args, &cfg, link::open_rtu(&cfg, rtu)?, sinks),
        LinkSettings::Can { iface, link: can } => {
            run_on_link(args, &cfg, link::open_can(&cfg, iface, *can)?, sinks)
        }
        LinkSettings::Hal { component } => {
            run_on_link(args, &cfg, link::open_hal(&cfg, component)?, sinks)
        }
    }
}

/// Print the opened link's banner, drive the run with the link's reopen, then print the
/// link's counters.
fn run_on_link<B: Board + Send>(
    args: &RunArgs,
    cfg: &RunConfig,
    link: OpenLink<'_, B>,
    sinks: RunSinks,
) -> anyhow::Result<()> {
    let OpenLink {
        mut board,
        status,
        device,
        banner,
        reopen: mut open_again,
        counters,
    } = link;
    println!("{banner}");
    let mut reopen = || open_again().map_err(|e| format!("{e:#}"));
    let reopen: Reopen<'_, _> = &mut reopen;
    let result = run_production_loop(args, cfg, &mut board, status, sinks, device, reopen);
    if let Some(line) = counters(&board) {
        println!("{line}");
    }
    result
}

/// Where a run's records go: the run log, and the watch with its tool-history writer.
struct RunSinks {
    log: RunLogWriter<BufWriter<File>>,
    history: PathBuf,
    watch: acc_runtime::history::Watch,
    history_writer: acc_runtime::history::HistoryWriter,
    fleet: Option<acc_fleet::sink::MachineFeed>,
}

/// The production loop's sink: run log, fleet store, telemetry tap, wear watch (outermost).
type ProductionSink = WatchSink<acc_runtime::TapSink<acc_fleet::FleetSink<RunLogSink>>>;

/// The production loop on `pmc`, in order: the board announced and its resolution checked,
/// the loop built for it, telemetry and the sinks started, the loop driven until Ctrl-C or
/// `--duration-s`, then the summary and the exit that says how the run ended.
fn run_production_loop<P: Board + Send>(
    args: &RunArgs,
    cfg: &RunConfig,
    pmc: &mut P,
    status: BoardStatus,
    sinks: RunSinks,
    device: &str,
    reopen: Reopen<'_, P>,
) -> anyhow::Result<()> {
    let step = announce_board(pmc.protocol(), &status, device)?;
    let (mut control, ccfg) = build_loop(args, cfg, step)?;
    let period_s = ccfg.period_s;
    let tel = start_telemetry(args, cfg, period_s)?;
    let history = sinks.history.clone();
    let mut sink = production_sink(sinks, &tel);
    let stop = install_stop_signals().context("installing the Ctrl-C handler")?;
    let opts = run_options(args, cfg, ccfg.force_ref_n, period_s);
    let device_lost_periods = opts.device_lost_periods.unwrap_or_default();
    println!(
        "running `{}`: T = {} s (tick every {:.1} ms of wall time), Fr = {} N; run log {}; Ctrl-C stops once the cut has ended (a second Ctrl-C: feed hold now)",
        cfg.name,
        period_s,
        cfg.tick_period().as_secs_f64() * 1e3,
        ccfg.force_ref_n,
        args.log.display()
    );
    let hooks = Hooks {
        reopen: Some(reopen),
        observer: None,
    };
    let s = acc_runtime::drive(
        pmc,
        &mut control,
        SystemClock::new(),
        &mut sink,
        &stop,
        opts,
        hooks,
    )
    .exit_as(RunExit::Internal)?;
    let left = ending::close_sinks(sink, tel);
    ending::print_summary(&s, &control, left, args, cfg, &history);
    ending::exit_of(&s, cfg, device, device_lost_periods)
}

/// Once per run: the board's protocol (a v1 board and what it cannot do), its override
/// resolution and status printed; a resolution other than 10 % or 1 % is refused. The
/// board's `OVERRIDE_STEP`, percent.
fn announce_board(
    protocol: Option<BoardProtocol>,
    status: &BoardStatus,
    device: &str,
) -> anyhow::Result<u16> {
    announce_v1(protocol, device);
    let step = status.override_step_pct;
    println!(
        "resolution: OVERRIDE_STEP = {} % ({})",
        step,
        match step {
            10 => "4-bit board, 16 positions 0..150 %",
            1 => "byte board, 1 % steps",
            _ => "non-standard step",
        }
    );
    println!("status: {}", describe_status(status));
    if !(step == 1 || step == 10) {
        return Err(anyhow::anyhow!(
            "board reports OVERRIDE_STEP = {step} %: the spec allows 10 or 1; refusing to drive it"
        ))
        .exit_as(RunExit::BoardNotAnswering);
    }
    Ok(step)
}

/// The control loop for a board of override resolution `step` (percent): the law with the
/// preset's override spec rounded to the board, the fault policy with the watch's limits,
/// the force source, the shop layer (`[tools]`) and the look-ahead (`--plan`); and the
/// controller settings it was built with.
fn build_loop(
    args: &RunArgs,
    cfg: &RunConfig,
    step: u16,
) -> anyhow::Result<(
    ControlLoop<Controller, acc_core::spindle_force::SpindleSource>,
    acc_core::ControllerConfig,
)> {
    let mut ccfg = cfg.controller;
    ccfg.override_spec = spec_for_board(ccfg.override_spec, step)
        .with_context(|| format!("{}: key `controller` (the preset)", cfg.path.display()))
        .exit_as(RunExit::BoardNotAnswering)?;
    let law = Controller::new(ccfg).map_err(|e| {
        anyhow::anyhow!("{}: key `controller` (the preset): {e}", cfg.path.display())
    })?;
    let period_s = ccfg.period_s;
    let source = cfg.force_source()?;
    let mut control = ControlLoop::new(
        FaultPolicy::new(cfg.policy).with_watch_limits(cfg.watch),
        law,
        source,
        period_s,
    )
    .with_air_force_n(cfg.shutdown.air_force_n);
    if let Some(table) = cfg.tools.clone() {
        control = control.with_shop(acc_runtime::ShopControl::new(table, period_s));
    }
    if let Some(p) = &args.plan {
        let plan = acc_runtime::Plan::load(p).exit_as(RunExit::Usage)?;
        let la = acc_runtime::LookAheadConfig {
            lead: args.plan_lead,
            ..acc_runtime::LookAheadConfig::new(
                period_s,
                ccfg.force_ref_n,
                cfg.policy.max_override_pct,
            )
        };
        control = control.with_lookahead(acc_runtime::LookAhead::new(plan, la));
    }
    Ok((control, ccfg))
}

/// SHDR, MQTT and OPC UA from the options over the config's `[telemetry]` (the PKI beside
/// the run log), and the live view's title. The logger thread publishes each record on the
/// tap just before writing it; the control thread never waits on it (a slow peer only
/// drops).
fn start_telemetry(
    args: &RunArgs,
    cfg: &RunConfig,
    period_s: f64,
) -> anyhow::Result<crate::telemetry::Telemetry> {
    let tel_cfg = crate::telemetry::with_default_pki(
        args.telemetry.over(&cfg.telemetry),
        &args
            .log
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join("pki"),
    );
    let tel =
        crate::telemetry::Telemetry::start(&tel_cfg, false, period_s).exit_as(RunExit::Usage)?;
    tel.set_live_info(acc_telemetry::LiveInfo {
        title: format!("acc run: {}", args.config.display()),
        overload_n: Some(cfg.policy.overload_force_n),
    });
    Ok(tel)
}

/// The sinks around the run log (created before the port was opened): the fleet store, the
/// telemetry tap, and the wear and breakage watch with the tool history on the logger
/// thread (the database writes on their own thread: bounded queue, never waited on).
fn production_sink(sinks: RunSinks, tel: &crate::telemetry::Telemetry) -> ProductionSink {
    let RunSinks {
        log: writer,
        history: _,
        watch,
        history_writer,
        fleet,
    } = sinks;
    WatchSink {
        inner: acc_runtime::TapSink {
            inner: acc_fleet::FleetSink {
                inner: RunLogSink::new(writer),
                feed: fleet,
            },
            tap: tel.tap.clone(),
        },
        watch,
        writer: Some(history_writer),
        summary: Default::default(),
    }
}

/// The runner's options from the config and `--duration-s`: the period on the wall clock
/// (time scale), the log buffer, the drain of a stop mid-cut and what a vanished device
/// does; timeouts in machine seconds are divided by the time scale.
fn run_options(args: &RunArgs, cfg: &RunConfig, force_ref_n: f64, period_s: f64) -> RunOptions {
    RunOptions {
        max_periods: args
            .duration_s
            .map(|d| (d / period_s).round().max(1.0) as u64),
        log_buffer: cfg.runtime.log_buffer,
        time_scale: cfg.runtime.time_scale,
        force_ref_n: Some(force_ref_n),
        drain: Some(Drain {
            max: std::time::Duration::from_secs_f64(cfg.shutdown.drain_s / cfg.runtime.time_scale),
            air_periods: cfg.shutdown.air_periods,
        }),
        on_device_lost: match cfg.runtime.on_device_lost {
            DeviceLostAction::Exit => OnDeviceLost::Exit,
            DeviceLostAction::Reconnect => OnDeviceLost::Reconnect {
                timeout: std::time::Duration::from_secs_f64(
                    cfg.runtime.reconnect_timeout_s / cfg.runtime.time_scale,
                ),
            },
        },
        ..RunOptions::new(cfg.tick_period())
    }
}

/// A fault feed hold was in force when the run ended: the overload alarm, or a latched
/// release whose last status shows the NC's feed hold.
fn fault_feed_hold(s: &acc_runtime::RunSummary) -> bool {
    s.alarms.overload
        || (matches!(s.final_state, acc_runtime::policy::AccState::Latched(_))
            && s.last_status.as_ref().is_some_and(|st| st.feed_hold_active))
}

/// Exit code of `acc run` when a stop request found the machine still cutting and ended
/// with a feed hold ([`RunExit::FeedHold`]).
pub const EXIT_FEED_HOLD: i32 = RunExit::FeedHold.code();

/// Exit code of `acc run` when the board's serial device or CAN interface vanished
/// ([`RunExit::DeviceLost`]).
pub const EXIT_DEVICE_LOST: i32 = RunExit::DeviceLost.code();

/// Exit code of `acc run` when a fault feed hold was in force at the end
/// ([`RunExit::FaultFeedHold`]).
pub const EXIT_FAULT_FEED_HOLD: i32 = RunExit::FaultFeedHold.code();

/// An error that ends the process with its own exit code (see `main`).
#[derive(Debug)]
pub struct ExitWith {
    /// Process exit code.
    pub code: i32,
    /// The last message.
    pub message: String,
}

impl std::fmt::Display for ExitWith {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for ExitWith {}

#[cfg(test)]
mod board_step_tests {
    use super::*;

    #[test]
    fn board_step_replaces_a_preset_step_it_does_not_divide() {
        let ten = OverrideSpec::paper();
        // 10 % is a multiple of a byte board's 1 %: the preset's step stays.
        assert_eq!(spec_for_board(ten, 1).map(|s| s.step_pct).ok(), Some(10));
        let fifteen = OverrideSpec {
            step_pct: 15,
            max_pct: 150,
            ..ten
        };
        assert_eq!(
            spec_for_board(fifteen, 10).map(|s| s.step_pct).ok(),
            Some(10)
        );
        // A hysteresis valid for 15 % (≤ 7.5) but not for the board's 10 % (≤ 5) is refused,
        // and the message says why.
        let err = spec_for_board(fifteen.with_hysteresis(6.0), 10)
            .expect_err("6 % > 10/2")
            .to_string();
        assert!(
            err.contains("hysteresis_pct") && err.contains("replaces the preset's 15 %"),
            "{err}"
        );
        assert!(spec_for_board(fifteen.with_hysteresis(5.0), 10).is_ok());
    }
}
