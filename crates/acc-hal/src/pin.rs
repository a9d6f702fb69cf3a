//! Typed HAL pins. Each read or write goes through the pin's pointer in HAL shared memory,
//! re-read every time: `halcmd net` / `unlinkp` repoint it while the component runs.

use std::ffi::c_void;
use std::sync::Arc;

use crate::component::Registration;

/// The address of one pin's data pointer (`hal_<type>_t **` in hal.h), kept with the
/// component registration that keeps the memory mapped.
#[derive(Debug)]
pub(crate) struct PinSlot {
    /// The pin's data pointer, in HAL shared memory; HAL points it at the linked signal's
    /// value (or the pin's own dummy signal).
    slot: *mut *mut c_void,
    /// The pin's full name.
    name: String,
    /// Keeps the component registered, and HAL's memory mapped, while the pin exists.
    _owner: Arc<Registration>,
}

// SAFETY: the slot and the value it points at are HAL shared memory, written by other
// processes (halcmd, rtapi_app) at any time; HAL's contract is single aligned loads and
// stores of values no wider than 8 bytes, which are the same from any thread. The Arc keeps
// the mapping alive wherever the pin moves.
unsafe impl Send for PinSlot {}

impl PinSlot {
    /// Wraps a slot that `hal_pin_<type>_new` filled.
    ///
    /// # Safety
    /// `slot` must be the `data_ptr_addr` of a successfully created pin of `owner`, and
    /// callers read and write it only as that pin's HAL type (see [`read`](Self::read)).
    pub(crate) unsafe fn new(
        slot: *mut *mut c_void,
        name: String,
        owner: Arc<Registration>,
    ) -> Self {
        Self {
            slot,
            name,
            _owner: owner,
        }
    }

    /// The pin's current value as `T`, the Rust type of its HAL type (`f64` for float,
    /// `u8` for bit, `i32` for s32).
    fn read<T: Copy>(&self) -> T {
        // SAFETY: by `new`'s contract the slot is a live pin's data pointer, which HAL always
        // points at a value of the pin's type (a signal or the dummy), aligned for it; `T` is
        // that type's Rust equivalent. Volatile: other processes write both.
        unsafe {
            let value = std::ptr::read_volatile(self.slot).cast::<T>();
            std::ptr::read_volatile(value)
        }
    }

    /// Stores `value` (of the pin's HAL type, as in [`read`](Self::read)) in the pin's signal.
    fn write<T: Copy>(&mut self, value: T) {
        // SAFETY: as in `read`; the pin is this component's output, so HAL lets it write.
        unsafe {
            let target = std::ptr::read_volatile(self.slot).cast::<T>();
            std::ptr::write_volatile(target, value);
        }
    }
}

/// What every pin has, whatever its type.
pub trait HalPin {
    /// The pin's full name (`<component>.<suffix>`), as `halcmd show pin` lists it.
    fn name(&self) -> &str;
}

/// Implements [`HalPin`] for pin types wrapping a [`PinSlot`].
macro_rules! impl_hal_pin {
    ($($pin:ty),*) => {
        $(impl HalPin for $pin {
            fn name(&self) -> &str {
                &self.0.name
            }
        })*
    };
}

impl_hal_pin!(FloatIn, FloatOut, BitIn, BitOut, S32In, S32Out);

/// A float input pin (`hal_float_t`, `HAL_IN`): another component or `halcmd setp` writes it.
#[derive(Debug)]
pub struct FloatIn(pub(crate) PinSlot);

impl FloatIn {
    /// The pin's value.
    pub fn get(&self) -> f64 {
        self.0.read::<f64>()
    }
}

/// A float output pin (`hal_float_t`, `HAL_OUT`): acc writes it.
#[derive(Debug)]
pub struct FloatOut(pub(crate) PinSlot);

impl FloatOut {
    /// Writes `value` to the pin (and its signal).
    pub fn set(&mut self, value: f64) {
        self.0.write::<f64>(value);
    }
    /// The value last written.
    pub fn get(&self) -> f64 {
        self.0.read::<f64>()
    }
}

/// A bit input pin (`hal_bit_t`, a C `bool`, `HAL_IN`).
#[derive(Debug)]
pub struct BitIn(pub(crate) PinSlot);

impl BitIn {
    /// The pin's value (read as a byte: any non-zero byte is true).
    pub fn get(&self) -> bool {
        self.0.read::<u8>() != 0
    }
}

/// A bit output pin (`hal_bit_t`, a C `bool`, `HAL_OUT`).
#[derive(Debug)]
pub struct BitOut(pub(crate) PinSlot);

impl BitOut {
    /// Writes `value` to the pin (and its signal).
    pub fn set(&mut self, value: bool) {
        self.0.write::<u8>(u8::from(value));
    }
    /// The value last written.
    pub fn get(&self) -> bool {
        self.0.read::<u8>() != 0
    }
}

/// A signed 32-bit input pin (`hal_s32_t`, `HAL_IN`).
#[derive(Debug)]
pub struct S32In(pub(crate) PinSlot);

impl S32In {
    /// The pin's value.
    pub fn get(&self) -> i32 {
        self.0.read::<i32>()
    }
}

/// A signed 32-bit output pin (`hal_s32_t`, `HAL_OUT`).
#[derive(Debug)]
pub struct S32Out(pub(crate) PinSlot);

impl S32Out {
    /// Writes `value` to the pin (and its signal).
    pub fn set(&mut self, value: i32) {
        self.0.write::<i32>(value);
    }
    /// The value last written.
    pub fn get(&self) -> i32 {
        self.0.read::<i32>()
    }
}
