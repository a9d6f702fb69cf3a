//! Material removal along the path, and the engagement at every path step.
//!
//! Each move is divided into `n = ⌈L / step⌉` equal steps; step `k = 1..=n` puts the tool tip
//! at `from + (k/n)·(to − from)`. For every step, first the engagement is read off the
//! leading half of the tool circle ([`crate::engagement`]), then the cutter lowers every
//! cell whose centre lies under it to its surface there (a flat end: the tip height; a ball
//! nose: `tip + R − √(R² − r²)`).
//!
//! **What the probes see.** The material the engagement is measured against is the stock
//! *before the current move*, cut down exactly by the part of the current move already
//! done (for a flat end that never reaches the leading half of its rim, which lies ahead;
//! for a ball nose it does, the thin chip its front surface takes being the engagement). The
//! last [`SweepOptions::exact_moves`] moves before it are not taken from the cells but from
//! their exact swept volume (the column at a probe point is cut down to the lowest height
//! the cutter's end reaches there along the segment, in closed form). Older moves are in the
//! cells. This keeps the engagement free of cell noise where it matters most: continuing a
//! cut across block boundaries, and corners, where the rim of the new move runs along the
//! boundary the previous move just left.
//!
//! Internally the sweep keeps two maps: the current stock (what [`Sweep::stock`] returns,
//! every move applied) and a lagged copy without the recent moves; when a move leaves the
//! window it is applied to the lagged copy the same way, step by step.

use std::collections::VecDeque;

use crate::cutter::{Cutter, Rotation, Shape, Spindle};
use crate::engagement::{Rim, StepEngagement, StepKind, Z_TOL_MM};
use crate::error::{in_range, StockError};
use crate::motion::Move;
use crate::zmap::{Removal, ZMap};

/// How finely the path and the tool circle are sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepOptions {
    /// Path step, mm (`None`, the default: the cell size). Range: `cell/100 ..= 4·cell`.
    pub step_mm: Option<f64>,
    /// Angular bins over the leading half (default 180: 1° each). Range 4 ..= 3600.
    pub angular_bins: usize,
    /// Recent moves whose removal the probes take from the exact swept volume instead of
    /// the cells (default 4). Range 0 ..= 64.
    pub exact_moves: usize,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            step_mm: None,
            angular_bins: 180,
            exact_moves: 4,
        }
    }
}

/// What one move did, summed over its steps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MoveSummary {
    /// Number of path steps.
    pub steps: usize,
    /// Removed volume, mm³.
    pub removed_mm3: f64,
    /// Largest radial width a_e over the steps, mm.
    pub max_ae_mm: f64,
    /// Largest effective radial depth over the steps, mm.
    pub max_radial_mm: f64,
    /// Largest axial depth a_p over the steps, mm.
    pub max_ap_mm: f64,
    /// A rapid move engaged or removed material.
    pub rapid_collision: bool,
    /// Material stood above the flutes at some step.
    pub beyond_flutes: bool,
}

/// A stock being machined by one cutter: feed it moves in path order with [`Sweep::cut`].
#[derive(Debug, Clone)]
pub struct Sweep {
    stock: ZMap,
    lagged: ZMap,
    recent: VecDeque<(Move, usize)>,
    cutter: Cutter,
    spindle: Spindle,
    step_mm: f64,
    exact_moves: usize,
    rim: Rim,
    /// Probe rings `(r, cutter surface above the tip at r, bin stride)`, mm, outermost
    /// first (for a ball nose a lower bound of the surface at the cells the ring reads; the
    /// ring is probed at every `stride`-th bin and its answer holds for the group).
    rings: Vec<(f64, f64, usize)>,
    /// Per bin: outermost engaged probe radius, mm (0: not engaged). Scratch.
    reach: Vec<f64>,
    /// Lateral extents of the arcs. Scratch.
    spans: Vec<(f64, f64)>,
    /// The highest column of the stock as given, mm: an upper bound on every height since.
    top_mm: f64,
}

impl Sweep {
    /// Start machining `stock` with `cutter` turning as `spindle`; errors name the option
    /// and its allowed range.
    pub fn new(
        stock: ZMap,
        cutter: Cutter,
        spindle: Spindle,
        options: SweepOptions,
    ) -> Result<Self, StockError> {
        let c = stock.cell_mm();
        let step_mm = match options.step_mm {
            Some(s) => in_range("step_mm", s, 0.01 * c, 4.0 * c)?,
            None => c,
        };
        in_range("angular_bins", options.angular_bins as f64, 4.0, 3600.0)?;
        in_range("exact_moves", options.exact_moves as f64, 0.0, 64.0)?;
        let r = cutter.radius_mm();
        let bin_rad = std::f64::consts::PI / options.angular_bins.max(1) as f64;
        let rings = match cutter.shape() {
            Shape::Flat => vec![(r, 0.0, 1)],
            Shape::Ball => {
                let m = (r / c).ceil().max(1.0) as usize;
                (1..=m)
                    .rev()
                    .map(|k| {
                        // The probe reads the cell centre, up to c/√2 nearer the axis: the
                        // ring's floor bound is the surface there. Inner rings are probed
                        // every `stride` bins, about every c/2 along the ring.
                        let rk = r * k as f64 / m as f64;
                        let stride = ((0.5 * c) / (rk * bin_rad)).floor().max(1.0) as usize;
                        (rk, cutter.surface_mm((rk - 0.75 * c).max(0.0)), stride)
                    })
                    .collect()
            }
        };
        let top_mm = stock.max_height_mm();
        Ok(Sweep {
            top_mm,
            lagged: stock.clone(),
            stock,
            recent: VecDeque::with_capacity(options.exact_moves + 1),
            cutter,
            spindle,
            step_mm,
            exact_moves: options.exact_moves,
            rim: Rim::new(options.angular_bins),
            rings,
            reach: vec![0.0; options.angular_bins],
            spans: Vec::with_capacity(options.angular_bins),
        })
    }

    /// Change the spindle (an S word, M3/M4) for the moves that follow.
    pub fn set_spindle(&mut self, spindle: Spindle) {
        self.spindle = spindle;
    }

    /// The cutter.
    pub fn cutter(&self) -> &Cutter {
        &self.cutter
    }

    /// The stock with every move so far removed.
    pub fn stock(&self) -> &ZMap {
        &self.stock
    }

    /// The stock with every move so far removed.
    pub fn into_stock(self) -> ZMap {
        self.stock
    }

    /// The path step in use, mm.
    pub fn step_mm(&self) -> f64 {
        self.step_mm
    }

    /// Run every move of `moves`; the engagement of every step, in path order.
    pub fn run(&mut self, moves: &[Move]) -> Vec<StepEngagement> {
        let mut out = Vec::new();
        for m in moves {
            self.cut(m, &mut out);
        }
        out
    }

    /// Machine one move: append the engagement of each of its steps to `out` (nothing for a
    /// move shorter than 1 µm or with a non-finite coordinate) and remove the material it sweeps.
    pub fn cut(&mut self, mv: &Move, out: &mut Vec<StepEngagement>) -> MoveSummary {
        let len = mv.length_mm();
        if !len.is_finite() || len <= 1e-6 {
            return MoveSummary::default();
        }
        let n = (len / self.step_mm).ceil().max(1.0) as usize;
        let start = out.len();
        let d = mv.delta();
        let dxy = d[0].hypot(d[1]);
        let vertical = dxy <= 1e-9 * len.max(1.0);
        let fz = self
            .cutter
            .feed_per_tooth_mm(mv.feed_mm_min, self.spindle.rpm);
        let dt_min = if mv.feed_mm_min > 0.0 {
            (len / n as f64) / mv.feed_mm_min
        } else {
            0.0
        };

        // Phase 1: engagement against the stock before this move.
        let frame = (!vertical).then(|| {
            let f = [d[0] / dxy, d[1] / dxy];
            let left = [-f[1], f[0]];
            let nrm = match self.spindle.rotation {
                Rotation::Clockwise => left,
                Rotation::CounterClockwise => [-left[0], -left[1]],
            };
            (f, nrm)
        });
        for k in 1..=n {
            let p = mv.at(k as f64 / n as f64);
            let mut e = StepEngagement {
                position_mm: p,
                kind: StepKind::Air,
                rapid: mv.rapid,
                entry_rad: 0.0,
                exit_rad: 0.0,
                span_rad: 0.0,
                arcs: 0,
                ae_mm: 0.0,
                radial_mm: 0.0,
                ap_mm: 0.0,
                beyond_flutes: false,
                feed_per_tooth_mm: fz,
                chip_max_mm: 0.0,
                removed_mm3: 0.0,
                removal_rate_mm3_min: 0.0,
            };
            if let Some((f, nrm)) = frame {
                // The current move up to the previous step may have cut the probes too (a
                // ball nose rising; never for the flat end's rim, which lies ahead).
                let done = (k - 1) as f64 / n as f64;
                self.leading_half(mv, done, f, nrm, &mut e);
            }
            out.push(e);
        }

        // Phase 2: removal, step by step, on the current stock.
        let flutes = self.cutter.flute_length_mm();
        let mut sum = MoveSummary {
            steps: n,
            ..MoveSummary::default()
        };
        for e in &mut out[start..] {
            let p = e.position_mm;
            let rem = remove(&mut self.stock, &self.cutter, p);
            e.removed_mm3 = rem.volume_mm3;
            if dt_min > 0.0 {
                e.removal_rate_mm3_min = rem.volume_mm3 / dt_min;
            }
            let removed = rem.volume_mm3 > 1e-9;
            if vertical && d[2] < 0.0 && removed {
                e.kind = StepKind::Plunge;
                e.ap_mm = rem.max_depth_mm.min(flutes);
                e.beyond_flutes = rem.max_depth_mm > flutes + Z_TOL_MM;
            }
            if mv.rapid && (e.kind != StepKind::Air || removed) {
                e.kind = StepKind::RapidCollision;
                sum.rapid_collision = true;
            }
            sum.removed_mm3 += e.removed_mm3;
            sum.max_ae_mm = sum.max_ae_mm.max(e.ae_mm);
            sum.max_radial_mm = sum.max_radial_mm.max(e.radial_mm);
            sum.max_ap_mm = sum.max_ap_mm.max(e.ap_mm);
            sum.beyond_flutes |= e.beyond_flutes;
        }

        // The move joins the exact window; the oldest leaves it into the lagged cells.
        self.recent.push_back((*mv, n));
        while self.recent.len() > self.exact_moves {
            let Some((old, steps)) = self.recent.pop_front() else {
                break;
            };
            for k in 1..=steps {
                remove(
                    &mut self.lagged,
                    &self.cutter,
                    old.at(k as f64 / steps as f64),
                );
            }
        }
        sum
    }

    /// Apply every move still in the exact window to the lagged cells (then both maps are
    /// equal). For tests.
    #[cfg(test)]
    fn flush(&mut self) {
        let keep = self.exact_moves;
        self.exact_moves = 0;
        while let Some((old, steps)) = self.recent.pop_front() {
            for k in 1..=steps {
                remove(
                    &mut self.lagged,
                    &self.cutter,
                    old.at(k as f64 / steps as f64),
                );
            }
        }
        self.exact_moves = keep;
    }

    /// Fill the leading-half fields of `e` for the tool at `e.position_mm` on move `mv`, of
    /// which the part `t ≤ done` is behind it, moving along `f` with the teeth coming from
    /// side `nrm`.
    fn leading_half(
        &mut self,
        mv: &Move,
        done: f64,
        f: [f64; 2],
        nrm: [f64; 2],
        e: &mut StepEngagement,
    ) {
        let p = e.position_mm;
        let base = p[2].max(self.lagged.bottom_mm());
        let flute_top = p[2] + self.cutter.flute_length_mm();
        let mut ap_raw = 0.0f64;
        let mut any = false;
        let bins = self.rim.trig.len();
        self.reach.fill(0.0);
        for &(r, surface, stride) in &self.rings {
            let floor = (p[2] + surface).max(base) + Z_TOL_MM;
            if floor >= self.top_mm {
                continue; // no column reaches this ring of a ball nose
            }
            let mut k = 0;
            while k < bins {
                let group = k..(k + stride).min(bins);
                k = group.end;
                let (s, c) = self.rim.trig[(group.start + group.end - 1) / 2];
                let (ux, uy) = (s * f[0] + c * nrm[0], s * f[1] + c * nrm[1]);
                let (qx, qy) = (p[0] + r * ux, p[1] + r * uy);
                let Some((qx, qy, h, floor)) = self.probe(p, qx, qy, base, floor) else {
                    continue;
                };
                let mut h = h;
                // The current move first (it is the likeliest to have cut here), then the
                // recent ones, newest first; stop as soon as the probe is cut down.
                if done > 0.0 {
                    if let Some(z) = mv.swept_min_surface(qx, qy, &self.cutter, done) {
                        h = h.min(z);
                    }
                }
                for (m, _) in self.recent.iter().rev() {
                    if h <= floor {
                        break;
                    }
                    if let Some(z) = m.swept_min_surface(qx, qy, &self.cutter, 1.0) {
                        h = h.min(z);
                    }
                }
                if h > floor {
                    any = true;
                    ap_raw = ap_raw.max(h - base);
                    for b in group {
                        self.reach[b] = self.reach[b].max(r);
                    }
                }
            }
        }
        if !any {
            return;
        }
        let a = self.rim.arcs(&self.reach, &mut self.spans);
        e.kind = StepKind::Cut;
        e.entry_rad = a.entry_rad;
        e.exit_rad = a.exit_rad;
        e.span_rad = a.span_rad;
        e.arcs = a.arcs;
        e.ae_mm = a.ae_mm;
        e.radial_mm = a.radial_mm;
        e.ap_mm = ap_raw.min(flute_top - base).max(0.0);
        e.beyond_flutes = ap_raw > flute_top - base + Z_TOL_MM;
        e.chip_max_mm = e.feed_per_tooth_mm * a.sin_max;
    }
}

impl Sweep {
    /// The point a probe at `(qx, qy)` reads, its column height and the height the column
    /// must exceed to engage, for the tool at `p` (mm); `None` when it cannot engage.
    ///
    /// A flat end reads the column under the probe point, against `floor` (the tip). A ball
    /// nose reads the cell's centre and its floor is the ball's surface there: the cells
    /// were cut to the surface at their centres, so a pass over a ball-cut surface must
    /// compare at the centres too, or the surface's slope across a cell would show as
    /// material (up to `slope · c/√2`).
    #[inline]
    fn probe(
        &self,
        p: [f64; 3],
        qx: f64,
        qy: f64,
        base: f64,
        floor: f64,
    ) -> Option<(f64, f64, f64, f64)> {
        match self.cutter.shape() {
            Shape::Flat => match self.lagged.height_at(qx, qy) {
                Some(h) if h > floor => Some((qx, qy, h, floor)),
                _ => None,
            },
            Shape::Ball => {
                let (cx, cy, h) = self.lagged.cell_at(qx, qy)?;
                let rc = (cx - p[0]).hypot(cy - p[1]);
                if rc >= self.cutter.radius_mm() {
                    return None;
                }
                let floor = (p[2] + self.cutter.surface_mm(rc)).max(base) + Z_TOL_MM;
                (h > floor).then_some((cx, cy, h, floor))
            }
        }
    }
}

/// Cut `map` with `cutter` at tip position `p` (mm).
fn remove(map: &mut ZMap, cutter: &Cutter, p: [f64; 3]) -> Removal {
    match cutter.shape() {
        Shape::Flat => map.cut_flat_disc(p[0], p[1], cutter.radius_mm(), p[2]),
        Shape::Ball => map.cut_ball(p[0], p[1], cutter.radius_mm(), p[2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagged_cells_catch_up_with_the_stock() {
        let stock = ZMap::from_box([0.0, 0.0, -10.0], [40.0, 30.0, 0.0], 0.5).expect("box");
        let cutter = Cutter::flat(6.0, 3, 20.0).expect("cutter");
        let mut s =
            Sweep::new(stock, cutter, Spindle::cw(1000.0), SweepOptions::default()).expect("sweep");
        let mut out = Vec::new();
        let path = [
            [-5.0, 10.0, -2.0],
            [20.0, 10.0, -2.0],
            [20.0, 20.0, -3.0],
            [45.0, 25.0, -1.0],
            [10.0, 5.0, -4.0],
            [10.0, 5.0, 2.0],
        ];
        for w in path.windows(2) {
            s.cut(&Move::feed(w[0], w[1], 500.0), &mut out);
        }
        assert_ne!(s.lagged, s.stock);
        s.flush();
        assert_eq!(s.lagged, s.stock);
    }
}
