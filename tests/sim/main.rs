//! The simulated machine: scenarios, programs, motor and sensor effects, tooth forces,
//! wear, the paced run, config errors, the simulated board through the `Board` trait; one clock
//! and one plant in the source tree.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;

mod board;
mod board_power;
mod compare;
mod config_errors;
mod motor_effects;
mod one_clock_one_plant;
mod paced;
mod program;
mod runtime_sim_loop;
mod scenarios;
mod spindle_scenario;
mod tooth;
mod wear;
