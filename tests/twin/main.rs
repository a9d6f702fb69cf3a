//! The model-discrepancy workflow and the twin: hidden-effect recovery, null logs and
//! pairs, real data, the `acc discrepancy` round trip, where a log's tool started, the
//! twin's library, replay and evaluation.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;
#[path = "../support/ident.rs"]
mod ident_common;
#[path = "../support/real_data.rs"]
mod real_data;

mod dead_rows;
mod eval;
mod extra_names;
mod ident_cli_roundtrip;
mod ident_null_and_pairs;
mod ident_real_data;
mod ident_recovery_dynamics;
mod ident_recovery_process;
mod ident_sim_and_files;
mod ident_unexplained;
mod library;
mod path_start;
mod program_visits;
mod replay;
mod spindle_calibration;
