//! What-if on a recorded cut (`acc replay`): the production loop with another preset,
//! closed loop, against the simulated plant whose cut geometry comes from a run log.
//!
//! The open-loop replay of [`crate::replay`] drives the plant with the logged override; a
//! what-if cannot, because another preset writes other overrides and therefore moves
//! through the part at another speed. So the recorded cut is turned into a function of the
//! path position `x`:
//!
//! - **From the log's plant truth** (an `acc sim` / `acc compare` log, [`EngagementProfile`]):
//!   per row the true tool position `x_true_mm`, the engaged radial and axial depth and
//!   the effective `Ks` factor `force_true_n / F_law(depths, feed_true, rpm, 1)` — which
//!   carries the material's hardness, an inclusion and the tool's wear at that place. The
//!   plant looks them up at its own position sample by sample (linear interpolation).
//! - **From a workpiece file** (an `acc run` log, which has no truth columns): the
//!   workpiece's engagement with the tool centre starting at `x0_mm`, as `acc
//!   discrepancy --workpiece` does.
//!
//! The twin is the scenario's machine, tool, measurement channel, programmed feed, NC
//! context and fault policy (`--scenario`), with the geometry above; with a logged profile
//! the scenario's wear growth and runout are off (the effective `Ks` already holds them).
//! [`ControlLoop`](acc_runtime::ControlLoop) + [`FaultPolicy`](acc_runtime::FaultPolicy)
//! run the other preset on it exactly as in [`crate::run`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use acc_core::ControllerConfig;
use acc_runtime::record::RunRecord;

use crate::engagement::Engagement;
pub use crate::engagement::EngagementProfile;
use crate::process::{ForceLaw, WearSpec};
use crate::run::{run, RunResult, RunSetup};
use crate::workpiece::{Segment, SegmentKind, Workpiece};
use crate::{Scenario, SimError};

/// A bad run log for the what-if: names the file, the column and the row (1-based data
/// row; the CSV line is one more, after the header).
#[derive(Debug, thiserror::Error)]
pub enum WhatIfError {
    /// A column the profile needs is empty in a row.
    #[error("{file}: column `{column}` is empty in data row {row} (CSV line {line}); {hint}", line = row + 1)]
    Missing {
        /// The log.
        file: PathBuf,
        /// Column name.
        column: &'static str,
        /// 1-based data row.
        row: usize,
        /// What to do.
        hint: &'static str,
    },
    /// A value out of its range.
    #[error("{file}: column `{column}` = {value} in data row {row} (CSV line {line}) is out of range: allowed {allowed}", line = row + 1)]
    Range {
        /// The log.
        file: PathBuf,
        /// Column name.
        column: &'static str,
        /// 1-based data row.
        row: usize,
        /// The value.
        value: f64,
        /// Allowed range.
        allowed: &'static str,
    },
    /// The log has no rows.
    #[error("{0}: the run log has no rows")]
    Empty(PathBuf),
}

const NO_TRUTH_HINT: &str = "the engagement comes from the plant-truth columns of an `acc sim` log; for an `acc run` log give --workpiece and --x0-mm";

/// The profile of a recorded cut (the profile itself, [`EngagementProfile::at`], is the
/// plant's engagement source, `acc_plant::engagement`), built from the plant-truth columns
/// of `rows` (read from `file`) with the tool's force law `law`. Rows where the tool is in
/// air or barely engaged (radial depth < 0.05 mm, feed < 1 mm/min or a law force < 1 N)
/// keep the last effective `Ks` (1 before the first cut); the factor is clamped to
/// 0.05 ..= 20.
pub fn profile_from_rows(
    file: &Path,
    rows: &[RunRecord],
    law: &ForceLaw,
) -> Result<EngagementProfile, WhatIfError> {
    {
        if rows.is_empty() {
            return Err(WhatIfError::Empty(file.to_path_buf()));
        }
        let mut x_mm = Vec::with_capacity(rows.len());
        let mut points = Vec::with_capacity(rows.len());
        let mut ks_last = 1.0;
        let mut x_last = f64::NEG_INFINITY;
        for (i, r) in rows.iter().enumerate() {
            let row = i + 1;
            let need = |v: Option<f64>, column: &'static str| {
                v.filter(|v| v.is_finite()).ok_or(WhatIfError::Missing {
                    file: file.to_path_buf(),
                    column,
                    row,
                    hint: NO_TRUTH_HINT,
                })
            };
            let x = need(r.x_true_mm, "x_true_mm")?;
            let radial = need(r.radial_depth_mm, "radial_depth_mm")?;
            let axial = need(r.axial_depth_mm, "axial_depth_mm")?;
            let force = need(r.force_true_n, "force_true_n")?;
            let feed = need(r.feed_true_mm_min, "feed_true_mm_min")?;
            let rpm = need(r.spindle_rpm, "spindle_rpm")?;
            let range =
                |column: &'static str, value: f64, allowed: &'static str| WhatIfError::Range {
                    file: file.to_path_buf(),
                    column,
                    row,
                    value,
                    allowed,
                };
            if radial < 0.0 {
                return Err(range("radial_depth_mm", radial, ">= 0"));
            }
            if axial < 0.0 {
                return Err(range("axial_depth_mm", axial, ">= 0"));
            }
            if x < x_last - 1e-9 {
                return Err(range(
                    "x_true_mm",
                    x,
                    ">= the previous row's (the tool moves forward along the path)",
                ));
            }
            x_last = x;
            let unit = if radial >= 0.05 && feed >= 1.0 {
                law.mean_force_n(radial, axial, feed, rpm, 1.0)
            } else {
                0.0
            };
            let ks = if unit >= 1.0 && force > 0.0 {
                (force / unit).clamp(0.05, 20.0)
            } else {
                ks_last
            };
            if radial > 0.0 {
                ks_last = ks;
            }
            x_mm.push(x);
            points.push(Engagement {
                radial_mm: radial,
                axial_mm: axial,
                ks_factor: if radial > 0.0 { ks } else { 1.0 },
            });
        }
        // The positions were checked to go forward above.
        EngagementProfile::new(x_mm, points).ok_or(WhatIfError::Empty(file.to_path_buf()))
    }
}

/// Where the twin's cut geometry comes from.
#[derive(Debug, Clone)]
pub enum CutGeometry {
    /// The log's plant truth.
    Logged(Arc<EngagementProfile>),
    /// A workpiece with the tool centre starting at `x0_mm` (an `acc run` log).
    Workpiece {
        /// The workpiece.
        workpiece: Workpiece,
        /// Tool-centre position at the log's first row, mm.
        x0_mm: f64,
    },
}

/// The twin scenario: `base` with the geometry of `geometry` (a logged profile: an air
/// workpiece as long as the recorded path, wear growth and runout off) and `controller`.
pub fn twin_scenario(
    base: &Scenario,
    geometry: &CutGeometry,
    controller: ControllerConfig,
) -> Scenario {
    let mut sc = base.clone();
    sc.controller = controller;
    match geometry {
        CutGeometry::Logged(p) => {
            let axial = p.points().iter().fold(0.0f64, |m, q| m.max(q.axial_mm));
            sc.workpiece = Workpiece {
                name: "recorded cut".into(),
                axial_depth_mm: if axial > 0.0 {
                    axial
                } else {
                    base.workpiece.axial_depth_mm
                },
                segments: vec![Segment {
                    kind: SegmentKind::Air,
                    start_mm: 0.0,
                    end_mm: p.end_mm().max(1e-3),
                    depth_start_mm: 0.0,
                    depth_end_mm: 0.0,
                    ks_factor: 1.0,
                }],
            };
            sc.wear = WearSpec {
                initial_factor: 1.0,
                growth_per_cm3: 0.0,
                growth_per_min: 0.0,
                ..sc.wear
            };
            sc.tool.runout = None;
        }
        CutGeometry::Workpiece { workpiece, .. } => sc.workpiece = workpiece.clone(),
    }
    sc
}

/// Run `controller` closed loop on the twin of `base` with `geometry` (the production loop
/// against the simulated board, [`crate::run`]).
pub fn run_what_if(
    base: &Scenario,
    geometry: &CutGeometry,
    controller: ControllerConfig,
) -> Result<RunResult, SimError> {
    let sc = twin_scenario(base, geometry, controller);
    let mut law = acc_core::Controller::new(controller)?;
    let mut prepare = |board: &mut crate::SimBoard| match geometry {
        CutGeometry::Logged(p) => board
            .machine_mut()
            .set_engagement_source(Some(Box::new(EngagementProfile::clone(p)))),
        CutGeometry::Workpiece { x0_mm, .. } => board.machine_mut().set_position_mm(*x0_mm),
    };
    let setup = RunSetup {
        prepare: Some(&mut prepare),
        ..RunSetup::default()
    };
    run(&sc, &mut law, setup)
}

/// The side-by-side figures of one run (recorded or what-if).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutMetrics {
    /// Force reference of the run (its last logged Fr), N.
    pub force_ref_n: f64,
    /// Periods in cut (see [`cut_metrics`]).
    pub cut_periods: usize,
    /// RMS of measured force − Fr over the periods in cut, N.
    pub rms_error_n: f64,
    /// Highest measured force, N.
    pub peak_force_n: f64,
    /// Mean measured force in cut, N.
    pub mean_force_cut_n: f64,
    /// Time of the last row, s.
    pub cycle_time_s: f64,
    /// Changes of the written override.
    pub override_switches: usize,
}

/// Whether every row of `rows` has the plant's radial depth (an `acc sim` log).
pub fn has_truth(rows: &[RunRecord]) -> bool {
    rows.iter().all(|r| r.radial_depth_mm.is_some())
}

/// [`CutMetrics`] of `rows`. A period is in cut when its radial depth is > 0 (`by_truth`:
/// both runs compared have the plant truth) or else when its measured force is above a
/// quarter of Fr (the same rule must be used on both sides of a comparison).
pub fn cut_metrics(rows: &[RunRecord], by_truth: bool) -> CutMetrics {
    let fr = rows
        .iter()
        .rev()
        .find_map(|r| r.force_ref_n)
        .unwrap_or(f64::NAN);
    let (mut n, mut se, mut sum, mut peak) = (0usize, 0.0, 0.0, 0.0f64);
    let mut last_cmd = None;
    let mut switches = 0;
    for r in rows {
        if let Some(c) = r.override_cmd_pct {
            if last_cmd.is_some_and(|l| l != c) {
                switches += 1;
            }
            last_cmd = Some(c);
        }
        let Some(f) = r.force_n.filter(|f| f.is_finite()) else {
            continue;
        };
        peak = peak.max(f);
        let in_cut = match (by_truth, r.radial_depth_mm) {
            (true, Some(d)) => d > 0.0,
            _ => f > 0.25 * r.force_ref_n.unwrap_or(fr),
        };
        if in_cut {
            n += 1;
            let e = f - r.force_ref_n.unwrap_or(fr);
            se += e * e;
            sum += f;
        }
    }
    let nf = n.max(1) as f64;
    CutMetrics {
        force_ref_n: fr,
        cut_periods: n,
        rms_error_n: (se / nf).sqrt(),
        peak_force_n: peak,
        mean_force_cut_n: sum / nf,
        cycle_time_s: rows.last().map_or(0.0, |r| r.t_s),
        override_switches: switches,
    }
}

/// RMS of the measured force difference between two runs period by period (over the
/// common length, rows where both have a force), N — the twin's fidelity when `b` replays
/// `a` with the recorded preset.
pub fn force_difference_rms_n(a: &[RunRecord], b: &[RunRecord]) -> f64 {
    let (mut n, mut s) = (0usize, 0.0);
    for (ra, rb) in a.iter().zip(b) {
        if let (Some(fa), Some(fb)) = (ra.force_n, rb.force_n) {
            n += 1;
            s += (fa - fb) * (fa - fb);
        }
    }
    (s / n.max(1) as f64).sqrt()
}

/// The `acc replay` table: recorded and what-if side by side with the difference.
pub fn side_by_side(rec: &CutMetrics, wi: &CutMetrics) -> String {
    let mut out =
        "| figure | recorded | what-if | difference |\n| --- | ---: | ---: | ---: |\n".to_string();
    let mut row = |name: &str, a: f64, b: f64, digits: usize| {
        out.push_str(&format!(
            "| {name} | {a:.digits$} | {b:.digits$} | {:+.digits$} |\n",
            b - a
        ));
    };
    row("force reference Fr [N]", rec.force_ref_n, wi.force_ref_n, 1);
    row(
        "force RMS error in cut [N]",
        rec.rms_error_n,
        wi.rms_error_n,
        1,
    );
    row("peak force [N]", rec.peak_force_n, wi.peak_force_n, 1);
    row(
        "mean force in cut [N]",
        rec.mean_force_cut_n,
        wi.mean_force_cut_n,
        1,
    );
    row("cycle time [s]", rec.cycle_time_s, wi.cycle_time_s, 1);
    row(
        "override switches",
        rec.override_switches as f64,
        wi.override_switches as f64,
        0,
    );
    out
}
