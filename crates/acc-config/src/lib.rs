//! `acc-config`: typed, validated TOML configuration for `acc`.
//!
//! Every configuration file is read once at start-up with [`load_toml`], which refuses
//! unknown keys (when the target type uses `#[serde(deny_unknown_fields)]`) and reports
//! the file and key of any error. Range checks use [`check_range`] so that every error
//! names the file, the key and the allowed range.
//!
//! ```
//! use acc_config::{check_range, ConfigError};
//! let err = check_range("m.toml", "controller.period_s", -1.0, 1e-3, 10.0).unwrap_err();
//! assert_eq!(err.to_string(), "m.toml: key `controller.period_s` = -1 is out of range: allowed 0.001 ..= 10");
//! ```

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

pub mod diagnose;
pub mod preset;
pub mod tools;

/// The one out-of-range error of the workspace (defined in `acc-core`, the lowest crate, so
/// that the control core reports its parameter ranges with it too).
pub use acc_core::RangeError;
pub use diagnose::{from_table, KeyRange};
pub use preset::{load_controller, load_preset, parse_preset, resolve_preset, Preset, PresetFile};
pub use tools::{EntrySpec, OverloadReaction, ToolLimits, ToolTable, DEFAULT_AIR_FEED_MM_MIN};

/// A configuration error: which file, which key, what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Io {
        /// File path.
        file: PathBuf,
        /// OS error text.
        reason: String,
    },
    /// TOML syntax or type error (unknown key, wrong type, missing key).
    #[error("{file}: {message}")]
    Parse {
        /// File path.
        file: PathBuf,
        /// Parser message, including line and column and the key where known.
        message: String,
    },
    /// A value outside its allowed range: `FILE: key `K` = V is out of range: allowed A`
    /// (the file is always set by this crate's checks).
    #[error("{0}")]
    OutOfRange(RangeError),
    /// Any other invalid value (inconsistent keys, unknown preset name, ...).
    #[error("{file}: key `{key}`: {message}")]
    Invalid {
        /// File path.
        file: PathBuf,
        /// Dotted key path.
        key: String,
        /// What is wrong and what is allowed.
        message: String,
    },
}

/// Read and deserialize a TOML file; errors name the file, the full dotted key, the value
/// and (for a number of the wrong type or outside its type) the type's range, with the
/// line and column.
pub fn load_toml<T: DeserializeOwned>(path: impl AsRef<Path>) -> Result<T, ConfigError> {
    load_toml_with(path, &[])
}

/// [`load_toml`] with the allowed ranges of the file's numeric keys, shown when a value
/// does not even deserialize (e.g. `-1` for an unsigned count).
pub fn load_toml_with<T: DeserializeOwned>(
    path: impl AsRef<Path>,
    ranges: &[KeyRange],
) -> Result<T, ConfigError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
        file: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    parse_toml_with(path, &text, ranges)
}

/// Deserialize TOML text that came from `path` (used for errors only).
pub fn parse_toml<T: DeserializeOwned>(
    path: impl AsRef<Path>,
    text: &str,
) -> Result<T, ConfigError> {
    parse_toml_with(path, text, &[])
}

/// [`parse_toml`] with the allowed ranges of the file's numeric keys (see
/// [`load_toml_with`]).
pub fn parse_toml_with<T: DeserializeOwned>(
    path: impl AsRef<Path>,
    text: &str,
    ranges: &[KeyRange],
) -> Result<T, ConfigError> {
    toml::from_str(text).map_err(|e| diagnose::from_toml_error(path.as_ref(), text, &e, ranges))
}

/// A file named by key `key` (value as written: `value`) of the config `file`: an error
/// reading it (missing, unreadable) names `file`, the key and the path it resolved to.
/// Errors inside the named file already name that file and its key, and pass through.
pub fn referenced(file: &Path, key: &str, value: &Path, e: ConfigError) -> ConfigError {
    match e {
        ConfigError::Io {
            file: target,
            reason,
        } => ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            message: format!(
                "\"{}\" cannot be read: {}: {reason} (paths are relative to this file)",
                value.display(),
                target.display()
            ),
        },
        other => other,
    }
}

impl From<RangeError> for ConfigError {
    fn from(e: RangeError) -> Self {
        ConfigError::OutOfRange(e)
    }
}

/// Check `lo <= value <= hi` (and finite); the error names file, key and range.
pub fn check_range(
    file: impl AsRef<Path>,
    key: &str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<f64, ConfigError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange(
            RangeError::new(key.to_string(), value.to_string(), format!("{lo} ..= {hi}"))
                .in_file(file),
        ))
    }
}

/// Check `lo < value < hi` (open interval, finite); the error names file, key and range.
pub fn check_open_range(
    file: impl AsRef<Path>,
    key: &str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<f64, ConfigError> {
    if value.is_finite() && value > lo && value < hi {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange(
            RangeError::new(
                key.to_string(),
                value.to_string(),
                format!("{lo} < x < {hi}"),
            )
            .in_file(file),
        ))
    }
}

/// Resolve `rel` against the directory of the config file `base` (config files refer to
/// each other by paths relative to themselves).
pub fn resolve_relative(base: impl AsRef<Path>, rel: impl AsRef<Path>) -> PathBuf {
    let rel = rel.as_ref();
    if rel.is_absolute() {
        return rel.to_path_buf();
    }
    match base.as_ref().parent() {
        Some(dir) => dir.join(rel),
        None => rel.to_path_buf(),
    }
}
