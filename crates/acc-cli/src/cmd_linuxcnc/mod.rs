//! acc on LinuxCNC: `acc linuxcnc part.ngc --scenario … --stock-box … --out DIR` (this
//! module: the one command that writes the configuration, runs LinuxCNC headless with acc
//! and the simulated process, and summarizes) and `acc linuxcnc-process` (the simulated
//! cutting process as a HAL component, [`process`], its model in [`cut`]). The files come
//! from the templates of `configs/linuxcnc/` ([`setup`]); the summary from the logs
//! ([`summary`]).
//!
//! Order: every input is checked (program, scenario, stock, config, plan, watchdog) before
//! LinuxCNC starts; another LinuxCNC on the host (its lock file) is an error. As root,
//! LinuxCNC's realtime runs as `nobody` (`RTAPI_UID`, `RTAPI_FIFO_PATH` in the run's
//! folder, which is made writable for it). After LinuxCNC exits (or is stopped at
//! `--timeout-s`), whatever it left (lock file, HAL's shared memory) is removed with
//! `halrun -U`.

pub mod cut;
pub mod ini;
pub mod process;
pub mod setup;
pub mod summary;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use acc_runtime::{Clock as _, SystemClock};

use anyhow::Context as _;

/// LinuxCNC's lock file: one LinuxCNC per host.
const LOCK_FILE: &str = "/tmp/linuxcnc.lock";

/// The faults `--fault KIND@N[+S]` names, carried out by `configs/linuxcnc/ui.py`.
pub const FAULT_KINDS: [&str; 9] = [
    "kill-acc",
    "stop-acc",
    "kill-process",
    "feed-override",
    "pause",
    "estop",
    "m52-off",
    "abort-restart",
    "tool-change",
];

/// `--fault KIND@N[+S]` checked: the kind, the force (N) and the delay after it (s).
pub fn parse_fault(spec: &str) -> anyhow::Result<(String, f64, f64)> {
    let (kind, at) = spec.split_once('@').ok_or_else(|| {
        anyhow::anyhow!("--fault {spec}: expected KIND@N[+S], e.g. stop-acc@700+2.5")
    })?;
    let (n, delay) = at.split_once('+').unwrap_or((at, "0"));
    if !FAULT_KINDS.contains(&kind) {
        anyhow::bail!(
            "--fault {spec}: no fault `{kind}`; allowed: {}",
            FAULT_KINDS.join(", ")
        );
    }
    let n: f64 = n
        .parse()
        .map_err(|_| anyhow::anyhow!("--fault {spec}: `{n}` is not a force in N"))?;
    if !(n.is_finite() && n > 0.0) {
        anyhow::bail!("--fault {spec}: the force {n}: allowed > 0 N");
    }
    let delay: f64 = delay
        .parse()
        .map_err(|_| anyhow::anyhow!("--fault {spec}: `{delay}` is not a delay in s"))?;
    if !(delay.is_finite() && (0.0..=60.0).contains(&delay)) {
        anyhow::bail!("--fault {spec}: the delay {delay}: allowed 0 ..= 60 s");
    }
    Ok((kind.to_string(), n, delay))
}

/// Arguments of `acc linuxcnc`.
#[derive(Debug, Clone, clap::Args)]
pub struct LinuxcncArgs {
    /// The NC program (RS274/NGC) LinuxCNC runs.
    pub program: PathBuf,
    /// Scenario of the simulated process (machine, tool, force law).
    #[arg(long, default_value = "paper_case3")]
    pub scenario: String,
    /// The stock the simulated process cuts, and the tool table LinuxCNC and the process
    /// read.
    #[command(flatten)]
    pub stock: crate::cmd_sim_program::StockArgs,
    /// acc's run config (default: the shipped `configs/linuxcnc/acc.toml`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The plan of the program (`acc plan`), for acc's look-ahead (`acc run --plan`).
    #[arg(long, value_name = "plan.csv")]
    pub plan: Option<PathBuf>,
    /// With `--plan`: the plan's lead sets the command from the force ahead while the
    /// measurement confirms the plan (`acc run --plan-lead`, docs/plan.md).
    #[arg(long, requires = "plan")]
    pub plan_lead: bool,
    /// The run's folder: INI, HAL, ui.py, run.csv, machine.csv, LinuxCNC's log.
    #[arg(long)]
    pub out: PathBuf,
    /// Timeout of the realtime watchdog on acc's heartbeat, s (0.12 ..= 1; the heartbeat
    /// toggles every 0.1 s).
    #[arg(long, default_value_t = 0.2)]
    pub watchdog_s: f64,
    /// Fault test: SIGKILL acc the first time the true force reaches this many newtons
    /// (> 0); the program is aborted 2 s later.
    #[arg(long, value_name = "N", conflicts_with = "fault")]
    pub kill_acc_at_force: Option<f64>,
    /// Fault test: `KIND@N[+S]`, carried out by `ui.py` S seconds (default 0) after the true
    /// force first reaches N newtons; KIND is one of `kill-acc`, `stop-acc` (SIGSTOP 2 s, SIGCONT, the watchdog
    /// re-armed), `kill-process` (the power pin frozen), `feed-override` (the operator's
    /// override to 30 %), `pause` (2 s), `estop`, `abort-restart` (abort, run again 1 s
    /// later), `m52-off` / `tool-change` (the program's own `M52 P0` / `M6`, marked)
    /// ([`FAULT_KINDS`]).
    #[arg(long, value_name = "KIND@N[+S]")]
    pub fault: Option<String>,
    /// The simulated spindle's speed while LinuxCNC's spindle turns: `scenario` (the
    /// scenario's machine, as `acc sim --program` and `acc plan` model it) or `program`
    /// (the program's S word, LinuxCNC's commanded speed).
    #[arg(long, value_enum, default_value_t = process::SpindleMode::Scenario)]
    pub spindle: process::SpindleMode,
    /// Capture LinuxCNC's joint positions with its `halsampler` every servo period
    /// (`halsampler.txt`) and compare the process's path with them.
    #[arg(long)]
    pub capture: bool,
    /// Longest run, s of wall time (10 ..= 86400): LinuxCNC is stopped after it. The
    /// default, an hour, holds the longest example program (17 minutes of machine time)
    /// with room for a slow cut.
    #[arg(long, default_value_t = 3600.0)]
    pub timeout_s: f64,
    /// A LinuxCNC configuration value, `SECTION.KEY=VALUE` (repeatable), set in the
    /// generated `acc.ini`: the section and key must be in the template, a number in its
    /// kind's range (accelerations 1 ..= 100000 mm/s²); an `AXIS_X/Y/Z` limit also sets its
    /// `JOINT_0/1/2` ([`ini`]).
    #[arg(long = "ini", value_name = "SECTION.KEY=VALUE")]
    pub ini: Vec<String>,
}

/// Of `--timeout-s`, the seconds left to LinuxCNC's start and stop: `ui.py` aborts the
/// program after the rest (`ACC_PROGRAM_TIMEOUT_S`).
const PROGRAM_TIMEOUT_MARGIN_S: f64 = 15.0;

/// `acc linuxcnc`.
pub fn run_cmd(args: &LinuxcncArgs) -> anyhow::Result<()> {
    // 1. Every input checked before LinuxCNC starts.
    let program = absolute(&args.program)
        .with_context(|| format!("PROGRAM {}: no such file", args.program.display()))?;
    let scenario_path = absolute(&crate::configs::find("scenarios", &args.scenario))
        .with_context(|| format!("--scenario {}: no such scenario", args.scenario))?;
    let scenario = acc_sim::Scenario::load(&scenario_path)
        .with_context(|| format!("--scenario {}", args.scenario))?;
    args.stock
        .source()?
        .build()
        .map_err(|e| anyhow::anyhow!("the stock: {e}"))?;
    std::fs::read_to_string(&program)
        .with_context(|| format!("PROGRAM {}: cannot read", program.display()))?;
    let config = match &args.config {
        Some(c) => {
            absolute(c).with_context(|| format!("--config {}: no such file", c.display()))?
        }
        None => absolute(&crate::configs::find(
            "linuxcnc",
            "configs/linuxcnc/acc.toml",
        ))
        .context("the shipped configs/linuxcnc/acc.toml")?,
    };
    let cfg = acc_runtime::config::RunConfig::load_with(
        &config,
        acc_runtime::config::LinkFlag::Hal("acc"),
    )?;
    let plan = match &args.plan {
        Some(p) => {
            acc_runtime::Plan::load(p)?;
            Some(absolute(p).with_context(|| format!("--plan {}", p.display()))?)
        }
        None => None,
    };
    let tools = match &args.stock.tools {
        Some(t) => {
            Some(absolute(t).with_context(|| format!("--tools {}: no such file", t.display()))?)
        }
        None => None,
    };
    if !(args.watchdog_s.is_finite() && (0.12..=1.0).contains(&args.watchdog_s)) {
        anyhow::bail!("--watchdog-s {}: allowed 0.12 ..= 1 s", args.watchdog_s);
    }
    if let Some(n) = args.kill_acc_at_force {
        if !(n.is_finite() && n > 0.0) {
            anyhow::bail!("--kill-acc-at-force {n}: allowed > 0 N");
        }
    }
    let fault = match (&args.fault, args.kill_acc_at_force) {
        (Some(spec), _) => Some(parse_fault(spec)?),
        (None, Some(n)) => Some(("kill-acc".to_string(), n, 0.0)),
        (None, None) => None,
    };
    if !(args.timeout_s.is_finite() && (10.0..=86_400.0).contains(&args.timeout_s)) {
        anyhow::bail!("--timeout-s {}: allowed 10 ..= 86400 s", args.timeout_s);
    }
    let ini_values = args
        .ini
        .iter()
        .map(|s| ini::parse(s))
        .collect::<anyhow::Result<Vec<_>>>()?;
    setup::check_ini(&ini_values)?;
    if let Some(why) = missing_linuxcnc() {
        anyhow::bail!("LinuxCNC is needed: {why} (apt-get install linuxcnc-uspace)");
    }
    if Path::new(LOCK_FILE).exists() {
        anyhow::bail!(
            "another LinuxCNC runs on this host ({LOCK_FILE} exists); one per host: stop it, or remove the file if it is stale"
        );
    }

    // 2. The folder and its files.
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("--out {}: cannot create it", args.out.display()))?;
    let dir = absolute(&args.out).with_context(|| format!("--out {}", args.out.display()))?;
    for stale in [
        "run.csv",
        "machine.csv",
        "ui.log",
        "linuxcnc.log",
        "blocks.csv",
        setup::CAPTURE_FILE,
    ] {
        let _ = std::fs::remove_file(dir.join(stale));
    }
    let mut stock_args = match (&args.stock.file, &args.stock.box_spec) {
        (Some(s), _) => format!(
            "--stock {}",
            absolute(s)
                .with_context(|| format!("--stock {}", s.display()))?
                .display()
        ),
        (None, Some(b)) => format!("--stock-box={b} --cell {}", args.stock.cell),
        (None, None) => anyhow::bail!("give --stock stock.toml or --stock-box X0,Y0,Z0,X1,Y1,Z1"),
    };
    if let Some(t) = &tools {
        stock_args.push_str(&format!(" --tools {}", t.display()));
    }
    let fill = setup::Fill {
        acc: std::env::current_exe().context("the path of the acc binary")?,
        program: program.clone(),
        scenario: scenario_path,
        stock_args,
        spindle: args.spindle,
        config,
        run_args: match (&plan, args.plan_lead) {
            (Some(p), true) => format!("--plan {} --plan-lead", p.display()),
            (Some(p), false) => format!("--plan {}", p.display()),
            (None, _) => String::new(),
        },
        watchdog_s: args.watchdog_s,
        dir: dir.clone(),
        ini: ini_values,
        capture: args.capture,
    };
    let ini = setup::write_files(&fill, tools.as_deref(), scenario.tool.diameter_mm)?;

    // 3. LinuxCNC, as an unprivileged realtime when invoked as root.
    let mut env: Vec<(&str, String)> = vec![("HOME", dir.display().to_string())];
    if command_out("id", &["-u"])?.trim() == "0" {
        let uid = command_out("id", &["-u", "nobody"])
            .context("running LinuxCNC's realtime as `nobody` (invoked as root)")?;
        env.push(("RTAPI_UID", uid.trim().to_string()));
        env.push((
            "RTAPI_FIFO_PATH",
            dir.join("rtapi_fifo").display().to_string(),
        ));
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777))
            .with_context(|| format!("--out {}: cannot make it writable", dir.display()))?;
    }
    // LinuxCNC's start and stop take a few seconds of the run's wall time.
    env.push((
        "ACC_PROGRAM_TIMEOUT_S",
        format!(
            "{:.0}",
            (args.timeout_s - PROGRAM_TIMEOUT_MARGIN_S).max(5.0)
        ),
    ));
    if let Some((kind, n, delay)) = &fault {
        env.push(("ACC_FAULT", format!("{kind}@{n}+{delay}")));
    }
    println!(
        "linuxcnc: {} on `{}`, Fr = {} N; files in {}",
        program.display(),
        scenario.name,
        cfg.controller.force_ref_n,
        dir.display()
    );
    let ran = run_linuxcnc(&ini, &dir, &env, Duration::from_secs_f64(args.timeout_s));
    cleanup(&env);
    let ended = ran?;

    // 4. The summary.
    if !dir.join("machine.csv").is_file() || !dir.join("run.csv").is_file() {
        anyhow::bail!(
            "LinuxCNC did not start acc and the process ({ended}): see {} and {}",
            dir.join("linuxcnc.log").display(),
            dir.join("linuxcnc_print.txt").display()
        );
    }
    let fr = cfg.controller.force_ref_n;
    let machine = summary::read_machine_log(&dir.join("machine.csv"))?;
    let periods = summary::run_log_periods(&dir.join("run.csv"))?;
    let consecutive = periods.windows(2).all(|w| w[1] == w[0] + 1);
    let peak = machine.iter().map(|r| r.force_n).fold(0.0, f64::max);
    let cutting: Vec<f64> = machine
        .iter()
        .filter(|r| r.force_n > 0.2 * fr)
        .map(|r| r.adaptive_feed)
        .collect();
    let (lo, hi) = cutting.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), a| {
        (lo.min(*a), hi.max(*a))
    });
    println!(
        "machine log: {} rows ({}); peak true force {:.0} N = {:.2} Fr",
        machine.len(),
        dir.join("machine.csv").display(),
        peak,
        peak / fr
    );
    println!(
        "run log: {} rows ({}), periods {}",
        periods.len(),
        dir.join("run.csv").display(),
        if consecutive {
            "consecutive"
        } else {
            "NOT consecutive"
        }
    );
    if !cutting.is_empty() {
        println!(
            "adaptive feed while cutting: {:.2} ..= {:.2} (law override {:.0} ..= {:.0} %)",
            lo,
            hi,
            150.0 * lo,
            150.0 * hi
        );
    }
    if let Some(s) = summary::stop_after_heartbeat_s(&machine) {
        println!(
            "acc's heartbeat stopped mid-cut: the motion stopped {s:.3} s after its last beat"
        );
    }
    // A run log a killed acc cut short still gives the rest of the summary.
    match summary::write_blocks(&dir, &machine, fr, cfg.controller.period_s) {
        Ok(b) => println!(
            "blocks: {} ({} block rows; force RMS error while cutting {:.1} N)",
            dir.join("blocks.csv").display(),
            b.blocks.len(),
            b.rms_error_n
        ),
        Err(e) => eprintln!("linuxcnc: blocks.csv not written: {e:#}"),
    }
    if args.capture {
        summary::print_path_match(&dir.join(setup::CAPTURE_FILE), &machine)?;
    }
    let cycle = summary::cycle_s(&dir.join("ui.log"));
    match cycle {
        Some(c) => println!("cycle time {c:.1} s (program start to idle)"),
        None => println!("the program did not reach its end (ui.log)"),
    }
    println!("linuxcnc: {ended}");
    let errors = summary::errors(&dir.join("ui.log"));
    for e in &errors {
        eprintln!("linuxcnc: LinuxCNC reported: {e}");
    }
    if let (Some(first), None) = (errors.first(), &fault) {
        anyhow::bail!(
            "LinuxCNC stopped the program: {first} (see {})",
            dir.join("ui.log").display()
        );
    }
    if cycle.is_none() && fault.is_none() {
        anyhow::bail!(
            "the program did not complete: see {} and {}",
            dir.join("ui.log").display(),
            dir.join("linuxcnc.log").display()
        );
    }
    Ok(())
}

/// `path` made absolute (it must exist).
fn absolute(path: &Path) -> anyhow::Result<PathBuf> {
    Ok(path.canonicalize()?)
}

/// Why LinuxCNC cannot run here, or `None`.
pub fn missing_linuxcnc() -> Option<String> {
    if let Err(e) = acc_hal::probe_library() {
        return Some(e.to_string());
    }
    for tool in ["linuxcnc", "halcmd", "halrun"] {
        if Command::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .stdout(Stdio::null())
            .status()
            .map_or(true, |s| !s.success())
        {
            return Some(format!("`{tool}` is not on the PATH"));
        }
    }
    None
}

/// The standard output of `program args`, or an error naming it.
fn command_out(program: &str, args: &[&str]) -> anyhow::Result<String> {
    let out = Command::new(program)
        .args(args)
        .output()
        .with_context(|| format!("running `{program}`"))?;
    if !out.status.success() {
        anyhow::bail!("`{program} {}` failed", args.join(" "));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Runs `linuxcnc INI` in `dir` with `env` until it exits or `timeout` passes (then SIGTERM:
/// its script shuts LinuxCNC down); its output to `dir/linuxcnc.log`. How it ended.
fn run_linuxcnc(
    ini: &Path,
    dir: &Path,
    env: &[(&str, String)],
    timeout: Duration,
) -> anyhow::Result<String> {
    let log = std::fs::File::create(dir.join("linuxcnc.log"))
        .with_context(|| format!("{}: cannot create linuxcnc.log", dir.display()))?;
    let mut child = Command::new("linuxcnc")
        .arg(ini)
        .current_dir(dir)
        .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log)
        .spawn()
        .context("starting `linuxcnc`")?;
    let clock = SystemClock::new();
    let pause = |clock: &SystemClock| clock.sleep_until(clock.now() + Duration::from_millis(100));
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(format!(
                "LinuxCNC exited ({status}) after {:.1} s",
                clock.now().as_secs_f64()
            ));
        }
        if clock.now() > timeout {
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            let grace = clock.now() + Duration::from_secs(20);
            while clock.now() < grace {
                if child.try_wait()?.is_some() {
                    break;
                }
                pause(&clock);
            }
            if child.try_wait()?.is_none() {
                let _ = child.kill();
                let _ = child.wait();
            }
            return Ok(format!(
                "stopped at --timeout-s {:.0} s",
                timeout.as_secs_f64()
            ));
        }
        pause(&clock);
    }
}

/// Removes what a LinuxCNC that did not shut down cleanly leaves: its components, HAL's
/// realtime and shared memory (`halrun -U`), and the lock file.
fn cleanup(env: &[(&str, String)]) {
    if !Path::new(LOCK_FILE).exists() {
        return;
    }
    eprintln!("linuxcnc: cleaning up after LinuxCNC (halrun -U, {LOCK_FILE})");
    let _ = Command::new("halrun")
        .arg("-U")
        .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    let _ = std::fs::remove_file(LOCK_FILE);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fault_is_a_kind_of_ui_py_at_a_positive_force() {
        assert_eq!(
            parse_fault("stop-acc@700").expect("ok"),
            ("stop-acc".to_string(), 700.0, 0.0)
        );
        assert_eq!(
            parse_fault("pause@650.5+2.5").expect("ok"),
            ("pause".to_string(), 650.5, 2.5)
        );
        for kind in FAULT_KINDS {
            assert!(parse_fault(&format!("{kind}@1.5")).is_ok(), "{kind}");
        }
        for (bad, says) in [
            ("stop-acc", "expected KIND@N"),
            ("nap@700", "allowed: kill-acc, stop-acc"),
            ("pause@x", "not a force"),
            ("pause@0", "allowed > 0 N"),
            ("pause@inf", "allowed > 0 N"),
            ("pause@700+x", "not a delay"),
            ("pause@700+61", "allowed 0 ..= 60 s"),
        ] {
            let e = parse_fault(bad).expect_err(bad).to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
