//! The threaded runtime on a manual clock: every period logged, orderly shutdown on the stop
//! flag, and a stalled log writer that holds the feed without losing a row.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use acc_runtime::policy::{AccState, FaultPolicy, PolicyConfig};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedLaw};
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
        max_periods: Some(max),
        log_buffer: 1 << 20,
        ..RunOptions::new(Duration::from_millis(100))
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
        self.1.push(self.0.board.heartbeat());
        self.0.board.push_power_sample(1500);
        self.0.now_ms += 100;
        self.0.read_status()
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
    let opts = RunOptions {
        max_periods: Some(50),
        ..RunOptions::new(Duration::from_millis(100))
    };
    let s = run(&mut board, &mut ctl, clock.clone(), &mut sink, &stop, opts).expect("runs");
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

/// A logger that takes 2 ms per record.
/// A sink whose writes block while the gate is shut (a stalled disk): it counts the records
/// it wrote.
struct GatedSink {
    gate: Arc<(Mutex<bool>, Condvar)>,
    written: Vec<RunRecord>,
}

impl GatedSink {
    fn shut() -> (Self, Arc<(Mutex<bool>, Condvar)>) {
        let gate = Arc::new((Mutex::new(false), Condvar::new()));
        (
            Self {
                gate: Arc::clone(&gate),
                written: Vec::new(),
            },
            gate,
        )
    }
}

fn open_gate(gate: &(Mutex<bool>, Condvar)) {
    *gate.0.lock().expect("gate") = true;
    gate.1.notify_all();
}

impl LogSink for GatedSink {
    type Error = std::convert::Infallible;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        let (open, cv) = &*self.gate;
        let mut g = open.lock().expect("gate");
        while !*g {
            g = cv.wait(g).expect("gate");
        }
        self.written.push(rec.clone());
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// The run log's writer stalls mid-cut: the loop keeps every record, holds the feed once the
/// writer is `log_buffer` records behind, and writes every row once the writer is back.
#[test]
fn a_stalled_log_writer_holds_the_feed_and_loses_no_row() {
    const BUFFER: usize = 40;
    const PERIODS: u64 = 120;
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = control();
    let (mut sink, gate) = GatedSink::shut();
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(PERIODS),
        log_buffer: BUFFER,
        ..RunOptions::new(Duration::from_millis(100))
    };
    // The disk comes back only once the last period has been decided: every period of the
    // run is decided with the writer stalled (the final hand-over then waits on it).
    struct OpenAtTheEnd(Arc<(Mutex<bool>, Condvar)>);
    impl acc_runtime::PeriodObserver for OpenAtTheEnd {
        fn period(&mut self, rec: &mut RunRecord) -> acc_runtime::Verdict {
            if rec.period + 1 == PERIODS {
                open_gate(&self.0);
            }
            acc_runtime::Verdict::Continue
        }
    }
    let mut opener = OpenAtTheEnd(gate);
    let hooks = acc_runtime::Hooks {
        reopen: None,
        observer: Some(&mut opener),
    };
    let s = acc_runtime::drive(
        &mut board,
        &mut ctl,
        ManualClock::new(),
        &mut sink,
        &stop,
        opts,
        hooks,
    )
    .expect("runs");
    assert_eq!(s.periods, PERIODS, "control ran every period");
    assert_eq!(s.log_dropped, 0, "no record lost");
    assert_eq!(s.logged, PERIODS);
    let rows = &sink.written;
    assert_eq!(rows.len() as u64, PERIODS, "every row written, late");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.period, k as u64, "in order");
    }
    // Stalled once the writer was more than the buffer behind (one record is in the
    // writer's hands, the queue and the backlog hold the buffer).
    let first = rows
        .iter()
        .position(|r| r.has_flag("log_stalled"))
        .expect("the stall is flagged");
    assert!(
        (BUFFER..=BUFFER + 2).contains(&first),
        "stalled from period {first}"
    );
    assert!(rows[first..].iter().all(|r| r.has_flag("log_stalled")));
    assert_eq!(s.log_stalled_periods, PERIODS - first as u64);
    assert!(s.log_backlog_max >= BUFFER as u64);
    // The loop was cutting under ACC; the stall releases with a feed hold, latched.
    assert_eq!(rows[first - 1].state, "active", "{:?}", rows[first - 1]);
    assert!(!rows[first - 1].feed_hold);
    assert!(rows[first].feed_hold, "{:?}", rows[first]);
    assert_eq!(
        rows[first].state, "log_stalled",
        "latched: {:?}",
        rows[first]
    );
    assert!(rows[first..].iter().all(|r| r.feed_hold));
    assert!(s.shutdown_feed_hold || s.final_state != acc_runtime::AccState::Active);
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

/// How many status reads the board has answered, shared between the board (the I/O thread)
/// and the law (the control thread) so that a test can order the two threads.
#[derive(Default)]
struct ReadCount {
    reads: Mutex<u64>,
    changed: Condvar,
}

impl ReadCount {
    fn get(&self) -> u64 {
        *self.reads.lock().expect("read counter")
    }

    /// Block until at least `n` reads were answered (panics after 30 s of wall time: the
    /// I/O thread is stuck, which is a failure of the run, not of the clock).
    fn wait_for(&self, n: u64) {
        let guard = self.reads.lock().expect("read counter");
        let (guard, timeout) = self
            .changed
            .wait_timeout_while(guard, Duration::from_secs(30), |r| *r < n)
            .expect("read counter");
        assert!(
            !timeout.timed_out(),
            "read {n} never came (reads: {})",
            *guard
        );
    }
}

/// [`LiveBoard`] whose status read of period `late_period` returns one whole period late on
/// the manual clock: the I/O thread then has no time left to wait for that period's plan.
struct LateReadBoard {
    live: LiveBoard,
    clock: ManualClock,
    period: Duration,
    late_period: u64,
    count: Arc<ReadCount>,
}

impl acc_pmc::Board for LateReadBoard {
    type Error = <ScriptedBoard as acc_pmc::Board>::Error;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        let status = self.live.read_status();
        let mut reads = self.count.reads.lock().expect("read counter");
        if *reads == self.late_period {
            self.clock.advance(self.period);
        }
        *reads += 1;
        self.count.changed.notify_all();
        status
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.live.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        self.live.write_control(c)
    }
}

/// A law whose decision of period `held_period` is held until the board has answered the
/// next period's status read, so that it reaches the I/O thread one period late.
struct HeldDecision {
    inner: ScriptedLaw,
    held_period: u64,
    count: Arc<ReadCount>,
}

impl acc_core::OverrideLaw for HeldDecision {
    fn name(&self) -> &str {
        "held-decision"
    }
    fn engage(&mut self, c: acc_core::FeedOverride) {
        self.inner.engage(c)
    }
    fn step(&mut self, m: &acc_core::Measurement) -> acc_core::StepOutput {
        // Reads answered = period index + 1 while period `held_period` is being decided.
        if self.count.get() == self.held_period + 1 {
            self.count.wait_for(self.held_period + 2);
        }
        self.inner.step(m)
    }
    fn set_frozen(&mut self, f: bool) {
        self.inner.set_frozen(f)
    }
}

/// Deterministic on the manual clock: the status read of period `LATE` takes the whole
/// period, so the I/O thread's wait for that period's plan ends at once; the decision itself
/// is held until the next period's read. The late plan must be dropped (that period writes
/// nothing) and must not be applied in the next period; every other period's plan is
/// applied in its own period. The plan wait of the other periods is the period (10 s) in
/// wall time, far longer than any decision takes.
#[test]
fn a_late_control_decision_is_dropped_not_applied_a_period_late() {
    const LATE: u64 = 10;
    let period = Duration::from_secs(10);
    let clock = ManualClock::new();
    let count = Arc::new(ReadCount::default());
    let mut board = LateReadBoard {
        live: LiveBoard(ScriptedBoard::new(), Vec::new()),
        clock: clock.clone(),
        period,
        late_period: LATE,
        count: Arc::clone(&count),
    };
    let mut ctl = ControlLoop::new(
        FaultPolicy::new(PolicyConfig::default()),
        HeldDecision {
            inner: ScriptedLaw::new([90, 80, 70]),
            held_period: LATE,
            count: Arc::clone(&count),
        },
        LinearPowerForce { n_per_w: 0.5 },
        0.1,
    );
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(20),
        ..RunOptions::new(period)
    };
    let s = run(&mut board, &mut ctl, clock.clone(), &mut sink, &stop, opts).expect("runs");
    assert_eq!(s.periods, 20);
    assert_eq!(count.get(), 20);
    // The late read ended exactly at the next deadline: no tick was missed.
    assert_eq!(s.ticker.overruns, 0);
    assert_eq!(clock.now(), period * 20);
    assert_eq!(sink.0.len(), 20);
    let hb_at_read = &board.live.1;
    let mut dropped = Vec::new();
    for (p, rec) in sink.0.iter().enumerate().take(19) {
        let hb = rec
            .heartbeat
            .unwrap_or_else(|| panic!("period {p}: the law decided, so the plan writes"));
        // the board shows this period's heartbeat at the next read, unless the plan was late
        if hb_at_read[p + 1] != hb {
            assert!(
                hb_at_read[p + 1] < hb,
                "period {p}: an older plan was applied late"
            );
            dropped.push(p as u64);
        }
    }
    // Only the held decision missed its period; afterwards every period's plan is applied
    // in its own period again.
    assert_eq!(dropped, vec![LATE], "periods whose plan was dropped");
}

/// A [`LiveBoard`] whose read in period `at` stalls for 3.5 periods on the manual clock (a
/// slow link): the next tick comes 2.5 periods late, and the ticker skips the two whole
/// deadlines that passed meanwhile.
struct StallingBoard {
    live: LiveBoard,
    clock: ManualClock,
    at: usize,
    reads: usize,
}

impl acc_pmc::Board for StallingBoard {
    type Error = <ScriptedBoard as acc_pmc::Board>::Error;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        if self.reads == self.at {
            self.clock.advance(Duration::from_millis(350));
        }
        self.reads += 1;
        self.live.read_status()
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.live.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        self.live.write_control(c)
    }
}

#[test]
fn skipped_periods_still_get_their_flagged_rows() {
    let clock = ManualClock::new();
    let mut board = StallingBoard {
        live: LiveBoard(ScriptedBoard::new(), Vec::new()),
        clock: clock.clone(),
        at: 5,
        reads: 0,
    };
    let mut ctl = control();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(20),
        ..RunOptions::new(Duration::from_millis(100))
    };
    let s = run(&mut board, &mut ctl, clock.clone(), &mut sink, &stop, opts).expect("runs");
    // `max_periods` counts the periods of the clock: 18 cycles and the 2 skipped deadlines.
    assert_eq!(s.periods, 18, "cycles run");
    assert_eq!(s.skipped, 2, "deadlines skipped by the stall");
    assert_eq!(s.ticker.skipped, 2);
    let rows = &sink.0;
    assert_eq!(rows.len(), 20, "one row per period, skipped ones included");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.period, k as u64, "consecutive period indices");
    }
    let skipped: Vec<u64> = rows
        .iter()
        .filter(|r| r.has_flag("skipped"))
        .map(|r| r.period)
        .collect();
    assert_eq!(
        skipped,
        vec![6, 7],
        "the two deadlines that passed during the stall"
    );
    for r in rows.iter().filter(|r| r.has_flag("skipped")) {
        assert_eq!(r.override_cmd_pct, None, "nothing was written");
        assert_eq!(r.force_n, None, "nothing was read");
    }
    // The period after the stall came late and says so.
    assert!(rows[8].has_flag("late"), "{:?}", rows[8]);
    // Times stay on the T grid: the skipped rows sit at their own deadlines.
    for w in rows.windows(2) {
        assert!(
            (w[1].t_s - w[0].t_s - 0.1).abs() < 1e-9,
            "{} -> {}",
            w[0].t_s,
            w[1].t_s
        );
    }
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

/// A live board cutting at 1500 W (750 N with [`control()`]'s force source) that raises a
/// stop request at read `stop_at` (as a Ctrl-C would) and leaves the cut (10 W, 5 N) from
/// read `air_from` on.
struct CuttingBoard {
    live: LiveBoard,
    reads: usize,
    stop_at: usize,
    air_from: usize,
    stop: Arc<AtomicBool>,
}

impl acc_pmc::Board for CuttingBoard {
    type Error = <ScriptedBoard as acc_pmc::Board>::Error;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        if self.reads == self.stop_at {
            self.stop.store(true, Ordering::SeqCst);
        }
        let power = if self.reads >= self.air_from {
            10
        } else {
            1500
        };
        self.reads += 1;
        let b = &mut self.live.0;
        b.board.push_power_sample(power);
        b.now_ms += 100;
        b.read_status()
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.live.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        self.live.write_control(c)
    }
}

/// Run [`CuttingBoard`] with a drain of `max_s` (manual clock, T = 0.1 s) and 3 air periods.
fn drain_run(
    stop_at: usize,
    air_from: usize,
    max_s: f64,
    stop_now: bool,
) -> (acc_runtime::RunSummary, CuttingBoard, Vec<RunRecord>) {
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
    let mut board = CuttingBoard {
        live: LiveBoard(ScriptedBoard::new(), Vec::new()),
        reads: 0,
        stop_at,
        air_from,
        stop: Arc::clone(&stop),
    };
    let mut ctl = control().with_air_force_n(100.0);
    let mut sink = VecSink::default();
    let opts = RunOptions {
        max_periods: Some(500),
        drain: Some(acc_runtime::Drain {
            max: Duration::from_secs_f64(max_s),
            air_periods: 3,
        }),
        ..RunOptions::new(Duration::from_millis(100))
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
    (s, board, sink.0)
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
        .live
        .0
        .control_writes
        .last()
        .copied()
        .expect("control written");
    assert!(
        !last.acc_request && !last.feed_hold_request,
        "released without feed hold out of the cut: {last:?}"
    );
    assert!(board
        .live
        .0
        .control_writes
        .iter()
        .all(|c| !c.feed_hold_request));
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
    let w = &board.live.0.control_writes;
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
    let st = board.live.0.board.status();
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
    let last = board
        .live
        .0
        .control_writes
        .last()
        .copied()
        .expect("written");
    assert!(!last.acc_request && last.feed_hold_request, "{last:?}");
}

#[test]
fn a_stop_out_of_the_cut_releases_at_once() {
    let (s, board, _) = drain_run(10, 0, 10.0, false);
    assert_eq!(s.ended, acc_runtime::Ended::Released);
    assert_eq!(s.periods, 11);
    assert!(board
        .live
        .0
        .control_writes
        .iter()
        .all(|c| !c.feed_hold_request));
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

/// A link to a shared board whose device can vanish: while `dead`, every transaction
/// answers `Disconnected` (the board itself keeps running: its time advances). The device
/// vanishes at the read `die_at` (counted on the board, so it does not depend on thread
/// timing).
struct Vanishing {
    board: Arc<Mutex<(ScriptedBoard, bool)>>,
    reads: Arc<Mutex<u32>>,
    die_at: u32,
    /// Applied override and feed hold at every read that answered.
    seen: Arc<Mutex<Vec<(u16, bool)>>>,
}

impl acc_pmc::Board for Vanishing {
    type Error = acc_runtime::testing::ScriptedError;
    fn read_status(&mut self) -> Result<acc_pmc::BoardStatus, Self::Error> {
        let mut g = self.board.lock().expect("board");
        let (b, dead) = &mut *g;
        let mut reads = self.reads.lock().expect("reads");
        *reads += 1;
        if *reads == self.die_at {
            *dead = true;
        }
        b.board.push_power_sample(1500);
        b.now_ms += 100;
        if *dead {
            b.board.tick(b.now_ms);
            return Err(acc_runtime::testing::ScriptedError(
                acc_pmc::BoardErrorKind::Disconnected,
            ));
        }
        let s = b.read_status()?;
        self.seen
            .lock()
            .expect("seen")
            .push((s.override_applied_pct, s.feed_hold_active));
        Ok(s)
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        let mut g = self.board.lock().expect("board");
        if g.1 {
            return Err(acc_runtime::testing::ScriptedError(
                acc_pmc::BoardErrorKind::Disconnected,
            ));
        }
        g.0.write_override(o, hb)
    }
    fn write_control(&mut self, c: acc_pmc::ControlBits) -> Result<(), Self::Error> {
        let mut g = self.board.lock().expect("board");
        if g.1 {
            return Err(acc_runtime::testing::ScriptedError(
                acc_pmc::BoardErrorKind::Disconnected,
            ));
        }
        g.0.write_control(c)
    }
}

/// Run a board whose device vanishes after 20 periods and comes back at the `back_at`-th
/// reopen attempt (never with `None`), with `[runtime] on_device_lost = "reconnect"`.
fn reconnect_run(
    back_at: Option<u32>,
    timeout: Duration,
) -> (
    acc_runtime::RunSummary,
    Vec<RunRecord>,
    Vec<(u16, bool)>,
    ScriptedBoard,
    u32,
) {
    let shared = Arc::new(Mutex::new((ScriptedBoard::new(), false)));
    let seen = Arc::new(Mutex::new(Vec::new()));
    let reads = Arc::new(Mutex::new(0u32));
    let mut board = Vanishing {
        board: Arc::clone(&shared),
        reads: Arc::clone(&reads),
        die_at: 21,
        seen: Arc::clone(&seen),
    };
    let mut sink = VecSink::default();
    let mut attempts = 0u32;
    let mut reopen = || -> Result<Vanishing, String> {
        attempts += 1;
        if back_at.is_some_and(|n| attempts >= n) {
            shared.lock().expect("board").1 = false;
            Ok(Vanishing {
                board: Arc::clone(&shared),
                reads: Arc::clone(&reads),
                die_at: 0,
                seen: Arc::clone(&seen),
            })
        } else {
            Err("no such device".into())
        }
    };
    let opts = RunOptions {
        max_periods: Some(80),
        on_device_lost: acc_runtime::OnDeviceLost::Reconnect { timeout },
        ..RunOptions::new(Duration::from_millis(100))
    };
    let mut ctl = control();
    let stop = AtomicBool::new(false);
    let hooks = acc_runtime::Hooks {
        reopen: Some(&mut reopen),
        observer: None,
    };
    let s = acc_runtime::drive(
        &mut board,
        &mut ctl,
        ManualClock::new(),
        &mut sink,
        &stop,
        opts,
        hooks,
    )
    .expect("runs");
    let seen = seen.lock().expect("seen").clone();
    let b = shared.lock().expect("board").0.clone();
    (s, sink.0, seen, b, attempts)
}

#[test]
fn reconnect_rearms_at_the_last_command_and_logs_every_period() {
    // gone for 15 periods (past link_hold_periods = 5: the policy released and the board's
    // watchdog tripped), then the device is back
    let (s, rows, seen, b, attempts) = reconnect_run(Some(15), Duration::from_secs(10));
    assert_eq!(s.ended, acc_runtime::Ended::Completed);
    assert_eq!(s.reconnects, 1);
    assert_eq!(attempts, 15, "one reopen attempt per period while gone");
    assert_eq!(rows.len() as u64, s.periods, "a row every period");
    let gone = rows
        .iter()
        .filter(|r| r.has_flag("link:disconnected"))
        .count();
    assert_eq!(gone, 15);
    assert!(rows.iter().any(|r| r.has_flag("rearm:link_restored")));
    // the law had reached 70 %: never above it again, before, during or after the outage
    let first70 = seen.iter().position(|p| p.0 == 70).expect("reached 70");
    for (i, (pct, hold)) in seen.iter().enumerate().skip(first70) {
        assert!(*pct <= 70 || *hold, "read {i}: {pct} %");
    }
    // driving again after the re-arm: at 70 %, the feed hold of the watchdog trip cleared
    assert!(seen.iter().rev().take(10).all(|p| *p == (70, false)));
    assert!(!b.board.status().watchdog_tripped);
    assert_eq!(s.final_state, AccState::Active);
    assert!(s.longest_device_loss >= Duration::from_millis(1400));
}

#[test]
fn reconnect_gives_up_after_the_timeout() {
    let (s, rows, _, _, attempts) = reconnect_run(None, Duration::from_secs(1));
    assert_eq!(s.ended, acc_runtime::Ended::DeviceLost);
    assert_eq!(rows.len() as u64, s.periods, "a row every period");
    let gone = rows
        .iter()
        .rev()
        .take_while(|r| r.has_flag("link:disconnected"))
        .count();
    assert_eq!(
        gone, 11,
        "1 s at T = 0.1 s after the first period without it"
    );
    assert!(attempts >= 10);
    assert!(s.longest_device_loss >= Duration::from_secs(1));
}
