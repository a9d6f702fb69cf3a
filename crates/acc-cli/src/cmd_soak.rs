//! `acc soak`: an hour of machine time (by default) of `acc run` against `acc board-sim`
//! over a pty, faster than real time, with a random board fault every few seconds; measures
//! memory growth, lost log rows, dead threads and the never-raise invariant.
//!
//! The machine cuts paper case III's 2-3-4 mm steps over and over (a generated workpiece with
//! as many repeats as the time needs). The fault schedule is drawn from `--seed`: CRC errors,
//! dropped and late replies, a frozen `SAMPLE_SEQ`, implausible power, board restarts, NC
//! override locks, the operator's knob down and back up, hard spots, a dead line for a few
//! seconds; after each one the operator switches ACC off and on again (re-arming a latched
//! release). Both processes' resident memory and thread counts are sampled once a wall
//! second from `/proc`.
//!
//! **Hostile line** (the default; `--no-hostile-line` for the plain soak): the man in the
//! middle (`tests/peers/mitm_proxy.py`) sits on the serial line between `acc board-sim` and
//! `acc run` for the whole soak, started with `--corrupt-always`: `--line-corrupt` (1 %) of
//! the replies are corrupted with a valid CRC all the time (every kind: flipped bit, slave,
//! exception, byte count, truncated, random), and every `--delay-every-s` of machine time
//! (180 s) the harness switches on a delay episode of `--delay-for-s` (10 s, SIGUSR1 on,
//! SIGUSR2 off: with `--corrupt-always` the signals switch only the delay) in which every
//! status read is answered with the board's reply of `--delay-reads` (2) reads earlier.
//! Machine time for the episodes is wall time × `--time-scale` since `acc board-sim` started
//! its machine. Ten seconds before the end the operator re-arms once more (switch off, on),
//! so a release a bad frame latched late in the run is re-armed as after every fault; ACC
//! must then control again, and still at the end unless a read the proxy altered in the five
//! periods before its last release explains it ([`controlling_after_rearm`]).
//!
//! Pass: RSS growth below 1 MiB for each process (median of the last minute of samples
//! against the median of the first minute after warm-up), no lost rows in either log, the
//! thread counts never drop (a dead server thread), `acc run` still controlling at the end
//! (on a hostile line: see above), and no period with an unusable force sample
//! raising the command; on a hostile line also that the proxy corrupted replies and ran
//! every planned delay episode (the table reports both).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use acc_runtime::record::RunRecord;
use anyhow::{bail, Context};
use rand::{Rng, SeedableRng};

use crate::harness::{
    align_reads, describe, fault_periods_raising, read, read_json_lines, read_proxy_stats,
    rss_kib_and_threads, spawn_proxy, stop_proxy, suspicious, trustworthy, Alignment, Proc,
    ProxyEvent, ProxyRead, ProxyStats,
};

/// Arguments of `acc soak`.
#[derive(Debug, clap::Args)]
pub struct SoakArgs {
    /// Machine time to run, s (60 ..= 86 400; default one hour).
    #[arg(long, default_value_t = 3600.0)]
    pub machine_s: f64,
    /// Machine seconds per wall second (1 ..= 20).
    #[arg(long, default_value_t = 10.0)]
    pub time_scale: f64,
    /// Mean time between faults, s of machine time (1 ..= 600).
    #[arg(long, default_value_t = 5.0)]
    pub fault_every_s: f64,
    /// Seed of the fault schedule.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Board protocol served by `acc board-sim`: 2 or 1.
    #[arg(long, default_value_t = 2)]
    pub protocol: u8,
    /// `acc run` configuration (its `runtime.time_scale` must equal `--time-scale`).
    #[arg(long, default_value = "configs/runtime/soak.toml")]
    pub config: PathBuf,
    /// Scenario whose machine, tool, controller and workpiece pattern are repeated.
    #[arg(long, default_value = "configs/scenarios/paper_case3.toml")]
    pub scenario: PathBuf,
    /// Output directory: soak.md, soak.json, memory plot, both run logs.
    #[arg(long, default_value = "out/soak")]
    pub out: PathBuf,
    /// Replace the text between `<!-- soak:begin -->` and `<!-- soak:end -->` in this file.
    #[arg(long)]
    pub update_doc: Option<PathBuf>,
    /// Put the man in the middle on the line (the default).
    #[arg(long, overrides_with = "no_hostile_line")]
    pub hostile_line: bool,
    /// The old soak: `acc run` directly on `acc board-sim`'s pty.
    #[arg(long, overrides_with = "hostile_line")]
    pub no_hostile_line: bool,
    /// Share of the replies corrupted with a valid CRC, all the time (0 ..= 1).
    #[arg(long, default_value_t = 0.01)]
    pub line_corrupt: f64,
    /// Reads of delay in a delay episode (1 ..= 20).
    #[arg(long, default_value_t = 2)]
    pub delay_reads: u32,
    /// A delay episode starts every this many s of machine time (10 ..= 86 400).
    #[arg(long, default_value_t = 180.0)]
    pub delay_every_s: f64,
    /// Length of a delay episode, s of machine time (> 0, < `--delay-every-s`).
    #[arg(long, default_value_t = 10.0)]
    pub delay_for_s: f64,
    /// The man-in-the-middle proxy (run with `python3`).
    #[arg(long, default_value = "tests/peers/mitm_proxy.py")]
    pub proxy: PathBuf,
}

impl SoakArgs {
    /// The proxy is in the line.
    pub fn hostile(&self) -> bool {
        !self.no_hostile_line
    }
}

/// The hostile line's delay episodes: (on, off) in machine time, each ending at least 15 s
/// before the end (the last re-arm is at 10 s before the end).
fn delay_episodes(machine_s: f64, every_s: f64, for_s: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut t = every_s;
    while t + for_s <= machine_s - 15.0 {
        out.push((t, t + for_s));
        t += every_s;
    }
    out
}

/// What the man in the middle did over the soak.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SoakLine {
    /// The proxy's counters.
    pub proxy: ProxyStats,
    /// Replies corrupted with a valid CRC.
    pub corrupted: u64,
    /// Delay episodes planned, and switched on.
    pub episodes_planned: usize,
    /// Delay episodes the proxy ran.
    pub episodes: u64,
    /// Status reads answered with an older reply.
    pub delayed_reads: u64,
    /// Rows of `acc run` flagged as not taking a read at face value (`link:`,
    /// `implausible:`, `unconfirmed:`, `force_invalid`, `echo`, `delay`).
    pub suspicious_rows: usize,
    /// Periods that entered `operator_handback` or `switch_off` (the soak's operator does
    /// switch and turn the knob: reported, not judged).
    pub operator_releases: usize,
    /// Rows whose logged power was checked against the proxy's reads, and agreed
    /// ([`align_reads`]).
    pub aligned: (usize, usize),
}

/// What `analyse` needs to know of the hostile line.
#[derive(Debug, Clone, Default)]
struct LineInput {
    stats: Option<ProxyStats>,
    episodes_planned: usize,
    /// Machine time of the last re-arm.
    rearm_at: f64,
    /// The proxy's alterations and the reads it handed over.
    events: Vec<ProxyEvent>,
    reads: Vec<ProxyRead>,
}

/// Periods before a release in which a read the proxy altered explains it.
const FRESH_BAD_FRAME_PERIODS: usize = 5;

/// On a hostile line, `acc run` still controls at the end: ACC is active after the
/// operator's last re-arm, and at the end, unless its last release came within
/// [`FRESH_BAD_FRAME_PERIODS`] periods after a read the proxy altered (a fresh bad frame
/// latched it, as it may at any time on this line). The reads are matched to the rows with
/// [`align_reads`]; without a reliable match ACC must be active at the end. A problem, if
/// any.
fn controlling_after_rearm(
    r: &[RunRecord],
    l: &LineInput,
    alignment: &Alignment,
) -> Option<String> {
    let from = r.iter().position(|x| x.t_s > l.rearm_at + 0.5)?;
    let active = |x: &RunRecord| x.state == "active";
    if !r[from..].iter().any(active) {
        return Some("ACC was not controlling after the operator's last re-arm".into());
    }
    if r.last().is_some_and(active) {
        return None;
    }
    let release = (from.max(1)..r.len())
        .rev()
        .find(|&j| active(&r[j - 1]) && !active(&r[j]))?;
    let x = &r[release];
    // The match where it matters: the 30 s of rows before the release.
    let (checked, agreed) =
        alignment.agreement_in(r, &l.reads, release.saturating_sub(300)..release + 1);
    if !trustworthy(checked, agreed) {
        return Some(format!(
            "ACC released at t = {:.1} s ({}) after the operator's last re-arm, and the proxy's reads could not be matched to the rows ({agreed} of {checked} powers agree)",
            x.t_s, x.state
        ));
    }
    let altered: std::collections::HashSet<usize> = l
        .events
        .iter()
        .filter_map(|e| e.read_index)
        .filter_map(|i| alignment.row_of_read.get(&i).copied())
        .collect();
    let fresh =
        (release.saturating_sub(FRESH_BAD_FRAME_PERIODS)..=release).any(|j| altered.contains(&j));
    (!fresh).then(|| {
        format!(
            "ACC released at t = {:.1} s ({}, flags `{}`) after the operator's last re-arm with no read altered by the proxy in the {FRESH_BAD_FRAME_PERIODS} periods before",
            x.t_s, x.state, x.flags
        )
    })
}

/// The measured outcome.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SoakReport {
    /// Machine time covered by `acc run`'s log, s.
    pub machine_s: f64,
    /// Wall time of the run, s.
    pub wall_s: f64,
    /// Faults the board fired.
    pub faults_fired: usize,
    /// Faults by kind.
    pub faults_by_kind: Vec<(String, usize)>,
    /// `acc run` rows, and the periods missing between its first and last row.
    pub run_rows: usize,
    /// Periods without a row in `acc run`'s log.
    pub run_missing: u64,
    /// Rows flagged skipped / late / link error in `acc run`'s log.
    pub run_flagged: usize,
    /// Machine-side rows and missing periods.
    pub machine_rows: usize,
    /// Periods without a row in the machine-side log.
    pub machine_missing: u64,
    /// Deadlines board-sim's ticker skipped (it fell more than a period behind the wall
    /// clock: machine time lagged, no machine period was lost; flagged `ticks_skipped:<n>`).
    pub machine_ticks_skipped: u64,
    /// The run was long enough (≥ 150 s of wall time) to measure memory growth.
    pub memory_measured: bool,
    /// RSS growth of `acc run`, KiB (last minute vs first minute after warm-up).
    pub run_rss_growth_kib: i64,
    /// RSS of `acc run` at the end, KiB.
    pub run_rss_end_kib: u64,
    /// RSS growth of `acc board-sim`, KiB.
    pub board_rss_growth_kib: i64,
    /// RSS of `acc board-sim` at the end, KiB.
    pub board_rss_end_kib: u64,
    /// Thread counts (min, max) of `acc run` and `acc board-sim` after start-up.
    pub run_threads: (u64, u64),
    /// Thread counts of `acc board-sim`.
    pub board_threads: (u64, u64),
    /// Fault periods that raised the command (must be 0).
    pub raised_in_fault: usize,
    /// Largest true force while ACC was active and not in feed hold, N; and Fr.
    pub max_force_n: f64,
    /// Share of the run ACC was active, percent.
    pub active_pct: f64,
    /// `acc run`'s exit.
    pub exit: String,
    /// ACC was active in the last second of the run.
    pub active_at_end: bool,
    /// The hostile line (`None`: `--no-hostile-line`).
    pub line: Option<SoakLine>,
    /// Verdict lines (empty = pass).
    pub problems: Vec<String>,
}

/// `acc soak`.
pub fn run_cmd(args: &SoakArgs) -> anyhow::Result<()> {
    if !(args.machine_s.is_finite() && (60.0..=86_400.0).contains(&args.machine_s)) {
        bail!("--machine-s {}: allowed 60 ..= 86400", args.machine_s);
    }
    if !(args.time_scale.is_finite() && (1.0..=20.0).contains(&args.time_scale)) {
        bail!("--time-scale {}: allowed 1 ..= 20", args.time_scale);
    }
    if !(args.fault_every_s.is_finite() && (1.0..=600.0).contains(&args.fault_every_s)) {
        bail!("--fault-every-s {}: allowed 1 ..= 600", args.fault_every_s);
    }
    if !matches!(args.protocol, 1 | 2) {
        bail!("--protocol {}: allowed 1 or 2", args.protocol);
    }
    if !(args.line_corrupt.is_finite() && (0.0..=1.0).contains(&args.line_corrupt)) {
        bail!("--line-corrupt {}: allowed 0 ..= 1", args.line_corrupt);
    }
    if !(1..=20).contains(&args.delay_reads) {
        bail!("--delay-reads {}: allowed 1 ..= 20", args.delay_reads);
    }
    if !(args.delay_every_s.is_finite() && (10.0..=86_400.0).contains(&args.delay_every_s)) {
        bail!(
            "--delay-every-s {}: allowed 10 ..= 86400",
            args.delay_every_s
        );
    }
    if !(args.delay_for_s.is_finite()
        && args.delay_for_s > 0.0
        && args.delay_for_s < args.delay_every_s)
    {
        bail!(
            "--delay-for-s {}: allowed 0 < s < --delay-every-s ({})",
            args.delay_for_s,
            args.delay_every_s
        );
    }
    for (what, p) in [("--scenario", &args.scenario), ("--config", &args.config)] {
        if !p.is_file() {
            bail!("{what} {}: no such file", p.display());
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let scenario = write_soak_scenario(&args.scenario, &args.out, args.machine_s)?;
    let mut schedule = fault_schedule(args.seed, args.machine_s, args.fault_every_s);
    let rearm_at = args.machine_s - 10.0;
    if args.hostile() {
        schedule.extend(final_rearm(rearm_at));
    }
    let episodes = if args.hostile() {
        delay_episodes(args.machine_s, args.delay_every_s, args.delay_for_s)
    } else {
        Vec::new()
    };
    let machine_log = args.out.join("machine.csv");
    let run_log = args.out.join("run.csv");

    let mut bargs: Vec<String> = [
        "board-sim",
        "--scenario",
        &scenario.to_string_lossy(),
        "--time-scale",
        &args.time_scale.to_string(),
        "--baud",
        "115200",
        "--wait-for-controller",
        "--watchdog-time",
        "machine",
        "--protocol",
        &args.protocol.to_string(),
        "--log",
        &machine_log.to_string_lossy(),
        "--late-ms",
        "8",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for f in &schedule {
        bargs.push("--fault".into());
        bargs.push(f.clone());
    }
    let (mut board, pty) = Proc::spawn(&bargs, &args.out, "board-sim")?;
    let pty = pty
        .filter(|p| p.starts_with('/'))
        .context("acc board-sim printed no pty path (see board-sim.stderr)")?;
    let stats_file = args.out.join("proxy-stats.json");
    let events_file = args.out.join("proxy-events.jsonl");
    let reads_file = args.out.join("proxy-reads.jsonl");
    let (mut proxy, port) = if args.hostile() {
        let pargs: Vec<String> = [
            "--seed",
            &args.seed.to_string(),
            "--corrupt",
            &args.line_corrupt.to_string(),
            "--corrupt-always",
            "--delay-reads",
            &args.delay_reads.to_string(),
            "--start",
            "off",
            "--stats",
            &stats_file.to_string_lossy(),
            "--events",
            &events_file.to_string_lossy(),
            "--reads",
            &reads_file.to_string_lossy(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let (p, port) = spawn_proxy(&args.proxy, &pty, &pargs, &args.out)?;
        (Some(p), port)
    } else {
        (None, pty)
    };
    let rargs: Vec<String> = [
        "run",
        "--config",
        &args.config.to_string_lossy(),
        "--port",
        &port,
        "--log",
        &run_log.to_string_lossy(),
        "--duration-s",
        &args.machine_s.to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let (mut run, _) = Proc::spawn(&rargs, &args.out, "run")?;
    eprintln!(
        "soak: {} s of machine time at {}x ({:.0} s wall), {} scheduled faults (seed {}), v{} board{}",
        args.machine_s,
        args.time_scale,
        args.machine_s / args.time_scale,
        schedule.len(),
        args.seed,
        args.protocol,
        if args.hostile() {
            format!(
                "; hostile line: {} % of the replies corrupted, {} delay episodes of {} reads",
                100.0 * args.line_corrupt,
                episodes.len(),
                args.delay_reads
            )
        } else {
            String::new()
        }
    );

    // Sample memory and threads once a wall second until acc run ends; switch the line's
    // delay episodes on and off on machine time (wall time × scale since the machine began).
    let started = Instant::now();
    let mut samples: Vec<Sample> = Vec::new();
    let limit = Duration::from_secs_f64(args.machine_s / args.time_scale * 1.5 + 120.0);
    let mut machine_origin: Option<Instant> = None;
    let mut next_episode = 0;
    let mut delay_on = false;
    let mut next_sample = Duration::from_secs(1);
    let status = loop {
        if let Some(st) = run.wait(Duration::from_millis(20)) {
            break Some(st);
        }
        if let Some(p) = &proxy {
            if machine_origin.is_none() {
                board.drain(Duration::ZERO);
                if board.seen.iter().any(|l| l.contains("machine time starts")) {
                    machine_origin = Some(Instant::now());
                }
            }
            if let Some(origin) = machine_origin {
                let now = origin.elapsed().as_secs_f64() * args.time_scale;
                if let Some(&(on, off)) = episodes.get(next_episode) {
                    if !delay_on && now >= on {
                        p.signal("USR1");
                        delay_on = true;
                    } else if delay_on && now >= off {
                        p.signal("USR2");
                        delay_on = false;
                        next_episode += 1;
                    }
                }
            }
        }
        if started.elapsed() < next_sample {
            continue;
        }
        next_sample += Duration::from_secs(1);
        let t = started.elapsed().as_secs_f64();
        samples.push((
            t,
            rss_kib_and_threads(run.child.id()),
            rss_kib_and_threads(board.child.id()),
        ));
        if samples.len().is_multiple_of(10) {
            let rss = |s: Option<(u64, u64)>| s.map_or(0.0, |(r, _)| r as f64 / 1024.0);
            let (_, r, b) = samples[samples.len() - 1];
            eprintln!(
                "soak: {:>5.0} s wall, ~{:>6.0} s machine ({:>3.0} %); RSS acc run {:.1} MiB, board-sim {:.1} MiB",
                t,
                t * args.time_scale,
                100.0 * t * args.time_scale / args.machine_s,
                rss(r),
                rss(b)
            );
        }
        if started.elapsed() > limit {
            run.signal("INT");
            break run.wait(Duration::from_secs(30));
        }
    };
    let exit = status.map_or_else(|| "hung (killed)".to_string(), describe);
    std::thread::sleep(Duration::from_millis(300));
    if let Some(p) = proxy.as_mut() {
        stop_proxy(p);
    }
    drop(proxy);
    board.signal("INT");
    if board.wait(Duration::from_secs(10)).is_none() {
        board.signal("KILL");
    }
    let fired: Vec<String> = {
        board.drain(Duration::from_millis(200));
        board
            .seen
            .iter()
            .filter(|l| l.contains(": fault "))
            .cloned()
            .collect()
    };
    drop(run);
    drop(board);

    let r = read(&run_log)?;
    let m = read(&machine_log)?;
    let line = args.hostile().then(|| LineInput {
        stats: read_proxy_stats(&stats_file).ok(),
        episodes_planned: episodes.len(),
        rearm_at,
        events: read_json_lines(&events_file).unwrap_or_default(),
        reads: read_json_lines(&reads_file).unwrap_or_default(),
    });
    let report = analyse(
        &r,
        &m,
        &samples,
        &fired,
        exit,
        started.elapsed().as_secs_f64(),
        line.as_ref(),
    );
    let text = markdown(&report, args);
    std::fs::write(args.out.join("soak.md"), &text)?;
    std::fs::write(
        args.out.join("soak.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    plot(&samples, &m, &args.out)?;
    println!("{text}");
    if let Some(doc) = &args.update_doc {
        crate::cmd_fault_matrix::update_between(doc, "soak", &text)?;
        eprintln!("soak: figures written into {}", doc.display());
    }
    if !report.problems.is_empty() {
        bail!("soak failed: {}", report.problems.join("; "));
    }
    Ok(())
}

/// The scenario with its workpiece repeated for `machine_s` (paths made absolute).
fn write_soak_scenario(base: &Path, out: &Path, machine_s: f64) -> anyhow::Result<PathBuf> {
    let text =
        std::fs::read_to_string(base).with_context(|| format!("reading {}", base.display()))?;
    let mut sc: toml::Table =
        toml::from_str(&text).with_context(|| format!("parsing {}", base.display()))?;
    let dir = base
        .parent()
        .unwrap_or(Path::new("."))
        .canonicalize()
        .with_context(|| format!("folder of {}", base.display()))?;
    for key in ["machine", "tool", "controller"] {
        if let Some(toml::Value::String(p)) = sc.get(key) {
            let abs = dir.join(p);
            sc.insert(key.into(), abs.to_string_lossy().into_owned().into());
        }
    }
    let wp_rel = match sc.get("workpiece") {
        Some(toml::Value::String(p)) => p.clone(),
        _ => bail!("{}: no `workpiece` path to repeat", base.display()),
    };
    let wp_path = dir.join(&wp_rel);
    let wp_text = std::fs::read_to_string(&wp_path)
        .with_context(|| format!("reading {}", wp_path.display()))?;
    let wp: toml::Table =
        toml::from_str(&wp_text).with_context(|| format!("parsing {}", wp_path.display()))?;
    let segments = match wp.get("segment") {
        Some(toml::Value::Array(a)) if !a.is_empty() => a.clone(),
        _ => bail!("{}: no [[segment]] to repeat", wp_path.display()),
    };
    // One pass of case III takes about 60 s; repeat with margin (a pass never takes less
    // than 20 s at 150 %).
    let repeats = (machine_s / 20.0).ceil() as usize + 2;
    let mut all = Vec::with_capacity(segments.len() * repeats);
    for _ in 0..repeats {
        all.extend(segments.iter().cloned());
    }
    let mut soak_wp = wp.clone();
    soak_wp.insert(
        "name".into(),
        format!(
            "soak: {} x {}",
            repeats,
            wp.get("name")
                .and_then(|v| v.as_str())
                .unwrap_or("workpiece")
        )
        .into(),
    );
    soak_wp.insert("segment".into(), toml::Value::Array(all));
    let wp_out = out.join("soak_workpiece.toml");
    std::fs::write(&wp_out, toml::to_string(&soak_wp)?)?;
    sc.insert(
        "workpiece".into(),
        wp_out.canonicalize()?.to_string_lossy().into_owned().into(),
    );
    sc.insert("max_time_s".into(), toml::Value::Float(machine_s + 600.0));
    sc.insert("name".into(), "soak".into());
    let sc_out = out.join("soak_scenario.toml");
    std::fs::write(&sc_out, toml::to_string(&sc)?)?;
    Ok(sc_out)
}

/// The operator re-arms once more near the end (switch off, on half a second later).
fn final_rearm(at: f64) -> [String; 2] {
    [
        format!("switch@{at:.1}:off"),
        format!("switch@{:.1}:on", at + 0.5),
    ]
}

/// The random fault schedule: `acc board-sim --fault` specs, each followed by the
/// operator re-arming ACC (switch off, on).
fn fault_schedule(seed: u64, machine_s: f64, every_s: f64) -> Vec<String> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let mut t = 30.0;
    while t < machine_s - 30.0 {
        let tt = format!("{t:.1}");
        match rng.random_range(0..10) {
            0 => out.push(format!("crc@{tt}:{}", rng.random_range(1..30))),
            1 => out.push(format!("drop@{tt}:{}", rng.random_range(1..30))),
            2 => out.push(format!("late@{tt}:{}", rng.random_range(1..30))),
            3 => out.push(format!("freeze-seq@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            4 => out.push(format!("bad-power@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            5 => out.push(format!("restart@{tt}")),
            6 => out.push(format!("lock@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            7 => {
                out.push(format!("operator@{tt}:{}", 10 * rng.random_range(5..10)));
                out.push(format!("operator@{:.1}:100", t + 2.0));
            }
            8 => out.push(format!(
                "hard@{tt}:{:.1}:{:.2}",
                rng.random_range(0.5..3.0),
                rng.random_range(1.2..2.5)
            )),
            _ => out.push(format!("unplug@{tt}:{:.1}", rng.random_range(0.5..3.0))),
        }
        // The operator re-arms a latched release: switch off, and on 0.5 s later (while
        // off, the cut runs at the knob: the operator's own act, not a fault).
        out.push(format!("switch@{:.1}:off", t + 3.5));
        out.push(format!("switch@{:.1}:on", t + 4.0));
        t += 4.5 + rng.random_range(0.5 * every_s..1.5 * every_s);
    }
    out
}

fn median(mut v: Vec<u64>) -> Option<u64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    Some(v[v.len() / 2])
}

/// Periods missing between the first and last row (`period` must count up by one).
fn missing(rows: &[RunRecord]) -> u64 {
    rows.windows(2)
        .map(|w| w[1].period.saturating_sub(w[0].period + 1))
        .sum()
}

/// Deadlines board-sim's ticker skipped, from its rows' `ticks_skipped:<n>` flags.
fn ticks_skipped(rows: &[RunRecord]) -> u64 {
    rows.iter()
        .flat_map(|x| x.flags.split(';'))
        .filter_map(|f| f.strip_prefix("ticks_skipped:"))
        .filter_map(|n| n.parse::<u64>().ok())
        .sum()
}

/// One sample: wall time s, (RSS KiB, threads) of acc run and of acc board-sim.
type Sample = (f64, Option<(u64, u64)>, Option<(u64, u64)>);

fn analyse(
    r: &[RunRecord],
    m: &[RunRecord],
    samples: &[Sample],
    fired: &[String],
    exit: String,
    wall_s: f64,
    line: Option<&LineInput>,
) -> SoakReport {
    let mut problems = Vec::new();
    // Memory: first minute after a 30 s warm-up against the last minute.
    let series = |pick: fn(&Sample) -> Option<(u64, u64)>| -> Vec<(f64, u64, u64)> {
        samples
            .iter()
            .filter_map(|s| pick(s).map(|(rss, th)| (s.0, rss, th)))
            .collect()
    };
    let growth = |v: &[(f64, u64, u64)]| -> (i64, u64, (u64, u64)) {
        let end_t = v.last().map_or(0.0, |x| x.0);
        let first = median(
            v.iter()
                .filter(|x| x.0 >= 30.0 && x.0 < 90.0)
                .map(|x| x.1)
                .collect(),
        );
        let last = median(
            v.iter()
                .filter(|x| x.0 > end_t - 60.0)
                .map(|x| x.1)
                .collect(),
        );
        let threads = v
            .iter()
            .filter(|x| x.0 >= 5.0)
            .fold((u64::MAX, 0), |(lo, hi), x| (lo.min(x.2), hi.max(x.2)));
        let g = match (first, last) {
            (Some(a), Some(b)) => b as i64 - a as i64,
            _ => 0,
        };
        (g, v.last().map_or(0, |x| x.1), threads)
    };
    let (run_g, run_end, run_th) = growth(&series(|s| s.1));
    let (board_g, board_end, board_th) = growth(&series(|s| s.2));
    // Memory growth needs a first and a last minute after the warm-up: shorter runs
    // (the CI test) report it as not measured.
    let memory_measured = samples.len() >= 150;
    if memory_measured {
        for (who, g) in [("acc run", run_g), ("acc board-sim", board_g)] {
            if g >= 1024 {
                problems.push(format!("{who} RSS grew by {g} KiB (limit 1024)"));
            }
        }
    }
    if board_th.0 < board_th.1 {
        problems.push(format!(
            "acc board-sim's threads went from {} to {}",
            board_th.1, board_th.0
        ));
    }
    let run_missing = missing(r);
    let machine_missing = missing(m);
    if run_missing > 0 || r.first().is_some_and(|x| x.period != 0) {
        problems.push(format!("acc run's log misses {run_missing} periods"));
    }
    if machine_missing > 0 {
        problems.push(format!("the machine log misses {machine_missing} periods"));
    }
    let run_flagged = r.iter().filter(|x| !x.flags.is_empty()).count();
    let machine_ticks_skipped = ticks_skipped(m);
    // The invariant: a period with an unusable force sample never raises the command.
    let raised = fault_periods_raising(r);
    if raised > 0 {
        problems.push(format!("{raised} fault periods raised the command"));
    }
    let t_end = r.last().map_or(0.0, |x| x.t_s);
    let (active_at_end, aligned) = match line {
        None => {
            let ok = r
                .iter()
                .filter(|x| x.t_s > t_end - 1.0)
                .any(|x| x.state == "active");
            if !ok {
                problems.push("ACC was not controlling at the end of the run".into());
            }
            (ok, None)
        }
        Some(l) => {
            let alignment = align_reads(r, &l.reads);
            let problem = controlling_after_rearm(r, l, &alignment);
            let ok = problem.is_none();
            problems.extend(problem);
            (ok, Some((alignment.checked, alignment.agreed)))
        }
    };
    let line = line.map(|l| {
        let mut out = SoakLine {
            episodes_planned: l.episodes_planned,
            aligned: aligned.unwrap_or_default(),
            suspicious_rows: r.iter().filter(|x| suspicious(&x.flags)).count(),
            ..SoakLine::default()
        };
        let operator =
            |x: &RunRecord| matches!(x.state.as_str(), "operator_handback" | "switch_off");
        out.operator_releases = r
            .windows(2)
            .filter(|w| operator(&w[1]) && !operator(&w[0]))
            .count();
        match &l.stats {
            Some(st) => {
                out.corrupted = st.corrupted();
                out.episodes = st.episodes;
                out.delayed_reads = st.altered.get("delay").copied().unwrap_or(0);
                out.proxy = st.clone();
                if out.corrupted == 0 {
                    problems.push("the hostile line corrupted no reply".into());
                }
                if out.episodes != l.episodes_planned as u64 {
                    problems.push(format!(
                        "the hostile line ran {} delay episodes of {} planned",
                        out.episodes, l.episodes_planned
                    ));
                }
            }
            None => problems.push("the man-in-the-middle proxy wrote no counters".into()),
        }
        out
    });
    if !(exit == "0" || exit == "3") {
        problems.push(format!("acc run exit {exit}"));
    }
    let active = r.iter().filter(|x| x.state == "active").count();
    let max_force_n = m
        .iter()
        .filter(|x| x.state == "acc_active" && !x.feed_hold)
        .filter_map(|x| x.force_true_n)
        .fold(0.0, f64::max);
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for l in fired {
        let k = l
            .split(": fault ")
            .nth(1)
            .and_then(|s| s.split(['(', ' ']).next())
            .unwrap_or("?")
            .to_string();
        match kinds.iter_mut().find(|(n, _)| *n == k) {
            Some((_, c)) => *c += 1,
            None => kinds.push((k, 1)),
        }
    }
    kinds.sort();
    SoakReport {
        machine_s: t_end,
        wall_s,
        faults_fired: fired.len(),
        faults_by_kind: kinds,
        run_rows: r.len(),
        run_missing,
        run_flagged,
        machine_rows: m.len(),
        machine_missing,
        machine_ticks_skipped,
        memory_measured,
        run_rss_growth_kib: run_g,
        run_rss_end_kib: run_end,
        board_rss_growth_kib: board_g,
        board_rss_end_kib: board_end,
        run_threads: run_th,
        board_threads: board_th,
        raised_in_fault: raised,
        max_force_n,
        active_pct: 100.0 * active as f64 / r.len().max(1) as f64,
        exit,
        active_at_end,
        line,
        problems,
    }
}

fn markdown(r: &SoakReport, args: &SoakArgs) -> String {
    let kinds: Vec<String> = r
        .faults_by_kind
        .iter()
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
    let (line_args, line_rows) = match &r.line {
        Some(l) => {
            let by_kind: Vec<String> = l
                .proxy
                .altered
                .iter()
                .filter(|(k, n)| k.as_str() != "delay" && **n > 0)
                .map(|(k, n)| format!("{k} {n}"))
                .collect();
            (
                format!(
                    " --line-corrupt {} --delay-reads {} --delay-every-s {} --delay-for-s {}",
                    args.line_corrupt, args.delay_reads, args.delay_every_s, args.delay_for_s
                ),
                format!(
                    "| hostile line: replies corrupted with a valid CRC (of all replies) | {} of {} ({}) |\n\
| hostile line: delay episodes ({} reads, {} s every {} s) / status reads delayed | {} of {} planned / {} |\n\
| acc run rows flagged as not taking a read at face value / entering an operator's state | {} / {} |\n",
                    l.corrupted,
                    l.proxy.replies,
                    by_kind.join(", "),
                    args.delay_reads,
                    args.delay_for_s,
                    args.delay_every_s,
                    l.episodes,
                    l.episodes_planned,
                    l.delayed_reads,
                    l.suspicious_rows,
                    l.operator_releases,
                ),
            )
        }
        None => (" --no-hostile-line".to_string(), String::new()),
    };
    format!(
        "Generated by `acc soak --machine-s {} --time-scale {} --fault-every-s {} --seed {} --protocol {}{line_args} --update-doc docs/reliability.md`.\n\n\
| figure | value |\n| --- | --- |\n\
| machine time / wall time | {:.0} s / {:.0} s |\n\
| faults fired (incl. the operator's re-arm switching) | {} ({}) |\n\
{line_rows}\
| acc run log rows / missing periods / flagged rows | {} / {} / {} |\n\
| machine log rows / missing periods / board-sim ticks skipped | {} / {} / {} |\n\
| acc run RSS at end / growth | {:.1} MiB / {} |\n\
| acc board-sim RSS at end / growth | {:.1} MiB / {} |\n\
| threads acc run (min–max) / board-sim | {}–{} / {}–{} |\n\
| fault periods that raised the command | {} |\n\
| ACC active | {:.1} % of periods; at the end: {} |\n\
| largest true force while ACC drove the feed | {:.0} N |\n\
| acc run exit | {} |\n\
| verdict | {} |\n\n\
Memory growth: median RSS of the last minute against the first minute after a 30 s warm-up; limit 1 MiB. Plot: `{}/soak.svg`.\n",
        args.machine_s,
        args.time_scale,
        args.fault_every_s,
        args.seed,
        args.protocol,
        r.machine_s,
        r.wall_s,
        r.faults_fired,
        kinds.join(", "),
        r.run_rows,
        r.run_missing,
        r.run_flagged,
        r.machine_rows,
        r.machine_missing,
        r.machine_ticks_skipped,
        r.run_rss_end_kib as f64 / 1024.0,
        growth(r.memory_measured, r.run_rss_growth_kib),
        r.board_rss_end_kib as f64 / 1024.0,
        growth(r.memory_measured, r.board_rss_growth_kib),
        r.run_threads.0,
        r.run_threads.1,
        r.board_threads.0,
        r.board_threads.1,
        r.raised_in_fault,
        r.active_pct,
        if r.active_at_end { "yes" } else { "no" },
        r.max_force_n,
        r.exit,
        if r.problems.is_empty() {
            "pass".to_string()
        } else {
            format!("FAIL: {}", r.problems.join("; "))
        },
        args.out.display(),
    )
}

fn growth(measured: bool, kib: i64) -> String {
    if measured {
        format!("{kib:+} KiB")
    } else {
        "not measured (run shorter than 150 s of wall time)".into()
    }
}

fn plot(samples: &[Sample], m: &[RunRecord], out: &Path) -> anyhow::Result<()> {
    use acc_plot::{time_series, Figure, HLine, Panel, Series};
    let mib = |pick: fn(&Sample) -> Option<(u64, u64)>| -> Vec<(f64, f64)> {
        samples
            .iter()
            .filter_map(|s| pick(s).map(|(rss, _)| (s.0, rss as f64 / 1024.0)))
            .collect()
    };
    // Machine log downsampled to one point per 10 s of machine time (largest true force,
    // largest applied override) so the plot stays small.
    let mut force = Vec::new();
    let mut ov = Vec::new();
    for chunk in m.chunks(100) {
        let t = chunk.last().map_or(0.0, |x| x.t_s);
        force.push((
            t,
            chunk
                .iter()
                .filter_map(|x| x.force_true_n)
                .fold(0.0, f64::max),
        ));
        ov.push((
            t,
            chunk
                .iter()
                .filter_map(|x| x.override_applied_pct)
                .map(f64::from)
                .fold(f64::NAN, f64::max),
        ));
    }
    let fig = Figure {
        title: "Soak: memory of both processes (wall time)".into(),
        x_label: "wall time [s]".into(),
        panels: vec![Panel {
            y_label: "RSS [MiB]".into(),
            series: vec![
                Series::line("acc run", mib(|s| s.1)),
                Series::line("acc board-sim", mib(|s| s.2)),
            ],
            ..Panel::default()
        }],
        ..Figure::default()
    };
    time_series(&fig, out.join("soak.svg"))?;
    let fig = Figure {
        title: "Soak: largest true force and override per 10 s (machine time)".into(),
        x_label: "machine time [s]".into(),
        panels: vec![
            Panel {
                y_label: "force [N]".into(),
                series: vec![Series::line("max true force", force)],
                hlines: vec![HLine::new("Fr", 800.0)],
                ..Panel::default()
            },
            Panel {
                y_label: "override [%]".into(),
                series: vec![Series::line("max applied", ov)],
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    time_series(&fig, out.join("soak_machine.svg"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_is_seeded_and_re_arms_after_every_fault() {
        let a = fault_schedule(7, 600.0, 5.0);
        assert_eq!(a, fault_schedule(7, 600.0, 5.0));
        assert_ne!(a, fault_schedule(8, 600.0, 5.0));
        let faults = a.iter().filter(|f| !f.starts_with("switch@")).count();
        let offs = a.iter().filter(|f| f.ends_with(":off")).count();
        assert!(faults >= 50, "{faults} faults in 600 s");
        assert_eq!(offs, a.iter().filter(|f| f.ends_with(":on")).count());
        // Every spec has a time in the run.
        for f in &a {
            let t: f64 = f
                .split('@')
                .nth(1)
                .and_then(|r| r.split(':').next())
                .and_then(|t| t.parse().ok())
                .unwrap_or(-1.0);
            assert!((30.0..600.0).contains(&t), "{f}");
        }
    }

    #[test]
    fn delay_episodes_end_before_the_last_re_arm() {
        assert_eq!(
            delay_episodes(200.0, 60.0, 10.0),
            vec![(60.0, 70.0), (120.0, 130.0)]
        );
        assert_eq!(delay_episodes(3600.0, 180.0, 10.0).len(), 19);
        assert!(delay_episodes(100.0, 180.0, 10.0).is_empty());
        assert_eq!(
            final_rearm(190.0),
            [
                "switch@190.0:off".to_string(),
                "switch@190.5:on".to_string()
            ]
        );
    }

    #[test]
    fn a_release_after_the_last_re_arm_needs_a_fresh_bad_frame() {
        // Rows 0..40 (0.1 s apart), one read each after one start-up read; unique powers.
        let rows = |released_from: usize, state: &str| -> Vec<RunRecord> {
            (0..40)
                .map(|i| RunRecord {
                    t_s: 0.1 * i as f64,
                    period: i as u64,
                    power_w: Some(1000.0 + i as f64),
                    state: if i >= released_from { state } else { "active" }.into(),
                    ..RunRecord::default()
                })
                .collect()
        };
        let reads: Vec<ProxyRead> = (0..41)
            .map(|i| ProxyRead {
                i: Some(i),
                power: Some(1000.0 + i as f64 - 1.0),
                applied: None,
                altered: false,
            })
            .collect();
        let bad_frame = |read: u64| ProxyEvent {
            t: 0.0,
            read_index: Some(read),
            fc: 4,
            kind: "random".into(),
            register: None,
            bit: None,
            before: None,
            after: None,
        };
        let line = |events: Vec<ProxyEvent>| LineInput {
            stats: None,
            episodes_planned: 0,
            rearm_at: 1.0,
            events,
            reads: reads.clone(),
        };
        let check = |r: &[RunRecord], l: &LineInput| {
            let a = align_reads(r, &l.reads);
            assert_eq!(a.offset, 1);
            controlling_after_rearm(r, l, &a)
        };
        // Active to the end.
        assert_eq!(check(&rows(99, ""), &line(vec![])), None);
        // Released at row 30: explained by the altered read 29 (row 28), not otherwise.
        let r = rows(30, "power_invalid");
        assert_eq!(check(&r, &line(vec![bad_frame(29)])), None);
        let p = check(&r, &line(vec![bad_frame(5)])).expect("a problem");
        assert!(
            p.contains("t = 3.0 s") && p.contains("no read altered"),
            "{p}"
        );
        // Never active again after the re-arm (rows after 1.5 s).
        let p = check(&rows(12, "delay"), &line(vec![bad_frame(13)])).expect("a problem");
        assert!(p.contains("not controlling after"), "{p}");
    }

    #[test]
    fn missing_periods_are_counted() {
        let row = |p| RunRecord {
            period: p,
            ..RunRecord::default()
        };
        assert_eq!(missing(&[row(0), row(1), row(2)]), 0);
        assert_eq!(missing(&[row(0), row(3), row(4), row(6)]), 3);
    }

    #[test]
    fn skipped_board_ticks_are_summed_from_the_flags() {
        let row = |p, flags: &str| RunRecord {
            period: p,
            flags: flags.into(),
            ..RunRecord::default()
        };
        let m = [
            row(0, ""),
            row(1, "late;ticks_skipped:2"),
            row(2, "late"),
            row(3, "fallback:50;late;ticks_skipped:1"),
        ];
        assert_eq!(ticks_skipped(&m), 3);
        // Consecutive machine periods: a skipped tick is not a missing row.
        assert_eq!(missing(&m), 0);
    }
}
