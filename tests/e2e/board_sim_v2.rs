//! `acc board-sim` as a v2 and as a v1 board, over its pty, with a minimal controller (the
//! production RTU client): the cable is pulled mid-cut (`--fault unplug@T[:S]`) and the
//! machine-side log shows what the board alone does — on v2 the watchdog trips, the clamp
//! keeps the last command and the feed is held; on v1 the operator's knob takes over. The log
//! has a row for every period, unplugged ones included.

use std::time::{Duration, Instant};

use crate::e2e_support::{read_log, Proc};
use acc_pmc::serial::{open_rtu_board, RtuConfig};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardProtocol, ControlBits};
use acc_runtime::record::RunRecord;

const ARM: ControlBits = ControlBits {
    acc_request: true,
    feed_hold_request: false,
    alarm_reset: false,
};

/// The board-sim (scenario paper case 1, time scale 1, knob at 150 %) with `extra` arguments;
/// the log goes to `log`.
fn board_sim(log: &std::path::Path, extra: &[&str]) -> Proc {
    let log = log.to_str().expect("utf-8 path").to_string();
    let mut args = vec![
        "board-sim",
        "--scenario",
        "configs/scenarios/paper_case1.toml",
        "--operator-override",
        "150",
        "--wait-for-controller",
        "--log",
        &log,
    ];
    args.extend_from_slice(extra);
    Proc::spawn(&args, true)
}

/// Drive the board at `cmd` % for `run` of wall time (one cycle per 20 ms); returns the
/// number of cycles that got no answer (timeouts while the cable is out) and of those that
/// did.
fn command_override_for(path: &str, cmd: u16, run: Duration, expect: BoardProtocol) -> (u32, u32) {
    let mut cfg = RtuConfig::for_port(path);
    cfg.parity = "none".into();
    // A board-sim started beside other tests on 2 cores can answer the start-up writes
    // later than the default 40 ms: retried, as a controller would; while the cable is out
    // a cycle then takes up to three timeouts, which only slows the loop.
    cfg.retries = 2;
    let settings = cfg.validate("e2e.toml", "board").expect("valid");
    let mut b = open_rtu_board(&settings).expect("open the board-sim pty");
    let s = b.read_status().expect("status");
    assert_eq!(b.protocol(), Some(expect), "{s:?}");
    // The command first, then ACC_REQUEST: the board never applies its power-up 100 %.
    b.write_override(cmd, 0).expect("command");
    b.write_control(ARM).expect("arm");
    let (mut lost, mut answered) = (0u32, 0u32);
    let end = Instant::now() + run;
    let mut hb = 0u16;
    while Instant::now() < end {
        hb = hb.wrapping_add(1);
        match b.write_override(cmd, hb).and_then(|()| b.read_status()) {
            Ok(s) => {
                answered += 1;
                if s.watchdog_tripped {
                    // Plugged back in: re-arm (the command first, then ALARM_RESET).
                    b.write_override(cmd, hb).ok();
                    b.write_control(ControlBits {
                        alarm_reset: true,
                        ..ARM
                    })
                    .ok();
                }
            }
            Err(e) => {
                assert_eq!(e.kind(), BoardErrorKind::Timeout, "{e}");
                lost += 1;
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    (lost, answered)
}

fn finish(sim: Proc) -> Vec<String> {
    sim.sigint();
    let (code, _, err) = sim.finish(Duration::from_secs(10));
    assert_eq!(code, Some(0), "{err:?}");
    err
}

/// Every machine period has its row, in order: machine time advances by one period T
/// from row to row (the wall-clock tick index may skip under load, machine time does not).
fn assert_complete(rows: &[RunRecord]) {
    assert!(rows.len() > 2);
    let t = rows[1].t_s - rows[0].t_s;
    assert!(t > 0.0);
    for w in rows.windows(2) {
        assert!(
            (w[1].t_s - w[0].t_s - t).abs() < 1e-6,
            "a period without a row between t = {} and {}",
            w[0].t_s,
            w[1].t_s
        );
    }
}

#[test]
fn a_pulled_cable_on_a_v2_board_clamps_and_holds_and_the_log_goes_on() {
    let dir = tempfile::tempdir().expect("tmp");
    let log = dir.path().join("board.csv");
    let sim = board_sim(&log, &["--fault", "unplug@1.0"]);
    let path = sim.first_line.clone().expect("pty path");
    let (lost, answered) =
        command_override_for(&path, 50, Duration::from_millis(2_500), BoardProtocol::V2);
    assert!(
        answered > 10 && lost >= 5,
        "answered {answered}, lost {lost}"
    );
    let err = finish(sim);
    assert!(err.iter().any(|l| l.contains("Unplug(None)")), "{err:?}");
    let rows = read_log(&log);
    assert_complete(&rows);
    let unplugged: Vec<&RunRecord> = rows.iter().filter(|r| r.has_flag("unplugged")).collect();
    assert!(unplugged.len() >= 10, "{} unplugged rows", unplugged.len());
    // Before the pull the board applied the controller's 50 %; after it never more, and once
    // the watchdog tripped (500 ms) the clamp holds 50 % and the feed is held.
    assert!(rows
        .iter()
        .any(|r| r.state == "acc_active" && r.override_applied_pct == Some(50)));
    for r in &unplugged {
        assert!(r.override_applied_pct <= Some(50), "{r:?}");
    }
    let tripped: Vec<&&RunRecord> = unplugged
        .iter()
        .filter(|r| r.has_flag("watchdog"))
        .collect();
    assert!(!tripped.is_empty(), "the watchdog tripped while unplugged");
    for r in &tripped {
        assert!(r.has_flag("fallback:50") && r.feed_hold, "{r:?}");
        assert_eq!(r.feed_mm_min, Some(0.0));
        assert_eq!((r.tool, r.program), (Some(1), Some(1000)));
    }
    // The true force after the pull never exceeds 1.05 × the largest before it.
    let before = rows
        .iter()
        .take_while(|r| !r.has_flag("unplugged"))
        .filter_map(|r| r.force_true_n)
        .fold(0.0, f64::max);
    let after = unplugged
        .iter()
        .filter_map(|r| r.force_true_n)
        .fold(0.0, f64::max);
    assert!(
        after <= 1.05 * before + 1.0,
        "{after} N after vs {before} N before"
    );
}

#[test]
fn a_cable_plugged_back_in_is_served_again() {
    let dir = tempfile::tempdir().expect("tmp");
    let log = dir.path().join("board.csv");
    let sim = board_sim(&log, &["--fault", "unplug@0.5:1.0"]);
    let path = sim.first_line.clone().expect("pty path");
    let (lost, answered) =
        command_override_for(&path, 60, Duration::from_millis(2_500), BoardProtocol::V2);
    let err = finish(sim);
    assert!(
        err.iter().any(|l| l.contains("cable plugged back in")),
        "{err:?}"
    );
    assert!(
        lost >= 4 && answered > 30,
        "answered {answered}, lost {lost}"
    );
    let rows = read_log(&log);
    assert_complete(&rows);
    let last_unplugged = rows
        .iter()
        .rposition(|r| r.has_flag("unplugged"))
        .expect("unplugged rows");
    // Re-armed after the reconnection: ACC drives 60 % again, the clamp released.
    let tail = &rows[last_unplugged + 1..];
    assert!(
        tail.iter().any(|r| r.state == "acc_active"
            && r.override_applied_pct == Some(60)
            && !r.has_flag("fallback")
            && !r.feed_hold),
        "not re-armed after the reconnection"
    );
    for r in &rows {
        assert!(r.override_applied_pct <= Some(60), "{r:?}");
    }
}

#[test]
fn a_pulled_cable_on_a_v1_board_hands_the_feed_to_the_knob() {
    // Why a controller on a v1 board must never rely on the board: the knob's 150 % comes
    // back when the watchdog trips.
    let dir = tempfile::tempdir().expect("tmp");
    let log = dir.path().join("board.csv");
    let sim = board_sim(&log, &["--protocol", "1", "--fault", "unplug@1.0"]);
    let path = sim.first_line.clone().expect("pty path");
    command_override_for(&path, 50, Duration::from_millis(2_500), BoardProtocol::V1);
    finish(sim);
    let rows = read_log(&log);
    assert_complete(&rows);
    let tripped: Vec<&RunRecord> = rows.iter().filter(|r| r.has_flag("watchdog")).collect();
    assert!(!tripped.is_empty());
    for r in &tripped {
        assert_eq!(r.override_applied_pct, Some(150), "{r:?}");
        assert!(!r.feed_hold && !r.has_flag("fallback"), "{r:?}");
        assert_eq!((r.tool, r.block), (None, None), "no NC context on v1");
    }
}
