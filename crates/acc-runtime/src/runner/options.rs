//! What a run is asked to do: the period, when it ends, the log's buffer, the drain of a
//! stop and what a vanished device does ([`RunOptions`]), and how the caller asks it to stop
//! ([`StopRequest`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

#[cfg(doc)]
use super::{drive, run, ControlLoop, Ended};

/// Options of [`run`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOptions {
    /// Control period T.
    pub period: Duration,
    /// Stop after this many periods of the clock (`None`: until the stop flag): the cycles
    /// run plus the periods the ticker skipped, so that a run on a loaded host ends at the
    /// same machine time (the first period at or past it).
    pub max_periods: Option<u64>,
    /// Records the logger may fall behind before the loop holds the feed (the logger's
    /// queue plus the control thread's backlog; default 6000, ten minutes at T = 0.1 s).
    /// Records beyond it are kept too (see the module docs): none is dropped.
    pub log_buffer: usize,
    /// Attempts of the final `CONTROL` write at shutdown (default 5).
    pub shutdown_attempts: u32,
    /// Machine seconds per wall second (default 1): the run log's `t_s` is machine time.
    pub time_scale: f64,
    /// Fr to log in periods where the law was not stepped, N (default `None`).
    pub force_ref_n: Option<f64>,
    /// Drain on a stop request (default `None`: release at once). With a drain, a stop
    /// request while ACC drives the override keeps the loop running until the cut has ended
    /// ([`Drain::air_periods`] in a row out of the cut, see [`ControlLoop::air_periods`]), at
    /// most [`Drain::max`]; still cutting then, or on a second request, it requests feed hold
    /// and then releases ([`Ended::FeedHold`]). `max_periods` ends without a drain.
    pub drain: Option<Drain>,
    /// End the run after this many consecutive periods in which the link reported the
    /// device gone (`BoardErrorKind::Disconnected`: the port or bus vanished), default 20
    /// (`None`: never). The policy has released by then (after `link_hold_periods`); the run
    /// ends with [`Ended::DeviceLost`] instead of logging "disconnected" forever. Used with
    /// [`OnDeviceLost::Exit`].
    pub device_lost_periods: Option<u32>,
    /// What a vanished device does (default [`OnDeviceLost::Exit`]).
    pub on_device_lost: OnDeviceLost,
}

/// What the runner does when the board's device vanishes (`[runtime] on_device_lost`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OnDeviceLost {
    /// End the run after [`RunOptions::device_lost_periods`] ([`Ended::DeviceLost`]).
    #[default]
    Exit,
    /// Keep a row every period (flagged `link:disconnected`) and try to reopen the link
    /// every period (the callback of [`drive`]); after `timeout` (clock time)
    /// without the device, end as [`OnDeviceLost::Exit`] does.
    Reconnect {
        /// Longest time without the device.
        timeout: Duration,
    },
}

/// The shutdown drain (`[shutdown]` of the run config).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drain {
    /// Longest drain, in the clock's (wall) time.
    pub max: Duration,
    /// Consecutive periods out of the cut that end the drain (≥ 1).
    pub air_periods: u32,
}

/// How the caller asks a run to stop: a plain flag (`AtomicBool`, a stop request) or the
/// process's signals ([`crate::shutdown::StopSignals`]: the first signal drains, a second
/// stops now).
pub trait StopRequest: Sync {
    /// A stop was requested (drain first, when the run has a [`Drain`]).
    fn stop_requested(&self) -> bool;
    /// Stop now, without waiting for the cut to end.
    fn stop_now(&self) -> bool {
        false
    }
}

impl StopRequest for AtomicBool {
    fn stop_requested(&self) -> bool {
        self.load(Ordering::SeqCst)
    }
}

impl StopRequest for crate::shutdown::StopSignals {
    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
    fn stop_now(&self) -> bool {
        self.again.load(Ordering::SeqCst)
    }
}

impl RunOptions {
    /// Options with period `period` and defaults otherwise.
    pub fn new(period: Duration) -> Self {
        Self {
            period,
            max_periods: None,
            log_buffer: 6000,
            shutdown_attempts: 5,
            time_scale: 1.0,
            force_ref_n: None,
            drain: None,
            device_lost_periods: Some(20),
            on_device_lost: OnDeviceLost::Exit,
        }
    }
}
