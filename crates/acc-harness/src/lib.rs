//! `acc-harness`: the reliability harness of `acc`, behind `acc fault-matrix` and `acc soak`.
//!
//! Both commands start the running `acc` binary as child processes, `acc board-sim` serving
//! the simulated machine on a pty and `acc run` driving it, bring faults about (board
//! faults, signals, a man in the middle on the serial line), and judge each run from both
//! run logs:
//!
//! - [`fault_matrix`]: every fault of the reliability table at the deepest cut of paper
//!   case III, on a v2 and a v1 board, one row each (`fault-matrix.md`, `.json`);
//! - [`soak`]: an hour of machine time (by default) with a random board fault every few
//!   seconds: memory growth, lost rows, dead threads (`soak.md`, `.json`, plots).
//!
//! The parts they share: the child processes ([`child`]), the man in the middle and its
//! files ([`proxy`]), the proxy's reads matched to `acc run`'s rows and the reads it must
//! flag ([`read_match`]), and the never-raise invariant ([`invariant`]). The harness writes
//! only into its `--out` folder; the tables in `docs/reliability.md` are spliced in by the
//! development tool (`cargo run -p xtask -- fault-matrix-doc`, `soak-doc`).
#![deny(missing_docs)]

pub mod child;
pub mod fault_matrix;
pub mod invariant;
pub mod proxy;
pub mod read_match;
pub mod soak;
