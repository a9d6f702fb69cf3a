//! The cutter–workpiece engagement of one path step, and how it is read off the leading
//! half of the tool circle.
//!
//! **Convention (Altintas' immersion angle).** In the tool frame, `f` is the unit feed
//! direction in XY and `n` the normal on the side the teeth come from: for a clockwise
//! spindle (M3, seen from above) `n` is the *left* normal (`f` turned +90°), for a
//! counter-clockwise spindle the right normal. The immersion angle `φ` of a point of the
//! tool circle is measured from `n` towards `f`: the rim point is
//! `centre + R·(sin φ · f + cos φ · n)`. The leading half is `0 ≤ φ ≤ π`; a tooth sweeps it
//! from `φ = 0` (side `n`) through `φ = π/2` (straight ahead) to `φ = π`, cutting a chip
//! `h = f_z · sin φ` (seed 004). So, with a clockwise spindle:
//!
//! - slot: entry 0, exit π, `a_e = D`;
//! - up milling (material on the left) at radial width `a_e`: entry 0,
//!   exit `acos(1 − 2a_e/D)`;
//! - down milling (material on the right): entry `π − acos(1 − 2a_e/D)`, exit π. The
//!   plant's angle `ψ` "from the finished wall" (`acc_plant::process::ToothModel`) is
//!   `ψ = π − φ` here.
//!
//! **Method.** The leading half is sampled at `N` equal angular bins (default 180, 1° each);
//! bin `k` covers `[kπ/N, (k+1)π/N)` and is probed along its centre line: for a flat end
//! mill at one point, on the circle of radius R; for a ball nose at rings `r = R·m/M`,
//! `m = 1..=M`, `M = ⌈R/c⌉` (c the cell size), an inner ring only at every few bins (about
//! every c/2 along the ring; the answer holds for the group). A flat end's probe is engaged
//! when the material column under it rises more than [`Z_TOL_MM`] above the tip and the
//! stock bottom; a ball nose's probe reads the cell containing it and is engaged when that
//! column rises above the ball's surface `tip + R − √(R² − r_c²)` at the cell centre
//! (distance `r_c` from the axis: where the cells were cut). A bin is engaged when one of
//! its probes is. Entry and exit are the outer edges of the first and
//! last engaged bins; the span is the number of engaged bins times π/N; an arc is a run of
//! consecutive engaged bins. Lateral extents (`a_e`, the effective radial depth) are taken
//! over each bin's outermost engaged probe, at the bin's edges.

use std::f64::consts::PI;

/// Material thinner than this above the tip does not engage, mm (covers the `f32`
/// rounding of cut heights).
pub const Z_TOL_MM: f64 = 1e-3;

/// What a path step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepKind {
    /// Nothing engaged on the leading half and (for a vertical move) nothing removed.
    Air,
    /// The leading half is engaged: side milling, slotting, ramping.
    Cut,
    /// A vertical move down into material: axial engagement only (the end face cuts;
    /// `a_e`, the angles and the arcs are 0).
    Plunge,
    /// A rapid (non-cutting) move that engaged or removed material. The material is
    /// removed all the same (the crash happened); the engagement fields are filled in.
    RapidCollision,
}

/// The cutter–workpiece engagement at one path step, measured *before* the step removes
/// material. Angles in radians (see the module docs for the convention), lengths in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepEngagement {
    /// Tool tip position at the step (centre of the end face), mm.
    pub position_mm: [f64; 3],
    /// What the step did.
    pub kind: StepKind,
    /// Whether the step belongs to a rapid move.
    pub rapid: bool,
    /// Entry angle φ_st: start of the first engaged arc, rad, in `[0, π]` (0 when not
    /// engaged).
    pub entry_rad: f64,
    /// Exit angle φ_ex: end of the last engaged arc, rad, in `[entry_rad, π]` (0 when not
    /// engaged).
    pub exit_rad: f64,
    /// Engaged angular span: sum of the arcs' lengths, rad (`≤ exit − entry`).
    pub span_rad: f64,
    /// Number of separate engaged arcs (2 or more: the tool re-enters within one half
    /// revolution, e.g. at a pocket corner or over a cut-through slot).
    pub arcs: u32,
    /// Radial width of cut a_e, mm: the extent perpendicular to the feed from the first
    /// entry to the last exit, `R·(cos φ_st − cos φ_ex)` for a flat end mill (≤ D; for a
    /// ball nose over the outermost engaged points, e.g. `2√(2R·a_p − a_p²)` in a slot).
    pub ae_mm: f64,
    /// Effective radial depth, mm: the sum over the arcs of their extents perpendicular to
    /// the feed, `R·Σ(cos φ_st,k − cos φ_ex,k)` for a flat end mill. Equals `ae_mm` for one arc; it is
    /// `acc_plant::Engagement::radial_mm` (the mean force over a revolution is
    /// proportional to it, `∫ sin φ dφ`).
    pub radial_mm: f64,
    /// Axial depth of cut a_p, mm: the highest material column above the tip over the
    /// engaged probes, capped by the flute length (for a plunge: the largest thickness the
    /// end face removes at this step).
    pub ap_mm: f64,
    /// Material stands above the flutes (the uncapped a_p exceeds the flute length): the
    /// shank or holder would rub.
    pub beyond_flutes: bool,
    /// Feed per tooth f_z = v_f / (n·z), mm (0 with the spindle stopped).
    pub feed_per_tooth_mm: f64,
    /// Largest chip thickness over the engaged arcs, `f_z · max sin φ`, mm (seed 004; for a
    /// ball nose an upper bound: the chip thins towards the tip).
    pub chip_max_mm: f64,
    /// Volume removed by this step, mm³ (from the cells).
    pub removed_mm3: f64,
    /// Material removal rate, mm³/min: removed volume over the step's time at the move's
    /// feed (0 at zero feed).
    pub removal_rate_mm3_min: f64,
}

impl StepEngagement {
    /// Whether anything is engaged (a cut, a plunge or a rapid collision).
    pub fn engaged(&self) -> bool {
        self.kind != StepKind::Air
    }
}

/// The engaged arcs read off the bins of the leading half.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Arcs {
    pub entry_rad: f64,
    pub exit_rad: f64,
    pub span_rad: f64,
    pub arcs: u32,
    pub ae_mm: f64,
    pub radial_mm: f64,
    /// max sin φ over the engaged arcs.
    pub sin_max: f64,
}

/// Probe directions of the leading half: bin centres `φ_k = (k + ½)·π/N`.
#[derive(Debug, Clone)]
pub(crate) struct Rim {
    /// `(sin φ_k, cos φ_k)`.
    pub trig: Vec<(f64, f64)>,
    /// `cos(kπ/N)` for the bin edges `k = 0..=N`.
    edge_cos: Vec<f64>,
    bin_rad: f64,
}

impl Rim {
    /// `bins` equal bins over `[0, π]`.
    pub fn new(bins: usize) -> Self {
        let bins = bins.max(1);
        let bin_rad = PI / bins as f64;
        Rim {
            trig: (0..bins)
                .map(|k| ((k as f64 + 0.5) * bin_rad).sin_cos())
                .collect(),
            edge_cos: (0..=bins).map(|k| (k as f64 * bin_rad).cos()).collect(),
            bin_rad,
        }
    }

    /// The arcs of the engaged bins: `reach[k]` is the distance from the axis of the
    /// outermost engaged probe of bin `k`, mm (0: bin not engaged; R for a flat end mill).
    /// The lateral coordinate (across the feed, towards `n`) of a point is `r·cos φ`; an
    /// arc's extent is the interval from the smallest to the largest over its bins'
    /// outermost points; the effective radial depth is the length of the union of the arcs'
    /// extents (for a flat end mill they are disjoint, and it is their sum). `spans` is
    /// scratch space.
    pub fn arcs(&self, reach: &[f64], spans: &mut Vec<(f64, f64)>) -> Arcs {
        spans.clear();
        let mut out = Arcs::default();
        let n = reach.len();
        let (mut hi_all, mut lo_all) = (f64::MIN, f64::MAX);
        let mut k = 0;
        while k < n {
            if reach[k] <= 0.0 {
                k += 1;
                continue;
            }
            let start = k;
            let (mut hi, mut lo) = (f64::MIN, f64::MAX);
            while k < n && reach[k] > 0.0 {
                hi = hi.max(reach[k] * self.edge_cos[k]);
                lo = lo.min(reach[k] * self.edge_cos[k + 1]);
                k += 1;
            }
            let (a, b) = (start as f64 * self.bin_rad, k as f64 * self.bin_rad);
            if out.arcs == 0 {
                out.entry_rad = a;
            }
            out.exit_rad = b;
            out.arcs += 1;
            out.span_rad += b - a;
            spans.push((lo, hi));
            hi_all = hi_all.max(hi);
            lo_all = lo_all.min(lo);
            let s = if a <= 0.5 * PI && b >= 0.5 * PI {
                1.0
            } else {
                a.sin().max(b.sin())
            };
            out.sin_max = out.sin_max.max(s);
        }
        if out.arcs > 0 {
            out.ae_mm = hi_all - lo_all;
        }
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut reach_hi = f64::MIN;
        for &(lo, hi) in spans.iter() {
            out.radial_mm += (hi - lo.max(reach_hi)).max(0.0);
            reach_hi = reach_hi.max(hi);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_of_bins() {
        let rim = Rim::new(4);
        let mut spans = Vec::new();
        let a = rim.arcs(&[5.0; 4], &mut spans);
        assert_eq!(a.arcs, 1);
        assert!((a.span_rad - PI).abs() < 1e-12 && (a.ae_mm - 10.0).abs() < 1e-12);
        assert_eq!(a.sin_max, 1.0);
        let b = rim.arcs(&[5.0, 0.0, 0.0, 5.0], &mut spans);
        assert_eq!(b.arcs, 2);
        assert!((b.entry_rad, b.exit_rad) == (0.0, PI));
        // Two 45° arcs at the sides: each 5·(1 − cos 45°) wide.
        let side = 5.0 * (1.0 - (0.25 * PI).cos());
        assert!((b.radial_mm - 2.0 * side).abs() < 1e-12);
        assert!((b.ae_mm - 10.0).abs() < 1e-12);
        assert_eq!(rim.arcs(&[0.0; 4], &mut spans), Arcs::default());
        // A ball nose in a shallow slot: engaged out to 4 mm only, 8 mm wide.
        let c = rim.arcs(&[4.0; 4], &mut spans);
        assert!((c.ae_mm - 8.0).abs() < 1e-12 && (c.span_rad - PI).abs() < 1e-12);
        // Two arcs whose extents overlap (a ball nose reaching unevenly): the union counts.
        // Bin 0 (0..22.5°) out to 1 mm spans [0.92, 1]; bin 2 (45..67.5°) out to 2 mm spans
        // [0.77, 1.41], which contains it.
        let d = Rim::new(8).arcs(&[1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0], &mut spans);
        let second = 2.0 * ((0.25 * PI).cos() - (0.375 * PI).cos());
        assert_eq!(d.arcs, 2);
        assert!((d.radial_mm - second).abs() < 1e-12, "{d:?}");
    }
}
