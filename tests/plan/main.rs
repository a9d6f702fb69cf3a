//! The cutting plan: the follower, learning from logs, the look-ahead, the optimized
//! program and the oracle bounds.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;

mod controller_log;
mod follower;
mod learns;
mod lookahead;
mod optimize_program;
mod oracle_bound;
mod oracle_program;
