//! The wear and breakage watch live, end to end over a real pty pair: `acc run` (production
//! code: threaded runtime, fault policy with the breakage detector, logger thread with the
//! watch, tool-history writer thread) against `acc board-sim` on
//! `configs/scenarios/tool_breakage.toml` (the tool breaks 30 s into the cut), both 4× real
//! time. The force drop is answered with feed hold within 2 periods, the `breakage` alarm is
//! in the run log, and the history file beside the log holds the cut and the alarm.

use std::time::{Duration, Instant};

use crate::e2e_support::{load_tolerant_config, read_log, spawn_board_sim_on, spawn_run};
use acc_runtime::history::History;

const BREAKAGE_BIT: u8 = 1 << 5;

#[test]
fn acc_run_catches_a_broken_tool_and_stores_it_in_the_history() {
    let dir = tempfile::tempdir().expect("temp dir");
    let run_log = dir.path().join("run.csv");
    // Paced by the controller's writes, late replies held: the subject is the watch, not the
    // link's timing on a loaded host.
    let (board, pty) = spawn_board_sim_on(
        "configs/scenarios/tool_breakage.toml",
        &["--pace", "controller"],
    );
    let config = load_tolerant_config(dir.path(), "");
    let run = spawn_run(&config.to_string_lossy(), &pty, &run_log);
    // The break is at 30 s of machine time (7.5 s of wall time at 4× on an idle host): wait
    // for the alarm; the deadline only guards a hang.
    let end = Instant::now() + Duration::from_secs(300);
    let mut caught = false;
    while Instant::now() < end {
        std::thread::sleep(Duration::from_millis(500));
        let Ok(text) = std::fs::read_to_string(&run_log) else {
            continue;
        };
        if text.lines().count() > 2
            && read_log(&run_log)
                .iter()
                .any(|r| r.alarms & BREAKAGE_BIT != 0)
        {
            caught = true;
            break;
        }
    }
    // Let a few more periods through, then stop both.
    std::thread::sleep(Duration::from_millis(500));
    run.sigint();
    let (_code, out, err) = run.finish(Duration::from_secs(20));
    board.sigint();
    let _ = board.finish(Duration::from_secs(10));
    assert!(
        caught,
        "no breakage alarm in the run log; acc run:\n{out}\n{err:?}"
    );

    let rows = read_log(&run_log);
    let fr = 800.0;
    // The first period whose force fell below 0.4 Fr after steady cutting, and the first
    // period with the feed-hold request.
    let steady_from = rows
        .iter()
        .position(|r| r.force_n.is_some_and(|f| f > 0.8 * fr))
        .expect("cutting");
    let drop = rows[steady_from..]
        .iter()
        .find(|r| r.force_n.is_some_and(|f| f < 0.4 * fr))
        .expect("the force drop of the broken tool");
    let hold = rows
        .iter()
        .find(|r| r.feed_hold)
        .expect("feed hold requested");
    let periods = hold.period as i64 - drop.period as i64;
    println!(
        "force drop at period {} ({:.1} s, {:?} N); feed hold requested at period {} ({:.1} s)",
        drop.period, drop.t_s, drop.force_n, hold.period, hold.t_s
    );
    assert!(
        (0..=2).contains(&periods),
        "feed hold {periods} periods after the drop"
    );
    assert_eq!(hold.alarms & BREAKAGE_BIT, BREAKAGE_BIT, "{hold:?}");
    assert!(
        out.contains("breakage"),
        "acc run's summary names the alarm:\n{out}"
    );

    // The history beside the log: the cut and the alarm, stored by the writer thread.
    let h = History::open(dir.path().join("acc-history.sqlite")).expect("history");
    assert_eq!(h.run_count().expect("runs"), 1);
    assert!(h.count("cuts").expect("cuts") >= 1, "{out}");
    assert!(h.count("alarms").expect("alarms") >= 1, "{out}");
    assert!(
        out.contains("history:") && out.contains("0 dropped"),
        "{out}"
    );
}
