//! acc-core's public API: the controller, its quantizers and hysteresis, the command
//! bounds, pole placement, sigma-delta, and no allocation on the period's path.
//!
//! One module per test file.

mod common;
// A GlobalAlloc impl is `unsafe` by definition; it only forwards to the system allocator.
#[allow(unsafe_code)]
mod counting_alloc;

mod command_bounds;
mod controller;
mod no_alloc;
mod override_hysteresis;
mod pole_regression;
mod sigma_delta;
mod spindle_no_alloc;
