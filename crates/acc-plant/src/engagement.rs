//! What the tool engages, and where the plant asks for it.
//!
//! The plant asks one question every internal step: *what does the tool engage at its
//! path position now?* The answer is one value, [`Engagement`] (radial depth as the
//! engaged lateral extent, axial depth, `Ks` factor of the material under the arc). The
//! question goes to an [`EngagementSource`]:
//!
//! - [`Workpiece`]: the 1-D workpiece of the scenario files (steps and ramps along the
//!   path, down milling, the material ahead of the tool centre);
//! - [`EngagementProfile`]: the engagement a run log recorded along the path (the what-if
//!   on a recorded cut);
//! - [`Held`]: one engagement wherever the tool is, and [`Ramp`]: the chord between two
//!   logged rows (the replay of a log that records its depths but not where they are).
//!
//! A source that holds stock (an NC program over a Z-map) is another implementation: the
//! plant calls [`EngagementSource::engagement_at`] once per internal step in path order,
//! with `&mut self`, so it may remove the material the tool swept.

use crate::config::ToolSpec;
use crate::workpiece::Workpiece;

/// Engaged part of the cutter at one tool position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Engagement {
    /// Effective radial depth, mm: the lateral extent of the engaged arc (0 in air). With
    /// chip thickness `h = f_z·sin ψ` (seed 004) the mean force over a revolution is
    /// proportional to it; it equals the material depth in a uniform stretch.
    pub radial_mm: f64,
    /// Axial depth of cut, mm.
    pub axial_mm: f64,
    /// `Ks` factor of the material under the engaged arc (weighted by lateral extent), −;
    /// 1 when not engaged.
    pub ks_factor: f64,
}

impl Engagement {
    /// Nothing engaged at axial depth `axial_mm` (mm).
    pub fn air(axial_mm: f64) -> Self {
        Engagement {
            radial_mm: 0.0,
            axial_mm,
            ks_factor: 1.0,
        }
    }
}

/// The cutter as an engagement source sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolGeometry {
    /// Diameter D, mm.
    pub diameter_mm: f64,
    /// Number of flutes z, −.
    pub flutes: usize,
}

impl ToolGeometry {
    /// The geometry of a tool file.
    pub fn of(tool: &ToolSpec) -> Self {
        ToolGeometry {
            diameter_mm: tool.diameter_mm,
            flutes: tool.flutes,
        }
    }

    /// Radius R = D/2, mm.
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }
}

/// What an NC program says at a path position: the programmed feed (or a rapid), the
/// block the board reports as `BLOCK_NUMBER` and the tool it reports as `TOOL_NUMBER`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Programmed feed, mm/min (for a rapid: the machine's rapid rate).
    pub feed_mm_min: f64,
    /// A rapid move: the feed override does not apply (a feed hold does).
    pub rapid: bool,
    /// Block number: the N word, else the line number.
    pub block: u32,
    /// Tool number (0: none named).
    pub tool: u32,
}

/// Where the plant's engagement comes from (see the module docs). Object safe: the
/// machine holds a `Box<dyn EngagementSource>`.
pub trait EngagementSource: std::fmt::Debug + Send {
    /// The engagement of `tool` with its centre at path position `x_mm` (mm). Called by the
    /// plant once per internal step, in path order.
    fn engagement_at(&mut self, tool: &ToolGeometry, x_mm: f64) -> Engagement;

    /// The program's feed, block and tool at path position `x_mm` (mm). `None` (the
    /// default, a 1-D workpiece): the machine's programmed feed, and the board's NC
    /// context numbers the workpiece's segments.
    fn path_at(&self, _x_mm: f64) -> Option<PathPoint> {
        None
    }

    /// Length of the whole path, mm; `None` (the default): the workpiece's length.
    fn path_length_mm(&self) -> Option<f64> {
        None
    }

    /// A copy of this source in its current state, if it can be copied (the oracle of
    /// `acc compare` runs copies of the plant ahead of the run; default: `None`).
    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        None
    }
}

impl EngagementSource for Workpiece {
    /// [`Workpiece::engagement`] of the tool's radius, at the workpiece's axial depth.
    fn engagement_at(&mut self, tool: &ToolGeometry, x_mm: f64) -> Engagement {
        self.engagement(x_mm, tool.radius_mm())
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(self.clone()))
    }
}

/// A workpiece as the plant's engagement source: [`Workpiece::engagement`], with the span
/// of positions over which the last one holds unchanged (inside one constant-depth
/// segment, or in the air before or after the workpiece), so that a tool moving through
/// that span gets it back without the geometry. The result is the workpiece's own.
#[derive(Debug, Clone)]
pub struct WorkpieceSource {
    workpiece: Workpiece,
    /// `[lo, hi)` of tool-centre positions, mm, the radius it holds for, mm, and the
    /// engagement there.
    span: Option<(f64, f64, f64, Engagement)>,
}

impl WorkpieceSource {
    /// The source of `workpiece`.
    pub fn new(workpiece: Workpiece) -> Self {
        Self {
            workpiece,
            span: None,
        }
    }
}

impl EngagementSource for WorkpieceSource {
    fn engagement_at(&mut self, tool: &ToolGeometry, x_mm: f64) -> Engagement {
        let r = tool.radius_mm();
        if let Some((lo, hi, held_r, e)) = self.span {
            if held_r == r && x_mm >= lo && x_mm < hi {
                return e;
            }
        }
        let e = self.workpiece.engagement(x_mm, r);
        self.span = self
            .workpiece
            .uniform_span(x_mm, r)
            .map(|(lo, hi)| (lo, hi, r, e));
        e
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(self.clone()))
    }
}

/// One engagement wherever the tool is (a replayed log row's depths, `Ks` factor as given).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held(pub Engagement);

impl EngagementSource for Held {
    fn engagement_at(&mut self, _tool: &ToolGeometry, _x_mm: f64) -> Engagement {
        self.0
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(*self))
    }
}

/// A replayed log row whose depths were sampled at the end of its period, the row
/// before's at its start: the engagement along the chord between the two samples, from
/// `from` at `x_start_mm` to `to` at `x_start_mm + length_mm`, `to` beyond. Where the
/// engagement changes inside a period (an entry, an exit, a depth step) this is the
/// unbiased guess of where; holding `to` over the whole period ([`Held`]) would put every
/// change one period early.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    /// Engagement at the period's start (the row before's sample).
    pub from: Engagement,
    /// Engagement at the period's end (the row's sample).
    pub to: Engagement,
    /// Tool-centre position at the period's start, mm.
    pub x_start_mm: f64,
    /// Path over which the engagement changes, mm (≤ 0: the row's engagement at once).
    pub length_mm: f64,
}

impl EngagementSource for Ramp {
    /// The radial depth along the chord; the axial depth is the row's own (`to`, or
    /// `from`'s where the row is in air) throughout: one depth per period, as a log of 1-D
    /// cuts and the synthetic logs record it (where an NC program's axial depth changes
    /// inside a period, `acc discrepancy` leaves the row out of the comparison,
    /// `acc_ident::dead::dead_rows`); the `Ks` factor of the engaged end, both ends' mixed
    /// in a cut.
    fn engagement_at(&mut self, _tool: &ToolGeometry, x_mm: f64) -> Engagement {
        let s = if self.length_mm > 0.0 {
            ((x_mm - self.x_start_mm) / self.length_mm).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let (a, b) = (self.from, self.to);
        let (a_cut, b_cut) = (a.radial_mm > 0.0, b.radial_mm > 0.0);
        Engagement {
            radial_mm: a.radial_mm + s * (b.radial_mm - a.radial_mm),
            axial_mm: if b_cut || !a_cut {
                b.axial_mm
            } else {
                a.axial_mm
            },
            ks_factor: match (a_cut, b_cut) {
                (true, true) => a.ks_factor + s * (b.ks_factor - a.ks_factor),
                (false, true) => b.ks_factor,
                _ => a.ks_factor,
            },
        }
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(*self))
    }
}

/// The engagement a run log recorded, as a function of the path position: per row the
/// true tool position, the engaged radial and axial depth and the effective `Ks` factor;
/// linear in between, air before the first and after the last row. Built by
/// [`crate::whatif`] from an `acc sim` log's plant-truth columns.
#[derive(Debug, Clone, PartialEq)]
pub struct EngagementProfile {
    x_mm: Vec<f64>,
    points: Vec<Engagement>,
}

impl EngagementProfile {
    /// A profile of `points` at the increasing path positions `x_mm` (mm); `None` when the
    /// lengths differ or a position goes backwards.
    pub fn new(x_mm: Vec<f64>, points: Vec<Engagement>) -> Option<Self> {
        let forward = x_mm.windows(2).all(|w| w[1] >= w[0] - 1e-9);
        (x_mm.len() == points.len() && forward).then_some(Self { x_mm, points })
    }

    /// The engagement at path position `x_mm`: linear between the recorded positions,
    /// air before the first and after the last (pure, allocation-free).
    pub fn at(&self, x_mm: f64) -> Engagement {
        let air = Engagement::air(self.points.first().map_or(0.0, |p| p.axial_mm));
        let n = self.x_mm.len();
        if n == 0 || !x_mm.is_finite() || x_mm < self.x_mm[0] || x_mm > self.x_mm[n - 1] {
            return air;
        }
        let k = self.x_mm.partition_point(|&x| x < x_mm);
        if k == 0 {
            return self.points[0];
        }
        let (x0, x1) = (self.x_mm[k - 1], self.x_mm[k]);
        let (a, b) = (self.points[k - 1], self.points[k]);
        if x1 - x0 <= 1e-12 {
            return b;
        }
        let s = (x_mm - x0) / (x1 - x0);
        let lerp = |u: f64, v: f64| u + s * (v - u);
        Engagement {
            radial_mm: lerp(a.radial_mm, b.radial_mm),
            axial_mm: lerp(a.axial_mm, b.axial_mm),
            // The factor of the engaged end (a row in air has factor 1 by convention).
            ks_factor: if a.radial_mm > 0.0 && b.radial_mm > 0.0 {
                lerp(a.ks_factor, b.ks_factor)
            } else if b.radial_mm > 0.0 {
                b.ks_factor
            } else {
                a.ks_factor
            },
        }
    }

    /// The recorded engagements, in path order.
    pub fn points(&self) -> &[Engagement] {
        &self.points
    }

    /// Where a run on the profile ends, mm: midway between the last two recorded
    /// positions, so a twin stops in the period the recorded run stopped in when it moves
    /// alike.
    pub fn end_mm(&self) -> f64 {
        match self.x_mm.as_slice() {
            [] => 0.0,
            [x] => *x,
            [.., a, b] => 0.5 * (a + b),
        }
    }

    /// Number of recorded positions.
    pub fn len(&self) -> usize {
        self.x_mm.len()
    }

    /// Whether the profile is empty.
    pub fn is_empty(&self) -> bool {
        self.x_mm.is_empty()
    }
}

impl EngagementSource for EngagementProfile {
    fn engagement_at(&mut self, _tool: &ToolGeometry, x_mm: f64) -> Engagement {
        self.at(x_mm)
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(self.clone()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::configs_dir;

    #[test]
    fn every_source_answers_through_the_trait_object() {
        let wp = Workpiece::load(configs_dir().join("workpieces/steps_2_3_4.toml")).expect("wp");
        let tool = ToolGeometry {
            diameter_mm: 16.0,
            flutes: 4,
        };
        let e = Engagement {
            radial_mm: 2.0,
            axial_mm: 16.0,
            ks_factor: 1.5,
        };
        let profile = EngagementProfile::new(vec![0.0, 10.0], vec![Engagement::air(16.0), e])
            .expect("forward");
        let mut sources: Vec<Box<dyn EngagementSource>> =
            vec![Box::new(wp.clone()), Box::new(Held(e)), Box::new(profile)];
        // 10 mm into the 2 mm step (15 mm of air first): fully engaged.
        assert_eq!(
            sources[0].engagement_at(&tool, 25.0),
            wp.engagement(25.0, 8.0)
        );
        assert_eq!(sources[0].engagement_at(&tool, 25.0).radial_mm, 2.0);
        assert_eq!(sources[1].engagement_at(&tool, -5.0), e);
        // Half-way: the engaged end's factor, depths linear; air past the end.
        let mid = sources[2].engagement_at(&tool, 5.0);
        assert_eq!((mid.radial_mm, mid.ks_factor), (1.0, 1.5));
        assert_eq!(sources[2].engagement_at(&tool, 11.0), Engagement::air(16.0));
        assert!(EngagementProfile::new(vec![1.0, 0.0], vec![e, e]).is_none());
    }

    #[test]
    fn a_ramp_runs_the_chord_between_two_rows() {
        let tool = ToolGeometry {
            diameter_mm: 16.0,
            flutes: 4,
        };
        let e = Engagement {
            radial_mm: 3.0,
            axial_mm: 16.0,
            ks_factor: 1.4,
        };
        // From air logged with axial depth 0 (a convention) into the cut over 10..14 mm.
        let mut r = Ramp {
            from: Engagement::air(0.0),
            to: e,
            x_start_mm: 10.0,
            length_mm: 4.0,
        };
        let at = |r: &mut Ramp, x: f64| r.engagement_at(&tool, x);
        let start = at(&mut r, 10.0);
        assert_eq!(start.radial_mm, 0.0);
        // The air end takes the engaged end's axial depth and factor.
        let mid = at(&mut r, 11.0);
        assert_eq!(
            (mid.radial_mm, mid.axial_mm, mid.ks_factor),
            (0.75, 16.0, 1.4)
        );
        assert_eq!(at(&mut r, 14.0), e);
        assert_eq!(at(&mut r, 30.0), e);
        assert_eq!(at(&mut r, 5.0).radial_mm, 0.0);
        // Between two cuts both ends' radial depth and factor count; the axial depth is
        // the row's own from the start (one depth per period).
        let mut step = Ramp {
            from: Engagement {
                radial_mm: 1.0,
                axial_mm: 8.0,
                ks_factor: 1.0,
            },
            ..r
        };
        let mid = at(&mut step, 12.0);
        assert_eq!((mid.radial_mm, mid.ks_factor), (2.0, 1.2));
        assert_eq!(at(&mut step, 10.0).axial_mm, 16.0);
        // Leaving the cut: the engaged end's axial depth.
        let mut exit = Ramp {
            from: e,
            to: Engagement::air(0.0),
            ..r
        };
        assert_eq!(at(&mut exit, 11.0).axial_mm, 16.0);
    }
}
