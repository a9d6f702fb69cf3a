//! The scheduled faults (`--fault KIND@T[:ARG]`): started when machine time reaches their
//! `T`, and ended when their duration has passed.

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::PoisonError;

use acc_pmc::emu::{lock_board, SharedBoard};
use acc_sim::board::{PowerFault, SimBoard};

use super::faults::Scheduled;
use super::serve::{LineFaults, Served};

/// The faults in force and when each ends (machine time, s).
pub(super) struct InForce {
    schedule: VecDeque<(f64, Scheduled)>,
    freeze_until: f64,
    bad_until: f64,
    lock_until: Option<f64>,
    replug_at: Option<f64>,
    hard_until: Option<f64>,
}

impl InForce {
    /// Nothing in force yet; `schedule` sorted by time.
    pub(super) fn new(schedule: VecDeque<(f64, Scheduled)>) -> Self {
        InForce {
            schedule,
            freeze_until: f64::NEG_INFINITY,
            bad_until: f64::NEG_INFINITY,
            lock_until: None,
            replug_at: None,
            hard_until: None,
        }
    }

    /// Start every fault due at machine time `t` (s), and plug a pulled cable back in when
    /// its time is up.
    pub(super) fn start_due(
        &mut self,
        t: f64,
        board: &SharedBoard,
        line: &LineFaults,
        served: &mut Served,
        sim: &mut SimBoard,
    ) -> anyhow::Result<()> {
        while self.schedule.front().is_some_and(|(at, _)| *at <= t) {
            let Some((at, f)) = self.schedule.pop_front() else {
                break;
            };
            eprintln!("board-sim: t = {t:.1} s: fault {f:?} (scheduled at {at} s)");
            self.start(f, t, board, line, served, sim)?;
        }
        if self.replug_at.is_some_and(|u| t >= u) {
            line.unplugged.store(false, Ordering::SeqCst);
            self.replug_at = None;
            eprintln!("board-sim: t = {t:.1} s: cable plugged back in");
        }
        Ok(())
    }

    fn start(
        &mut self,
        f: Scheduled,
        t: f64,
        board: &SharedBoard,
        line: &LineFaults,
        served: &mut Served,
        sim: &mut SimBoard,
    ) -> anyhow::Result<()> {
        match f {
            Scheduled::Replies(kind, n) => line
                .queue
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .extend(std::iter::repeat_n(kind, n)),
            Scheduled::Restart => lock_board(board).power_cycle(),
            Scheduled::FreezeSeq(s) => self.freeze_until = t + s,
            Scheduled::BadPower(s) => self.bad_until = t + s,
            Scheduled::Lock(s) => {
                lock_board(board).set_override_locked(true);
                self.lock_until = Some(t + s);
            }
            Scheduled::Switch(on) => lock_board(board).set_acc_switch(on),
            Scheduled::Operator(p) => lock_board(board).set_operator_override_pct(p),
            Scheduled::Unplug(s) => {
                line.unplugged.store(true, Ordering::SeqCst);
                self.replug_at = s.map(|s| t + s);
            }
            Scheduled::Vanish => served.vanish(t)?,
            Scheduled::Hard(secs, factor) => {
                sim.machine_mut().set_hardness_factor(factor);
                self.hard_until = Some(t + secs);
            }
        }
        Ok(())
    }

    /// End the hard spot and the override lock whose time is up at `t`, and set the power
    /// register's fault for the period (garbage before frozen).
    pub(super) fn end_due(&mut self, t: f64, board: &SharedBoard, sim: &mut SimBoard) {
        if self.hard_until.is_some_and(|u| t >= u) {
            sim.machine_mut().set_hardness_factor(1.0);
            self.hard_until = None;
        }
        if self.lock_until.is_some_and(|u| t >= u) {
            lock_board(board).set_override_locked(false);
            self.lock_until = None;
        }
        sim.set_power_fault(if t < self.bad_until {
            Some(PowerFault::Garbage)
        } else if t < self.freeze_until {
            Some(PowerFault::FrozenSeq)
        } else {
            None
        });
    }
}
