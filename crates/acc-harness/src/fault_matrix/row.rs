//! Running one row of `acc fault-matrix`: the board, the proxy on a hostile line and `acc
//! run` as child processes, the fault brought about at its moment, the logs read back.

use std::path::Path;
use std::time::Duration;

use anyhow::{bail, Context};

use super::faults::{window_s, Action, Fault};
use super::verdict::{judge, Logs, Row};
use super::FaultMatrixArgs;
use crate::child::{describe, read, Proc};
use crate::proxy::{spawn_proxy, stop_proxy, ProxyFiles};

fn s(v: impl ToString) -> String {
    v.to_string()
}

/// One row: `acc board-sim` with the fault (or a marker at the moment), the proxy on a
/// hostile line, `acc run`; the fault brought about at the moment; then both logs judged.
pub fn run_row(args: &FaultMatrixArgs, f: &Fault, protocol: u8, dir: &Path) -> anyhow::Result<Row> {
    if let Action::Plan(kind) = f.action {
        return super::wrong_plan::run_plan_row(args, f, protocol, dir, kind);
    }
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
    let proxy_files = ProxyFiles::in_dir(dir);
    let (mut proxy, port) = match f.action {
        Action::Line {
            corrupt,
            delay_reads,
        } => {
            let mut pargs = vec![
                s("--seed"),
                args.line_seed.to_string(),
                s("--corrupt"),
                format!("{corrupt}"),
                s("--delay-reads"),
                delay_reads.to_string(),
                s("--start"),
                s("off"),
            ];
            pargs.extend(proxy_files.args());
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
    // Wait for the moment: machine time `at`, plus start-up slack for a loaded host.
    let line =
        wait_for_moment(&mut board, &mut run, wall(at) + MOMENT_SLACK).with_context(|| {
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
        Action::Board(_) | Action::Plan(_) => {}
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
            None => run.stop_running(),
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
        Action::Line { .. } => Some(proxy_files.read()),
        _ => None,
    };
    let logs = Logs {
        machine: &m,
        run: &r,
        line: line.as_ref(),
    };
    Ok(judge(f, protocol, t_fault, logs, exit, args))
}

/// Wall time beyond the fault moment's own that the processes may take to start and reach
/// it (a loaded host starts `acc run`, and on a hostile line the Python proxy, slowly).
const MOMENT_SLACK: Duration = Duration::from_secs(120);

/// The board's line at the fault moment, waiting at most `timeout`; an `acc run` that ends
/// before it is an error at once (with its exit), not a wait to the deadline.
fn wait_for_moment(board: &mut Proc, run: &mut Proc, timeout: Duration) -> anyhow::Result<String> {
    let end = std::time::Instant::now() + timeout;
    loop {
        if let Some(line) = board.wait_for(": fault ", Duration::from_millis(500)) {
            return Ok(line);
        }
        if let Ok(Some(st)) = run.child.try_wait() {
            bail!("acc run ended ({}) before the fault moment", describe(st));
        }
        if std::time::Instant::now() >= end {
            bail!("not within {:.0} s of wall time", timeout.as_secs_f64());
        }
    }
}

/// `board-sim: t = 40.0 s: fault Operator(100) (scheduled at 40 s)` → 40.0.
pub(super) fn parse_fault_time(line: &str) -> Option<f64> {
    let rest = line.split("t = ").nth(1)?;
    rest.split(' ').next()?.parse().ok()
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
}
