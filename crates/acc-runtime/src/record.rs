//! The run log: one [`RunRecord`] per control period, the same typed record for every
//! writer (`acc sim`, `acc run`, `acc board-sim`) and every reader (`acc discrepancy`, the
//! summaries, the tests).
//!
//! The CSV layout is schema **v4** (documented column by column with units in
//! `docs/runlog.md`): one header line with the names of [`COLUMNS`], then one row per period,
//! skipped and late periods included (flagged in `flags`). A value the writer cannot know —
//! the true force and depth of cut on a real machine, the controller's gains in a period
//! where it was not stepped — is an **empty cell**, read back as `None`, never parsed as a
//! number. Rows are flushed one by one, so a crash leaves a complete log up to the last
//! period.
//!
//! Logs of the previous schema (v1: 20 columns, `t_s,x_mm,radial_depth_mm,…,valid,
//! saturation`) still read: [`read_run_log`] recognises them by their header and migrates
//! each row ([`migrate_v1`]).
//!
//! ```
//! use acc_runtime::record::{read_run_log, RunLogWriter, RunRecord};
//! let mut buf = Vec::new();
//! {
//!     let mut w = RunLogWriter::new(&mut buf).unwrap();
//!     let rec = RunRecord { t_s: 0.1, period: 1, force_n: Some(812.5), ..RunRecord::default() };
//!     w.write(&rec).unwrap();
//! }
//! let back = read_run_log(buf.as_slice()).unwrap();
//! assert_eq!(back[0].force_n, Some(812.5));
//! // What the writer did not know stays unknown.
//! assert_eq!(back[0].radial_depth_mm, None);
//! ```

use std::io::{Read, Write};

use serde::{Deserialize, Serialize};

/// Version of the CSV layout written by [`RunLogWriter`].
pub const SCHEMA_VERSION: u32 = 4;

/// One control period, as logged. Field order is the CSV column order ([`COLUMNS`]).
///
/// Columns up to `feed_hold` come from the production loop (board status, force source,
/// fault policy, control law) and are the same for every writer. The last five (`x_true_mm`
/// … `feed_true_mm_min`) are the plant's truth and are written only by the simulator; a real
/// machine leaves them empty.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RunRecord {
    /// Time of the period's status read, s since the run began (machine time: wall time ×
    /// `time_scale` under `acc run`, the stepped clock under `acc sim`).
    pub t_s: f64,
    /// Period index, 0-based; consecutive (a skipped period still has its row).
    pub period: u64,
    /// What was unusual in this period, `;`-separated (empty when nothing): `skipped`
    /// (no cycle ran: the ticker overran), `late` (the tick came after its deadline),
    /// `link:<kind>` (the status read failed), `write:<kind>` (the previous writes failed),
    /// `force_invalid`, `fault` (a fault input: the command could only go down),
    /// `rearm:<reason>`, `breakage:drop` / `breakage:spike` (the breakage watch requested
    /// feed hold this period), `no_log` (reserved).
    pub flags: String,
    /// Lateness of the tick against its deadline, ms (0 on a stepped clock).
    pub late_ms: f64,
    /// Active tool number (`TOOL_NUMBER`, board protocol v2), empty when unknown.
    pub tool: Option<u16>,
    /// Running program number (`PROGRAM_NUMBER`, v2), empty when unknown.
    pub program: Option<u16>,
    /// Active block number (`BLOCK_NUMBER`, v2), empty when unknown.
    pub block: Option<u16>,
    /// Path position, mm: the integral of the period's feed since the run began (programmed
    /// feed × applied override, 0 in feed hold; [`RunRecord::board_feed_mm_min`] is not
    /// integrated).
    pub x_mm: Option<f64>,
    /// Spindle speed, rpm.
    pub spindle_rpm: Option<f64>,
    /// Programmed feed of the active block, mm/min (100 % override).
    pub programmed_feed_mm_min: Option<f64>,
    /// Actual feed of the period as the loop used it, mm/min (see `x_mm`).
    pub feed_mm_min: Option<f64>,
    /// Spindle input power as the board reported it, W.
    pub power_w: Option<f64>,
    /// Estimated mean cutting force of the period (the force source's sample), N; empty
    /// when the source had no usable sample (no status, NaN or implausible power).
    pub force_n: Option<f64>,
    /// The policy used the force sample as valid.
    pub force_valid: bool,
    /// Force reference Fr, N.
    pub force_ref_n: Option<f64>,
    /// Estimated process gain Kc_hat, N/(mm/min) (empty when the law was not stepped).
    pub kc_hat: Option<f64>,
    /// Proportional gain, (mm/min)/N.
    pub kp: Option<f64>,
    /// Integral gain, (mm/min)/(N·s).
    pub ki: Option<f64>,
    /// Force error Fr − Fc, N (seed 002 eq. 2).
    pub error_n: Option<f64>,
    /// Law mode (`adaptive_pi`, `fixed_pi`, `adaptive_integral`, `baseline`), empty when the
    /// law was not stepped.
    pub mode: String,
    /// Saturation after the step (`none`, `low`, `high`), empty when not stepped.
    pub saturation: String,
    /// Override written to the board this period, percent (empty: nothing written).
    pub override_cmd_pct: Option<u16>,
    /// `HEARTBEAT` written with that override (empty: nothing written).
    pub heartbeat: Option<u16>,
    /// Override in force on the PMC inputs at the read (`OVERRIDE_APPLIED`), percent.
    pub override_applied_pct: Option<u16>,
    /// Position of the operator's override knob (`OPERATOR_OVERRIDE`), percent.
    pub override_operator_pct: Option<u16>,
    /// Policy state after the period: `idle`, `active` or the latched release reason
    /// (`link_lost`, `watchdog`, `overload`, …).
    pub state: String,
    /// Alarms in force, bit code: 0 link lost, 1 power invalid, 2 watchdog, 3 board reset,
    /// 4 overload.
    pub alarms: u8,
    /// Feed hold requested by the controller.
    pub feed_hold: bool,
    /// Measured delay from an override command to its echo in `OVERRIDE_APPLIED`, periods
    /// (1 = as designed; empty until the command has moved enough to tell). Schema v3.
    #[serde(default)]
    pub echo_delay_periods: Option<u32>,
    /// The same in `ACTUAL_FEED` (v2 boards), periods. Schema v3.
    #[serde(default)]
    pub feed_echo_periods: Option<u32>,
    /// How far the sample's `SAMPLE_SEQ` lags the freshest seen against the period count,
    /// periods. Schema v3.
    #[serde(default)]
    pub seq_lag_periods: Option<u32>,
    /// Extra periods of dead time the law's gains tolerate (empty for a law without a
    /// model). Schema v3.
    #[serde(default)]
    pub delay_margin_periods: Option<u32>,
    /// `ACTUAL_FEED` as the board reported it with the period's sample (v2 boards), mm/min:
    /// the NC's path feed over the sampled period, after override, 0 in feed hold. Empty
    /// without a read, or on a v1 board. Tells which override drove the sampled period
    /// where a write raced the board's tick (`acc_ident`'s replay). Schema v4.
    #[serde(default)]
    pub board_feed_mm_min: Option<f64>,
    /// Simulator only: true tool-centre position along the path, mm.
    pub x_true_mm: Option<f64>,
    /// Simulator only: engaged radial depth of cut at the period's end, mm (0 in air).
    pub radial_depth_mm: Option<f64>,
    /// Simulator only: axial depth of cut at the period's end, mm.
    pub axial_depth_mm: Option<f64>,
    /// Simulator only: true mean cutting force over what the sensor looked at, N.
    pub force_true_n: Option<f64>,
    /// Simulator only: mean actual feed of the feed drive over the period, mm/min.
    pub feed_true_mm_min: Option<f64>,
}

/// Column names of schema v4, in order (the [`RunRecord`] fields).
pub const COLUMNS: [&str; 38] = [
    "t_s",
    "period",
    "flags",
    "late_ms",
    "tool",
    "program",
    "block",
    "x_mm",
    "spindle_rpm",
    "programmed_feed_mm_min",
    "feed_mm_min",
    "power_w",
    "force_n",
    "force_valid",
    "force_ref_n",
    "kc_hat",
    "kp",
    "ki",
    "error_n",
    "mode",
    "saturation",
    "override_cmd_pct",
    "heartbeat",
    "override_applied_pct",
    "override_operator_pct",
    "state",
    "alarms",
    "feed_hold",
    "echo_delay_periods",
    "feed_echo_periods",
    "seq_lag_periods",
    "delay_margin_periods",
    "board_feed_mm_min",
    "x_true_mm",
    "radial_depth_mm",
    "axial_depth_mm",
    "force_true_n",
    "feed_true_mm_min",
];

/// Columns added in schema v3 (a v2 log without them reads them as empty).
pub const SINCE_V3: [&str; 4] = [
    "echo_delay_periods",
    "feed_echo_periods",
    "seq_lag_periods",
    "delay_margin_periods",
];

/// Columns added in schema v4 (a v2 or v3 log without them reads them as empty).
pub const SINCE_V4: [&str; 1] = ["board_feed_mm_min"];

/// Column names of the schema as a slice.
pub fn columns() -> &'static [&'static str] {
    &COLUMNS
}

impl RunRecord {
    /// Add a flag to `flags` (`;`-separated).
    pub fn flag(&mut self, f: &str) {
        if !self.flags.is_empty() {
            self.flags.push(';');
        }
        self.flags.push_str(f);
    }

    /// Whether `flags` holds `f` (a whole item, or an item starting with `f:`).
    pub fn has_flag(&self, f: &str) -> bool {
        self.flags
            .split(';')
            .any(|x| x == f || x.strip_prefix(f).is_some_and(|r| r.starts_with(':')))
    }

    /// This record with the simulator-only columns (`x_true_mm` … `feed_true_mm_min`) taken
    /// from `truth`.
    pub fn with_truth_of(self, truth: &RunRecord) -> RunRecord {
        RunRecord {
            x_true_mm: truth.x_true_mm,
            radial_depth_mm: truth.radial_depth_mm,
            axial_depth_mm: truth.axial_depth_mm,
            force_true_n: truth.force_true_n,
            feed_true_mm_min: truth.feed_true_mm_min,
            ..self
        }
    }

    /// The row of a period in which no cycle ran (the ticker skipped it): time and index,
    /// flagged `skipped`, everything else unknown.
    pub fn skipped(period: u64, t_s: f64, state: &str) -> Self {
        let mut r = RunRecord {
            t_s,
            period,
            state: state.to_string(),
            ..RunRecord::default()
        };
        r.flag("skipped");
        r
    }
}

/// Error of the run-log writer and reader.
#[derive(Debug, thiserror::Error)]
pub enum RunLogError {
    /// Underlying I/O.
    #[error("run log: {0}")]
    Io(#[from] std::io::Error),
    /// Malformed CSV (wrong number of fields, bad quoting).
    #[error("run log line {line}: {message}")]
    Csv {
        /// 1-based line number (the header is line 1).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A field that does not parse, or a missing column.
    #[error("run log line {line}: column `{column}`: {message}")]
    Field {
        /// 1-based line number (the header is line 1).
        line: u64,
        /// Column name.
        column: String,
        /// What is wrong.
        message: String,
    },
}

impl From<csv::Error> for RunLogError {
    fn from(e: csv::Error) -> Self {
        let line = e.position().map_or(0, |p| p.line());
        match e.into_kind() {
            csv::ErrorKind::Io(io) => RunLogError::Io(io),
            csv::ErrorKind::Deserialize { pos, err } => RunLogError::Field {
                line: pos.map_or(line, |p| p.line()),
                column: err
                    .field()
                    .and_then(|i| columns().get(i as usize))
                    .map_or_else(|| "?".to_string(), |c| (*c).to_string()),
                message: err.kind().to_string(),
            },
            other => RunLogError::Csv {
                line,
                message: format!("{other:?}"),
            },
        }
    }
}

/// Writes [`RunRecord`]s as CSV of the current schema ([`SCHEMA_VERSION`]) to any `Write`,
/// flushing every row.
#[derive(Debug)]
pub struct RunLogWriter<W: Write> {
    csv: csv::Writer<W>,
}

impl<W: Write> RunLogWriter<W> {
    /// Write the header line.
    pub fn new(out: W) -> Result<Self, RunLogError> {
        let mut csv = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(out);
        csv.write_record(columns())?;
        csv.flush()?;
        Ok(RunLogWriter { csv })
    }

    /// Write one record and flush it.
    pub fn write(&mut self, rec: &RunRecord) -> Result<(), RunLogError> {
        self.csv.serialize(rec)?;
        self.csv.flush()?;
        Ok(())
    }
}

/// Which schema a header line belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Schema {
    /// The previous 20-column layout (`valid`, no `period`).
    V1,
    /// [`COLUMNS`] (v2; v3 adds its four delay columns, v4 the board's feed).
    V2,
}

/// Recognise the schema of a run log from its header fields.
pub fn detect_schema<'a>(header: impl IntoIterator<Item = &'a str>) -> Option<Schema> {
    let h: Vec<&str> = header.into_iter().collect();
    let has = |c: &str| h.contains(&c);
    if has("period") && has("force_valid") && has("state") {
        Some(Schema::V2)
    } else if has("t_s") && has("valid") && has("override_cmd_pct") && has("kc_hat") {
        Some(Schema::V1)
    } else {
        None
    }
}

/// Read a run log of schema v4, v3 or v2, or of schema v1 (migrated row by row).
pub fn read_run_log(input: impl Read) -> Result<Vec<RunRecord>, RunLogError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(input);
    let headers = rdr.headers()?.clone();
    match detect_schema(headers.iter()) {
        Some(Schema::V2) => {
            let later = |c: &&&str| SINCE_V3.contains(c) || SINCE_V4.contains(c);
            for c in columns().iter().filter(|c| !later(c)) {
                if !headers.iter().any(|h| h == *c) {
                    return Err(RunLogError::Field {
                        line: 1,
                        column: (*c).to_string(),
                        message: "missing column (run log schema v2 to v4)".into(),
                    });
                }
            }
            let mut out = Vec::new();
            for r in rdr.deserialize::<RunRecord>() {
                out.push(r?);
            }
            Ok(out)
        }
        Some(Schema::V1) => v1::read(rdr, &headers),
        None => Err(RunLogError::Field {
            line: 1,
            column: "(header)".into(),
            message: format!(
                "not an acc run log: expected the v2 columns ({}) or the v1 columns",
                columns().join(",")
            ),
        }),
    }
}

pub use v1::migrate as migrate_v1;
pub use v1::RowV1;

/// The previous schema and its migration.
pub mod v1 {
    use super::{RunLogError, RunRecord};

    /// Column names of schema v1, in order.
    pub const COLUMNS: [&str; 20] = [
        "t_s",
        "x_mm",
        "radial_depth_mm",
        "axial_depth_mm",
        "spindle_rpm",
        "programmed_feed_mm_min",
        "override_cmd_pct",
        "override_applied_pct",
        "feed_mm_min",
        "force_n",
        "force_true_n",
        "force_ref_n",
        "power_w",
        "kc_hat",
        "kp",
        "ki",
        "mode",
        "error_n",
        "valid",
        "saturation",
    ];

    /// One row of schema v1 as written (numbers may be `NaN` where v1 had no value).
    #[derive(Debug, Clone, PartialEq, Default)]
    pub struct RowV1 {
        /// Time at the end of the period, s.
        pub t_s: f64,
        /// Tool centre position, mm.
        pub x_mm: Option<f64>,
        /// Radial depth, mm.
        pub radial_depth_mm: Option<f64>,
        /// Axial depth, mm.
        pub axial_depth_mm: Option<f64>,
        /// Spindle speed, rpm.
        pub spindle_rpm: f64,
        /// Programmed feed, mm/min.
        pub programmed_feed_mm_min: f64,
        /// Override commanded, percent.
        pub override_cmd_pct: u16,
        /// Override applied, percent.
        pub override_applied_pct: u16,
        /// Actual feed, mm/min.
        pub feed_mm_min: f64,
        /// Force the controller saw, N.
        pub force_n: f64,
        /// True force, N.
        pub force_true_n: Option<f64>,
        /// Fr, N.
        pub force_ref_n: f64,
        /// Power, W.
        pub power_w: Option<f64>,
        /// Kc_hat.
        pub kc_hat: f64,
        /// Kp.
        pub kp: f64,
        /// Ki.
        pub ki: f64,
        /// Mode or policy state.
        pub mode: String,
        /// Error, N.
        pub error_n: f64,
        /// Sample valid.
        pub valid: bool,
        /// Saturation.
        pub saturation: String,
    }

    fn finite(x: f64) -> Option<f64> {
        x.is_finite().then_some(x)
    }

    /// Migrate one v1 row (period index `period`) to a v2 record. v1 wrote the policy state
    /// into `mode` when the law was not stepped (`idle`, `link_lost`, …) and `NaN` gains;
    /// those become `state` and empty cells. v1's `x_mm` was the simulator's true position:
    /// it fills both `x_mm` and `x_true_mm` when the row carries a depth (a simulator log).
    pub fn migrate(row: &RowV1, period: u64) -> RunRecord {
        const MODES: [&str; 4] = ["adaptive_pi", "fixed_pi", "adaptive_integral", "baseline"];
        let stepped = MODES.contains(&row.mode.as_str()) && row.kc_hat.is_finite();
        let sim = row.radial_depth_mm.is_some();
        let mut r = RunRecord {
            t_s: row.t_s,
            period,
            x_mm: row.x_mm,
            spindle_rpm: finite(row.spindle_rpm),
            programmed_feed_mm_min: finite(row.programmed_feed_mm_min),
            feed_mm_min: finite(row.feed_mm_min),
            power_w: row.power_w,
            force_n: finite(row.force_n),
            force_valid: row.valid,
            force_ref_n: finite(row.force_ref_n),
            kc_hat: stepped.then_some(row.kc_hat),
            kp: stepped.then(|| finite(row.kp)).flatten(),
            ki: stepped.then(|| finite(row.ki)).flatten(),
            error_n: stepped.then(|| finite(row.error_n)).flatten(),
            mode: if stepped {
                row.mode.clone()
            } else {
                String::new()
            },
            saturation: if stepped {
                row.saturation.clone()
            } else {
                String::new()
            },
            override_cmd_pct: Some(row.override_cmd_pct),
            override_applied_pct: Some(row.override_applied_pct),
            state: if stepped {
                "active".into()
            } else {
                row.mode.clone()
            },
            x_true_mm: if sim { row.x_mm } else { None },
            radial_depth_mm: row.radial_depth_mm,
            axial_depth_mm: row.axial_depth_mm,
            force_true_n: row.force_true_n,
            feed_true_mm_min: if sim { finite(row.feed_mm_min) } else { None },
            ..RunRecord::default()
        };
        if !row.valid {
            r.flag("force_invalid");
        }
        r
    }

    fn field(line: u64, column: &str, message: String) -> RunLogError {
        RunLogError::Field {
            line,
            column: column.to_string(),
            message,
        }
    }

    /// Read the v1 rows of `rdr` (its header already read into `headers`) and migrate them.
    pub(super) fn read<R: std::io::Read>(
        mut rdr: csv::Reader<R>,
        headers: &csv::StringRecord,
    ) -> Result<Vec<RunRecord>, RunLogError> {
        let mut pos = [0usize; 20];
        for (i, name) in COLUMNS.iter().enumerate() {
            pos[i] = headers
                .iter()
                .position(|h| h == *name)
                .ok_or_else(|| field(1, name, "missing column (run log schema v1)".into()))?;
        }
        let mut out = Vec::new();
        for (k, rec) in rdr.records().enumerate() {
            let rec = rec?;
            let line = k as u64 + 2;
            let cell = |i: usize| rec.get(pos[i]).unwrap_or("");
            let f = |i: usize| -> Result<Option<f64>, RunLogError> {
                let s = cell(i);
                if s.is_empty() {
                    return Ok(None);
                }
                s.parse::<f64>()
                    .map(Some)
                    .map_err(|e| field(line, COLUMNS[i], format!("`{s}`: {e}")))
            };
            let req = |i: usize| -> Result<f64, RunLogError> {
                f(i)?.ok_or_else(|| field(line, COLUMNS[i], "empty".into()))
            };
            let pct = |i: usize| -> Result<u16, RunLogError> {
                let v = req(i)?;
                if (0.0..=1000.0).contains(&v) {
                    Ok(v.round() as u16)
                } else {
                    Err(field(line, COLUMNS[i], format!("{v} is not a percentage")))
                }
            };
            let row = RowV1 {
                t_s: req(0)?,
                x_mm: f(1)?,
                radial_depth_mm: f(2)?,
                axial_depth_mm: f(3)?,
                spindle_rpm: req(4)?,
                programmed_feed_mm_min: req(5)?,
                override_cmd_pct: pct(6)?,
                override_applied_pct: pct(7)?,
                feed_mm_min: req(8)?,
                force_n: req(9)?,
                force_true_n: f(10)?,
                force_ref_n: req(11)?,
                power_w: f(12)?,
                kc_hat: req(13)?,
                kp: req(14)?,
                ki: req(15)?,
                mode: cell(16).to_string(),
                error_n: req(17)?,
                valid: cell(18) == "1",
                saturation: cell(19).to_string(),
            };
            out.push(migrate(&row, k as u64));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full() -> RunRecord {
        RunRecord {
            t_s: 12.3,
            period: 123,
            flags: "late".into(),
            late_ms: 1.25,
            tool: Some(4),
            program: Some(1234),
            block: Some(56),
            x_mm: Some(45.25),
            spindle_rpm: Some(600.0),
            programmed_feed_mm_min: Some(200.0),
            feed_mm_min: Some(120.0),
            power_w: Some(3456.5),
            force_n: Some(801.5),
            force_valid: true,
            force_ref_n: Some(800.0),
            kc_hat: Some(6.25),
            kp: Some(1.5e-7),
            ki: Some(1.6),
            error_n: Some(-1.5),
            mode: "adaptive_pi".into(),
            saturation: "none".into(),
            override_cmd_pct: Some(70),
            heartbeat: Some(7),
            override_applied_pct: Some(60),
            override_operator_pct: Some(100),
            state: "active".into(),
            alarms: 0b10001,
            feed_hold: true,
            echo_delay_periods: Some(1),
            feed_echo_periods: Some(2),
            seq_lag_periods: Some(0),
            delay_margin_periods: Some(0),
            board_feed_mm_min: Some(119.0),
            x_true_mm: Some(45.2),
            radial_depth_mm: Some(3.0),
            axial_depth_mm: Some(10.0),
            force_true_n: Some(799.0),
            feed_true_mm_min: Some(119.5),
        }
    }

    #[test]
    fn a_v2_log_without_the_delay_columns_reads_them_as_empty() {
        let v2: Vec<&str> = columns()
            .iter()
            .copied()
            .filter(|c| !SINCE_V3.contains(c) && !SINCE_V4.contains(c))
            .collect();
        let mut text = v2.join(",");
        text.push('\n');
        let mut row = vec![""; v2.len()];
        row[0] = "0.1";
        row[1] = "1";
        row[v2.iter().position(|c| *c == "force_valid").expect("column")] = "true";
        row[v2.iter().position(|c| *c == "alarms").expect("column")] = "0";
        row[v2.iter().position(|c| *c == "feed_hold").expect("column")] = "false";
        row[v2.iter().position(|c| *c == "late_ms").expect("column")] = "0";
        text.push_str(&row.join(","));
        text.push('\n');
        let back = read_run_log(text.as_bytes()).expect("a v2 log reads");
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].echo_delay_periods, None);
        assert_eq!(back[0].delay_margin_periods, None);
        assert_eq!(back[0].board_feed_mm_min, None);
    }

    #[test]
    fn the_columns_are_the_record_fields_in_order() {
        let mut buf = Vec::new();
        let mut w = csv::WriterBuilder::new()
            .has_headers(true)
            .from_writer(&mut buf);
        w.serialize(full()).expect("serialize");
        drop(w);
        let text = String::from_utf8(buf).expect("utf8");
        let header = text.lines().next().expect("header");
        assert_eq!(header, columns().join(","));
    }

    #[test]
    fn round_trip_is_exact_and_unknowns_stay_unknown() {
        let a = full();
        let b = RunRecord {
            t_s: 0.2,
            period: 2,
            state: "link_lost".into(),
            ..RunRecord::default()
        };
        let mut buf = Vec::new();
        {
            let mut w = RunLogWriter::new(&mut buf).expect("header");
            w.write(&a).expect("row");
            w.write(&b).expect("row");
        }
        let back = read_run_log(buf.as_slice()).expect("read");
        assert_eq!(back, vec![a, b]);
        let text = String::from_utf8(buf).expect("utf8");
        // The empty record has empty cells, not NaN or 0.
        let last = text.lines().nth(2).expect("row 2");
        assert!(last.starts_with("0.2,2,,0.0,,,,,"), "{last}");
    }

    #[test]
    fn a_bad_cell_names_line_and_column() {
        let mut buf = Vec::new();
        {
            let mut w = RunLogWriter::new(&mut buf).expect("header");
            w.write(&full()).expect("row");
        }
        let text = String::from_utf8(buf)
            .expect("utf8")
            .replace(",801.5,", ",abc,");
        let err = read_run_log(text.as_bytes())
            .expect_err("bad field")
            .to_string();
        assert!(err.contains("line 2") && err.contains("force_n"), "{err}");
    }

    #[test]
    fn a_v1_log_is_migrated() {
        let mut text = v1::COLUMNS.join(",");
        text.push('\n');
        // A simulator row and an `acc run` row whose law was not stepped.
        text.push_str("0.1,1.5,3.0,10.0,600,200,100,100,200,812.5,810.0,800,3000.0,6.0,1e-7,1.6,adaptive_pi,-12.5,1,none\n");
        text.push_str("0.2,,,,600,200,100,100,200,0,,800,,NaN,NaN,NaN,link_lost,NaN,0,none\n");
        let rows = read_run_log(text.as_bytes()).expect("v1 reads");
        assert_eq!(rows.len(), 2);
        let (a, b) = (&rows[0], &rows[1]);
        assert_eq!(a.period, 0);
        assert_eq!(a.radial_depth_mm, Some(3.0));
        assert_eq!(a.x_true_mm, Some(1.5));
        assert_eq!(a.kc_hat, Some(6.0));
        assert_eq!(a.state, "active");
        assert!(a.force_valid && a.flags.is_empty());
        assert_eq!(b.period, 1);
        assert_eq!(b.state, "link_lost");
        assert_eq!((b.kc_hat, b.kp, b.mode.as_str()), (None, None, ""));
        assert!(b.has_flag("force_invalid"));
        assert_eq!(b.x_true_mm, None);
    }

    #[test]
    fn an_unknown_header_is_refused_with_the_expected_columns() {
        let err = read_run_log("a,b,c\n1,2,3\n".as_bytes())
            .expect_err("not a run log")
            .to_string();
        assert!(err.contains("line 1") && err.contains("period"), "{err}");
    }

    #[test]
    fn flags_are_items() {
        let mut r = RunRecord::default();
        r.flag("late");
        r.flag("link:timeout");
        assert_eq!(r.flags, "late;link:timeout");
        assert!(r.has_flag("late") && r.has_flag("link") && !r.has_flag("lin"));
        assert!(RunRecord::skipped(3, 0.3, "active").has_flag("skipped"));
    }
}
