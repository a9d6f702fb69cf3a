//! End to end through the `acc` binary over real ptys: `acc run` against `acc board-sim`,
//! the pymodbus stand-in and the protocol peers; bad configs, faults, reconnects, shutdown.
//!
//! One module per test file; shared helpers in `tests/support/`.
//!
//! libtest starts the tests in the order of their names, two at a time on 2 cores. The
//! wall-paced loops (`fault_matrix`, `pymodbus_standin`, `reconnect`, `scheduled_faults`,
//! one of `shutdown`, `soak`) hold [`e2e_support::one_at_a_time`]; their module names fall
//! between those of the tests that take no lock, so that the second test thread runs the
//! controller-paced loops and the CPU-bound replays while the first holds the lock, instead
//! of waiting for it.

#[path = "../support/e2e.rs"]
mod e2e_support;

mod bad_config;
mod board_sim_v2;
mod closed_loop;
mod fault_matrix;
mod override_step;
mod peer_mitm_proxy;
mod plan_production;
mod pmc_interop;
mod protocol;
mod pymodbus_standin;
mod reconnect;
mod scheduled_faults;
mod shutdown;
mod soak;
mod tool_table;
mod twin_demo;
mod twin_production;
mod watch_live;
