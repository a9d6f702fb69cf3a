//! The sampled motor ([`MotorSim`]): drive lag, phase currents and line voltages with
//! harmonics, noise and ADC quantisation, one [`MotorBlock`] per period.

use std::f64::consts::PI;

use acc_core::filter::FirstOrderLag;
use acc_core::spindle_force::PhaseSamples;
use acc_core::PhaseBlock;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::{
    circuit::{Motor, MotorEffects, OperatingPoint},
    config::MotorConfig,
};

/// Means over one simulated period (the truth a test compares against).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PeriodTruth {
    /// Mean cutting torque at the motor (after the drive lag), N·m.
    pub cut_torque_nm: f64,
    /// Mean input power (noise-free), W.
    pub input_w: f64,
    /// Mean cutting power, W.
    pub cut_w: f64,
    /// RMS phase current (noise-free fundamental), A.
    pub current_a: f64,
    /// Mean slip, −.
    pub slip: f64,
    /// Last operating point of the period.
    pub last: OperatingPoint,
}

/// One period of sampled signals.
#[derive(Debug, Clone, Default)]
pub struct MotorBlock {
    /// The sampled channels `i_U`, `i_V` (A), `v_UW`, `v_VW` (V) at the DAQ rate.
    pub samples: PhaseSamples,
    /// Noise-free means of the period.
    pub truth: PeriodTruth,
}

impl MotorBlock {
    /// The block as the force sources take it.
    pub fn phase_block(&self) -> PhaseBlock<'_> {
        self.samples.block()
    }
}

/// The sampled motor: physics + drive lag + DAQ, seeded.
#[derive(Debug, Clone)]
pub struct MotorSim {
    motor: Motor,
    rng: ChaCha8Rng,
    theta: f64,
    lagged_torque_nm: f64,
    block: MotorBlock,
    effects: MotorEffects,
    /// Time since the simulation started (the spindle start of the drift), s.
    t_s: f64,
}

/// Quantise to the ADC grid and clip to the range.
fn adc(x: f64, range: f64, lsb: f64) -> f64 {
    // `exact::round` is `f64::round` bit for bit, without the library call.
    (crate::exact::round(x.clamp(-range, range) / lsb) * lsb).clamp(-range, range)
}

impl MotorSim {
    /// A motor at rest in phase, idle, with RNG `seed`.
    pub fn new(cfg: MotorConfig, seed: u64) -> Self {
        Self {
            motor: Motor::new(cfg),
            rng: ChaCha8Rng::seed_from_u64(seed),
            theta: 0.0,
            lagged_torque_nm: 0.0,
            block: MotorBlock::default(),
            effects: MotorEffects::default(),
            t_s: 0.0,
        }
    }

    /// The same motor with the machine file's extra losses `effects` (see
    /// [`MotorEffects`]).
    pub fn with_effects(mut self, effects: MotorEffects) -> Self {
        self.effects = effects;
        self
    }

    /// The extra losses it honours.
    pub fn effects(&self) -> &MotorEffects {
        &self.effects
    }

    /// Time since the simulation started, s.
    pub fn elapsed_s(&self) -> f64 {
        self.t_s
    }

    /// The motor physics.
    pub fn motor(&self) -> &Motor {
        &self.motor
    }

    /// Simulate one period of `period_s` at `rpm`. `torque_nm` holds the cutting torque over
    /// the period in equal time slices (one value = constant over the period; the
    /// simulator passes its internal samples). Returns the sampled block.
    pub fn run_period(&mut self, rpm: f64, torque_nm: &[f64], period_s: f64) -> &MotorBlock {
        self.run_period_tail(rpm, torque_nm, period_s, usize::MAX)
    }

    /// DAQ samples in a period of `period_s` (the block length of [`MotorSim::run_period`]).
    pub fn samples_in(&self, period_s: f64) -> usize {
        (period_s * self.motor.cfg.sensors.sample_rate_hz)
            .round()
            .max(0.0) as usize
    }

    /// [`MotorSim::run_period`] keeping only the last `keep` samples of the block (all of
    /// them if `keep` ≥ [`MotorSim::samples_in`]): the earlier ones are not synthesised,
    /// but their noise is still drawn, so the kept samples, the truth and every later
    /// period are bit for bit those of `run_period` (for a reader of a window at the end
    /// of the period, e.g. [`super::SpindlePowerChannel`]).
    pub fn run_period_tail(
        &mut self,
        rpm: f64,
        torque_nm: &[f64],
        period_s: f64,
        keep: usize,
    ) -> &MotorBlock {
        let s = self.motor.cfg.sensors;
        let fs = s.sample_rate_hz;
        let n = self.samples_in(period_s);
        let skip = n.saturating_sub(keep);
        let b = &mut self.block.samples;
        b.sample_rate_hz = fs;
        b.clear();
        for ch in [&mut b.i_u, &mut b.i_v, &mut b.v_uw, &mut b.v_vw] {
            ch.reserve(n - skip);
        }
        let slices = torque_nm.len().clamp(1, n.max(1));
        let lag = FirstOrderLag::new(self.motor.cfg.drive.torque_lag_s);
        let mut truth = PeriodTruth::default();
        let full = 2f64.powi(s.adc_bits as i32 - 1);
        let (lsb_i, lsb_v) = (s.current_range_a / full, s.voltage_range_v / full);
        let (c3, s3) = ((2.0 * PI / 3.0).cos(), (2.0 * PI / 3.0).sin());
        // Harmonic k of a phase shifted by −2π/3: angle shift k·2π/3.
        let rot = |k: f64| ((k * 2.0 * PI / 3.0).cos(), (k * 2.0 * PI / 3.0).sin());
        let (r5, r7) = (rot(5.0), rot(7.0));
        let mut current_sq = 0.0;
        for j in 0..slices {
            let start = j * n / slices;
            let end = (j + 1) * n / slices;
            let t_cut = torque_nm.get(j).copied().unwrap_or(0.0);
            let dt = (end - start) as f64 / fs;
            self.lagged_torque_nm = lag.step(self.lagged_torque_nm, t_cut, dt);
            let disturbance = if self.motor.cfg.drive.torque_noise_nm > 0.0 {
                let z: f64 = StandardNormal.sample(&mut self.rng);
                self.motor.cfg.drive.torque_noise_nm * z
            } else {
                0.0
            };
            self.t_s += dt;
            let omega = if rpm.is_finite() {
                2.0 * PI * rpm.abs() / 60.0
            } else {
                0.0
            };
            let extra = self.effects.losses(self.t_s, self.lagged_torque_nm * omega);
            let mut op =
                self.motor
                    .operating_point_with(rpm, self.lagged_torque_nm + disturbance, extra);
            // The disturbance is drive-side: the cutting truth is the lagged cutting torque.
            op.cut_torque_nm = self.lagged_torque_nm;
            op.cut_w = self.lagged_torque_nm * 2.0 * PI * op.rpm / 60.0;
            let w = (end - start) as f64 / n.max(1) as f64;
            truth.cut_torque_nm += w * op.cut_torque_nm;
            truth.input_w += w * op.input_w;
            truth.cut_w += w * op.cut_w;
            truth.slip += w * op.slip;
            current_sq += w * op.current_a * op.current_a;
            truth.last = op;
            let av = 2f64.sqrt() * op.line_voltage_v / 3f64.sqrt();
            let ai = 2f64.sqrt() * op.current_a;
            let dtheta = 2.0 * PI * op.freq_hz / fs;
            let (sva, cva) = op.voltage_angle.sin_cos();
            let (sia, cia) = op.current_angle.sin_cos();
            for idx in start..end {
                self.theta = crate::exact::rem_tau(self.theta + dtheta);
                if idx < skip {
                    // Not kept: draw the sample's noise (same order, same draws) only.
                    for sigma in [s.current_noise_a, s.current_noise_a] {
                        if sigma > 0.0 {
                            let _: f64 = StandardNormal.sample(&mut self.rng);
                        }
                    }
                    for sigma in [s.voltage_noise_v, s.voltage_noise_v] {
                        if sigma > 0.0 {
                            let _: f64 = StandardNormal.sample(&mut self.rng);
                        }
                    }
                    continue;
                }
                let (sn, cs) = self.theta.sin_cos();
                // Voltage phase U angle θ+α_v; V, W lag/lead by 2π/3.
                let (cv, sv) = (cs * cva - sn * sva, sn * cva + cs * sva);
                let (ci, si) = (cs * cia - sn * sia, sn * cia + cs * sia);
                let v_u = cv;
                let v_v = cv * c3 + sv * s3;
                let v_w = cv * c3 - sv * s3;
                let mut vu = av * v_u;
                let mut vv = av * v_v;
                let mut vw = av * v_w;
                let mut iu = ai * ci;
                let mut iv = ai * (ci * c3 + si * s3);
                for (k, hv, hi, (ck, sk)) in [
                    (5.0, s.voltage_h5, s.current_h5, r5),
                    (7.0, s.voltage_h7, s.current_h7, r7),
                ] {
                    if hv == 0.0 && hi == 0.0 {
                        continue;
                    }
                    let x = k * (self.theta + op.voltage_angle);
                    let (sx, cx) = x.sin_cos();
                    // Phase V: cos(x − k·2π/3); W: cos(x + k·2π/3).
                    vu += hv * av * cx;
                    vv += hv * av * (cx * ck + sx * sk);
                    vw += hv * av * (cx * ck - sx * sk);
                    // Current harmonic lags its voltage by π/2 (inductive): cos(y) = sin(x).
                    iu += hi * ai * sx;
                    iv += hi * ai * (sx * ck - cx * sk);
                }
                let mut noise = |sigma: f64| -> f64 {
                    if sigma > 0.0 {
                        let z: f64 = StandardNormal.sample(&mut self.rng);
                        sigma * z
                    } else {
                        0.0
                    }
                };
                let ni = s.current_noise_a;
                let nv = s.voltage_noise_v;
                let iu_n = iu + noise(ni);
                let iv_n = iv + noise(ni);
                let vuw_n = vu - vw + noise(nv);
                let vvw_n = vv - vw + noise(nv);
                b.i_u.push(adc(iu_n, s.current_range_a, lsb_i));
                b.i_v.push(adc(iv_n, s.current_range_a, lsb_i));
                b.v_uw.push(adc(vuw_n, s.voltage_range_v, lsb_v));
                b.v_vw.push(adc(vvw_n, s.voltage_range_v, lsb_v));
            }
        }
        truth.current_a = current_sq.sqrt();
        self.block.truth = truth;
        &self.block
    }
}
