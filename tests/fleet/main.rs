//! The fleet store: `acc sim --fleet` and `acc collect` from a real broker, read by
//! the embedded DataFusion and by engines we did not write.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;
#[path = "../support/fleet.rs"]
mod fleet_support;
#[path = "../support/mqtt.rs"]
mod mqtt_support;

mod collect;
mod store;
