//! Feed override values, resolution and range.
//!
//! The paper's FANUC 0-MC takes the override from 0 % to 150 % in 10 % steps (a 4-bit PMC
//! code, physics.md §1); a byte board takes 1 % steps. [`OverrideSpec::quantize`] turns the
//! controller's continuous override into what the board can actually apply;
//! [`OverrideSpec::quantize_hysteresis`] does the same with an optional deadband around the
//! midpoints (`hysteresis_pct`, default 0 = plain round-to-nearest) so that a command sitting
//! between two positions does not dither between them. [`SigmaDelta`] is the other choice
//! ([`Quantizer::SigmaDelta`]): a first-order error-feedback quantizer that carries the
//! rounding residue from one period to the next, so that the *time average* of the written
//! positions equals the continuous command (a command of 64 % on a 10 % board is written as
//! 60, 70, 60, 70, 60, 60, 70, … with a mean of 64 %).

use crate::CoreError;
use crate::RangeError;

/// A feed override in percent of the programmed feed (integer percent).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FeedOverride(pub u16);

impl FeedOverride {
    /// 100 %: the programmed feed.
    pub const NOMINAL: FeedOverride = FeedOverride(100);

    /// The override in percent.
    pub fn pct(self) -> u16 {
        self.0
    }

    /// The override as a fraction (100 % → 1.0).
    pub fn fraction(self) -> f64 {
        f64::from(self.0) / 100.0
    }

    /// The feed this override gives at `programmed_feed_mm_min`, mm/min.
    ///
    /// ```
    /// use acc_core::FeedOverride;
    /// assert_eq!(FeedOverride(150).feed_mm_min(200.0), 300.0);
    /// ```
    pub fn feed_mm_min(self, programmed_feed_mm_min: f64) -> f64 {
        self.fraction() * programmed_feed_mm_min
    }
}

impl Default for FeedOverride {
    fn default() -> Self {
        Self::NOMINAL
    }
}

/// Override resolution and range of the PMC board, and the quantizer's deadband.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OverrideSpec {
    /// Step in percent: 10 for a 4-bit PMC board, 1 for a byte board.
    pub step_pct: u16,
    /// Minimum override, percent (default 0).
    pub min_pct: u16,
    /// Maximum override, percent (default 150; never above 150).
    pub max_pct: u16,
    /// Quantizer hysteresis `h`, percent of the override (0 ..= `step_pct`/2; default 0 =
    /// plain round-to-nearest). See [`OverrideSpec::quantize_hysteresis`].
    pub hysteresis_pct: f64,
    /// How the continuous command becomes a board position (default
    /// [`Quantizer::Round`]).
    pub quantizer: Quantizer,
}

/// How the controller turns its continuous override command into a board position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quantizer {
    /// Round to the nearest position (with the optional hysteresis,
    /// [`OverrideSpec::quantize_hysteresis`]): the paper's behaviour.
    #[default]
    Round,
    /// First-order error feedback (σ-Δ, [`SigmaDelta`]): the time average of the written
    /// positions follows the continuous command; needs `hysteresis_pct = 0`.
    SigmaDelta,
}

impl Quantizer {
    /// The configuration name: `"round"` or `"sigma_delta"`.
    pub fn name(self) -> &'static str {
        match self {
            Quantizer::Round => "round",
            Quantizer::SigmaDelta => "sigma_delta",
        }
    }
}

/// First-order σ-Δ (error-feedback) step scheduler: pure, allocation-free state of one
/// quantizer (the residue, percent).
///
/// Per period, with the continuous command `u` clamped to `[min_pct, max_pct]` and the
/// residue `e` carried from the last period (|e| ≤ step/2):
///
/// ```text
/// v = u + e            q = quantize(v)  (nearest position, clamped to the range)
/// e' = v − q
/// ```
///
/// So `Σq = Σu + e₀ − e_N`: over N periods the mean written override is within
/// `step/N` of the mean command (`step/(2N)` from a reset). The output is always a
/// position in `[min_pct, max_pct]` and never more than one step above (or below) `u`:
/// `|q − u| ≤ |q − v| + |e| ≤ step`. A NaN command writes `min_pct` and resets the
/// residue (the safe side).
///
/// ```
/// use acc_core::{OverrideSpec, SigmaDelta};
/// let spec = OverrideSpec::paper();
/// let mut sd = SigmaDelta::new();
/// let out: Vec<u16> = (0..10).map(|_| sd.step(&spec, 64.0).pct()).collect();
/// assert_eq!(out.iter().map(|&q| u32::from(q)).sum::<u32>(), 640); // mean 64 %
/// assert!(out.iter().all(|&q| q == 60 || q == 70));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SigmaDelta {
    residue_pct: f64,
}

impl SigmaDelta {
    /// A quantizer with zero residue.
    pub const fn new() -> Self {
        Self { residue_pct: 0.0 }
    }

    /// The carried residue `e`, percent (|e| ≤ step/2).
    pub fn residue_pct(&self) -> f64 {
        self.residue_pct
    }

    /// Forget the residue (engage, saturation, held periods).
    pub fn reset(&mut self) {
        self.residue_pct = 0.0;
    }

    /// One period: the board position for the continuous command `pct`, percent.
    pub fn step(&mut self, spec: &OverrideSpec, pct: f64) -> FeedOverride {
        if pct.is_nan() {
            self.reset();
            return FeedOverride(spec.min_pct);
        }
        let u = spec.clamp_pct(pct);
        let half = f64::from(spec.step_pct.max(1)) / 2.0;
        let e = if self.residue_pct.is_finite() {
            self.residue_pct.clamp(-half, half)
        } else {
            0.0
        };
        let v = u + e;
        let q = spec.quantize(v);
        // |v − q| ≤ step/2 inside the range; at a limit the clamp keeps the residue bounded.
        self.residue_pct = (v - f64::from(q.pct())).clamp(-half, half);
        q
    }
}

impl OverrideSpec {
    /// Highest override any CNC in scope accepts, percent.
    pub const ABSOLUTE_MAX_PCT: u16 = 150;

    /// The paper's board: 10 % steps, 0 … 150 % (16 positions, a 4-bit code).
    pub const fn paper() -> Self {
        Self {
            step_pct: 10,
            min_pct: 0,
            max_pct: 150,
            hysteresis_pct: 0.0,
            quantizer: Quantizer::Round,
        }
    }

    /// A byte board: 1 % steps, 0 … 150 %.
    pub const fn byte_board() -> Self {
        Self {
            step_pct: 1,
            min_pct: 0,
            max_pct: 150,
            hysteresis_pct: 0.0,
            quantizer: Quantizer::Round,
        }
    }

    /// The same board with quantizer hysteresis `hysteresis_pct`, percent (checked by
    /// [`OverrideSpec::validate`]).
    pub const fn with_hysteresis(self, hysteresis_pct: f64) -> Self {
        Self {
            hysteresis_pct,
            ..self
        }
    }

    /// The same board with quantizer `quantizer`.
    pub const fn with_quantizer(self, quantizer: Quantizer) -> Self {
        Self { quantizer, ..self }
    }

    /// This spec on a board whose `OVERRIDE_STEP` is `board_step` percent: unchanged when
    /// the spec's step is a multiple of the board's (or `board_step` is 0 = unknown),
    /// otherwise the board's step (commands must be multiples of `OVERRIDE_STEP`), with the
    /// limits floored (max) and ceiled (min) onto the new grid. A hysteresis above half the
    /// replacing step is refused (`override.hysteresis_pct`).
    pub fn for_board(self, board_step: u16) -> Result<Self, CoreError> {
        if board_step == 0 || self.step_pct.is_multiple_of(board_step) {
            return Ok(self);
        }
        let half = f64::from(board_step) / 2.0;
        if self.hysteresis_pct > half {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.hysteresis_pct",
                self.hysteresis_pct,
                "0 ..= half the board's OVERRIDE_STEP",
            )));
        }
        Ok(self.on_grid(board_step))
    }

    /// A command range `[min_pct, max_pct]`, percent, on 1 % steps (`max_pct` above 150 is
    /// taken as 150; no hysteresis, [`Quantizer::Round`]): put it on a board's grid with
    /// [`OverrideSpec::on_grid`].
    ///
    /// ```
    /// use acc_core::{FeedOverride, OverrideSpec};
    /// let grid = OverrideSpec::range(5, 200).on_grid(10);
    /// assert_eq!((grid.step_pct, grid.min_pct, grid.max_pct), (10, 10, 150));
    /// assert_eq!(grid.floor(67), FeedOverride(60));
    /// ```
    pub const fn range(min_pct: u16, max_pct: u16) -> Self {
        let max_pct = if max_pct > Self::ABSOLUTE_MAX_PCT {
            Self::ABSOLUTE_MAX_PCT
        } else {
            max_pct
        };
        Self {
            step_pct: 1,
            min_pct,
            max_pct,
            hysteresis_pct: 0.0,
            quantizer: Quantizer::Round,
        }
    }

    /// This spec on a grid of `step_pct` percent (0 is taken as 1): `max_pct` floored and
    /// `min_pct` ceiled onto the grid (never above `max_pct`); hysteresis and quantizer kept
    /// (check them with [`OverrideSpec::validate`]).
    pub fn on_grid(self, step_pct: u16) -> Self {
        let step = step_pct.max(1);
        let max_pct = self.max_pct - self.max_pct % step;
        let min_pct = self.min_pct.div_ceil(step) * step;
        Self {
            step_pct: step,
            min_pct: min_pct.min(max_pct),
            max_pct,
            ..self
        }
    }

    /// Check the spec: `step_pct` in 1 ..= 50, `min_pct <= max_pct <= 150`, both limits on
    /// the step grid (so that the limits are reachable positions), and `hysteresis_pct`
    /// finite in 0 ..= `step_pct`/2.
    pub fn validate(&self) -> Result<(), CoreError> {
        if self.step_pct == 0 || self.step_pct > 50 {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.step_pct",
                f64::from(self.step_pct),
                "1 ..= 50",
            )));
        }
        if self.max_pct > Self::ABSOLUTE_MAX_PCT || !self.max_pct.is_multiple_of(self.step_pct) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.max_pct",
                f64::from(self.max_pct),
                "a multiple of step_pct, <= 150",
            )));
        }
        if self.min_pct > self.max_pct || !self.min_pct.is_multiple_of(self.step_pct) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.min_pct",
                f64::from(self.min_pct),
                "a multiple of step_pct, <= max_pct",
            )));
        }
        let h = self.hysteresis_pct;
        if !(h.is_finite() && h >= 0.0 && h <= f64::from(self.step_pct) / 2.0) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.hysteresis_pct",
                h,
                "0 ..= step_pct/2",
            )));
        }
        if self.quantizer == Quantizer::SigmaDelta && h != 0.0 {
            return Err(CoreError::OutOfRange(RangeError::new(
                "override.hysteresis_pct",
                h,
                "0 with quantizer = \"sigma_delta\"",
            )));
        }
        Ok(())
    }

    /// Round `pct` to the nearest board step and clamp it to `[min_pct, max_pct]`.
    /// A NaN request gives `min_pct` (the safe side: never raise the feed on garbage).
    ///
    /// ```
    /// use acc_core::{FeedOverride, OverrideSpec};
    /// let spec = OverrideSpec::paper();
    /// assert_eq!(spec.quantize(64.9), FeedOverride(60));
    /// assert_eq!(spec.quantize(65.0), FeedOverride(70));
    /// assert_eq!(spec.quantize(212.0), FeedOverride(150));
    /// assert_eq!(spec.quantize(-3.0), FeedOverride(0));
    /// assert_eq!(spec.quantize(f64::NAN), FeedOverride(0));
    /// ```
    pub fn quantize(&self, pct: f64) -> FeedOverride {
        if pct.is_nan() {
            return FeedOverride(self.min_pct);
        }
        let clamped = self.clamp_pct(pct);
        let step = f64::from(self.step_pct.max(1));
        let q = (clamped / step).round() * step;
        // `q` is inside [min_pct, max_pct] <= 150, so the cast cannot truncate.
        let q = q.clamp(f64::from(self.min_pct), f64::from(self.max_pct));
        FeedOverride(q as u16)
    }

    /// The highest position at or below the integer override `pct`, clamped to `[min_pct,
    /// max_pct]`: the quantizer of a limit or of a guard, which must never raise a command
    /// (a command below `min_pct` gives `min_pct`). [`OverrideSpec::quantize`] is the
    /// law's: it rounds a continuous command to the nearest position.
    ///
    /// ```
    /// use acc_core::{FeedOverride, OverrideSpec};
    /// let spec = OverrideSpec::paper();
    /// assert_eq!(spec.floor(69), FeedOverride(60));
    /// assert_eq!(spec.floor(70), FeedOverride(70));
    /// assert_eq!(spec.floor(400), FeedOverride(150));
    /// ```
    pub fn floor(&self, pct: u16) -> FeedOverride {
        let step = self.step_pct.max(1);
        let v = pct.min(self.max_pct);
        FeedOverride((v - v % step).max(self.min_pct).min(self.max_pct))
    }

    /// The lowest position at or above the integer override `pct`, clamped to `[min_pct,
    /// max_pct]`: the quantizer of a floor on the command.
    ///
    /// ```
    /// use acc_core::{FeedOverride, OverrideSpec};
    /// let spec = OverrideSpec::paper();
    /// assert_eq!(spec.ceil(61), FeedOverride(70));
    /// assert_eq!(spec.ceil(60), FeedOverride(60));
    /// assert_eq!(spec.ceil(155), FeedOverride(150));
    /// ```
    pub fn ceil(&self, pct: u16) -> FeedOverride {
        let step = self.step_pct.max(1);
        let v = pct.min(self.max_pct);
        FeedOverride(
            (v.div_ceil(step) * step)
                .max(self.min_pct)
                .min(self.max_pct),
        )
    }

    /// [`OverrideSpec::quantize`] with a deadband of `h = hysteresis_pct` around the
    /// midpoints, relative to the position `prev` written last (`q_prev`). With `h = 0` it
    /// *is* `quantize(pct)` for every input (today's behaviour, bit for bit).
    ///
    /// With step `s`, continuous command `u = pct` clamped to `[min_pct, max_pct]`:
    ///
    /// ```text
    ///            q_prev − s      midpoint        q_prev        midpoint       q_prev + s
    /// u:  ───────────┼──────────┼─┬─┬─────────────┼─────────────┬─┬─┼──────────────┼──────
    ///                         −h│ │+h                        −h│ │+h
    ///                ◄─ down ──┘ └──────────── hold q_prev ────┘ └─── up ─►
    /// ```
    ///
    /// | condition (d = u − q_prev)                                 | output                |
    /// |------------------------------------------------------------|-----------------------|
    /// | `h = 0`, or NaN, or `q_prev` not a valid position          | `quantize(pct)`       |
    /// | `u` at or beyond a limit (`u <= min_pct` or `u >= max_pct`) | that limit (never held) |
    /// | `d ≥ s/2 + h`  or  `d < −(s/2 + h)` (incl. `abs(d) ≥ s`)   | `quantize(pct)`       |
    /// | otherwise (inside the deadband)                            | `q_prev`              |
    ///
    /// So the output is always a board position in `[min_pct, max_pct]`, differs from
    /// round-to-nearest by at most one step, never switches while `u` stays within `±h` of a
    /// midpoint, and equals round-to-nearest whenever `abs(u − q_prev) ≥ s`. A command at a
    /// limit (saturation, e.g. an overload clamping to `min_pct`) is written at once. Pure
    /// and allocation-free.
    ///
    /// ```
    /// use acc_core::{FeedOverride, OverrideSpec};
    /// let spec = OverrideSpec::paper().with_hysteresis(3.0);
    /// let at60 = FeedOverride(60);
    /// assert_eq!(spec.quantize_hysteresis(67.9, at60), FeedOverride(60)); // < 65 + 3: hold
    /// assert_eq!(spec.quantize_hysteresis(68.0, at60), FeedOverride(70)); // up
    /// assert_eq!(spec.quantize_hysteresis(52.5, at60), FeedOverride(60)); // >= 55 − 3: hold
    /// assert_eq!(spec.quantize_hysteresis(51.9, at60), FeedOverride(50)); // down
    /// assert_eq!(spec.quantize_hysteresis(93.0, at60), FeedOverride(90)); // far: nearest
    /// assert_eq!(spec.quantize_hysteresis(-1.0, FeedOverride(10)), FeedOverride(0)); // limit
    /// ```
    pub fn quantize_hysteresis(&self, pct: f64, prev: FeedOverride) -> FeedOverride {
        let nearest = self.quantize(pct);
        let h = self.hysteresis_pct;
        let step_pct = self.step_pct.max(1);
        let q_prev = prev.pct();
        let prev_valid = (self.min_pct..=self.max_pct).contains(&q_prev)
            && (q_prev - self.min_pct).is_multiple_of(step_pct);
        // A non-finite `h` (refused by `validate`) also gets plain rounding.
        if !h.is_finite() || h <= 0.0 || pct.is_nan() || !prev_valid {
            return nearest;
        }
        let u = self.clamp_pct(pct);
        if u <= f64::from(self.min_pct) || u >= f64::from(self.max_pct) {
            return nearest;
        }
        let d = u - f64::from(q_prev);
        let band = f64::from(step_pct) / 2.0 + h;
        if d >= band || d < -band {
            nearest
        } else {
            prev
        }
    }

    /// Clamp a continuous override to `[min_pct, max_pct]`, percent (NaN stays NaN).
    pub fn clamp_pct(&self, pct: f64) -> f64 {
        pct.clamp(f64::from(self.min_pct), f64::from(self.max_pct))
    }

    /// Number of positions the board can take (16 for the paper's board).
    pub fn positions(&self) -> u16 {
        (self.max_pct - self.min_pct) / self.step_pct.max(1) + 1
    }
}

/// Limits on a law's command set from outside the law for one period: the tool table and
/// entry control of the shop layer, and the plan's look-ahead cap (the lower cap wins).
/// Applied by [`CommandBounds::place`] after the guards, the cap last.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommandLimits {
    /// Highest command this period, percent (floored onto the grid).
    pub cap_pct: Option<u16>,
    /// Lowest command this period while the force sample is valid, percent (ceiled onto the
    /// grid; never above the cap).
    pub floor_pct: Option<u16>,
}

/// Everything outside the law that bounds its command in one period, handed to the law's
/// quantization ([`OverrideSpec::place`]) so that the grid is applied once, in one place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandBounds {
    /// The configured command range on the board's `OVERRIDE_STEP` grid: the law's position
    /// is floored onto it ([`OverrideSpec::floor`]; never raised).
    pub grid: OverrideSpec,
    /// The force sample is valid: the limits' floor applies only then.
    pub valid: bool,
    /// Never above this command, percent: the last command on an invalid sample (taken as
    /// it is; it is already a position).
    pub hold_pct: Option<u16>,
    /// Never above the operator's knob when it caps ACC, percent (floored onto the grid).
    pub knob_pct: Option<u16>,
    /// The shop layer's and the plan's limits.
    pub limits: CommandLimits,
}

/// Where [`OverrideSpec::place`] put a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placed {
    /// The law's own position (its quantizer, before the bounds).
    pub law: FeedOverride,
    /// The command to write: the law's position on the grid within the bounds.
    pub cmd: FeedOverride,
    /// The limits (floor or cap) changed the command: the law re-seats its integrator on
    /// `cmd` (bumpless, no windup against the limit). The grid and the guards (hold, knob)
    /// do not re-seat.
    pub reseat: bool,
}

/// What the law asks of the quantizer in one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Demand {
    /// Hold the last position (invalid sample, no programmed feed).
    Held,
    /// The demand is beyond a limit of the law's range: this limit, written at once (never
    /// held back by the deadband or the dither).
    Saturated(FeedOverride),
    /// A continuous command inside the range, percent.
    Within(f64),
}

impl CommandBounds {
    /// The bounds on `position` (a position of the law's spec): floored onto the grid, never
    /// above `hold_pct`, never above the floored knob; then, while valid, never below the
    /// limits' floor (ceiled onto the grid; the floor itself never above the knob), and
    /// never above their cap (floored), last.
    ///
    /// ```
    /// use acc_core::{CommandBounds, CommandLimits, FeedOverride, OverrideSpec};
    /// let b = CommandBounds {
    ///     grid: OverrideSpec::range(0, 150).on_grid(10),
    ///     valid: true,
    ///     hold_pct: None,
    ///     knob_pct: None,
    ///     limits: CommandLimits { cap_pct: Some(87), floor_pct: None },
    /// };
    /// let p = b.place(FeedOverride(120));
    /// assert_eq!((p.cmd, p.reseat), (FeedOverride(80), true));
    /// ```
    pub fn place(&self, position: FeedOverride) -> Placed {
        let grid = &self.grid;
        let mut cmd = grid.floor(position.0).0;
        if let Some(h) = self.hold_pct {
            cmd = cmd.min(h);
        }
        if let Some(knob) = self.knob_pct {
            cmd = cmd.min(grid.floor(knob).0);
        }
        let guarded = cmd;
        if let Some(f) = self.limits.floor_pct.filter(|_| self.valid) {
            // A floor never lifts the command above the operator's knob (operator priority).
            let mut f = grid.ceil(f).0;
            if let Some(knob) = self.knob_pct {
                f = f.min(grid.floor(knob).0);
            }
            cmd = cmd.max(f);
        }
        if let Some(c) = self.limits.cap_pct {
            cmd = cmd.min(grid.floor(c).0);
        }
        Placed {
            law: position,
            cmd: FeedOverride(cmd),
            reseat: cmd != guarded,
        }
    }
}

impl OverrideSpec {
    /// The law's one quantization step: the position for `demand` by this spec's quantizer
    /// (hysteresis relative to `prev`, the law's last position; or the σ-Δ `sigma`, reset at
    /// a limit), then within `bounds` when the law runs under a policy
    /// ([`CommandBounds::place`]). Without bounds the command is the law's position.
    pub fn place(
        &self,
        demand: Demand,
        prev: FeedOverride,
        sigma: &mut SigmaDelta,
        bounds: Option<&CommandBounds>,
    ) -> Placed {
        let position = match (demand, self.quantizer) {
            (Demand::Held, _) => prev,
            (Demand::Within(pct), Quantizer::Round) => self.quantize_hysteresis(pct, prev),
            (Demand::Within(pct), Quantizer::SigmaDelta) => sigma.step(self, pct),
            (Demand::Saturated(limit), _) => {
                sigma.reset();
                limit
            }
        };
        match bounds {
            Some(b) => b.place(position),
            None => Placed {
                law: position,
                cmd: position,
                reseat: false,
            },
        }
    }
}

impl Default for OverrideSpec {
    /// [`OverrideSpec::paper`].
    fn default() -> Self {
        Self::paper()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_board_has_sixteen_positions() {
        assert_eq!(OverrideSpec::paper().positions(), 16);
        assert!(OverrideSpec::paper().validate().is_ok());
    }

    #[test]
    fn byte_board_quantizes_to_one_percent() {
        let s = OverrideSpec::byte_board();
        assert_eq!(s.quantize(63.4), FeedOverride(63));
        assert_eq!(s.quantize(63.6), FeedOverride(64));
    }

    #[test]
    fn invalid_specs_are_refused() {
        let bad = [
            OverrideSpec {
                step_pct: 0,
                min_pct: 0,
                max_pct: 150,
                hysteresis_pct: 0.0,
                quantizer: Quantizer::Round,
            },
            OverrideSpec {
                step_pct: 10,
                min_pct: 0,
                max_pct: 160,
                hysteresis_pct: 0.0,
                quantizer: Quantizer::Round,
            },
            OverrideSpec {
                step_pct: 10,
                min_pct: 0,
                max_pct: 145,
                hysteresis_pct: 0.0,
                quantizer: Quantizer::Round,
            },
            OverrideSpec {
                step_pct: 10,
                min_pct: 100,
                max_pct: 50,
                hysteresis_pct: 0.0,
                quantizer: Quantizer::Round,
            },
            OverrideSpec::paper().with_hysteresis(5.5),
            OverrideSpec::paper().with_hysteresis(-0.1),
            OverrideSpec::paper().with_hysteresis(f64::NAN),
            OverrideSpec::byte_board().with_hysteresis(0.6),
        ];
        for s in bad {
            assert!(s.validate().is_err(), "{s:?} accepted");
        }
    }

    #[test]
    fn quantize_respects_a_raised_minimum() {
        let s = OverrideSpec {
            step_pct: 10,
            min_pct: 20,
            max_pct: 120,
            hysteresis_pct: 0.0,
            quantizer: Quantizer::Round,
        };
        assert_eq!(s.quantize(0.0), FeedOverride(20));
        assert_eq!(s.quantize(500.0), FeedOverride(120));
    }

    #[test]
    fn hysteresis_limits_are_accepted_at_half_a_step() {
        assert!(OverrideSpec::paper()
            .with_hysteresis(5.0)
            .validate()
            .is_ok());
        assert!(OverrideSpec::byte_board()
            .with_hysteresis(0.5)
            .validate()
            .is_ok());
    }

    #[test]
    fn hysteresis_writes_a_limit_at_once_even_at_half_a_step() {
        let s = OverrideSpec {
            step_pct: 10,
            min_pct: 20,
            max_pct: 120,
            hysteresis_pct: 5.0,
            quantizer: Quantizer::Round,
        };
        // u exactly at the lower limit: the band edge would be 30 − 5 − 5 = 20 (not < 20).
        assert_eq!(
            s.quantize_hysteresis(20.0, FeedOverride(30)),
            FeedOverride(20)
        );
        assert_eq!(
            s.quantize_hysteresis(120.0, FeedOverride(110)),
            FeedOverride(120)
        );
        // An off-grid last position (e.g. engaged at 95 %) falls back to rounding.
        assert_eq!(
            s.quantize_hysteresis(99.0, FeedOverride(95)),
            FeedOverride(100)
        );
        assert_eq!(
            s.quantize_hysteresis(f64::NAN, FeedOverride(60)),
            FeedOverride(20)
        );
    }
}
