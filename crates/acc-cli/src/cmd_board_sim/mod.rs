//! `acc board-sim --scenario <scenario.toml>`: the PMC interface board served over Modbus
//! RTU on a new pseudo-terminal (its path is printed) or a given serial port, backed by the
//! simulated machine of the scenario.
//!
//! - The register behaviour is acc-pmc's `BoardLogic`, served by its `RtuServer`:
//!   protocol v2 by default (`../shared/docs/pmc-board.md`: the fallback clamp — a release,
//!   watchdog trip or lost link never raises the applied override —, `FALLBACK_MODE`, the
//!   watchdog's and the power-up feed hold, `BOARD_RESTARTED`, the NC context registers
//!   9…14); `--protocol 1` emulates a v1 board that answers exception 02 for registers 9…14
//!   and holding register 4 (`--v1-registers exception`, the default) or reads them as 0
//!   (`--v1-registers zeros`), with no clamp and no feed hold of its own.
//! - The server answers every request for its slave address (malformed writes with
//!   exception 03) and keeps serving however many requests queue up unread: replies it
//!   cannot deliver are dropped and counted (printed at exit).
//! - The machine (acc-sim's `Machine`: workpiece, force law, feed drive, override delay,
//!   spindle) advances one control period `T` (the scenario preset's) on its own ticker,
//!   every `T / time_scale` of wall time: the override now applied by the board (with the
//!   clamp) and the board's feed hold act on the simulated feed; the period's mean spindle
//!   power goes to `POWER_HI:POWER_LO` with a new `SAMPLE_SEQ`; the NC context (tool,
//!   program, block = `nc.block_step` × (segment + 1), actual feed, 0 in feed hold) to
//!   registers 10…13 (scenario table `[nc]`, defaults tool 1, program 1000, step 10).
//! - `--log` writes the machine-side run log every period (the simulator's schema: path
//!   position, depths, true force `force_true_n`, applied override, `feed_hold`, tool /
//!   program / block) so that a closed loop over the serial line can be judged with the
//!   simulator's summary. Its `flags` carry the board's state: `fallback:<pct>` (the clamp
//!   is engaged at `FALLBACK_OVERRIDE` = pct), `watchdog` (tripped), `restarted`
//!   (`BOARD_RESTARTED`), `unplugged` (the cable is out), `late` (the machine tick was late),
//!   `ticks_skipped:<n>` (board-sim fell more than a period behind the wall clock and its
//!   ticker skipped n deadlines: machine time then lags wall time; no machine period is lost,
//!   and `period` counts machine periods, consecutive).
//! - `--fault KIND@T[:ARG]` schedules faults at machine time `T` s for the end-to-end tests:
//!   `crc@T:N` (corrupt the CRC of the next N replies), `drop@T:N` (swallow N replies),
//!   `late@T:N` (deliver N replies `--late-ms` late), `restart@T` (board power cycle: v2
//!   holds the feed if a cycle is running), `freeze-seq@T:S` (`SAMPLE_SEQ` frozen for S s),
//!   `bad-power@T:S` (power register 0xFFFFFFFF, i.e. −1 W, for S s), `stall@T:S` (the board
//!   stops serving for S s of wall time: its watchdog trips), `lock@T:S` (`OVERRIDE_LOCKED`
//!   for S s: the NC forces 100 %, as in tapping), `switch@T:on|off` (operator's ACC
//!   switch), `operator@T:PCT` or `knob@T:PCT` (the operator turns the override knob to PCT:
//!   a deliberate act that ends the clamp), `unplug@T` (the cable is pulled for good: the
//!   board reads and discards whatever arrives and answers nothing, the controller sees
//!   timeouts; the machine runs on under the board's own logic — watchdog, clamp, feed
//!   hold — and the log keeps being written), `unplug@T:S` (plugged back in after S s of
//!   machine time), `vanish@T` (the device disappears: board-sim closes its end of the pty,
//!   the controller's reads fail with EIO, as when a USB adapter is unplugged; the machine
//!   runs on under the board's own logic) and `hard@T:S:F` (a hard spot: the material's
//!   `Ks` × F for S s of machine time, 0 < F <= 20).
//! - `--pace controller` moves the machine in lockstep with the controller: one period per
//!   command write (FC 16 with a new `HEARTBEAT`), and the write's reply leaves only after
//!   the period, so the controller's next read sees the period its command drove. A run is
//!   then the same on a loaded host as on a quiet one (the end-to-end tests use it); the
//!   default `--pace wall` moves the machine on its own ticker, as a real machine moves
//!   whatever the controller does, and is what the timing faults need: `unplug`, `vanish`
//!   and `stall` are refused with `--pace controller`. Once the controller has released
//!   (`ACC_REQUEST` cleared, e.g. after a feed-hold stop), a controller-paced machine runs on
//!   its own ticker again, as a real machine runs on when ACC lets go.
//! - `--program part.ngc --stock-box X0,Y0,Z0,X1,Y1,Z1` (or `--stock stock.toml`, with
//!   `--tools T.tbl`, `--cell MM`): the machine follows the NC program through its stock
//!   instead of the scenario's 1-D workpiece — the same options, path and engagement source
//!   as `acc sim --program` (`crate::cmd_sim_program::load`) — and the board reports the
//!   program's `BLOCK_NUMBER` (N word, else line number), `TOOL_NUMBER`,
//!   `PROGRAMMED_FEED` (per block; a rapid's is the rapid rate) and `ACTUAL_FEED`; the
//!   machine log's `x_mm` is the path position along the program.
//! - `--watchdog-time machine` runs the board's clock (its watchdog, `WATCHDOG_MS`) on
//!   machine time, as on the real machine; the default `wall` keeps it on wall time, which
//!   is more forgiving of a loaded host at high `--time-scale`.

mod faults;
mod in_force;
mod line;
mod machine_row;
mod next_period;
mod serve;

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use acc_pmc::emu::{lock_board, EmulatedProtocol, SharedBoard};
use acc_runtime::record::RunLogWriter;
use acc_runtime::shutdown::install_stop_flag;
use acc_runtime::{Clock, SystemClock};
use acc_sim::Scenario;
use anyhow::{bail, Context};

use faults::{parse_fault, Scheduled};
use in_force::InForce;
use line::CommandPace;
use machine_row::BoardSide;
use next_period::{Next, NextPeriod};
use serve::LineFaults;

/// Arguments of `acc board-sim`.
#[derive(Debug, clap::Args)]
pub struct BoardSimArgs {
    /// Scenario (machine, tool, workpiece, controller preset for T), e.g.
    /// `configs/scenarios/paper_case3.toml`.
    #[arg(long)]
    pub scenario: PathBuf,
    /// Serve on this serial device instead of a new pty.
    #[arg(long)]
    pub port: Option<String>,
    /// Baud rate (pty: informative unless `--paced`).
    #[arg(long, default_value_t = 19_200)]
    pub baud: u32,
    /// Parity of `--port`: none, even, odd (a pty is always 8N1).
    #[arg(long, default_value = "even")]
    pub parity: String,
    /// Modbus slave address, 1..=247.
    #[arg(long, default_value_t = 1)]
    pub slave: u8,
    /// Machine seconds per wall second (0.1..=100); run `acc run` with the same
    /// `runtime.time_scale`.
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Emulate the wire time of each reply at `--baud` (a pty moves bytes instantly).
    #[arg(long)]
    pub paced: bool,
    /// Operator's override knob at start, percent (0..=150).
    #[arg(long, default_value_t = 100)]
    pub operator_override: u16,
    /// Machine-side run log (CSV, simulator schema).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Scheduled fault, `KIND@T[:ARG]` (repeatable; see the module docs).
    #[arg(long = "fault")]
    pub faults: Vec<String>,
    /// Delay of a `late` reply, ms.
    #[arg(long, default_value_t = 60)]
    pub late_ms: u64,
    /// Exit once the workpiece is finished (after `--linger-s`).
    #[arg(long)]
    pub exit_when_done: bool,
    /// Time to keep serving after the workpiece is finished with `--exit-when-done`, s.
    #[arg(long, default_value_t = 0.5)]
    pub linger_s: f64,
    /// Hold the machine at t = 0 until the controller sets `ACC_REQUEST` (so that machine
    /// time and the controller's time share their origin, to half a period: the board's
    /// ticks then fall half a period after the controller's, so that a write never races
    /// the tick that takes it into the machine).
    #[arg(long)]
    pub wait_for_controller: bool,
    /// Board protocol to emulate: 2 (fallback clamp, feed holds, NC context) or 1.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub protocol: u8,
    /// How a v1 board (`--protocol 1`) answers registers 9…14 and holding register 4.
    #[arg(long, value_enum, default_value_t = V1Registers::Exception)]
    pub v1_registers: V1Registers,
    /// The board's clock (its watchdog): `wall` time or `machine` time (wall × time scale).
    #[arg(long, value_enum, default_value_t = WatchdogTime::Wall)]
    pub watchdog_time: WatchdogTime,
    /// What moves the machine: its own `wall` ticker, or the `controller`'s command writes
    /// (one period per write, in lockstep).
    #[arg(long, value_enum, default_value_t = Pace::Wall)]
    pub pace: Pace,
    /// Telemetry of the machine side (`--shdr`, `--mqtt`): the board's registers and the
    /// plant's truth every period.
    #[command(flatten)]
    pub telemetry: crate::telemetry::TelemetryArgs,
    /// An NC program on a stock (`--program`, `--stock`, `--stock-box`, `--cell`,
    /// `--tools`), as `acc sim --program`.
    #[command(flatten)]
    pub program: crate::cmd_sim_program::ProgramArgs,
}

/// Which time the emulated board's watchdog counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum WatchdogTime {
    /// Wall-clock time.
    Wall,
    /// Machine time (wall time × `--time-scale`).
    Machine,
}

/// What moves the simulated machine from one period to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Pace {
    /// Its own ticker, every `T / time_scale` of wall time, as a real machine moves
    /// whatever the controller does.
    Wall,
    /// One period per command write of the controller (FC 16 with a new `HEARTBEAT`); the
    /// reply leaves after the period. The run is then the same on a loaded host as on a
    /// quiet one; faults that silence the controller (`unplug`, `vanish`, `stall`) would
    /// stop the machine and are refused.
    Controller,
}

/// How an emulated v1 board answers the v2 registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum V1Registers {
    /// Exception 02 (illegal data address).
    Exception,
    /// Read as 0 (writes to register 4 ignored).
    Zeros,
}

impl BoardSimArgs {
    /// The emulated board's protocol from `--protocol` and `--v1-registers`.
    pub fn emulated_protocol(&self) -> EmulatedProtocol {
        match (self.protocol, self.v1_registers) {
            (1, V1Registers::Exception) => EmulatedProtocol::V1Exception,
            (1, V1Registers::Zeros) => EmulatedProtocol::V1Zeros,
            _ => EmulatedProtocol::V2,
        }
    }
}

/// The emulated board's clock: wall time, or machine time (wall × `time_scale`).
fn board_clock(kind: WatchdogTime, time_scale: f64) -> Box<dyn acc_pmc::clock::Clock> {
    let wall = SystemClock::new();
    match kind {
        WatchdogTime::Wall => Box::new(wall),
        WatchdogTime::Machine => match acc_pmc::clock::ScaledClock::new(wall, time_scale) {
            Some(c) => Box::new(c),
            None => Box::new(wall),
        },
    }
}

/// `acc board-sim`: serve the board, then advance the machine one period at a time until
/// Ctrl-C (or the finished workpiece with `--exit-when-done`).
pub fn run_cmd(args: &BoardSimArgs) -> anyhow::Result<()> {
    acc_runtime::shutdown::init_tracing(acc_runtime::shutdown::LogFormat::Text, "warn");
    let (sc, program) = load_scenario(args)?;
    check_args(args)?;
    let mut in_force = InForce::new(fault_schedule(args)?);
    let period_s = sc.controller.period_s;
    // The same simulated board and plant `acc sim` steps in process, served over the link.
    let protocol = args.emulated_protocol();
    let mut sim = sc.build_board_with(protocol);
    if let Some(p) = program {
        sim.set_engagement_source(Some(Box::new(p)));
    }
    sim.logic_mut()
        .set_operator_override_pct(args.operator_override);
    let board: SharedBoard = sim.serve();
    let line = LineFaults {
        queue: Arc::default(),
        unplugged: Arc::new(AtomicBool::new(false)),
        paced_baud: args.paced.then_some(args.baud),
        pace: (args.pace == Pace::Controller).then(|| Arc::new(CommandPace::default())),
    };
    // The board's own clock, shared by the server (watchdog on requests) and the machine
    // loop below (watchdog ticks every period, also when no request arrives at all).
    let clock: Arc<dyn acc_pmc::clock::Clock> =
        Arc::from(board_clock(args.watchdog_time, args.time_scale));
    let mut served = serve::open(args, &board, &line, &clock)?;
    std::io::stdout().flush().ok();
    eprintln!(
        "board-sim: `{}`, {:?} board, slave {}, T = {} s machine time every {:.1} ms wall; operator override {} %",
        sc.name,
        protocol,
        args.slave,
        period_s,
        1e3 * period_s / args.time_scale,
        args.operator_override
    );
    let mut log = open_machine_log(args.log.as_deref())?;
    let stop = install_stop_flag().context("installing the Ctrl-C handler")?;
    let tel = start_telemetry(args, &sc)?;
    if args.wait_for_controller {
        wait_for_controller(
            &stop,
            &board,
            line.pace.as_deref(),
            period_s / args.time_scale,
        );
    }
    let mut next = NextPeriod::new(
        Duration::from_secs_f64(period_s / args.time_scale),
        line.pace.clone(),
    )?;
    // The machine log's period index: one per machine period, consecutive. A tick the
    // ticker skipped (board-sim fell more than a period behind the wall clock) is not a lost
    // machine period — the machine advances one period per loop — and is flagged instead.
    let mut machine_period: u64 = 0;
    let mut done_at: Option<f64> = None;
    while !stop.load(Ordering::SeqCst) {
        // A controller-paced run ends once the finished machine's controller is quiet for
        // the linger time (it stopped out of the cut): nothing will move it again.
        let quiet_end = (args.exit_when_done && done_at.is_some())
            .then(|| Duration::from_secs_f64(args.linger_s / args.time_scale));
        let tick = match next.wait(&board, machine_period, quiet_end)? {
            Next::Period(tick) => tick,
            Next::NotYet => continue,
            Next::Done => break,
        };
        let t = sim.machine().t_s();
        in_force.start_due(t, &board, &line, &mut served, &mut sim)?;
        // The board's watchdog runs on its own timer, requests or not (a vanished device
        // sends none).
        lock_board(&board).tick(clock.now().as_millis() as u64);
        in_force.end_due(t, &board, &mut sim);
        let side = {
            let b = lock_board(&board);
            BoardSide {
                status: b.status(),
                command_pct: b.override_cmd_pct(),
                unplugged: line.unplugged.load(Ordering::SeqCst),
            }
        };
        let row = machine_row::advance_and_record(
            &mut sim,
            period_s,
            machine_period,
            &tick,
            &side,
            sc.controller.force_ref_n,
        );
        machine_period += 1;
        if let Some(w) = log.as_mut() {
            w.write(&row)?;
        }
        tel.tap.publish(&row);
        next.period_taken();
        if sim.machine().finished() && done_at.is_none() {
            done_at = Some(sim.machine().t_s());
            eprintln!(
                "board-sim: workpiece finished at t = {:.1} s",
                sim.machine().t_s()
            );
        }
        if let (true, Some(d)) = (args.exit_when_done, done_at) {
            if sim.machine().t_s() - d >= args.linger_s * args.time_scale {
                break;
            }
        }
    }
    next.close();
    tel.finish();
    print_end(next.stats(), &board);
    served.close()
}

/// The scenario, and the NC program's path through its stock (`--program`), checked before
/// the pty exists; with a program, the scenario is the program's.
fn load_scenario(
    args: &BoardSimArgs,
) -> anyhow::Result<(Scenario, Option<acc_sim::program::ProgramPath>)> {
    let sc = Scenario::load(&args.scenario)?;
    let program = crate::cmd_sim_program::load(&args.program, &sc)?;
    let sc = match &program {
        Some(p) => p.scenario_for(&sc),
        None => sc,
    };
    Ok((sc, program))
}

/// The numeric options in their ranges.
fn check_args(args: &BoardSimArgs) -> anyhow::Result<()> {
    if !(args.time_scale.is_finite() && (0.1..=100.0).contains(&args.time_scale)) {
        bail!("--time-scale {}: allowed 0.1 ..= 100", args.time_scale);
    }
    if !(1..=247).contains(&args.slave) {
        bail!("--slave {}: allowed 1 ..= 247", args.slave);
    }
    if args.operator_override > 150 {
        bail!(
            "--operator-override {}: allowed 0 ..= 150",
            args.operator_override
        );
    }
    if !acc_pmc::serial::BAUD_RATES.contains(&args.baud) {
        bail!(
            "--baud {}: allowed one of {:?}",
            args.baud,
            acc_pmc::serial::BAUD_RATES
        );
    }
    Ok(())
}

/// `--fault` parsed and sorted by machine time; a fault that would silence a
/// controller-paced machine is refused.
fn fault_schedule(args: &BoardSimArgs) -> anyhow::Result<VecDeque<(f64, Scheduled)>> {
    let late = Duration::from_millis(args.late_ms);
    let mut schedule: Vec<(f64, Scheduled)> = args
        .faults
        .iter()
        .map(|f| parse_fault(f, late))
        .collect::<anyhow::Result<_>>()?;
    schedule.sort_by(|a, b| a.0.total_cmp(&b.0));
    if args.pace == Pace::Controller {
        if let Some((at, f)) = schedule.iter().find(|(_, f)| f.silences_controller()) {
            bail!(
                "--fault {f:?} at {at} s with --pace controller: a fault that silences the controller would stop the machine; use --pace wall"
            );
        }
    }
    Ok(schedule.into())
}

/// `--log`: the machine log's writer (its folder created).
fn open_machine_log(
    path: Option<&std::path::Path>,
) -> anyhow::Result<Option<RunLogWriter<BufWriter<File>>>> {
    let Some(p) = path else {
        return Ok(None);
    };
    if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let f = File::create(p).with_context(|| format!("creating {}", p.display()))?;
    Ok(Some(RunLogWriter::new(BufWriter::new(f))?))
}

/// The machine side's telemetry (`--shdr`, `--mqtt`, the live view); its OPC UA keys in
/// `pki/` beside the log.
fn start_telemetry(
    args: &BoardSimArgs,
    sc: &Scenario,
) -> anyhow::Result<crate::telemetry::Telemetry> {
    let pki = match &args.log {
        Some(l) => l.parent().unwrap_or(std::path::Path::new(".")).join("pki"),
        None => std::env::temp_dir().join("acc-board-sim-pki"),
    };
    let tel = crate::telemetry::Telemetry::start(
        &crate::telemetry::with_default_pki(args.telemetry.over(&Default::default()), &pki),
        true,
        sc.controller.period_s,
    )?;
    tel.set_live_info(acc_telemetry::LiveInfo {
        title: "acc board-sim (the simulated machine, as the board sees it)".into(),
        overload_n: None,
    });
    Ok(tel)
}

/// `--wait-for-controller`: hold the machine at t = 0 until the controller sets
/// `ACC_REQUEST`; `period_wall_s` is one period of wall time (s).
fn wait_for_controller(
    stop: &AtomicBool,
    board: &SharedBoard,
    pace: Option<&CommandPace>,
    period_wall_s: f64,
) {
    let wall = SystemClock::new();
    while !stop.load(Ordering::SeqCst) && !lock_board(board).control().acc_request {
        // The controller's writes before its request move nothing.
        if let Some(pace) = pace {
            pace.take_all();
        }
        wall.sleep_until(wall.now() + Duration::from_millis(2));
    }
    // The request arrived a write's time after the controller's tick, and so would every
    // tick of ours: a slow write would then sometimes land after the tick that starts the
    // next period, and the override the controller reads back (OVERRIDE_APPLIED, changed on
    // the write) would not be the one that drove the power sample it reads with it — the
    // discrepancy workflow's replay of `acc run`'s log went 0.033 mm off in position at
    // every such row (docs/twin.md). Half a period later the writes land mid-period.
    if pace.is_none() {
        wall.sleep_until(wall.now() + Duration::from_secs_f64(0.5 * period_wall_s));
    }
    eprintln!("board-sim: controller connected (ACC_REQUEST set); machine time starts");
}

/// The end of a run on stderr: the ticker's figures and the board's final registers.
fn print_end(st: &acc_runtime::TickerStats, board: &SharedBoard) {
    eprintln!(
        "board-sim: {} periods; sim ticker jitter {}; overruns {}",
        st.ticks,
        st.jitter.summary(),
        st.overruns
    );
    let b = lock_board(board);
    let st = b.status();
    eprintln!(
        "board-sim: final ACC_REQUEST={} ACC_ACTIVE={} OVERRIDE_APPLIED={} WATCHDOG_TRIPPED={} FALLBACK_ACTIVE={} FALLBACK_OVERRIDE={} FEED_HOLD_ACTIVE={}",
        u8::from(b.control().acc_request),
        u8::from(st.acc_active),
        st.override_applied_pct,
        u8::from(st.watchdog_tripped),
        u8::from(st.fallback_active),
        st.fallback_override_pct,
        u8::from(st.feed_hold_active)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn protocol_arguments_choose_the_emulated_board() {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: BoardSimArgs,
        }
        let parse = |extra: &[&str]| {
            let mut argv = vec!["acc", "--scenario", "s.toml"];
            argv.extend_from_slice(extra);
            Cli::try_parse_from(argv).map(|c| c.args.emulated_protocol())
        };
        assert_eq!(parse(&[]).expect("default"), EmulatedProtocol::V2);
        assert_eq!(
            parse(&["--protocol", "1"]).expect("v1"),
            EmulatedProtocol::V1Exception
        );
        assert_eq!(
            parse(&["--protocol", "1", "--v1-registers", "zeros"]).expect("v1 zeros"),
            EmulatedProtocol::V1Zeros
        );
        assert_eq!(
            parse(&["--protocol", "2"]).expect("v2"),
            EmulatedProtocol::V2
        );
        for bad in [
            &["--protocol", "3"][..],
            &["--protocol", "0"],
            &["--v1-registers", "ones"],
        ] {
            let e = parse(bad).expect_err("refused").to_string();
            assert!(e.contains(bad[0]), "{e}");
        }
    }
}
