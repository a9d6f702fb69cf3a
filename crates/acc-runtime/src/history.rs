//! The tool history: one schema-versioned SQLite file beside the run logs
//! (`acc-history.sqlite` by default) that keeps each tool's Kc trend, its cuts and alarms
//! across runs.
//!
//! Tables (schema version [`SCHEMA_VERSION`]):
//! - `schema_version(version)`: one row; a file written by a newer `acc` is refused
//!   ([`HistoryError::NewerSchema`]), an older one is migrated in place;
//! - `tools(tool, first_run, kc_ref)`: each tool seen, with the fresh reference of its first
//!   trend point;
//! - `refs(tool, program, block, kc_ref)`: fresh reference per tool and cut;
//! - `runs(id, label, started_utc_s)`;
//! - `cuts(run, tool, program, block_first, block_last, t_start_s, …, time_saved_s)`;
//! - `wear_samples(run, tool, program, block, t_s, x_mm, kc, kc_ref, rise_pct, level)`;
//! - `alarms(run, tool, t_s, kind, detail)`.
//!
//! Writes never happen on the control thread: live, the [`Watch`] runs on the logging side
//! ([`WatchSink`], the runner's logger thread) and hands its items to a [`HistoryWriter`]
//! thread through a bounded channel with `try_send` (a full queue drops the item and counts
//! it, it never waits); offline (`acc sim`) the items are written after the run.

use std::path::{Path, PathBuf};

use rusqlite::{params, Connection, OptionalExtension};

use crate::cuts::{CutRecord, CutRecorder};
use crate::record::RunRecord;
use crate::runner::LogSink;
use crate::watch::{RefKey, WatchLimits, WearLevel, WearSample, WearTracker};

/// Schema version this `acc` writes.
pub const SCHEMA_VERSION: i64 = 1;

/// Default file name, beside the run log.
pub const DEFAULT_FILE: &str = "acc-history.sqlite";

/// Error of the history database.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// SQLite failed.
    #[error("{file}: history database: {source}")]
    Sqlite {
        /// The file.
        file: PathBuf,
        /// The error.
        source: rusqlite::Error,
    },
    /// The file was written by a newer `acc`.
    #[error("{file}: history database schema version {found} is newer than this acc supports ({supported}); use a newer acc or another --history file")]
    NewerSchema {
        /// The file.
        file: PathBuf,
        /// Version in the file.
        found: i64,
        /// [`SCHEMA_VERSION`].
        supported: i64,
    },
}

/// One point of a tool's stored trend.
#[derive(Debug, Clone, PartialEq)]
pub struct TrendPoint {
    /// Run id.
    pub run: i64,
    /// Time in that run, s.
    pub t_s: f64,
    /// Block (0: unknown).
    pub block: u16,
    /// Median Kc_hat of the window, N/(mm/min).
    pub kc: f64,
    /// Rise over the fresh reference, percent.
    pub rise_pct: f64,
    /// `ok`, `warn`, `limit`.
    pub level: String,
}

/// The history database.
#[derive(Debug)]
pub struct History {
    conn: Connection,
    path: PathBuf,
}

const SCHEMA_V1: &str = "
CREATE TABLE IF NOT EXISTS tools (tool INTEGER PRIMARY KEY, first_run INTEGER, kc_ref REAL NOT NULL);
CREATE TABLE IF NOT EXISTS refs (tool INTEGER NOT NULL, program INTEGER NOT NULL, block INTEGER NOT NULL,
    kc_ref REAL NOT NULL, PRIMARY KEY (tool, program, block));
CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY AUTOINCREMENT, label TEXT NOT NULL, started_utc_s REAL NOT NULL);
CREATE TABLE IF NOT EXISTS cuts (id INTEGER PRIMARY KEY AUTOINCREMENT, run INTEGER NOT NULL, tool INTEGER NOT NULL,
    program INTEGER NOT NULL, block_first INTEGER NOT NULL, block_last INTEGER NOT NULL,
    t_start_s REAL NOT NULL, t_end_s REAL NOT NULL, x_start_mm REAL, x_end_mm REAL,
    time_in_cut_s REAL NOT NULL, force_mean_n REAL NOT NULL, force_max_n REAL NOT NULL,
    force_rms_error_n REAL NOT NULL, force_ref_n REAL NOT NULL, hist_bin_pct INTEGER NOT NULL,
    override_hist TEXT NOT NULL, alarms TEXT NOT NULL, feed_hold_periods INTEGER NOT NULL,
    time_saved_s REAL NOT NULL);
CREATE TABLE IF NOT EXISTS wear_samples (id INTEGER PRIMARY KEY AUTOINCREMENT, run INTEGER NOT NULL,
    tool INTEGER NOT NULL, program INTEGER NOT NULL, block INTEGER NOT NULL, t_s REAL NOT NULL,
    x_mm REAL, kc REAL NOT NULL, kc_ref REAL NOT NULL, rise_pct REAL NOT NULL, level TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS alarms (id INTEGER PRIMARY KEY AUTOINCREMENT, run INTEGER NOT NULL,
    tool INTEGER NOT NULL, t_s REAL NOT NULL, kind TEXT NOT NULL, detail TEXT NOT NULL);
";

impl History {
    /// Open (or create) the history file at `path`; refuses a newer schema version.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, HistoryError> {
        let path = path.as_ref().to_path_buf();
        let sql = |source| HistoryError::Sqlite {
            file: path.clone(),
            source,
        };
        let conn = Connection::open(&path).map_err(sql)?;
        // A small page cache: a run of hours must not grow the process by SQLite's default
        // 2 MiB cache.
        conn.execute_batch("PRAGMA cache_size = -256;")
            .map_err(sql)?;
        conn.execute_batch("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL);")
            .map_err(sql)?;
        let found: Option<i64> = conn
            .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
            .optional()
            .map_err(sql)?
            .flatten();
        match found {
            Some(v) if v > SCHEMA_VERSION => {
                return Err(HistoryError::NewerSchema {
                    file: path,
                    found: v,
                    supported: SCHEMA_VERSION,
                })
            }
            Some(v) if v == SCHEMA_VERSION => {}
            // New file (or an older schema: version 1 is the first, so only a new file).
            _ => {
                conn.execute_batch(SCHEMA_V1).map_err(sql)?;
                conn.execute("DELETE FROM schema_version", [])
                    .map_err(sql)?;
                conn.execute(
                    "INSERT INTO schema_version (version) VALUES (?1)",
                    [SCHEMA_VERSION],
                )
                .map_err(sql)?;
            }
        }
        Ok(History { conn, path })
    }

    fn err(&self, source: rusqlite::Error) -> HistoryError {
        HistoryError::Sqlite {
            file: self.path.clone(),
            source,
        }
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Schema version in the file.
    pub fn schema_version(&self) -> Result<i64, HistoryError> {
        self.conn
            .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    /// Start a run; returns its id.
    pub fn begin_run(&mut self, label: &str) -> Result<i64, HistoryError> {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        self.conn
            .execute(
                "INSERT INTO runs (label, started_utc_s) VALUES (?1, ?2)",
                params![label, now],
            )
            .map_err(|e| self.err(e))?;
        Ok(self.conn.last_insert_rowid())
    }

    /// Number of runs stored.
    pub fn run_count(&self) -> Result<i64, HistoryError> {
        self.conn
            .query_row("SELECT COUNT(*) FROM runs", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    /// The fresh references stored (for [`WearTracker::set_reference`]).
    pub fn references(&self) -> Result<Vec<(RefKey, f64)>, HistoryError> {
        let mut st = self
            .conn
            .prepare("SELECT tool, program, block, kc_ref FROM refs")
            .map_err(|e| self.err(e))?;
        let rows = st
            .query_map([], |r| {
                Ok(((r.get::<_, u16>(0)?, r.get(1)?, r.get(2)?), r.get(3)?))
            })
            .map_err(|e| self.err(e))?;
        rows.collect::<Result<Vec<_>, _>>().map_err(|e| self.err(e))
    }

    /// Store one trend point (and the tool's / cut's fresh reference if new).
    pub fn add_wear_sample(&mut self, run: i64, s: &WearSample) -> Result<(), HistoryError> {
        let c = &self.conn;
        let r = (|| {
            c.execute(
                "INSERT OR IGNORE INTO tools (tool, first_run, kc_ref) VALUES (?1, ?2, ?3)",
                params![s.tool, run, s.kc_ref],
            )?;
            c.execute(
                "INSERT OR IGNORE INTO refs (tool, program, block, kc_ref) VALUES (?1, ?2, ?3, ?4)",
                params![s.tool, s.program, s.block, s.kc_ref],
            )?;
            c.execute(
                "INSERT INTO wear_samples (run, tool, program, block, t_s, x_mm, kc, kc_ref, rise_pct, level)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
                params![
                    run,
                    s.tool,
                    s.program,
                    s.block,
                    s.t_s,
                    s.x_mm.is_finite().then_some(s.x_mm),
                    s.kc,
                    s.kc_ref,
                    s.rise_pct,
                    s.level.as_str()
                ],
            )?;
            Ok(())
        })();
        r.map_err(|e| self.err(e))
    }

    /// Store one cut.
    pub fn add_cut(&mut self, run: i64, c: &CutRecord) -> Result<(), HistoryError> {
        let hist = c
            .override_hist
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(",");
        self.conn
            .execute(
                "INSERT INTO cuts (run, tool, program, block_first, block_last, t_start_s, t_end_s,
                 x_start_mm, x_end_mm, time_in_cut_s, force_mean_n, force_max_n, force_rms_error_n,
                 force_ref_n, hist_bin_pct, override_hist, alarms, feed_hold_periods, time_saved_s)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19)",
                params![
                    run,
                    c.tool,
                    c.program,
                    c.block_first,
                    c.block_last,
                    c.t_start_s,
                    c.t_end_s,
                    c.x_start_mm.is_finite().then_some(c.x_start_mm),
                    c.x_end_mm.is_finite().then_some(c.x_end_mm),
                    c.time_in_cut_s,
                    c.force_mean_n,
                    c.force_max_n,
                    c.force_rms_error_n,
                    c.force_ref_n,
                    c.hist_bin_pct,
                    hist,
                    c.alarms().join(","),
                    c.feed_hold_periods,
                    c.time_saved_s
                ],
            )
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    /// Store one alarm.
    pub fn add_alarm(
        &mut self,
        run: i64,
        tool: u16,
        t_s: f64,
        kind: &str,
        detail: &str,
    ) -> Result<(), HistoryError> {
        self.conn
            .execute(
                "INSERT INTO alarms (run, tool, t_s, kind, detail) VALUES (?1, ?2, ?3, ?4, ?5)",
                params![run, tool, t_s, kind, detail],
            )
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    /// Number of rows of `table` (`cuts`, `wear_samples`, `alarms`, `tools`, `runs`).
    pub fn count(&self, table: &str) -> Result<i64, HistoryError> {
        let table = match table {
            "cuts" | "wear_samples" | "alarms" | "tools" | "runs" | "refs" => table,
            _ => "runs",
        };
        self.conn
            .query_row(&format!("SELECT COUNT(*) FROM {table}"), [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    /// A tool's Kc trend across runs, oldest first.
    pub fn wear_trend(&self, tool: u16) -> Result<Vec<TrendPoint>, HistoryError> {
        let mut st = self
            .conn
            .prepare(
                "SELECT run, t_s, block, kc, rise_pct, level FROM wear_samples WHERE tool = ?1 ORDER BY run, t_s",
            )
            .map_err(|e| self.err(e))?;
        let rows = st
            .query_map([tool], |r| {
                Ok(TrendPoint {
                    run: r.get(0)?,
                    t_s: r.get(1)?,
                    block: r.get(2)?,
                    kc: r.get(3)?,
                    rise_pct: r.get(4)?,
                    level: r.get(5)?,
                })
            })
            .map_err(|e| self.err(e))?;
        rows.collect::<Result<Vec<_>, _>>().map_err(|e| self.err(e))
    }

    /// Store one watch item.
    pub fn add(&mut self, run: i64, item: &WatchItem) -> Result<(), HistoryError> {
        match item {
            WatchItem::Wear(s) => self.add_wear_sample(run, s),
            WatchItem::Cut(c) => self.add_cut(run, c),
            WatchItem::Alarm {
                tool,
                t_s,
                kind,
                detail,
            } => self.add_alarm(run, *tool, *t_s, kind, detail),
        }
    }
}

/// What the watch produced from the records.
#[derive(Debug, Clone, PartialEq)]
pub enum WatchItem {
    /// A trend point.
    Wear(WearSample),
    /// A cut ended.
    Cut(CutRecord),
    /// An alarm was raised (a run-log alarm bit rising, a wear level reached).
    Alarm {
        /// Tool (0: unknown).
        tool: u16,
        /// Time, s.
        t_s: f64,
        /// `breakage`, `overload`, `wear_warn`, `wear_limit`, …
        kind: String,
        /// Text.
        detail: String,
    },
}

/// The watch beside the loop: Kc trend ([`WearTracker`]), cuts ([`CutRecorder`]) and alarm
/// edges, from the stream of run-log records.
#[derive(Debug, Clone)]
pub struct Watch {
    /// The Kc trend.
    pub wear: WearTracker,
    /// The cuts.
    pub cuts: CutRecorder,
    last_alarms: u8,
    levels: std::collections::BTreeMap<u16, WearLevel>,
}

impl Watch {
    /// A watch with `limits` for every tool on a loop of period `period_s` (s).
    pub fn new(limits: WatchLimits, period_s: f64) -> Self {
        let mut cuts = CutRecorder::new(period_s);
        cuts.cut_force_fraction = limits.cut_force_fraction;
        Watch {
            wear: WearTracker::new(limits),
            cuts,
            last_alarms: 0,
            levels: Default::default(),
        }
    }

    /// Load the fresh references of `history` so the trend continues across runs.
    pub fn continue_from(&mut self, history: &History) -> Result<(), HistoryError> {
        for (k, kc) in history.references()? {
            self.wear.set_reference(k, kc);
        }
        Ok(())
    }

    /// Feed one record.
    pub fn push(&mut self, r: &RunRecord) -> Vec<WatchItem> {
        let mut out = Vec::new();
        let tool = r.tool.unwrap_or(0);
        let rising = r.alarms & !self.last_alarms;
        self.last_alarms = r.alarms;
        for name in crate::cuts::alarm_names(rising) {
            out.push(WatchItem::Alarm {
                tool,
                t_s: r.t_s,
                kind: name.to_string(),
                detail: format!(
                    "force {} N, state {}",
                    r.force_n.map_or("?".into(), |f| format!("{f:.0}")),
                    r.state
                ),
            });
        }
        if let Some(s) = self.wear.observe(r) {
            let prev = self.levels.insert(s.tool, s.level).unwrap_or(WearLevel::Ok);
            if s.level > prev {
                out.push(WatchItem::Alarm {
                    tool: s.tool,
                    t_s: s.t_s,
                    kind: format!("wear_{}", s.level.as_str()),
                    detail: format!(
                        "Kc_hat {:.3} N/(mm/min), +{:.1} % over the fresh reference {:.3}",
                        s.kc, s.rise_pct, s.kc_ref
                    ),
                });
            }
            out.push(WatchItem::Wear(s));
        }
        if let Some(c) = self.cuts.push(r) {
            out.push(WatchItem::Cut(c));
        }
        for it in &out {
            if let WatchItem::Alarm { kind, .. } = it {
                if kind.starts_with("wear_") {
                    self.cuts.note_alarm(kind);
                }
            }
        }
        out
    }

    /// End of the stream: the open cut, if any.
    pub fn finish(&mut self) -> Vec<WatchItem> {
        self.cuts.finish().map(WatchItem::Cut).into_iter().collect()
    }

    /// Every item of a whole log.
    pub fn run_all(&mut self, rows: &[RunRecord]) -> Vec<WatchItem> {
        let mut out: Vec<WatchItem> = rows.iter().flat_map(|r| self.push(r)).collect();
        out.extend(self.finish());
        out
    }
}

/// A thread that owns the [`History`] and stores the items sent to it; senders never block.
#[derive(Debug)]
pub struct HistoryWriter {
    tx: Option<crossbeam_channel::Sender<WatchItem>>,
    handle: Option<std::thread::JoinHandle<Result<u64, HistoryError>>>,
    dropped: u64,
}

impl HistoryWriter {
    /// Queue length (items).
    pub const QUEUE: usize = 1024;

    /// Start the writer on `history`, recording into run `run`.
    pub fn spawn(mut history: History, run: i64) -> Self {
        let (tx, rx) = crossbeam_channel::bounded::<WatchItem>(Self::QUEUE);
        let handle = std::thread::Builder::new()
            .name("acc-history".into())
            .spawn(move || {
                let mut n = 0u64;
                for item in rx {
                    history.add(run, &item)?;
                    n += 1;
                }
                Ok(n)
            })
            .ok();
        HistoryWriter {
            tx: Some(tx),
            handle,
            dropped: 0,
        }
    }

    /// Queue an item; a full queue (or a stopped writer) drops it and counts it.
    pub fn send(&mut self, item: WatchItem) {
        let ok = self.tx.as_ref().is_some_and(|tx| tx.try_send(item).is_ok());
        if !ok {
            self.dropped += 1;
        }
    }

    /// Items dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Close the queue, wait for the writer; the number of items stored.
    pub fn finish(&mut self) -> Result<u64, HistoryError> {
        self.tx = None;
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(r)) => r,
            _ => Ok(0),
        }
    }
}

/// A [`LogSink`] that writes the run log through `inner` and feeds each record to a
/// [`Watch`] whose items go to a [`HistoryWriter`] (the runner's logger thread runs it, not
/// the control thread).
#[derive(Debug)]
pub struct WatchSink<S> {
    /// The run-log sink.
    pub inner: S,
    /// The watch.
    pub watch: Watch,
    /// The writer (`None`: watch without storage).
    pub writer: Option<HistoryWriter>,
    /// What the watch found, bounded (for the end-of-run summary; a run of hours does
    /// not grow it).
    pub summary: WatchSummary,
}

/// A bounded summary of the watch's items: counts, time saved, the last trend point per
/// tool and the first [`WatchSummary::MAX_ALARMS`] alarms.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WatchSummary {
    /// Cuts ended.
    pub cuts: u64,
    /// Sum of the cuts' time saved, s.
    pub time_saved_s: f64,
    /// Trend points.
    pub wear_samples: u64,
    /// Last trend point per tool.
    pub last_wear: std::collections::BTreeMap<u16, WearSample>,
    /// Alarms `(tool, t_s, kind, detail)`, the first [`WatchSummary::MAX_ALARMS`].
    pub alarms: Vec<(u16, f64, String, String)>,
    /// Alarms in all.
    pub alarm_count: u64,
}

impl WatchSummary {
    /// Alarms kept in [`WatchSummary::alarms`].
    pub const MAX_ALARMS: usize = 100;

    /// Account for one item.
    pub fn add(&mut self, item: &WatchItem) {
        match item {
            WatchItem::Cut(c) => {
                self.cuts += 1;
                self.time_saved_s += c.time_saved_s;
            }
            WatchItem::Wear(w) => {
                self.wear_samples += 1;
                self.last_wear.insert(w.tool, w.clone());
            }
            WatchItem::Alarm {
                tool,
                t_s,
                kind,
                detail,
            } => {
                self.alarm_count += 1;
                if self.alarms.len() < Self::MAX_ALARMS {
                    self.alarms
                        .push((*tool, *t_s, kind.clone(), detail.clone()));
                }
            }
        }
    }

    /// The summary of `items`.
    pub fn of(items: &[WatchItem]) -> Self {
        let mut s = Self::default();
        for i in items {
            s.add(i);
        }
        s
    }
}

impl<S: LogSink> LogSink for WatchSink<S> {
    type Error = S::Error;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.inner.write(rec)?;
        for item in self.watch.push(rec) {
            self.summary.add(&item);
            if let Some(w) = self.writer.as_mut() {
                w.send(item);
            }
        }
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        for item in self.watch.finish() {
            self.summary.add(&item);
            if let Some(w) = self.writer.as_mut() {
                w.send(item);
            }
        }
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newer_schema_is_refused_and_data_survives_reopen() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join(DEFAULT_FILE);
        {
            let mut h = History::open(&p).expect("create");
            let run = h.begin_run("a").expect("run");
            h.add_alarm(run, 3, 1.0, "breakage", "x").expect("alarm");
        }
        let h = History::open(&p).expect("reopen");
        assert_eq!(h.count("alarms").expect("count"), 1);
        assert_eq!(h.schema_version().expect("v"), SCHEMA_VERSION);
        h.conn
            .execute("UPDATE schema_version SET version = 99", [])
            .expect("bump");
        drop(h);
        let e = History::open(&p).expect_err("newer schema");
        let msg = e.to_string();
        assert!(msg.contains("99") && msg.contains(DEFAULT_FILE), "{msg}");
    }
}
