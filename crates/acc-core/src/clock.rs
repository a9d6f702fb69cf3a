//! Injected time, the one clock of the workspace: a [`Clock`] trait with a [`SystemClock`]
//! (monotonic, real sleeps), a [`ScaledClock`] (machine time on a faster wall clock) and a
//! [`ManualClock`] (the stepped clock: per instance, advanced by the caller or jumped to a
//! deadline). Re-exported as `acc_pmc::clock` and `acc_runtime::{Clock, ManualClock,
//! SystemClock}`.
//!
//! Users: the runtime's period driver and ticker; the links' deadlines (`acc_pmc`'s RTU and
//! CAN boards); the board emulators' watchdog time and tickers; the simulated machine behind
//! `acc sim` and `acc board-sim`. Nothing outside this module calls `Instant::now()` or
//! `sleep` (clippy's `disallowed-methods`, `clippy.toml`, enforces it; the telemetry servers
//! and the fault harness are the documented exceptions), so a simulation on a
//! [`ManualClock`] runs as fast as the CPU allows and is deterministic (copper-rs habit: the
//! mock clock is handed out per instance, never a global).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A monotonic time source that can block until an absolute deadline.
pub trait Clock: Send + Sync + std::fmt::Debug {
    /// Time elapsed since this clock's origin (monotonic, never goes back).
    fn now(&self) -> Duration;
    /// Block until `now() >= deadline` (absolute, since the clock's origin). Returns at once
    /// if the deadline has passed. A manual clock jumps to the deadline instead of waiting.
    fn sleep_until(&self, deadline: Duration);
    /// Time moves only when the owner steps it ([`ManualClock`]): a wait for another thread
    /// costs no clock time, so the period driver waits on it without a wall-time bound
    /// while the period still has clock time left (default `false`).
    fn is_stepped(&self) -> bool {
        false
    }
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now(&self) -> Duration {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Duration) {
        (**self).sleep_until(deadline)
    }
    fn is_stepped(&self) -> bool {
        (**self).is_stepped()
    }
}

impl<C: Clock + ?Sized> Clock for Arc<C> {
    fn now(&self) -> Duration {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Duration) {
        (**self).sleep_until(deadline)
    }
    fn is_stepped(&self) -> bool {
        (**self).is_stepped()
    }
}

/// The real monotonic clock (`std::time::Instant`), origin at construction.
///
/// `sleep_until` sleeps with `std::thread::sleep` until `deadline − spin`, then busy-waits the
/// last `spin` (default 0: no busy-wait; on a shared 2-core machine spinning costs the other
/// threads more than the kernel's timer slack costs us).
#[derive(Debug, Clone, Copy)]
pub struct SystemClock {
    origin: Instant,
    spin: Duration,
}

impl Default for SystemClock {
    fn default() -> Self {
        Self::new()
    }
}

impl SystemClock {
    /// A clock whose origin is now, without busy-waiting.
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
            spin: Duration::ZERO,
        }
    }

    /// Busy-wait the last `spin` before each deadline (trades CPU for lower jitter).
    pub fn with_spin(mut self, spin: Duration) -> Self {
        self.spin = spin;
        self
    }
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn sleep_until(&self, deadline: Duration) {
        loop {
            let now = self.now();
            if now >= deadline {
                return;
            }
            let left = deadline - now;
            if left > self.spin {
                std::thread::sleep(left - self.spin);
            } else {
                std::hint::spin_loop();
            }
        }
    }
}

/// Machine time on a faster-than-real-time wall clock: `now()` is the inner clock's time
/// multiplied by `scale`, and `sleep_until(deadline)` waits until `deadline / scale` on the
/// inner clock. `acc board-sim --time-scale 10` runs the board's watchdog on it, so that
/// `WATCHDOG_MS` = 500 means 500 ms of machine time, as on the real machine.
///
/// ```
/// use acc_core::clock::{Clock, ManualClock, ScaledClock};
/// use std::time::Duration;
/// let wall = ManualClock::new();
/// let machine = ScaledClock::new(wall.clone(), 10.0).unwrap();
/// wall.advance(Duration::from_millis(50));
/// assert_eq!(machine.now(), Duration::from_millis(500));
/// machine.sleep_until(Duration::from_secs(1));
/// assert_eq!(wall.now(), Duration::from_millis(100));
/// assert!(ScaledClock::new(wall, 0.0).is_none());
/// ```
#[derive(Debug, Clone)]
pub struct ScaledClock<C: Clock> {
    inner: C,
    scale: f64,
}

impl<C: Clock> ScaledClock<C> {
    /// `scale` machine seconds per inner second (finite, > 0); `None` otherwise.
    pub fn new(inner: C, scale: f64) -> Option<Self> {
        (scale.is_finite() && scale > 0.0).then_some(Self { inner, scale })
    }
}

impl<C: Clock> Clock for ScaledClock<C> {
    fn now(&self) -> Duration {
        self.inner.now().mul_f64(self.scale)
    }

    fn sleep_until(&self, deadline: Duration) {
        self.inner.sleep_until(deadline.div_f64(self.scale));
    }

    fn is_stepped(&self) -> bool {
        self.inner.is_stepped()
    }
}

/// A manual clock: time moves only when the owner advances it, or when a sleeper asks for a
/// later deadline (`sleep_until` jumps to it). Clones share the same time; separate
/// `ManualClock::new()` instances are independent.
///
/// ```
/// use acc_core::clock::{Clock, ManualClock};
/// use std::time::Duration;
/// let clock = ManualClock::new();
/// let other = ManualClock::new();
/// clock.advance(Duration::from_millis(30));
/// clock.sleep_until(Duration::from_millis(100));
/// assert_eq!(clock.now(), Duration::from_millis(100));
/// assert_eq!(other.now(), Duration::ZERO); // per instance, not global
/// ```
#[derive(Debug, Clone, Default)]
pub struct ManualClock {
    nanos: Arc<AtomicU64>,
}

impl ManualClock {
    /// A clock at t = 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Move time forward by `d` (e.g. to model the duration of work inside a period).
    pub fn advance(&self, d: Duration) {
        self.nanos.fetch_add(to_nanos(d), Ordering::SeqCst);
    }

    /// Set the time to `t` if `t` is later than now (time never goes back).
    pub fn set(&self, t: Duration) {
        self.nanos.fetch_max(to_nanos(t), Ordering::SeqCst);
    }
}

fn to_nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

impl Clock for ManualClock {
    fn now(&self) -> Duration {
        Duration::from_nanos(self.nanos.load(Ordering::SeqCst))
    }

    fn sleep_until(&self, deadline: Duration) {
        self.set(deadline);
    }

    fn is_stepped(&self) -> bool {
        true
    }
}

/// The stepped clock paced from outside: like a [`ManualClock`], time moves only when a
/// sleeper asks for a later deadline, but never past what the owner has allowed
/// ([`GatedClock::allow`]); a sleeper waits (in wall time) until it is allowed. `acc sim
/// --step-stdin` runs on it so that an end-to-end test decides how far the simulated run
/// may go, instead of racing a wall-clock run.
///
/// ```
/// use acc_core::clock::{Clock, GatedClock};
/// use std::time::Duration;
/// let clock = GatedClock::new();
/// clock.allow(Duration::from_millis(300));
/// clock.sleep_until(Duration::from_millis(200));
/// assert_eq!(clock.now(), Duration::from_millis(200));
/// let c = clock.clone();
/// let t = std::thread::spawn(move || c.sleep_until(Duration::from_millis(500)));
/// clock.allow(Duration::from_millis(500));
/// t.join().unwrap();
/// assert_eq!(clock.now(), Duration::from_millis(500));
/// ```
#[derive(Debug, Clone, Default)]
pub struct GatedClock {
    time: ManualClock,
    allowed: Arc<(std::sync::Mutex<Duration>, std::sync::Condvar)>,
}

impl GatedClock {
    /// A clock at t = 0 that may not move yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Let the clock go up to `t` (never back: a smaller `t` than allowed so far is ignored).
    pub fn allow(&self, t: Duration) {
        let (lock, cv) = &*self.allowed;
        let mut a = lock
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        *a = (*a).max(t);
        cv.notify_all();
    }

    /// How far the clock may go.
    pub fn allowed(&self) -> Duration {
        *self
            .allowed
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl Clock for GatedClock {
    fn now(&self) -> Duration {
        self.time.now()
    }

    fn sleep_until(&self, deadline: Duration) {
        let (lock, cv) = &*self.allowed;
        let mut a = lock
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        while *a < deadline {
            a = cv
                .wait(a)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        drop(a);
        self.time.set(deadline);
    }

    fn is_stepped(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_clock_never_goes_back() {
        let c = ManualClock::new();
        c.set(Duration::from_secs(5));
        c.set(Duration::from_secs(1));
        assert_eq!(c.now(), Duration::from_secs(5));
        c.sleep_until(Duration::from_secs(2));
        assert_eq!(c.now(), Duration::from_secs(5));
    }

    #[test]
    fn manual_clock_clones_share_time() {
        let a = ManualClock::new();
        let b = a.clone();
        a.advance(Duration::from_millis(7));
        assert_eq!(b.now(), Duration::from_millis(7));
    }

    #[test]
    fn system_clock_sleeps_at_least_to_deadline() {
        let c = SystemClock::new();
        let deadline = c.now() + Duration::from_millis(2);
        c.sleep_until(deadline);
        assert!(c.now() >= deadline);
    }
}
