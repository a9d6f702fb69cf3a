//! `acc fault-matrix`: every fault of the reliability table, driven at the worst moment of
//! a real closed loop, on a v2 and on a v1 board, measured on the machine side.
//!
//! Each row is one production run: `acc board-sim` (this same binary) serves the simulated
//! machine of paper case III on a new pty, `acc run` drives it, and the fault hits at
//! `--at-s` of machine time, deep in the 4 mm step where the override and the force are at
//! their highest. Board faults are `acc board-sim --fault` schedules; process faults are real
//! signals sent to the `acc run` process when the board reports the moment. The row is then
//! judged from the two run logs:
//!
//! - **last cmd**: the override ACC last commanded before the fault (the board's
//!   `OVERRIDE_CMD` in the last period it was `ACC_ACTIVE`);
//! - **max applied after**: the largest override on the PMC inputs in the window after the
//!   fault while the feed was not held (in feed hold the axes stand still, whatever the
//!   override);
//! - **force before / after**: the largest true cutting force (the simulator's) in the
//!   `--before-s` before the fault and in the window after it;
//! - **log complete**: `acc run`'s log has one row for every period from the first to the last
//!   (`period` consecutive), skipped and faulty ones included;
//! - **exit**: `acc run`'s exit code (or the signal that ended it).
//!
//! Pass: max applied after ≤ last cmd, force after ≤ 1.05 × force before, log complete. A
//! row no controller can make safe (a v1 board has no fallback clamp) is marked with why;
//! the NC's own override lock is reported, not judged (the NC ignores the override inputs).
//!
//! **Hostile-line rows** (`garbage-*`, `delay-*`): a man in the middle
//! (`tests/peers/mitm_proxy.py`, an independent Python program) sits on the serial line
//! between `acc board-sim`'s pty and `acc run`, transparent until the fault moment, when
//! the harness switches its faults on (SIGUSR1) until the end of the window (SIGUSR2): a
//! share of the replies corrupted with a VALID CRC (a flipped register bit, another slave
//! address, an exception, a wrong byte count, a truncated frame, random contents), or every
//! status read answered with the board's reply of N reads earlier (a buffering gateway).
//! These rows also pass only if
//!
//! - the true force in every period after the fault in which the feed was not held is at
//!   most 1.05 × the force before (ACC keeps driving through a bad line: every period
//!   counts, not only the released ones);
//! - no period after the fault ends in the state `operator_handback` or `switch_off`: the
//!   proxy never touches the knob or the switch, so such a release is a bad frame taken for
//!   the operator;
//! - every status read (FC04) the proxy altered in a way the controller can tell from the
//!   frame ([`must_be_flagged`]) has its period flagged in `acc run`'s log ([`suspicious`]:
//!   `link:`, `implausible:`, `unconfirmed:`, `force_invalid`, `echo`, `delay`). The reads
//!   are matched to the log's rows in order ([`align_reads`], checked on the power the
//!   proxy handed over); if that match is not reliable, the row falls back to counting:
//!   flagged rows after the fault ≥ altered reads that must be flagged, and says so.
//!   Delayed replies are not required to be flagged (nothing in one frame shows them).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use acc_runtime::record::RunRecord;
use anyhow::{bail, Context};

use crate::harness::{
    align_reads, describe, fault_periods_raising, must_be_flagged, read, read_json_lines,
    read_proxy_stats, spawn_proxy, stop_proxy, suspicious, Proc, ProxyEvent, ProxyRead, ProxyStats,
};

/// Arguments of `acc fault-matrix`.
#[derive(Debug, clap::Args)]
pub struct FaultMatrixArgs {
    /// Output directory: `fault-matrix.md` (the table), `fault-matrix.json`, and one folder
    /// of logs per row.
    #[arg(long, default_value = "out/fault-matrix")]
    pub out: PathBuf,
    /// Replace the table between `<!-- fault-matrix:begin -->` and `<!-- fault-matrix:end -->`
    /// in this markdown file (e.g. `docs/reliability.md`).
    #[arg(long)]
    pub update_doc: Option<PathBuf>,
    /// Board protocols to test: `2`, `1` or `both`.
    #[arg(long, default_value = "both")]
    pub protocol: String,
    /// Only these faults (repeatable; names as in the table's first column).
    #[arg(long = "only")]
    pub only: Vec<String>,
    /// Scenario served by `acc board-sim`.
    #[arg(long, default_value = "configs/scenarios/paper_case3.toml")]
    pub scenario: PathBuf,
    /// `acc run` configuration (its `runtime.time_scale` must equal `--time-scale`).
    #[arg(long, default_value = "configs/runtime/fault_matrix.toml")]
    pub config: PathBuf,
    /// Machine seconds per wall second for both processes (1 ..= 20).
    #[arg(long, default_value_t = 5.0)]
    pub time_scale: f64,
    /// Machine time of the fault, s (paper case III: the 4 mm step runs from about 31 s to
    /// 55 s).
    #[arg(long, default_value_t = 40.0)]
    pub at_s: f64,
    /// Window before the fault for the reference force, s of machine time.
    #[arg(long, default_value_t = 2.0)]
    pub before_s: f64,
    /// Window after the fault, s of machine time.
    #[arg(long, default_value_t = 6.0)]
    pub after_s: f64,
    /// Window after the fault of the hostile-line rows (`garbage-*`, `delay-*`), s of machine
    /// time: long enough for 1 % of the replies to be a handful (paper case III's 4 mm step
    /// ends at about 55 s).
    #[arg(long, default_value_t = 12.0)]
    pub line_after_s: f64,
    /// The man-in-the-middle proxy of the hostile-line rows (run with `python3`).
    #[arg(long, default_value = "tests/peers/mitm_proxy.py")]
    pub proxy: PathBuf,
    /// Seed of the proxy's corruption.
    #[arg(long, default_value_t = 1)]
    pub line_seed: u64,
}

/// Largest plausible spindle power, W: `policy.max_power_w` of
/// `configs/runtime/fault_matrix.toml` (a flipped power bit above it must be flagged).
const MAX_POWER_W: f64 = 30_000.0;

/// How a fault is brought about.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Action {
    /// A signal to `acc run` at the moment (`SIGINT`, `SIGTERM`, `SIGKILL`).
    Signal(&'static str),
    /// Two `SIGINT`s, 0.5 s of machine time apart.
    DoubleSigint,
    /// `SIGSTOP` for this many s of machine time, then `SIGCONT` (the controller hangs: the
    /// board's watchdog trips).
    Hang(f64),
    /// An `acc board-sim --fault` at the moment; `{t}` in the text is replaced by the time.
    Board(&'static str),
    /// The man in the middle on the serial line switches its faults on at the moment and off
    /// at the end of the window: `corrupt` of the replies corrupted with a valid CRC (every
    /// kind), and/or every status read answered with the reply of `delay_reads` reads
    /// earlier.
    Line {
        /// Share of the replies corrupted, 0 ..= 1.
        corrupt: f64,
        /// Reads of delay (0: none).
        delay_reads: u32,
    },
}

/// One fault of the matrix.
#[derive(Debug, Clone, Copy)]
struct Fault {
    name: &'static str,
    what: &'static str,
    action: Action,
    /// Why a v1 board cannot be made safe against it (`None`: it must pass on v1 too).
    v1_unsafe: Option<&'static str>,
    /// Not judged: the NC itself ignores the override inputs.
    not_judged: Option<&'static str>,
}

const NO_CLAMP: &str = "v1 board: no fallback clamp; with the controller gone the board falls back to the operator's knob (100 %)";

const FAULTS: &[Fault] = &[
    Fault {
        name: "sigint",
        what: "Ctrl-C to acc run",
        action: Action::Signal("INT"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigterm",
        what: "SIGTERM to acc run",
        action: Action::Signal("TERM"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigint-twice",
        what: "a second Ctrl-C 0.5 s later",
        action: Action::DoubleSigint,
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigkill",
        what: "kill -9 acc run",
        action: Action::Signal("KILL"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "watchdog",
        what: "acc run hangs 2 s (SIGSTOP/SIGCONT): the board's watchdog trips",
        action: Action::Hang(2.0),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "cable-pulled",
        what: "the line goes dead for 3 s (no replies), then comes back",
        action: Action::Board("unplug@{t}:3"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "device-vanished",
        what: "the serial device disappears for good",
        action: Action::Board("vanish@{t}"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "board-restart",
        what: "the board power-cycles",
        action: Action::Board("restart@{t}"),
        v1_unsafe: Some("v1 board: it comes up at the operator's knob, with no feed hold at power-up, for the period before the controller sees it"),
        not_judged: None,
    },
    Fault {
        name: "crc",
        what: "20 replies with a bad CRC",
        action: Action::Board("crc@{t}:20"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "late",
        what: "4 replies late (after the timeout: the link resynchronises)",
        action: Action::Board("late@{t}:4"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "frozen-seq",
        what: "SAMPLE_SEQ frozen for 3 s (stale power sensor)",
        action: Action::Board("freeze-seq@{t}:3"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "bad-power",
        what: "power register 0xFFFFFFFF (implausible) for 3 s",
        action: Action::Board("bad-power@{t}:3"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "knob-down",
        what: "the operator turns the knob from 100 % to 60 %",
        action: Action::Board("operator@{t}:60"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "override-locked",
        what: "the NC locks the override for 3 s (tapping, override cancel)",
        action: Action::Board("lock@{t}:3"),
        v1_unsafe: None,
        not_judged: Some("the NC forces 100 % itself (OVERRIDE_LOCKED): the board reports it, no controller can change it"),
    },
    Fault {
        name: "hard-spot",
        what: "a hard spot: the material's Ks × 2.5 for 2 s (ACC rides it)",
        action: Action::Board("hard@{t}:2:2.5"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "overload",
        what: "Ks × 12 for 2 s: above the overload limit even at the 10 % minimum (overload protection)",
        action: Action::Board("hard@{t}:2:12"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "garbage-1pct",
        what: "a man in the middle corrupts 1 % of the replies with a valid CRC (flipped bit, slave, exception, byte count, truncated, random)",
        action: Action::Line {
            corrupt: 0.01,
            delay_reads: 0,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "garbage-10pct",
        what: "a man in the middle corrupts 10 % of the replies with a valid CRC (all six kinds)",
        action: Action::Line {
            corrupt: 0.10,
            delay_reads: 0,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-2",
        what: "every status read answered with the board's reply of 2 reads earlier (a buffering gateway), sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 2,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-3",
        what: "every status read answered with the board's reply of 3 reads earlier, sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 3,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-5",
        what: "every status read answered with the board's reply of 5 reads earlier, sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 5,
        },
        v1_unsafe: None,
        not_judged: None,
    },
];

/// What the man in the middle did in a hostile-line row, and what `acc run` made of it.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LineReport {
    /// The proxy's counters.
    pub proxy: ProxyStats,
    /// Replies the proxy altered after the fault (corrupted or delayed).
    pub altered_replies: u64,
    /// Status reads (FC04) it corrupted (delays not counted).
    pub corrupted_reads: usize,
    /// Status reads it delayed.
    pub delayed_reads: usize,
    /// Corrupted status reads that must be flagged ([`must_be_flagged`]).
    pub must_flag: usize,
    /// Of which flagged in `acc run`'s log (read by read), or, when `matching` is
    /// `counts`, the rows after the fault flagged as suspicious.
    pub flagged: usize,
    /// `read by read` (matched, [`align_reads`]) or `counts` (the match was not reliable).
    pub matching: String,
    /// Rows whose logged power was checked against the proxy's reads, and agreed.
    pub aligned: (usize, usize),
    /// Rows after the fault that `acc run` flagged as suspicious ([`suspicious`]).
    pub suspicious_rows: usize,
    /// Corrupted reads that must be flagged and were not: `read #i (kind, register): t = …`.
    pub unflagged: Vec<String>,
    /// Periods after the fault that entered `operator_handback` or `switch_off`.
    pub operator_releases: usize,
}

/// The measured outcome of one row.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    /// Fault name.
    pub fault: String,
    /// What the fault is.
    pub what: String,
    /// Board protocol, 1 or 2.
    pub protocol: u8,
    /// Machine time the fault hit, s.
    pub t_fault_s: Option<f64>,
    /// Last override ACC commanded before the fault, percent.
    pub last_cmd_pct: Option<u16>,
    /// Largest applied override after the fault in periods where ACC was not driving the
    /// override and the feed was not held, percent (`None`: ACC drove, or the feed was held,
    /// in every period of the window).
    pub max_applied_after_pct: Option<u16>,
    /// Largest true force in the window before the fault, N.
    pub force_before_n: f64,
    /// Largest true force in the window after the fault, N (all periods, including those
    /// in which ACC drove the override again).
    pub force_after_n: f64,
    /// Largest true force after the fault in periods where ACC was not driving, N.
    pub force_after_released_n: f64,
    /// Periods of `acc run` with an unusable force sample or a link fault in which the
    /// command rose above the one before.
    pub raised_in_fault: usize,
    /// The feed was held (feed hold active) at some point after the fault.
    pub feed_hold_after: bool,
    /// `acc run`'s log rows, and whether every period from first to last has one.
    pub log_rows: usize,
    /// Every period has a row.
    pub log_complete: bool,
    /// `acc run`'s exit: code, or `signal N`, or `stopped by the harness (code)`.
    pub exit: String,
    /// `pass`, `FAIL: …`, `unsafe on v1: …` or `not judged: …`.
    pub verdict: String,
    /// The row passed (or is marked with a reason).
    pub ok: bool,
    /// Hostile-line rows: the proxy's alterations and the controller's flags.
    pub line: Option<LineReport>,
}

/// `acc fault-matrix`.
pub fn run_cmd(args: &FaultMatrixArgs) -> anyhow::Result<()> {
    if !(args.time_scale.is_finite() && (1.0..=20.0).contains(&args.time_scale)) {
        bail!("--time-scale {}: allowed 1 ..= 20", args.time_scale);
    }
    let protocols: &[u8] = match args.protocol.as_str() {
        "both" => &[2, 1],
        "2" => &[2],
        "1" => &[1],
        p => bail!("--protocol {p}: allowed 2, 1 or both"),
    };
    for o in &args.only {
        if !FAULTS.iter().any(|f| f.name == o) {
            let names: Vec<_> = FAULTS.iter().map(|f| f.name).collect();
            bail!(
                "--only {o}: not a fault of the matrix; allowed: {}",
                names.join(", ")
            );
        }
    }
    for (flag, v) in [
        ("--at-s", args.at_s),
        ("--before-s", args.before_s),
        ("--after-s", args.after_s),
        ("--line-after-s", args.line_after_s),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 600.0) {
            bail!("{flag} {v}: allowed 0 < s <= 600");
        }
    }
    for (what, p) in [("--scenario", &args.scenario), ("--config", &args.config)] {
        if !p.is_file() {
            bail!("{what} {}: no such file", p.display());
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let faults: Vec<&Fault> = FAULTS
        .iter()
        .filter(|f| args.only.is_empty() || args.only.iter().any(|o| o == f.name))
        .collect();
    let total = faults.len() * protocols.len();
    let mut rows = Vec::new();
    let started = Instant::now();
    for &protocol in protocols {
        for f in &faults {
            let dir = args.out.join(format!("v{protocol}-{}", f.name));
            std::fs::create_dir_all(&dir)?;
            eprint!(
                "[{:>2}/{total}] v{protocol} {:<16} ",
                rows.len() + 1,
                f.name
            );
            std::io::stderr().flush().ok();
            let row = run_row(args, f, protocol, &dir)
                .with_context(|| format!("fault-matrix row v{protocol} {}", f.name))?;
            eprintln!(
                "{} ({:.0} s elapsed)",
                row.verdict,
                started.elapsed().as_secs_f64()
            );
            rows.push(row);
        }
    }
    let table = markdown(&rows, args);
    std::fs::write(args.out.join("fault-matrix.md"), &table)?;
    std::fs::write(
        args.out.join("fault-matrix.json"),
        serde_json::to_string_pretty(&rows)?,
    )?;
    println!("{table}");
    if let Some(doc) = &args.update_doc {
        update_doc(doc, &table)?;
        eprintln!("fault-matrix: table written into {}", doc.display());
    }
    let failed: Vec<_> = rows.iter().filter(|r| !r.ok).collect();
    if !failed.is_empty() {
        bail!(
            "{} of {} rows failed: {}",
            failed.len(),
            rows.len(),
            failed
                .iter()
                .map(|r| format!("v{} {}", r.protocol, r.fault))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

fn s(v: impl ToString) -> String {
    v.to_string()
}

/// The window after the fault of a row, s of machine time.
fn window_s(f: &Fault, args: &FaultMatrixArgs) -> f64 {
    match f.action {
        Action::Line { .. } => args.line_after_s,
        _ => args.after_s,
    }
}

fn run_row(args: &FaultMatrixArgs, f: &Fault, protocol: u8, dir: &Path) -> anyhow::Result<Row> {
    let machine_log = dir.join("machine.csv");
    let run_log = dir.join("run.csv");
    let at = args.at_s;
    let scale = args.time_scale;
    let after_s = window_s(f, args);
    let wall = |machine_s: f64| Duration::from_secs_f64(machine_s / scale);
    // The moment: a board fault at `at`, or a marker (the knob set to where it is) for the
    // process and line faults.
    let fault_spec = match f.action {
        Action::Board(spec) => spec.replace("{t}", &format!("{at}")),
        _ => format!("operator@{at}:100"),
    };
    let mut bargs = vec![
        s("board-sim"),
        s("--scenario"),
        args.scenario.to_string_lossy().into_owned(),
        s("--time-scale"),
        format!("{scale}"),
        s("--baud"),
        s("115200"),
        s("--wait-for-controller"),
        s("--watchdog-time"),
        s("machine"),
        s("--protocol"),
        protocol.to_string(),
        s("--log"),
        machine_log.to_string_lossy().into_owned(),
        s("--fault"),
        fault_spec,
        s("--late-ms"),
        s("12"),
    ];
    if protocol == 1 {
        bargs.extend([s("--v1-registers"), s("exception")]);
    }
    let (mut board, pty) = Proc::spawn(&bargs, dir, "board-sim")?;
    let Some(pty) = pty.filter(|p| p.starts_with('/')) else {
        board.wait(Duration::from_secs(2));
        board.drain(Duration::from_millis(200));
        bail!(
            "acc board-sim printed no pty path: {}",
            board.seen.join(" / ")
        );
    };
    // A hostile line: the man in the middle between the board's pty and acc run, faults off.
    let proxy_files = (
        dir.join("proxy-stats.json"),
        dir.join("proxy-events.jsonl"),
        dir.join("proxy-reads.jsonl"),
    );
    let (mut proxy, port) = match f.action {
        Action::Line {
            corrupt,
            delay_reads,
        } => {
            let pargs = vec![
                s("--seed"),
                args.line_seed.to_string(),
                s("--corrupt"),
                format!("{corrupt}"),
                s("--delay-reads"),
                delay_reads.to_string(),
                s("--start"),
                s("off"),
                s("--stats"),
                proxy_files.0.to_string_lossy().into_owned(),
                s("--events"),
                proxy_files.1.to_string_lossy().into_owned(),
                s("--reads"),
                proxy_files.2.to_string_lossy().into_owned(),
            ];
            let (p, port) = spawn_proxy(&args.proxy, &pty, &pargs, dir)?;
            (Some(p), port)
        }
        _ => (None, pty),
    };
    let rargs = vec![
        s("run"),
        s("--config"),
        args.config.to_string_lossy().into_owned(),
        s("--port"),
        port,
        s("--log"),
        run_log.to_string_lossy().into_owned(),
    ];
    let (mut run, _) = Proc::spawn(&rargs, dir, "run")?;
    // Wait for the moment (machine time `at` plus start-up slack).
    let line = board
        .wait_for(": fault ", wall(at) + Duration::from_secs(30))
        .with_context(|| {
            format!(
                "acc board-sim never reached t = {at} s; see {}",
                dir.display()
            )
        })?;
    let t_fault = parse_fault_time(&line);
    let mut harness_stop = true;
    match f.action {
        Action::Signal(sig) => {
            run.signal(sig);
            harness_stop = false;
        }
        Action::DoubleSigint => {
            run.signal("INT");
            std::thread::sleep(wall(0.5));
            run.signal("INT");
            harness_stop = false;
        }
        Action::Hang(secs) => {
            run.signal("STOP");
            std::thread::sleep(wall(secs));
            run.signal("CONT");
        }
        Action::Line { .. } => {
            if let Some(p) = &proxy {
                p.signal("USR1");
            }
        }
        Action::Board(_) => {}
    }
    // The window after the fault (and a signalled acc run's drain: at most 10 s + slack).
    let exit = if harness_stop {
        let st = run.wait(wall(after_s + 0.5));
        // The line's faults end with the window: acc run then stops on a clean line.
        if let Some(p) = &proxy {
            p.signal("USR2");
        }
        match st {
            Some(st) => describe(st),
            None => {
                run.signal("INT");
                match run.wait(Duration::from_secs(20)) {
                    Some(st) => format!("running; stopped by the harness ({})", describe(st)),
                    None => "hung (killed by the harness)".into(),
                }
            }
        }
    } else {
        match run.wait(wall(15.0) + Duration::from_secs(10)) {
            Some(st) => describe(st),
            None => "hung (killed by the harness)".into(),
        }
    };
    // Let the machine show what the board does with the controller gone, then stop it.
    std::thread::sleep(wall(1.0));
    if let Some(p) = proxy.as_mut() {
        stop_proxy(p);
    }
    board.signal("INT");
    if board.wait(Duration::from_secs(10)).is_none() {
        board.signal("KILL");
    }
    drop(run);
    drop(board);
    drop(proxy);

    let m = read(&machine_log)?;
    let r = read(&run_log).unwrap_or_default();
    let line = match f.action {
        Action::Line { .. } => Some(LineInput {
            stats: read_proxy_stats(&proxy_files.0).ok(),
            events: read_json_lines(&proxy_files.1).unwrap_or_default(),
            reads: read_json_lines(&proxy_files.2).unwrap_or_default(),
        }),
        _ => None,
    };
    let logs = Logs {
        machine: &m,
        run: &r,
        line: line.as_ref(),
    };
    Ok(judge(f, protocol, t_fault, logs, exit, args))
}

/// What the proxy of a hostile-line row wrote.
#[derive(Debug, Clone, Default)]
struct LineInput {
    stats: Option<ProxyStats>,
    events: Vec<ProxyEvent>,
    reads: Vec<ProxyRead>,
}

/// `board-sim: t = 40.0 s: fault Operator(100) (scheduled at 40 s)` → 40.0.
fn parse_fault_time(line: &str) -> Option<f64> {
    let rest = line.split("t = ").nth(1)?;
    rest.split(' ').next()?.parse().ok()
}

/// What a row is judged from: the machine-side log, `acc run`'s log, and on a hostile line
/// what the proxy wrote.
#[derive(Debug, Clone, Copy)]
struct Logs<'a> {
    machine: &'a [RunRecord],
    run: &'a [RunRecord],
    line: Option<&'a LineInput>,
}

fn judge(
    f: &Fault,
    protocol: u8,
    t_fault: Option<f64>,
    logs: Logs<'_>,
    exit: String,
    args: &FaultMatrixArgs,
) -> Row {
    let (m, r) = (logs.machine, logs.run);
    let tf = t_fault.unwrap_or(args.at_s);
    // A machine row covers the period ending at t_s: the fault's period is the first with
    // t_s > tf. A signalled acc run drains for up to 10 s and then releases: its window runs
    // to the end of the machine log.
    let until = match f.action {
        Action::Signal(_) | Action::DoubleSigint => f64::INFINITY,
        _ => tf + window_s(f, args),
    };
    let before: Vec<&RunRecord> = m.iter().filter(|x| x.t_s <= tf).collect();
    let after: Vec<&RunRecord> = m.iter().filter(|x| x.t_s > tf && x.t_s <= until).collect();
    let driving = |x: &RunRecord| x.state == "acc_active";
    let last_cmd = before
        .iter()
        .rev()
        .find(|x| driving(x))
        .and_then(|x| x.override_applied_pct);
    // Board side: in every period after the fault in which ACC was not driving the override
    // and the feed was not held, the applied override is at most what ACC last commanded
    // (tracked through the window: ACC may re-arm and command again).
    let mut last = last_cmd;
    let mut max_released: Option<u16> = None;
    let mut over = Vec::new();
    for x in &after {
        if driving(x) {
            last = x.override_applied_pct.or(last);
            continue;
        }
        if x.feed_hold {
            continue;
        }
        if let Some(a) = x.override_applied_pct {
            max_released = Some(max_released.map_or(a, |m: u16| m.max(a)));
            if let Some(c) = last.filter(|c| a > *c) {
                over.push(format!("t = {:.1} s: {c} → {a} %", x.t_s));
            }
        }
    }
    let force = |x: &&RunRecord| x.force_true_n.unwrap_or(0.0);
    let force_before = before
        .iter()
        .filter(|x| x.t_s > tf - args.before_s)
        .map(force)
        .fold(0.0, f64::max);
    let force_after = after.iter().map(force).fold(0.0, f64::max);
    let force_after_released = after
        .iter()
        .filter(|x| !driving(x))
        .map(force)
        .fold(0.0, f64::max);
    let feed_hold_after = after.iter().any(|x| x.feed_hold);
    // Controller side: no period with an unusable force sample or a link fault raised the
    // command above the one before it.
    let raised = fault_periods_raising(r);
    let log_complete =
        !r.is_empty() && r.windows(2).all(|w| w[1].period == w[0].period + 1) && r[0].period == 0;

    let mut problems = Vec::new();
    if m.is_empty() || after.is_empty() {
        problems.push("no machine rows after the fault".to_string());
    }
    if last_cmd.is_none() {
        problems.push("ACC was not active before the fault".into());
    }
    if let Some(first) = over.first() {
        problems.push(format!(
            "override above ACC's last command in {} periods (first {first})",
            over.len()
        ));
    }
    let on_line = matches!(f.action, Action::Line { .. });
    if on_line {
        // ACC drives through a bad line: every period counts in which the feed moved.
        let moving = after
            .iter()
            .filter(|x| !x.feed_hold)
            .max_by(|a, b| force(a).total_cmp(&force(b)));
        if let Some(x) = moving.filter(|x| force(x) > 1.05 * force_before) {
            problems.push(format!(
                "force {force_before:.0} → {:.0} N at t = {:.1} s with the feed not held (> 1.05×)",
                force(x),
                x.t_s
            ));
        }
    } else if force_after_released > 1.05 * force_before {
        problems.push(format!(
            "force {force_before:.0} → {force_after_released:.0} N with ACC not driving (> 1.05×)"
        ));
    }
    if raised > 0 {
        problems.push(format!("{raised} fault periods raised the command"));
    }
    if !log_complete {
        problems.push("acc run's log misses periods".into());
    }
    let line = logs
        .line
        .filter(|_| on_line)
        .map(|l| judge_line(l, r, tf, &mut problems));
    let (verdict, ok) = if let Some(why) = f.not_judged {
        (format!("not judged: {why}"), true)
    } else if problems.is_empty() {
        ("pass".to_string(), true)
    } else if protocol == 1 && f.v1_unsafe.is_some() {
        (
            format!(
                "unsafe on v1 ({}): {}",
                problems.join("; "),
                f.v1_unsafe.unwrap_or_default()
            ),
            true,
        )
    } else {
        (format!("FAIL: {}", problems.join("; ")), false)
    };
    Row {
        fault: f.name.into(),
        what: f.what.into(),
        protocol,
        t_fault_s: t_fault,
        last_cmd_pct: last_cmd,
        max_applied_after_pct: max_released,
        force_before_n: force_before,
        force_after_n: force_after,
        force_after_released_n: force_after_released,
        raised_in_fault: raised,
        feed_hold_after,
        log_rows: r.len(),
        log_complete,
        exit,
        verdict,
        ok,
        line,
    }
}

/// The hostile-line criteria (see the module docs); problems are added to `problems`.
fn judge_line(l: &LineInput, r: &[RunRecord], tf: f64, problems: &mut Vec<String>) -> LineReport {
    let mut rep = LineReport::default();
    match &l.stats {
        Some(st) => {
            rep.proxy = st.clone();
            if st.episodes != 1 {
                problems.push(format!(
                    "the proxy's faults were switched on {} times (1 expected)",
                    st.episodes
                ));
            }
        }
        None => problems.push("the proxy wrote no counters".into()),
    }
    rep.altered_replies = rep.proxy.altered_replies;
    if l.events.is_empty() {
        problems.push("the proxy altered no reply: the fault did not happen".into());
    }
    let mut corrupted = std::collections::BTreeSet::new();
    let mut must: std::collections::BTreeMap<u64, &ProxyEvent> = Default::default();
    for e in &l.events {
        let Some(i) = e.read_index.filter(|_| e.fc == 4) else {
            continue;
        };
        if e.kind == "delay" {
            rep.delayed_reads += 1;
            continue;
        }
        corrupted.insert(i);
        if must_be_flagged(e, MAX_POWER_W) {
            must.entry(i).or_insert(e);
        }
    }
    rep.corrupted_reads = corrupted.len();
    rep.must_flag = must.len();
    let after = || r.iter().filter(|x| x.t_s > tf);
    rep.suspicious_rows = after().filter(|x| suspicious(&x.flags)).count();
    let alignment = align_reads(r, &l.reads);
    rep.aligned = (alignment.checked, alignment.agreed);
    if alignment.reliable() {
        rep.matching = "read by read".into();
        for (i, e) in &must {
            let row = alignment.row_of_read.get(i).map(|&j| &r[j]);
            if row.is_some_and(|x| suspicious(&x.flags)) {
                rep.flagged += 1;
            } else {
                let reg = e
                    .register
                    .map_or(String::new(), |g| format!(" register {g}"));
                let at = row.map_or("no row".to_string(), |x| {
                    format!("t = {:.1} s, flags `{}`", x.t_s, x.flags)
                });
                rep.unflagged
                    .push(format!("read #{i} ({}{reg}): {at}", e.kind));
            }
        }
        if let Some(first) = rep.unflagged.first() {
            problems.push(format!(
                "{} of {} corrupted status reads not flagged (first {first})",
                rep.unflagged.len(),
                rep.must_flag
            ));
        }
    } else {
        rep.matching = "counts".into();
        rep.flagged = rep.suspicious_rows;
        if rep.flagged < rep.must_flag {
            problems.push(format!(
                "{} flagged rows after the fault for {} corrupted status reads (reads not matched to rows: {} of {} powers agreed)",
                rep.flagged, rep.must_flag, alignment.agreed, alignment.checked
            ));
        }
    }
    // A release labelled as the operator's: the proxy never touches the knob or the switch.
    let operator = |x: &RunRecord| matches!(x.state.as_str(), "operator_handback" | "switch_off");
    let mut prev_operator = r
        .iter()
        .take_while(|x| x.t_s <= tf)
        .last()
        .is_some_and(operator);
    let mut first = None;
    for x in after() {
        let now = operator(x);
        if now && !prev_operator {
            rep.operator_releases += 1;
            first.get_or_insert(format!("t = {:.1} s: {}", x.t_s, x.state));
        }
        prev_operator = now;
    }
    if let Some(first) = first {
        problems.push(format!(
            "{} releases labelled as the operator's (first {first}): a bad frame taken for the operator",
            rep.operator_releases
        ));
    }
    rep
}

fn markdown(rows: &[Row], args: &FaultMatrixArgs) -> String {
    let mut t = String::new();
    t.push_str(&format!(
        "Generated by `acc fault-matrix --update-doc docs/reliability.md` ({} at {}× time, fault at t = {} s of machine time, windows {} s before / {} s after ({} s on a hostile line); `{}`; hostile line: `{}`, seed {}).\n\n",
        args.scenario.display(),
        args.time_scale,
        args.at_s,
        args.before_s,
        args.after_s,
        args.line_after_s,
        args.config.display(),
        args.proxy.display(),
        args.line_seed,
    ));
    t.push_str("| fault | board | what | last cmd % | max applied, ACC not driving % | force before N | max force after N: all / ACC not driving | feed hold after | fault periods raising cmd | line: replies altered (status reads corrupted / delayed) | corrupted reads flagged / to flag (rows flagged) | operator-labelled releases | log rows (complete) | acc run exit | verdict |\n");
    t.push_str("| --- | --- | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | --- | --- | --- |\n");
    for r in rows {
        let opt = |v: Option<u16>| v.map_or("–".to_string(), |v| v.to_string());
        let (altered, flagged, operator) = match &r.line {
            Some(l) => (
                format!(
                    "{} ({} / {})",
                    l.altered_replies, l.corrupted_reads, l.delayed_reads
                ),
                format!(
                    "{} / {}{} ({} rows)",
                    l.flagged,
                    l.must_flag,
                    if l.matching == "counts" {
                        ", counted"
                    } else {
                        ""
                    },
                    l.suspicious_rows
                ),
                l.operator_releases.to_string(),
            ),
            None => ("–".into(), "–".into(), "–".into()),
        };
        t.push_str(&format!(
            "| {} | v{} | {} | {} | {} | {:.0} | {:.0} / {:.0} | {} | {} | {altered} | {flagged} | {operator} | {} ({}) | {} | {} |\n",
            r.fault,
            r.protocol,
            r.what,
            opt(r.last_cmd_pct),
            opt(r.max_applied_after_pct),
            r.force_before_n,
            r.force_after_n,
            r.force_after_released_n,
            if r.feed_hold_after { "yes" } else { "no" },
            r.raised_in_fault,
            r.log_rows,
            if r.log_complete { "yes" } else { "NO" },
            r.exit,
            r.verdict
        ));
    }
    t
}

fn update_doc(doc: &Path, table: &str) -> anyhow::Result<()> {
    update_between(doc, "fault-matrix", table)
}

/// Replace the text between `<!-- {name}:begin -->` and `<!-- {name}:end -->` in `doc`.
pub fn update_between(doc: &Path, name: &str, table: &str) -> anyhow::Result<()> {
    let begin = format!("<!-- {name}:begin -->");
    let end = format!("<!-- {name}:end -->");
    let text = std::fs::read_to_string(doc).with_context(|| format!("{}", doc.display()))?;
    let (Some(b), Some(e)) = (text.find(&begin), text.find(&end)) else {
        bail!(
            "{}: no `{begin}` … `{end}` markers to put the table between",
            doc.display()
        );
    };
    if e < b {
        bail!("{}: `{end}` comes before `{begin}`", doc.display());
    }
    let new = format!("{}{begin}\n{table}{}", &text[..b], &text[e..]);
    std::fs::write(doc, new).with_context(|| format!("{}", doc.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_time_is_parsed_from_the_board_sim_line() {
        assert_eq!(
            parse_fault_time("board-sim: t = 40.1 s: fault Operator(100) (scheduled at 40 s)"),
            Some(40.1)
        );
        assert_eq!(parse_fault_time("board-sim: something else"), None);
    }

    fn row(t: f64, state: &str, applied: u16, force: f64, hold: bool, period: u64) -> RunRecord {
        RunRecord {
            t_s: t,
            period,
            state: state.into(),
            override_applied_pct: Some(applied),
            force_true_n: Some(force),
            feed_hold: hold,
            ..RunRecord::default()
        }
    }

    fn args() -> FaultMatrixArgs {
        FaultMatrixArgs {
            out: PathBuf::from("x"),
            update_doc: None,
            protocol: "both".into(),
            only: vec![],
            scenario: PathBuf::from("s"),
            config: PathBuf::from("c"),
            time_scale: 10.0,
            at_s: 1.0,
            before_s: 1.0,
            after_s: 1.0,
            line_after_s: 1.0,
            proxy: PathBuf::from("p"),
            line_seed: 1,
        }
    }

    fn logs<'a>(m: &'a [RunRecord], r: &'a [RunRecord]) -> Logs<'a> {
        Logs {
            machine: m,
            run: r,
            line: None,
        }
    }

    #[test]
    fn a_raised_override_or_force_fails_and_a_held_feed_does_not_count() {
        let sigkill = FAULTS.iter().find(|f| f.name == "sigkill").expect("row");
        let run: Vec<RunRecord> = (0..5)
            .map(|i| row(0.1 * i as f64, "active", 80, 0.0, false, i))
            .collect();
        // The knob's 100 % while the feed is held: fine.
        let m = vec![
            row(0.9, "acc_active", 80, 800.0, false, 9),
            row(1.0, "acc_active", 80, 800.0, false, 10),
            row(1.1, "operator", 100, 700.0, true, 11),
            row(1.2, "operator", 100, 0.0, true, 12),
        ];
        let r = judge(
            sigkill,
            2,
            Some(1.0),
            logs(&m, &run),
            "killed".into(),
            &args(),
        );
        assert!(r.ok && r.verdict == "pass", "{r:?}");
        assert_eq!((r.last_cmd_pct, r.max_applied_after_pct), (Some(80), None));
        // The knob's 100 % with the feed moving: a failure on v2, marked on v1.
        let m2 = vec![
            row(1.0, "acc_active", 80, 800.0, false, 10),
            row(1.1, "operator", 100, 900.0, false, 11),
        ];
        let r = judge(
            sigkill,
            2,
            Some(1.0),
            logs(&m2, &run),
            "killed".into(),
            &args(),
        );
        assert!(!r.ok && r.verdict.starts_with("FAIL"), "{r:?}");
        assert!(r.verdict.contains("80 → 100") && r.verdict.contains("800 → 900"));
        let r = judge(
            sigkill,
            1,
            Some(1.0),
            logs(&m2, &run),
            "killed".into(),
            &args(),
        );
        assert!(r.ok && r.verdict.starts_with("unsafe on v1"), "{r:?}");
        // A gap in acc run's periods fails the log check.
        let mut gappy = run.clone();
        gappy.remove(2);
        let r = judge(
            sigkill,
            2,
            Some(1.0),
            logs(&m, &gappy),
            "killed".into(),
            &args(),
        );
        assert!(!r.ok && r.verdict.contains("misses periods"), "{r:?}");
    }

    #[test]
    fn on_a_hostile_line_every_corrupted_read_is_flagged_and_no_release_is_the_operators() {
        // acc run's rows 0..40 (0.1 s apart), one read each after one start-up read.
        let run = |flags_at_20: &str, state_at_25: &str| -> Vec<RunRecord> {
            (0..40)
                .map(|i| RunRecord {
                    t_s: 0.1 * i as f64,
                    period: i as u64,
                    power_w: Some(1000.0 + i as f64),
                    flags: if i == 20 { flags_at_20 } else { "" }.into(),
                    state: if i >= 25 { state_at_25 } else { "active" }.into(),
                    ..RunRecord::default()
                })
                .collect()
        };
        let ev = |read: u64, kind: &str, register: Option<u16>| ProxyEvent {
            t: 0.0,
            read_index: Some(read),
            fc: 4,
            kind: kind.into(),
            register,
            bit: Some(1),
            before: Some(100),
            after: Some(102),
        };
        let input = LineInput {
            stats: Some(ProxyStats {
                episodes: 1,
                altered_replies: 3,
                ..ProxyStats::default()
            }),
            // Read 21 (row 20): a flipped OPERATOR_OVERRIDE bit; read 31: a flipped
            // SPINDLE_RPM bit (not required); a write's echo (not a read).
            events: vec![
                ev(21, "flip", Some(2)),
                ev(31, "flip", Some(6)),
                ProxyEvent {
                    read_index: None,
                    fc: 16,
                    ..ev(0, "slave", None)
                },
            ],
            reads: (0..41)
                .map(|i| ProxyRead {
                    i: Some(i),
                    power: Some(999.0 + i as f64),
                    applied: None,
                    altered: false,
                })
                .collect(),
        };
        let mut problems = Vec::new();
        let rep = judge_line(
            &input,
            &run("unconfirmed:operator_override", "active"),
            1.0,
            &mut problems,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!((rep.corrupted_reads, rep.must_flag, rep.flagged), (2, 1, 1));
        assert_eq!(rep.matching, "read by read");
        let rep = judge_line(
            &input,
            &run("seq_skip:2", "operator_handback"),
            1.0,
            &mut problems,
        );
        assert_eq!((rep.flagged, rep.operator_releases), (0, 1));
        assert!(problems[0].contains("1 of 1 corrupted status reads not flagged (first read #21 (flip register 2): t = 2.0 s"), "{problems:?}");
        assert!(
            problems[1].contains("t = 2.5 s: operator_handback"),
            "{problems:?}"
        );
    }

    #[test]
    fn the_doc_table_goes_between_the_markers() {
        let dir = tempfile::tempdir().expect("tmp");
        let doc = dir.path().join("r.md");
        std::fs::write(
            &doc,
            "# R\n<!-- fault-matrix:begin -->\nold\n<!-- fault-matrix:end -->\ntail\n",
        )
        .expect("write");
        update_doc(&doc, "| new |\n").expect("update");
        let text = std::fs::read_to_string(&doc).expect("read");
        assert_eq!(
            text,
            "# R\n<!-- fault-matrix:begin -->\n| new |\n<!-- fault-matrix:end -->\ntail\n"
        );
        std::fs::write(&doc, "no markers").expect("write");
        assert!(update_doc(&doc, "x").is_err());
    }
}
