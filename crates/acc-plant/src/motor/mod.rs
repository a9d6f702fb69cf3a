//! Induction spindle motor: what a DAQ on the spindle cables samples.
//!
//! The spindle drive holds the commanded speed (speed loop, slip compensation): the
//! electrical frequency is `f_e = p·n/60 / (1 − s)` with `p` pole pairs and slip `s`. Per
//! phase, the steady-state equivalent circuit (seed 000 §2.2, Fig. 3; the textbook
//! T-circuit):
//!
//! ```text
//!   V ──R_s──jX_s──┬──────────┬──────────┐
//!                  │          │          │
//!                R_fe       jX_m     R_r/s + jX_r
//!                  │          │          │
//!   N ─────────────┴──────────┴──────────┘        E = air-gap EMF
//! ```
//!
//! * The drive holds the flux: `E ∝ f_e` up to base speed, `E` constant above it (field
//!   weakening). Reactances scale with `f_e`; `R_fe` with `f_e^(2−k)` so the iron loss
//!   `3E²/R_fe` grows as `f_e^k` (`iron_loss_exponent`, default 1.5).
//! * Air-gap power `P_ag = 3·|I_r|²·R_r/s`, electromagnetic torque
//!   `T_em = P_ag / ω_sync` with `ω_sync = 2π·f_e/p`; the slip is solved so that `T_em` equals
//!   the load: cutting torque plus friction and windage (`T_f = T_0 + B·n + windage`). In
//!   the stable region torque ∝ slip (seed 000 eq. 7).
//! * Losses: stator copper `3|I_s|²R_s` (∝ I²), iron `3E²/R_fe`, rotor copper `s·P_ag`,
//!   friction and windage. So the power factor, slip and efficiency change with load as on
//!   a real motor (seed 000 Figs. 2, 4): at light load the no-load losses dominate and the
//!   efficiency is low.
//!
//! The load torque reaches the motor through a first-order lag `torque_lag_s` (the drive's
//! speed loop and the rotor inertia; seed 004 reports ≈ 5 Hz for spindle current), plus a white
//! drive-side torque disturbance `torque_noise_nm` (not part of the cutting truth). The sampled
//! signals are the phase currents `i_U`, `i_V` and the line voltages `v_UW`, `v_VW` (as in
//! seed 000's test bed), with 5th/7th harmonics, seeded Gaussian noise (ChaCha8) and ADC
//! quantisation. Deterministic for a seed.
//!
//! | module | what |
//! | --- | --- |
//! | `config` | motor files: [`MotorConfig`] and its tables, [`BuiltinMotor`] |
//! | `circuit` | the equivalent circuit: [`Motor`], [`OperatingPoint`], [`MotorEffects`] |
//! | `signals` | the sampled motor: [`MotorSim`], [`MotorBlock`], [`PeriodTruth`] |
//! | `channel` | [`FeedDriveCurrent`], [`SpindlePowerChannel`] |
//! | [`sweep`] | the seed 000 experiment on the simulated motor |

mod channel;
mod circuit;
mod config;
mod signals;
pub mod sweep;

pub use channel::*;
pub use circuit::*;
pub use config::*;
pub use signals::*;

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::config::SensorLowpass;

    fn seed000() -> MotorConfig {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../configs/motors/seed000-dnm4500.toml"
        );
        MotorConfig::load(path).unwrap()
    }

    #[test]
    fn power_balance_and_load_dependence() {
        let m = Motor::new(seed000());
        let mut prev: Option<OperatingPoint> = None;
        for t in [0.0, 5.0, 20.0, 60.0, 118.0] {
            let op = m.operating_point(1500.0, t);
            let losses =
                op.stator_copper_w + op.iron_w + op.rotor_copper_w + op.friction_w + op.cut_w;
            assert!(
                (op.input_w - losses).abs() < 1e-6 * op.input_w,
                "{t}: {op:?}"
            );
            assert!(!op.overloaded);
            if let Some(p) = prev {
                assert!(op.slip > p.slip && op.current_a > p.current_a);
                assert!(op.power_factor > p.power_factor, "PF rises with load");
            }
            prev = Some(op);
        }
        // Efficiency low at light load (iron loss dominates), high near rated.
        let light = m.operating_point(1500.0, 2.0).efficiency;
        let rated = m.operating_point(1500.0, 100.0).efficiency;
        assert!(light < 0.6 && rated > 0.85, "{light} {rated}");
        // Torque ∝ slip in the stable region: doubling the load doubles the slip ± 10 %.
        let s1 = m.operating_point(1500.0, 30.0).slip;
        let s2 = m.operating_point(1500.0, 60.0).slip;
        assert!((s2 / s1 - 2.0).abs() < 0.2, "{s1} {s2}");
    }

    /// The extra losses keep the power balance: the drift is friction (shaft), the load
    /// loss is stator copper at the same currents (input rises by exactly it; slip and
    /// current unchanged, voltage and power factor up).
    #[test]
    fn extra_losses_keep_the_power_balance() {
        let m = Motor::new(seed000());
        for (t, drift_w, load_loss_w) in
            [(0.0, 150.0, 0.0), (40.0, 150.0, 300.0), (40.0, -80.0, 0.0)]
        {
            let base = m.operating_point(1500.0, t);
            let op = m.operating_point_with(
                1500.0,
                t,
                ExtraLosses {
                    drift_w,
                    load_loss_w,
                },
            );
            let out = op.stator_copper_w
                + op.iron_w
                + op.rotor_copper_w
                + op.friction_w
                + op.cut_w
                + op.load_loss_w;
            assert!((op.input_w - out).abs() < 1e-6 * op.input_w, "{op:?}");
            assert!((op.drift_w - drift_w).abs() < 1e-9);
            assert!((op.friction_w - base.friction_w - drift_w).abs() < 1e-9);
            // The drift rises the input by itself plus the extra copper loss of its current.
            let rise = op.input_w - base.input_w - load_loss_w;
            assert!(
                rise / drift_w > 0.99 && rise / drift_w < 1.1,
                "{rise} for {drift_w}"
            );
            if load_loss_w > 0.0 {
                let no_ll = m.operating_point_with(
                    1500.0,
                    t,
                    ExtraLosses {
                        drift_w,
                        load_loss_w: 0.0,
                    },
                );
                assert!((op.input_w - no_ll.input_w - load_loss_w).abs() < 1e-9);
                assert_eq!(op.slip, no_ll.slip);
                assert_eq!(op.current_a, no_ll.current_a);
                assert!(op.line_voltage_v > no_ll.line_voltage_v);
                assert!(op.power_factor > no_ll.power_factor);
            }
        }
        // At rest there is no drift torque.
        let rest = m.operating_point_with(
            0.0,
            0.0,
            ExtraLosses {
                drift_w: 100.0,
                load_loss_w: 0.0,
            },
        );
        assert_eq!(rest, m.operating_point(0.0, 0.0));
    }

    #[test]
    fn tail_period_is_the_tail_of_the_full_period_bit_for_bit() {
        let mut full = MotorSim::new(seed000(), 3);
        let mut tail = MotorSim::new(seed000(), 3);
        let torques: Vec<f64> = (0..100).map(|k| 20.0 + 0.3 * f64::from(k)).collect();
        for (period, keep) in [(0, 500), (1, 1), (2, 0), (3, 1000), (4, 5000), (5, 499)] {
            let rpm = 1500.0 + f64::from(period);
            let a = full.run_period(rpm, &torques, 0.1).clone();
            let b = tail.run_period_tail(rpm, &torques, 0.1, keep);
            let n = a.samples.len();
            assert_eq!(n, 1000);
            let k = keep.min(n);
            for (x, y) in [
                (&a.samples.i_u, &b.samples.i_u),
                (&a.samples.i_v, &b.samples.i_v),
                (&a.samples.v_uw, &b.samples.v_uw),
                (&a.samples.v_vw, &b.samples.v_vw),
            ] {
                let x: Vec<u64> = x[n - k..].iter().map(|v| v.to_bits()).collect();
                let y: Vec<u64> = y.iter().map(|v| v.to_bits()).collect();
                assert_eq!(x, y, "period {period}, keep {keep}");
            }
            assert_eq!(a.truth, b.truth);
        }
    }

    #[test]
    fn sampled_power_matches_the_operating_point() {
        let mut sim = MotorSim::new(seed000(), 1);
        sim.run_period(1500.0, &[40.0], 1.0);
        let b = sim.run_period(1500.0, &[40.0], 0.1);
        let s = &b.samples;
        assert_eq!(s.i_u.len(), 1000);
        let p: f64 = (0..1000)
            .map(|k| s.i_u[k] * s.v_uw[k] + s.i_v[k] * s.v_vw[k])
            .sum::<f64>()
            / 1000.0;
        let t = b.truth;
        assert!(
            (p - t.input_w).abs() < 0.01 * t.input_w,
            "{p} vs {}",
            t.input_w
        );
        let again = MotorSim::new(seed000(), 1)
            .run_period(1500.0, &[40.0], 1.0)
            .samples
            .i_u[5];
        let mut s2 = MotorSim::new(seed000(), 1);
        assert_eq!(s2.run_period(1500.0, &[40.0], 1.0).samples.i_u[5], again);
    }

    #[test]
    fn bad_motor_file_names_the_key() {
        let dir = std::env::temp_dir().join(format!("acc-motor-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.toml");
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../configs/motors/seed000-dnm4500.toml"
        ))
        .unwrap()
        .replace("r_r_ohm = ", "r_r_ohm = -");
        std::fs::write(&path, text).unwrap();
        let e = MotorConfig::load(&path).unwrap_err().to_string();
        assert!(e.contains("circuit.r_r_ohm") && e.contains("m.toml"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Records what the channel hands a force source: the block's two-wattmeter power and
    /// RMS current, and the board's power value.
    #[derive(Default)]
    struct Recorder(Vec<(f64, f64, Option<f64>)>);

    impl acc_core::ForceSource for Recorder {
        fn name(&self) -> &str {
            "recorder"
        }

        fn estimate(&mut self, input: &acc_core::PeriodInput<'_>) -> acc_core::ForceSample {
            let s = acc_core::spindle_force::block_stats(&input.phases.unwrap()).unwrap();
            self.0.push((s.power_w, s.current_rms_a, input.power_w));
            acc_core::ForceSample::INVALID
        }
    }

    /// The sensor low-pass reaches the source both ways: the block's two-wattmeter power
    /// and the board value are the filtered power (`SensorLowpass::step` of the unfiltered
    /// channel's power), the block's currents are those of the unfiltered channel.
    #[test]
    fn sensor_lowpass_rescales_the_block_power_and_keeps_the_currents() {
        use crate::channel::MeasurementChannel;
        let lp = SensorLowpass { tau_s: 0.3 };
        let run = |lowpass: Option<SensorLowpass>| {
            let mut ch =
                SpindlePowerChannel::new(MotorSim::new(seed000(), 3), Recorder::default(), 0.05)
                    .with_sensor_lowpass(lowpass);
            for k in 0..12 {
                let torque = if k < 4 { 0.0 } else { 40.0 };
                let samples = [crate::machine::Sample {
                    torque_nm: torque,
                    ..Default::default()
                }];
                let rec = crate::machine::PeriodRecord {
                    t_end_s: 0.1 * f64::from(k + 1),
                    period_s: 0.1,
                    x_mm: 0.0,
                    radial_depth_mm: 0.0,
                    axial_depth_mm: 0.0,
                    spindle_rpm: 1500.0,
                    feed_mean_mm_min: 0.0,
                    force_mean_n: 0.0,
                    torque_mean_nm: torque,
                    power_mean_w: 0.0,
                    wear_factor: 1.0,
                    samples: &samples,
                    sample_dt_s: 0.1,
                    path_point: None,
                };
                ch.measure(&rec);
            }
            ch.source.0
        };
        let raw = run(None);
        let filt = run(Some(lp));
        let mut state = None;
        for (k, (a, b)) in raw.iter().zip(&filt).enumerate() {
            let want = lp.step(&mut state, a.0, 0.1);
            assert!(
                (b.0 - want).abs() < 1e-9 * want,
                "period {k}: {} vs {want}",
                b.0
            );
            assert_eq!(b.2, Some(want.round()));
            assert_eq!(b.1, a.1, "period {k}: current");
        }
        // The step is there and the filter lags it.
        assert!(raw[11].0 > raw[3].0 + 1000.0);
        assert!(filt[4].0 < raw[3].0 + 0.5 * (raw[4].0 - raw[3].0));
    }
}
