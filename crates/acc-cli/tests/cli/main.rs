//! The `acc` binary end to end where only the binary can be tested: `acc nc` on our programs
//! and on bad ones, and `acc linuxcnc` on headless LinuxCNC.
//!
//! One module per command.

mod linuxcnc;
mod linuxcnc_twin;
mod nc;
