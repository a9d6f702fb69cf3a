//! Comparison baselines, each an [`OverrideLaw`] like the adaptive controller.
//!
//! - [`ConstantFeed`]: no control, a fixed override throughout: 100 % (the programmed
//!   feed), or the "safe" override an NC programmer without ACC would choose so that the
//!   deepest, hardest section stays at Fr (see `Scenario::safe_override_pct`).
//! - the paper's fixed-gain PI is the core's `Controller` in `FixedPi` mode (built by the
//!   scenario from the `fixed_gain` preset), not a copy here;
//! - [`RateLimited`]: like Haas Autofeed — the override moves down at 20 %/s while the force
//!   is above the limit and up at 10 %/s while it is below 95 % of it, in 0.1 s steps;
//! - [`Proportional`]: like ToolScope's adaptive control — each period the override changes
//!   by minus the relative force error, `Δov = −g·100 %·(F − Fr)/Fr`.
//!
//! Baselines keep a continuous internal override and send it rounded to the board's step,
//! so a 1 %/step law still moves on a 10 % board (every few steps).

use acc_core::{
    FeedOverride, Measurement, Mode, OverrideLaw, OverrideSpec, Saturation, StepOutput, Trace,
};

/// State shared by the baselines: a continuous override, its limits and freezing.
#[derive(Debug, Clone)]
struct Core {
    spec: OverrideSpec,
    force_ref_n: f64,
    ov_pct: f64,
    frozen: bool,
}

impl Core {
    fn new(spec: OverrideSpec, force_ref_n: f64) -> Self {
        Core {
            spec,
            force_ref_n,
            ov_pct: 100.0,
            frozen: false,
        }
    }

    fn engage(&mut self, current: FeedOverride) {
        self.ov_pct = self.spec.clamp_pct(f64::from(current.pct()));
    }

    /// Apply a change of the continuous override (refused while frozen; a rise is refused
    /// on an invalid sample) and build the output.
    fn apply(&mut self, m: &Measurement, delta_pct: f64) -> StepOutput {
        let usable = m.valid && m.force_n.is_finite();
        let delta = if self.frozen || !delta_pct.is_finite() || (!usable && delta_pct > 0.0) {
            0.0
        } else {
            delta_pct
        };
        let raw = self.ov_pct + delta;
        self.ov_pct = self.spec.clamp_pct(raw);
        let command = self.spec.quantize(self.ov_pct);
        let saturation = if raw >= f64::from(self.spec.max_pct) {
            Saturation::High
        } else if raw <= f64::from(self.spec.min_pct) {
            Saturation::Low
        } else {
            Saturation::None
        };
        StepOutput {
            command,
            trace: Trace {
                force_ref_n: self.force_ref_n,
                error_n: self.force_ref_n - m.force_n,
                kc_hat: 0.0,
                kp: 0.0,
                ki: 0.0,
                integral_mm_min: 0.0,
                feed_cmd_mm_min: command.feed_mm_min(m.programmed_feed_mm_min),
                unquantized_pct: self.ov_pct,
                saturation,
                mode: Mode::Baseline,
                estimator_active: false,
                excitation: 0.0,
            },
        }
    }
}

/// No control: a constant override.
#[derive(Debug, Clone)]
pub struct ConstantFeed {
    core: Core,
    pct: f64,
    name: String,
}

impl ConstantFeed {
    /// 100 % of the programmed feed, with the board's override spec and the force
    /// reference (for the trace only).
    pub fn new(spec: OverrideSpec, force_ref_n: f64) -> Self {
        Self::at(spec, force_ref_n, 100, "constant-feed")
    }

    /// A constant `pct` (clamped to the spec) under the table name `name`.
    pub fn at(spec: OverrideSpec, force_ref_n: f64, pct: u16, name: &str) -> Self {
        ConstantFeed {
            core: Core::new(spec, force_ref_n),
            pct: spec.clamp_pct(f64::from(pct)),
            name: name.to_string(),
        }
    }
}

impl OverrideLaw for ConstantFeed {
    fn name(&self) -> &str {
        &self.name
    }

    fn engage(&mut self, _current: FeedOverride) {
        self.core.ov_pct = self.pct;
    }

    fn step(&mut self, m: &Measurement) -> StepOutput {
        self.core.ov_pct = self.pct;
        self.core.apply(m, 0.0)
    }

    fn set_frozen(&mut self, frozen: bool) {
        self.core.frozen = frozen;
    }
}

/// Haas-Autofeed-like rate-limited law.
#[derive(Debug, Clone)]
pub struct RateLimited {
    core: Core,
    period_s: f64,
    /// Rate down while `F > limit`, %/s (Haas: 20).
    pub down_pct_per_s: f64,
    /// Rate up while `F < 0.95·limit`, %/s (Haas: 10).
    pub up_pct_per_s: f64,
    /// Fraction of the limit below which the override rises (Haas: 0.95).
    pub up_below: f64,
}

impl RateLimited {
    /// The Haas defaults with the limit at `force_ref_n` and the loop period `period_s`
    /// (the 0.1 s steps).
    pub fn new(spec: OverrideSpec, force_ref_n: f64, period_s: f64) -> Self {
        RateLimited {
            core: Core::new(spec, force_ref_n),
            period_s,
            down_pct_per_s: 20.0,
            up_pct_per_s: 10.0,
            up_below: 0.95,
        }
    }
}

impl OverrideLaw for RateLimited {
    fn name(&self) -> &str {
        "rate-limited"
    }

    /// A tool change: the force limit follows the tool table's Fr.
    fn set_force_ref_n(&mut self, force_ref_n: f64) {
        if force_ref_n.is_finite() && force_ref_n > 0.0 {
            self.core.force_ref_n = force_ref_n;
        }
    }

    fn engage(&mut self, current: FeedOverride) {
        self.core.engage(current);
    }

    fn step(&mut self, m: &Measurement) -> StepOutput {
        let limit = self.core.force_ref_n;
        let delta = if m.force_n > limit {
            -self.down_pct_per_s * self.period_s
        } else if m.force_n < self.up_below * limit {
            self.up_pct_per_s * self.period_s
        } else {
            0.0
        };
        self.core.apply(m, delta)
    }

    fn set_frozen(&mut self, frozen: bool) {
        self.core.frozen = frozen;
    }
}

/// ToolScope-like proportional law: `Δov = −gain·100 %·(F − Fr)/Fr` per period.
#[derive(Debug, Clone)]
pub struct Proportional {
    core: Core,
    /// Gain on the relative error (1 = the literal law).
    pub gain: f64,
}

impl Proportional {
    /// Gain 1.
    pub fn new(spec: OverrideSpec, force_ref_n: f64) -> Self {
        Proportional {
            core: Core::new(spec, force_ref_n),
            gain: 1.0,
        }
    }
}

impl OverrideLaw for Proportional {
    fn name(&self) -> &str {
        "proportional"
    }

    /// A tool change: the force limit follows the tool table's Fr.
    fn set_force_ref_n(&mut self, force_ref_n: f64) {
        if force_ref_n.is_finite() && force_ref_n > 0.0 {
            self.core.force_ref_n = force_ref_n;
        }
    }

    fn engage(&mut self, current: FeedOverride) {
        self.core.engage(current);
    }

    fn step(&mut self, m: &Measurement) -> StepOutput {
        let fr = self.core.force_ref_n;
        let delta = -self.gain * 100.0 * (m.force_n - fr) / fr;
        self.core.apply(m, delta)
    }

    fn set_frozen(&mut self, frozen: bool) {
        self.core.frozen = frozen;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(force_n: f64) -> Measurement {
        Measurement {
            force_n,
            feed_mm_min: 200.0,
            programmed_feed_mm_min: 200.0,
            valid: true,
        }
    }

    #[test]
    fn rate_limited_moves_at_its_rates() {
        let mut law = RateLimited::new(OverrideSpec::byte_board(), 800.0, 0.1);
        law.engage(FeedOverride(100));
        // 1 s above the limit: −20 %.
        for _ in 0..10 {
            law.step(&m(900.0));
        }
        assert_eq!(law.step(&m(790.0)).command, FeedOverride(80));
        // Between 95 % and 100 % of the limit: hold. Below: +10 %/s.
        for _ in 0..10 {
            law.step(&m(500.0));
        }
        assert_eq!(law.step(&m(790.0)).command, FeedOverride(90));
    }

    #[test]
    fn proportional_changes_by_the_relative_error_and_never_rises_on_invalid() {
        let mut law = Proportional::new(OverrideSpec::byte_board(), 800.0);
        law.engage(FeedOverride(100));
        // 25 % too much force: −25 %.
        assert_eq!(law.step(&m(1000.0)).command, FeedOverride(75));
        let mut bad = m(0.0);
        bad.valid = false;
        assert_eq!(law.step(&bad).command, FeedOverride(75));
        assert_eq!(law.step(&m(0.0)).command, FeedOverride(150));
    }

    #[test]
    fn constant_feed_stays_at_100() {
        let mut law = ConstantFeed::new(OverrideSpec::paper(), 800.0);
        law.engage(FeedOverride(150));
        assert_eq!(law.step(&m(5000.0)).command, FeedOverride(100));
    }
}
