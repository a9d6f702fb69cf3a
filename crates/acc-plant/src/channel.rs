//! Measurement channels: how the loop gets its force for a period.
//!
//! The loop only calls [`MeasurementChannel::measure`]. A channel turns the machine's
//! [`PeriodRecord`] into the [`PeriodInput`] of an `acc_core::ForceSource` (the same trait
//! the real runtime uses) and asks the source for its estimate. The dynamometer channel is
//! here; a spindle-power channel (an induction-motor model producing 3-phase signals and a
//! power-based force source) implements the same trait and is selected by the scenario's
//! `[measurement] kind`, so the loop does not change.
//!
//! A channel whose sensor is the interface board's power transducer (the spindle-power
//! channel on a power method) hands its estimator to the production loop instead
//! ([`MeasurementChannel::take_board_source`]): the simulated board publishes the measured
//! power in its `POWER` registers ([`Reading::board_power_w`]) and the loop estimates the
//! force from the status read, as `acc run` does.

use acc_core::filter::FirstOrderLag;
use acc_core::{ForceSample, ForceSource, PeriodInput};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::machine::PeriodRecord;

/// A channel's reading for one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// What the controller gets.
    pub sample: ForceSample,
    /// The noise-free true mean force over what the channel looked at, N (sim only; the
    /// run log's `force_true_n`).
    pub true_force_n: f64,
    /// The spindle power the board's transducer reports for the period, W (whole watts,
    /// published in input registers 4–5); `None`: the channel does not measure the
    /// spindle power and the board publishes the machine's spindle model.
    pub board_power_w: Option<f64>,
}

/// A measurement channel of the simulated machine.
pub trait MeasurementChannel: Send {
    /// Short name for logs and tables.
    fn name(&self) -> &str;
    /// Measure the period that just ended.
    fn measure(&mut self, period: &PeriodRecord<'_>) -> Reading;
    /// The force source of the production loop when this channel's sensor is the board's
    /// power transducer: the estimator calibrated by the channel's start-up cut, reading
    /// the board's power register (`acc_core::spindle_force::SpindleInput::BoardPower`, the
    /// source `acc run` uses). After the call the channel only measures: [`Reading::sample`] is
    /// then invalid and the loop estimates from the status read. `None` (the default):
    /// the sensor is not on the board (a dynamometer, a current method on the three-phase
    /// block) and the loop takes [`Reading::sample`].
    fn take_board_source(&mut self) -> Option<Box<dyn ForceSource>> {
        None
    }
}

/// A dynamometer (Kistler 9257B-like, seed 002): the true mean force plus seeded Gaussian
/// noise, optionally low-passed period to period. Implements the core's [`ForceSource`]:
/// it reads `PeriodInput::true_force_n` and nothing else.
#[derive(Debug, Clone)]
pub struct Dynamometer {
    noise: Option<Normal<f64>>,
    /// Corner frequency f_c of the first-order low-pass on the period means, Hz (0 = off).
    /// The smoothing factor `e^(−2π·f_c·T)` is computed each period from
    /// `PeriodInput::period_s`.
    lowpass_hz: f64,
    state: Option<f64>,
    rng: ChaCha8Rng,
}

impl Dynamometer {
    /// `noise_n`: standard deviation of the additive noise, N (≥ 0); `lowpass_hz`: corner
    /// of a first-order low-pass on the period means, Hz (0 = off); `seed`: RNG seed.
    pub fn new(noise_n: f64, lowpass_hz: f64, seed: u64) -> Self {
        Dynamometer {
            noise: (noise_n > 0.0)
                .then(|| Normal::new(0.0, noise_n).ok())
                .flatten(),
            lowpass_hz,
            state: None,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }
}

impl ForceSource for Dynamometer {
    fn name(&self) -> &str {
        "dynamometer"
    }

    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample {
        let Some(truth) = input.true_force_n.filter(|f| f.is_finite()) else {
            return ForceSample::INVALID;
        };
        let noisy = truth + self.noise.map_or(0.0, |n| n.sample(&mut self.rng));
        let out = if self.lowpass_hz > 0.0 {
            FirstOrderLag::from_cutoff_hz(self.lowpass_hz).step_from(
                &mut self.state,
                noisy,
                input.period_s,
            )
        } else {
            noisy
        };
        ForceSample {
            force_n: out,
            power_w: input.power_w,
            valid: true,
        }
    }
}

/// Feeds a [`ForceSource`] with the mean force over the last `window_s` of each period
/// (the window the rig averages, e.g. two tooth passes after the previous override change
/// has settled), the mean feed, speed and spindle power.
#[derive(Debug, Clone)]
pub struct WindowedChannel<S> {
    source: S,
    window_s: f64,
}

impl<S: ForceSource> WindowedChannel<S> {
    /// `window_s` = 0 averages the whole period.
    pub fn new(source: S, window_s: f64) -> Self {
        WindowedChannel { source, window_s }
    }
}

impl<S: ForceSource> MeasurementChannel for WindowedChannel<S> {
    fn name(&self) -> &str {
        self.source.name()
    }

    fn measure(&mut self, period: &PeriodRecord<'_>) -> Reading {
        let truth = period.force_window_mean_n(self.window_s);
        let input = PeriodInput {
            period_s: period.period_s,
            spindle_rpm: period.spindle_rpm,
            feed_mm_min: period.feed_mean_mm_min,
            true_force_n: Some(truth),
            power_w: Some(period.power_mean_w),
            phases: None,
        };
        Reading {
            sample: self.source.estimate(&input),
            true_force_n: truth,
            board_power_w: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(f: f64) -> PeriodInput<'static> {
        PeriodInput {
            period_s: 0.1,
            true_force_n: Some(f),
            ..PeriodInput::default()
        }
    }

    #[test]
    fn noise_is_seeded_and_has_the_configured_spread() {
        let mut a = Dynamometer::new(10.0, 0.0, 7);
        let mut b = Dynamometer::new(10.0, 0.0, 7);
        let xs: Vec<f64> = (0..4000)
            .map(|_| a.estimate(&input(800.0)).force_n)
            .collect();
        let ys: Vec<f64> = (0..4000)
            .map(|_| b.estimate(&input(800.0)).force_n)
            .collect();
        assert_eq!(xs, ys);
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        // 4000 samples: the standard error of the mean is 10/√4000 ≈ 0.16 N.
        assert!((mean - 800.0).abs() < 0.8, "{mean}");
        assert!((sd - 10.0).abs() < 0.5, "{sd}");
    }

    #[test]
    fn lowpass_follows_a_step_with_its_time_constant() {
        let mut d = Dynamometer::new(0.0, 1.0, 1);
        d.estimate(&input(0.0));
        let y = d.estimate(&input(100.0)).force_n;
        let a = (-2.0 * std::f64::consts::PI * 0.1f64).exp();
        assert!((y - 100.0 * (1.0 - a)).abs() < 1e-9);
    }

    #[test]
    fn missing_or_nan_truth_is_invalid() {
        let mut d = Dynamometer::new(0.0, 0.0, 1);
        assert!(!d.estimate(&input(f64::NAN)).valid);
        assert!(!d.estimate(&PeriodInput::default()).valid);
    }
}
