//! The LinuxCNC link: [`acc_linuxcnc::HalBoard`] against a fake pin backend, and
//! [`acc_linuxcnc::HalPins`] on LinuxCNC's own HAL, driven by `halcmd`.

mod hal_board;
mod hal_pins;
