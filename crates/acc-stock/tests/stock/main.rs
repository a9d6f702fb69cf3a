//! The Z-map stock through its public API: ball nose, corners and re-entry, files,
//! properties, slots and side cuts, removed volume.
//!
//! One module per test file.

mod common;

mod ball_nose;
mod corners_and_reentry;
mod files;
mod props;
mod slot_and_side;
mod volume;
