//! `Controller::step`: one control period of the adaptive feedrate-override loop.

use crate::{DesiredPoles, EstimatorConfig, FeedOverride, OverrideSpec};

/// What the controller sees once per period `T`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Measured mean cutting force over the last period, N (`Fc(i)`).
    pub force_n: f64,
    /// Actual feed that produced `force_n`, mm/min (`U_applied` in eq. 11).
    pub feed_mm_min: f64,
    /// Programmed feed of the active NC block, mm/min (override 100 %).
    pub programmed_feed_mm_min: f64,
    /// `false` when the force source flags the sample invalid or stale: the controller then
    /// must not raise the feed (it holds or lowers) and the estimator does not run.
    pub valid: bool,
}

/// Saturation state of the override after the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Saturation {
    /// Inside the allowed range.
    None,
    /// Clamped at the minimum override.
    Low,
    /// Clamped at the maximum override (e.g. air cut at 150 %).
    High,
}

/// Controller mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// PI with gains from pole assignment on `Kc_hat` (eq. 14).
    AdaptivePi,
    /// PI with fixed gains (the paper's Ki = 2.5, Kp = 0.05).
    FixedPi,
    /// Integral-only with its single pole assigned on `Kc_hat` (paper conclusion 5).
    AdaptiveIntegral,
    /// A baseline law (not a PI), reported by baselines implementing [`OverrideLaw`].
    Baseline,
}

/// Mode and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModeConfig {
    /// Adaptive PI: desired closed-loop poles.
    AdaptivePi {
        /// Desired poles z1, z2.
        poles: DesiredPoles,
    },
    /// Fixed-gain PI.
    FixedPi {
        /// Proportional gain, (mm/min)/N.
        kp: f64,
        /// Integral gain, (mm/min)/(N·s).
        ki: f64,
    },
    /// Integral-only adaptive with one desired real pole.
    AdaptiveIntegral {
        /// Desired pole, |pole| < 1.
        pole: f64,
    },
}

/// Full controller configuration (validated by [`Controller::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerConfig {
    /// Sampling period T, s (paper: 0.1).
    pub period_s: f64,
    /// Force reference Fr, N (paper: 800).
    pub force_ref_n: f64,
    /// Km: feed-drive gain × force-measurement gain (paper: 1).
    pub km: f64,
    /// Mode and its parameters.
    pub mode: ModeConfig,
    /// Override resolution and range.
    pub override_spec: OverrideSpec,
    /// Kc estimator settings.
    pub estimator: EstimatorConfig,
    /// Anti-windup on (default true). Off only to demonstrate windup.
    pub anti_windup: bool,
}

/// Per-step trace: what each part of the controller did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trace {
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// Force error E = Fr − Fc, N (eq. 2).
    pub error_n: f64,
    /// Estimated process gain Kc_hat, N/(mm/min).
    pub kc_hat: f64,
    /// Proportional gain in force, (mm/min)/N.
    pub kp: f64,
    /// Integral gain in force, (mm/min)/(N·s).
    pub ki: f64,
    /// Integrator state, mm/min.
    pub integral_mm_min: f64,
    /// Feed command before quantization and clamping, mm/min.
    pub feed_cmd_mm_min: f64,
    /// Override before quantization and clamping, percent.
    pub unquantized_pct: f64,
    /// Saturation after the step.
    pub saturation: Saturation,
    /// Mode.
    pub mode: Mode,
    /// Whether the estimator updated Kc_hat this step.
    pub estimator_active: bool,
    /// Excitation / health indicator of the estimator in [0, 1].
    pub excitation: f64,
}

/// Result of one control period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutput {
    /// Override command to write to the PMC.
    pub command: FeedOverride,
    /// Trace for the run log.
    pub trace: Trace,
}

/// Anything that turns a measurement into an override command once per period: the
/// adaptive controller and the comparison baselines.
pub trait OverrideLaw {
    /// Short name for tables and plots.
    fn name(&self) -> &str;
    /// ACC switched on while `current` is in force (bumpless start).
    fn engage(&mut self, current: FeedOverride);
    /// Advance one period.
    fn step(&mut self, m: &Measurement) -> StepOutput;
    /// Freeze integrators (e.g. `OVERRIDE_LOCKED`): the next steps hold state.
    fn set_frozen(&mut self, frozen: bool);
}

/// The adaptive feedrate-override controller.
#[derive(Debug, Clone)]
pub struct Controller {
    // implementation-defined
}
