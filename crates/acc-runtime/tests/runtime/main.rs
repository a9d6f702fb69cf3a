//! The runtime through its public API: the runner's threads, the fault policy and the
//! operator, command limits, configs, skipped periods, tool changes, the watch.
//!
//! One module per test file.

mod common;
// A GlobalAlloc impl is `unsafe` by definition; it only forwards to the system allocator.
#[allow(unsafe_code)]
#[path = "../../../acc-core/tests/control/counting_alloc.rs"]
mod counting_alloc;

mod command_limits;
mod config;
mod policy;
mod policy_operator;
mod runner;
mod skipped_period;
mod tool_change;
mod watch_no_alloc;
