//! The `ks_step` candidate: `Ks` factors per row from the tool-centre positions, with the
//! simulator's engagement weighting across the material boundary.

#[allow(unused_imports)]
use super::*;

/// The `ks_step` candidate's `Ks` factors per row over the period and over the channel's
/// window (the last `win_frac` of the period), with the tool centre moving from
/// `x_start[i]` to `x_end[i]` (mm) in row `i`; the boundary (mm) is placed on the path from
/// where the first cutting row (`cut`) begins to where the last one ends. The factor at a
/// tool-centre position is `at(x, b)` (the simulator's engagement-weighted `Ks` factor,
/// see [`KsStepShape`]), averaged over [`KS_SUB`] positions per period. `None`: no
/// candidate or no cutting row.
pub(super) fn ks_step_factors(
    step: Option<crate::effects::KsStep>,
    x_start: &[f64],
    x_end: &[f64],
    cut: &[bool],
    win_frac: &[f64],
    shape: &KsStepShape<'_>,
) -> Option<(f64, Vec<f64>, Vec<f64>)> {
    let step = step?;
    let first = cut.iter().position(|c| *c)?;
    let last = cut.iter().rposition(|c| *c)?;
    let b = step.boundary_mm(x_start[first], x_end[last]);
    let stepped = shape.stepped(b, step.delta);
    let n = x_end.len();
    let mut mean = vec![1.0; n];
    let mut win = vec![1.0; n];
    for i in 0..n {
        let (x0, x1) = (x_start[i], x_end[i]);
        let w = win_frac[i].clamp(0.0, 1.0);
        let (mut s, mut sw, mut nw) = (0.0, 0.0, 0usize);
        for j in 0..KS_SUB {
            let u = (j as f64 + 0.5) / KS_SUB as f64;
            let g = shape.factor(stepped.as_ref(), x0 + u * (x1 - x0), b, step.delta, i);
            s += g;
            if u >= 1.0 - w {
                sw += g;
                nw += 1;
            }
        }
        mean[i] = s / KS_SUB as f64;
        win[i] = if nw > 0 { sw / nw as f64 } else { mean[i] };
    }
    Some((b, mean, win))
}

/// Positions per period at which the `ks_step` factor is evaluated.
pub(super) const KS_SUB: usize = 8;

/// How a material boundary meets the tool: the simulator's engagement over the tool's
/// arc ([`acc_sim::Workpiece::engagement`], the `Ks` factor weighted by lateral extent)
/// when the replay runs on the workpiece, else the same arc geometry with the logged
/// radial depth of the row.
pub(super) enum KsStepShape<'a> {
    /// The workpiece the replay runs on.
    Workpiece(&'a acc_sim::Workpiece, f64),
    /// Logged radial depths per row, mm, and the tool radius, mm.
    Logged(&'a [f64], f64),
}

impl KsStepShape<'_> {
    /// The workpiece with the material from `b` on (mm) at `Ks × (1 + δ)`.
    pub(super) fn stepped(&self, b: f64, delta: f64) -> Option<acc_sim::Workpiece> {
        let KsStepShape::Workpiece(wp, _) = self else {
            return None;
        };
        let mut out = (*wp).clone();
        out.segments.clear();
        for g in &wp.segments {
            if g.end_mm <= b {
                out.segments.push(*g);
            } else if g.start_mm >= b {
                out.segments.push(acc_sim::workpiece::Segment {
                    ks_factor: g.ks_factor * (1.0 + delta),
                    ..*g
                });
            } else {
                let d = g.depth_at(b);
                out.segments.push(acc_sim::workpiece::Segment {
                    end_mm: b,
                    depth_end_mm: d,
                    ..*g
                });
                out.segments.push(acc_sim::workpiece::Segment {
                    start_mm: b,
                    depth_start_mm: d,
                    ks_factor: g.ks_factor * (1.0 + delta),
                    ..*g
                });
            }
        }
        Some(out)
    }

    /// Factor on the replayed force with the tool centre at `x` (row `i`), boundary `b`.
    pub(super) fn factor(
        &self,
        stepped: Option<&acc_sim::Workpiece>,
        x: f64,
        b: f64,
        delta: f64,
        i: usize,
    ) -> f64 {
        let r = match self {
            KsStepShape::Workpiece(_, r) | KsStepShape::Logged(_, r) => *r,
        };
        // The engaged arc lies ahead of the tool centre, within one radius.
        if x >= b {
            return 1.0 + delta;
        }
        if x + r <= b {
            return 1.0;
        }
        match (self, stepped) {
            (KsStepShape::Workpiece(wp, _), Some(st)) => {
                let e0 = wp.engagement(x, r);
                let e1 = st.engagement(x, r);
                if e0.radial_mm > 0.0 && e0.ks_factor > 0.0 {
                    e1.ks_factor / e0.ks_factor
                } else {
                    1.0
                }
            }
            (KsStepShape::Logged(depth, _), _) => {
                // Lateral extent y of the arc sits (r² − (r − y)²)^½ ahead of the centre:
                // past the boundary for y > r − (r² − (b − x)²)^½.
                let d = depth.get(i).copied().unwrap_or(0.0);
                if d <= 0.0 {
                    return 1.0;
                }
                let off = b - x;
                let y = r - (r * r - off * off).max(0.0).sqrt();
                1.0 + delta * ((d - y) / d).clamp(0.0, 1.0)
            }
            _ => 1.0,
        }
    }
}
