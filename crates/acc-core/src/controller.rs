//! `Controller::step`: one control period of the adaptive feedrate-override loop.
//!
//! Per period `T` (seed 002, physics.md §1):
//!
//! 1. `E(i) = Fr − Fc(i)` (eq. 2).
//! 2. The Kc estimator (eqs. 11–12) compares `Fc(i)` with the feed that produced it
//!    (`Measurement::feed_mm_min`); it runs only while cutting.
//! 3. The gains: fixed, or by pole assignment on `Kc_hat(i)` (eq. 14), or the single pole
//!    of the integral-only law (conclusion 5).
//! 4. The PI law (eq. 4) gives the feed command `U(i)` in mm/min; the override is
//!    `100·U/F_programmed`, quantized to the board step and clamped, with anti-windup
//!    (see [`crate::pi`]).
//! 5. Optional quantizer hysteresis (`override_spec.hysteresis_pct`, default 0 = off): in a
//!    normal step inside the range the written position moves only when the command is
//!    beyond a midpoint by more than `h` ([`OverrideSpec::quantize_hysteresis`], relative to
//!    [`Controller::last_command`]). A step whose demand is beyond a limit
//!    ([`Saturation`] not `None`) writes the clamped value at once, and held steps (invalid
//!    sample, no programmed feed) only ever hold, so no lowering is delayed by it. The
//!    anti-windup acts only at the limits, where the written value *is* the limit; inside
//!    the range a held position is bounded to one step, like the quantization itself.
//! 6. Or the σ-Δ quantizer (`override_spec.quantizer = SigmaDelta`, [`crate::SigmaDelta`]):
//!    inside the range the written position dithers between the two neighbours of the
//!    continuous command so that its time average equals the command. The PI sees only the
//!    continuous command (its integrator keeps the unquantized value, as with rounding); the
//!    residue is reset at a limit (saturation writes the limit at once), at engage, and a
//!    held step (invalid sample, no programmed feed) holds the last position without
//!    touching the residue, so the dither never raises the feed on a held step. The written
//!    position is never more than one step above the continuous command.
//! 7. Under a policy ([`OverrideLaw::step_within`]) the position is put within the policy's
//!    [`CommandBounds`] in the same step ([`OverrideSpec::place`]: the range on the board's
//!    grid, no raise on an invalid sample, the knob, the tool's and the plan's limits), and
//!    a command the limits changed re-engages the law there (the integrator re-seated on
//!    it: no windup against the limit).
//!
//! ```
//! use acc_core::{Controller, ControllerConfig, FeedOverride, Measurement, OverrideLaw, PaperCase};
//! let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::III)).unwrap();
//! ctl.engage(FeedOverride(100));
//! // Plant of eq. 6 with Kc = 5 N/(mm/min): F(i) = Km·Kc·U_applied(i−1).
//! let (kc, programmed) = (5.0, 200.0);
//! let mut feed = 200.0;
//! let mut out = None;
//! for _ in 0..60 {
//!     let m = Measurement { force_n: kc * feed, feed_mm_min: feed,
//!                           programmed_feed_mm_min: programmed, valid: true };
//!     let o = ctl.step(&m);
//!     feed = o.command.feed_mm_min(programmed);
//!     out = Some(o);
//! }
//! let o = out.unwrap();
//! // 800 N needs 160 mm/min = 80 %, a board position: the loop settles there exactly.
//! assert_eq!(o.command, FeedOverride(80));
//! assert!((ctl.kc_hat() - 5.0).abs() < 1e-6);
//! ```

use crate::estimator::KcEstimator;
use crate::pi::PiState;
use crate::poles::{self, PiGains};
use crate::RangeError;
use crate::{
    CommandBounds, CoreError, Demand, DesiredPoles, EstimatorConfig, FeedOverride, OverrideSpec,
    Placed, SigmaDelta,
};

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
/// adaptive controller and the comparison baselines. `Send`: the period driver runs it on
/// its control thread.
pub trait OverrideLaw: Send {
    /// Short name for tables and plots.
    fn name(&self) -> &str;
    /// ACC switched on while `current` is in force (bumpless start).
    fn engage(&mut self, current: FeedOverride);
    /// Advance one period.
    fn step(&mut self, m: &Measurement) -> StepOutput;
    /// Advance one period under a policy's `bounds`: the command is the law's position
    /// within them ([`CommandBounds::place`]); when the limits changed it, the law is
    /// re-engaged on the written command (bumpless, no windup against the limit). The
    /// default steps the law and then places its command; [`Controller`] places it in its
    /// own quantization step ([`OverrideSpec::place`]).
    fn step_within(&mut self, m: &Measurement, bounds: &CommandBounds) -> StepOutput {
        let mut out = self.step(m);
        let placed = bounds.place(out.command);
        if placed.reseat {
            self.engage(placed.cmd);
        }
        out.command = placed.cmd;
        out
    }
    /// Freeze integrators (e.g. `OVERRIDE_LOCKED`): the next steps hold state.
    fn set_frozen(&mut self, frozen: bool);
    /// Change the force reference Fr, N (a tool change; default: ignored). Values that are
    /// not finite and > 0 are ignored.
    fn set_force_ref_n(&mut self, _force_ref_n: f64) {}
    /// The law's process-gain estimate Kc_hat, N/(mm/min), if it keeps one (default: none).
    fn kc_estimate(&self) -> Option<f64> {
        None
    }
    /// Restart the process-gain estimate at `kc_hat`, N/(mm/min) (a tool change; default:
    /// ignored).
    fn reset_kc_estimate(&mut self, _kc_hat: f64) {}
    /// Extra periods of dead time the closed loop tolerates with the gains in use, judged
    /// on the law's own plant model (Km·Kc_hat; [`crate::delay::delay_margin_periods`]).
    /// `None` when the law has no model to judge by (default) or its loop is not stable
    /// even without extra delay.
    fn delay_margin_periods(&self) -> Option<u32> {
        None
    }
}

impl<T: OverrideLaw + ?Sized> OverrideLaw for &mut T {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn engage(&mut self, current: FeedOverride) {
        (**self).engage(current)
    }
    fn step(&mut self, m: &Measurement) -> StepOutput {
        (**self).step(m)
    }
    fn step_within(&mut self, m: &Measurement, bounds: &CommandBounds) -> StepOutput {
        (**self).step_within(m, bounds)
    }
    fn set_frozen(&mut self, frozen: bool) {
        (**self).set_frozen(frozen)
    }
    fn set_force_ref_n(&mut self, force_ref_n: f64) {
        (**self).set_force_ref_n(force_ref_n)
    }
    fn kc_estimate(&self) -> Option<f64> {
        (**self).kc_estimate()
    }
    fn reset_kc_estimate(&mut self, kc_hat: f64) {
        (**self).reset_kc_estimate(kc_hat)
    }
    fn delay_margin_periods(&self) -> Option<u32> {
        (**self).delay_margin_periods()
    }
}

/// The adaptive feedrate-override controller.
#[derive(Debug, Clone)]
pub struct Controller {
    cfg: ControllerConfig,
    estimator: KcEstimator,
    pi: PiState,
    /// Gain-free numerator of Kp (eq. 14: −z1·z2; 0 in integral-only mode).
    num_p: f64,
    /// Gain-free numerator of Ki (eq. 14: 1 − (z1 + z2) + z1·z2; 1 − p integral-only).
    num_i: f64,
    pending_engage: Option<FeedOverride>,
    last_command: FeedOverride,
    last_saturation: Saturation,
    frozen: bool,
    sigma_delta: SigmaDelta,
}

impl Controller {
    /// Build a controller; every parameter is validated (errors name the configuration key
    /// and the allowed range). The controller starts as if engaged at 100 %; call
    /// [`OverrideLaw::engage`] with the override in force when ACC is switched on.
    pub fn new(cfg: ControllerConfig) -> Result<Self, CoreError> {
        cfg.validate()?;
        let estimator = KcEstimator::new(cfg.estimator, cfg.km)?;
        let (num_p, num_i) = match cfg.mode {
            ModeConfig::AdaptivePi { poles } => poles.numerators(),
            ModeConfig::FixedPi { .. } => (0.0, 0.0),
            ModeConfig::AdaptiveIntegral { pole } => (0.0, 1.0 - pole),
        };
        Ok(Self {
            cfg,
            estimator,
            pi: PiState::new(0.0),
            num_p,
            num_i,
            pending_engage: Some(FeedOverride::NOMINAL),
            last_command: FeedOverride::NOMINAL,
            last_saturation: Saturation::None,
            frozen: false,
            sigma_delta: SigmaDelta::new(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// Current estimate Kc_hat, N/(mm/min).
    pub fn kc_hat(&self) -> f64 {
        self.estimator.kc_hat()
    }

    /// The Kc estimator.
    pub fn estimator(&self) -> &KcEstimator {
        &self.estimator
    }

    /// Integrator state, mm/min.
    pub fn integral_mm_min(&self) -> f64 {
        self.pi.integral_mm_min()
    }

    /// The last override command.
    pub fn last_command(&self) -> FeedOverride {
        self.last_command
    }

    /// Whether the integrator is frozen.
    pub fn is_frozen(&self) -> bool {
        self.frozen
    }

    /// Change the force reference Fr, N (ignored unless finite and > 0).
    pub fn set_force_ref_n(&mut self, force_ref_n: f64) {
        if force_ref_n.is_finite() && force_ref_n > 0.0 {
            self.cfg.force_ref_n = force_ref_n;
        }
    }

    /// The gains in use at the current `Kc_hat` (eq. 14 in adaptive modes).
    pub fn gains(&self) -> PiGains {
        let g = self.cfg.km * self.estimator.kc_hat();
        match self.cfg.mode {
            ModeConfig::FixedPi { kp, ki } => PiGains { kp, ki },
            ModeConfig::AdaptivePi { .. } | ModeConfig::AdaptiveIntegral { .. } => PiGains {
                kp: self.num_p / g,
                ki: self.num_i / (self.cfg.period_s * g),
            },
        }
    }

    /// The mode reported in the trace.
    pub fn mode(&self) -> Mode {
        self.cfg.mode.mode()
    }

    fn held_output(&mut self, m: &Measurement, feed_ok: bool) -> StepOutput {
        self.estimator.hold();
        let gains = self.gains();
        let cmd = self.last_command;
        let feed = if feed_ok {
            cmd.feed_mm_min(m.programmed_feed_mm_min)
        } else {
            f64::NAN
        };
        StepOutput {
            command: cmd,
            trace: Trace {
                force_ref_n: self.cfg.force_ref_n,
                error_n: self.cfg.force_ref_n - m.force_n,
                kc_hat: self.estimator.kc_hat(),
                kp: gains.kp,
                ki: gains.ki,
                integral_mm_min: self.pi.integral_mm_min(),
                feed_cmd_mm_min: feed,
                unquantized_pct: f64::from(cmd.pct()),
                saturation: self.last_saturation,
                mode: self.mode(),
                estimator_active: false,
                excitation: self.estimator.excitation(),
            },
        }
    }

    /// One period ([`OverrideLaw::step`]); the command is placed once, by the spec's
    /// quantizer within `bounds` ([`OverrideSpec::place`]), and a command the limits
    /// changed re-engages the law on it.
    fn step_placed(&mut self, m: &Measurement, bounds: Option<&CommandBounds>) -> StepOutput {
        let fp = m.programmed_feed_mm_min;
        let feed_ok = fp.is_finite() && fp > 0.0;
        if feed_ok {
            if let Some(cur) = self.pending_engage.take() {
                self.pi.set_integral_mm_min(cur.feed_mm_min(fp));
            }
        }
        let spec = self.cfg.override_spec;
        if !(feed_ok && m.valid && m.force_n.is_finite()) {
            let mut out = self.held_output(m, feed_ok);
            let placed = spec.place(
                Demand::Held,
                self.last_command,
                &mut self.sigma_delta,
                bounds,
            );
            out.command = self.settle(placed);
            return out;
        }
        let error_n = self.cfg.force_ref_n - m.force_n; // eq. 2
        let active = self.estimator.update(m.force_n, m.feed_mm_min); // eqs. 11-12
        let gains = self.gains(); // eq. 14 or fixed
        let s = self.pi.step(
            gains,
            error_n,
            self.cfg.period_s,
            fp,
            &spec,
            self.cfg.anti_windup,
            !self.frozen,
        ); // eq. 4
        let demand = match s.saturation {
            Saturation::None => Demand::Within(s.unquantized_pct),
            Saturation::Low | Saturation::High => Demand::Saturated(s.command),
        };
        let placed = spec.place(demand, self.last_command, &mut self.sigma_delta, bounds);
        self.last_command = placed.law;
        self.last_saturation = s.saturation;
        StepOutput {
            command: self.settle(placed),
            trace: Trace {
                force_ref_n: self.cfg.force_ref_n,
                error_n,
                kc_hat: self.estimator.kc_hat(),
                kp: gains.kp,
                ki: gains.ki,
                integral_mm_min: s.integral_mm_min,
                feed_cmd_mm_min: s.feed_cmd_mm_min,
                unquantized_pct: s.unquantized_pct,
                saturation: s.saturation,
                mode: self.mode(),
                estimator_active: active,
                excitation: self.estimator.excitation(),
            },
        }
    }

    /// The command to write: re-engaged on it when the limits changed the law's position.
    fn settle(&mut self, placed: Placed) -> FeedOverride {
        if placed.reseat {
            self.engage(placed.cmd);
        }
        placed.cmd
    }
}

impl OverrideLaw for Controller {
    fn name(&self) -> &str {
        match self.cfg.mode {
            ModeConfig::AdaptivePi { .. } => "adaptive-pi",
            ModeConfig::FixedPi { .. } => "fixed-pi",
            ModeConfig::AdaptiveIntegral { .. } => "adaptive-i",
        }
    }

    /// Bumpless start: the integrator starts from the feed `current` gives at the next
    /// step's programmed feed, so with zero error the first command equals `current`.
    fn engage(&mut self, current: FeedOverride) {
        let spec = self.cfg.override_spec;
        let current = FeedOverride(current.pct().clamp(spec.min_pct, spec.max_pct));
        self.pending_engage = Some(current);
        self.last_command = current;
        self.last_saturation = Saturation::None;
        self.sigma_delta.reset();
    }

    /// One period. An invalid or non-finite measurement, or a programmed feed that is not
    /// > 0, holds the last command, the integrator and the estimator (never raises the feed).
    fn step(&mut self, m: &Measurement) -> StepOutput {
        self.step_placed(m, None)
    }

    /// [`OverrideLaw::step`] with the policy's bounds applied in the one quantization step.
    fn step_within(&mut self, m: &Measurement, bounds: &CommandBounds) -> StepOutput {
        self.step_placed(m, Some(bounds))
    }

    /// Frozen: the integrator holds (the P term still acts on the error); the estimator
    /// keeps learning because it compares the force with the applied feed.
    fn set_frozen(&mut self, frozen: bool) {
        self.frozen = frozen;
    }

    fn set_force_ref_n(&mut self, force_ref_n: f64) {
        Controller::set_force_ref_n(self, force_ref_n);
    }

    fn kc_estimate(&self) -> Option<f64> {
        Some(self.estimator.kc_hat())
    }

    /// The estimator restarts at `kc_hat` (clamped to its bounds); the gains follow at once.
    fn reset_kc_estimate(&mut self, kc_hat: f64) {
        self.estimator.reset(kc_hat);
    }

    /// The gains in use ([`Controller::gains`]) on the plant `Km·Kc_hat`.
    fn delay_margin_periods(&self) -> Option<u32> {
        let g = self.gains();
        crate::delay::delay_margin_periods(
            g.kp,
            g.ki,
            self.cfg.km * self.estimator.kc_hat(),
            self.cfg.period_s,
        )
    }
}

impl ModeConfig {
    /// The paper's fixed-gain controller: Ki = 2.5 (mm/min)/(N·s), Kp = 0.05 (mm/min)/N.
    pub const PAPER_FIXED: ModeConfig = ModeConfig::FixedPi { kp: 0.05, ki: 2.5 };

    /// The [`Mode`] this configuration runs in.
    pub fn mode(&self) -> Mode {
        match self {
            ModeConfig::AdaptivePi { .. } => Mode::AdaptivePi,
            ModeConfig::FixedPi { .. } => Mode::FixedPi,
            ModeConfig::AdaptiveIntegral { .. } => Mode::AdaptiveIntegral,
        }
    }

    /// Check the mode parameters: poles strictly inside the unit circle, fixed gains
    /// finite with `kp >= 0`, `ki > 0`.
    pub fn validate(&self) -> Result<(), CoreError> {
        match *self {
            ModeConfig::AdaptivePi { poles } => poles.validate().map_err(CoreError::Pole),
            ModeConfig::AdaptiveIntegral { pole } => {
                poles::validate_single(pole).map_err(CoreError::Pole)
            }
            ModeConfig::FixedPi { kp, ki } => {
                if !(kp.is_finite() && kp >= 0.0) {
                    return Err(CoreError::OutOfRange(RangeError::new(
                        "mode.kp", kp, ">= 0",
                    )));
                }
                if !(ki.is_finite() && ki > 0.0) {
                    return Err(CoreError::OutOfRange(RangeError::new("mode.ki", ki, "> 0")));
                }
                Ok(())
            }
        }
    }
}

/// The paper's experiments (seed 002, physics.md §1 table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperCase {
    /// Fixed gains Ki = 2.5, Kp = 0.05 (depth steps 1, 2, 3 mm).
    FixedGain,
    /// Poles 0.2, −0.05 (depth steps 2, 3, 4 mm).
    I,
    /// Poles 0.1, −0.6 (depth steps 2, 3, 4 mm).
    II,
    /// Poles 0.001, −0.001 (depth steps 2, 3, 4 mm).
    III,
    /// Poles 0.001, −0.001 (depth ramp 2 → 4 mm).
    IV,
}

impl PaperCase {
    /// The controller mode of the case.
    pub fn mode(self) -> ModeConfig {
        match self {
            PaperCase::FixedGain => ModeConfig::PAPER_FIXED,
            PaperCase::I => ModeConfig::AdaptivePi {
                poles: DesiredPoles::PAPER_CASE_I,
            },
            PaperCase::II => ModeConfig::AdaptivePi {
                poles: DesiredPoles::PAPER_CASE_II,
            },
            PaperCase::III | PaperCase::IV => ModeConfig::AdaptivePi {
                poles: DesiredPoles::PAPER_CASE_III,
            },
        }
    }
}

impl ControllerConfig {
    /// The paper's set-up with `mode`: T = 0.1 s, Fr = 800 N, Km = 1, 10 % board 0…150 %,
    /// [`EstimatorConfig::paper`], anti-windup on.
    pub const fn paper(mode: ModeConfig) -> Self {
        Self {
            period_s: 0.1,
            force_ref_n: 800.0,
            km: 1.0,
            mode,
            override_spec: OverrideSpec::paper(),
            estimator: EstimatorConfig::paper(),
            anti_windup: true,
        }
    }

    /// One of the paper's experiments, see [`PaperCase`].
    pub fn paper_case(case: PaperCase) -> Self {
        Self::paper(case.mode())
    }

    /// Check every value; errors name the configuration key and the allowed range.
    pub fn validate(&self) -> Result<(), CoreError> {
        if !(self.period_s.is_finite() && self.period_s > 0.0 && self.period_s <= 10.0) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "period_s",
                self.period_s,
                "0 < T <= 10",
            )));
        }
        if !(self.force_ref_n.is_finite() && self.force_ref_n > 0.0) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "force_ref_n",
                self.force_ref_n,
                "> 0",
            )));
        }
        if !(self.km.is_finite() && self.km > 0.0) {
            return Err(CoreError::OutOfRange(RangeError::new("km", self.km, "> 0")));
        }
        self.mode.validate()?;
        self.override_spec.validate()?;
        self.estimator.validate()
    }
}

impl Default for ControllerConfig {
    /// Paper case III (poles 0.001, −0.001), see [`ControllerConfig::paper`].
    fn default() -> Self {
        Self::paper_case(PaperCase::III)
    }
}
