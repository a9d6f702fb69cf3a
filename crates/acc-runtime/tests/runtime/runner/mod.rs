//! The threaded runtime on a manual clock: every period logged, orderly shutdown on the stop
//! flag, and a stalled log writer that holds the feed without losing a row.
//!
//! | module | what |
//! | --- | --- |
//! | here | the shared boards and loop; the driver on both clocks, the stop flag, CAN, the path |
//! | `log_stall` | a stalled run-log writer holds the feed and loses no row |
//! | `late_periods` | a late decision is dropped; skipped periods get flagged rows |
//! | `drain` | a stop mid-cut drains, a second stop holds; a vanished device ends the run |
//! | `reconnect` | the device comes back: re-armed at the last command, or given up |

mod drain;
mod late_periods;
mod log_stall;
mod reconnect;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use acc_runtime::policy::{AccState, FaultPolicy, PolicyConfig};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedError, ScriptedLaw};
use acc_runtime::{
    run, Clock, ControlLoop, LogSink, ManualClock, RunOptions, RunRecord, SystemClock, VecSink,
};

/// Run `pmc` with [`control()`] on a fresh manual clock, T = 0.1 s, at most `max` periods.
fn run_manual<P: acc_pmc::Board + Send, S: LogSink + Send>(
    pmc: &mut P,
    ctl: &mut ControlLoop<ScriptedLaw, LinearPowerForce>,
    sink: &mut S,
    stop: &AtomicBool,
    max: u64,
) -> acc_runtime::RunSummary {
    // On the manual clock the control thread runs flat out; a buffer that holds every period
    // keeps a starved logger thread (a loaded test machine) from holding the feed.
    let opts = RunOptions {
        log_buffer: 1 << 20,
        ..options(max)
    };
    run(pmc, ctl, ManualClock::new(), sink, stop, opts).expect("runs")
}

fn control() -> ControlLoop<ScriptedLaw, LinearPowerForce> {
    ControlLoop::new(
        FaultPolicy::new(PolicyConfig::default()),
        ScriptedLaw::new([90, 80, 70]),
        LinearPowerForce { n_per_w: 0.5 },
        0.1,
    )
}

/// A board whose power sample advances on every read (a live sensor); records the board's
/// `HEARTBEAT` at every read.
struct LiveBoard(ScriptedBoard, Vec<u16>);

impl acc_pmc::Board for LiveBoard {
    type Error = <ScriptedBoard as acc_pmc::Board>::Error;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        self.read_with_power(1500)
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.0.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        self.0.write_control(c)
    }
    fn protocol(&self) -> Option<acc_pmc::BoardProtocol> {
        self.0.protocol()
    }
}

impl LiveBoard {
    /// One status read whose new power sample is `power_w` (W); the board's clock advances
    /// one period (100 ms).
    fn read_with_power(&mut self, power_w: u32) -> Result<acc_pmc::BoardStatus, ScriptedError> {
        use acc_pmc::Board as _;
        self.1.push(self.0.board.heartbeat());
        self.0.board.push_power_sample(power_w);
        self.0.now_ms += 100;
        self.0.read_status()
    }
}

/// [`LiveBoard`] with a hook run before each status read: given the read's index (from 0),
/// it returns the power (W) that read's sample carries, and may raise a stop request or
/// stall the clock at a chosen read.
struct HookedBoard<F: FnMut(usize) -> u32> {
    live: LiveBoard,
    reads: usize,
    before_read: F,
}

impl<F: FnMut(usize) -> u32> HookedBoard<F> {
    fn new(before_read: F) -> Self {
        HookedBoard {
            live: LiveBoard(ScriptedBoard::new(), Vec::new()),
            reads: 0,
            before_read,
        }
    }
}

impl<F: FnMut(usize) -> u32> acc_pmc::Board for HookedBoard<F> {
    type Error = ScriptedError;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        let power_w = (self.before_read)(self.reads);
        self.reads += 1;
        self.live.read_with_power(power_w)
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.live.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        self.live.write_control(c)
    }
}

/// The run options of these tests: T = 0.1 s, at most `max` periods.
fn options(max: u64) -> RunOptions {
    RunOptions {
        max_periods: Some(max),
        ..RunOptions::new(Duration::from_millis(100))
    }
}

/// The one period driver on both clocks: the same loop on the same board decides the same
/// sequence on the stepped clock and on the wall clock (a period the wall clock skipped on a
/// loaded machine reads nothing and decides nothing: the other periods' decisions still
/// follow the stepped run's, in order).
#[test]
fn the_driver_decides_the_same_on_the_stepped_and_the_wall_clock() {
    const PERIODS: u64 = 40;
    let period = Duration::from_millis(20);
    let decisions = |rows: &[RunRecord]| -> Vec<(Option<u16>, String, Option<f64>, bool)> {
        rows.iter()
            .filter(|r| !r.has_flag("skipped"))
            .map(|r| (r.override_cmd_pct, r.state.clone(), r.force_n, r.feed_hold))
            .collect()
    };
    let go = |clock_is_wall: bool| {
        let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
        let mut ctl = control();
        let mut sink = VecSink::default();
        let opts = RunOptions {
            max_periods: Some(PERIODS),
            ..RunOptions::new(period)
        };
        let stop = AtomicBool::new(false);
        let s = if clock_is_wall {
            run(
                &mut board,
                &mut ctl,
                SystemClock::new(),
                &mut sink,
                &stop,
                opts,
            )
        } else {
            run(
                &mut board,
                &mut ctl,
                ManualClock::new(),
                &mut sink,
                &stop,
                opts,
            )
        }
        .expect("runs");
        (s, sink.0)
    };
    let (stepped, stepped_rows) = go(false);
    let (wall, wall_rows) = go(true);
    assert_eq!(stepped.periods, PERIODS);
    assert_eq!(wall.periods, PERIODS, "the wall clock ran every cycle");
    assert_eq!(stepped.skipped, 0, "the stepped clock never skips");
    assert_eq!(
        wall_rows.len() as u64,
        PERIODS + wall.skipped,
        "one row per deadline on the wall clock too"
    );
    let (a, b) = (decisions(&stepped_rows), decisions(&wall_rows));
    assert_eq!(a.len(), PERIODS as usize);
    assert_eq!(a, b, "the same decisions, period by period");
    // Both armed and drove the override through the scripted law.
    assert!(a.iter().any(|d| d.1 == "active" && d.0 == Some(80)));
    // Stepped time is exact: row k at (k + 1)·T.
    for (k, r) in stepped_rows.iter().enumerate() {
        assert!((r.t_s - (k as f64 + 1.0) * 0.02).abs() < 1e-12, "{}", r.t_s);
        assert_eq!(r.late_ms, 0.0);
    }
}

#[test]
fn runs_max_periods_logs_each_and_clears_acc_request() {
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = control();
    let clock = ManualClock::new();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let s = run(
        &mut board,
        &mut ctl,
        clock.clone(),
        &mut sink,
        &stop,
        options(50),
    )
    .expect("runs");
    assert_eq!(s.periods, 50);
    assert_eq!(s.logged, 50);
    assert_eq!(s.log_dropped, 0);
    assert_eq!(sink.0.len(), 50);
    // absolute deadlines on the manual clock: period k at (k+1)·T
    assert_eq!(clock.now(), Duration::from_millis(5000));
    assert_eq!(s.ticker.overruns, 0);
    for (k, r) in sink.0.iter().enumerate() {
        assert_eq!(r.period, k as u64);
        assert!((r.t_s - 0.1 * (k + 1) as f64).abs() < 1e-9);
    }
    assert_eq!(s.final_state, AccState::Active);
    // a v2 board: the release engages its fallback clamp, min(knob 100 %, last 70 %)
    let st = board.0.board.status();
    assert_eq!(st.override_applied_pct, 70, "clamped, never the knob's 100");
    assert!(st.fallback_active && !st.feed_hold_active);
    assert!(!s.shutdown_feed_hold);
    assert_eq!(s.protocol, Some(acc_pmc::BoardProtocol::V2));
    assert!(!board.0.board.control().acc_request, "ACC_REQUEST cleared");
    assert!(s.shutdown_ok.is_ok());
    // the law's commands reached the board while running
    assert!(board.0.override_writes.iter().any(|&(c, _)| c == 70));
}

/// A sink that raises the stop flag after `n` records (Ctrl-C in the middle of a cut).
struct StopAfter {
    n: usize,
    stop: Arc<AtomicBool>,
    rows: Vec<RunRecord>,
    flushed: bool,
}

impl LogSink for StopAfter {
    type Error = std::convert::Infallible;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.rows.push(rec.clone());
        if self.rows.len() == self.n {
            self.stop.store(true, Ordering::SeqCst);
        }
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.flushed = true;
        Ok(())
    }
}

#[test]
fn stop_flag_mid_run_logs_to_the_last_period_and_flushes() {
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = control();
    let stop = Arc::new(AtomicBool::new(false));
    let mut sink = StopAfter {
        n: 20,
        stop: Arc::clone(&stop),
        rows: Vec::new(),
        flushed: false,
    };
    let s = run_manual(&mut board, &mut ctl, &mut sink, &stop, 100_000);
    assert!(s.periods >= 20 && s.periods < 100_000);
    assert_eq!(
        sink.rows.len() as u64,
        s.periods,
        "every period up to the last is logged"
    );
    assert_eq!(s.log_dropped, 0);
    assert!(sink.flushed);
    assert!(!board.0.board.control().acc_request);
    assert!(!board.0.board.status().acc_active);
}

/// The same loop drives the CAN board (acc-pmc's CanBoard over its in-memory bus emulator).
#[test]
fn drives_the_can_board_through_the_same_loop() {
    use acc_pmc::can::{CanBoard, CanLinkConfig};
    use acc_pmc::emu::{lock_board, BoardLogic, CanBoardEmulator};

    let mut logic = BoardLogic::default();
    logic.set_acc_switch(true);
    logic.set_operator_override_pct(100);
    logic.set_programmed_feed_mm_min(200);
    logic.set_spindle_rpm(600);
    let shared = logic.shared();
    let bus = CanBoardEmulator::new(std::sync::Arc::clone(&shared), 1).expect("node 1");
    let can = CanBoard::new(bus, CanLinkConfig::default()).expect("CAN board");

    /// New power sample before every read, as the board's sensor would.
    struct Live(CanBoard<CanBoardEmulator>, acc_pmc::emu::SharedBoard);
    impl acc_pmc::Board for Live {
        type Error = <CanBoard<CanBoardEmulator> as acc_pmc::Board>::Error;
        fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
            lock_board(&self.1).push_power_sample(1500);
            self.0.read_status()
        }
        fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
            self.0.write_override(o, hb)
        }
        fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
            self.0.write_control(c)
        }
    }
    let mut pmc = Live(can, std::sync::Arc::clone(&shared));
    let mut ctl = control();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let s = run_manual(&mut pmc, &mut ctl, &mut sink, &stop, 20);
    assert_eq!(s.periods, 20);
    assert!(
        sink.0.iter().all(|r| !r.has_flag("link")),
        "every status pair arrived"
    );
    assert!(
        sink.0.iter().any(|r| r.override_cmd_pct == Some(70)),
        "the law's command was sent"
    );
    let b = lock_board(&shared);
    assert!(!b.control().acc_request, "ACC_REQUEST cleared at the end");
    assert_eq!(
        b.override_cmd_pct(),
        70,
        "the last command reached the board"
    );
}

#[test]
fn the_path_integrates_the_actual_feed_and_stands_still_in_a_feed_hold() {
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = control();
    let mut x = 0.0;
    for k in 0..5 {
        let c = ctl.cycle(&mut board, 0.1 * k as f64);
        let feed = c.feed_mm_min.expect("status read");
        assert!(feed > 0.0);
        x += feed * 0.1 / 60.0;
        assert!((c.path_mm - x).abs() < 1e-12, "{} vs {x}", c.path_mm);
    }
    board.0.board.set_operator_feed_hold(true);
    // The feed hold is a STATUS change: it counts once the next read confirms it (the line
    // guard), and the held period carries the last feed.
    let c = ctl.cycle(&mut board, 0.5);
    assert_eq!(
        c.guard.unconfirmed,
        Some(acc_runtime::guard::Register::Status)
    );
    x += c.feed_mm_min.expect("the last accepted status") * 0.1 / 60.0;
    for k in 6..10 {
        let c = ctl.cycle(&mut board, 0.1 * k as f64);
        assert_eq!(c.feed_mm_min, Some(0.0), "no feed in a feed hold");
    }
    assert!((ctl.path_mm() - x).abs() < 1e-12, "the path stood still");
}
