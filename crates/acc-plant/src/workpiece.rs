//! Workpieces along the tool path.
//!
//! A workpiece is a sequence of segments measured in mm of **tool travel** (not time): air
//! gaps, constant radial depth, linear depth ramps, each with a material factor on `Ks`
//! (a material change or a hard inclusion is a segment with `ks_factor ≠ 1`). Because the
//! geometry is along the path, a faster feed really finishes the part sooner.
//!
//! Coordinates: `u` is the position along the path in mm, 0 at the start of the first
//! segment; the tool centre travels from `u = 0` to `u = length_mm()`. The cutter engages the
//! material *ahead* of its centre (down milling, peripheral cut): a cutter point at angle ψ
//! from the finished wall sits at forward offset `R·sin ψ` and lateral height
//! `R·(1 − cos ψ)` above the wall, and it cuts when that height is below the material depth
//! at its forward position. [`Workpiece::engagement`] integrates this exactly, so tool entry
//! and depth steps ramp the force in over the real contact length `√(d·(D − d))`.

use std::path::Path;

use acc_config::RangeError;
use acc_config::{check_range, load_toml, ConfigError};
use serde::Deserialize;

use crate::engagement::Engagement;

/// One segment as written in a workpiece TOML file (`[[segment]]` tables).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SegmentSpec {
    /// No material: the tool cuts air.
    Air {
        /// Travel, mm (> 0).
        length_mm: f64,
    },
    /// Constant radial depth.
    Cut {
        /// Travel, mm (> 0).
        length_mm: f64,
        /// Radial depth of cut, mm (0 < d ≤ tool diameter; checked when the tool is known).
        depth_mm: f64,
        /// Multiplier on `Ks` for this material (default 1; a hard inclusion is e.g. 1.4).
        #[serde(default)]
        ks_factor: Option<f64>,
    },
    /// Radial depth changing linearly from `from_mm` to `to_mm`.
    Ramp {
        /// Travel, mm (> 0).
        length_mm: f64,
        /// Radial depth at the start of the ramp, mm.
        from_mm: f64,
        /// Radial depth at the end of the ramp, mm.
        to_mm: f64,
        /// Multiplier on `Ks` (default 1).
        #[serde(default)]
        ks_factor: Option<f64>,
    },
}

/// A workpiece TOML file (`configs/workpieces/*.toml`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WorkpieceFile {
    /// Human-readable name (used in summaries and plot titles).
    pub name: String,
    /// Axial depth of cut, mm: the width of the block the flank of the end mill cuts
    /// (paper: SB40 block 16 mm wide).
    pub axial_depth_mm: f64,
    /// The segments in path order.
    #[serde(rename = "segment")]
    pub segments: Vec<SegmentSpec>,
}

/// What a segment is, after validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SegmentKind {
    /// No material.
    Air,
    /// Constant depth.
    Cut,
    /// Linear depth ramp.
    Ramp,
}

/// A validated segment with absolute start and end positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Kind.
    pub kind: SegmentKind,
    /// Start position along the path, mm.
    pub start_mm: f64,
    /// End position along the path, mm.
    pub end_mm: f64,
    /// Radial depth at the start, mm (0 for air).
    pub depth_start_mm: f64,
    /// Radial depth at the end, mm (0 for air).
    pub depth_end_mm: f64,
    /// Multiplier on `Ks`.
    pub ks_factor: f64,
}

impl Segment {
    /// Radial depth at path position `u` (mm), assuming `u` lies in this segment.
    pub fn depth_at(&self, u: f64) -> f64 {
        let len = self.end_mm - self.start_mm;
        if len <= 0.0 {
            return self.depth_end_mm;
        }
        let s = ((u - self.start_mm) / len).clamp(0.0, 1.0);
        self.depth_start_mm + s * (self.depth_end_mm - self.depth_start_mm)
    }

    /// Whether the segment has material.
    pub fn is_cut(&self) -> bool {
        self.kind != SegmentKind::Air
    }

    /// Short label for summaries, e.g. `"cut 2.0 mm"` or `"ramp 2.0→4.0 mm"`.
    pub fn label(&self) -> String {
        let ks = if (self.ks_factor - 1.0).abs() > 1e-9 {
            format!(" Ks×{:.2}", self.ks_factor)
        } else {
            String::new()
        };
        match self.kind {
            SegmentKind::Air => "air".to_string(),
            SegmentKind::Cut => format!("cut {:.1} mm{ks}", self.depth_start_mm),
            SegmentKind::Ramp => format!(
                "ramp {:.1}→{:.1} mm{ks}",
                self.depth_start_mm, self.depth_end_mm
            ),
        }
    }
}

/// Measure of `{y ∈ [ya, yb] : g(y) > 0}` for the smooth `g(y) = depth(x + u'(y)) − y`
/// of a ramp: sign changes located on 32 sub-intervals, each refined by bisection to
/// 1e-9 mm (g has at most two roots there: `u'(y)` is concave and the depth linear).
fn ramp_engaged(ya: f64, yb: f64, g: impl Fn(f64) -> f64) -> f64 {
    if yb <= ya {
        return 0.0;
    }
    const SUB: usize = 32;
    let dy = (yb - ya) / SUB as f64;
    let mut total = 0.0;
    let mut y0 = ya;
    let mut g0 = g(y0);
    for k in 1..=SUB {
        let y1 = if k == SUB { yb } else { ya + k as f64 * dy };
        let g1 = g(y1);
        total += match (g0 > 0.0, g1 > 0.0) {
            (true, true) => y1 - y0,
            (false, false) => 0.0,
            (pos0, _) => {
                let (mut lo, mut hi) = (y0, y1);
                while hi - lo > 1e-9 {
                    let mid = 0.5 * (lo + hi);
                    if (g(mid) > 0.0) == pos0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                if pos0 {
                    lo - y0
                } else {
                    y1 - hi
                }
            }
        };
        y0 = y1;
        g0 = g1;
    }
    total
}

/// A validated workpiece.
#[derive(Debug, Clone, PartialEq)]
pub struct Workpiece {
    /// Name.
    pub name: String,
    /// Axial depth of cut, mm.
    pub axial_depth_mm: f64,
    /// Segments in path order, contiguous from 0.
    pub segments: Vec<Segment>,
}

impl Workpiece {
    /// Load and validate a workpiece file. Every error names the file and the key
    /// (`segment[i].depth_mm`, ...) with its allowed range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let file: WorkpieceFile = load_toml(path)?;
        Self::from_file(path, &file)
    }

    /// Validate a parsed file; `path` is used in error messages only.
    pub fn from_file(path: &Path, file: &WorkpieceFile) -> Result<Self, ConfigError> {
        check_range(path, "axial_depth_mm", file.axial_depth_mm, 0.01, 200.0)?;
        if file.segments.is_empty() {
            return Err(ConfigError::Invalid {
                file: path.to_path_buf(),
                key: "segment".into(),
                message: "a workpiece needs at least one [[segment]]".into(),
            });
        }
        let mut segments = Vec::with_capacity(file.segments.len());
        let mut pos = 0.0;
        for (i, spec) in file.segments.iter().enumerate() {
            let key = |k: &str| format!("segment[{i}].{k}");
            let (kind, length, d0, d1, ks) = match *spec {
                SegmentSpec::Air { length_mm } => (SegmentKind::Air, length_mm, 0.0, 0.0, None),
                SegmentSpec::Cut {
                    length_mm,
                    depth_mm,
                    ks_factor,
                } => {
                    check_range(path, &key("depth_mm"), depth_mm, 1e-3, 100.0)?;
                    (SegmentKind::Cut, length_mm, depth_mm, depth_mm, ks_factor)
                }
                SegmentSpec::Ramp {
                    length_mm,
                    from_mm,
                    to_mm,
                    ks_factor,
                } => {
                    check_range(path, &key("from_mm"), from_mm, 0.0, 100.0)?;
                    check_range(path, &key("to_mm"), to_mm, 0.0, 100.0)?;
                    (SegmentKind::Ramp, length_mm, from_mm, to_mm, ks_factor)
                }
            };
            check_range(path, &key("length_mm"), length, 1e-3, 1e5)?;
            let ks_factor = match ks {
                Some(k) => check_range(path, &key("ks_factor"), k, 0.01, 100.0)?,
                None => 1.0,
            };
            segments.push(Segment {
                kind,
                start_mm: pos,
                end_mm: pos + length,
                depth_start_mm: d0,
                depth_end_mm: d1,
                ks_factor,
            });
            pos += length;
        }
        Ok(Workpiece {
            name: file.name.clone(),
            axial_depth_mm: file.axial_depth_mm,
            segments,
        })
    }

    /// Check that no depth exceeds the tool diameter (slotting is the limit).
    pub fn check_tool(&self, path: &Path, diameter_mm: f64) -> Result<(), ConfigError> {
        for (i, s) in self.segments.iter().enumerate() {
            // The key as written in the file: `depth_mm` of a cut, `from_mm`/`to_mm` of a ramp.
            let keys = match s.kind {
                SegmentKind::Ramp => ["from_mm", "to_mm"],
                SegmentKind::Cut | SegmentKind::Air => ["depth_mm", "depth_mm"],
            };
            for (k, d) in keys.into_iter().zip([s.depth_start_mm, s.depth_end_mm]) {
                if d > diameter_mm {
                    return Err(ConfigError::OutOfRange(
                        RangeError::new(
                            format!("segment[{i}].{k}"),
                            d.to_string(),
                            format!("0 ..= {diameter_mm} (the tool diameter)"),
                        )
                        .in_file(path),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Total path length, mm.
    pub fn length_mm(&self) -> f64 {
        self.segments.last().map_or(0.0, |s| s.end_mm)
    }

    /// Largest radial depth anywhere, mm.
    pub fn max_depth_mm(&self) -> f64 {
        self.segments
            .iter()
            .map(|s| s.depth_start_mm.max(s.depth_end_mm))
            .fold(0.0, f64::max)
    }

    /// Index of the segment containing path position `u` (segments are half-open
    /// `[start, end)`), `None` outside the workpiece.
    pub fn segment_index_at(&self, u: f64) -> Option<usize> {
        if !(0.0..self.length_mm()).contains(&u) {
            return None;
        }
        // Few segments: a binary search on the end positions.
        let i = self.segments.partition_point(|s| s.end_mm <= u);
        (i < self.segments.len()).then_some(i)
    }

    /// Material depth at path position `u`, mm (0 in air and outside the workpiece).
    pub fn depth_at(&self, u: f64) -> f64 {
        self.segment_index_at(u)
            .map_or(0.0, |i| self.segments[i].depth_at(u))
    }

    /// `Ks` factor at path position `u` (1 outside the workpiece).
    pub fn ks_factor_at(&self, u: f64) -> f64 {
        self.segment_index_at(u)
            .map_or(1.0, |i| self.segments[i].ks_factor)
    }

    /// If the material over `[x, x + reach]` is one constant-depth segment (or air), its
    /// depth and `Ks` factor: the fast path of the engagement and tooth models.
    pub fn uniform_over(&self, x: f64, reach: f64) -> Option<(f64, f64)> {
        let end = x + reach;
        if x >= self.length_mm() || end < 0.0 {
            return Some((0.0, 1.0));
        }
        let i = self.segment_index_at(x.max(0.0))?;
        let s = &self.segments[i];
        let inside = x >= s.start_mm && end < s.end_mm;
        let constant = s.depth_start_mm == s.depth_end_mm;
        (inside && constant).then_some((s.depth_start_mm, s.ks_factor))
    }

    /// The interval `[lo, hi)` of tool-centre positions around `x` over which
    /// [`Workpiece::uniform_over`] with reach `reach` gives the same depth and `Ks` factor
    /// as at `x`; `None` where it gives none at `x`.
    pub fn uniform_span(&self, x: f64, reach: f64) -> Option<(f64, f64)> {
        self.uniform_over(x, reach)?;
        let len = self.length_mm();
        if x >= len {
            return Some((len, f64::INFINITY));
        }
        if x + reach < 0.0 {
            return Some((f64::NEG_INFINITY, -reach));
        }
        // Inside one constant segment: from its start until the reach meets its end.
        let s = &self.segments[self.segment_index_at(x.max(0.0))?];
        Some((s.start_mm, s.end_mm - reach))
    }

    /// Engaged arc of a cutter of radius `radius_mm` whose centre is at path position `x`
    /// (down milling, material ahead of the centre), at the workpiece's axial depth (the
    /// workpiece's [`crate::engagement::EngagementSource`]).
    ///
    /// A cutter point at lateral height `y` above the finished wall (0 ≤ y ≤ 2R) sits at
    /// forward offset `u'(y) = √(R² − (R − y)²)`; it is in material when
    /// `y < depth(x + u'(y))`. With chip thickness `h = f_z·sin ψ` (seed 004), the mean force
    /// over a revolution is proportional to `∫ sin ψ dψ` over the engaged angles, i.e. to
    /// the engaged lateral extent `∫ dy` — which is what `radial_mm` returns. It is exact for
    /// constant-depth segments (breakpoints solved analytically) and solved by bisection
    /// inside ramps.
    pub fn engagement(&self, x: f64, radius_mm: f64) -> Engagement {
        let r = radius_mm;
        if let Some((d, ks)) = self.uniform_over(x, r) {
            let depth = d.min(2.0 * r);
            return Engagement {
                radial_mm: depth,
                axial_mm: self.axial_depth_mm,
                ks_factor: if depth > 0.0 { ks } else { 1.0 },
            };
        }
        // Breakpoints in y where x + u'(y) crosses a segment boundary.
        let mut ys: [f64; 64] = [0.0; 64];
        let mut n = 0;
        let push = |ys: &mut [f64; 64], n: &mut usize, y: f64| {
            if *n < ys.len() {
                ys[*n] = y;
                *n += 1;
            }
        };
        push(&mut ys, &mut n, 0.0);
        push(&mut ys, &mut n, 2.0 * r);
        for s in &self.segments {
            for b in [s.start_mm, s.end_mm] {
                let off = b - x;
                if off > 0.0 && off <= r {
                    let h = (r * r - off * off).sqrt();
                    push(&mut ys, &mut n, r - h);
                    push(&mut ys, &mut n, r + h);
                }
            }
        }
        let ys = &mut ys[..n];
        ys.sort_by(f64::total_cmp);
        let fwd = |y: f64| x + (r * r - (r - y) * (r - y)).max(0.0).sqrt();
        let mut extent = 0.0;
        let mut ks_sum = 0.0;
        for w in ys.windows(2) {
            let (ya, yb) = (w[0], w[1]);
            if yb - ya <= 0.0 {
                continue;
            }
            let ym = 0.5 * (ya + yb);
            let Some(i) = self.segment_index_at(fwd(ym)) else {
                continue;
            };
            let seg = &self.segments[i];
            let engaged = if seg.depth_start_mm == seg.depth_end_mm {
                (seg.depth_start_mm.clamp(ya, yb)) - ya
            } else {
                ramp_engaged(ya, yb.min(seg.depth_start_mm.max(seg.depth_end_mm)), |y| {
                    seg.depth_at(fwd(y)) - y
                })
            };
            extent += engaged;
            ks_sum += engaged * seg.ks_factor;
        }
        Engagement {
            radial_mm: extent,
            axial_mm: self.axial_depth_mm,
            ks_factor: if extent > 0.0 { ks_sum / extent } else { 1.0 },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(segs: Vec<SegmentSpec>) -> Workpiece {
        let file = WorkpieceFile {
            name: "t".into(),
            axial_depth_mm: 16.0,
            segments: segs,
        };
        Workpiece::from_file(Path::new("t.toml"), &file).expect("valid")
    }

    fn steps() -> Workpiece {
        wp(vec![
            SegmentSpec::Air { length_mm: 20.0 },
            SegmentSpec::Cut {
                length_mm: 40.0,
                depth_mm: 2.0,
                ks_factor: None,
            },
            SegmentSpec::Cut {
                length_mm: 40.0,
                depth_mm: 3.0,
                ks_factor: Some(1.4),
            },
            SegmentSpec::Air { length_mm: 20.0 },
        ])
    }

    #[test]
    fn positions_and_depths() {
        let w = steps();
        assert_eq!(w.length_mm(), 120.0);
        assert_eq!(w.depth_at(10.0), 0.0);
        assert_eq!(w.depth_at(20.0), 2.0);
        assert_eq!(w.depth_at(60.0), 3.0);
        assert_eq!(w.ks_factor_at(70.0), 1.4);
        assert_eq!(w.segment_index_at(120.0), None);
        assert_eq!(w.max_depth_mm(), 3.0);
    }

    #[test]
    fn engagement_ramps_in_over_the_contact_length() {
        let w = steps();
        let r = 8.0;
        // Contact length at 2 mm: sqrt(d (D - d)) = sqrt(28) = 5.29 mm ahead of the centre.
        let lc = (2.0f64 * 14.0).sqrt();
        assert_eq!(w.engagement(20.0 - lc - 0.01, r).radial_mm, 0.0);
        let half = w.engagement(20.0 - 0.5 * lc, r).radial_mm;
        assert!(half > 0.0 && half < 2.0, "{half}");
        // Exact: at offset o the engaged extent is d − (R − √(R² − o²)).
        let o: f64 = 3.0;
        let expect = 2.0 - (r - (r * r - o * o).sqrt());
        let got = w.engagement(20.0 - o, r).radial_mm;
        assert!((got - expect).abs() < 1e-12, "{got} vs {expect}");
        assert_eq!(w.engagement(30.0, r).radial_mm, 2.0);
    }

    #[test]
    fn engagement_through_a_step_is_monotone_and_weights_ks() {
        let w = steps();
        let mut last = 0.0;
        for k in 0..100 {
            let x = 50.0 + 0.1 * k as f64;
            let e = w.engagement(x, 8.0);
            assert!(
                e.radial_mm >= last - 1e-12 && e.radial_mm <= 3.0 + 1e-12,
                "{x} {e:?} {last}"
            );
            assert!(e.ks_factor >= 1.0 && e.ks_factor <= 1.4 + 1e-12);
            last = e.radial_mm;
        }
        assert_eq!(w.engagement(61.0, 8.0).radial_mm, 3.0);
        assert_eq!(w.engagement(61.0, 8.0).ks_factor, 1.4);
    }

    #[test]
    fn ramp_engagement_follows_the_depth() {
        let w = wp(vec![
            SegmentSpec::Air { length_mm: 20.0 },
            SegmentSpec::Ramp {
                length_mm: 100.0,
                from_mm: 2.0,
                to_mm: 4.0,
                ks_factor: None,
            },
            SegmentSpec::Air { length_mm: 20.0 },
        ]);
        // In the middle of the ramp (slope k = 0.02) the engaged depth is the root of
        // y = 3 + k·√(R² − (R − y)²): the material ahead is deeper than at the centre.
        let e = w.engagement(70.0, 8.0).radial_mm;
        let root = 3.0 + 0.02 * (64.0 - (8.0 - e) * (8.0 - e)).sqrt();
        assert!(e > 3.1 && (e - root).abs() < 1e-6, "{e} vs {root}");
    }

    #[test]
    fn bad_values_name_the_key() {
        let file = WorkpieceFile {
            name: "t".into(),
            axial_depth_mm: 16.0,
            segments: vec![SegmentSpec::Cut {
                length_mm: 10.0,
                depth_mm: -1.0,
                ks_factor: None,
            }],
        };
        let err = Workpiece::from_file(Path::new("w.toml"), &file).expect_err("negative depth");
        assert!(err.to_string().contains("segment[0].depth_mm"), "{err}");
        assert!(err.to_string().contains("w.toml"), "{err}");
    }
}
