//! The paper's cases reproduced, the runs deterministic, every shipped config and controller
//! preset loads.
//!
//! One module per test file; shared helpers in `tests/support/`.

mod cases;
mod configs_load;
mod determinism;
mod fixed_gain;
mod presets;
