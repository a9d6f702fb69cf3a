//! A stalled run-log writer: the loop keeps every record, holds the feed, loses no row.

use super::*;

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
        log_buffer: BUFFER,
        ..options(PERIODS)
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
