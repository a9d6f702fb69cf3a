//! The crate's one error type: configuration errors in the repository's convention (file,
//! key, allowed range) and height-map file errors (file, line, column).

use std::path::PathBuf;

use acc_config::{ConfigError, RangeError};

/// What went wrong building a stock or a cutter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StockError {
    /// A `stock.toml` error, or a value out of range: names the file (when there is one),
    /// the dotted key and the allowed range (`acc_config` convention).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A height-map file error: `FILE:LINE:COLUMN: message` (line and column 1-based; column
    /// is the value's position in its row).
    #[error("{}: {message}", location(.file, .line, .column))]
    HeightMap {
        /// The height-map file.
        file: PathBuf,
        /// Line of the file, 1-based.
        line: u64,
        /// Value number in the row, 1-based (0 when the whole line or file is at fault; then
        /// the message shows `FILE:LINE`, or `FILE` when the line is 0 too).
        column: usize,
        /// What is wrong and what is allowed.
        message: String,
    },
}

impl From<RangeError> for StockError {
    fn from(e: RangeError) -> Self {
        StockError::Config(ConfigError::OutOfRange(e))
    }
}

/// `Ok(value)` when `lo <= value <= hi` and finite, else a [`RangeError`] naming `key`
/// (no file: for values given in code; files add theirs with [`RangeError::in_file`]).
pub(crate) fn in_range(key: &str, value: f64, lo: f64, hi: f64) -> Result<f64, RangeError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(RangeError::new(key, value, format!("{lo} ..= {hi}")))
    }
}

/// `FILE:LINE:COLUMN`, leaving out a 0 column (and a 0 line).
fn location(file: &std::path::Path, line: &u64, column: &usize) -> String {
    match (line, column) {
        (0, _) => file.display().to_string(),
        (l, 0) => format!("{}:{l}", file.display()),
        (l, c) => format!("{}:{l}:{c}", file.display()),
    }
}
