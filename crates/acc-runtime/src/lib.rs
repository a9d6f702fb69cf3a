//! `acc-runtime`: the fixed-period real-time loop of `acc`, its fault policy and operator
//! priority, the threads that join link I/O, control and logging, and shutdown.
//!
//! Layers (copper-rs habit: pure algorithm, thin runtime adapter):
//! - [`config`]: the typed, validated run config of `acc run`;
//! - [`clock`]: injected time ([`clock::SystemClock`], the stepped [`clock::ManualClock`]),
//!   re-exported from acc-core;
//! - [`ticker`]: absolute-deadline ticker with overrun counting and jitter statistics;
//! - [`stats`]: allocation-free latency histogram (p50 / p99 / max);
//! - [`policy`]: the fault policy and operator priority as a pure state machine;
//! - [`shop`]: the tool table per `TOOL_NUMBER` and entry/exit control (limits on the law's
//!   command);
//! - [`lookahead`]: the cutting plan ([`plan`], `plan.csv`) read by the loop: the cap on the
//!   command ahead of an engagement change, and the plan's lead that raises it to the
//!   engagement ahead while the plan and the measurement agree ([`plan_error`]: the plan's
//!   force error of a run log);
//! - [`control_loop`]: the control loop: one period against any `Board` (read, decide, write);
//! - [`record`]: the run log — one [`RunRecord`] per period, schema v4, older versions
//!   migrated;
//! - [`watch`]: wear and breakage watch (Kc trend, breakage detector the policy steps);
//! - [`cuts`]: per-cut records from a stream of run-log records;
//! - [`history`]: the tool history (SQLite) and the watch beside the loop;
//! - [`runner`]: the one period driver ([`drive`]: link I/O, control, logging on three
//!   threads, on any clock) and orderly shutdown; every record reaches the log;
//! - [`tap`]: fan-out of every period's record to telemetry subscribers (never blocks);
//! - [`shutdown`]: the Ctrl-C stop flag and the `tracing` subscriber (env filter, JSON);
//! - `testing` (feature `testing`, which enables acc-pmc's `emulator`): a scripted board,
//!   law and force source for tests.
#![deny(missing_docs)]

/// Injected time: the one [`Clock`] of the workspace lives in acc-core (the links'
/// deadlines, the emulators and the simulator use it too); re-exported here.
pub use acc_pmc::clock;
pub mod config;
pub mod control_loop;
pub mod cuts;
pub mod echo;
pub mod guard;
pub mod history;
mod log_backlog;
pub mod lookahead;
pub mod opcua_config;
pub mod policy;
pub mod record;
pub mod runner;
pub mod shop;
pub mod shutdown;
pub mod stats;
pub mod tap;
#[cfg(feature = "testing")]
pub mod testing;
pub mod ticker;
pub mod watch;

pub use clock::{Clock, ManualClock, SystemClock};
pub use control_loop::{BoardWrites, ControlLoop, PeriodRecord, WriteResult};
pub use lookahead::{plan, plan_error};
pub use lookahead::{LookAhead, LookAheadConfig, LookAheadInput, LookAheadStep};
pub use plan::{ForceProfile, Plan, PlanError, PlanRow};
pub use policy::{
    AccState, Alarms, CommandLimits, Event, FaultPolicy, PolicyConfig, PolicyInput, PolicyOutput,
    Rearm, Release,
};
pub use record::{RunLogWriter, RunRecord};
pub use runner::{
    drive, run, Drain, Ended, Hooks, LogSink, OnDeviceLost, PeriodObserver, Reopen, RunError,
    RunOptions, RunSummary, StopRequest, VecSink, Verdict,
};
pub use shop::{ShopControl, ShopDecision, ShopState, ToolChange};
pub use stats::LatencyStats;
pub use tap::{Subscriber, Tap, TapSink};
pub use ticker::{Tick, Ticker, TickerError, TickerStats};
