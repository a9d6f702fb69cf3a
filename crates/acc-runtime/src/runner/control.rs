//! The control thread: it owns the [`ControlLoop`] (policy, law, force source) and makes
//! the period's decision from the I/O thread's status, with no I/O of its own. Every period
//! it hands the writes back to the I/O thread and the [`RunRecord`] to the logger's
//! [`Backlog`] (`try_send`: it never waits on the logger).

use std::sync::atomic::Ordering;

use acc_core::{ForceSource, OverrideLaw};
use crossbeam_channel::{Receiver, Sender};

use crate::control_loop::{BoardWrites, ControlLoop, PeriodRecord};
use crate::log_backlog::Backlog;
use crate::policy::{AccState, Alarms};
use crate::record::RunRecord;

use super::io::StatusMsg;
#[cfg(doc)]
use super::Ended;
use super::{Flags, RunOptions};

/// The caller's view of every period, on the control thread, after the decision and before
/// the period's writes go to the board: its verdict takes effect before the next period,
/// whatever the threads' timing (the simulator's end conditions are deterministic).
pub trait PeriodObserver: Send {
    /// Annotate the period's record before it is logged (the simulator adds its plant's
    /// truth) and say whether the run ends after this period.
    fn period(&mut self, rec: &mut RunRecord) -> Verdict;
}

/// A [`PeriodObserver`]'s answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Go on.
    Continue,
    /// End the run after this period ([`Ended::Finished`]).
    Finish,
}

/// The control thread of one run: the loop, the caller's observer, the records on their
/// way to the logger and the run's time base.
pub(super) struct ControlThread<'a, 'o, L, F> {
    control: &'a mut ControlLoop<L, F>,
    observer: Option<&'o mut dyn PeriodObserver>,
    log: Backlog,
    flags: &'a Flags,
    /// The period T, s.
    tick_s: f64,
    /// Machine seconds per wall second ([`RunOptions::time_scale`]).
    time_scale: f64,
    /// Fr to log in periods where the law was not stepped, N.
    force_ref_n: Option<f64>,
    /// Consecutive periods out of the cut that end a stop's drain.
    air_needed: u32,
    /// Deadlines the ticker skipped (each has a flagged row).
    skipped: u64,
}

/// What the control thread counted, and the policy's state at its end (before the
/// shutdown write).
#[derive(Debug, Clone, Copy)]
pub(super) struct ControlTotals {
    /// Periods the ticker skipped.
    pub skipped: u64,
    /// Policy state at the end.
    pub final_state: AccState,
    /// Alarms at the end.
    pub alarms: Alarms,
}

/// What the control thread hands back when the I/O thread closes the status channel.
pub(super) struct ControlEnd<'a, L, F> {
    /// The records not yet handed to the logger.
    pub log: Backlog,
    /// The counts and the final state.
    pub totals: ControlTotals,
    /// The loop, for the shutdown write.
    pub control: &'a mut ControlLoop<L, F>,
}

impl<'a, 'o, L: OverrideLaw, F: ForceSource> ControlThread<'a, 'o, L, F> {
    /// The control thread of a run with `opts`, logging through `log`.
    pub(super) fn new(
        control: &'a mut ControlLoop<L, F>,
        observer: Option<&'o mut dyn PeriodObserver>,
        log: Backlog,
        opts: &RunOptions,
        flags: &'a Flags,
    ) -> Self {
        Self {
            control,
            observer,
            log,
            flags,
            tick_s: opts.period.as_secs_f64(),
            time_scale: opts.time_scale,
            force_ref_n: opts.force_ref_n,
            air_needed: opts.drain.map_or(1, |d| d.air_periods.max(1)),
            skipped: 0,
        }
    }

    /// The thread's body: one period per status until the I/O thread closes the channel
    /// (or stops taking the writes).
    pub(super) fn run(
        mut self,
        statuses: Receiver<StatusMsg>,
        writes: Sender<(u64, BoardWrites)>,
    ) -> ControlEnd<'a, L, F> {
        let _span = tracing::info_span!("control").entered();
        for msg in statuses.iter() {
            self.begin_period(&msg);
            let rec = self.control.decide(msg.t_s * self.time_scale, msg.link);
            self.tell_io_out_of_cut();
            let r = self.record(&rec, &msg);
            if writes.send((msg.seq, rec.writes)).is_err() {
                break;
            }
            self.log.offer(r);
        }
        ControlEnd {
            totals: ControlTotals {
                skipped: self.skipped,
                final_state: self.control.policy().state(),
                alarms: self.control.policy().alarms(),
            },
            log: self.log,
            control: self.control,
        }
    }

    /// Before the decision: the writer's state (stalled → no cut), a row for each deadline
    /// the ticker skipped, and what the I/O thread saw of the link (reopened, last writes,
    /// a late period).
    fn begin_period(&mut self, msg: &StatusMsg) {
        self.log.pump();
        self.control.set_log_stalled(self.log.stalled());
        self.skipped += msg.skipped;
        for k in 0..msg.skipped {
            let t = msg.t_s - (msg.skipped - k) as f64 * self.tick_s;
            self.log.offer(self.control.skip(t * self.time_scale));
        }
        if msg.reopened {
            self.control.link_reopened();
        }
        self.control.writes_done(&msg.writes);
        self.control.set_period_late(msg.overrun);
    }

    /// After the decision: whether a stop may end the run now (ACC not driving, or out of
    /// the cut for the drain's periods).
    fn tell_io_out_of_cut(&self) {
        self.flags.out_of_cut.store(
            self.control.policy().state() != AccState::Active
                || self.control.air_periods() >= self.air_needed,
            Ordering::SeqCst,
        );
    }

    /// The period's run-log row from the decision `rec`: the policy's events traced, the
    /// period's lateness, and the observer's annotations and verdict ([`Verdict::Finish`]
    /// ends the run after this period).
    fn record(&mut self, rec: &PeriodRecord, msg: &StatusMsg) -> RunRecord {
        for e in rec.out.events.iter() {
            tracing::info!(period = rec.index, event = ?e, "policy event");
        }
        let mut r = rec.record(self.force_ref_n);
        r.late_ms = msg.lateness.as_secs_f64() * 1e3;
        if msg.overrun {
            r.flag("late");
        }
        if let Some(o) = self.observer.as_deref_mut() {
            if o.period(&mut r) == Verdict::Finish {
                self.flags.finished.store(true, Ordering::SeqCst);
            }
        }
        r
    }
}
