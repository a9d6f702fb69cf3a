//! The NC interpreter through its public API: errors, no panic on any input, the
//! tool path of the shipped programs, and LinuxCNC's rs274 as an oracle.
//!
//! One module per test file.

mod errors;
mod no_panic;
mod oracle_rs274;
mod path;
