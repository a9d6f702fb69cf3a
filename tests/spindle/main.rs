//! The spindle force estimate: closed loop, fusion, garbage input, real data, the sweep.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/real_data.rs"]
mod real_data;

mod closed_loop;
mod fusion;
mod garbage;
mod real_datasets;
mod sweep;
