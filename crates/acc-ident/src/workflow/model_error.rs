//! The model error's own structure, the yardstick of a name where the replay is not exact.
//!
//! On a log the simulator's plant replays exactly (the workpiece given, the applied
//! override logged) a correct model leaves only noise, and a name whose updated model
//! leaves a biased stretch in the sealed part is withheld (`report::assemble`). On logged
//! depths and real machines a model error remains whatever is named: every segment keeps
//! a bias of its own, so that rule would withhold every name. There the yardstick is the
//! model error measured where the fit was made: the spread of the selection part's
//! block biases beyond their noise, after the updated model's fit (a random-effects
//! variance by the method of moments, `τ² = max(0, mean(bᵢ² − seᵢ²))`, DerSimonian and
//! Laird 1986). A sealed block whose bias stands out of `√(τ² + se²)` at the Bonferroni
//! level is error the model did not have where it was fitted. When the names moved every
//! such block toward the measurement and left it on the same side (the effect is right
//! but grows faster there than its law: the turning tools' wear accelerating at the end
//! of their life) the names stand and the blocks are reported; when the names made one of
//! them materially worse (beyond that bound, its floor and a share of what they fixed on
//! the sealed part, `sealed_rule`), they explain the rows they saw but not the ones they
//! did not, and are withheld. Both parts are judged in blocks of one length ([`SEALED_BLOCKS`]), outside
//! the rows where the engagement changes inside a period ([`ENGAGEMENT_CHANGES`]), where
//! the logged-depth replay has an error of its own. A model error that is large where
//! the names were fitted (a hard band of the part the logged depths do not carry) hides
//! every single block, so the sealed part is also judged as a whole ([`sealed_error`]):
//! names that predict it worse than the model without them, beyond the noise, are
//! withheld.

#[allow(unused_imports)]
use super::*;
use crate::report::{ModelError, SealedBlock, SealedError};
use crate::segment::{Regime, Segment, SegmentBias};

/// Fewest selection blocks the model error is estimated from: with fewer the spread of
/// the biases is not a variance (no judgement is made, and the report says so).
pub const MODEL_ERROR_MIN_SEGMENTS: usize = 4;

/// The standard error of a segment's bias (its AR(1) noise), channel unit.
fn standard_error(b: &SegmentBias) -> f64 {
    if b.z != 0.0 {
        (b.bias / b.z).abs()
    } else {
        0.0
    }
}

/// `τ`: the spread of `biases` beyond their noise, channel unit (method of moments).
pub(super) fn bias_spread(biases: &[SegmentBias]) -> f64 {
    if biases.is_empty() {
        return 0.0;
    }
    let excess = biases
        .iter()
        .map(|b| b.bias * b.bias - standard_error(b).powi(2))
        .sum::<f64>()
        / biases.len() as f64;
    excess.max(0.0).sqrt()
}

/// The regimes in which the engagement changes inside a period: on logged depths the
/// replay runs the chord between two rows' depths there while the true engagement bends
/// (up to 25 W / 54 N off at an entry row, docs/twin.md), the known structure of that model
/// error, larger than elsewhere and the same wherever the part has an edge. They are not judged (a name that
/// moves them is neither borrowing a signature nor carrying one): the yardstick and the
/// judged blocks are the steady cut, override steps and air.
pub const ENGAGEMENT_CHANGES: [Regime; 2] = [Regime::Entry, Regime::DepthChange];

/// Blocks the sealed part is cut into for the judgement, −: the selection part, four
/// times as long, then gives about four times as many blocks of the same length to
/// measure the model error on — the yardstick and what it judges at one scale.
pub const SEALED_BLOCKS: usize = 8;

/// `segs` cut into blocks of about `len` rows (a segment shorter than `1.5·len` stays
/// whole; the blocks of one segment are of equal length).
pub(super) fn blocks(segs: &[Segment], len: usize) -> Vec<Segment> {
    let len = len.max(1);
    segs.iter()
        .flat_map(|s| {
            let n = s.end - s.start;
            let k = ((n as f64 / len as f64).round() as usize).max(1);
            (0..k).map(move |j| Segment {
                start: s.start + j * n / k,
                end: s.start + (j + 1) * n / k,
                regime: s.regime,
            })
        })
        .collect()
}

/// The model error of the updated model (`updated`, its prediction) on the selection part,
/// and the sealed blocks whose bias stands out of it at the Bonferroni level `alpha`
/// (two-sided) and above their practical floor. The sealed part is cut into about
/// [`SEALED_BLOCKS`] blocks and the selection part into blocks of the same length.
pub(super) fn judge(
    p: &Prepared,
    updated: &[f64],
    without: &[f64],
    noise: Noise,
    alpha: f64,
) -> ModelError {
    let first = p.sealed_rows.first().copied().unwrap_or(p.n);
    let sealed_segs = segments_from(&p.segs, first);
    let len = (p.sealed_rows.len() / SEALED_BLOCKS).max(p.min_len);
    let biases = |pred: &[f64], segs: &[Segment]| {
        let residual: Vec<f64> = (0..p.n).map(|i| p.inp.measured[i] - pred[i]).collect();
        segment_biases(
            &residual,
            &p.inp.measured,
            &blocks(segs, len),
            &p.inp.t_s,
            noise,
            p.min_len,
            p.practical(),
        )
    };
    let judged_regimes = |segs: &[Segment]| -> Vec<Segment> {
        segs.iter()
            .filter(|s| !ENGAGEMENT_CHANGES.contains(&s.regime))
            .copied()
            .collect()
    };
    let (sel_segs, sealed_segs) = (judged_regimes(&p.sel_segs), judged_regimes(&sealed_segs));
    let on_selection = biases(updated, &sel_segs);
    let sealed = biases(updated, &sealed_segs);
    let sealed_without = biases(without, &sealed_segs);
    let tau = bias_spread(&on_selection);
    let judged = on_selection.len() >= MODEL_ERROR_MIN_SEGMENTS && !sealed.is_empty();
    let whole = sealed_error(p, updated, without, noise, alpha);
    let gain = sealed_rule::sealed_gain(whole.mse_without.sqrt(), whole.mse_with.sqrt());
    let beyond: Vec<SealedBlock> = if judged {
        let zc = normal_quantile(1.0 - 0.5 * alpha / sealed.len() as f64);
        let bound = |b: &SegmentBias| zc * (tau * tau + standard_error(b).powi(2)).sqrt();
        sealed
            .into_iter()
            .zip(sealed_without)
            .filter(|(b, _)| b.bias.abs() > bound(b) && b.bias.abs() > b.floor)
            .map(|(b, w)| {
                let worse = sealed_rule::worse_by(b.bias, w.bias);
                SealedBlock {
                    under_corrected: b.bias * w.bias > 0.0 && b.bias.abs() < w.bias.abs(),
                    withholds: sealed_rule::made_materially_worse(worse, bound(&b), b.floor, gain),
                    worse_by: worse,
                    bias_without: w.bias,
                    block: b,
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    ModelError {
        sealed_error: whole,
        sealed_gain: gain,
        selection_segments: on_selection.len(),
        block_rows: len,
        segment_bias_sd: tau,
        judged,
        sealed_beyond: beyond,
    }
}

/// The sealed part predicted with the names (`updated`) against without them: the better
/// on the sealed part of the nominal model refitted (`refit`) and the model as given (a
/// refit that took a structure of the selection part into `Ks` can be the worse of the
/// two). [`SealedError`] over [`SEALED_BLOCKS`] contiguous blocks of the sealed rows, at
/// the one-sided level `alpha`, worse only beyond the noise variance `noise.sigma²`.
pub(super) fn sealed_error(
    p: &Prepared,
    updated: &[f64],
    refit: &[f64],
    noise: Noise,
    alpha: f64,
) -> SealedError {
    let rows = &p.sealed_rows;
    let sq = |pred: &[f64], i: usize| (p.inp.measured[i] - pred[i]).powi(2);
    let mse = |pred: &[f64]| mean(&rows.iter().map(|&i| sq(pred, i)).collect::<Vec<_>>());
    let as_given = &p.nominal_replay.predicted;
    let without = if mse(as_given) < mse(refit) {
        as_given
    } else {
        refit
    };
    let b = SEALED_BLOCKS.min(rows.len());
    let diffs: Vec<f64> = (0..b)
        .map(|k| {
            let block = &rows[k * rows.len() / b..(k + 1) * rows.len() / b];
            mean(
                &block
                    .iter()
                    .map(|&i| sq(updated, i) - sq(without, i))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    let m = mean(&diffs);
    let sd = if b > 1 {
        (diffs.iter().map(|d| (d - m).powi(2)).sum::<f64>() / (b - 1) as f64).sqrt()
    } else {
        0.0
    };
    let t = if sd > 0.0 {
        m / (sd / (b as f64).sqrt())
    } else if m > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    let t_crit = stats::t_critical(1.0 - 2.0 * alpha, b.saturating_sub(1) as f64);
    SealedError {
        blocks: b,
        mse_without: mse(without),
        mse_with: mse(updated),
        t,
        worse: b > 1 && t > t_crit && m > noise.sigma * noise.sigma,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(bias: f64, se: f64) -> SegmentBias {
        SegmentBias {
            regime: Regime::SteadyCut,
            t_start_s: 0.0,
            t_end_s: 1.0,
            samples: 10,
            bias,
            z: bias / se,
            floor: 0.0,
            significant: false,
        }
    }

    #[test]
    fn blocks_cover_each_segment_without_gaps() {
        let segs = [
            Segment {
                start: 0,
                end: 100,
                regime: Regime::SteadyCut,
            },
            Segment {
                start: 100,
                end: 112,
                regime: Regime::Air,
            },
        ];
        let b = blocks(&segs, 25);
        assert_eq!(b.len(), 5);
        assert_eq!(
            (b[0].start, b[3].end, b[4].start, b[4].end),
            (0, 100, 100, 112)
        );
        assert!(b.windows(2).all(|w| w[0].end == w[1].start));
    }

    #[test]
    fn the_spread_is_what_the_biases_have_beyond_their_noise() {
        // Biases ±3 with a standard error of 1 each: τ² = 9 − 1 = 8.
        let b: Vec<SegmentBias> = [3.0, -3.0, 3.0, -3.0]
            .iter()
            .map(|&x| seg(x, 1.0))
            .collect();
        assert!((bias_spread(&b) - 8f64.sqrt()).abs() < 1e-12);
        // Biases within their noise: no model error.
        let b: Vec<SegmentBias> = [0.5, -0.5].iter().map(|&x| seg(x, 1.0)).collect();
        assert_eq!(bias_spread(&b), 0.0);
        assert_eq!(bias_spread(&[]), 0.0);
    }

    proptest::proptest! {
        /// τ never exceeds the RMS of the biases and is zero when every bias is within
        /// its standard error.
        #[test]
        fn the_spread_is_bounded_by_the_biases(
            v in proptest::collection::vec((-50.0..50.0f64, 0.01..10.0f64), 1..30)
        ) {
            let b: Vec<SegmentBias> = v.iter().map(|&(x, se)| seg(x, se)).collect();
            let tau = bias_spread(&b);
            let rms = (v.iter().map(|(x, _)| x * x).sum::<f64>() / v.len() as f64).sqrt();
            proptest::prop_assert!(tau <= rms + 1e-9);
            if v.iter().all(|(x, se)| x.abs() <= *se) {
                proptest::prop_assert_eq!(tau, 0.0);
            }
        }
    }
}
