//! Where the tool stood when a production log began, estimated from the log itself.
//!
//! A log from `acc run` places its engagement by the path travelled since the first read
//! (`x_mm`) and by the workpiece coordinate of the tool centre at that read, `--x0-mm`
//! ([`crate::engagement::PathEngagement`]). An integrator rarely knows that offset to a
//! tenth of a millimetre, and a tenth matters: every entry and depth change of the
//! replay then comes a fraction of a period early or late, which leaves a spike in the
//! residual at each of them that no effect in the library explains (docs/twin.md, "Where
//! the tool stood").
//!
//! When the start is not given ([`super::Options::estimate_path_start`]), the replay's
//! start is searched along the path: on the log's first part ([`ESTIMATED_SHARE_OF_LOG`] of it, at least
//! [`MIN_ROWS`] rows), for each trial start the model as given is replayed once and the
//! residual is high-passed — first differences between consecutive valid rows, the
//! replay's scaled by the factor that fits the measured ones best (`Ks`; a constant level
//! drops out). A slow discrepancy (tool wear, a drift) hardly moves the differences; a
//! misplaced edge does. The sum of their squares is minimised over a grid of
//! [`GRID_STEP_MM`] across ±[`SEARCH_MM`], then by golden-section search inside the best
//! grid cell to [`TOLERANCE_MM`]. The estimate is adopted only when it cuts that sum to at
//! most [`ADOPT_RATIO`] of the given start's and does not lie at the search's bound; a log
//! whose start was right (a simulator's log, which places itself, or `acc board-sim
//! --wait-for-controller`, whose first read sees the held machine) keeps it.

use super::*;
use crate::report::PathShift;
use acc_sim::Workpiece;

/// Half-width of the search around the given start, mm.
pub const SEARCH_MM: f64 = 3.0;
/// Step of the coarse grid, mm.
pub const GRID_STEP_MM: f64 = 0.5;
/// Width at which the golden-section search stops, mm. A start 0.03 mm off left a bias
/// of 4.8 W (z 52 against whole-watt rounding) at the first entry of the speed
/// benchmark's log; 0.001 mm is well below what the rounding can show.
pub const TOLERANCE_MM: f64 = 0.001;
/// The estimate is adopted when the high-passed residual's sum of squares falls to at
/// most this fraction of the given start's.
pub const ADOPT_RATIO: f64 = 0.8;
/// Share of the log, from its beginning, the start is estimated on.
pub const ESTIMATED_SHARE_OF_LOG: f64 = 0.25;
/// Fewest rows the start is estimated on (the whole log when it is shorter).
pub const MIN_ROWS: usize = 300;

/// The start of the replay that `opts` gives for `log`, mm (workpiece coordinate): the
/// log's own ([`RunLog::path_start_mm`]) under `opts.anchor_to_log`, else the given one.
pub(super) fn given_start_mm(log: &RunLog, opts: &Options) -> Option<f64> {
    let (_, x0) = opts.workpiece.as_ref()?;
    Some(if opts.anchor_to_log {
        log.path_start_mm().unwrap_or(*x0)
    } else {
        *x0
    })
}

/// Estimate how far the replay's start lies from the given one (see the module). `None`
/// without a workpiece or with too few valid rows.
pub fn estimate_path_shift(
    model: &Model,
    log: &RunLog,
    opts: &Options,
) -> Result<Option<PathShift>, WorkflowError> {
    let (Some((wp, _)), Some(start)) = (&opts.workpiece, given_start_mm(log, opts)) else {
        return Ok(None);
    };
    let n = ((log.len() as f64 * ESTIMATED_SHARE_OF_LOG) as usize)
        .max(MIN_ROWS)
        .min(log.len());
    let head = log.slice(0..n);
    let valid: Vec<bool> = head
        .dead_rows(model.measurement.channel)
        .iter()
        .map(Option::is_none)
        .collect();
    let rows: Vec<usize> = (0..n).filter(|&i| valid[i]).collect();
    if rows.len() < MIN_ROWS / 2 {
        return Ok(None);
    }
    let mut inp = Inputs::from_log(&head, model)?;
    // One replay per trial start, its differences scaled by the factor that fits the
    // measured ones best (`Ks`; a constant level such as the no-load power drops out of a
    // difference): Σ(Δm − k·Δp)² at its least, Σ Δm² − (Σ Δm·Δp)² / Σ Δp².
    let mut sse = |shift: f64| -> f64 {
        inp.use_workpiece(wp.clone(), start + shift);
        let p = replay(model, &inp).predicted;
        let (mut mm, mut mp, mut pp) = (0.0, 0.0, 0.0);
        for i in (1..n).filter(|&i| valid[i] && valid[i - 1]) {
            let dm = inp.measured[i] - inp.measured[i - 1];
            let dp = p[i] - p[i - 1];
            mm += dm * dm;
            mp += dm * dp;
            pp += dp * dp;
        }
        if pp > 0.0 {
            mm - mp * mp / pp
        } else {
            mm
        }
    };
    let sse_given = sse(0.0);
    let k = (SEARCH_MM / GRID_STEP_MM).round() as i32;
    let (mut best, mut best_sse) = (0.0, sse_given);
    for j in (-k..=k).filter(|&j| j != 0) {
        let s = f64::from(j) * GRID_STEP_MM;
        let v = sse(s);
        if v < best_sse {
            (best, best_sse) = (s, v);
        }
    }
    let (shift, sse_estimated) = golden_min(
        &mut sse,
        (best - GRID_STEP_MM).max(-SEARCH_MM),
        (best + GRID_STEP_MM).min(SEARCH_MM),
        TOLERANCE_MM,
        (best, best_sse),
    );
    let at_bound = SEARCH_MM - shift.abs() < GRID_STEP_MM / 2.0;
    let adopted = !at_bound && sse_estimated <= ADOPT_RATIO * sse_given;
    Ok(Some(PathShift {
        given_start_mm: start,
        shift_mm: shift,
        sse_given,
        sse_estimated,
        rows: n,
        adopted,
        at_bound,
    }))
}

/// Golden-section search for the minimum of `f` on `[a, b]` down to a width of `tol`;
/// `seed` (a point and its value) is returned when nothing better is found.
fn golden_min(
    f: &mut impl FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    tol: f64,
    seed: (f64, f64),
) -> (f64, f64) {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut best = seed;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > tol {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
        for (x, v) in [(c, fc), (d, fd)] {
            if v < best.1 {
                best = (x, v);
            }
        }
    }
    best
}

/// `log` with its path moved `shift_mm` (mm) along `workpiece`: the positions shifted and
/// the depth columns rebuilt from the workpiece there, for a tool of `tool_radius_mm`.
pub(super) fn shifted(
    log: &RunLog,
    shift_mm: f64,
    workpiece: &Workpiece,
    tool_radius_mm: f64,
) -> RunLog {
    let mut out = log.clone();
    if let Some(x) = out.x_mm.as_mut() {
        for (i, xi) in x.iter_mut().enumerate() {
            *xi += shift_mm;
            let e = workpiece.engagement(*xi, tool_radius_mm);
            out.radial_depth_mm[i] = e.radial_mm;
            out.axial_depth_mm[i] = e.axial_mm;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::golden_min;

    #[test]
    fn golden_section_finds_the_minimum_of_a_v() {
        let mut calls = 0;
        let mut f = |x: f64| {
            calls += 1;
            (x - 0.333).abs()
        };
        let (x, v) = golden_min(&mut f, 0.0, 1.0, 0.005, (0.5, 0.167));
        assert!((x - 0.333).abs() < 0.005, "{x}");
        assert!(v < 0.005);
        assert!(calls < 20, "{calls}");
    }

    #[test]
    fn golden_section_keeps_the_seed_when_nothing_is_lower() {
        let mut f = |_x: f64| 1.0;
        assert_eq!(golden_min(&mut f, -1.0, 1.0, 0.01, (0.0, 0.5)), (0.0, 0.5));
    }
}
