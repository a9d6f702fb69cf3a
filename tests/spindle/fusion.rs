//! Spindle + feed-drive current fusion (seed 004) on the simulated machine with the
//! tooth-level force model: the low-passed spindle estimate carries the mean, the
//! band-passed feed-drive current the tooth-pass ripple; together they follow the true
//! force within a revolution better than the spindle signal alone.

#![allow(clippy::unwrap_used)]

use acc_core::spindle_force::block_stats;
use acc_sim::motor::{BuiltinMotor, FeedDriveCurrent, FeedDriveCurrentSpec, MotorSim};
use acc_sim::run::configs_dir;
use acc_sim::Scenario;
use acc_spindle::fusion::{Biquad, Fusion, FusionConfig};

/// Samples per 1 kHz output sample (the machine and the DAQ run at 10 kHz).
const DECIM: usize = 10;

#[test]
fn fusion_follows_the_tooth_ripple() {
    let sc = Scenario::load(configs_dir().join("scenarios/paper_case3_tooth.toml")).unwrap();
    // The operator's 100 % override: the board is never asked to drive it.
    let mut board = sc.build_board();
    let rpm = sc.machine.spindle.rpm;
    let radius = sc.tool.radius_mm();
    let torque_per_n = board.machine().force_law().torque_nm(1.0, radius);
    let omega = 2.0 * std::f64::consts::PI * rpm / 60.0;
    let mut motor = MotorSim::new(BuiltinMotor::Seed002SmallMill.config().unwrap(), 11);
    // No-load power from one second of air.
    let mut p_air = 0.0;
    for _ in 0..10 {
        let b = motor.run_period(rpm, &[0.0], 0.1);
        p_air = block_stats(&b.phase_block()).unwrap().power_w;
    }
    // Feed force taken as 0.6 × the resultant (seed 004: f_x from f_t, f_r over the flute
    // engagement; an assumption of this test, the mean-force ratio does not matter here).
    let feed = FeedDriveCurrentSpec::default();
    let feed_ratio = 0.6;
    let mut feed_drive = FeedDriveCurrent::new(feed, 12);
    let fs = 1000.0;
    let cfg = FusionConfig {
        sample_rate_hz: fs,
        lowpass_hz: 5.0,
        bandpass_hz: 40.0, // tooth passing: 600 rpm × 4 flutes
        bandpass_q: 0.3,
        feed_n_per_a: 1.0 / (feed.a_per_n * feed_ratio),
    };
    let mut fusion = Fusion::new(cfg).unwrap();
    let mut spindle_lp = Biquad::lowpass(fs, 5.0, std::f64::consts::FRAC_1_SQRT_2);
    let (mut e_raw, mut e_lp, mut e_fused, mut n) = (0.0, 0.0, 0.0, 0);
    let mut ripple = 0.0;
    for period in 0..80 {
        let rec = board.advance_period(0.1);
        assert_eq!(rec.samples.len() % DECIM, 0);
        let torques: Vec<f64> = rec.samples.iter().map(|s| s.torque_nm).collect();
        let forces: Vec<f64> = rec.samples.iter().map(|s| s.force_n).collect();
        let dt = rec.sample_dt_s;
        let cutting = rec.force_mean_n > 300.0;
        let b = &motor.run_period(rpm, &torques, 0.1).samples;
        assert_eq!(b.i_u.len(), forces.len());
        for j in 0..forces.len() / DECIM {
            let r = j * DECIM..(j + 1) * DECIM;
            let p = block_stats(&acc_core::PhaseBlock {
                sample_rate_hz: b.sample_rate_hz,
                i_u: &b.i_u[r.clone()],
                i_v: &b.i_v[r.clone()],
                v_uw: &b.v_uw[r.clone()],
                v_vw: &b.v_vw[r.clone()],
            })
            .unwrap()
            .power_w;
            let spindle = (p - p_air) / omega / torque_per_n;
            let truth = forces[r.clone()].iter().sum::<f64>() / DECIM as f64;
            let current = forces[r]
                .iter()
                .map(|f| feed_drive.step(feed_ratio * f, dt))
                .sum::<f64>()
                / DECIM as f64;
            let fused = fusion.push(spindle, current);
            let lp = spindle_lp.push(spindle);
            // Settled cutting only (the mean filters need ≈ 1 s after the entry).
            if cutting && period > 40 {
                e_raw += (spindle - truth).powi(2);
                e_lp += (lp - truth).powi(2);
                e_fused += (fused - truth).powi(2);
                ripple += (truth - rec.force_mean_n).powi(2);
                n += 1;
            }
        }
    }
    assert!(n > 1000, "{n} cutting samples");
    let rms = |e: f64| (e / n as f64).sqrt();
    println!(
        "ripple {:.1} N RMS; error: spindle raw {:.1}, spindle 5 Hz {:.1}, fused {:.1} N",
        rms(ripple),
        rms(e_raw),
        rms(e_lp),
        rms(e_fused)
    );
    // There is a tooth ripple (the spindle signal misses it: its error is the ripple), and
    // the fusion follows its fundamental; the harmonics above the feed drive's 60 Hz
    // bandwidth stay out of reach.
    assert!(rms(ripple) > 100.0);
    assert!(rms(e_raw) > 0.9 * rms(ripple));
    assert!(
        rms(e_fused) < 0.7 * rms(e_lp),
        "fused vs low-passed spindle"
    );
    assert!(rms(e_fused) < 0.7 * rms(e_raw), "fused vs raw spindle");
}
