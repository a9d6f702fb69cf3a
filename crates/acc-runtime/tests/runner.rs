//! The threaded runtime on a manual clock: every period logged, orderly shutdown on the stop
//! flag, and a logger that is too slow never blocks control (drops are counted).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use acc_runtime::policy::{AccState, FaultPolicy, PolicyConfig};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedLaw};
use acc_runtime::{run, Clock, ControlLoop, LogSink, ManualClock, RunOptions, RunRecord, VecSink};

/// Run `pmc` with [`control()`] on a fresh manual clock, T = 0.1 s, at most `max` periods.
fn run_manual<P: acc_pmc::Board + Send, S: LogSink + Send>(
    pmc: &mut P,
    ctl: &mut ControlLoop<ScriptedLaw, LinearPowerForce>,
    sink: &mut S,
    stop: &AtomicBool,
    max: u64,
) -> acc_runtime::RunSummary {
    let opts = RunOptions {
        max_periods: Some(max),
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
        assert_eq!(r.cycle.index, k as u64);
        assert!((r.cycle.t_s - 0.1 * (k + 1) as f64).abs() < 1e-9);
    }
    assert_eq!(s.final_state, AccState::Active);
    assert_eq!(
        board.0.board.status().override_applied_pct,
        100,
        "operator's"
    );
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
        self.rows.push(*rec);
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
struct SlowSink(u64);

impl LogSink for SlowSink {
    type Error = std::convert::Infallible;
    fn write(&mut self, _: &RunRecord) -> Result<(), Self::Error> {
        std::thread::sleep(Duration::from_millis(2));
        self.0 += 1;
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

#[test]
fn a_slow_logger_never_blocks_control() {
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = control();
    let mut sink = SlowSink(0);
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(300),
        log_queue: 4,
        ..RunOptions::new(Duration::from_millis(100))
    };
    let s = run(
        &mut board,
        &mut ctl,
        ManualClock::new(),
        &mut sink,
        &stop,
        opts,
    )
    .expect("runs");
    assert_eq!(s.periods, 300, "control ran every period");
    assert!(s.log_dropped > 0, "full queue counted");
    assert_eq!(s.logged + s.log_dropped, 300);
    assert_eq!(sink.0, s.logged, "everything queued was written");
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
        sink.0.iter().all(|r| r.cycle.link.is_ok()),
        "every status pair arrived"
    );
    assert!(
        sink.0
            .iter()
            .any(|r| r.cycle.plan.override_and_heartbeat.map(|p| p.0) == Some(70)),
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

/// A law that stalls once for far longer than the period.
struct StallOnce {
    inner: ScriptedLaw,
    at: usize,
    steps: usize,
}

impl acc_core::OverrideLaw for StallOnce {
    fn name(&self) -> &str {
        "stall-once"
    }
    fn engage(&mut self, c: acc_core::FeedOverride) {
        self.inner.engage(c)
    }
    fn step(&mut self, m: &acc_core::Measurement) -> acc_core::StepOutput {
        self.steps += 1;
        if self.steps == self.at {
            std::thread::sleep(Duration::from_millis(60));
        }
        self.inner.step(m)
    }
    fn set_frozen(&mut self, f: bool) {
        self.inner.set_frozen(f)
    }
}

#[test]
fn a_late_control_decision_is_dropped_not_applied_a_period_late() {
    let mut board = LiveBoard(ScriptedBoard::new(), Vec::new());
    let mut ctl = ControlLoop::new(
        FaultPolicy::new(PolicyConfig::default()),
        StallOnce {
            inner: ScriptedLaw::new([90, 80, 70]),
            at: 5,
            steps: 0,
        },
        LinearPowerForce { n_per_w: 0.5 },
        0.1,
    );
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(20),
        // 5 ms of wall time to wait for a plan; the stalled step takes 60 ms
        ..RunOptions::new(Duration::from_millis(5))
    };
    let s = run(
        &mut board,
        &mut ctl,
        ManualClock::new(),
        &mut sink,
        &stop,
        opts,
    )
    .expect("runs");
    assert_eq!(s.periods, 20);
    let hb_at_read = &board.1;
    let mut skipped = 0;
    for (p, rec) in sink.0.iter().enumerate().take(19) {
        let Some((_, hb)) = rec.cycle.plan.override_and_heartbeat else {
            continue;
        };
        // the board shows this period's heartbeat at the next read, unless the plan was late
        if hb_at_read[p + 1] != hb {
            skipped += 1;
            assert!(
                hb_at_read[p + 1] < hb,
                "period {p}: an older plan was applied late"
            );
            assert!((4..8).contains(&p), "period {p}: only around the stall");
        }
    }
    // The stalled decision (and the one queued behind it) missed their periods and were
    // dropped; afterwards every period's plan is applied in its own period again.
    assert!((1..=3).contains(&skipped), "dropped plans: {skipped}");
}
