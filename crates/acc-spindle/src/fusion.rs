//! Spindle + feed-drive current fusion (seed 004, physics.md §3).
//!
//! The spindle signal has a low bandwidth (≈ 5 Hz) but a high static sensitivity to the
//! cutting force; the feed drive current has ≈ 60 Hz bandwidth and a high dynamic
//! sensitivity (`Kt·I_rms = C + Kf·F_x`). The fused estimate adds the low-passed spindle
//! force (the mean) to the band-passed, scaled feed current (the per-tooth variation):
//!
//! ```text
//! F(k) = LP(F_spindle)(k) + k_feed · BP(I_feed)(k)
//! ```
//!
//! Both filters are second-order sections (RBJ audio-EQ cookbook forms), run per sample,
//! no allocation. The band-pass removes the feed drive's constant friction part `C`.
//!
//! ```
//! use acc_spindle::fusion::{Fusion, FusionConfig};
//! let mut f = Fusion::new(FusionConfig { sample_rate_hz: 1000.0, ..Default::default() }).unwrap();
//! let mut y = 0.0;
//! for _ in 0..5000 { y = f.push(300.0, 4.0); }
//! // Constant inputs: the mean passes, the feed current's constant part is removed.
//! assert!((y - 300.0).abs() < 1e-6);
//! ```

use serde::{Deserialize, Serialize};

use acc_core::spindle_force::SpindleError;
use acc_core::RangeError;

/// Fusion settings. TOML keys are the field names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FusionConfig {
    /// Rate at which both signals are pushed, Hz. Default 1000.
    pub sample_rate_hz: f64,
    /// Low-pass corner for the spindle force, Hz (seed 004: ≈ 5 Hz bandwidth). Default 5.
    pub lowpass_hz: f64,
    /// Band-pass centre for the feed current, Hz (set near the tooth-passing frequency).
    /// Default 40.
    pub bandpass_hz: f64,
    /// Band-pass quality factor, −. Default 0.5 (wide: passes roughly 5…80 Hz at 40 Hz).
    pub bandpass_q: f64,
    /// Scale from feed current to tangential force, N/A (`R/Kf·Kt` of seed 004, fitted
    /// against a reference). Default 50.
    pub feed_n_per_a: f64,
}

impl Default for FusionConfig {
    fn default() -> Self {
        Self {
            sample_rate_hz: 1000.0,
            lowpass_hz: 5.0,
            bandpass_hz: 40.0,
            bandpass_q: 0.5,
            feed_n_per_a: 50.0,
        }
    }
}

/// One second-order section, transposed direct form II.
#[derive(Debug, Clone, Copy, Default)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Biquad {
    /// Low-pass with corner `fc` Hz and quality `q` at sample rate `fs` Hz.
    pub fn lowpass(fs: f64, fc: f64, q: f64) -> Self {
        let w = 2.0 * std::f64::consts::PI * fc / fs;
        let (s, c) = w.sin_cos();
        let alpha = s / (2.0 * q);
        let a0 = 1.0 + alpha;
        Self::norm(
            [(1.0 - c) / 2.0, 1.0 - c, (1.0 - c) / 2.0],
            [a0, -2.0 * c, 1.0 - alpha],
        )
    }

    /// Band-pass (0 dB peak gain) centred at `fc` Hz with quality `q`.
    pub fn bandpass(fs: f64, fc: f64, q: f64) -> Self {
        let w = 2.0 * std::f64::consts::PI * fc / fs;
        let (s, c) = w.sin_cos();
        let alpha = s / (2.0 * q);
        Self::norm([alpha, 0.0, -alpha], [1.0 + alpha, -2.0 * c, 1.0 - alpha])
    }

    fn norm(b: [f64; 3], a: [f64; 3]) -> Self {
        Self {
            b: [b[0] / a[0], b[1] / a[0], b[2] / a[0]],
            a: [a[1] / a[0], a[2] / a[0]],
            z: [0.0; 2],
        }
    }

    /// Filter one sample.
    pub fn push(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }

    /// Start from the steady state of a constant input `x` (no start-up transient).
    pub fn settle(&mut self, x: f64) {
        let dc = (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1]);
        let y = dc * x;
        self.z[1] = self.b[2] * x - self.a[1] * y;
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
    }
}

/// The fused estimator.
#[derive(Debug, Clone, Copy)]
pub struct Fusion {
    cfg: FusionConfig,
    lp: Biquad,
    bp: Biquad,
    started: bool,
}

impl Fusion {
    /// Build; corner frequencies must lie below the Nyquist frequency.
    pub fn new(cfg: FusionConfig) -> Result<Self, SpindleError> {
        let nyq = cfg.sample_rate_hz / 2.0;
        let bad = |key, value: f64, ok: bool| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(SpindleError::OutOfRange(RangeError::new(
                    key,
                    value,
                    "0 < f < sample_rate_hz / 2",
                )))
            }
        };
        bad(
            "sample_rate_hz",
            cfg.sample_rate_hz,
            cfg.sample_rate_hz > 0.0,
        )?;
        bad(
            "lowpass_hz",
            cfg.lowpass_hz,
            cfg.lowpass_hz > 0.0 && cfg.lowpass_hz < nyq,
        )?;
        bad(
            "bandpass_hz",
            cfg.bandpass_hz,
            cfg.bandpass_hz > 0.0 && cfg.bandpass_hz < nyq,
        )?;
        bad("bandpass_q", cfg.bandpass_q, cfg.bandpass_q > 0.0)?;
        bad("feed_n_per_a", cfg.feed_n_per_a, true)?;
        let q = std::f64::consts::FRAC_1_SQRT_2;
        Ok(Self {
            cfg,
            lp: Biquad::lowpass(cfg.sample_rate_hz, cfg.lowpass_hz, q),
            bp: Biquad::bandpass(cfg.sample_rate_hz, cfg.bandpass_hz, cfg.bandpass_q),
            started: false,
        })
    }

    /// Push one spindle force sample (N) and one feed-drive current sample (A); returns the
    /// fused force, N.
    pub fn push(&mut self, spindle_force_n: f64, feed_current_a: f64) -> f64 {
        if !self.started {
            self.lp.settle(spindle_force_n);
            self.bp.settle(feed_current_a);
            self.started = true;
        }
        self.lp.push(spindle_force_n) + self.cfg.feed_n_per_a * self.bp.push(feed_current_a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Tooth-pass ripple at 25 Hz around a 400 N mean. The spindle signal sees the mean
    /// (plus slow noise), the feed current sees ripple with an offset: fused ≈ true force.
    #[test]
    fn fusion_tracks_mean_and_ripple_better_than_either() {
        let fs = 1000.0;
        let cfg = FusionConfig {
            sample_rate_hz: fs,
            bandpass_hz: 25.0,
            bandpass_q: 0.7,
            feed_n_per_a: 100.0,
            ..Default::default()
        };
        let mut fu = Fusion::new(cfg).unwrap();
        let mut spindle_lp = Biquad::lowpass(fs, 5.0, std::f64::consts::FRAC_1_SQRT_2);
        spindle_lp.settle(400.0);
        let (mut e_fused, mut e_spindle) = (0.0, 0.0);
        for k in 0..4000 {
            let t = k as f64 / fs;
            let truth = 400.0 + 80.0 * (2.0 * PI * 25.0 * t).sin();
            // The spindle drive's own ≈ 5 Hz bandwidth.
            let spindle = spindle_lp.push(truth);
            let feed_current = 3.0 + (truth - 400.0) / 100.0;
            let fused = fu.push(spindle, feed_current);
            if k > 1000 {
                e_fused += (fused - truth).powi(2);
                e_spindle += (spindle - truth).powi(2);
            }
        }
        assert!(
            e_fused < 0.1 * e_spindle,
            "fused {e_fused} spindle {e_spindle}"
        );
    }

    #[test]
    fn bad_corner_is_refused() {
        let cfg = FusionConfig {
            lowpass_hz: 600.0,
            ..Default::default()
        };
        assert!(Fusion::new(cfg)
            .unwrap_err()
            .to_string()
            .contains("lowpass_hz"));
    }
}
