//! LinuxCNC's HAL library, opened at run time with `dlopen`: the few C functions a
//! userspace component calls, as typed function pointers.
//!
//! The library is `liblinuxcnchal.so.0` (Debian `linuxcnc-uspace`, in `/usr/lib`); the
//! environment variable [`LIBRARY_ENV`] names another file (a run-in-place LinuxCNC build).
//! It is opened once per process and never closed: pins point into the shared memory it
//! maps, and its state (the component count, the mapping) is per process.

use std::ffi::{c_char, c_int, c_long, c_void, CStr, CString};
use std::sync::OnceLock;

use crate::HalError;

/// Environment variable that names the HAL library file to open instead of the default
/// (e.g. `/home/me/linuxcnc-dev/lib/liblinuxcnchal.so.0`).
pub const LIBRARY_ENV: &str = "ACC_HAL_LIBRARY";

/// The library's soname as Debian installs it.
pub const DEFAULT_LIBRARY: &str = "liblinuxcnchal.so.0";

/// `int hal_init(const char *name)`: a component ID (> 0) or a negative errno.
type InitFn = unsafe extern "C" fn(*const c_char) -> c_int;
/// `int hal_exit(int comp_id)` and `int hal_ready(int comp_id)`: 0 or a negative errno.
type CompFn = unsafe extern "C" fn(c_int) -> c_int;
/// `void *hal_malloc(long int size)`: memory in HAL shared memory, or NULL.
type MallocFn = unsafe extern "C" fn(c_long) -> *mut c_void;
/// `int hal_pin_<type>_new(const char *name, hal_pin_dir_t dir, hal_<type>_t **data_ptr_addr,
/// int comp_id)`: 0 or a negative errno. `hal_pin_dir_t` is a C enum (an `int`).
type PinNewFn = unsafe extern "C" fn(*const c_char, c_int, *mut *mut c_void, c_int) -> c_int;

/// The HAL functions acc calls, resolved from one opened library.
#[derive(Debug)]
pub(crate) struct HalApi {
    /// `hal_init`.
    pub init: InitFn,
    /// `hal_exit`.
    pub exit: CompFn,
    /// `hal_ready`.
    pub ready: CompFn,
    /// `hal_malloc`.
    pub malloc: MallocFn,
    /// `hal_pin_bit_new`.
    pub pin_bit_new: PinNewFn,
    /// `hal_pin_float_new`.
    pub pin_float_new: PinNewFn,
    /// `hal_pin_s32_new`.
    pub pin_s32_new: PinNewFn,
}

/// The process's HAL library, opened on first use (from [`LIBRARY_ENV`] or
/// [`DEFAULT_LIBRARY`]); the same answer every later call.
pub(crate) fn hal_api() -> Result<&'static HalApi, HalError> {
    static API: OnceLock<Result<HalApi, HalError>> = OnceLock::new();
    API.get_or_init(|| {
        let path = std::env::var(LIBRARY_ENV).unwrap_or_else(|_| DEFAULT_LIBRARY.to_string());
        open(&path)
    })
    .as_ref()
    .map_err(Clone::clone)
}

/// Checks that LinuxCNC's HAL library can be opened and has every function acc calls,
/// without creating a component: `Ok` on a machine with LinuxCNC installed.
pub fn probe_library() -> Result<(), HalError> {
    hal_api().map(|_| ())
}

/// Opens the library at `path` (a file name is searched like `dlopen` does) and resolves
/// every function of [`HalApi`]. The handle is never closed.
pub(crate) fn open(path: &str) -> Result<HalApi, HalError> {
    let missing = |detail: String| HalError::LibraryMissing {
        path: path.to_string(),
        detail,
    };
    let c_path = CString::new(path).map_err(|_| missing("the path holds a NUL byte".into()))?;
    // SAFETY: `c_path` is a NUL-terminated string that outlives the call; dlopen has no
    // other precondition. Running the library's initialisers is the point of loading it
    // (liblinuxcnchal has no constructors that need more than libc).
    let handle = unsafe { libc::dlopen(c_path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
    if handle.is_null() {
        return Err(missing(last_dl_error()));
    }
    let symbol = |name: &'static CStr| -> Result<*mut c_void, HalError> {
        // SAFETY: `handle` is a live handle from dlopen (never closed) and `name` is
        // NUL-terminated.
        let address = unsafe { libc::dlsym(handle, name.as_ptr()) };
        if address.is_null() {
            Err(HalError::SymbolMissing {
                path: path.to_string(),
                symbol: name.to_string_lossy().into_owned(),
            })
        } else {
            Ok(address)
        }
    };
    // SAFETY (each transmute below): the symbol is the function of that name in LinuxCNC's
    // hal.h, whose C signature is the one written on the target type alias; a data pointer
    // and a function pointer have the same size on every platform LinuxCNC runs on.
    unsafe {
        Ok(HalApi {
            init: std::mem::transmute::<*mut c_void, InitFn>(symbol(c"hal_init")?),
            exit: std::mem::transmute::<*mut c_void, CompFn>(symbol(c"hal_exit")?),
            ready: std::mem::transmute::<*mut c_void, CompFn>(symbol(c"hal_ready")?),
            malloc: std::mem::transmute::<*mut c_void, MallocFn>(symbol(c"hal_malloc")?),
            pin_bit_new: std::mem::transmute::<*mut c_void, PinNewFn>(symbol(c"hal_pin_bit_new")?),
            pin_float_new: std::mem::transmute::<*mut c_void, PinNewFn>(symbol(
                c"hal_pin_float_new",
            )?),
            pin_s32_new: std::mem::transmute::<*mut c_void, PinNewFn>(symbol(c"hal_pin_s32_new")?),
        })
    }
}

/// The text of the last `dlopen`/`dlsym` failure on this thread.
fn last_dl_error() -> String {
    // SAFETY: dlerror returns NULL or a NUL-terminated string owned by libc that stays valid
    // until the next dl* call on this thread; it is copied before returning.
    unsafe {
        let text = libc::dlerror();
        if text.is_null() {
            "dlopen failed".to_string()
        } else {
            CStr::from_ptr(text).to_string_lossy().into_owned()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_file_is_library_missing_with_the_loader_reason() {
        let err = open("/nonexistent/liblinuxcnchal.so.0").unwrap_err();
        let HalError::LibraryMissing { path, detail } = &err else {
            panic!("expected LibraryMissing, got {err:?}");
        };
        assert_eq!(path, "/nonexistent/liblinuxcnchal.so.0");
        assert!(detail.contains("No such file"), "{detail}");
        assert!(err.to_string().contains("linuxcnc-uspace"), "{err}");
    }

    #[test]
    fn a_library_without_hal_functions_is_symbol_missing() {
        // libc is on every Linux machine and has no hal_init.
        let err = open("libc.so.6").unwrap_err();
        assert_eq!(
            err,
            HalError::SymbolMissing {
                path: "libc.so.6".into(),
                symbol: "hal_init".into()
            }
        );
    }
}
