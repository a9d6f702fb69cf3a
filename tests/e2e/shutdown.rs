//! Ctrl-C in the middle of a cut never raises the feed: `acc run` against `acc board-sim`
//! over a pty (paper case III's cut as the fault matrix runs it,
//! `configs/scenarios/fault_matrix.toml`; the board paced by the controller's writes), SIGINT
//! while the tool is deep in the 4 mm step.
//! ACC keeps control through the drain (`[shutdown] drain_s`, 10 s of machine time by
//! default); the cut is still going when the drain ends, so `acc run` requests feed hold,
//! then releases with the hold kept, and exits with code 3. The machine-side log of
//! `acc board-sim` shows no force above the pre-signal level and the feed stopped.

use std::time::Duration;

use crate::e2e_support::{
    load_tolerant_config, one_at_a_time, read_log, spawn_board_sim, spawn_board_sim_on, spawn_run,
};

#[test]
fn sigint_mid_cut_keeps_control_then_holds_the_feed_and_never_raises_the_force() {
    let dir = tempfile::tempdir().expect("temp dir");
    let sim_log = dir.path().join("machine.csv");
    let run_log = dir.path().join("run.csv");
    let sim_log_s = sim_log.to_string_lossy().to_string();
    // A no-op operator fault at 16 s of machine time marks the moment (the knob stays at
    // 100 %): the 4 mm step runs from about 10 s to 34 s.
    // The machine moves one period per command write of `acc run` (`--pace controller`):
    // the signal lands at the same machine time whatever the host's load.
    let (mut board, pty) = spawn_board_sim_on(
        "configs/scenarios/fault_matrix.toml",
        &[
            "--log",
            &sim_log_s,
            "--fault",
            "operator@16:100",
            "--pace",
            "controller",
        ],
    );
    let config = load_tolerant_config(dir.path(), "");
    let run = spawn_run(&config.to_string_lossy(), &pty, &run_log);
    assert!(
        board.wait_for("fault Operator(100)", Duration::from_secs(60)),
        "board-sim did not reach t = 16 s: {:?}",
        board.err_lines
    );
    run.sigint();
    let (code, out, err) = run.finish(Duration::from_secs(30));
    let text = format!("{out}\n{}", err.join("\n"));
    assert_eq!(code, Some(3), "exit code of a feed-hold stop:\n{text}");
    assert!(
        text.contains("still cutting") && text.contains("feed hold requested"),
        "the last message says how it ended:\n{text}"
    );
    // Let the machine stand in the feed hold for a moment, then stop the board.
    std::thread::sleep(Duration::from_millis(500));
    board.sigint();
    let (bcode, _, berr) = board.finish(Duration::from_secs(10));
    assert_eq!(bcode, Some(0), "board-sim exit: {berr:?}");

    // The controller's log: ACC drove the override to the end, every period has a row.
    let rows = read_log(&run_log);
    let last = rows.last().expect("rows");
    assert_eq!(last.state, "active", "ACC kept control through the drain");
    assert!(
        last.t_s > 24.0,
        "drained for ~10 s after the signal: {}",
        last.t_s
    );

    // The machine's log: before the signal (deep in the 4 mm step) and after it.
    let m = read_log(&sim_log);
    let force = |r: &acc_runtime::RunRecord| r.force_true_n.unwrap_or(0.0);
    let pre = m
        .iter()
        .filter(|r| (10.0..16.0).contains(&r.t_s))
        .map(force)
        .fold(0.0, f64::max);
    let post = m
        .iter()
        .filter(|r| r.t_s >= 16.0)
        .map(force)
        .fold(0.0, f64::max);
    println!("largest true force: {pre:.0} N in 10..16 s, {post:.0} N after the signal");
    assert!(pre > 600.0, "cutting before the signal: {pre}");
    assert!(
        post <= 1.05 * pre,
        "the force rose after the signal: {post:.0} N against {pre:.0} N"
    );
    // The override applied after the signal never went above what ACC had commanded while
    // the feed was moving. (Once released into the feed hold, this v1 board applies the
    // operator's 100 % again, with the axes stopped: cycle start is the operator's act. A v2
    // board's fallback clamp keeps the last command.)
    let cmd_before = m
        .iter()
        .filter(|r| (10.0..16.0).contains(&r.t_s))
        .filter_map(|r| r.override_applied_pct)
        .max()
        .expect("applied");
    let applied_after = m
        .iter()
        .filter(|r| r.t_s >= 16.0 && !r.feed_hold)
        .filter_map(|r| r.override_applied_pct)
        .max()
        .expect("applied");
    assert!(
        applied_after <= cmd_before,
        "applied override rose: {applied_after} % after vs {cmd_before} % before"
    );
    // At the end the NC is in feed hold and the feed has stopped.
    let end = m.last().expect("machine rows");
    assert!(end.feed_hold, "feed hold at the end: {end:?}");
    assert!(
        end.feed_true_mm_min.unwrap_or(1.0) < 1.0,
        "the feed stopped: {end:?}"
    );
}

/// The board's device vanishes (board-sim killed: the pty's other end closes, every read
/// fails with EIO): `acc run` ends within the configured periods with exit code 4, a clear
/// message and a complete run log, instead of logging "disconnected" forever.
#[test]
fn a_vanished_device_ends_acc_run_with_its_exit_code() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let run_log = dir.path().join("run.csv");
    let (mut board, pty) = spawn_board_sim(&["--fault", "operator@5:100"]);
    let run = spawn_run("configs/runtime/board_sim_fast.toml", &pty, &run_log);
    assert!(
        board.wait_for("fault Operator(100)", Duration::from_secs(60)),
        "board-sim did not reach t = 5 s: {:?}",
        board.err_lines
    );
    board.child.kill().expect("kill board-sim");
    let _ = board.child.wait();
    let started = std::time::Instant::now();
    let (code, out, err) = run.finish(Duration::from_secs(30));
    let text = format!("{out}\n{}", err.join("\n"));
    assert_eq!(code, Some(4), "exit code of a lost device:\n{text}");
    assert!(
        text.contains("the board's device is gone"),
        "the message says why:\n{text}"
    );
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "ended within a bounded time: {:?}",
        started.elapsed()
    );
    let rows = read_log(&run_log);
    let periods: usize = crate::e2e_support::field(&out, "periods")
        .and_then(|v| v.parse().ok())
        .expect("summary line `periods: N`");
    assert_eq!(rows.len(), periods, "run log complete to the last period");
    assert!(rows
        .last()
        .is_some_and(|r| r.has_flag("link:disconnected") || r.has_flag("link:timeout")));
}
