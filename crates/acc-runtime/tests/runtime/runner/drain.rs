//! The drain: a stop mid-cut keeps control until the cut ends, a second stop holds the feed
//! at once, and a vanished device ends the run within the configured periods.

use super::*;

/// A live board cutting at 1500 W (750 N with [`control()`]'s force source) that raises a
/// stop request at read `stop_at` (as a Ctrl-C would) and leaves the cut (10 W, 5 N) from
/// read `air_from` on, run with a drain of `max_s` (manual clock, T = 0.1 s) and 3 air
/// periods.
fn drain_run(
    stop_at: usize,
    air_from: usize,
    max_s: f64,
    stop_now: bool,
) -> (acc_runtime::RunSummary, LiveBoard, Vec<RunRecord>) {
    struct Signals {
        stop: Arc<AtomicBool>,
        now: bool,
    }
    impl acc_runtime::StopRequest for Signals {
        fn stop_requested(&self) -> bool {
            self.stop.load(Ordering::SeqCst)
        }
        fn stop_now(&self) -> bool {
            self.now && self.stop_requested()
        }
    }
    let stop = Arc::new(AtomicBool::new(false));
    let raise = Arc::clone(&stop);
    let mut board = HookedBoard::new(move |read| {
        if read == stop_at {
            raise.store(true, Ordering::SeqCst);
        }
        if read >= air_from {
            10
        } else {
            1500
        }
    });
    let mut ctl = control().with_air_force_n(100.0);
    let mut sink = VecSink::default();
    let opts = RunOptions {
        drain: Some(acc_runtime::Drain {
            max: Duration::from_secs_f64(max_s),
            air_periods: 3,
        }),
        ..options(500)
    };
    let signals = Signals {
        stop,
        now: stop_now,
    };
    let s = run(
        &mut board,
        &mut ctl,
        ManualClock::new(),
        &mut sink,
        &signals,
        opts,
    )
    .expect("runs");
    (s, board.live, sink.0)
}

#[test]
fn a_stop_mid_cut_keeps_control_until_the_cut_ends_then_releases() {
    let (s, board, rows) = drain_run(10, 20, 10.0, false);
    assert_eq!(s.ended, acc_runtime::Ended::Released);
    // Stop requested at read 10; the cut ends at read 20; 3 air periods end the drain.
    assert_eq!(s.periods, 23, "cycles until three periods out of the cut");
    assert!(
        rows.iter().all(|r| r.state == "active"),
        "ACC kept driving the override through the drain"
    );
    assert!(rows[11..20].iter().all(|r| r.override_cmd_pct.is_some()));
    let last = board
        .0
        .control_writes
        .last()
        .copied()
        .expect("control written");
    assert!(
        !last.acc_request && !last.feed_hold_request,
        "released without feed hold out of the cut: {last:?}"
    );
    assert!(board.0.control_writes.iter().all(|c| !c.feed_hold_request));
}

#[test]
fn still_cutting_when_the_drain_ends_holds_the_feed_then_releases() {
    let (s, board, rows) = drain_run(10, usize::MAX, 1.0, false);
    assert_eq!(
        s.ended,
        acc_runtime::Ended::FeedHold {
            reason: "drain_timeout"
        }
    );
    // 1 s of drain at T = 0.1 s after the stop at read 10.
    assert!((20..=22).contains(&s.periods), "{} cycles", s.periods);
    assert!(rows.iter().all(|r| r.state == "active"));
    let w = &board.0.control_writes;
    let n = w.len();
    assert!(n >= 3, "{w:?}");
    assert!(
        w[n - 2].acc_request && w[n - 2].feed_hold_request,
        "feed hold while ACC still drives: {w:?}"
    );
    assert!(
        !w[n - 1].acc_request && w[n - 1].feed_hold_request,
        "then released with the hold kept: {w:?}"
    );
    let st = board.0.board.status();
    assert!(st.feed_hold_active, "the NC is in feed hold: {st:?}");
}

#[test]
fn a_second_stop_holds_the_feed_at_once() {
    let (s, board, _) = drain_run(10, usize::MAX, 60.0, true);
    assert_eq!(
        s.ended,
        acc_runtime::Ended::FeedHold {
            reason: "second_signal"
        }
    );
    assert_eq!(s.periods, 11, "ends at the first check after the request");
    let last = board.0.control_writes.last().copied().expect("written");
    assert!(!last.acc_request && last.feed_hold_request, "{last:?}");
}

#[test]
fn a_stop_out_of_the_cut_releases_at_once() {
    let (s, board, _) = drain_run(10, 0, 10.0, false);
    assert_eq!(s.ended, acc_runtime::Ended::Released);
    assert_eq!(s.periods, 11);
    assert!(board.0.control_writes.iter().all(|c| !c.feed_hold_request));
}

#[test]
fn a_vanished_device_ends_the_run_within_the_configured_periods() {
    // Healthy for 10 transactions' worth of periods, then every transaction finds the
    // device gone (a pulled USB adapter: EIO on every read and write).
    let mut b = ScriptedBoard::new();
    b.faults.extend(std::iter::repeat_n(None, 25));
    b.faults.extend(std::iter::repeat_n(
        Some(acc_runtime::testing::LinkFault::RequestLost(
            acc_pmc::BoardErrorKind::Disconnected,
        )),
        10_000,
    ));
    let mut board = LiveBoard(b, Vec::new());
    let mut ctl = control();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    // The default gives a device 20 periods (`RunOptions::device_lost_periods`).
    let s = run_manual(&mut board, &mut ctl, &mut sink, &stop, 1000);
    assert_eq!(s.ended, acc_runtime::Ended::DeviceLost);
    assert!(
        s.periods < 60,
        "ended soon after the loss: {} periods",
        s.periods
    );
    let gone = sink
        .0
        .iter()
        .rev()
        .take_while(|r| r.has_flag("link:disconnected"))
        .count();
    assert_eq!(
        gone, 20,
        "exactly the configured periods without the device"
    );
    // Every period has its row; the policy released (link lost) before the end.
    assert_eq!(sink.0.len() as u64, s.periods);
    assert!(sink.0.last().is_some_and(|r| r.state == "link_lost"));
}

#[test]
fn ending_mid_cut_on_a_v1_board_holds_the_feed_before_the_release() {
    let mut board = LiveBoard(ScriptedBoard::v1(), Vec::new());
    let mut ctl = control();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let s = run_manual(&mut board, &mut ctl, &mut sink, &stop, 30);
    assert_eq!(s.ended, acc_runtime::Ended::Completed);
    assert_eq!(s.protocol, Some(acc_pmc::BoardProtocol::V1));
    assert!(s.shutdown_feed_hold, "v1, in the cut: feed hold first");
    let writes = &board.0.control_writes;
    let n = writes.len();
    assert!(n >= 2);
    // feed hold while ACC still drives the override, then the release with the hold kept
    assert!(writes[n - 2].acc_request && writes[n - 2].feed_hold_request);
    assert!(!writes[n - 1].acc_request && writes[n - 1].feed_hold_request);
    let st = board.0.board.status();
    assert!(
        st.feed_hold_active,
        "the knob (100 %) is applied, but the axes stand"
    );
}
