//! [`ForceSource`] implementations over the spindle estimator: from the period's
//! three-phase block (`PeriodInput::phases`) or from the spindle power the interface board
//! reports (`PeriodInput::power_w`, input registers 4–5 of `pmc-board.md`).
//!
//! Whatever goes wrong — no block, a block whose length does not match the period, NaN,
//! negative power, a speed transient, a speed the no-load model does not know — the loop
//! gets [`ForceSample::INVALID`] and [`SpindleSource::last`] says why.

use super::estimate::{Estimate, Invalid, Method, SpindleEstimator};
use super::power::block_stats;
use super::SpindleError;
use crate::{ForceSample, ForceSource, PeriodInput};

/// Which field of [`PeriodInput`] the source reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpindleInput {
    /// The raw three-phase block (`phases`): power and current.
    Phases,
    /// The board's power value (`power_w`): power only, so only the power methods.
    BoardPower,
}

/// A force source driven by the spindle estimator.
#[derive(Debug, Clone)]
pub struct SpindleSource {
    name: String,
    input: SpindleInput,
    est: SpindleEstimator,
    deadband: bool,
    last: Option<Result<Estimate, Invalid>>,
    last_error: Option<SpindleError>,
    block_tolerance: f64,
}

impl SpindleSource {
    /// A source reading `input` through `est`. Forces within the estimator's noise floor
    /// are reported as 0 (no measurable cut); see [`SpindleSource::with_deadband`].
    ///
    /// Errors if the board input is combined with a current method (the board has no
    /// current).
    pub fn new(input: SpindleInput, est: SpindleEstimator) -> Result<Self, SpindleError> {
        let method = est.config().method;
        if input == SpindleInput::BoardPower && !method.needs_power() {
            return Err(SpindleError::InputLacksSignal {
                input: "board-power",
                method: method.name(),
            });
        }
        let name = match input {
            SpindleInput::Phases if method.needs_power() => "spindle-power",
            SpindleInput::Phases => match method {
                Method::Current => "spindle-current",
                _ => "spindle-current-motor",
            },
            SpindleInput::BoardPower => "board-power",
        };
        Ok(Self {
            name: name.to_string(),
            input,
            est,
            deadband: true,
            last: None,
            last_error: None,
            block_tolerance: 0.01,
        })
    }

    /// Report forces within the noise floor as 0 (`true`, the default) or as estimated.
    pub fn with_deadband(mut self, on: bool) -> Self {
        self.deadband = on;
        self
    }

    /// The estimator.
    pub fn estimator(&self) -> &SpindleEstimator {
        &self.est
    }

    /// The estimator, mutable (e.g. to learn an air cut).
    pub fn estimator_mut(&mut self) -> &mut SpindleEstimator {
        &mut self.est
    }

    /// The last period's estimate or the reason it was invalid.
    pub fn last(&self) -> Option<&Result<Estimate, Invalid>> {
        self.last.as_ref()
    }

    /// The block error behind the last [`Invalid::BadBlock`], if any.
    pub fn last_block_error(&self) -> Option<&SpindleError> {
        self.last_error.as_ref()
    }

    fn run(&mut self, input: &PeriodInput<'_>) -> Result<Estimate, Invalid> {
        self.last_error = None;
        match self.input {
            SpindleInput::BoardPower => {
                let p = input.power_w.ok_or(Invalid::MissingPower)?;
                self.est.estimate(input.spindle_rpm, Some(p), None)
            }
            SpindleInput::Phases => {
                let block = input.phases.ok_or(Invalid::BadBlock)?;
                let n = block.i_u.len() as f64;
                let expected = input.period_s * block.sample_rate_hz;
                if input.period_s > 0.0
                    && (n - expected).abs() > (self.block_tolerance * expected).max(1.0)
                {
                    return Err(Invalid::Truncated);
                }
                let s = block_stats(&block).map_err(|e| {
                    let inv = match e {
                        SpindleError::NonFinite { .. } | SpindleError::Overflow => {
                            Invalid::NonFinite
                        }
                        _ => Invalid::BadBlock,
                    };
                    self.last_error = Some(e);
                    inv
                })?;
                self.est
                    .estimate(input.spindle_rpm, Some(s.power_w), Some(s.current_rms_a))
            }
        }
    }
}

impl ForceSource for SpindleSource {
    fn name(&self) -> &str {
        &self.name
    }

    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample {
        let r = self.run(input);
        self.last = Some(r);
        match r {
            Ok(e) => ForceSample {
                force_n: if self.deadband && !e.above_floor {
                    0.0
                } else {
                    e.force_n.max(0.0)
                },
                power_w: e.power_w,
                valid: true,
            },
            Err(_) => ForceSample {
                power_w: input.power_w,
                ..ForceSample::INVALID
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spindle_force::constants::{Constants, CurrentConstant};
    use crate::spindle_force::estimate::{EstimatorConfig, NoLoadMode};
    use crate::spindle_force::noload::{AdaptRule, NoLoadModel};
    use crate::PhaseBlock;

    fn source(input: SpindleInput) -> SpindleSource {
        let mut nl = NoLoadModel::new(AdaptRule::default());
        nl.learn(1500.0, 600.0, 25.0).unwrap();
        let cfg = EstimatorConfig {
            method: Method::Power,
            no_load: NoLoadMode::Fixed,
            ..Default::default()
        };
        SpindleSource::new(
            input,
            SpindleEstimator::new(cfg, Constants::default(), nl).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn board_power_gives_force_and_flags_garbage() {
        let mut s = source(SpindleInput::BoardPower);
        let mut input = PeriodInput {
            period_s: 0.1,
            spindle_rpm: 1500.0,
            power_w: Some(1600.0),
            ..Default::default()
        };
        let f = s.estimate(&input);
        assert!(f.valid && (f.force_n - 159.15).abs() < 0.01);
        for bad in [f64::NAN, -10.0, f64::INFINITY] {
            input.power_w = Some(bad);
            let f = s.estimate(&input);
            assert!(!f.valid && f.force_n == 0.0, "{bad}");
        }
        input.power_w = None;
        assert!(!s.estimate(&input).valid);
        assert_eq!(s.last(), Some(&Err(Invalid::MissingPower)));
    }

    #[test]
    fn wrong_block_length_is_truncated() {
        let mut s = source(SpindleInput::Phases);
        let x = vec![1.0; 500];
        let block = PhaseBlock {
            sample_rate_hz: 10_000.0,
            i_u: &x,
            i_v: &x,
            v_uw: &x,
            v_vw: &x,
        };
        let input = PeriodInput {
            period_s: 0.1,
            spindle_rpm: 1500.0,
            phases: Some(block),
            ..Default::default()
        };
        assert!(!s.estimate(&input).valid);
        assert_eq!(s.last(), Some(&Err(Invalid::Truncated)));
        // Right length, but one channel short: a wrong channel layout.
        let full = vec![1.0; 1000];
        let short = vec![1.0; 999];
        let input = PeriodInput {
            phases: Some(PhaseBlock {
                sample_rate_hz: 10_000.0,
                i_u: &full,
                i_v: &full,
                v_uw: &full,
                v_vw: &short,
            }),
            ..input
        };
        assert!(!s.estimate(&input).valid);
        assert_eq!(s.last(), Some(&Err(Invalid::BadBlock)));
        assert!(matches!(
            s.last_block_error(),
            Some(SpindleError::LengthMismatch { v_vw: 999, .. })
        ));
    }

    #[test]
    fn board_with_current_method_is_refused() {
        let mut nl = NoLoadModel::new(AdaptRule::default());
        nl.learn(1500.0, 600.0, 25.0).unwrap();
        let cfg = EstimatorConfig {
            method: Method::Current,
            ..Default::default()
        };
        let c = Constants {
            current: Some(CurrentConstant { kt_nm_per_a: 1.0 }),
            ..Default::default()
        };
        let est = SpindleEstimator::new(cfg, c, nl).unwrap();
        let Err(e) = SpindleSource::new(SpindleInput::BoardPower, est) else {
            panic!("board power with the current method must be refused");
        };
        // A configuration mismatch, not a failed calibration fit.
        assert_eq!(
            e,
            SpindleError::InputLacksSignal {
                input: "board-power",
                method: Method::Current.name(),
            }
        );
        assert!(e.to_string().contains("method `power`"), "{e}");
    }
}
