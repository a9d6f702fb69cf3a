//! When a biased sealed block withholds the names: only when it is large against what
//! they fixed.
//!
//! A block biased beyond the noise is evidence against a name only in proportion to what
//! the name did on the rest of the sealed part. A name that takes the sealed RMS from
//! 213 N to 0.66 N and leaves one 2-second block at +1.9 N (0.23 % of the force) is right
//! about the log; that block is another, smaller effect (the link's timing at a depth
//! change). So a block withholds only when it is significant against the channel's noise
//! and rounding, above its practical floor, and more than [`SEALED_GAIN_SHARE`] of what
//! the names fixed: the sealed RMS without them less with them. A name that fixes
//! nothing on the sealed part is withheld by any significant block, as before.
//!
//! Where the replay is exact ([`judge_exact`]) the judged size is the block's bias with
//! the names: a correct model leaves only noise. Where it is not (`model_error`,
//! [`worse_by`]) every block keeps a model error of its own, so the judged size is what
//! the names made worse there, and that against the model error's spread too.
//! A block that does not withhold is reported ([`crate::report::KeptBlock`]).

#[allow(unused_imports)]
use super::*;
use crate::report::KeptBlock;
use crate::segment::SegmentBias;

/// Share of what the names fixed on the sealed part (its RMS without them less with
/// them) that a biased sealed block must exceed to withhold them, −. A block under a
/// tenth of that gain changes no verdict about them: the names still remove ten times
/// more error than the block holds.
pub const SEALED_GAIN_SHARE: f64 = 0.1;

/// What the names fixed on the sealed part, channel unit: `rms_without − rms_with`, 0
/// when they fixed nothing.
pub fn sealed_gain(rms_without: f64, rms_with: f64) -> f64 {
    (rms_without - rms_with).max(0.0)
}

/// The sealed metrics without the names: the better on the sealed part of the model as
/// given and the nominal model refitted.
pub(super) fn without_names(sealed: &Sealed) -> &Metrics {
    if sealed.nominal.rms < sealed.nominal_refit.rms {
        &sealed.nominal
    } else {
        &sealed.nominal_refit
    }
}

/// Whether a sealed block whose bias is `size` (already significant and above its
/// practical floor) withholds names that fixed `gain` on the sealed part, both channel
/// unit.
pub fn block_withholds(size: f64, gain: f64) -> bool {
    size.abs() > SEALED_GAIN_SHARE * gain
}

/// The sealed part judged where the replay is exact: the significant blocks of the
/// updated model that withhold the names, and those the names are kept despite.
pub(super) fn judge_exact(sealed: &Sealed) -> (Vec<SegmentBias>, Vec<KeptBlock>) {
    let without = without_names(sealed);
    let gain = sealed_gain(without.rms, sealed.updated.rms);
    let mut withholding = Vec::new();
    let mut kept = Vec::new();
    for (b, w) in sealed.updated.segments.iter().zip(&without.segments) {
        if !b.significant {
            continue;
        }
        if block_withholds(b.bias, gain) {
            withholding.push(b.clone());
        } else {
            kept.push(KeptBlock {
                block: b.clone(),
                bias_without: w.bias,
                gain,
            });
        }
    }
    (withholding, kept)
}

/// How much the names made a block worse, channel unit: `|with| − |without|` of its
/// bias (negative where they improved it).
pub fn worse_by(bias_with: f64, bias_without: f64) -> f64 {
    bias_with.abs() - bias_without.abs()
}

/// Whether names made a sealed block materially worse where the replay is not exact:
/// the worsening `worse` exceeds the block's bound `bound` (the Bonferroni `z` times
/// `√(τ² + se²)`, the model error with the block's noise), its practical floor `floor`,
/// and [`SEALED_GAIN_SHARE`] of what the names fixed on the sealed part, `gain`; all
/// channel unit.
pub fn made_materially_worse(worse: f64, bound: f64, floor: f64, gain: f64) -> bool {
    worse > bound && worse > floor && block_withholds(worse, gain)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::Regime;

    fn block(bias: f64, z: f64) -> SegmentBias {
        SegmentBias {
            regime: Regime::DepthChange,
            t_start_s: 329.1,
            t_end_s: 331.0,
            samples: 20,
            bias,
            z,
            floor: 1.6,
            significant: true,
        }
    }

    fn metrics(rms: f64, segments: Vec<SegmentBias>) -> Metrics {
        Metrics {
            rms,
            fit_pct: 0.0,
            bias: 0.0,
            segments,
        }
    }

    fn sealed(rms_without: f64, rms_with: f64, with: f64, without: f64) -> Sealed {
        Sealed {
            from_s: 300.0,
            to_s: 340.0,
            rows: 400,
            nominal: metrics(rms_without, vec![block(without, 100.0)]),
            nominal_refit: metrics(2.0 * rms_without, vec![block(2.0 * without, 200.0)]),
            updated: metrics(rms_with, vec![block(with, 11.4)]),
            rms_reduction_pct: 0.0,
            rms_reduction_vs_refit_pct: 0.0,
        }
    }

    #[test]
    fn a_small_block_beside_a_large_gain_keeps_the_name_and_is_reported() {
        // Issue 57: tool wear takes the sealed RMS 213.1 → 0.66 N and leaves one depth
        // change at +1.872 N (z 11.4), where the model without it is off by −250 N.
        let (withholding, kept) = judge_exact(&sealed(213.1, 0.66, 1.872, -250.0));
        assert!(withholding.is_empty(), "{withholding:?}");
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0].bias_without, -250.0);
        assert!((kept[0].gain - 212.44).abs() < 1e-9, "{}", kept[0].gain);
        assert!(
            kept[0].text("N").contains("+1.872 N"),
            "{}",
            kept[0].text("N")
        );
    }

    #[test]
    fn a_block_the_name_makes_materially_worse_still_withholds() {
        // Unbiased without the name, 30 N with it: more than a tenth of the 212 N gain.
        let (withholding, kept) = judge_exact(&sealed(213.1, 0.66, 30.0, 0.5));
        assert_eq!(withholding.len(), 1);
        assert!(kept.is_empty());
        // A name that fixes nothing on the sealed part is withheld by any such block.
        let (withholding, _) = judge_exact(&sealed(5.0, 6.0, 1.872, 0.0));
        assert_eq!(withholding.len(), 1);
    }

    #[test]
    fn a_block_not_significant_is_neither_withholding_nor_kept() {
        let mut s = sealed(213.1, 0.66, 30.0, 0.5);
        s.updated.segments[0].significant = false;
        let (withholding, kept) = judge_exact(&s);
        assert!(withholding.is_empty() && kept.is_empty());
    }

    #[test]
    fn off_an_exact_replay_a_worsening_within_the_model_error_keeps_the_names() {
        // Issue 57, a real turning tool: wear and a feed exponent take the sealed RMS
        // 71.9 → 17.7 N; one block goes +20.2 → −21.9 N, 1.7 N worse, against a spread
        // of 7.2 N in the selection part's block biases (bound z·√(τ² + se²), z ≈ 2.7).
        let gain = sealed_gain(71.9, 17.7);
        let worse = worse_by(-21.9, 20.2);
        assert!((worse - 1.7).abs() < 1e-9);
        let bound = 2.7 * (7.2f64.powi(2) + 1.0).sqrt();
        assert!(!made_materially_worse(worse, bound, 0.5, gain));
        // A block the names take from +5 to −40 N is worse beyond every scale.
        assert!(made_materially_worse(
            worse_by(-40.0, 5.0),
            bound,
            0.5,
            gain
        ));
        // A worsening beyond the model error but small against the gain does not.
        assert!(!made_materially_worse(
            worse_by(-20.0, 0.0),
            bound,
            0.5,
            300.0
        ));
    }
}
