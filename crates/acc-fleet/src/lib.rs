//! The fleet store: the run records (one row per control period) and the per-cut records
//! of many machines as Parquet files partitioned `machine=<id>/date=<YYYY-MM-DD>/`, which
//! Spark, DuckDB, pyarrow and the embedded DataFusion (`acc history query`) read as they
//! are. Layout, schema and recipes: `docs/fleet.md`.
//!
//! - [`schema`]: the tables `period` and `cut`, their rows and schema version.
//! - `columns`: their Arrow columns, and rows as record batches.
//! - [`store`]: the partitioned writer ([`StoreWriter`]); `parquet_file` writes one file.
//! - [`sink`]: the writer on the run's logging side ([`FleetSink`]).
//! - `check`: the version and integrity check of every file before a query.
//! - [`query`]: SQL with DataFusion, and the text / CSV output.
//! - [`collect`]: `acc collect`, the store written from the machines' MQTT messages.
//!
//! Arrow, Parquet and DataFusion are in the build only with the `store` feature (`acc-cli`'s
//! `fleet`, in `full`; the tests build it). Without it the types are there, and opening a
//! store or running a query fails with [`FleetError::NotBuilt`], which says how to build it in.

#[cfg(feature = "store")]
pub mod check;
pub mod collect;
#[cfg(feature = "store")]
pub mod columns;
#[cfg(feature = "store")]
mod parquet_file;
#[cfg(feature = "store")]
pub mod query;
/// SQL over the store in a build without the `store` feature (it refuses, naming the
/// feature). It is compiled, and linted, in every build.
#[doc(hidden)]
pub mod query_absent;
#[cfg(not(feature = "store"))]
pub use query_absent as query;
pub mod schema;
pub mod sink;
pub mod store;

use std::path::{Path, PathBuf};

pub use schema::{CutRow, PeriodRow, SCHEMA_VERSION};
pub use sink::FleetSink;
pub use store::StoreWriter;

/// Error of the fleet store: each names the file or the input that failed, on one line.
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// File-system error on a path.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Encoding or writing a Parquet file failed.
    #[error("{}: cannot write Parquet: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// A file that does not open as Parquet.
    #[error("{}: not a readable Parquet file: {message}", file.display())]
    Corrupt {
        /// The file.
        file: PathBuf,
        /// What the reader said.
        message: String,
    },
    /// A Parquet file without the store's schema version.
    #[error("{}: not a fleet-store file: no `acc.schema_version` metadata", .0.display())]
    NoVersion(PathBuf),
    /// A file of a newer schema than this build reads.
    #[error("{}: schema version {found} is newer than this acc reads (version {supported}): update acc to read it", file.display())]
    NewerVersion {
        /// The file.
        file: PathBuf,
        /// Its version.
        found: u32,
        /// The newest version this build reads.
        supported: u32,
    },
    /// A folder that holds neither table.
    #[error("{}: not a fleet store: no period/ or cut/ folder", .0.display())]
    NoStore(PathBuf),
    /// A machine id that cannot be a partition.
    #[error(
        "machine id `{0}`: allowed 1..=64 characters of A-Z a-z 0-9 _ - . (not starting with .)"
    )]
    MachineId(String),
    /// SQL that does not parse or plan.
    #[error("SQL: {0}")]
    Sql(String),
    /// The query failed while running.
    #[error("query: {0}")]
    Query(String),
    /// This `acc` was built without the fleet store.
    #[error("this acc was built without the fleet store (Parquet, SQL): build it with `cargo build --release -p acc-cli --features fleet` (or `--features full`)")]
    NotBuilt,
}

impl FleetError {
    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// A write error on `path`.
    pub fn write(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    }
}
