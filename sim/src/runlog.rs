//! The run log: one CSV row per control period, written by the simulator and by the real
//! runtime alike (same schema, see [`COLUMNS`]). Every row is flushed as soon as it is
//! written, so a crash or Ctrl-C leaves a complete log up to the last period.
//!
//! Values the writer does not know (e.g. `force_true_n` on a real machine, `x_mm` when the
//! path position is unknown) are written as empty fields. Numbers have a fixed number of
//! decimals per column, so the same run gives a byte-identical file.
//!
//! ```
//! use acc_sim::runlog::{RunLogRow, RunLogWriter, COLUMNS};
//! let mut buf = Vec::new();
//! {
//!     let mut w = RunLogWriter::new(&mut buf).unwrap();
//!     w.write(&RunLogRow { t_s: 0.1, force_n: 812.5, ..RunLogRow::default() }).unwrap();
//! }
//! let text = String::from_utf8(buf).unwrap();
//! assert!(text.starts_with("t_s,x_mm,radial_depth_mm"));
//! assert_eq!(text.lines().nth(1).unwrap().split(',').count(), COLUMNS.len());
//! ```

use std::io::{Read, Write};

/// Column names, in order.
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

/// One row of the run log (one control period).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunLogRow {
    /// Time at the end of the period, s.
    pub t_s: f64,
    /// Tool centre position along the path, mm (unknown on a real machine: `None`).
    pub x_mm: Option<f64>,
    /// Engaged radial depth, mm (sim only).
    pub radial_depth_mm: Option<f64>,
    /// Axial depth, mm (sim only).
    pub axial_depth_mm: Option<f64>,
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// Programmed feed of the active block, mm/min.
    pub programmed_feed_mm_min: f64,
    /// Override commanded at the end of this period, percent.
    pub override_cmd_pct: u16,
    /// Override that was in force during this period (board `OVERRIDE_APPLIED`), percent.
    pub override_applied_pct: u16,
    /// Actual feed over the period, mm/min (sim: the machine's mean feed; real machine:
    /// programmed × applied override).
    pub feed_mm_min: f64,
    /// Force the controller saw, N.
    pub force_n: f64,
    /// True mean force over the measured window, N (sim only).
    pub force_true_n: Option<f64>,
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// Spindle input power, W (if known).
    pub power_w: Option<f64>,
    /// Estimated process gain Kc_hat, N/(mm/min).
    pub kc_hat: f64,
    /// Proportional gain, (mm/min)/N.
    pub kp: f64,
    /// Integral gain, (mm/min)/(N·s).
    pub ki: f64,
    /// Controller mode (`adaptive_pi`, `fixed_pi`, `adaptive_integral`, `baseline`).
    pub mode: String,
    /// Force error Fr − Fc, N (eq. 2).
    pub error_n: f64,
    /// Whether the force sample was valid.
    pub valid: bool,
    /// Saturation after the step (`none`, `low`, `high`).
    pub saturation: String,
}

/// Error of the run-log writer and reader.
#[derive(Debug, thiserror::Error)]
pub enum RunLogError {
    /// CSV layer.
    #[error("run log: {0}")]
    Csv(#[from] csv::Error),
    /// Underlying I/O.
    #[error("run log: {0}")]
    Io(#[from] std::io::Error),
    /// A field that does not parse, or a missing column.
    #[error("run log line {line}: column `{column}`: {message}")]
    Field {
        /// 1-based line number (header is line 1).
        line: u64,
        /// Column name.
        column: &'static str,
        /// What is wrong.
        message: String,
    },
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(String::new, |x| format!("{x:.decimals$}"))
}

impl RunLogRow {
    /// The row as CSV fields, in [`COLUMNS`] order.
    pub fn fields(&self) -> [String; 20] {
        [
            format!("{:.3}", self.t_s),
            opt(self.x_mm, 4),
            opt(self.radial_depth_mm, 4),
            opt(self.axial_depth_mm, 3),
            format!("{:.1}", self.spindle_rpm),
            format!("{:.2}", self.programmed_feed_mm_min),
            self.override_cmd_pct.to_string(),
            self.override_applied_pct.to_string(),
            format!("{:.3}", self.feed_mm_min),
            format!("{:.3}", self.force_n),
            opt(self.force_true_n, 3),
            format!("{:.1}", self.force_ref_n),
            opt(self.power_w, 1),
            format!("{:.6}", self.kc_hat),
            format!("{:.6e}", self.kp),
            format!("{:.6e}", self.ki),
            self.mode.clone(),
            format!("{:.3}", self.error_n),
            u8::from(self.valid).to_string(),
            self.saturation.clone(),
        ]
    }
}

/// Writes run-log rows to any `Write` (a file, a pipe, a buffer), flushing every row.
#[derive(Debug)]
pub struct RunLogWriter<W: Write> {
    csv: csv::Writer<W>,
}

impl<W: Write> RunLogWriter<W> {
    /// Write the header.
    pub fn new(out: W) -> Result<Self, RunLogError> {
        let mut csv = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(out);
        csv.write_record(COLUMNS)?;
        csv.flush()?;
        Ok(RunLogWriter { csv })
    }

    /// Write one row and flush it.
    pub fn write(&mut self, row: &RunLogRow) -> Result<(), RunLogError> {
        self.csv.write_record(row.fields())?;
        self.csv.flush()?;
        Ok(())
    }
}

fn parse_f(rec: &csv::StringRecord, idx: usize, line: u64) -> Result<Option<f64>, RunLogError> {
    let s = rec.get(idx).unwrap_or("");
    if s.is_empty() {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).map_err(|e| RunLogError::Field {
        line,
        column: COLUMNS[idx],
        message: format!("`{s}`: {e}"),
    })
}

/// Read a run log written by [`RunLogWriter`] (columns located by name, extra columns
/// ignored).
pub fn read_run_log(input: impl Read) -> Result<Vec<RunLogRow>, RunLogError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(input);
    let headers = rdr.headers()?.clone();
    let mut pos = [0usize; 20];
    for (i, name) in COLUMNS.iter().enumerate() {
        pos[i] = headers
            .iter()
            .position(|h| h == *name)
            .ok_or(RunLogError::Field {
                line: 1,
                column: COLUMNS[i],
                message: "missing column".into(),
            })?;
    }
    let mut rows = Vec::new();
    for (k, rec) in rdr.records().enumerate() {
        let rec = rec?;
        let line = k as u64 + 2;
        // Reorder the record into COLUMNS order.
        let ordered: csv::StringRecord = pos.iter().map(|&p| rec.get(p).unwrap_or("")).collect();
        let f = |i: usize| parse_f(&ordered, i, line);
        let req = |i: usize| -> Result<f64, RunLogError> {
            f(i)?.ok_or(RunLogError::Field {
                line,
                column: COLUMNS[i],
                message: "empty".into(),
            })
        };
        let pct = |i: usize| -> Result<u16, RunLogError> {
            let v = req(i)?;
            if (0.0..=1000.0).contains(&v) {
                Ok(v.round() as u16)
            } else {
                Err(RunLogError::Field {
                    line,
                    column: COLUMNS[i],
                    message: format!("{v} is not a percentage"),
                })
            }
        };
        rows.push(RunLogRow {
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
            mode: ordered.get(16).unwrap_or("").to_string(),
            error_n: req(17)?,
            valid: ordered.get(18) == Some("1"),
            saturation: ordered.get(19).unwrap_or("").to_string(),
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_values_at_their_precision() {
        let row = RunLogRow {
            t_s: 12.3,
            x_mm: Some(45.25),
            radial_depth_mm: None,
            spindle_rpm: 600.0,
            programmed_feed_mm_min: 200.0,
            override_cmd_pct: 70,
            override_applied_pct: 60,
            feed_mm_min: 120.0,
            force_n: 801.5,
            force_true_n: Some(799.0),
            force_ref_n: 800.0,
            kc_hat: 6.25,
            kp: 1.5e-7,
            ki: 1.6,
            mode: "adaptive_pi".into(),
            error_n: -1.5,
            valid: true,
            saturation: "none".into(),
            ..RunLogRow::default()
        };
        let mut buf = Vec::new();
        {
            let mut w = RunLogWriter::new(&mut buf).expect("header");
            w.write(&row).expect("row");
        }
        let back = read_run_log(buf.as_slice()).expect("read");
        assert_eq!(back, vec![row]);
    }

    #[test]
    fn a_bad_field_names_line_and_column() {
        let mut text = COLUMNS.join(",");
        text.push('\n');
        text.push_str("0.1,,,,600,200,100,100,200,abc,,800,,4,0,0,fixed_pi,0,1,none\n");
        let err = read_run_log(text.as_bytes())
            .expect_err("bad field")
            .to_string();
        assert!(err.contains("line 2") && err.contains("force_n"), "{err}");
    }
}
