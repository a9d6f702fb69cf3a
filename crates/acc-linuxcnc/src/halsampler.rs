//! The process's path against LinuxCNC's own record of its motion: a `halsampler` capture.
//!
//! `acc linuxcnc --capture` loads LinuxCNC's realtime `sampler` in the servo thread with
//! the joints' feedback positions (`joint.0/1/2.pos-fb`, trivial kinematics: X, Y, Z) and
//! the process's sample counter (`acc-process.sample-seq`), and LinuxCNC's `halsampler -t`
//! writes one line per servo period: `TAG X Y Z SEQ`, or `overrun` where the FIFO lost
//! samples. The process writes machine-log row `k` (0-based) after reading the position and
//! before it sets the counter to `k + 1`, so row `k`'s position was read between the servo
//! periods where the counter became `k` and `k + 1`. [`compare`] takes, for each row, the
//! nearest joint position in that window, shifted by the feedback's lag behind the command:
//! the distance is what the process's path and LinuxCNC's motion disagree by.

use std::path::{Path, PathBuf};

use crate::machine_log::MachineRow;

/// One servo period of the capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The sampler's sample number (consecutive unless the FIFO overran).
    pub tag: u64,
    /// The joints' feedback positions X, Y, Z, mm.
    pub position_mm: [f64; 3],
    /// The process's sample counter in that servo period.
    pub seq: i64,
}

/// Why a capture cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The file cannot be read.
    #[error("{}: cannot read the halsampler capture: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A line that is neither a sample nor `overrun`.
    #[error("{}: line {line}: {what} (a line is `TAG X Y Z SEQ` or `overrun`)", path.display())]
    BadLine {
        /// The file.
        path: PathBuf,
        /// The line, 1-based.
        line: usize,
        /// What is wrong with it.
        what: String,
    },
}

/// A capture: its samples and how many `overrun` marks it has.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Capture {
    /// The samples, in order.
    pub samples: Vec<Sample>,
    /// `overrun` lines: gaps where the FIFO lost samples.
    pub overruns: usize,
}

/// The capture at `path`.
pub fn read(path: &Path) -> Result<Capture, CaptureError> {
    let text = std::fs::read_to_string(path).map_err(|source| CaptureError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&text, path)
}

/// A capture's text; `path` names it in errors. A last line without its newline (halsampler
/// stopped while it wrote) is skipped.
pub fn parse(text: &str, path: &Path) -> Result<Capture, CaptureError> {
    let mut capture = Capture::default();
    let lines: Vec<&str> = text.lines().collect();
    let cut_short = !text.is_empty() && !text.ends_with('\n');
    for (k, line) in lines.iter().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if line == "overrun" {
            capture.overruns += 1;
            continue;
        }
        match parse_sample(line) {
            Ok(s) => capture.samples.push(s),
            Err(_) if cut_short && k + 1 == lines.len() => {}
            Err(what) => {
                return Err(CaptureError::BadLine {
                    path: path.to_path_buf(),
                    line: k + 1,
                    what,
                })
            }
        }
    }
    Ok(capture)
}

fn parse_sample(line: &str) -> Result<Sample, String> {
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() != 5 {
        return Err(format!("{} fields, not 5", f.len()));
    }
    let num = |i: usize| -> Result<f64, String> {
        f[i].parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("field {} `{}` is not a number", i + 1, f[i]))
    };
    let tag = f[0]
        .parse::<u64>()
        .map_err(|_| format!("the tag `{}` is not a sample number", f[0]))?;
    let seq = f[4]
        .parse::<i64>()
        .map_err(|_| format!("the counter `{}` is not an integer", f[4]))?;
    Ok(Sample {
        tag,
        position_mm: [num(1)?, num(2)?, num(3)?],
        seq,
    })
}

/// How the process's path matches the capture.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathMatch {
    /// Machine-log rows compared.
    pub rows: usize,
    /// Rows not compared: read before the capture started or after it ended, or in a gap
    /// the FIFO lost.
    pub rows_outside: usize,
    /// Largest distance of a row's position from LinuxCNC's positions in its window, mm.
    pub max_mm: f64,
    /// The same over the rows that cut (true force > 0), mm.
    pub max_cutting_mm: f64,
    /// Largest distance the joints moved in one servo period, mm (the resolution of a
    /// comparison by time alone).
    pub max_step_mm: f64,
    /// The lag of the joints' feedback behind the axis command the process reads, servo
    /// periods: the one that brings the path and the capture closest.
    pub lag_periods: usize,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The longest lag of the joints' feedback behind the axis command [`compare`] tries,
/// servo periods.
pub const MAX_LAG_PERIODS: usize = 5;

/// Each machine-log row against the capture's positions in its window (module docs),
/// the window shifted by the lag (0 ..= [`MAX_LAG_PERIODS`] servo periods) that brings the
/// two closest: the process reads the axis command (`axis.L.pos-cmd`), which the joints'
/// feedback follows a few servo periods later.
pub fn compare(rows: &[MachineRow], capture: &Capture) -> PathMatch {
    let at: Vec<PathMatch> = (0..=MAX_LAG_PERIODS)
        .map(|lag| compare_at(rows, capture, lag))
        .collect();
    let best = at.iter().map(|m| m.max_mm).fold(f64::INFINITY, f64::min);
    // Several lags fit as well when a row's window is longer than one servo period: the
    // middle one.
    let fit: Vec<&PathMatch> = at
        .iter()
        .filter(|m| m.max_mm <= best + LOG_ROUNDING_MM)
        .collect();
    fit.get(fit.len() / 2).map(|m| **m).unwrap_or_default()
}

/// The machine log's and the capture's rounding of a position, mm (4 decimals).
const LOG_ROUNDING_MM: f64 = 1e-4;

/// [`compare`] at one lag, servo periods.
fn compare_at(rows: &[MachineRow], capture: &Capture, lag: usize) -> PathMatch {
    let s = &capture.samples;
    let mut m = PathMatch {
        lag_periods: lag,
        max_step_mm: s
            .windows(2)
            .filter(|w| w[1].tag == w[0].tag + 1)
            .map(|w| dist(w[0].position_mm, w[1].position_mm))
            .fold(0.0, f64::max),
        ..PathMatch::default()
    };
    // first[q]: the index of the first sample whose counter is q (counters only grow).
    let mut first: std::collections::HashMap<i64, usize> = std::collections::HashMap::new();
    for (i, x) in s.iter().enumerate() {
        first.entry(x.seq).or_insert(i);
    }
    for (k, row) in rows.iter().enumerate() {
        let (Some(&a), Some(&b)) = (first.get(&(k as i64)), first.get(&(k as i64 + 1))) else {
            m.rows_outside += 1;
            continue;
        };
        let (lo, hi) = (a + lag, b + lag);
        if hi >= s.len() || s[hi].tag - s[lo].tag != (hi - lo) as u64 {
            m.rows_outside += 1;
            continue;
        }
        let p = [row.x_mm, row.y_mm, row.z_mm];
        let d = s[lo..=hi]
            .iter()
            .map(|x| dist(p, x.position_mm))
            .fold(f64::INFINITY, f64::min);
        m.rows += 1;
        m.max_mm = m.max_mm.max(d);
        if row.force_n > 0.0 {
            m.max_cutting_mm = m.max_cutting_mm.max(d);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A capture of a tool moving 0.1 mm per servo period along X, the process reading
    /// every second period (counter set one period after its read).
    fn moving(n: u64) -> (Vec<MachineRow>, String) {
        let mut text = String::new();
        let mut rows = Vec::new();
        for t in 0..n {
            let x = 0.1 * t as f64;
            // Row k is read at t = 2k; the counter becomes k + 1 at t = 2k + 1.
            let seq = t.div_ceil(2);
            text.push_str(&format!("{t} {x:.6} 0.000000 -1.000000 {seq}\n"));
            if t % 2 == 0 && t + 2 < n {
                rows.push(MachineRow {
                    x_mm: x,
                    z_mm: -1.0,
                    force_n: 100.0,
                    ..MachineRow::default()
                });
            }
        }
        (rows, text)
    }

    #[test]
    fn a_path_read_from_linuxcncs_positions_matches_exactly() {
        let (rows, text) = moving(200);
        let c = parse(&text, "c.txt".as_ref()).expect("capture");
        assert_eq!(c.samples.len(), 200);
        let m = compare(&rows, &c);
        assert_eq!(m.rows + m.rows_outside, rows.len());
        assert!(m.rows >= rows.len() - 2, "{m:?}");
        assert!(m.max_mm < 1e-9 && m.max_cutting_mm < 1e-9, "{m:?}");
        assert!((m.max_step_mm - 0.1).abs() < 1e-9, "{m:?}");
    }

    #[test]
    fn the_feedbacks_lag_is_found() {
        let (rows, text) = moving(200);
        // The joints report each position two servo periods later.
        let lagged: String = text
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                let t: u64 = f[0].parse().expect("tag");
                let x = 0.1 * t.saturating_sub(2) as f64;
                format!("{t} {x:.6} 0.000000 -1.000000 {}\n", f[4])
            })
            .collect();
        let c = parse(&lagged, "c.txt".as_ref()).expect("capture");
        let m = compare(&rows, &c);
        assert_eq!(m.lag_periods, 2, "{m:?}");
        assert!(m.max_mm < 1e-9 && m.rows > 90, "{m:?}");
    }

    #[test]
    fn a_path_off_by_a_millimetre_is_seen() {
        let (mut rows, text) = moving(200);
        rows[40].y_mm = 1.0;
        let c = parse(&text, "c.txt".as_ref()).expect("capture");
        let m = compare(&rows, &c);
        assert!((m.max_mm - 1.0).abs() < 1e-9, "{m:?}");
    }

    #[test]
    fn gaps_and_bad_lines() {
        let (rows, text) = moving(40);
        // A gap of lost samples: the rows in it are not compared.
        let gapped: String = text
            .lines()
            .filter(|l| !l.starts_with("10 ") && !l.starts_with("11 "))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
            .replacen("12 ", "overrun\n12 ", 1);
        let c = parse(&gapped, "c.txt".as_ref()).expect("capture");
        assert_eq!(c.overruns, 1);
        let m = compare(&rows, &c);
        assert!(m.rows_outside >= 1, "{m:?}");
        assert!(m.max_mm < 1e-9, "{m:?}");
        // A broken line is named; a last line cut short is not an error.
        let e = parse("0 1 2 3 0\n1 x 2 3 0\n", "c.txt".as_ref()).expect_err("bad");
        assert!(e.to_string().contains("c.txt: line 2: field 2 `x`"), "{e}");
        let c = parse("0 1 2 3 0\n1 1.5 2", "c.txt".as_ref()).expect("cut short");
        assert_eq!(c.samples.len(), 1);
    }
}
