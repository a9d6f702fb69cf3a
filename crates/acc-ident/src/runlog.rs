//! Run logs: the CSV schema `acc sim` and `acc run` write, read column by column.
//!
//! Required columns: `t_s, feed_mm_min, spindle_rpm, radial_depth_mm, axial_depth_mm` and at
//! least one of `power_w`, `force_n`. Optional: `x_mm, programmed_feed_mm_min,
//! override_cmd_pct, override_applied_pct, force_true_n, force_ref_n, kc_hat, kp, ki, mode`
//! and, from the importers, `tool_id`, `phase`, `wear_vb_um`. Unknown columns are ignored.
//! Every error names the file, the 1-based line and the column.
//!
//! A log written by `acc` (run-log schema v2 or v1) is read as typed records. A production
//! log (`acc run`) has no engagement: [`read_csv_with`] rebuilds it from the workpiece at
//! the logged path position `x_mm` ([`crate::engagement`]); without a workpiece the error
//! ([`RunLogError::MissingEngagement`]) names the empty columns and lines.

use std::path::{Path, PathBuf};

use crate::dead::{dead_rows, DeadReason, RowFlags};
use crate::engagement::PathEngagement;
use crate::model::Channel;

/// A run-log reading or writing error; names file, line and column where they exist.
#[derive(Debug, thiserror::Error)]
pub enum RunLogError {
    /// The file could not be opened or written.
    #[error("{file}: cannot open: {reason}")]
    Io {
        /// File path.
        file: PathBuf,
        /// OS error text.
        reason: String,
    },
    /// A required column is missing from the header line.
    #[error("{file}: line 1: missing required column `{column}` (required: {required})")]
    MissingColumn {
        /// File path.
        file: PathBuf,
        /// The missing column.
        column: String,
        /// The list of required columns.
        required: String,
    },
    /// A cell is not a finite number, or is out of its allowed range.
    #[error("{file}: line {line}, column {col} (`{column}`): {message}")]
    BadValue {
        /// File path.
        file: PathBuf,
        /// 1-based line number in the file (the header is line 1).
        line: u64,
        /// 1-based column number.
        col: usize,
        /// Column name.
        column: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Malformed CSV (wrong number of fields, bad quoting).
    #[error("{file}: line {line}: malformed CSV: {message}")]
    Csv {
        /// File path.
        file: PathBuf,
        /// 1-based line number.
        line: u64,
        /// Parser message.
        message: String,
    },
    /// A run log without engagement (a production log from `acc run`) and no workpiece to
    /// rebuild it from.
    #[error("{file}: line {line}: columns {radial_col} (`radial_depth_mm`) and {axial_col} (`axial_depth_mm`) are empty ({empty_rows} of {rows} data rows, lines {line}..={last_line}): a production log (`acc run`) does not know its depth of cut. Without the engagement the model cannot be replayed, so nothing can be compared on this log: no effect named, no model updated (the log alone shows power and force over time and where the tool cut, not why they differ from the model). Add `--workpiece WORKPIECE.toml` (the workpiece file, or the scenario the machine ran) so that the engagement comes from the logged path position (column {x_col}, `x_mm`), and `--x0-mm X0` if the tool centre was not at the start of the workpiece's first segment when `acc run` first read the machine (default 0)")]
    MissingEngagement {
        /// File path.
        file: PathBuf,
        /// 1-based line of the first row without engagement (the header is line 1).
        line: u64,
        /// 1-based line of the last such row.
        last_line: u64,
        /// Rows without engagement.
        empty_rows: usize,
        /// Data rows in the log.
        rows: usize,
        /// 1-based column number of `radial_depth_mm` (schema v2).
        radial_col: usize,
        /// 1-based column number of `axial_depth_mm` (schema v2).
        axial_col: usize,
        /// 1-based column number of `x_mm` (schema v2).
        x_col: usize,
    },
    /// The log is unusable as a whole (too short, time not increasing).
    #[error("{file}: {message}")]
    Invalid {
        /// File path.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// One run log held column-wise. All vectors have the same length; optional columns are
/// `None` when the file did not have them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunLog {
    /// Time since start, s (strictly increasing).
    pub t_s: Vec<f64>,
    /// Tool position along the path, mm.
    pub x_mm: Option<Vec<f64>>,
    /// Radial depth of cut, mm (0 = air cut).
    pub radial_depth_mm: Vec<f64>,
    /// Axial depth of cut, mm (0 = air cut).
    pub axial_depth_mm: Vec<f64>,
    /// Spindle speed, rpm.
    pub spindle_rpm: Vec<f64>,
    /// Programmed feed (100 % override), mm/min.
    pub programmed_feed_mm_min: Option<Vec<f64>>,
    /// Override commanded by the controller, % (0–150).
    pub override_cmd_pct: Option<Vec<f64>>,
    /// Override in effect at the CNC, %.
    pub override_applied_pct: Option<Vec<f64>>,
    /// Actual (recorded) feed, mm/min.
    pub feed_mm_min: Vec<f64>,
    /// Measured mean cutting force, N.
    pub force_n: Option<Vec<f64>>,
    /// Measured spindle input power, W.
    pub power_w: Option<Vec<f64>>,
    /// Tool flank wear VB, µm (importers only; the workflow never reads it).
    pub wear_vb_um: Option<Vec<f64>>,
    /// Machining phase label per row (importers), e.g. `Layer 1 Up`.
    pub phase: Option<Vec<String>>,
    /// How many board samples each row's power read moved on from the previous row's
    /// (`acc run`'s flags: `seq_repeat` = 0, `seq_skip:<n>` = n, otherwise 1); `None` when
    /// every row moved by one.
    pub sample_advance: Option<Vec<u32>>,
    /// The board's `ACTUAL_FEED` with each row's sample (`board_feed_mm_min`, v2 boards),
    /// mm/min: the NC's feed over the sampled period; `None` in a row without a used read
    /// (a failed or held read). `None` as a whole when no row has it, and for a simulator's
    /// log (`x_true_mm` in every row: its board runs in lockstep). The replay reads it
    /// to find writes that raced the board's tick ([`crate::replay::raced`]).
    pub board_feed_mm_min: Option<Vec<Option<f64>>>,
    /// Every row carries the plant's truth (`x_true_mm`): a simulator's log (`acc sim`,
    /// `acc board-sim --log`). `false` for `acc run`'s logs, logs built in code and the
    /// importers.
    pub plant_truth: bool,
    /// What each row's flags and cells say about its sample (a log written by `acc`);
    /// `None` when every row holds a sample (the importers, logs built in code). Rows
    /// without a valid measurement on the compared channel ([`RunLog::dead_rows`]) are
    /// replayed but never compared.
    pub row_flags: Option<Vec<RowFlags>>,
}

/// The columns a run log must have.
pub const REQUIRED: [&str; 5] = [
    "t_s",
    "feed_mm_min",
    "spindle_rpm",
    "radial_depth_mm",
    "axial_depth_mm",
];

impl RunLog {
    /// Workpiece coordinate of the tool centre at the start of the first row's period, mm:
    /// the first row's position (`x_mm`) less that row's travel (its feed × its period, the
    /// period taken from the first two rows). `None` without positions, with fewer than two
    /// rows or a non-finite value.
    ///
    /// A production log read with a workpiece ([`read_csv_with`]) has its first position at
    /// `--x0-mm` — where the tool was when `acc run` first read the machine — and logs the
    /// feed it used, so the replay's first period ends there; against `acc board-sim
    /// --wait-for-controller` that period stands for the held sample 0 and the replay's
    /// drive starting from rest in it for the board's own start one period later. A
    /// simulator's log has its true positions and its true mean feed: the start is the
    /// simulator's own.
    pub fn path_start_mm(&self) -> Option<f64> {
        let x0 = *self.x_mm.as_ref()?.first()?;
        let dt = self.t_s.get(1)? - self.t_s.first()?;
        let start = x0 - self.feed_mm_min.first()? * dt / 60.0;
        start.is_finite().then_some(start)
    }

    /// Per row, why it cannot be compared on `channel` ([`dead_rows`]); `None`
    /// for a row to compare. Logs without flags (built in code, importers) compare every row.
    pub fn dead_rows(&self, channel: Channel) -> Vec<Option<DeadReason>> {
        match &self.row_flags {
            Some(f) => dead_rows(f, &self.radial_depth_mm, &self.axial_depth_mm, channel),
            None => vec![None; self.len()],
        }
    }

    /// Written by `acc run` (or another production writer): flags and cells of a log
    /// written by `acc` ([`RunLog::row_flags`]) without the plant's truth. Its `force_n` is
    /// the loop's estimate from the board's power register (`power_w`).
    pub fn is_production(&self) -> bool {
        self.row_flags.is_some() && !self.plant_truth
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// `true` when the log has no rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Median sampling period, s (0 for fewer than two rows).
    pub fn median_period_s(&self) -> f64 {
        let mut d: Vec<f64> = self.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return 0.0;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    }

    /// Rows `keep` of the log, in that order, as a new log (all columns alike; time kept as
    /// recorded).
    pub fn rows(&self, keep: &[usize]) -> RunLog {
        let pick = |v: &Vec<f64>| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        let pick_o = |v: &Option<Vec<f64>>| v.as_ref().map(pick);
        RunLog {
            t_s: pick(&self.t_s),
            x_mm: pick_o(&self.x_mm),
            radial_depth_mm: pick(&self.radial_depth_mm),
            axial_depth_mm: pick(&self.axial_depth_mm),
            spindle_rpm: pick(&self.spindle_rpm),
            programmed_feed_mm_min: pick_o(&self.programmed_feed_mm_min),
            override_cmd_pct: pick_o(&self.override_cmd_pct),
            override_applied_pct: pick_o(&self.override_applied_pct),
            feed_mm_min: pick(&self.feed_mm_min),
            force_n: pick_o(&self.force_n),
            power_w: pick_o(&self.power_w),
            wear_vb_um: pick_o(&self.wear_vb_um),
            phase: self
                .phase
                .as_ref()
                .map(|v| keep.iter().map(|&i| v[i].clone()).collect()),
            sample_advance: self
                .sample_advance
                .as_ref()
                .map(|v| keep.iter().map(|&i| v[i]).collect()),
            board_feed_mm_min: self
                .board_feed_mm_min
                .as_ref()
                .map(|v| keep.iter().map(|&i| v[i]).collect()),
            plant_truth: self.plant_truth,
            row_flags: self
                .row_flags
                .as_ref()
                .map(|v| keep.iter().map(|&i| v[i]).collect()),
        }
    }

    /// Rows `range` of the log as a new log.
    pub fn slice(&self, range: std::ops::Range<usize>) -> RunLog {
        self.rows(&range.collect::<Vec<usize>>())
    }

    /// Check lengths, time order and value ranges; `file` is used in errors only.
    pub fn validate(&self, file: &Path) -> Result<(), RunLogError> {
        let n = self.t_s.len();
        let invalid = |message: String| RunLogError::Invalid {
            file: file.to_path_buf(),
            message,
        };
        if n < 10 {
            return Err(invalid(format!("{n} data rows; at least 10 are needed")));
        }
        if self.force_n.is_none() && self.power_w.is_none() {
            return Err(invalid(
                "neither `power_w` nor `force_n` present: one measured channel is required".into(),
            ));
        }
        let lens = [
            self.radial_depth_mm.len(),
            self.axial_depth_mm.len(),
            self.spindle_rpm.len(),
            self.feed_mm_min.len(),
        ];
        if lens.iter().any(|&l| l != n) {
            return Err(invalid("columns have different lengths".into()));
        }
        // Non-finite values (a log built in code; the CSV reader refuses them already).
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![
            ("t_s", &self.t_s),
            ("radial_depth_mm", &self.radial_depth_mm),
            ("axial_depth_mm", &self.axial_depth_mm),
            ("spindle_rpm", &self.spindle_rpm),
            ("feed_mm_min", &self.feed_mm_min),
        ];
        for (name, c) in [("power_w", &self.power_w), ("force_n", &self.force_n)] {
            if let Some(c) = c {
                cols.push((name, c));
            }
        }
        for (name, c) in &cols {
            if let Some((i, v)) = c.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(invalid(format!(
                    "line {}: column `{name}` is {v}: every value must be a finite number",
                    i + 2
                )));
            }
        }
        // A dead or constant measured channel carries nothing to compare.
        for (name, c) in [("power_w", &self.power_w), ("force_n", &self.force_n)] {
            if let Some(c) = c {
                let (lo, hi) = c
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                if hi - lo <= 1e-12 * hi.abs().max(1.0) {
                    return Err(invalid(format!(
                        "column `{name}` is constant ({lo} on all {n} data rows, lines 2..={}): \
                         a dead or disconnected channel; nothing can be compared on it",
                        n + 1
                    )));
                }
            }
        }
        for (i, w) in self.t_s.windows(2).enumerate() {
            if w[1] <= w[0] {
                return Err(RunLogError::BadValue {
                    file: file.to_path_buf(),
                    line: i as u64 + 3,
                    col: 1,
                    column: "t_s".into(),
                    message: format!("time {} is not after the previous row's {}", w[1], w[0]),
                });
            }
        }
        Ok(())
    }

    /// Gaps in time longer than `max_periods` median periods: `(row, gap_s)` with `row` the
    /// first row after the gap (0-based data row).
    pub fn gaps(&self, max_periods: f64) -> Vec<(usize, f64)> {
        let p = self.median_period_s();
        self.t_s
            .windows(2)
            .enumerate()
            .filter(|(_, w)| w[1] - w[0] > max_periods * p)
            .map(|(i, w)| (i + 1, w[1] - w[0]))
            .collect()
    }

    /// Warnings about values that look like the wrong unit (a factor 10³ off): power in kW,
    /// speed in krpm, depths in m or µm, force in kN. Each names the column, a row (line)
    /// and the value.
    pub fn unit_warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let cut: Vec<usize> = (0..self.len())
            .filter(|&i| self.radial_depth_mm[i] > 0.0 && self.axial_depth_mm[i] > 0.0)
            .collect();
        let median = |v: &[f64], rows: &[usize]| -> Option<(f64, usize)> {
            let mut x: Vec<(f64, usize)> = rows.iter().map(|&i| (v[i], i)).collect();
            if x.is_empty() {
                return None;
            }
            x.sort_by(|a, b| a.0.total_cmp(&b.0));
            Some(x[x.len() / 2])
        };
        let all: Vec<usize> = (0..self.len())
            .filter(|&i| self.spindle_rpm[i] > 0.0)
            .collect();
        let mut check = |name: &str, v: &[f64], rows: &[usize], lo: f64, hi: f64, unit: &str| {
            if let Some((m, i)) = median(v, rows) {
                if m != 0.0 && (m.abs() < lo || m.abs() > hi) {
                    w.push(format!(
                        "column `{name}`: median {m} (e.g. line {}) is outside {lo}..{hi} {unit}: \
                         a unit off by 10³?",
                        i + 2
                    ));
                }
            }
        };
        if let Some(p) = &self.power_w {
            check("power_w", p, &all, 20.0, 2e5, "W");
        }
        if let Some(f) = &self.force_n {
            check("force_n", f, &cut, 2.0, 1e5, "N");
        }
        check("spindle_rpm", &self.spindle_rpm, &all, 5.0, 1e5, "rpm");
        check(
            "radial_depth_mm",
            &self.radial_depth_mm,
            &cut,
            0.01,
            200.0,
            "mm",
        );
        check(
            "axial_depth_mm",
            &self.axial_depth_mm,
            &cut,
            0.01,
            200.0,
            "mm",
        );
        w
    }

    /// Write the log as CSV in the run-log schema (present optional columns only).
    pub fn write_csv(&self, path: &Path) -> Result<(), RunLogError> {
        let io = |e: &dyn std::fmt::Display| RunLogError::Io {
            file: path.to_path_buf(),
            reason: e.to_string(),
        };
        let mut w = csv::Writer::from_path(path).map_err(|e| io(&e))?;
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![("t_s", &self.t_s)];
        if let Some(v) = &self.x_mm {
            cols.push(("x_mm", v));
        }
        cols.push(("radial_depth_mm", &self.radial_depth_mm));
        cols.push(("axial_depth_mm", &self.axial_depth_mm));
        cols.push(("spindle_rpm", &self.spindle_rpm));
        for (name, v) in [
            ("programmed_feed_mm_min", &self.programmed_feed_mm_min),
            ("override_cmd_pct", &self.override_cmd_pct),
            ("override_applied_pct", &self.override_applied_pct),
        ] {
            if let Some(v) = v {
                cols.push((name, v));
            }
        }
        cols.push(("feed_mm_min", &self.feed_mm_min));
        for (name, v) in [
            ("force_n", &self.force_n),
            ("power_w", &self.power_w),
            ("wear_vb_um", &self.wear_vb_um),
        ] {
            if let Some(v) = v {
                cols.push((name, v));
            }
        }
        let mut header: Vec<&str> = cols.iter().map(|c| c.0).collect();
        if self.phase.is_some() {
            header.push("phase");
        }
        w.write_record(&header).map_err(|e| io(&e))?;
        for i in 0..self.len() {
            let mut rec: Vec<String> = cols.iter().map(|c| format!("{}", c.1[i])).collect();
            if let Some(p) = &self.phase {
                rec.push(p[i].clone());
            }
            w.write_record(&rec).map_err(|e| io(&e))?;
        }
        w.flush().map_err(|e| io(&e))
    }
}

/// Run-log records as a [`RunLog`], with the engagement they carry. The simulator's truth
/// columns are preferred where present (true position, the drive's actual feed); the
/// engagement (`radial_depth_mm`, `axial_depth_mm`) must be in every row — a production log
/// (`acc run`) has none, and the error ([`RunLogError::MissingEngagement`]) says which
/// columns and lines and what to add. A cell a period did not have (the override in an
/// arming period, the force in a period whose read failed) carries the previous row's
/// value.
pub fn from_records(rows: &[acc_runtime::RunRecord], path: &Path) -> Result<RunLog, RunLogError> {
    from_records_with(rows, path, None)
}

/// [`from_records`], with the engagement rebuilt from the workpiece when `engagement` is
/// given: every row's radial and axial depth come from [`PathEngagement::at`] at the path
/// travelled since the first row (the production column `x_mm`, placed at `--x0-mm`; a
/// simulator's log with `x_true_mm` in every row places itself by that), and the log's own
/// depth columns, if any, are not used. `x_mm` must then be in every row.
pub fn from_records_with(
    rows: &[acc_runtime::RunRecord],
    path: &Path,
    engagement: Option<&PathEngagement>,
) -> Result<RunLog, RunLogError> {
    let column_no = |name: &str| {
        acc_runtime::record::COLUMNS
            .iter()
            .position(|c| *c == name)
            .map_or(0, |i| i + 1)
    };
    let (radial, axial, x) = match engagement {
        None => {
            let missing: Vec<usize> = rows
                .iter()
                .enumerate()
                .filter(|(_, r)| r.radial_depth_mm.is_none() || r.axial_depth_mm.is_none())
                .map(|(i, _)| i)
                .collect();
            if let (Some(&first), Some(&last)) = (missing.first(), missing.last()) {
                return Err(RunLogError::MissingEngagement {
                    file: path.to_path_buf(),
                    line: first as u64 + 2,
                    last_line: last as u64 + 2,
                    empty_rows: missing.len(),
                    rows: rows.len(),
                    radial_col: column_no("radial_depth_mm"),
                    axial_col: column_no("axial_depth_mm"),
                    x_col: column_no("x_mm"),
                });
            }
            let radial = rows.iter().map(|r| r.radial_depth_mm.unwrap_or(0.0));
            let axial = rows.iter().map(|r| r.axial_depth_mm.unwrap_or(0.0));
            let x: Vec<f64> = carry(rows, |r| r.x_true_mm.or(r.x_mm));
            (radial.collect::<Vec<f64>>(), axial.collect::<Vec<f64>>(), x)
        }
        Some(eng) => {
            let mut radial = Vec::with_capacity(rows.len());
            let mut axial = Vec::with_capacity(rows.len());
            let mut x = Vec::with_capacity(rows.len());
            // The path travelled since the first read (see `PathEngagement`). A simulator's
            // log (`x_true_mm` in every row) knows where its tool was: workpiece
            // coordinates, placed without `--x0-mm`.
            let first = rows.first().and_then(|r| r.x_mm).unwrap_or(0.0);
            let truth = rows.iter().all(|r| r.x_true_mm.is_some());
            for (i, r) in rows.iter().enumerate() {
                let travel = if truth {
                    r.x_true_mm.map(|x| x - eng.x0_mm)
                } else {
                    r.x_mm.map(|xm| xm - first)
                };
                let Some(xm) = travel else {
                    return Err(RunLogError::BadValue {
                        file: path.to_path_buf(),
                        line: i as u64 + 2,
                        col: column_no("x_mm"),
                        column: "x_mm".into(),
                        message: format!(
                            "empty: the engagement from the workpiece `{}` needs the path position in every row",
                            eng.source.display()
                        ),
                    });
                };
                let e = eng.at(xm);
                let (d, ap) = (e.radial_mm, e.axial_mm);
                radial.push(d);
                axial.push(ap);
                x.push(xm + eng.x0_mm);
            }
            (radial, axial, x)
        }
    };
    let row_flags: Vec<RowFlags> = rows
        .iter()
        .zip(radial.iter().zip(&axial))
        .map(|(r, (d, ap))| RowFlags::of_record(r, *d > 0.0 && *ap > 0.0))
        .collect();
    let power = |r: &acc_runtime::RunRecord| r.power_w;
    let force = |r: &acc_runtime::RunRecord| r.force_n;
    let has =
        |f: &dyn Fn(&acc_runtime::RunRecord) -> Option<f64>| rows.iter().any(|r| f(r).is_some());
    Ok(RunLog {
        t_s: rows.iter().map(|r| r.t_s).collect(),
        x_mm: Some(x),
        radial_depth_mm: radial,
        axial_depth_mm: axial,
        spindle_rpm: carry(rows, |r| r.spindle_rpm),
        programmed_feed_mm_min: Some(carry(rows, |r| r.programmed_feed_mm_min)),
        override_cmd_pct: Some(carry(rows, |r| {
            r.override_cmd_pct.or(r.override_applied_pct).map(f64::from)
        })),
        override_applied_pct: Some(carry_back(rows, |r| {
            r.override_applied_pct
                .filter(|_| !r.flags.split(';').any(crate::dead::guard_held))
                .map(f64::from)
        })),
        feed_mm_min: carry(rows, |r| r.feed_true_mm_min.or(r.feed_mm_min)),
        force_n: has(&force).then(|| carry(rows, force)),
        power_w: has(&power).then(|| carry(rows, power)),
        wear_vb_um: None,
        phase: None,
        sample_advance: {
            let adv: Vec<u32> = rows.iter().map(|r| sample_advance(&r.flags)).collect();
            adv.iter().any(|&a| a != 1).then_some(adv)
        },
        // A log with the plant's truth ran its board in the same process, in lockstep: no
        // write can race its tick, and its feeds are left unread.
        board_feed_mm_min: (!rows.iter().all(|r| r.x_true_mm.is_some())
            && rows.iter().any(|r| r.board_feed_mm_min.is_some()))
        .then(|| {
            rows.iter()
                .zip(&row_flags)
                .map(|(r, f)| {
                    let used = !f.has(RowFlags::NO_STATUS | RowFlags::SKIPPED)
                        && !f.has(RowFlags::HELD | RowFlags::IMPLAUSIBLE);
                    r.board_feed_mm_min.filter(|v| used && v.is_finite())
                })
                .collect()
        }),
        plant_truth: !rows.is_empty() && rows.iter().all(|r| r.x_true_mm.is_some()),
        row_flags: Some(row_flags),
    })
}

/// Board samples a row's power read moved on from the previous row's, from its flags
/// (`seq_repeat`: 0, `seq_skip:<n>`: n, otherwise 1). A row whose status read failed
/// (`link:<kind>`), that the ticker skipped (`skipped`: no cycle ran), or whose read the
/// line guard held (`implausible:<register>`, [`crate::dead::guard_held`]) read nothing
/// the loop used: 0 (the next used read's `seq_skip` counts the samples since the last
/// used read, the dead rows' included). Counted 1, each held read put every later row a
/// board period ahead of the sample it read.
fn sample_advance(flags: &str) -> u32 {
    flags
        .split(';')
        .find_map(|f| match f {
            "seq_repeat" | "skipped" => Some(0),
            _ if f.starts_with("link:") || f.starts_with("implausible:") => Some(0),
            _ if crate::dead::guard_held(f) => Some(0),
            _ => f.strip_prefix("seq_skip:").and_then(|n| n.parse().ok()),
        })
        .unwrap_or(1)
}

/// Read a run log from a CSV file; see the module docs for the columns.
pub fn read_csv(path: &Path) -> Result<RunLog, RunLogError> {
    read_csv_with(path, None)
}

/// [`read_csv`], with the engagement of a run log (schema v1/v2) rebuilt from the workpiece
/// when `engagement` is given ([`from_records_with`]).
pub fn read_csv_with(
    path: &Path,
    engagement: Option<&PathEngagement>,
) -> Result<RunLog, RunLogError> {
    let file = std::fs::File::open(path).map_err(|e| RunLogError::Io {
        file: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    read_csv_from_with(file, path, engagement)
}

/// Read a run log from any reader; `path` is used in errors only. A log written by `acc sim`,
/// `acc run` or `acc board-sim` (run-log schema v2, or v1) is read as typed records
/// ([`acc_runtime::record::read_run_log`]) and converted with [`from_records`]; any other CSV
/// is read column by column (the importers' layout).
pub fn read_csv_from(reader: impl std::io::Read, path: &Path) -> Result<RunLog, RunLogError> {
    read_csv_from_with(reader, path, None)
}

/// [`read_csv_from`] with an optional [`PathEngagement`]: a run log written by `acc`
/// then takes its engagement from the workpiece at `x_mm` ([`from_records_with`]). Any
/// other CSV must carry its own depth columns, and giving a workpiece for it is an error.
pub fn read_csv_from_with(
    mut reader: impl std::io::Read,
    path: &Path,
    engagement: Option<&PathEngagement>,
) -> Result<RunLog, RunLogError> {
    let mut text = String::new();
    reader
        .read_to_string(&mut text)
        .map_err(|e| RunLogError::Io {
            file: path.to_path_buf(),
            reason: e.to_string(),
        })?;
    let first = text.lines().next().unwrap_or("");
    if acc_runtime::record::detect_schema(first.split(',').map(str::trim)).is_some() {
        let rows = acc_runtime::record::read_run_log(text.as_bytes()).map_err(|e| {
            RunLogError::Invalid {
                file: path.to_path_buf(),
                message: e.to_string(),
            }
        })?;
        return from_records_with(&rows, path, engagement);
    }
    if let Some(eng) = engagement {
        return Err(RunLogError::Invalid {
            file: path.to_path_buf(),
            message: format!(
                "line 1: not a run log written by `acc` (schema v1/v2: `t_s,period,…,state,…`): the workpiece `{}` rebuilds the engagement of `acc run` logs only; give a CSV with `radial_depth_mm` and `axial_depth_mm` without `--workpiece`",
                eng.source.display()
            ),
        });
    }
    let mut csv = acc_spindle::datasets::CsvFile::from_reader(text.as_bytes(), path)?;
    let mut idx_req = [0usize; 5];
    for (k, name) in REQUIRED.iter().enumerate() {
        idx_req[k] = csv.find(name).ok_or_else(|| RunLogError::MissingColumn {
            file: path.to_path_buf(),
            column: name.to_string(),
            required: format!("{} and one of power_w, force_n", REQUIRED.join(", ")),
        })?;
    }
    let optional = [
        "x_mm",
        "programmed_feed_mm_min",
        "override_cmd_pct",
        "override_applied_pct",
        "force_n",
        "power_w",
        "wear_vb_um",
    ];
    let idx_opt: Vec<Option<usize>> = optional.iter().map(|n| csv.find(n)).collect();
    let idx_phase = csv.find("phase");
    let mut req: [Vec<f64>; 5] = Default::default();
    let mut opt: Vec<Vec<f64>> = vec![Vec::new(); optional.len()];
    let mut phase = Vec::new();
    let mut rows_line = Vec::new();
    for row in csv.rows() {
        let row = row?;
        rows_line.push(row.line());
        let cell = |col: usize, name: &str| -> Result<f64, RunLogError> {
            let v = row.num(col)?;
            let nonneg = matches!(
                name,
                "radial_depth_mm" | "axial_depth_mm" | "spindle_rpm" | "feed_mm_min"
            );
            if nonneg && v < 0.0 {
                return Err(row
                    .bad(col, format!("{v} is negative; allowed >= 0"))
                    .into());
            }
            Ok(v)
        };
        for (k, name) in REQUIRED.iter().enumerate() {
            req[k].push(cell(idx_req[k], name)?);
        }
        for (k, name) in optional.iter().enumerate() {
            if let Some(c) = idx_opt[k] {
                // An optional cell may be empty (e.g. `x_mm` on a real machine); a column
                // that is empty throughout is treated as absent.
                if row.text(c).is_empty() {
                    opt[k].push(f64::NAN);
                } else {
                    opt[k].push(cell(c, name)?);
                }
            }
        }
        if let Some(c) = idx_phase {
            phase.push(row.text(c).to_string());
        }
    }
    let take = |k: usize| -> Result<Option<Vec<f64>>, RunLogError> {
        let Some(c) = idx_opt[k] else { return Ok(None) };
        let v = &opt[k];
        if v.iter().all(|x| x.is_nan()) {
            return Ok(None);
        }
        if let Some(i) = v.iter().position(|x| x.is_nan()) {
            return Err(RunLogError::BadValue {
                file: path.to_path_buf(),
                line: rows_line.get(i).copied().unwrap_or(0),
                col: c + 1,
                column: optional[k].to_string(),
                message: "empty cell in a column that has values elsewhere".into(),
            });
        }
        Ok(Some(v.clone()))
    };
    let [t_s, feed_mm_min, spindle_rpm, radial_depth_mm, axial_depth_mm] = req;
    let log = RunLog {
        t_s,
        x_mm: take(0)?,
        radial_depth_mm,
        axial_depth_mm,
        spindle_rpm,
        programmed_feed_mm_min: take(1)?,
        override_cmd_pct: take(2)?,
        override_applied_pct: take(3)?,
        feed_mm_min,
        force_n: take(4)?,
        power_w: take(5)?,
        wear_vb_um: take(6)?,
        phase: idx_phase.map(|_| phase),
        sample_advance: None,
        board_feed_mm_min: None,
        plant_truth: false,
        row_flags: None,
    };
    log.validate(path)?;
    Ok(log)
}

#[path = "runlog_carry.rs"]
mod carry;
use carry::{carry, carry_back};

#[cfg(test)]
#[path = "runlog_tests.rs"]
mod tests;
