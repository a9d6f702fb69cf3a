//! The measurement channel: anything that turns one period's raw input into a force
//! estimate for the controller (dynamometer, spindle power from 3-phase signals, the
//! board's power register, a recorded stream). The loop only sees this trait, so a new
//! channel plugs in without changing the loop.

/// One period of raw three-phase samples (seed 000: phase currents U, V; line voltages
/// U–W, V–W). All slices have the same length.
#[derive(Debug, Clone, Copy)]
pub struct PhaseBlock<'a> {
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
    /// Phase current U, A.
    pub i_u: &'a [f64],
    /// Phase current V, A.
    pub i_v: &'a [f64],
    /// Line voltage U–W, V.
    pub v_uw: &'a [f64],
    /// Line voltage V–W, V.
    pub v_vw: &'a [f64],
}

/// What is known about the period that just ended. A source uses what it needs and
/// ignores the rest; fields that the installation cannot provide are `None`.
#[derive(Debug, Clone, Copy, Default)]
pub struct PeriodInput<'a> {
    /// Period length T, s.
    pub period_s: f64,
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// Actual feed over the period, mm/min.
    pub feed_mm_min: f64,
    /// True mean cutting force over the period, N (simulator only: what a dynamometer sees).
    pub true_force_n: Option<f64>,
    /// Spindle input power as reported by a transducer or the board, W.
    pub power_w: Option<f64>,
    /// Raw three-phase samples of the period.
    pub phases: Option<PhaseBlock<'a>>,
}

/// A force estimate for one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceSample {
    /// Estimated mean cutting force, N (0 when invalid).
    pub force_n: f64,
    /// Spindle input power used, W, if the source knows it.
    pub power_w: Option<f64>,
    /// `false` if the sample must not be used to raise the feed (NaN, stale, out of range).
    pub valid: bool,
}

impl ForceSample {
    /// An invalid sample: force 0, flagged so the controller never raises the feed on it.
    pub const INVALID: ForceSample = ForceSample {
        force_n: 0.0,
        power_w: None,
        valid: false,
    };
}

/// A measurement channel.
pub trait ForceSource: Send {
    /// Short name for logs and tables (e.g. `"dynamometer"`, `"spindle-power"`).
    fn name(&self) -> &str;
    /// Estimate the mean cutting force of the period described by `input`.
    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample;
}
