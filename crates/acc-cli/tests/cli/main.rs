//! The `acc` binary end to end where only the binary can be tested: `acc nc` on our programs
//! and on bad ones, the Debian package, and `acc linuxcnc` on headless LinuxCNC from the
//! installed package.
//!
//! One module per command.

mod linuxcnc;
mod linuxcnc_twin;
mod nc;
mod package;
