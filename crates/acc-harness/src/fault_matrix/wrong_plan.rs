//! The wrong-plan rows of `acc fault-matrix`: `acc run --plan` against `acc board-sim
//! --program`, the machine cutting the pocket program (`tests/nc/pocket_rect.ngc`) on a box
//! stock. These are not timing faults: the board runs `--pace controller` (the machine
//! moves one period per command write, so it stands still once `acc run` has ended), and
//! `acc run` runs on `--plan-config` (`configs/runtime/fault_matrix_plan.toml`: 2× time, a
//! link tolerant of a loaded host).
//!
//! - **`plan-low-stock`**: the harness plans the program (`acc plan`) for a stock 1 mm lower
//!   than the one on the table, so the machine cuts more than planned. Two runs of
//!   [`PLAN_RUN_S`] s of machine time each: the reference with feedback alone (no plan, in
//!   `<row>/alone/`) and the run with the wrong plan. Pass: the largest true force with the
//!   wrong plan ≤ 1.05 × the reference's (the force stays controlled), no period commands
//!   above the plan's cap in force (`plan_cap:<pct>`: the plan only lowers the law's
//!   command) nor raises the command with an unusable force sample, `acc run`'s log flags
//!   the disagreement (`plan_disagree:above`; a v1 board has no `BLOCK_NUMBER`, so the
//!   look-ahead cannot place the tool and flags `plan_lost` instead, with no cap at all),
//!   and its log misses no period.
//! - **`plan-lead-low-stock`**: the same with the plan's lead (`--plan-lead`): the limit in
//!   force in a period the lead set is the lead (`plan_lead:<pct>`), and no period commands
//!   above it.
//! - **`plan-lead-slow-line`**: the right plan (made for the stock on the table) followed
//!   with the plan's lead, and at [`SLOW_LINE_AT_S`] s of machine time, mid-cut, the man in
//!   the middle (`tests/peers/mitm_proxy.py`) starts answering every status read with the
//!   board's reply of 2 reads earlier (a buffering gateway), to the end of the run. The
//!   reference is the same plan with its cap only on the same slow line. Pass: the largest
//!   true force after the line went slow ≤ 1.05 × the reference's (or, when the reference
//!   stopped sooner, × the largest force of the [`SLOW_LINE_BEFORE_S`] before the line
//!   went slow: what ACC allowed), no period commands above
//!   the limit in force or raises the command with an unusable force sample, `acc run`'s
//!   log shows the slow line (a replayed or lagging sample, a measured delay, or the delay
//!   judge's state) and no period is led (`plan_lead:`) from [`SLOW_LINE_GRACE_S`] s after
//!   the first such row on (the lead's window assumes the line as designed), the lead did
//!   act before the moment (on v2; a v1 board has no `BLOCK_NUMBER` and no lead at all:
//!   none may appear), and the log misses no period.
//! - **`plan-missing`**: `acc run --plan` names a file that does not exist. Pass: `acc run`
//!   exits with the usage code (2) naming the file, writes no run log, and the board served
//!   no request (nothing was sent to it).

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context};

use super::faults::{Fault, PlanFault};
use super::row::parse_fault_time;
use super::verdict::Row;
use super::FaultMatrixArgs;
use crate::child::{describe, read, Proc};
use crate::invariant::fault_periods_raising;
use crate::proxy::{spawn_proxy, stop_proxy, ProxyFiles};

/// The NC program of the plan rows (relative to the working directory: the repository).
pub const PLAN_PROGRAM: &str = "tests/nc/pocket_rect.ngc";
/// The stock on the table, `X0,Y0,Z0,X1,Y1,Z1` mm: the pocket's box.
pub const PLAN_STOCK: &str = "-20,-20,-10,60,50,0";
/// The stock the wrong plan was made for: 1 mm lower.
pub const PLAN_STOCK_LOW: &str = "-20,-20,-10,60,50,-1";
/// Machine time of each plan run, s: the approach, the plunge and the first pass (its
/// slotting entry and the zig-zag's corners).
pub const PLAN_RUN_S: f64 = 30.0;
/// Machine time at which the line goes slow in `plan-lead-slow-line`, s: in the first pass,
/// with the lead acting.
pub const SLOW_LINE_AT_S: f64 = 14.0;
/// Status reads of delay on the slow line (every read answered with the reply of this many
/// reads earlier).
pub const SLOW_LINE_DELAY_READS: u32 = 2;
/// After `acc run`'s log first shows the slow line, the loop has this long to stop the
/// lead, s.
pub const SLOW_LINE_GRACE_S: f64 = 0.5;
/// The window before the line goes slow whose largest force is what ACC allowed, s.
pub const SLOW_LINE_BEFORE_S: f64 = 2.0;

fn s(v: impl ToString) -> String {
    v.to_string()
}

/// The outcome of one closed loop of a plan row.
struct Loop {
    machine: Vec<acc_runtime::record::RunRecord>,
    run: Vec<acc_runtime::record::RunRecord>,
    exit: String,
    /// Machine time at which the line went slow, s (`None`: a clean line).
    slow_from_s: Option<f64>,
}

/// `acc board-sim --program … --pace controller` and `acc run [--plan plan]` for
/// [`PLAN_RUN_S`] s of machine time, logs in `dir` (`machine.csv`, `run.csv`); with
/// `slow_line`, the man in the middle between them, its delay switched on at
/// [`SLOW_LINE_AT_S`] s.
fn closed_loop(
    args: &FaultMatrixArgs,
    protocol: u8,
    dir: &Path,
    plan: Option<&Path>,
    lead: bool,
    slow_line: bool,
) -> anyhow::Result<Loop> {
    std::fs::create_dir_all(dir)?;
    let machine_log = dir.join("machine.csv");
    let run_log = dir.join("run.csv");
    let mut bargs = board_args(args, protocol, &machine_log);
    bargs.extend([
        s("--program"),
        s(PLAN_PROGRAM),
        format!("--stock-box={PLAN_STOCK}"),
    ]);
    if slow_line {
        // A marker at the moment: the knob set to where it is.
        bargs.extend([s("--fault"), format!("operator@{SLOW_LINE_AT_S}:100")]);
    }
    let (mut board, pty) = spawn_board(&bargs, dir)?;
    let mut proxy = None;
    let port = if slow_line {
        let mut pargs = vec![
            s("--seed"),
            args.line_seed.to_string(),
            s("--corrupt"),
            s("0"),
            s("--delay-reads"),
            SLOW_LINE_DELAY_READS.to_string(),
            s("--start"),
            s("off"),
        ];
        pargs.extend(ProxyFiles::in_dir(dir).args());
        let (p, port) = spawn_proxy(&args.proxy, &pty, &pargs, dir)?;
        proxy = Some(p);
        port
    } else {
        pty
    };
    let mut rargs = run_args(args, &port, &run_log);
    if let Some(p) = plan {
        rargs.extend([s("--plan"), p.to_string_lossy().into_owned()]);
        if lead {
            rargs.push(s("--plan-lead"));
        }
    }
    let (mut run, _) = Proc::spawn(&rargs, dir, "run")?;
    // At most real time (the plan config runs at 2×), plus start-up slack.
    let deadline =
        std::time::Instant::now() + Duration::from_secs_f64(PLAN_RUN_S) + Duration::from_secs(60);
    let mut slow_from_s = None;
    if let Some(p) = &proxy {
        // The moment: board-sim prints its marker; the delay is on from then to the end.
        while std::time::Instant::now() < deadline {
            if let Some(line) = board.wait_for(": fault ", Duration::from_millis(200)) {
                p.signal("USR1");
                slow_from_s = Some(parse_fault_time(&line).unwrap_or(SLOW_LINE_AT_S));
                break;
            }
            if let Ok(Some(_)) = run.child.try_wait() {
                break;
            }
        }
    }
    let left = deadline.saturating_duration_since(std::time::Instant::now());
    let exit = match run.wait(left) {
        Some(st) => describe(st),
        None => run.stop_running(),
    };
    if let Some(p) = proxy.as_mut() {
        stop_proxy(p);
    }
    stop_board(&mut board);
    Ok(Loop {
        machine: read(&machine_log)?,
        run: read(&run_log).unwrap_or_default(),
        exit,
        slow_from_s,
    })
}

/// `acc board-sim` on the matrix's scenario and time scale, `--pace controller`.
fn board_args(args: &FaultMatrixArgs, protocol: u8, machine_log: &Path) -> Vec<String> {
    let mut bargs = vec![
        s("board-sim"),
        s("--scenario"),
        args.scenario.to_string_lossy().into_owned(),
        s("--time-scale"),
        format!("{}", args.time_scale),
        s("--baud"),
        s("115200"),
        s("--wait-for-controller"),
        s("--pace"),
        s("controller"),
        s("--protocol"),
        protocol.to_string(),
        s("--log"),
        machine_log.to_string_lossy().into_owned(),
    ];
    if protocol == 1 {
        bargs.extend([s("--v1-registers"), s("exception")]);
    }
    bargs
}

/// `acc run` on the plan rows' config (`--plan-config`) for [`PLAN_RUN_S`] s of machine time.
fn run_args(args: &FaultMatrixArgs, port: &str, run_log: &Path) -> Vec<String> {
    vec![
        s("run"),
        s("--config"),
        args.plan_config.to_string_lossy().into_owned(),
        s("--port"),
        s(port),
        s("--log"),
        run_log.to_string_lossy().into_owned(),
        s("--duration-s"),
        format!("{PLAN_RUN_S}"),
    ]
}

fn spawn_board(bargs: &[String], dir: &Path) -> anyhow::Result<(Proc, String)> {
    let (mut board, pty) = Proc::spawn(bargs, dir, "board-sim")?;
    match pty.filter(|p| p.starts_with('/')) {
        Some(p) => Ok((board, p)),
        None => {
            board.wait(Duration::from_secs(2));
            board.drain(Duration::from_millis(200));
            bail!(
                "acc board-sim printed no pty path: {}",
                board.seen.join(" / ")
            )
        }
    }
}

/// Ctrl-C to `acc board-sim` (killed if it does not stop), its stderr collected.
fn stop_board(board: &mut Proc) {
    board.signal("INT");
    if board.wait(Duration::from_secs(10)).is_none() {
        board.signal("KILL");
    }
    board.drain(Duration::from_millis(200));
}

/// `N` of board-sim's `served N requests` line (`None`: no such line).
fn served_requests(lines: &[String]) -> Option<u64> {
    lines
        .iter()
        .find_map(|l| l.split("served ").nth(1)?.split(' ').next()?.parse().ok())
}

/// One plan row (see the module docs).
pub fn run_plan_row(
    args: &FaultMatrixArgs,
    f: &Fault,
    protocol: u8,
    dir: &Path,
    kind: PlanFault,
) -> anyhow::Result<Row> {
    match kind {
        PlanFault::LowerStock => low_stock_row(args, f, protocol, dir, false),
        PlanFault::LowerStockLead => low_stock_row(args, f, protocol, dir, true),
        PlanFault::LeadSlowLine => slow_line_row(args, f, protocol, dir),
        PlanFault::Missing => missing_row(args, f, protocol, dir),
    }
}

/// The row's fields that a plan row does not measure.
fn row_of(f: &Fault, protocol: u8, exit: String) -> Row {
    Row {
        fault: f.name.into(),
        what: f.what.into(),
        protocol,
        // The plan is wrong from the start.
        t_fault_s: Some(0.0),
        last_cmd_pct: None,
        max_applied_after_pct: None,
        force_before_n: 0.0,
        force_after_n: 0.0,
        force_after_released_n: 0.0,
        raised_in_fault: 0,
        feed_hold_after: false,
        log_rows: 0,
        log_complete: false,
        exit,
        verdict: String::new(),
        ok: false,
        line: None,
        first_attempt: None,
        untested: None,
    }
}

fn verdict(row: &mut Row, problems: &[String]) {
    row.ok = problems.is_empty();
    row.verdict = if row.ok {
        "pass".into()
    } else {
        format!("FAIL: {}", problems.join("; "))
    };
}

fn low_stock_row(
    args: &FaultMatrixArgs,
    f: &Fault,
    protocol: u8,
    dir: &Path,
    lead: bool,
) -> anyhow::Result<Row> {
    let plan = write_plan(args, dir, PLAN_STOCK_LOW)?;
    let (alone, wrong) = side_by_side(
        || closed_loop(args, protocol, &dir.join("alone"), None, false, false),
        || closed_loop(args, protocol, dir, Some(&plan), lead, false),
    );
    Ok(judge_low_stock(f, protocol, &alone?, &wrong?))
}

fn slow_line_row(
    args: &FaultMatrixArgs,
    f: &Fault,
    protocol: u8,
    dir: &Path,
) -> anyhow::Result<Row> {
    let plan = write_plan(args, dir, PLAN_STOCK)?;
    let (capped, led) = side_by_side(
        || closed_loop(args, protocol, &dir.join("cap"), Some(&plan), false, true),
        || closed_loop(args, protocol, dir, Some(&plan), true, true),
    );
    Ok(judge_slow_line(f, protocol, &capped?, &led?))
}

/// The reference loop and the loop under test of a row, at the same time: each has its
/// own board-sim, pty and `acc run`, and the board moves with its controller's writes
/// (`--pace controller`), so neither slips the other's timing.
fn side_by_side<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    std::thread::scope(|s| {
        let b = s.spawn(b);
        let a = a();
        (a, b.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
    })
}

/// `acc plan` of the program for the stock `stock_box` into `dir/plan/plan.csv`.
fn write_plan(args: &FaultMatrixArgs, dir: &Path, stock_box: &str) -> anyhow::Result<PathBuf> {
    let out = dir.join("plan");
    let exe = std::env::current_exe().context("path of the acc binary")?;
    let o = std::process::Command::new(exe)
        .args(["plan", PLAN_PROGRAM])
        .arg(format!("--stock-box={stock_box}"))
        .arg("--scenario")
        .arg(&args.scenario)
        .args(["--no-plot", "--out"])
        .arg(&out)
        .output()
        .context("running acc plan")?;
    if !o.status.success() {
        bail!("acc plan failed: {}", String::from_utf8_lossy(&o.stderr));
    }
    Ok(out.join("plan.csv"))
}

/// Periods of `acc run` that commanded above the plan's limit in force: the lead where the
/// plan's lead set the command (`plan_lead:<pct>`), else the cap (`plan_cap:<pct>`).
fn above_cap(run: &[acc_runtime::record::RunRecord]) -> usize {
    let flag = |r: &acc_runtime::record::RunRecord, name: &str| {
        r.flags
            .split(';')
            .find_map(|f| f.strip_prefix(name)?.parse::<u16>().ok())
    };
    run.iter()
        .filter(|r| {
            let limit = flag(r, "plan_lead:").or_else(|| flag(r, "plan_cap:"));
            matches!((limit, r.override_cmd_pct), (Some(l), Some(c)) if c > l)
        })
        .count()
}

/// The fields and checks every closed-loop plan row shares: from `run`'s logs, the periods
/// that commanded above the limit in force or raised on an unusable sample, the feed hold,
/// the log's rows, the last command; `row.force_before_n` / `force_after_n` must be set.
/// Returns the problems: no machine rows, ACC never active, the force above 1.05 × the
/// reference (`what` names the run and the reference), a raising period.
fn shared_checks(row: &mut Row, reference: &Loop, run: &Loop, what: (&str, &str)) -> Vec<String> {
    let (r, m) = (&run.run, &run.machine);
    row.raised_in_fault = fault_periods_raising(r) + above_cap(r);
    row.feed_hold_after = m.iter().any(|x| x.feed_hold);
    row.log_rows = r.len();
    row.log_complete = complete(r);
    row.last_cmd_pct = r
        .iter()
        .rev()
        .filter(|x| x.state == "active")
        .find_map(|x| x.override_cmd_pct);
    let mut problems = Vec::new();
    if reference.machine.is_empty() || m.is_empty() {
        problems.push("no machine rows".to_string());
    }
    if row.last_cmd_pct.is_none() {
        problems.push("ACC was never active with the plan".into());
    }
    if row.force_after_n > 1.05 * row.force_before_n {
        problems.push(format!(
            "force {:.0} N {} above {:.0} N {} (> 1.05×)",
            row.force_after_n, what.0, row.force_before_n, what.1
        ));
    }
    if row.raised_in_fault > 0 {
        problems.push(format!(
            "{} periods commanded above the plan's limit or raised with an unusable force",
            row.raised_in_fault
        ));
    }
    problems
}

fn judge_low_stock(f: &Fault, protocol: u8, alone: &Loop, wrong: &Loop) -> Row {
    let top = |rows: &[acc_runtime::record::RunRecord], released: bool| {
        rows.iter()
            .filter(|x| !released || x.state != "acc_active")
            .filter_map(|x| x.force_true_n)
            .fold(0.0, f64::max)
    };
    let (r, m) = (&wrong.run, &wrong.machine);
    let mut row = row_of(f, protocol, wrong.exit.clone());
    row.force_before_n = top(&alone.machine, false);
    row.force_after_n = top(m, false);
    row.force_after_released_n = top(m, true);
    let mut problems = shared_checks(
        &mut row,
        alone,
        wrong,
        ("with the wrong plan", "with feedback alone"),
    );
    let flag = if protocol == 1 {
        "plan_lost"
    } else {
        "plan_disagree:above"
    };
    if !r.iter().any(|x| x.flags.contains(flag)) {
        problems.push(format!("acc run's log never flags `{flag}`"));
    }
    if !row.log_complete {
        problems.push("acc run's log misses periods".into());
    }
    verdict(&mut row, &problems);
    row
}

/// Whether `acc run`'s log is whole: every period from 0 on, none missing.
fn complete(r: &[acc_runtime::record::RunRecord]) -> bool {
    !r.is_empty() && r.windows(2).all(|w| w[1].period == w[0].period + 1) && r[0].period == 0
}

fn led(r: &acc_runtime::record::RunRecord) -> bool {
    r.flags.split(';').any(|f| f.starts_with("plan_lead:"))
}

fn judge_slow_line(f: &Fault, protocol: u8, capped: &Loop, led_loop: &Loop) -> Row {
    let (r, m) = (&led_loop.run, &led_loop.machine);
    let mut row = row_of(f, protocol, led_loop.exit.clone());
    let t0 = led_loop.slow_from_s;
    row.t_fault_s = t0;
    // The largest true force from the moment on (machine time), N.
    let after = |l: &Loop| {
        let from = l.slow_from_s.unwrap_or(f64::INFINITY);
        l.machine
            .iter()
            .filter(|x| x.t_s >= from)
            .filter_map(|x| x.force_true_n)
            .fold(0.0, f64::max)
    };
    // The bound: the reference's largest force on the same slow line, or, when the
    // reference stopped sooner (its delay judge saw the line earlier), what ACC allowed in
    // this run in the SLOW_LINE_BEFORE_S before the line went slow.
    let allowed_before = t0.map_or(0.0, |t| {
        m.iter()
            .filter(|x| x.t_s < t && x.t_s >= t - SLOW_LINE_BEFORE_S)
            .filter_map(|x| x.force_true_n)
            .fold(0.0, f64::max)
    });
    row.force_before_n = after(capped).max(allowed_before);
    row.force_after_n = after(led_loop);
    row.force_after_released_n = m
        .iter()
        .filter(|x| x.state != "acc_active" && x.t_s >= t0.unwrap_or(f64::INFINITY))
        .filter_map(|x| x.force_true_n)
        .fold(0.0, f64::max);
    let Some(t0) = t0.filter(|_| capped.slow_from_s.is_some()) else {
        row.log_rows = r.len();
        row.log_complete = complete(r);
        verdict(
            &mut row,
            &["the line never went slow (no moment from board-sim)".to_string()],
        );
        return row;
    };
    let mut problems = shared_checks(
        &mut row,
        capped,
        led_loop,
        ("with the lead on the slow line", "with the cap alone"),
    );
    // When the loop first saw the slow line: its log's first flag of a stale or replayed
    // sample or of a measured delay, or the delay judge's state, from the moment on (the
    // run's clock follows the machine's: the board is paced by the controller).
    let seen = r.iter().find(|x| {
        x.t_s >= t0 - 1.0
            && (x.state == "delay"
                || x.flags.contains("seq_repeat")
                || x.flags.contains("seq_lag")
                || x.flags.contains("delay:"))
    });
    match seen {
        None => problems.push(format!(
            "acc run's log never shows the slow line (from {t0:.1} s on)"
        )),
        Some(first) => {
            let led_late = r
                .iter()
                .filter(|x| x.t_s >= first.t_s + SLOW_LINE_GRACE_S && led(x))
                .count();
            if led_late > 0 {
                problems.push(format!(
                    "{led_late} periods led more than {SLOW_LINE_GRACE_S} s after acc run saw the slow line ({:.1} s)",
                    first.t_s
                ));
            }
        }
    }
    let led_before = r.iter().filter(|x| x.t_s < t0 && led(x)).count();
    if protocol == 2 && led_before == 0 {
        problems.push("the lead never acted before the line went slow".into());
    }
    if protocol == 1 && r.iter().any(led) {
        problems.push("a v1 board (no BLOCK_NUMBER) was led".into());
    }
    if !row.log_complete {
        problems.push("acc run's log misses periods".into());
    }
    verdict(&mut row, &problems);
    row
}

fn missing_row(args: &FaultMatrixArgs, f: &Fault, protocol: u8, dir: &Path) -> anyhow::Result<Row> {
    let machine_log = dir.join("machine.csv");
    let run_log = dir.join("run.csv");
    let missing = dir.join("no-such-plan.csv");
    let _ = std::fs::remove_file(&run_log);
    let (mut board, pty) = spawn_board(&board_args(args, protocol, &machine_log), dir)?;
    let mut rargs = run_args(args, &pty, &run_log);
    rargs.extend([s("--plan"), missing.to_string_lossy().into_owned()]);
    let (mut run, _) = Proc::spawn(&rargs, dir, "run")?;
    let exit = match run.wait(Duration::from_secs(60)) {
        Some(st) => describe(st),
        None => {
            run.signal("KILL");
            "hung (killed by the harness)".into()
        }
    };
    run.drain(Duration::from_millis(200));
    // Give a run that did open the port the time to be served, then stop the board.
    std::thread::sleep(Duration::from_millis(300));
    stop_board(&mut board);
    let served = served_requests(&board.seen);
    let mut row = row_of(f, protocol, exit.clone());
    // No run log: no period to miss.
    row.log_complete = true;
    let mut problems = Vec::new();
    if exit != "2" {
        problems.push(format!(
            "acc run exit {exit} (2 expected: refused at start)"
        ));
    }
    if !run.seen.iter().any(|l| l.contains("no-such-plan.csv")) {
        problems.push("acc run's error does not name the plan file".into());
    }
    if run_log.exists() {
        problems.push("acc run wrote a run log".into());
        row.log_rows = read(&run_log).map(|r| r.len()).unwrap_or_default();
    }
    match served {
        Some(0) => {}
        Some(n) => problems.push(format!("the board served {n} requests")),
        None => problems.push("board-sim printed no request count".into()),
    }
    verdict(&mut row, &problems);
    Ok(row)
}

#[cfg(test)]
mod tests {
    use super::*;
    use acc_runtime::record::RunRecord;

    fn rec(period: u64, cmd: u16, flags: &str, force: f64) -> RunRecord {
        RunRecord {
            t_s: 0.1 * period as f64,
            period,
            state: "active".into(),
            override_cmd_pct: Some(cmd),
            force_valid: true,
            flags: flags.into(),
            force_true_n: Some(force),
            ..RunRecord::default()
        }
    }

    fn row(alone_force: f64, wrong: Vec<RunRecord>, protocol: u8) -> Row {
        let f = super::super::faults::FAULTS
            .iter()
            .find(|f| f.name == "plan-low-stock")
            .expect("row");
        let alone = Loop {
            machine: vec![rec(0, 100, "", alone_force)],
            run: vec![],
            exit: "0".into(),
            slow_from_s: None,
        };
        let wrong = Loop {
            machine: wrong.clone(),
            run: wrong,
            exit: "0".into(),
            slow_from_s: None,
        };
        judge_low_stock(f, protocol, &alone, &wrong)
    }

    #[test]
    fn a_wrong_plan_passes_only_below_the_cap_flagged_and_controlled() {
        let good = vec![
            rec(0, 60, "plan_cap:60", 700.0),
            rec(1, 50, "plan_cap:80;plan_disagree:above", 820.0),
        ];
        let r = row(800.0, good.clone(), 2);
        assert!(r.ok, "{r:?}");
        // The same log on a v1 board must flag plan_lost instead.
        let r = row(800.0, good.clone(), 1);
        assert!(!r.ok && r.verdict.contains("`plan_lost`"), "{r:?}");
        // A command above the cap in force.
        let mut over = good.clone();
        over[0].override_cmd_pct = Some(70);
        let r = row(800.0, over, 2);
        assert!(!r.ok && r.raised_in_fault == 1, "{r:?}");
        // More force than feedback alone.
        let r = row(700.0, good.clone(), 2);
        assert!(!r.ok && r.verdict.contains("820 N"), "{r:?}");
        // No disagreement flagged.
        let mut quiet = good;
        quiet[1].flags = "plan_cap:80".into();
        let r = row(800.0, quiet, 2);
        assert!(!r.ok && r.verdict.contains("plan_disagree:above"), "{r:?}");
    }

    fn slow(run: Vec<RunRecord>, machine_force: f64) -> Loop {
        let machine = (0..40)
            .map(|k| {
                let mut m = rec(k, 100, "", if k >= 20 { machine_force } else { 500.0 });
                m.t_s = 0.1 * k as f64;
                m
            })
            .collect();
        Loop {
            machine,
            run,
            exit: "6".into(),
            slow_from_s: Some(2.0),
        }
    }

    #[test]
    fn the_lead_on_a_slow_line_passes_only_when_it_stops_and_the_force_stays() {
        let f = super::super::faults::FAULTS
            .iter()
            .find(|f| f.name == "plan-lead-slow-line")
            .expect("row");
        // Led before the moment (2.0 s), the slow line seen at 2.1 s, no lead after.
        let run: Vec<RunRecord> = (0..40)
            .map(|k| match k {
                0..=20 => rec(k, 50, "plan_cap:60;plan_lead:50", 700.0),
                21 => rec(k, 50, "seq_repeat;fault;plan_cap:60", 700.0),
                _ => rec(k, 50, "plan_cap:60", 700.0),
            })
            .collect();
        let capped = slow(vec![], 700.0);
        let good = judge_slow_line(f, 2, &capped, &slow(run.clone(), 700.0));
        assert!(good.ok, "{good:?}");
        // A led period 0.5 s after the slow line was seen.
        let mut late = run.clone();
        late[27].flags = "plan_cap:60;plan_lead:50".into();
        let r = judge_slow_line(f, 2, &capped, &slow(late, 700.0));
        assert!(!r.ok && r.verdict.contains("1 periods led"), "{r:?}");
        // The slow line never seen.
        let mut unseen = run.clone();
        unseen[21].flags = "plan_cap:60".into();
        let r = judge_slow_line(f, 2, &capped, &slow(unseen, 700.0));
        assert!(!r.ok && r.verdict.contains("never shows"), "{r:?}");
        // More force after the moment than the cap alone on the same line.
        let r = judge_slow_line(f, 2, &capped, &slow(run.clone(), 800.0));
        assert!(!r.ok && r.verdict.contains("800 N"), "{r:?}");
        // A reference that stopped sooner (200 N): the bound is what ACC allowed before
        // the line went slow in this run (500 N before 2.0 s here, so 800 N fails) ...
        let early = slow(vec![], 200.0);
        let r = judge_slow_line(f, 2, &early, &slow(run.clone(), 800.0));
        assert!(
            !r.ok && r.verdict.contains("800 N") && r.verdict.contains("500 N"),
            "{r:?}"
        );
        // ... and a cut that kept the force it had before the line went slow passes.
        let mut flat = slow(run.clone(), 700.0);
        for m in &mut flat.machine {
            m.force_true_n = Some(700.0);
        }
        let r = judge_slow_line(f, 2, &early, &flat);
        assert!(r.ok, "{r:?}");
        // A v1 board is never led; and on v2 the lead must have acted before the moment.
        let r = judge_slow_line(f, 1, &capped, &slow(run.clone(), 700.0));
        assert!(!r.ok && r.verdict.contains("v1"), "{r:?}");
        let unled: Vec<RunRecord> = run
            .iter()
            .map(|x| RunRecord {
                flags: x.flags.replace(";plan_lead:50", ""),
                ..x.clone()
            })
            .collect();
        let r = judge_slow_line(f, 2, &capped, &slow(unled.clone(), 700.0));
        assert!(!r.ok && r.verdict.contains("never acted"), "{r:?}");
        assert!(judge_slow_line(f, 1, &capped, &slow(unled, 700.0)).ok);
    }

    #[test]
    fn the_request_count_is_read_from_board_sims_last_line() {
        let lines = vec![
            "board-sim: 0 periods".to_string(),
            "board-sim: served 0 requests (0 exceptions, 0 replies dropped undelivered, 0 read errors)".into(),
        ];
        assert_eq!(served_requests(&lines), Some(0));
        assert_eq!(served_requests(&lines[..1]), None);
    }
}
