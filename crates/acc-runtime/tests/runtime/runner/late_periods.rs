//! Late periods: a decision that reaches the I/O thread a period late is dropped, and the
//! periods a slow link made the ticker skip still get their flagged rows.

use super::*;

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

#[test]
fn skipped_periods_still_get_their_flagged_rows() {
    // Read 5 answers 350 ms late (a slow link): the next tick comes 2.5 periods late, and
    // the ticker skips the two whole deadlines that passed meanwhile.
    let clock = ManualClock::new();
    let stalled = clock.clone();
    let mut board = HookedBoard::new(move |read| {
        if read == 5 {
            stalled.advance(Duration::from_millis(350));
        }
        1500
    });
    let mut ctl = control();
    let mut sink = VecSink::default();
    let stop = AtomicBool::new(false);
    let s = run(
        &mut board,
        &mut ctl,
        clock.clone(),
        &mut sink,
        &stop,
        options(20),
    )
    .expect("runs");
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
