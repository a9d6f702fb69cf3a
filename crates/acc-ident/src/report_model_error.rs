//! The model error section of a report (`report.json` → `model_error`): where the replay
//! is not exact, what the names are judged against (`acc_ident::workflow`'s `model_error`).
//! Re-exported from [`crate::report`].

use serde::Serialize;

use crate::segment::SegmentBias;

/// The model error's own structure (`acc_ident::workflow`'s `model_error`): on a log whose
/// replay is not exact (logged depths, a real machine) names are judged against the model
/// error measured on the selection part, not against the noise.
#[derive(Debug, Clone, Serialize)]
pub struct ModelError {
    /// Selection-part blocks it was estimated from (the selection part's segments cut to
    /// the length of the sealed part's blocks).
    pub selection_segments: usize,
    /// Rows per block, −.
    pub block_rows: usize,
    /// Spread of the selection part's segment biases beyond their noise with the updated
    /// model, `τ = √max(0, mean(bᵢ² − seᵢ²))`, channel unit.
    pub segment_bias_sd: f64,
    /// Whether there were enough segments to judge
    /// (`acc_ident::workflow::MODEL_ERROR_MIN_SEGMENTS`).
    pub judged: bool,
    /// Sealed blocks whose bias with the updated model stands out of `√(τ² + se²)` at the
    /// Bonferroni level: the names are withheld when one of them
    /// [`SealedBlock::withholds`].
    pub sealed_beyond: Vec<SealedBlock>,
    /// The sealed part's squared error with the names against without them.
    pub sealed_error: SealedError,
    /// What the names fixed on the sealed part: its RMS without them less with them (0
    /// when they fixed nothing), channel unit.
    pub sealed_gain: f64,
}

impl ModelError {
    /// Whether the names are withheld: a sealed block beyond the model error that they
    /// made materially worse, or the sealed part predicted worse with them.
    pub fn withholds(&self) -> bool {
        self.sealed_beyond.iter().any(|b| b.withholds) || self.sealed_error.worse
    }
}

/// The sealed part's mean squared error with the names and without them (the better
/// there of the nominal model refitted and the model as given), compared block by block:
/// `dᵢ = eᵢ²(with) − eᵢ²(without)` over the sealed rows, its means over [`SealedError::blocks`] contiguous blocks (each long
/// against the noise's correlation), a one-sided Student-t test of their mean against 0.
#[derive(Debug, Clone, Serialize)]
pub struct SealedError {
    /// Blocks the sealed rows were cut into, −.
    pub blocks: usize,
    /// Mean squared error without the names, channel unit².
    pub mse_without: f64,
    /// Mean squared error with them, channel unit².
    pub mse_with: f64,
    /// Student-t statistic of the blocks' mean difference, −.
    pub t: f64,
    /// The names predict the sealed part worse: the difference is significant at the
    /// analysis's α (one-sided) and larger than the noise variance (what a correct name
    /// could add by its own estimation error is far below it).
    pub worse: bool,
}

/// A sealed block beyond the model error ([`ModelError`]).
#[derive(Debug, Clone, Serialize)]
pub struct SealedBlock {
    /// The block and its bias with the updated model.
    pub block: SegmentBias,
    /// Its bias with the model without the names (the nominal model refitted), channel
    /// unit.
    pub bias_without: f64,
    /// The names moved it toward the measurement and left it on the same side: the effect
    /// is right but larger there than its law.
    pub under_corrected: bool,
    /// How much the names made it worse, `|bias| − |bias_without|` (negative where they
    /// improved it), channel unit.
    pub worse_by: f64,
    /// The names made it materially worse: the worsening exceeds the block's bound, its
    /// floor and a tenth of [`ModelError::sealed_gain`]; such a block withholds them.
    pub withholds: bool,
}
