//! Issue 13, item 1: the replay is the simulator. Null logs from `acc sim`'s production
//! loop (random shipped workpiece, force model, measurement channel and seed) replay to
//! within the measurement noise on both channels.

use acc_ident::model::Channel;
use acc_ident::twin;
use acc_sim::scenario::MeasurementSpec;
use acc_sim::{ForceModel, Scenario, Workpiece};
use proptest::prelude::*;

fn base() -> Scenario {
    let dir = acc_sim::run::configs_dir();
    Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario")
}

const WORKPIECES: [&str; 5] = [
    "steps_1_2_3.toml",
    "steps_2_3_4.toml",
    "ramp_2_4.toml",
    "interrupted.toml",
    "hard_inclusion.toml",
];

/// Robust noise σ of a residual: MAD of first differences / (0.6745·√2).
fn sigma(r: &[f64]) -> f64 {
    let mut d: Vec<f64> = r.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] / 0.6745 / 2f64.sqrt()
}

/// The estimated force per watt of the board's power register, N: the largest force step
/// between consecutive logged rows whose power differs by exactly one watt at one speed.
fn board_step_n(log: &acc_ident::runlog::RunLog) -> f64 {
    let (Some(f), Some(p)) = (&log.force_n, &log.power_w) else {
        return 0.0;
    };
    (1..f.len())
        .filter(|&i| {
            (p[i] - p[i - 1]).abs() == 1.0
                && log.spindle_rpm[i] == log.spindle_rpm[i - 1]
                && f[i] != 0.0
                && f[i - 1] != 0.0
        })
        .map(|i| (f[i] - f[i - 1]).abs())
        .fold(0.0, f64::max)
}

fn check(wp: usize, tooth: bool, dyn_channel: bool, seed: u64) {
    check_with(wp, tooth, dyn_channel, seed, |_| {});
}

/// `effects` puts spindle effects into the simulated machine; the model is built from the
/// same scenario, so the replay must carry them exactly as the simulator does.
fn check_with(wp: usize, tooth: bool, dyn_channel: bool, seed: u64, effects: fn(&mut Scenario)) {
    let dir = acc_sim::run::configs_dir();
    let mut sc = base();
    effects(&mut sc);
    sc.workpiece = Workpiece::load(dir.join("workpieces").join(WORKPIECES[wp])).expect("wp");
    sc.seed = seed;
    sc.max_time_s = 40.0;
    if tooth {
        sc.force_model = ForceModel::Tooth;
    }
    if dyn_channel {
        sc.measurement = MeasurementSpec::Dynamometer {
            noise_n: 5.0,
            lowpass_hz: 0.0,
            window_s: 0.05,
        };
    }
    let log = twin::simulate(&sc).expect("simulated");
    for ch in [Channel::Force, Channel::Power] {
        let m = twin::model_for_scenario(&sc, ch);
        let r = twin::replay_residual(&m, &log, Some((&sc.workpiece, 0.0))).expect("replay");
        let n = r.len() as f64;
        let rms = (r.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        let mean = r.iter().sum::<f64>() / n;
        // The floor: the board's whole watts (1/√12 W) or a noise-free channel. Rows the
        // spindle-power estimator reports as exactly 0 (air, dead band) are replayed as 0
        // and carry no noise: σ is that of the other rows.
        let live: Vec<f64> = r.iter().copied().filter(|x| *x != 0.0).collect();
        let mut s = sigma(if live.len() > 20 { &live } else { &r }).max(0.5);
        if ch == Channel::Force && !dyn_channel {
            // The estimator reads the board's whole watts: one watt is `board_step_n(&log)`
            // newtons (2 N at 600 rpm), a rounding the first differences of a quantized
            // signal mostly do not see (they are exactly 0), added in quadrature.
            s = s.hypot(board_step_n(&log) / 12f64.sqrt());
        }
        let tag = format!(
            "{} tooth={tooth} dyn={dyn_channel} seed {seed} {ch:?}",
            WORKPIECES[wp]
        );
        // The spindle-power channel's force is the power estimator's output, replayed
        // through the estimator (acc_ident::model::ForceEstimator): RMS ≈ 1.2 N against
        // 3.3 N before; the dead band's edge rows add to it (bound 2σ instead of 1.6σ).
        let k = if ch == Channel::Force && !dyn_channel {
            2.0
        } else {
            1.6
        };
        assert!(rms <= k * s, "{tag}: replay RMS {rms:.2} vs noise σ {s:.2}");
        // The estimated force with the tooth model carries a bias of ≈ 0.7 N (≈ 0.1 % of
        // the cutting force: the dead band's edge rows, the ripple's mean square).
        let b = if ch == Channel::Force && !dyn_channel {
            1.0
        } else {
            0.3
        };
        assert!(
            mean.abs() <= 0.5 * s + b,
            "{tag}: bias {mean:.2} vs σ {s:.2}"
        );
    }
}

proptest! {
    // A fixed seed: the cases are random but the same on every run (CI never flakes on a
    // lucky draw; change the seed to explore).
    #![proptest_config(ProptestConfig {
        cases: 6,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_124),
        ..ProptestConfig::default()
    })]
    #[test]
    fn null_logs_from_acc_sim_replay_within_the_noise(
        wp in 0usize..5, tooth in any::<bool>(), dyn_channel in any::<bool>(), seed in 1u64..10_000
    ) {
        check(wp, tooth, dyn_channel, seed);
    }
}

#[test]
fn both_force_models_on_both_channels() {
    for (tooth, dyn_channel) in [(false, false), (true, false), (false, true), (true, true)] {
        check(3, tooth, dyn_channel, 17);
    }
}

/// The spindle's own effects replay as the simulator produces them: a no-load drift is
/// bearing friction (T_d = P_drift/ω) through the motor's loss curve, not a flat offset,
/// and the copper loss is the mean of c·P_c² over the tooth ripple, not c·⟨P_c⟩². Before
/// (flat offset, squared mean) the spindle-power force replayed with RMS 8.7 N against a
/// noise σ of 0.9 N on steps_2_3_4 (seed 23); now 1.1 N.
#[test]
fn spindle_drift_and_copper_loss_replay_as_the_simulator_makes_them() {
    fn effects(sc: &mut Scenario) {
        sc.machine.spindle.noload_drift = Some(acc_sim::config::NoloadDrift {
            delta_w: 120.0,
            tau_s: 20.0,
        });
        sc.machine.spindle.motor_efficiency = Some(acc_sim::config::MotorEfficiency {
            copper_loss_per_kw: 0.3,
        });
    }
    for wp in [1, 3] {
        for tooth in [false, true] {
            check_with(wp, tooth, false, 23, effects);
        }
    }
}

/// A slow override path (dead time 0.136 s, longer than a control period) replays as the
/// simulator runs it: the model with the true delay leaves noise (0.67 W against σ 0.50 W
/// on ramp_2_4, seed 1014). The fit of that delay is checked below.
#[test]
fn a_dead_time_longer_than_a_period_replays_as_the_simulator_makes_it() {
    fn effects(sc: &mut Scenario) {
        sc.machine.override_path.delay_s += 0.12;
    }
    for wp in [2, 4] {
        check_with(wp, false, false, 1014, effects);
    }
}

/// The fit finds that delay to the plant's 1 ms step and leaves noise. The sum of squares
/// is piecewise constant in the dead time (the simulator delays in whole 1 ms steps), so
/// LM alone stopped near where the 50 ms grid left it: here 4.6 ms off with a residual RMS
/// of 6.1 W (now 0.4 ms, 0.59 W against σ 0.45 W); in the workflow's evaluation such a
/// residual was then given to `motor_efficiency` as well.
#[test]
fn the_fit_finds_a_long_dead_time_to_the_plant_step() {
    use acc_ident::fit::{self, Free};
    use acc_ident::replay::{replay, Inputs};
    use acc_ident::EffectKind;
    let dir = acc_sim::run::configs_dir();
    let mut sc = base();
    sc.workpiece = Workpiece::load(dir.join("workpieces/ramp_2_4.toml")).expect("wp");
    sc.seed = 1014;
    sc.max_time_s = 40.0;
    let model = twin::model_for_scenario(&sc, Channel::Power);
    let truth = 0.12;
    sc.machine.override_path.delay_s += truth;
    let log = twin::simulate(&sc).expect("simulated");
    let mut inp = Inputs::from_log(&log, &model).expect("inputs");
    inp.use_workpiece(sc.workpiece.clone(), 0.0);
    let rows: Vec<usize> = (0..inp.len()).collect();
    let dead = Free::Effect(EffectKind::OverrideDeadTime, 0);
    let free = [Free::KsScale, Free::Noload, dead];
    let f = fit::fit(&model, &free, &[dead], &inp, &rows);
    let fitted = f.theta[2];
    let r = replay(&f.model, &inp);
    let res: Vec<f64> = rows
        .iter()
        .map(|&i| inp.measured[i] - r.predicted[i])
        .collect();
    let rms = (res.iter().map(|x| x * x).sum::<f64>() / res.len() as f64).sqrt();
    let s = sigma(&res);
    println!("dead time fitted {fitted:.4} s (true {truth}), residual RMS {rms:.3} W, σ {s:.3} W");
    assert!(
        (fitted - truth).abs() <= 0.0015,
        "fitted {fitted} s, true {truth} s"
    );
    assert!(rms < 1.5 * s, "residual RMS {rms} W against σ {s} W");
}
