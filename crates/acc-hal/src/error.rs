//! What can go wrong between acc and LinuxCNC's HAL.

/// An error from opening the HAL library, creating a component or a pin.
///
/// HAL's C functions answer almost every failure with `-EINVAL` (and print the reason on
/// stderr); the wrappers check names and order before calling, so each variant here names
/// one cause.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HalError {
    /// The HAL library could not be opened: LinuxCNC is not installed here.
    #[error(
        "LinuxCNC's HAL library {path} could not be opened ({detail}): install \
         linuxcnc-uspace, or set ACC_HAL_LIBRARY to the path of liblinuxcnchal.so.0"
    )]
    LibraryMissing {
        /// The file name or path passed to `dlopen`.
        path: String,
        /// The loader's reason.
        detail: String,
    },
    /// The library opened but lacks a function acc calls (not LinuxCNC's HAL, or a version
    /// without it).
    #[error("{path} has no function {symbol}: not LinuxCNC's HAL library")]
    SymbolMissing {
        /// The library's path.
        path: String,
        /// The missing function.
        symbol: String,
    },
    /// A component or pin name HAL would refuse.
    #[error("HAL name '{name}' is invalid: {reason}")]
    InvalidName {
        /// The refused name.
        name: String,
        /// Why (length, characters).
        reason: &'static str,
    },
    /// `hal_init` failed and HAL itself is not usable by this process: the realtime
    /// environment's shared memory could not be opened (for example it was created by
    /// another user, or RTAPI could not start).
    #[error(
        "HAL is not available to this process (hal_init returned {code}): start LinuxCNC's \
         realtime environment as this user (halrun, or loadusr from a HAL file) and see \
         the HAL messages above"
    )]
    RealtimeUnavailable {
        /// `hal_init`'s return value (a negative errno).
        code: i32,
    },
    /// Another component of that name is loaded.
    #[error("a HAL component named '{name}' is already loaded")]
    ComponentNameTaken {
        /// The component name.
        name: String,
    },
    /// A pin of that name exists (this component's or another's).
    #[error("a HAL pin named '{name}' already exists")]
    PinNameTaken {
        /// The full pin name.
        name: String,
    },
    /// A pin was asked for after [`ready`](crate::HalComponent::ready): HAL allows pins only
    /// before.
    #[error("pin '{name}' asked for after the component was made ready")]
    AlreadyReady {
        /// The full pin name.
        name: String,
    },
    /// HAL's shared memory has no room left.
    #[error("HAL shared memory is full (creating '{name}')")]
    OutOfMemory {
        /// The pin being created.
        name: String,
    },
    /// HAL is locked against configuration changes (`halcmd lock`).
    #[error("HAL is locked: '{name}' cannot be created (halcmd unlock)")]
    Locked {
        /// The pin being created.
        name: String,
    },
    /// Any other negative return of a HAL call.
    #[error("{call} failed with code {code}")]
    Call {
        /// The C function.
        call: &'static str,
        /// Its return value (a negative errno).
        code: i32,
    },
}
