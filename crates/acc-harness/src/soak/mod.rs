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
//! periods before its last release explains it
//! ([`controlling_after_rearm`](verdict::controlling_after_rearm)).
//!
//! Pass: RSS growth below 1 MiB for each process (median of the last minute of samples
//! against the median of the first minute after warm-up), no lost rows in either log, the
//! thread counts never drop (a dead server thread), `acc run` still controlling at the end
//! (on a hostile line: see above), and no period with an unusable force sample
//! raising the command; on a hostile line also that the proxy corrupted replies and ran
//! every planned delay episode (the table reports both).

mod report;
mod schedule;
mod verdict;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

use crate::child::{describe, read, rss_kib_and_threads, Proc};
use crate::proxy::{spawn_proxy, stop_proxy, ProxyFiles};
use report::{markdown, plot};
use schedule::{delay_episodes, fault_schedule, final_rearm, write_soak_scenario};
use verdict::{analyse, LineInput, Sample};

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

/// `acc soak`: the soak, its report written to `--out` (`soak.md`, `soak.json`, the plots)
/// and printed; an error naming its problems.
pub fn run(args: &SoakArgs) -> anyhow::Result<()> {
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
    let proxy_files = ProxyFiles::in_dir(&args.out);
    let (mut proxy, port) = if args.hostile() {
        let mut pargs: Vec<String> = [
            "--seed",
            &args.seed.to_string(),
            "--corrupt",
            &args.line_corrupt.to_string(),
            "--corrupt-always",
            "--delay-reads",
            &args.delay_reads.to_string(),
            "--start",
            "off",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        pargs.extend(proxy_files.args());
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
        proxy: proxy_files.read(),
        episodes_planned: episodes.len(),
        rearm_at,
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
    if !report.problems.is_empty() {
        bail!("soak failed: {}", report.problems.join("; "));
    }
    Ok(())
}
