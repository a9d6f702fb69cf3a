//! End to end through the `acc` binary over real ptys: `acc run` against `acc board-sim`,
//! the pymodbus stand-in and the protocol peers; bad configs, faults, reconnects, shutdown.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;

mod bad_config;
mod board_sim_v2;
mod closed_loop;
mod fault_matrix;
mod faults;
mod interop_pymodbus;
mod override_step;
mod peer_mitm_proxy;
mod plan_production;
mod pmc_interop;
mod protocol;
mod reconnect;
mod shutdown;
mod tool_table;
mod twin_production;
mod watch_live;
