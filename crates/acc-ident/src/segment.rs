//! Segmentation of a log by regime (air, entry, steady cut, depth change, override step)
//! and the per-segment bias test.

use serde::Serialize;

use crate::replay::Inputs;
use crate::stats::{normal_quantile, Noise};

/// Operating regime of a stretch of the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Regime {
    /// No engagement (depth 0) with the spindle on.
    Air,
    /// The first `transient_s` after the tool enters the material.
    Entry,
    /// Cutting with no recent change of depth or feed command.
    SteadyCut,
    /// The first `transient_s` after a change of radial or axial depth.
    DepthChange,
    /// The first `transient_s` after a step of the feed command.
    OverrideStep,
    /// Spindle stopped.
    Idle,
}

impl Regime {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Regime::Air => "air",
            Regime::Entry => "entry",
            Regime::SteadyCut => "steady_cut",
            Regime::DepthChange => "depth_change",
            Regime::OverrideStep => "override_step",
            Regime::Idle => "idle",
        }
    }
}

/// A contiguous run of rows in one regime.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Segment {
    /// First row (inclusive).
    pub start: usize,
    /// Last row (exclusive).
    pub end: usize,
    /// Regime.
    pub regime: Regime,
}

/// Label every row with its regime. `transient_s` is how long entry, depth-change and
/// override-step regimes last after their event, s.
pub fn label_rows(inp: &Inputs, transient_s: f64) -> Vec<Regime> {
    let n = inp.len();
    let mut out = vec![Regime::SteadyCut; n];
    let mut last_entry = f64::NEG_INFINITY;
    let mut last_depth = f64::NEG_INFINITY;
    let mut last_step = f64::NEG_INFINITY;
    for i in 0..n {
        let t = inp.t_s[i];
        if i > 0 {
            let was_cut = inp.is_cut(i - 1);
            if inp.is_cut(i) && !was_cut {
                last_entry = t;
            } else if inp.is_cut(i) {
                let rel = |a: f64, b: f64| (a - b).abs() > 0.02 * a.abs().max(b.abs());
                if rel(inp.radial_depth_mm[i], inp.radial_depth_mm[i - 1])
                    || rel(inp.axial_depth_mm[i], inp.axial_depth_mm[i - 1])
                {
                    last_depth = t;
                }
            }
            let cmd = inp.feed_cmd_mm_min.as_ref().unwrap_or(&inp.feed_mm_min);
            if (cmd[i] - cmd[i - 1]).abs() > 0.04 * cmd[i].abs().max(cmd[i - 1].abs()) {
                last_step = t;
            }
        }
        out[i] = if inp.spindle_rpm[i] <= 0.0 {
            Regime::Idle
        } else if !inp.is_cut(i) {
            Regime::Air
        } else if t - last_entry < transient_s {
            Regime::Entry
        } else if t - last_depth < transient_s {
            Regime::DepthChange
        } else if t - last_step < transient_s {
            Regime::OverrideStep
        } else {
            Regime::SteadyCut
        };
    }
    out
}

/// Contiguous runs of equal labels.
pub fn segments(labels: &[Regime]) -> Vec<Segment> {
    let mut out: Vec<Segment> = Vec::new();
    for (i, &r) in labels.iter().enumerate() {
        match out.last_mut() {
            Some(s) if s.regime == r => s.end = i + 1,
            _ => out.push(Segment {
                start: i,
                end: i + 1,
                regime: r,
            }),
        }
    }
    out
}

/// Bias of one segment.
#[derive(Debug, Clone, Serialize)]
pub struct SegmentBias {
    /// Regime.
    pub regime: Regime,
    /// Start time, s.
    pub t_start_s: f64,
    /// End time, s.
    pub t_end_s: f64,
    /// Rows.
    pub samples: usize,
    /// Mean residual (measured − model), channel unit.
    pub bias: f64,
    /// Bias divided by its standard error (AR(1) noise).
    pub z: f64,
    /// `true` when |z| exceeds the Bonferroni-corrected 5 % two-sided threshold.
    pub significant: bool,
}

/// Per-segment mean residual with its AR(1) standard error
/// `σ·sqrt((1+ρ)/((1−ρ)·n))` (the variance of the mean of an AR(1) series, see
/// [`crate::stats`]); flagged when significant after a Bonferroni correction over all
/// segments considered. Segments shorter than `min_len` rows are merged out of the test.
pub fn segment_biases(
    residual: &[f64],
    segs: &[Segment],
    t_s: &[f64],
    noise: Noise,
    min_len: usize,
) -> Vec<SegmentBias> {
    let tested: Vec<&Segment> = segs.iter().filter(|s| s.end - s.start >= min_len).collect();
    let m = tested.len().max(1) as f64;
    let zc = normal_quantile(1.0 - 0.025 / m);
    let rho = noise.rho.clamp(0.0, 0.99);
    tested
        .into_iter()
        .map(|s| {
            let r = &residual[s.start..s.end];
            let n = r.len() as f64;
            let bias = r.iter().sum::<f64>() / n;
            let se = noise.sigma * ((1.0 + rho) / ((1.0 - rho) * n)).sqrt();
            let z = if se > 0.0 { bias / se } else { 0.0 };
            SegmentBias {
                regime: s.regime,
                t_start_s: t_s[s.start],
                t_end_s: t_s[s.end - 1],
                samples: s.end - s.start,
                bias,
                z,
                significant: z.abs() > zc,
            }
        })
        .collect()
}
