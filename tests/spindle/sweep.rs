//! Seed 000 on the simulated spindle motor: the ranking of the estimators over the feed
//! sweep, the efficiency-corrected power method within 2 % RMS, and no-load learning.

#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use acc_core::spindle_force::{
    block_stats, AdaptOutcome, AdaptRule, Constants, EstimatorConfig, Method, NoLoadMode,
    NoLoadModel, SpindleEstimator,
};
use acc_sim::motor::sweep::{self, SweepConfig};
use acc_sim::motor::MotorSim;
use acc_spindle::calibrate::SpindleCalibration;

fn sweep_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("configs/calibration/seed000-sweep.toml")
}

fn idx(m: Method) -> usize {
    Method::ALL
        .iter()
        .position(|x| *x == m)
        .unwrap_or(usize::MAX)
}

#[test]
fn seed000_ranking_holds_on_the_simulated_sweep() {
    let (cfg, motor) = SweepConfig::load(sweep_file()).unwrap();
    let r = sweep::run(&cfg, &motor).unwrap();
    for (m, (rms, rate)) in Method::ALL.iter().zip(r.rms_n.iter().zip(r.rate_pct)) {
        println!("{:<24} RMS {:7.2} N  rate {:6.2} %", m.name(), rms, rate);
    }
    for p in &r.points {
        println!("{:6.0} {:8.2} {:?}", p.feed_mm_min, p.true_n, p.est_n);
    }
    println!("Kt per calibration feed: {:?}", r.kt_per_feed);
    let cur = r.rate_pct[idx(Method::Current)];
    let motor_m = r.rate_pct[idx(Method::MotorCharacteristics)];
    let power = r.rate_pct[idx(Method::Power)];
    let eff = r.rate_pct[idx(Method::PowerEfficiency)];
    // Seed 000: conventional current several times worse than the other methods.
    assert!(
        cur > 3.0 * motor_m,
        "current {cur} % vs motor-char {motor_m} %"
    );
    assert!(cur > 3.0 * power, "current {cur} % vs power {power} %");
    assert!(cur > 3.0 * eff, "current {cur} % vs power-eff {eff} %");
    // Power with efficiency correction within 2 % RMS of the true force.
    assert!(eff < 2.0, "power-efficiency error rate {eff} %");
    // Without the no-load model the power method is far off (P_air ≈ 0.64 kW ≈ 100 N).
    println!("power, no-load off: {:?}", r.no_load_off);
    assert!(
        r.no_load_off.1 > 10.0 * power,
        "no-load off {:?}",
        r.no_load_off
    );
    // The committed calibration file is what this run fits
    // (`acc estimate-eval --sim-only --save-calibration configs/calibration/seed000-dnm4500.toml`).
    let committed = SpindleCalibration::load(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("configs/calibration/seed000-dnm4500.toml"),
    )
    .unwrap();
    assert_eq!(committed, r.calibration);
}

/// Learn the no-load model at 1 500 rpm from 30 air periods of the simulated motor.
fn learned(sim: &mut MotorSim) -> NoLoadModel {
    let mut nl = NoLoadModel::new(AdaptRule::default());
    for k in 0..40 {
        let b = sim.run_period(1500.0, &[0.0], 0.1);
        if k >= 10 {
            let s = block_stats(&b.phase_block()).unwrap();
            nl.learn(1500.0, s.power_w, s.current_rms_a).unwrap();
        }
    }
    nl
}

fn estimator(nl: &NoLoadModel, mode: NoLoadMode) -> SpindleEstimator {
    let cfg = EstimatorConfig {
        method: Method::Power,
        tool_radius_mm: 40.0,
        no_load: mode,
        ..EstimatorConfig::default()
    };
    SpindleEstimator::new(cfg, Constants::default(), nl.clone()).unwrap()
}

/// Air: with the learned model the estimate stays within its noise floor; with the model
/// off the no-load power shows up as a large phantom force.
#[test]
fn no_load_model_on_and_off() {
    let (_, motor) = SweepConfig::load(sweep_file()).unwrap();
    let mut sim = MotorSim::new(motor, 7);
    let nl = learned(&mut sim);
    let mut on = estimator(&nl, NoLoadMode::Fixed);
    let mut off = estimator(&nl, NoLoadMode::Off);
    let (mut above, mut sum_on, mut sum_off, mut floor) = (0, 0.0, 0.0, 0.0);
    let n = 200;
    for _ in 0..n {
        let b = sim.run_period(1500.0, &[0.0], 0.1);
        let s = block_stats(&b.phase_block()).unwrap();
        let e = on
            .estimate(1500.0, Some(s.power_w), Some(s.current_rms_a))
            .unwrap();
        above += usize::from(e.force_n.abs() > e.noise_floor_n);
        floor = e.noise_floor_n;
        sum_on += e.force_n;
        sum_off += off
            .estimate(1500.0, Some(s.power_w), Some(s.current_rms_a))
            .unwrap()
            .force_n;
    }
    let (mean_on, mean_off) = (sum_on / n as f64, sum_off / n as f64);
    println!("air: floor {floor:.2} N, mean on {mean_on:.3} N, off {mean_off:.1} N, {above} above");
    assert!(floor > 0.0 && floor < 20.0, "noise floor {floor} N");
    // 3σ floor: a handful of the 200 periods may cross it, not more.
    assert!(above <= 5, "{above} of {n} air periods above the floor");
    assert!(mean_on.abs() < floor / 3.0, "mean air force {mean_on} N");
    // Model off: P_air/(ω·r) ≈ 0.6 kW / 6.3 m/s ≈ 100 N of phantom force.
    assert!(mean_off > 10.0 * floor, "model off: {mean_off} N");
}

/// Warm-up lowers friction: the adaptive model follows in air, the fixed one keeps a bias;
/// a long cut never moves the adaptive model.
#[test]
fn no_load_adaptation_tracks_drift_but_not_cuts() {
    let (_, motor) = SweepConfig::load(sweep_file()).unwrap();
    let mut sim = MotorSim::new(motor.clone(), 3);
    let nl = learned(&mut sim);
    let mut warm = motor.clone();
    // −0.15 N·m of bearing friction: ≈ −24 W at 1 500 rpm, inside the air band.
    warm.friction.coulomb_nm -= 0.15;
    let mut sim = MotorSim::new(warm, 4);
    let mut fixed = estimator(&nl, NoLoadMode::Fixed);
    let mut adaptive = estimator(&nl, NoLoadMode::Adaptive);
    let mut adapted = 0;
    let (mut f_fixed, mut f_adapt) = (0.0, 0.0);
    for k in 0..600 {
        let b = sim.run_period(1500.0, &[0.0], 0.1);
        let s = block_stats(&b.phase_block()).unwrap();
        let a = adaptive.estimate(1500.0, Some(s.power_w), None).unwrap();
        let f = fixed.estimate(1500.0, Some(s.power_w), None).unwrap();
        adapted += usize::from(matches!(a.adapt, AdaptOutcome::Adapted(_)));
        if k >= 500 {
            f_fixed += f.force_n / 100.0;
            f_adapt += a.force_n / 100.0;
        }
    }
    println!("after warm-up: fixed {f_fixed:.2} N, adaptive {f_adapt:.2} N, {adapted} updates");
    assert!(
        f_fixed < -2.5,
        "fixed model keeps the warm-up bias: {f_fixed} N"
    );
    assert!(
        f_adapt.abs() < 0.3 * f_fixed.abs(),
        "adaptive {f_adapt} vs fixed {f_fixed}"
    );
    // A 200 N cut for 30 s: the model must not absorb it.
    let p_before = adaptive.no_load().lookup(1500.0).unwrap().power_w;
    let torque = 200.0 * 0.04;
    let mut last = 0.0;
    for _ in 0..300 {
        let b = sim.run_period(1500.0, &[torque], 0.1);
        let s = block_stats(&b.phase_block()).unwrap();
        let e = adaptive.estimate(1500.0, Some(s.power_w), None).unwrap();
        assert_eq!(e.adapt, AdaptOutcome::Loaded);
        last = e.force_n;
    }
    assert_eq!(adaptive.no_load().lookup(1500.0).unwrap().power_w, p_before);
    assert!((last - 200.0).abs() < 10.0, "cut still measured: {last} N");
}

/// A calibration recording (CSV of periods, as a DAQ program would log it next to the
/// dynamometer) gives the same constants as the in-process calibration cut.
#[test]
fn calibration_from_a_recorded_csv() {
    let (cfg, motor) = SweepConfig::load(sweep_file()).unwrap();
    let r = cfg.radius_mm() * 1e-3;
    let mut sim = MotorSim::new(motor, 21);
    let mut csv = String::from("rpm,power_w,current_a,force_ref_n,air\n");
    let mut period = |rpm: f64, force: f64, air: u8, csv: &mut String| {
        let b = sim.run_period(rpm, &[force * r], 0.1);
        let s = block_stats(&b.phase_block()).unwrap();
        csv.push_str(&format!(
            "{rpm},{},{},{force},{air}\n",
            s.power_w, s.current_rms_a
        ));
    };
    for rpm in [1100.0, 1500.0] {
        for _ in 0..20 {
            period(rpm, 0.0, 1, &mut csv);
        }
    }
    for feed in [400.0, 500.0, 600.0, 700.0] {
        let f = cfg.tangential_force_n(feed, 1100.0);
        for _ in 0..20 {
            period(1100.0, f, 0, &mut csv);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("periods.csv");
    std::fs::write(&path, &csv).unwrap();
    let rows = acc_spindle::datasets::read_calibration_periods(&path).unwrap();
    assert_eq!(rows.len(), 120);
    let air: Vec<_> = rows
        .iter()
        .filter(|x| x.air)
        .map(|x| (x.rpm, x.power_w, x.current_a))
        .collect();
    let cut: Vec<_> = rows
        .iter()
        .filter(|x| !x.air)
        .map(|x| acc_spindle::CalPoint {
            rpm: x.rpm,
            power_w: x.power_w,
            current_a: x.current_a,
            force_ref_n: x.force_ref_n,
        })
        .collect();
    let cal = acc_spindle::calibrate::calibrate_recording(
        &air,
        &cut,
        cfg.radius_mm(),
        AdaptRule::default(),
        "test",
    )
    .unwrap();
    let reference = SpindleCalibration::load(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("configs/calibration/seed000-dnm4500.toml"),
    )
    .unwrap();
    let (a, b) = (cal.constants, reference.constants);
    let close = |x: f64, y: f64, tol: f64| (x - y).abs() <= tol * y.abs();
    let (pa, pb) = (a.power_efficiency.unwrap(), b.power_efficiency.unwrap());
    assert!(close(pa.gain, pb.gain, 0.01), "{pa:?} {pb:?}");
    assert!(close(
        a.current.unwrap().kt_nm_per_a,
        b.current.unwrap().kt_nm_per_a,
        0.05
    ));
    let (ma, mb) = (
        a.motor_characteristics.unwrap(),
        b.motor_characteristics.unwrap(),
    );
    assert!(close(ma.a_a2_per_nm, mb.a_a2_per_nm, 0.05), "{ma:?} {mb:?}");
    // A bad `air` flag names the line.
    std::fs::write(&path, csv.replacen(",1\n", ",2\n", 1)).unwrap();
    let e = acc_spindle::datasets::read_calibration_periods(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("`air`"), "{e}");
}
