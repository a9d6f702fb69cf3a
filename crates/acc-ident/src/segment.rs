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

/// The smallest segment bias that counts, channel unit: a flagged bias must be
/// statistically significant *and* of practical size. Significance alone flags ever
/// smaller biases as a log grows — on a 10-minute production log a 73 s stretch biased by
/// 0.07 % of the force is significant against a noise of 5 N — and a bias of a steady
/// stretch within the rounding of a coarsely quantised channel is the rounding, not the
/// model (docs/twin.md, "The practical floor").
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PracticalSize {
    /// The largest bias the channel's rounding can leave on the mean of a steady stretch,
    /// channel unit ([`rounding_bias`]).
    pub rounding: f64,
    /// Share of the segment's mean |measured| level below which a bias is not of
    /// practical size, − ([`PRACTICAL_BIAS_SHARE`] in the workflow).
    pub share: f64,
}

impl PracticalSize {
    /// No floor: significance alone decides.
    pub const NONE: Self = Self {
        rounding: 0.0,
        share: 0.0,
    };

    /// The floor for a segment whose mean |measured| value is `level`, channel unit.
    pub fn floor(&self, level: f64) -> f64 {
        self.rounding.max(self.share * level.abs())
    }
}

/// The largest bias that rounding to steps of `q` leaves on the mean of a steady signal
/// with Gaussian noise of standard deviation `sigma` (before the rounding), channel unit.
/// The rounding error is a sawtooth in the signal's offset within a step,
/// `Σₖ (−1)ᵏ·q/(πk)·sin(2πk·y/q)`; under Gaussian noise each term is damped by the
/// noise's characteristic function at `2πk/q` (Widrow & Kollár, *Quantization Noise*,
/// 2008, ch. 5), so the mean error is at most `Σₖ q/(πk)·exp(−2π²k²σ²/q²)`, and never more
/// than `q/2`, the bias of a noise-free signal. With `σ ≥ q/2` it is below 0.3 % of a step:
/// the noise dithers the rounding away.
pub fn rounding_bias(q: f64, sigma: f64) -> f64 {
    if q <= 0.0 {
        return 0.0;
    }
    let x = std::f64::consts::PI * sigma.max(0.0) / q;
    let mut sum = 0.0;
    for k in 1..=2000 {
        let kf = k as f64;
        let term = q / (std::f64::consts::PI * kf) * (-2.0 * x * x * kf * kf).exp();
        sum += term;
        if term < 1e-9 * q || sum >= 0.5 * q {
            break;
        }
    }
    sum.min(0.5 * q)
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
    /// The practical floor of this segment ([`PracticalSize::floor`] of its mean
    /// |measured| level), channel unit.
    pub floor: f64,
    /// `true` when |z| exceeds the Bonferroni-corrected 5 % two-sided threshold and |bias|
    /// exceeds `floor`.
    pub significant: bool,
}

/// Per-segment mean residual with its AR(1) standard error
/// `σ·sqrt((1+ρ)/((1−ρ)·n))` (the variance of the mean of an AR(1) series, see
/// [`crate::stats`]); flagged when significant after a Bonferroni correction over all
/// segments considered and larger than the segment's practical floor (`practical`, on the
/// segment's mean |`measured`|). Segments shorter than `min_len` rows are merged out of the
/// test.
pub fn segment_biases(
    residual: &[f64],
    measured: &[f64],
    segs: &[Segment],
    t_s: &[f64],
    noise: Noise,
    min_len: usize,
    practical: PracticalSize,
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
            let level = measured[s.start..s.end]
                .iter()
                .map(|v| v.abs())
                .sum::<f64>()
                / n;
            let floor = practical.floor(level);
            let se = noise.sigma * ((1.0 + rho) / ((1.0 - rho) * n)).sqrt();
            let z = if se > 0.0 { bias / se } else { 0.0 };
            SegmentBias {
                regime: s.regime,
                t_start_s: t_s[s.start],
                t_end_s: t_s[s.end - 1],
                samples: s.end - s.start,
                bias,
                z,
                floor,
                significant: z.abs() > zc && bias.abs() > floor,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn one_segment(n: usize) -> Vec<Segment> {
        vec![Segment {
            start: 0,
            end: n,
            regime: Regime::SteadyCut,
        }]
    }

    #[test]
    fn a_significant_bias_below_the_practical_floor_is_not_flagged() {
        // 700 rows biased by 0.5 N on a level of 800 N with a noise of 5 N: z ≈ 2.6 for
        // one segment (threshold 1.96), but 0.06 % of the level.
        let n = 700;
        let measured = vec![800.0; n];
        let residual = vec![0.5; n];
        let t: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
        let noise = Noise {
            sigma: 5.0,
            rho: 0.0,
            samples: n,
        };
        let segs = one_segment(n);
        let plain = segment_biases(
            &residual,
            &measured,
            &segs,
            &t,
            noise,
            3,
            PracticalSize::NONE,
        );
        assert!(plain[0].significant, "z {}", plain[0].z);
        let practical = PracticalSize {
            rounding: 0.0,
            share: 0.002,
        };
        let b = &segment_biases(&residual, &measured, &segs, &t, noise, 3, practical)[0];
        assert!((b.floor - 1.6).abs() < 1e-12, "floor {}", b.floor);
        assert!(!b.significant);
        // Four times the bias clears both the test and the floor.
        let big = vec![2.0; n];
        assert!(segment_biases(&big, &measured, &segs, &t, noise, 3, practical)[0].significant);
    }

    #[test]
    fn the_rounding_bias_is_half_a_step_without_noise_and_vanishes_with_it() {
        assert_eq!(rounding_bias(1.0, 0.0), 0.5);
        assert_eq!(rounding_bias(0.0, 3.0), 0.0);
        assert!(rounding_bias(1.0, 0.5) < 0.003);
        assert!(rounding_bias(1.0, 0.2) > rounding_bias(1.0, 0.3));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// The mean error of rounding a steady value plus Gaussian noise to whole steps
        /// stays within `rounding_bias` (plus the sampling error of 20 000 draws).
        #[test]
        fn rounding_a_noisy_steady_value_biases_its_mean_at_most_by_the_bound(
            level in 100.0f64..1000.0,
            sigma in 0.05f64..0.8,
            seed in 0u64..1000,
        ) {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let normal = Normal::new(0.0, sigma).expect("σ in 0.05..0.8 is a valid standard deviation");
            let n = 20_000;
            let err: f64 = (0..n)
                .map(|_| {
                    let y = level + normal.sample(&mut rng);
                    y.round() - y
                })
                .sum::<f64>()
                / n as f64;
            // The rounding error is within ±0.5, so its mean's sampling σ ≤ 0.5/√n.
            let slack = 4.0 * 0.5 / (n as f64).sqrt();
            prop_assert!(err.abs() <= rounding_bias(1.0, sigma) + slack,
                "level {level} σ {sigma}: mean error {err} > bound {}", rounding_bias(1.0, sigma));
        }
    }
}
