//! `acc-linuxcnc`: acc's board link to LinuxCNC. [`HalBoard`] implements acc's
//! [`Board`](acc_pmc::Board) over the pins of a HAL component (`acc-hal`), so the same
//! control loop, fault policy and run log drive LinuxCNC's `motion.adaptive-feed`.
//!
//! | module | what |
//! | --- | --- |
//! | [`mapping`] | the law's 0–150 % onto the pin's [0, 1]: `adaptive = override / 150 %` with the machine at a 150 % feed override; rapids never slowed |
//! | [`HalBoard`] | the [`Board`](acc_pmc::Board): status from the machine's pins, override and control to the adaptive feed, heartbeat and state pins; a v2 board's fallback clamp |
//! | [`MachineInputs`], [`AccOutputs`], [`PinBackend`], [`HalPins`] | the pins of one period, and what moves them (HAL, or a test's fake) |
//! | [`machine_log`] | the simulated process's machine log (`machine.csv`) read: one reader for `acc linuxcnc` and the fault matrix |
//!
//! `acc run --hal` loads this link; `configs/linuxcnc/acc.hal` nets its pins and puts
//! LinuxCNC's realtime `watchdog` on `acc.heartbeat-bit` (docs/linuxcnc.md).
//!
//! ```
//! use acc_linuxcnc::{AccOutputs, HalBoard, MachineInputs, PinBackend};
//! use acc_pmc::{Board, ControlBits};
//! struct Fake(MachineInputs, AccOutputs);
//! impl PinBackend for Fake {
//!     fn read(&mut self) -> MachineInputs { self.0 }
//!     fn write(&mut self, outputs: &AccOutputs) { self.1 = *outputs; }
//! }
//! let machine = MachineInputs {
//!     feed_override: 1.5, machine_on: true, program_running: true,
//!     adaptive_enabled: true, acc_switch: true, watchdog_ok: true, motion_type: 2,
//!     ..Default::default()
//! };
//! let mut board = HalBoard::new(Fake(machine, AccOutputs::default()));
//! board.write_control(ControlBits { acc_request: true, ..Default::default() })?;
//! board.read_status()?;
//! board.write_override(120, 1)?;
//! assert_eq!(board.pins().1.adaptive_feed, 0.8); // 120 % / 150 %
//! assert_eq!(board.read_status()?.override_applied_pct, 120);
//! # Ok::<(), acc_linuxcnc::HalBoardError>(())
//! ```

mod board;
pub mod cycle;
pub mod halsampler;
pub mod machine_log;
pub mod mapping;
mod pins;

pub use board::{HalBoard, HalBoardError, MIN_BEAT_SPACING};
pub use pins::{AccOutputs, HalPins, MachineInputs, PinBackend};
