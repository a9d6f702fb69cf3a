//! A vanished device that comes back (`on_device_lost = "reconnect"`): re-armed at the last
//! command with every period logged, or given up after the timeout.

use super::*;

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
        on_device_lost: acc_runtime::OnDeviceLost::Reconnect { timeout },
        ..options(80)
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
