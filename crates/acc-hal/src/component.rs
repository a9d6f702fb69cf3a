//! A userspace HAL component: `hal_init` on creation, pins, `hal_ready`, `hal_exit` when the
//! component and all its pins are dropped.

use std::collections::HashSet;
use std::ffi::{c_int, c_void, CString};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::library::{hal_api, HalApi};
use crate::pin::{BitIn, BitOut, FloatIn, FloatOut, PinSlot, S32In, S32Out};
use crate::HalError;

/// Longest component, pin or signal name HAL accepts (`HAL_NAME_LEN` in hal.h), in bytes.
pub const HAL_NAME_LEN: usize = 47;

/// `hal_pin_dir_t` values (hal.h).
const HAL_IN: c_int = 16;
const HAL_OUT: c_int = 32;

/// A userspace HAL component, as `loadusr` expects one: created with a unique name, given
/// its pins, then made [`ready`](Self::ready) (`loadusr -Wn NAME` waits for that).
///
/// Pins are named `<component>.<suffix>`. The component leaves HAL (`hal_exit`, its pins
/// disappear from `halcmd show pin`) when this value and every pin made from it are dropped.
#[derive(Debug)]
pub struct HalComponent {
    registration: Arc<Registration>,
}

/// One `hal_init` registration; `hal_exit` runs when the last owner (component or pin) drops.
#[derive(Debug)]
pub(crate) struct Registration {
    /// The opened HAL library.
    api: &'static HalApi,
    /// The component ID `hal_init` returned (> 0).
    id: c_int,
    /// The component's name.
    name: String,
    /// `hal_ready` has succeeded.
    ready: AtomicBool,
    /// Full names of the pins created so far.
    pin_names: Mutex<HashSet<String>>,
}

impl Drop for Registration {
    fn drop(&mut self) {
        // SAFETY: `id` came from a successful hal_init and Drop runs once, so hal_exit is
        // called once for it; every PinSlot holds an Arc of this Registration, so no pin
        // pointer into HAL memory is used after hal_exit unmaps it.
        let _ = unsafe { (self.api.exit)(self.id) };
    }
}

/// The HAL type of a new pin, with the library function that creates it.
#[derive(Debug, Clone, Copy)]
enum PinType {
    Bit,
    Float,
    S32,
}

impl HalComponent {
    /// Registers a component called `name` with HAL (`hal_init`).
    ///
    /// Errors: [`HalError::LibraryMissing`] without LinuxCNC, [`HalError::InvalidName`],
    /// [`HalError::ComponentNameTaken`] when a component of that name is loaded, and
    /// [`HalError::RealtimeUnavailable`] when HAL's shared memory cannot be opened.
    pub fn new(name: &str) -> Result<Self, HalError> {
        let c_name = hal_name(name)?;
        let api = hal_api()?;
        // SAFETY: `c_name` is NUL-terminated, at most HAL_NAME_LEN bytes (checked by
        // hal_name) and outlives the call.
        let id = unsafe { (api.init)(c_name.as_ptr()) };
        if id <= 0 {
            return Err(init_failure(api, name, id));
        }
        Ok(Self {
            registration: Arc::new(Registration {
                api,
                id,
                name: name.to_string(),
                ready: AtomicBool::new(false),
                pin_names: Mutex::new(HashSet::new()),
            }),
        })
    }

    /// The component's name, as `halcmd show comp` lists it.
    pub fn name(&self) -> &str {
        &self.registration.name
    }

    /// Tells HAL the component has all its pins (`hal_ready`): `loadusr -W` returns and
    /// `halcmd show comp` says `ready`. No pins can be added afterwards.
    pub fn ready(&self) -> Result<(), HalError> {
        let registration = &self.registration;
        if registration.ready.load(Ordering::Acquire) {
            return Ok(());
        }
        // SAFETY: `id` is this process's live component (its Registration is alive).
        let code = unsafe { (registration.api.ready)(registration.id) };
        if code != 0 {
            return Err(HalError::Call {
                call: "hal_ready",
                code,
            });
        }
        registration.ready.store(true, Ordering::Release);
        Ok(())
    }

    /// Whether [`ready`](Self::ready) has succeeded.
    pub fn is_ready(&self) -> bool {
        self.registration.ready.load(Ordering::Acquire)
    }

    /// A new float input pin `<component>.<suffix>` (LinuxCNC writes, acc reads).
    pub fn float_in(&self, suffix: &str) -> Result<FloatIn, HalError> {
        self.new_pin(suffix, HAL_IN, PinType::Float).map(FloatIn)
    }

    /// A new float output pin `<component>.<suffix>` (acc writes).
    pub fn float_out(&self, suffix: &str) -> Result<FloatOut, HalError> {
        self.new_pin(suffix, HAL_OUT, PinType::Float).map(FloatOut)
    }

    /// A new bit input pin `<component>.<suffix>`.
    pub fn bit_in(&self, suffix: &str) -> Result<BitIn, HalError> {
        self.new_pin(suffix, HAL_IN, PinType::Bit).map(BitIn)
    }

    /// A new bit output pin `<component>.<suffix>`.
    pub fn bit_out(&self, suffix: &str) -> Result<BitOut, HalError> {
        self.new_pin(suffix, HAL_OUT, PinType::Bit).map(BitOut)
    }

    /// A new signed 32-bit input pin `<component>.<suffix>`.
    pub fn s32_in(&self, suffix: &str) -> Result<S32In, HalError> {
        self.new_pin(suffix, HAL_IN, PinType::S32).map(S32In)
    }

    /// A new signed 32-bit output pin `<component>.<suffix>`.
    pub fn s32_out(&self, suffix: &str) -> Result<S32Out, HalError> {
        self.new_pin(suffix, HAL_OUT, PinType::S32).map(S32Out)
    }

    /// Creates pin `<component>.<suffix>`: checks the name and the order, allocates the
    /// pin's pointer in HAL shared memory (`hal_malloc`) and calls `hal_pin_<type>_new`.
    fn new_pin(&self, suffix: &str, dir: c_int, pin_type: PinType) -> Result<PinSlot, HalError> {
        let registration = &self.registration;
        let name = format!("{}.{suffix}", registration.name);
        let c_name = hal_name(&name)?;
        if registration.ready.load(Ordering::Acquire) {
            return Err(HalError::AlreadyReady { name });
        }
        let mut names = registration
            .pin_names
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        if names.contains(&name) {
            return Err(HalError::PinNameTaken { name });
        }
        let api = registration.api;
        let pointer_size = std::mem::size_of::<*mut c_void>() as std::ffi::c_long;
        // SAFETY: hal_malloc may be called by any component after hal_init (ours is live).
        let slot = unsafe { (api.malloc)(pointer_size) }.cast::<*mut c_void>();
        if slot.is_null() {
            return Err(HalError::OutOfMemory { name });
        }
        // SAFETY: `slot` is a fresh, pointer-aligned (hal.h: aligned for any HAL type)
        // allocation of one pointer; hal_pin_new refuses a slot that is not NULL.
        unsafe { slot.write(std::ptr::null_mut()) };
        let create = match pin_type {
            PinType::Bit => api.pin_bit_new,
            PinType::Float => api.pin_float_new,
            PinType::S32 => api.pin_s32_new,
        };
        // SAFETY: `c_name` is NUL-terminated and at most HAL_NAME_LEN bytes; `slot` is in HAL
        // shared memory as hal.h requires; `dir` is HAL_IN or HAL_OUT; the component is live
        // and not yet ready.
        let code = unsafe { create(c_name.as_ptr(), dir, slot, registration.id) };
        match code {
            0 => {
                names.insert(name.clone());
                // SAFETY: hal_pin_new succeeded, so `slot` points at the pin's data pointer
                // for a pin of `pin_type`, valid while `registration` lives.
                Ok(unsafe { PinSlot::new(slot, name, Arc::clone(registration)) })
            }
            code if code == -libc::ENOMEM => Err(HalError::OutOfMemory { name }),
            code if code == -libc::EPERM => Err(HalError::Locked { name }),
            // The name, type, direction, memory and order are checked above: what is left of
            // hal_pin_new's EINVAL cases is a name some component already has.
            code if code == -libc::EINVAL => Err(HalError::PinNameTaken { name }),
            code => Err(HalError::Call {
                call: "hal_pin_new",
                code,
            }),
        }
    }
}

/// `name` as a C string, if HAL and halcmd accept it: 1 to [`HAL_NAME_LEN`] bytes of
/// printable ASCII without spaces.
fn hal_name(name: &str) -> Result<CString, HalError> {
    let invalid = |reason| HalError::InvalidName {
        name: name.to_string(),
        reason,
    };
    if name.is_empty() {
        return Err(invalid("empty"));
    }
    if name.len() > HAL_NAME_LEN {
        return Err(invalid("longer than HAL_NAME_LEN (47 bytes)"));
    }
    if !name.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(invalid("only printable ASCII without spaces"));
    }
    CString::new(name).map_err(|_| invalid("holds a NUL byte"))
}

/// Names the cause of a failed `hal_init(name)`: a second registration under a name of this
/// process's own tells a clash (HAL works) from HAL being unusable (both fail). Both answer
/// `-EINVAL`.
fn init_failure(api: &'static HalApi, name: &str, code: c_int) -> HalError {
    let probe = format!("acc-probe-{}", std::process::id());
    let Ok(c_probe) = CString::new(probe) else {
        return HalError::RealtimeUnavailable { code };
    };
    // SAFETY: `c_probe` is NUL-terminated, shorter than HAL_NAME_LEN, and outlives the call.
    let probe_id = unsafe { (api.init)(c_probe.as_ptr()) };
    if probe_id > 0 {
        // SAFETY: `probe_id` came from the successful hal_init just above; exited once.
        let _ = unsafe { (api.exit)(probe_id) };
        HalError::ComponentNameTaken {
            name: name.to_string(),
        }
    } else {
        HalError::RealtimeUnavailable { code }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_halcmd_would_misparse_are_refused_before_hal_is_asked() {
        assert!(hal_name("acc.spindle-power").is_ok());
        for (name, reason) in [
            ("", "empty"),
            ("acc power", "only printable ASCII without spaces"),
            ("accé", "only printable ASCII without spaces"),
        ] {
            assert_eq!(
                hal_name(name).unwrap_err(),
                HalError::InvalidName {
                    name: name.into(),
                    reason
                }
            );
        }
        let long = "a".repeat(HAL_NAME_LEN + 1);
        assert!(matches!(hal_name(&long), Err(HalError::InvalidName { .. })));
        assert!(hal_name(&"a".repeat(HAL_NAME_LEN)).is_ok());
    }
}
