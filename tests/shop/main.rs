//! The shop: entry, tools, the wear and breakage watch, override resolution, what-if replay.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;
#[path = "../support/real_data.rs"]
mod real_data;

mod entry;
mod override_resolution;
mod tools;
mod watch_breakage;
mod watch_history;
mod watch_real_wear;
mod whatif_replay;
