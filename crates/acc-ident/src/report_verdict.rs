//! The verdict beside the confirmed names (`report.json` → `most_likely`, `kept_despite`):
//! what best explains a log when no name is confirmed, and the sealed blocks a name was
//! kept despite. Re-exported from [`crate::report`].

use serde::Serialize;

use crate::segment::SegmentBias;

/// The effects that best explain the log when none is confirmed: they passed selection
/// and predict the sealed part better than the model without them, but a rule withheld
/// them. Never a confirmed name ([`crate::report::Report::accepted`] stays empty).
#[derive(Debug, Clone, Serialize)]
pub struct MostLikely {
    /// The effects, in the order selection added them.
    pub effects: Vec<String>,
    /// Sealed-part RMS without them (the better there of the model as given and the
    /// nominal model refitted), channel unit.
    pub sealed_rms_without: f64,
    /// Sealed-part RMS with them (the updated model), channel unit.
    pub sealed_rms_with: f64,
    /// Why they are not confirmed, one short phrase per rule that withheld them.
    pub not_confirmed: Vec<String>,
}

impl MostLikely {
    /// The summary's words: "most likely `tool_wear`: sealed RMS 71.9 → 17.7 N; not
    /// confirmed: …".
    pub fn text(&self, unit: &str) -> String {
        let names: Vec<String> = self.effects.iter().map(|e| format!("`{e}`")).collect();
        format!(
            "Most likely {}: sealed RMS {:.3} → {:.3} {unit}; not confirmed: {}.",
            names.join(" + "),
            self.sealed_rms_without,
            self.sealed_rms_with,
            self.not_confirmed.join("; ")
        )
    }
}

/// A sealed block biased beyond the noise (or the model error) that does not withhold
/// the names: its bias, or what the names made worse there, is small against what they
/// fixed on the sealed part (`acc_ident::workflow::SEALED_GAIN_SHARE`).
#[derive(Debug, Clone, Serialize)]
pub struct KeptBlock {
    /// The block and its bias with the updated model.
    pub block: SegmentBias,
    /// Its bias without the names, channel unit.
    pub bias_without: f64,
    /// What the names fixed on the sealed part: its RMS without them less with them,
    /// channel unit.
    pub gain: f64,
}

impl KeptBlock {
    /// One line for the report: where, how biased, and against what.
    pub fn text(&self, unit: &str) -> String {
        format!(
            "{} {:.1}–{:.1} s: {:+.3} {unit} ({:+.3} {unit} without the names), against {:.3} {unit} of sealed RMS the names removed",
            self.block.regime.name(),
            self.block.t_start_s,
            self.block.t_end_s,
            self.block.bias,
            self.bias_without,
            self.gain
        )
    }
}
