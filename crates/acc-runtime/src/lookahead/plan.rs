//! The cutting plan as data the loop reads: `plan.csv`, written by `acc plan` (the planner,
//! `acc_sim::plan`) and read by `acc sim --plan` / `acc run --plan` ([`crate::lookahead`]).
//!
//! One row per stretch of the program's path along which the block and the planned
//! override stay the same, in path order, contiguous (`start_mm` of a row is `end_mm` of
//! the one before). Columns (units in the names):
//!
//! | column | unit | meaning |
//! | --- | --- | --- |
//! | `block` | — | the block the board reports as `BLOCK_NUMBER` (N word, else line number) |
//! | `tool` | — | the tool number (`TOOL_NUMBER`) |
//! | `start_mm`, `end_mm` | mm | path position where the stretch starts and ends (along the whole program, rapids included) |
//! | `x_mm`, `y_mm`, `z_mm` | mm | tool position where the stretch starts (program frame) |
//! | `rapid` | bool | a rapid move (not overridden) |
//! | `feed_mm_min` | mm/min | programmed feed (a rapid: the machine's rapid rate) |
//! | `radial_mm`, `axial_mm` | mm | engagement where the force of the stretch is largest (0 radial: air) |
//! | `force_100_n` | N | largest predicted mean force along the stretch at 100 % override |
//! | `force_min_100_n` | N | smallest predicted mean force along the stretch at 100 % override |
//! | `override_pct` | % | the planned override: the largest on the board's grid whose predicted force is ≤ Fr, clamped to the tool's limits (the maximum in air and on rapids) |
//! | `force_planned_n` | N | predicted largest force at `override_pct` |
//! | `feed_exponent` | — | β of the force law `F ∝ f^β` (seed 002 eq. 1): the force at another feed `f` is `force_100_n · (f / feed_mm_min)^β` |
//! | `profile` | — | the force along the stretch: `rising` (linear from `force_min_100_n` at `start_mm` to `force_100_n` at `end_mm`), `falling` (the reverse), `flat` (not known inside the stretch: take `force_100_n` throughout). Optional: a file without the column reads as `flat` |
//! | `force_ref_n` | N | the force reference Fr the stretch was planned for (the tool's, from the tool table, else the scenario's). A run whose Fr for the tool is lower lowers the stretch's cap to its own Fr ([`PlanRow::cap_for_fr`]); a higher Fr never raises it. Optional (after `profile`): a file without the column caps at `override_pct` whatever the run's Fr |
//!
//! Lines that start with `#` are comments (`acc plan --model` names the model that predicted
//! the force on the first line). Reading checks every cell and the order; an error names
//! the file, the line and the column, and the allowed range.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// One stretch of the plan (see the module docs for the columns).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanRow {
    /// Block number (N word, else line number).
    pub block: u32,
    /// Tool number.
    pub tool: u32,
    /// Path position where the stretch starts, mm.
    pub start_mm: f64,
    /// Path position where the stretch ends, mm.
    pub end_mm: f64,
    /// Tool position where the stretch starts, mm (program frame).
    pub x_mm: f64,
    /// See `x_mm`.
    pub y_mm: f64,
    /// See `x_mm`.
    pub z_mm: f64,
    /// A rapid move (not overridden).
    pub rapid: bool,
    /// Programmed feed, mm/min (rapid: the rapid rate).
    pub feed_mm_min: f64,
    /// Radial engagement where the stretch's force is largest, mm (0: air).
    pub radial_mm: f64,
    /// Axial engagement there, mm.
    pub axial_mm: f64,
    /// Largest predicted mean force at 100 % override, N.
    pub force_100_n: f64,
    /// Smallest predicted mean force at 100 % override, N.
    pub force_min_100_n: f64,
    /// Planned override, percent (on the board's grid, within the tool's limits).
    pub override_pct: u16,
    /// Largest predicted force at the planned override, N.
    pub force_planned_n: f64,
    /// Feed exponent β of the force law, −.
    pub feed_exponent: f64,
    /// The force along the stretch at 100 %.
    pub profile: ForceProfile,
    /// The force reference Fr the stretch was planned for, N (`None`: not recorded).
    pub force_ref_n: Option<f64>,
}

/// How the predicted force runs along a plan row (the planner's intervals have the
/// engagement linear between the stock's knots; a row of several intervals is `Flat`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ForceProfile {
    /// Linear from the smallest force at the row's start to the largest at its end.
    Rising,
    /// Linear from the largest force at the row's start to the smallest at its end.
    Falling,
    /// Not known inside the row: the largest force throughout (the safe reading).
    #[default]
    Flat,
}

impl ForceProfile {
    /// The name in `plan.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            ForceProfile::Rising => "rising",
            ForceProfile::Falling => "falling",
            ForceProfile::Flat => "flat",
        }
    }
}

impl PlanRow {
    /// Predicted force of this stretch at actual feed `feed_mm_min` (mm/min), N:
    /// `force_100_n · (f / f_prog)^β` (seed 002 eq. 1).
    pub fn force_at_feed_n(&self, feed_mm_min: f64) -> f64 {
        self.scale_to_feed(self.force_100_n, feed_mm_min)
    }

    /// [`PlanRow::force_at_feed_n`] of the stretch's smallest force, N.
    pub fn force_min_at_feed_n(&self, feed_mm_min: f64) -> f64 {
        self.scale_to_feed(self.force_min_100_n, feed_mm_min)
    }

    fn scale_to_feed(&self, f100_n: f64, feed_mm_min: f64) -> f64 {
        if f100_n <= 0.0 || self.feed_mm_min <= 0.0 || feed_mm_min <= 0.0 {
            return 0.0;
        }
        f100_n * (feed_mm_min / self.feed_mm_min).powf(self.feed_exponent)
    }

    /// The tool's speed along this stretch at override `pct` (%), mm/min: the programmed
    /// feed × the override; a rapid at its rapid rate, which the feed override does not
    /// scale.
    pub fn speed_mm_min(&self, pct: u16) -> f64 {
        if self.rapid {
            self.feed_mm_min
        } else {
            self.feed_mm_min * f64::from(pct) / 100.0
        }
    }

    /// Whether the tool cuts along this stretch (a predicted force).
    pub fn cuts(&self) -> bool {
        self.force_100_n > 0.0
    }

    /// The override that gives force `fr_n` (N) at this stretch's force `f100_n` (N, at
    /// 100 %), percent, unrounded: `100 · (Fr / F)^(1/β)` (seed 002 eq. 1 solved for the
    /// feed; β taken as 1 if the file gives none). `None` without a force or a positive Fr.
    pub fn override_for_fr(&self, f100_n: f64, fr_n: f64) -> Option<f64> {
        if !(f100_n > 0.0 && fr_n > 0.0 && fr_n.is_finite()) {
            return None;
        }
        let beta = if self.feed_exponent > 0.0 {
            self.feed_exponent
        } else {
            1.0
        };
        Some(acc_core::force_law::feed_for_force(
            100.0, f100_n, fr_n, beta,
        ))
    }

    /// The stretch's planned override for a run whose force reference is `fr_n` (N),
    /// percent: `override_pct`, lowered where `fr_n` is below the Fr the stretch was
    /// planned for (`force_ref_n`) to the override that gives `fr_n` at the stretch's
    /// largest force, rounded down, at least 1 %. A higher `fr_n`, a stretch without
    /// force or a plan without `force_ref_n` keeps `override_pct`: the plan's Fr never
    /// raises it.
    pub fn cap_for_fr(&self, fr_n: f64) -> u16 {
        let lower = self.force_ref_n.is_some_and(|planned| fr_n < planned);
        match self.override_for_fr(self.force_100_n, fr_n) {
            Some(o) if lower && self.cuts() => {
                let scaled = (o.floor().max(1.0)).min(f64::from(self.override_pct));
                scaled as u16
            }
            _ => self.override_pct,
        }
    }

    /// The largest predicted force at 100 % over the part `from_mm ..= to_mm` of this
    /// stretch, N: linear along a `rising` or `falling` stretch, `force_100_n` on a `flat`
    /// one (positions clamped to the stretch).
    pub fn force_100_over_n(&self, from_mm: f64, to_mm: f64) -> f64 {
        let len = self.end_mm - self.start_mm;
        if self.profile == ForceProfile::Flat || len <= 0.0 {
            return self.force_100_n;
        }
        let at = |x: f64| {
            let u = ((x - self.start_mm) / len).clamp(0.0, 1.0);
            let (a, b) = match self.profile {
                ForceProfile::Rising => (self.force_min_100_n, self.force_100_n),
                _ => (self.force_100_n, self.force_min_100_n),
            };
            a + (b - a) * u
        };
        at(from_mm).max(at(to_mm))
    }
}

/// A whole plan: its rows in path order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plan {
    /// The stretches, in path order, contiguous.
    pub rows: Vec<PlanRow>,
}

/// The column names of `plan.csv`, in order.
pub const PLAN_COLUMNS: [&str; 18] = [
    "block",
    "tool",
    "start_mm",
    "end_mm",
    "x_mm",
    "y_mm",
    "z_mm",
    "rapid",
    "feed_mm_min",
    "radial_mm",
    "axial_mm",
    "force_100_n",
    "force_min_100_n",
    "override_pct",
    "force_planned_n",
    "feed_exponent",
    "profile",
    "force_ref_n",
];

/// The columns a plan file must have (`profile` and then `force_ref_n` are optional:
/// `flat` and not recorded when absent).
const REQUIRED_COLUMNS: usize = 16;

/// Why a plan file was refused.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The file cannot be read.
    #[error("{file}: cannot read the plan")]
    Io {
        /// The plan file.
        file: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A line of the file is wrong.
    #[error("{file}:{line}: {what}")]
    Line {
        /// The plan file.
        file: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong (names the column and the allowed range).
        what: String,
    },
    /// The file has no rows.
    #[error("{file}: the plan has no rows (write one with `acc plan`)")]
    Empty {
        /// The plan file.
        file: PathBuf,
    },
    /// The plan cannot be written.
    #[error("cannot write the plan: {0}")]
    Write(String),
}

/// Tolerance of the contiguity check between rows, mm.
const CONTIGUOUS_MM: f64 = 1e-3;

impl Plan {
    /// Read `plan.csv` at `path`.
    pub fn load(path: &Path) -> Result<Self, PlanError> {
        let text = std::fs::read_to_string(path).map_err(|source| PlanError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Self::parse(path, &text)
    }

    /// Parse the text of a plan file (`file` names it in errors).
    pub fn parse(file: &Path, text: &str) -> Result<Self, PlanError> {
        let err = |line: u64, what: String| PlanError::Line {
            file: file.to_path_buf(),
            line,
            what,
        };
        let mut rd = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        // The header is the first line that is not a comment.
        let header_line = 1 + text.lines().take_while(|l| l.starts_with('#')).count() as u64;
        let header = rd
            .headers()
            .map_err(|e| err(header_line, format!("header: {e}")))?
            .clone();
        let got: Vec<&str> = header.iter().collect();
        // The optional columns, in order: how many of them the header has.
        let optional = (0..=PLAN_COLUMNS.len() - REQUIRED_COLUMNS)
            .find(|&k| got == PLAN_COLUMNS[..REQUIRED_COLUMNS + k]);
        let Some(optional) = optional else {
            return Err(err(
                header_line,
                format!(
                    "header `{}`: expected `{}`",
                    got.join(","),
                    PLAN_COLUMNS.join(",")
                ),
            ));
        };
        let with_profile = optional >= 1;
        let with_fr = optional >= 2;
        let mut rows: Vec<PlanRow> = Vec::new();
        for rec in rd.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line());
                err(line, e.to_string())
            })?;
            let line = rec.position().map_or(0, |p| p.line());
            let cell = |i: usize| rec.get(i).unwrap_or("");
            let num = |i: usize, lo: f64, hi: f64| -> Result<f64, PlanError> {
                let s = cell(i);
                let v: f64 = s.trim().parse().map_err(|_| {
                    err(
                        line,
                        format!("column `{}`: `{s}` is not a number", PLAN_COLUMNS[i]),
                    )
                })?;
                if !(v.is_finite() && (lo..=hi).contains(&v)) {
                    return Err(err(
                        line,
                        format!("column `{}`: {v} outside {lo} ..= {hi}", PLAN_COLUMNS[i]),
                    ));
                }
                Ok(v)
            };
            let int = |i: usize, hi: f64| -> Result<u32, PlanError> {
                let v = num(i, 0.0, hi)?;
                if v.fract() != 0.0 {
                    return Err(err(
                        line,
                        format!("column `{}`: {v} is not a whole number", PLAN_COLUMNS[i]),
                    ));
                }
                Ok(v as u32)
            };
            let rapid = match cell(7).trim() {
                "true" | "1" => true,
                "false" | "0" => false,
                s => {
                    return Err(err(
                        line,
                        format!("column `rapid`: `{s}`: allowed true or false"),
                    ))
                }
            };
            let profile = if with_profile {
                match cell(16).trim() {
                    "rising" => ForceProfile::Rising,
                    "falling" => ForceProfile::Falling,
                    "flat" => ForceProfile::Flat,
                    s => {
                        return Err(err(
                            line,
                            format!("column `profile`: `{s}`: allowed rising, falling or flat"),
                        ))
                    }
                }
            } else {
                ForceProfile::Flat
            };
            let big = 1e9;
            let row = PlanRow {
                block: int(0, f64::from(u32::MAX))?,
                tool: int(1, f64::from(u32::MAX))?,
                start_mm: num(2, 0.0, big)?,
                end_mm: num(3, 0.0, big)?,
                x_mm: num(4, -big, big)?,
                y_mm: num(5, -big, big)?,
                z_mm: num(6, -big, big)?,
                rapid,
                feed_mm_min: num(8, 0.0, 1e7)?,
                radial_mm: num(9, 0.0, 1e4)?,
                axial_mm: num(10, 0.0, 1e4)?,
                force_100_n: num(11, 0.0, 1e9)?,
                force_min_100_n: num(12, 0.0, 1e9)?,
                override_pct: int(13, 150.0)? as u16,
                force_planned_n: num(14, 0.0, 1e9)?,
                feed_exponent: num(15, 0.1, 2.0)?,
                profile,
                force_ref_n: if with_fr {
                    Some(num(17, 1.0, 1e9)?)
                } else {
                    None
                },
            };
            if row.force_min_100_n > row.force_100_n {
                return Err(err(
                    line,
                    format!(
                        "column `force_min_100_n`: {} above force_100_n {}",
                        row.force_min_100_n, row.force_100_n
                    ),
                ));
            }
            if row.end_mm < row.start_mm {
                return Err(err(
                    line,
                    format!(
                        "column `end_mm`: {} before start_mm {}",
                        row.end_mm, row.start_mm
                    ),
                ));
            }
            if let Some(prev) = rows.last() {
                if (row.start_mm - prev.end_mm).abs() > CONTIGUOUS_MM {
                    return Err(err(
                        line,
                        format!(
                            "column `start_mm`: {} does not continue the row before (end_mm {}); \
                             rows must be in path order",
                            row.start_mm, prev.end_mm
                        ),
                    ));
                }
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(PlanError::Empty {
                file: file.to_path_buf(),
            });
        }
        Ok(Plan { rows })
    }

    /// The plan as `plan.csv` text.
    pub fn to_csv(&self) -> Result<String, PlanError> {
        self.to_csv_noted(&[])
    }

    /// The plan as `plan.csv` text with `notes` as comment lines (`# …`) above the header
    /// (a line break inside a note starts a new comment line).
    pub fn to_csv_noted(&self, notes: &[String]) -> Result<String, PlanError> {
        let mut head = String::new();
        for line in notes.iter().flat_map(|n| n.lines()) {
            head.push_str("# ");
            head.push_str(line);
            head.push('\n');
        }
        let mut w = csv::Writer::from_writer(head.into_bytes());
        // `force_ref_n` is written when every row has it (a column is whole or absent).
        let with_fr = self.rows.iter().all(|r| r.force_ref_n.is_some());
        let n = if with_fr {
            PLAN_COLUMNS.len()
        } else {
            PLAN_COLUMNS.len() - 1
        };
        w.write_record(&PLAN_COLUMNS[..n])
            .map_err(|e| PlanError::Write(e.to_string()))?;
        for r in &self.rows {
            let cells = [
                r.block.to_string(),
                r.tool.to_string(),
                format!("{:.3}", r.start_mm),
                format!("{:.3}", r.end_mm),
                format!("{:.3}", r.x_mm),
                format!("{:.3}", r.y_mm),
                format!("{:.3}", r.z_mm),
                r.rapid.to_string(),
                format!("{:.1}", r.feed_mm_min),
                format!("{:.3}", r.radial_mm),
                format!("{:.3}", r.axial_mm),
                format!("{:.1}", r.force_100_n),
                format!("{:.1}", r.force_min_100_n),
                r.override_pct.to_string(),
                format!("{:.1}", r.force_planned_n),
                format!("{}", r.feed_exponent),
                r.profile.as_str().to_string(),
                r.force_ref_n.map_or(String::new(), |f| format!("{f:.1}")),
            ];
            w.write_record(&cells[..n])
                .map_err(|e| PlanError::Write(e.to_string()))?;
        }
        let bytes = w
            .into_inner()
            .map_err(|e| PlanError::Write(e.to_string()))?;
        String::from_utf8(bytes).map_err(|e| PlanError::Write(e.to_string()))
    }

    /// Length of the planned path, mm.
    pub fn length_mm(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r.end_mm)
    }

    /// Index of the row containing path position `x` (mm; the last row past the end).
    /// The plan has at least one row ([`Plan::load`] refuses an empty one).
    pub fn row_at(&self, x: f64) -> usize {
        self.rows
            .partition_point(|r| r.end_mm < x)
            .min(self.rows.len().saturating_sub(1))
    }

    /// Walk the tool `time_s` (s) from `x` (mm) at override `pct` (a rapid at its rapid
    /// rate): `part(row, from, to)` for each row's part it crosses (mm); where it ends, mm.
    pub fn walk(
        &self,
        x: f64,
        pct: u16,
        time_s: f64,
        mut part: impl FnMut(&PlanRow, f64, f64),
    ) -> f64 {
        let rows = &self.rows;
        let mut i = self.row_at(x);
        let mut at = x.max(rows[i].start_mm);
        let mut left_s = time_s;
        loop {
            let r: &PlanRow = &rows[i];
            let speed = r.speed_mm_min(pct.max(1)) / 60.0;
            let len = (r.end_mm - at).max(0.0);
            let t = if speed > 0.0 {
                len / speed
            } else {
                f64::INFINITY
            };
            let to = if t >= left_s {
                (at + speed * left_s).min(r.end_mm)
            } else {
                r.end_mm
            };
            part(r, at, to);
            if t >= left_s || i + 1 >= rows.len() {
                return to;
            }
            left_s -= t;
            i += 1;
            at = rows[i].start_mm;
        }
    }

    /// Where the tool is `time_s` (s) after `x` (mm) at override `pct`, mm.
    pub fn advance(&self, x: f64, pct: u16, time_s: f64) -> f64 {
        self.walk(x, pct, time_s, |_, _, _| {})
    }

    /// The plan's mean force at override `o_pct` (N) over the path the tool covers in one
    /// period from `x` (mm) at `o_pct` (a rapid at its rapid rate): the force the next
    /// period's command governs, path-weighted, each feed row at `force_100 · (o/100)^β`.
    pub fn period_force_n(&self, x: f64, o_pct: u16, period_s: f64) -> f64 {
        let scale = f64::from(o_pct.max(1)) / 100.0;
        let (mut sum, mut len_sum) = (0.0, 0.0);
        self.walk(x, o_pct, period_s, |r, at, to| {
            let part = to - at;
            if part > 0.0 {
                let mid = 0.5 * (at + to);
                let f = if !r.rapid && r.cuts() {
                    r.force_100_over_n(mid, mid) * scale.powf(r.feed_exponent)
                } else {
                    0.0
                };
                sum += f * part;
                len_sum += part;
            }
        });
        if len_sum > 0.0 {
            sum / len_sum
        } else {
            0.0
        }
    }
}

/// A plan row for tests: block `block` from `a` to `b` mm at `feed` mm/min, force `f100` N
/// at 100 % (its smallest too), planned override `ov` %.
#[cfg(test)]
pub(crate) fn test_row(block: u32, a: f64, b: f64, feed: f64, f100: f64, ov: u16) -> PlanRow {
    PlanRow {
        block,
        tool: 1,
        start_mm: a,
        end_mm: b,
        x_mm: 0.0,
        y_mm: 0.0,
        z_mm: 0.0,
        rapid: false,
        feed_mm_min: feed,
        radial_mm: 1.0,
        axial_mm: 5.0,
        force_100_n: f100,
        force_min_100_n: f100,
        override_pct: ov,
        force_planned_n: f100 * f64::from(ov) / 100.0,
        feed_exponent: 1.0,
        profile: ForceProfile::Flat,
        force_ref_n: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(block: u32, a: f64, b: f64, f100: f64, ov: u16) -> PlanRow {
        test_row(block, a, b, 200.0, f100, ov)
    }

    #[test]
    fn round_trip_and_force_at_feed() {
        let p = Plan {
            rows: vec![row(10, 0.0, 5.0, 0.0, 150), row(20, 5.0, 9.5, 1600.0, 50)],
        };
        let text = p.to_csv().expect("csv");
        let back = Plan::parse(Path::new("p.csv"), &text).expect("parse");
        assert_eq!(back, p);
        assert!((back.rows[1].force_at_feed_n(100.0) - 800.0).abs() < 1e-9);
        assert_eq!(back.length_mm(), 9.5);
        // Notes are comment lines above the header; errors still name the file's line.
        let noted = p
            .to_csv_noted(&["force predicted by model m.toml".into(), "a\nb".into()])
            .expect("csv");
        assert!(noted.starts_with("# force predicted by model m.toml\n# a\n# b\nblock,"));
        assert_eq!(Plan::parse(Path::new("p.csv"), &noted).expect("parse"), p);
        let bad = noted.replace("1600.0", "lots");
        let e = Plan::parse(Path::new("p.csv"), &bad)
            .expect_err("bad")
            .to_string();
        assert!(e.contains("p.csv:6") && e.contains("force_100_n"), "{e}");
        let e = Plan::parse(Path::new("p.csv"), "# x\na,b\n1,2\n")
            .expect_err("header")
            .to_string();
        assert!(e.contains("p.csv:2") && e.contains("header"), "{e}");
    }

    #[test]
    fn the_plans_fr_round_trips_and_older_files_still_load() {
        let mut p = Plan {
            rows: vec![row(10, 0.0, 5.0, 0.0, 150), row(20, 5.0, 9.5, 1600.0, 50)],
        };
        for r in &mut p.rows {
            r.force_ref_n = Some(800.0);
        }
        let text = p.to_csv().expect("csv");
        assert!(text
            .lines()
            .next()
            .expect("header")
            .ends_with(",profile,force_ref_n"));
        assert_eq!(Plan::parse(Path::new("p.csv"), &text).expect("parse"), p);
        // Without the column (and without `profile` too) the rows read as not recorded.
        let cut = |text: &str, cols: usize| -> String {
            text.lines()
                .map(|l| l.split(',').take(cols).collect::<Vec<_>>().join(","))
                .collect::<Vec<_>>()
                .join("\n")
        };
        for cols in [16, 17] {
            let back = Plan::parse(Path::new("p.csv"), &cut(&text, cols)).expect("parse");
            assert!(back.rows.iter().all(|r| r.force_ref_n.is_none()), "{cols}");
        }
        // A row without a recorded Fr writes no column at all.
        p.rows[0].force_ref_n = None;
        let text = p.to_csv().expect("csv");
        assert!(text.lines().next().expect("header").ends_with(",profile"));
        let e = Plan::parse(Path::new("p.csv"), &text.replace(",flat\n", ",flat,0.5\n"))
            .expect_err("short header");
        assert!(e.to_string().contains("p.csv:"), "{e}");
        let bad = Plan::parse(
            Path::new("p.csv"),
            &Plan {
                rows: vec![PlanRow {
                    force_ref_n: Some(800.0),
                    ..row(10, 0.0, 5.0, 0.0, 150)
                }],
            }
            .to_csv()
            .expect("csv")
            .replace(",800.0", ",-3"),
        )
        .expect_err("negative Fr")
        .to_string();
        assert!(
            bad.contains("force_ref_n") && bad.contains("1 ..="),
            "{bad}"
        );
    }

    #[test]
    fn the_cap_for_a_lower_fr_is_the_override_that_gives_it() {
        let r = PlanRow {
            force_ref_n: Some(800.0),
            ..row(20, 0.0, 5.0, 2400.0, 30)
        };
        assert_eq!(r.cap_for_fr(800.0), 30);
        assert_eq!(r.cap_for_fr(500.0), 20);
        assert_eq!(r.cap_for_fr(2000.0), 30);
        assert_eq!(r.cap_for_fr(1.0), 1);
        let air = PlanRow {
            force_ref_n: Some(800.0),
            ..row(10, 0.0, 5.0, 0.0, 150)
        };
        assert_eq!(air.cap_for_fr(100.0), 150);
    }

    #[test]
    fn bad_files_name_the_line_and_column() {
        let p = Plan {
            rows: vec![row(10, 0.0, 5.0, 0.0, 150), row(20, 5.0, 9.5, 1600.0, 50)],
        };
        let text = p.to_csv().expect("csv");
        let f = Path::new("plan.csv");
        let bad = text.replace("1600.0", "lots");
        let e = Plan::parse(f, &bad).expect_err("not a number").to_string();
        assert!(e.contains("plan.csv:3") && e.contains("force_100_n"), "{e}");
        let gap = text.replace("\n20,1,5.000", "\n20,1,6.000");
        let e = Plan::parse(f, &gap).expect_err("gap").to_string();
        assert!(e.contains("plan.csv:3") && e.contains("start_mm"), "{e}");
        let ov = text.replace(",50,", ",170,");
        let e = Plan::parse(f, &ov).expect_err("override").to_string();
        assert!(e.contains("override_pct") && e.contains("150"), "{e}");
        let e = Plan::parse(f, "a,b\n1,2\n")
            .expect_err("header")
            .to_string();
        assert!(e.contains("plan.csv:1") && e.contains("header"), "{e}");
        let e = Plan::parse(f, &PLAN_COLUMNS.join(","))
            .expect_err("empty")
            .to_string();
        assert!(e.contains("no rows"), "{e}");
        let short = text.lines().take(2).collect::<Vec<_>>().join("\n") + "\n20,1,5.0\n";
        let e = Plan::parse(f, &short).expect_err("short").to_string();
        assert!(e.contains("plan.csv:3"), "{e}");
    }
}
