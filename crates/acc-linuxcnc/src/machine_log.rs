//! The machine log of the simulated process `acc linuxcnc-process` (`machine.csv`, one row
//! per process period: true force, position, engagement, and the pins it logs), read once
//! for every reader: `acc linuxcnc`'s summary and `acc fault-matrix --linuxcnc`'s verdicts.
//!
//! Columns are found by name (any order, more columns allowed). Every value must parse;
//! the one exception is a last line without its newline (the process was killed while it
//! wrote): it is skipped. Errors name the file and the line.
//!
//! ```
//! use acc_linuxcnc::machine_log;
//! let text = format!(
//!     "{}\n0.5,1,0,-3,300,600,1,16,3,700.5,1100,1090,0.6,1,0,1.500,0\n0.6,1,0",
//!     machine_log::COLUMNS.join(",")
//! );
//! let rows = machine_log::parse(&text, "machine.csv".as_ref())?;
//! assert_eq!(rows.len(), 1); // the last line was cut short
//! assert_eq!(rows[0].force_n, 700.5);
//! assert!(rows[0].heartbeat && !rows[0].fault);
//! # Ok::<(), acc_linuxcnc::machine_log::MachineLogError>(())
//! ```

use std::path::{Path, PathBuf};

/// The columns, as `acc linuxcnc-process` writes them.
pub const COLUMNS: [&str; 17] = [
    "t_s",
    "x_mm",
    "y_mm",
    "z_mm",
    "feed_mm_min",
    "spindle_rpm",
    "tool",
    "radial_mm",
    "axial_mm",
    "force_n",
    "power_w",
    "power_mean_w",
    "adaptive_feed",
    "heartbeat",
    "feed_inhibit",
    "feed_override",
    "fault",
];

/// One machine-log row.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MachineRow {
    /// Time since the process started, s.
    pub t_s: f64,
    /// Tool tip (`axis.L.pos-cmd`), mm.
    pub x_mm: f64,
    /// Tool tip, mm.
    pub y_mm: f64,
    /// Tool tip, mm.
    pub z_mm: f64,
    /// Path speed (`motion.current-vel`), mm/min.
    pub feed_mm_min: f64,
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// Tool number.
    pub tool: i32,
    /// Radial depth of cut, mm.
    pub radial_mm: f64,
    /// Axial depth of cut, mm.
    pub axial_mm: f64,
    /// True force, N.
    pub force_n: f64,
    /// The spindle's electrical power, W.
    pub power_w: f64,
    /// Its mean over the scenario's period (what acc reads), W.
    pub power_mean_w: f64,
    /// The adaptive feed acc wrote, 0 ..= 1.
    pub adaptive_feed: f64,
    /// acc's heartbeat bit.
    pub heartbeat: bool,
    /// `motion.feed-inhibit`.
    pub feed_inhibit: bool,
    /// The operator's feed override, ratio (1.5 = 150 %).
    pub feed_override: f64,
    /// `ui.py`'s fault marker.
    pub fault: bool,
}

/// Why the machine log cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum MachineLogError {
    /// The file cannot be read.
    #[error("{}: cannot read the machine log: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The header lacks a column.
    #[error("{}: line 1: no column `{column}` (a machine log of `acc linuxcnc-process` has {})", path.display(), COLUMNS.join(","))]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column.
        column: &'static str,
    },
    /// A line that is not a row.
    #[error("{}: line {line}: {what}", path.display())]
    BadLine {
        /// The file.
        path: PathBuf,
        /// The line, 1-based (the header is line 1).
        line: usize,
        /// What is wrong with it.
        what: String,
    },
}

/// The machine log at `path`.
pub fn read(path: &Path) -> Result<Vec<MachineRow>, MachineLogError> {
    let text = std::fs::read_to_string(path).map_err(|source| MachineLogError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&text, path)
}

/// A machine log's text; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<Vec<MachineRow>, MachineLogError> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let mut at = [0usize; COLUMNS.len()];
    for (slot, name) in at.iter_mut().zip(COLUMNS) {
        *slot = header
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| MachineLogError::MissingColumn {
                path: path.to_path_buf(),
                column: name,
            })?;
    }
    let body: Vec<&str> = lines.collect();
    let cut_short = !text.ends_with('\n');
    let mut rows = Vec::with_capacity(body.len());
    for (k, line) in body.iter().enumerate() {
        let last = k + 1 == body.len();
        match parse_row(line, &at) {
            Ok(row) => rows.push(row),
            Err(_) if last && cut_short => {}
            Err(what) => {
                return Err(MachineLogError::BadLine {
                    path: path.to_path_buf(),
                    line: k + 2,
                    what,
                })
            }
        }
    }
    Ok(rows)
}

/// One line, by the column positions `at` (in [`COLUMNS`]' order).
fn parse_row(line: &str, at: &[usize; COLUMNS.len()]) -> Result<MachineRow, String> {
    let f: Vec<&str> = line.split(',').collect();
    let mut v = [0.0f64; COLUMNS.len()];
    for ((value, &i), name) in v.iter_mut().zip(at).zip(COLUMNS) {
        let text = f
            .get(i)
            .ok_or_else(|| format!("{} fields, no `{name}` (field {})", f.len(), i + 1))?;
        *value = text
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("`{name}` = `{text}` is not a number"))?;
    }
    let bit = |x: f64| x != 0.0;
    Ok(MachineRow {
        t_s: v[0],
        x_mm: v[1],
        y_mm: v[2],
        z_mm: v[3],
        feed_mm_min: v[4],
        spindle_rpm: v[5],
        tool: v[6] as i32,
        radial_mm: v[7],
        axial_mm: v[8],
        force_n: v[9],
        power_w: v[10],
        power_mean_w: v[11],
        adaptive_feed: v[12],
        heartbeat: bit(v[13]),
        feed_inhibit: bit(v[14]),
        feed_override: v[15],
        fault: bit(v[16]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> String {
        COLUMNS.join(",")
    }

    #[test]
    fn columns_are_found_by_name_and_a_cut_short_last_line_is_skipped() {
        // Another order, one more column.
        let mut cols: Vec<&str> = COLUMNS.iter().rev().copied().collect();
        cols.push("extra");
        let row: Vec<String> = (0..cols.len()).map(|k| k.to_string()).collect();
        let text = format!("{}\n{}\n1,2", cols.join(","), row.join(","));
        let rows = parse(&text, Path::new("m.csv")).expect("parses");
        assert_eq!(rows.len(), 1);
        // Reversed: `fault` is field 0, `t_s` field 16.
        assert_eq!(rows[0].t_s, 16.0);
        assert!(!rows[0].fault);
        assert_eq!(rows[0].tool, 10);
    }

    #[test]
    fn a_bad_line_or_a_missing_column_names_the_file_and_the_line() {
        let good = "1,0,0,0,300,600,1,16,3,700,1100,1090,0.6,1,0,1.5,0";
        let text = format!("{}\n{good}\n{good}\n1,0,x,0\n{good}\n", header());
        let e = parse(&text, Path::new("/run/machine.csv")).expect_err("bad line 4");
        let s = e.to_string();
        assert!(s.starts_with("/run/machine.csv: line 4: "), "{s}");
        assert!(s.contains("`y_mm` = `x`"), "{s}");
        // Cut short in the middle of the file: not the last line, an error.
        let text = format!("{}\n1,0\n{good}\n", header());
        let s = parse(&text, Path::new("m.csv"))
            .expect_err("short")
            .to_string();
        assert!(s.contains("line 2: 2 fields, no `y_mm` (field 3)"), "{s}");
        // A complete last line that does not parse is an error too.
        let text = format!("{}\n{good}\n1,0\n", header());
        assert!(parse(&text, Path::new("m.csv")).is_err());
        let s = parse("t_s,force_n\n", Path::new("m.csv"))
            .expect_err("columns")
            .to_string();
        assert!(s.starts_with("m.csv: line 1: no column `x_mm`"), "{s}");
        let s = read(Path::new("/nonexistent/machine.csv"))
            .expect_err("io")
            .to_string();
        assert!(
            s.starts_with("/nonexistent/machine.csv: cannot read the machine log"),
            "{s}"
        );
    }
}
