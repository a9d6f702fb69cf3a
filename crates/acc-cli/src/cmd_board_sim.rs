//! `acc board-sim --scenario <scenario.toml>`: the PMC interface board served over Modbus
//! RTU on a new pseudo-terminal (its path is printed) or a given serial port, backed by the
//! simulated machine of the scenario.
//!
//! - The register behaviour is acc-pmc's `BoardLogic`, served by its `RtuServer`.
//! - The machine (acc-sim's `Machine`: workpiece, force law, feed drive, override delay,
//!   spindle) advances one control period `T` (the scenario preset's) on its own ticker,
//!   every `T / time_scale` of wall time: the override now applied by the board acts on the
//!   simulated feed; the period's mean spindle power goes to `POWER_HI:POWER_LO` with a new
//!   `SAMPLE_SEQ`.
//! - `--log` writes the machine-side run log (the simulator's schema: path position,
//!   depths, true force) so that a closed loop over the serial line can be judged with the
//!   simulator's summary.
//! - `--fault KIND@T[:ARG]` schedules faults at machine time `T` s for the end-to-end tests:
//!   `crc@T:N` (corrupt the CRC of the next N replies), `drop@T:N` (swallow N replies),
//!   `late@T:N` (deliver N replies `--late-ms` late), `restart@T` (board power cycle),
//!   `freeze-seq@T:S` (`SAMPLE_SEQ` frozen for S s), `bad-power@T:S` (power register
//!   0xFFFFFFFF, i.e. −1 W, for S s), `stall@T:S` (the board stops serving for S s of wall
//!   time: its watchdog trips), `lock@T:S` (`OVERRIDE_LOCKED` for S s: the NC forces 100 %,
//!   as in tapping), `switch@T:on|off` (operator's ACC switch), `operator@T:PCT`
//!   (operator's override knob).

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use acc_pmc::emu::{lock_board, spawn_server, Paced, PtyBoard, SharedBoard};
use acc_runtime::record::{RunLogWriter, RunRecord};
use acc_runtime::shutdown::install_stop_flag;
use acc_runtime::{SystemClock, Ticker};
use acc_sim::board::{add_truth, PowerFault};
use acc_sim::Scenario;
use anyhow::{bail, Context};

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
    /// time and the controller's time share their origin).
    #[arg(long)]
    pub wait_for_controller: bool,
}

/// A fault on the replies the board sends.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ReplyFault {
    Crc,
    Drop,
    Late(Duration),
    Stall(Duration),
}

/// A scheduled fault.
#[derive(Debug, Clone, PartialEq)]
enum Scheduled {
    Replies(ReplyFault, usize),
    Restart,
    FreezeSeq(f64),
    BadPower(f64),
    Lock(f64),
    Switch(bool),
    Operator(u16),
}

fn parse_fault(spec: &str, late: Duration) -> anyhow::Result<(f64, Scheduled)> {
    let err = || {
        anyhow::anyhow!(
            "--fault `{spec}`: expected KIND@T[:ARG] with KIND one of crc, drop, late, restart, freeze-seq, bad-power, lock, stall, switch, operator (T in machine seconds)"
        )
    };
    let (kind, rest) = spec.split_once('@').ok_or_else(err)?;
    let (t, arg) = match rest.split_once(':') {
        Some((t, a)) => (t, Some(a)),
        None => (rest, None),
    };
    let t: f64 = t.parse().map_err(|_| err())?;
    if !(t.is_finite() && t >= 0.0) {
        return Err(err());
    }
    let count = || -> anyhow::Result<usize> {
        arg.unwrap_or("1")
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=10_000).contains(n))
            .ok_or_else(err)
    };
    let secs = || -> anyhow::Result<f64> {
        arg.and_then(|a| a.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s > 0.0 && *s <= 3600.0)
            .ok_or_else(err)
    };
    let f = match kind {
        "crc" => Scheduled::Replies(ReplyFault::Crc, count()?),
        "drop" => Scheduled::Replies(ReplyFault::Drop, count()?),
        "late" => Scheduled::Replies(ReplyFault::Late(late), count()?),
        "stall" => Scheduled::Replies(ReplyFault::Stall(Duration::from_secs_f64(secs()?)), 1),
        "restart" => Scheduled::Restart,
        "freeze-seq" => Scheduled::FreezeSeq(secs()?),
        "bad-power" => Scheduled::BadPower(secs()?),
        "lock" => Scheduled::Lock(secs()?),
        "switch" => match arg {
            Some("on") => Scheduled::Switch(true),
            Some("off") => Scheduled::Switch(false),
            _ => return Err(err()),
        },
        "operator" => Scheduled::Operator(
            arg.and_then(|a| a.parse::<u16>().ok())
                .filter(|p| *p <= 150)
                .ok_or_else(err)?,
        ),
        _ => return Err(err()),
    };
    Ok((t, f))
}

type FaultQueue = Arc<Mutex<VecDeque<ReplyFault>>>;

/// The board's side of the line with reply faults: each `write` of the server is one reply.
struct FaultyReplies<P> {
    inner: P,
    queue: FaultQueue,
}

impl<P: Read> Read for FaultyReplies<P> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf)
    }
}

impl<P: Write> Write for FaultyReplies<P> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let fault = self
            .queue
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop_front();
        match fault {
            None => self.inner.write_all(buf)?,
            Some(ReplyFault::Drop) => {}
            Some(ReplyFault::Crc) => {
                let mut b = buf.to_vec();
                if let Some(x) = b.get_mut(3) {
                    *x ^= 0x01;
                }
                self.inner.write_all(&b)?;
            }
            Some(ReplyFault::Late(d)) | Some(ReplyFault::Stall(d)) => {
                std::thread::sleep(d);
                self.inner.write_all(buf)?;
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

fn wrap<P: Read + Write + Send + 'static>(
    inner: P,
    queue: FaultQueue,
    paced: Option<u32>,
) -> Box<dyn ReadWrite> {
    match paced {
        Some(baud) => Box::new(FaultyReplies {
            inner: Paced::new(inner, baud, 10),
            queue,
        }),
        None => Box::new(FaultyReplies { inner, queue }),
    }
}

trait ReadWrite: Read + Write + Send {}
impl<T: Read + Write + Send> ReadWrite for T {}

/// `acc board-sim`.
pub fn run_cmd(args: &BoardSimArgs) -> anyhow::Result<()> {
    acc_runtime::shutdown::init_tracing(acc_runtime::shutdown::LogFormat::Text, "warn");
    let sc = Scenario::load(&args.scenario)?;
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
    let late = Duration::from_millis(args.late_ms);
    let mut schedule: Vec<(f64, Scheduled)> = args
        .faults
        .iter()
        .map(|f| parse_fault(f, late))
        .collect::<anyhow::Result<_>>()?;
    schedule.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut schedule: VecDeque<_> = schedule.into();

    let period_s = sc.controller.period_s;
    // The same simulated board and plant `acc sim` steps in process, served over the link.
    let mut sim = sc.build_board();
    sim.logic_mut()
        .set_operator_override_pct(args.operator_override);
    let board: SharedBoard = sim.serve();
    let queue: FaultQueue = Arc::default();
    let paced = args.paced.then_some(args.baud);

    // Serve: a new pty (path printed) or the given port.
    let stop_server = Arc::new(AtomicBool::new(false));
    let (pty, server) = match &args.port {
        None => {
            let q = Arc::clone(&queue);
            let pty = PtyBoard::spawn_with(Arc::clone(&board), args.slave, args.baud, move |p| {
                wrap(p, q, paced)
            })
            .context("creating the pseudo-terminal")?;
            println!("{}", pty.path());
            (Some(pty), None)
        }
        Some(dev) => {
            let parity = match args.parity.as_str() {
                "none" => acc_pmc::serialport::Parity::None,
                "even" => acc_pmc::serialport::Parity::Even,
                "odd" => acc_pmc::serialport::Parity::Odd,
                p => bail!("--parity {p}: allowed none, even, odd"),
            };
            let port = acc_pmc::serialport::new(dev, args.baud)
                .parity(parity)
                .data_bits(acc_pmc::serialport::DataBits::Eight)
                .stop_bits(acc_pmc::serialport::StopBits::One)
                .timeout(acc_pmc::serial::POLL_SLICE)
                .open_native()
                .with_context(|| format!("--port {dev}: cannot open"))?;
            let h = spawn_server(
                wrap(port, Arc::clone(&queue), paced),
                args.slave,
                Arc::clone(&board),
                Arc::clone(&stop_server),
            );
            println!("{dev}");
            (None, Some(h))
        }
    };
    std::io::stdout().flush().ok();
    eprintln!(
        "board-sim: `{}`, slave {}, T = {} s machine time every {:.1} ms wall; operator override {} %",
        sc.name,
        args.slave,
        period_s,
        1e3 * period_s / args.time_scale,
        args.operator_override
    );

    let mut log = match &args.log {
        Some(p) => {
            if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            let f = File::create(p).with_context(|| format!("creating {}", p.display()))?;
            Some(RunLogWriter::new(BufWriter::new(f))?)
        }
        None => None,
    };
    let stop = install_stop_flag().context("installing the Ctrl-C handler")?;
    if args.wait_for_controller {
        while !stop.load(Ordering::SeqCst) && !lock_board(&board).control().acc_request {
            std::thread::sleep(Duration::from_millis(2));
        }
        eprintln!("board-sim: controller connected (ACC_REQUEST set); machine time starts");
    }
    let mut ticker = Ticker::new(
        SystemClock::new(),
        Duration::from_secs_f64(period_s / args.time_scale),
    )?;
    let (mut freeze_until, mut bad_until) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut lock_until: Option<f64> = None;
    let mut done_at: Option<f64> = None;
    while !stop.load(Ordering::SeqCst) {
        let tick = ticker.wait();
        let t = sim.machine().t_s();
        while schedule.front().is_some_and(|(at, _)| *at <= t) {
            let Some((at, f)) = schedule.pop_front() else {
                break;
            };
            eprintln!("board-sim: t = {t:.1} s: fault {f:?} (scheduled at {at} s)");
            let mut b = lock_board(&board);
            match f {
                Scheduled::Replies(kind, n) => queue
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .extend(std::iter::repeat_n(kind, n)),
                Scheduled::Restart => b.power_cycle(),
                Scheduled::FreezeSeq(s) => freeze_until = t + s,
                Scheduled::BadPower(s) => bad_until = t + s,
                Scheduled::Lock(s) => {
                    b.set_override_locked(true);
                    lock_until = Some(t + s);
                }
                Scheduled::Switch(on) => b.set_acc_switch(on),
                Scheduled::Operator(p) => b.set_operator_override_pct(p),
            }
        }
        if lock_until.is_some_and(|u| t >= u) {
            lock_board(&board).set_override_locked(false);
            lock_until = None;
        }
        sim.set_power_fault(if t < bad_until {
            Some(PowerFault::Garbage)
        } else if t < freeze_until {
            Some(PowerFault::FrozenSeq)
        } else {
            None
        });
        // The board's side of the period: what the PMC inputs carried while the machine
        // moved (the controller's side is logged by `acc run`).
        let (status, cmd) = {
            let b = lock_board(&board);
            (b.status(), b.override_cmd_pct())
        };
        let programmed = sim.machine().programmed_feed_mm_min();
        let mut row = {
            let rec = sim.advance_period(period_s);
            let mut row = RunRecord {
                t_s: rec.t_end_s,
                period: tick.index,
                late_ms: tick.lateness.as_secs_f64() * 1e3,
                spindle_rpm: Some(rec.spindle_rpm),
                programmed_feed_mm_min: Some(programmed),
                feed_mm_min: Some(programmed * f64::from(status.override_applied_pct) / 100.0),
                power_w: Some(rec.power_mean_w),
                force_ref_n: Some(sc.controller.force_ref_n),
                override_cmd_pct: Some(cmd),
                override_applied_pct: Some(status.override_applied_pct),
                override_operator_pct: Some(status.operator_override_pct),
                state: if status.acc_active {
                    "acc_active"
                } else {
                    "operator"
                }
                .into(),
                feed_hold: status.feed_hold_active,
                x_mm: Some(rec.x_mm),
                ..RunRecord::default()
            };
            add_truth(&mut row, &rec, rec.force_mean_n);
            row
        };
        if tick.overrun {
            row.flag("late");
        }
        if status.watchdog_tripped {
            row.flag("watchdog");
        }
        if let Some(w) = log.as_mut() {
            w.write(&row)?;
        }
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
    let st = ticker.stats();
    eprintln!(
        "board-sim: {} periods; sim ticker jitter {}; overruns {}",
        st.ticks,
        st.jitter.summary(),
        st.overruns
    );
    {
        let b = lock_board(&board);
        let st = b.status();
        eprintln!(
            "board-sim: final ACC_REQUEST={} ACC_ACTIVE={} OVERRIDE_APPLIED={} WATCHDOG_TRIPPED={}",
            u8::from(b.control().acc_request),
            u8::from(st.acc_active),
            st.override_applied_pct,
            u8::from(st.watchdog_tripped)
        );
    }
    stop_server.store(true, Ordering::SeqCst);
    if let Some(p) = pty {
        let s = p.stop()?;
        eprintln!(
            "board-sim: served {} requests ({} exceptions)",
            s.requests, s.exceptions
        );
    }
    if let Some(h) = server {
        match h.join() {
            Ok(Ok(s)) => eprintln!(
                "board-sim: served {} requests ({} exceptions)",
                s.requests, s.exceptions
            ),
            Ok(Err(e)) => eprintln!("board-sim: server stopped: {e}"),
            Err(_) => bail!("board-sim: server thread panicked"),
        }
    }
    Ok(())
}
