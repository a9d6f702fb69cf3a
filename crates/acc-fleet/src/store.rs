//! The partitioned writer: rows are buffered per (table, machine, date) and committed as
//! Parquet files `DIR/<table>/machine=<id>/date=<YYYY-MM-DD>/part-<tag>-<seq>.parquet`.
//!
//! A file is written under a hidden temporary name (`.part-….parquet.tmp`, which no engine
//! lists) and renamed when complete, so a reader never sees half a file. A buffer is
//! committed when it holds [`StoreWriter::rows_per_file`] rows, on
//! [`StoreWriter::commit`] and on [`StoreWriter::finish`]; a commit that fails keeps its
//! rows in the buffer (the next commit retries them) and returns the error naming the file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[cfg(feature = "store")]
use crate::parquet_file::{write_cuts, write_periods};
use crate::schema::{CutRow, PeriodRow};
use crate::FleetError;
#[cfg(not(feature = "store"))]
use absent::{write_cuts, write_periods};

/// Periods per file by default: ten minutes at T = 0.1 s.
pub const ROWS_PER_FILE: usize = 6000;

/// Longest machine id, characters.
pub const MACHINE_ID_MAX: usize = 64;

/// Check a machine id: 1 ..= [`MACHINE_ID_MAX`] characters of `A-Z a-z 0-9 _ - .`, not
/// starting with `.` (engines skip hidden folders).
pub fn check_machine_id(id: &str) -> Result<(), FleetError> {
    let ok_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if id.is_empty() || id.len() > MACHINE_ID_MAX || id.starts_with('.') || !id.chars().all(ok_char)
    {
        return Err(FleetError::MachineId(id.to_string()));
    }
    Ok(())
}

/// UTC date (`YYYY-MM-DD`) of a time in µs since the Unix epoch.
pub fn utc_date(us: i64) -> String {
    chrono::DateTime::from_timestamp_micros(us)
        .map_or_else(|| "1970-01-01".into(), |t| t.format("%Y-%m-%d").to_string())
}

/// Rows committed so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Committed {
    /// Period rows.
    pub periods: u64,
    /// Cut rows.
    pub cuts: u64,
    /// Files written.
    pub files: u64,
}

type Key = (String, String);

/// Writes the store's partitions; see the module docs.
#[derive(Debug)]
pub struct StoreWriter {
    root: PathBuf,
    tag: String,
    seq: u64,
    /// Rows of one table and partition per file (a buffer this full is committed at once).
    pub rows_per_file: usize,
    periods: BTreeMap<Key, Vec<PeriodRow>>,
    cuts: BTreeMap<Key, Vec<CutRow>>,
    committed: Committed,
}

impl StoreWriter {
    /// A writer into store `root` (created if missing). `tag` makes its file names unique
    /// among writers (the run's start and the process id).
    /// In a build without the `store` feature: [`FleetError::NotBuilt`], before anything is
    /// created.
    pub fn new(root: impl AsRef<Path>, tag: &str) -> Result<Self, FleetError> {
        if cfg!(not(feature = "store")) {
            return Err(FleetError::NotBuilt);
        }
        let root = root.as_ref().to_path_buf();
        std::fs::create_dir_all(&root).map_err(|e| FleetError::io(&root, e))?;
        Ok(Self {
            root,
            tag: tag.to_string(),
            seq: 0,
            rows_per_file: ROWS_PER_FILE,
            periods: BTreeMap::new(),
            cuts: BTreeMap::new(),
            committed: Committed::default(),
        })
    }

    /// The store's folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Rows committed so far.
    pub fn committed(&self) -> Committed {
        self.committed
    }

    /// Rows buffered, not yet committed (periods, cuts).
    pub fn pending(&self) -> (usize, usize) {
        (
            self.periods.values().map(Vec::len).sum(),
            self.cuts.values().map(Vec::len).sum(),
        )
    }

    /// Buffer one period of `machine` (committing its partition when full).
    pub fn push_period(&mut self, machine: &str, row: PeriodRow) -> Result<(), FleetError> {
        let key = (machine.to_string(), utc_date(row.ts_us()));
        let buf = self.periods.entry(key.clone()).or_default();
        buf.push(row);
        if buf.len() >= self.rows_per_file {
            self.commit_periods(&key)?;
        }
        Ok(())
    }

    /// Buffer one cut of `machine` (committing its partition when full).
    pub fn push_cut(&mut self, machine: &str, row: CutRow) -> Result<(), FleetError> {
        let key = (machine.to_string(), utc_date(row.ts_us()));
        let buf = self.cuts.entry(key.clone()).or_default();
        buf.push(row);
        if buf.len() >= self.rows_per_file {
            self.commit_cuts(&key)?;
        }
        Ok(())
    }

    /// Commit every buffer. On an error the rows not written stay buffered.
    pub fn commit(&mut self) -> Result<(), FleetError> {
        let keys: Vec<Key> = self.periods.keys().cloned().collect();
        for k in keys {
            self.commit_periods(&k)?;
        }
        let keys: Vec<Key> = self.cuts.keys().cloned().collect();
        for k in keys {
            self.commit_cuts(&k)?;
        }
        Ok(())
    }

    /// Commit everything and return the totals.
    pub fn finish(mut self) -> Result<Committed, FleetError> {
        self.commit()?;
        Ok(self.committed)
    }

    fn commit_periods(&mut self, key: &Key) -> Result<(), FleetError> {
        let Some(rows) = self.periods.remove(key).filter(|r| !r.is_empty()) else {
            return Ok(());
        };
        let path = self.next_path("period", key);
        let written = write_periods(&path, &rows);
        if let Err(e) = written {
            // Keep the rows for the next commit.
            self.periods.insert(key.clone(), rows);
            return Err(e);
        }
        self.committed.periods += rows.len() as u64;
        self.committed.files += 1;
        Ok(())
    }

    fn commit_cuts(&mut self, key: &Key) -> Result<(), FleetError> {
        let Some(rows) = self.cuts.remove(key).filter(|r| !r.is_empty()) else {
            return Ok(());
        };
        let path = self.next_path("cut", key);
        let written = write_cuts(&path, &rows);
        if let Err(e) = written {
            // Keep the rows for the next commit.
            self.cuts.insert(key.clone(), rows);
            return Err(e);
        }
        self.committed.cuts += rows.len() as u64;
        self.committed.files += 1;
        Ok(())
    }

    fn next_path(&mut self, table: &str, (machine, date): &Key) -> PathBuf {
        self.seq += 1;
        self.root
            .join(table)
            .join(format!("machine={machine}"))
            .join(format!("date={date}"))
            .join(format!("part-{}-{:06}.parquet", self.tag, self.seq))
    }
}

/// The writers of a build without the `store` feature: no file is written
/// ([`StoreWriter::new`] refuses first). Compiled, and linted, in every build.
#[cfg_attr(feature = "store", allow(dead_code))]
mod absent {
    use std::path::Path;

    use crate::schema::{CutRow, PeriodRow};
    use crate::FleetError;

    /// Always [`FleetError::NotBuilt`].
    pub(super) fn write_periods(_path: &Path, _rows: &[PeriodRow]) -> Result<(), FleetError> {
        Err(FleetError::NotBuilt)
    }

    /// Always [`FleetError::NotBuilt`].
    pub(super) fn write_cuts(_path: &Path, _rows: &[CutRow]) -> Result<(), FleetError> {
        Err(FleetError::NotBuilt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn machine_ids_are_checked() {
        for ok in ["m1", "mill-12", "A_b.c"] {
            assert!(check_machine_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", ".hidden", "a/b", "a=b", "x y", &"m".repeat(65)] {
            let e = check_machine_id(bad).expect_err(bad).to_string();
            assert!(e.contains("allowed"), "{e}");
        }
    }

    #[test]
    fn rows_land_in_machine_and_date_partitions_and_full_buffers_commit() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut w = StoreWriter::new(dir.path(), "t").expect("writer");
        w.rows_per_file = 2;
        // 2026-11-27T23:59:59.9 UTC, then 0.2 s later: the next day.
        let start = 1_795_823_999_900_000;
        assert_eq!(utc_date(start), "2026-11-27");
        let row = |t_s: f64| PeriodRow {
            run_start_us: start,
            t_s,
            ..PeriodRow::default()
        };
        w.push_period("m1", row(0.0)).expect("push");
        w.push_period("m1", row(0.05)).expect("push");
        assert_eq!(w.committed().periods, 2, "a full buffer commits");
        w.push_period("m1", row(0.2)).expect("push");
        assert_eq!(w.pending(), (1, 0));
        let done = w.finish().expect("finish");
        assert_eq!(done.periods, 3);
        assert_eq!(done.files, 2);
        let day = |d: &str| {
            dir.path()
                .join("period/machine=m1")
                .join(format!("date={d}"))
        };
        assert_eq!(
            std::fs::read_dir(day("2026-11-27")).expect("dir").count(),
            1
        );
        assert_eq!(
            std::fs::read_dir(day("2026-11-28")).expect("dir").count(),
            1
        );
    }
}
