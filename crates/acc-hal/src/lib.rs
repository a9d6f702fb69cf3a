//! `acc-hal`: acc as a LinuxCNC userspace HAL component — a safe binding to the few HAL
//! functions a userspace component calls (`hal_init`, `hal_malloc`, `hal_pin_*_new`,
//! `hal_ready`, `hal_exit`; `/usr/include/linuxcnc/hal.h`).
//!
//! This is the workspace's only crate with `unsafe` code; every block states the invariant
//! it relies on. LinuxCNC is not needed to build or link anything: the HAL library
//! (`liblinuxcnchal.so.0`, Debian `linuxcnc-uspace`) is opened at run time, and without it
//! [`HalComponent::new`] answers [`HalError::LibraryMissing`].
//!
//! | module | what |
//! | --- | --- |
//! | [`HalComponent`] | one component: name, typed pins, [`ready`](HalComponent::ready), `hal_exit` on drop |
//! | pins | [`FloatIn`], [`FloatOut`], [`BitIn`], [`BitOut`], [`S32In`], [`S32Out`] with `get` / `set`; [`HalPin::name`] |
//! | [`HalError`] | library absent, HAL unavailable, name clashes, order, memory |
//! | [`probe_library`] | whether LinuxCNC's HAL library opens here |
//!
//! A component as `loadusr -Wn acc-demo …` starts one (`no_run`: it registers with the
//! HAL of the machine it runs on):
//!
//! ```no_run
//! use acc_hal::{HalComponent, HalError};
//! let comp = HalComponent::new("acc-demo")?;
//! let power_w = comp.float_in("spindle-power")?;
//! let mut adaptive_feed = comp.float_out("adaptive-feed")?;
//! comp.ready()?;
//! adaptive_feed.set(0.5 * power_w.get() / 4_000.0);
//! # Ok::<(), HalError>(())
//! ```
#![allow(unsafe_code)]
#![cfg_attr(test, allow(clippy::unwrap_used))]

mod component;
mod error;
mod library;
mod pin;

pub use component::{HalComponent, HAL_NAME_LEN};
pub use error::HalError;
pub use library::{probe_library, DEFAULT_LIBRARY, LIBRARY_ENV};
pub use pin::{BitIn, BitOut, FloatIn, FloatOut, HalPin, S32In, S32Out};
