//! Controller behaviour a real machine needs: estimator convergence
//! with the normalized gain at every feed, estimator guards and bounds, anti-windup after an
//! air cut at 150 % (with and without), bumpless start, invalid samples, frozen integrator.
#![allow(clippy::unwrap_used)]

use crate::common::{run, PROGRAMMED};
use acc_core::{
    Controller, ControllerConfig, EstimatorConfig, EstimatorGain, FeedOverride, KcEstimator,
    Measurement, ModeConfig, OverrideLaw, PaperCase, Saturation,
};
use proptest::prelude::*;

const KC: f64 = 4.0; // N/(mm/min): 800 N at 200 mm/min

/// Estimator with wide bounds; the paper's thresholds (100 N, 5 mm/min) unless `any_force`.
fn estimator_with(kc_initial: f64, gain: EstimatorGain, any_force: bool) -> KcEstimator {
    let cfg = EstimatorConfig {
        kc_initial,
        kc_min: 1e-3,
        kc_max: 1000.0,
        gain,
        min_force_n: if any_force { 0.0 } else { 100.0 },
        ..EstimatorConfig::paper()
    };
    KcEstimator::new(cfg, 1.0).unwrap()
}

fn estimator(kc_initial: f64, gain: EstimatorGain) -> KcEstimator {
    estimator_with(kc_initial, gain, false)
}

/// Periods until Kc_hat is within `rel` of `kc` at constant feed, or `None` within `limit`.
fn periods_to_converge(
    est: &mut KcEstimator,
    kc: f64,
    feed: f64,
    rel: f64,
    limit: usize,
) -> Option<usize> {
    (1..=limit).find(|_| {
        est.update(kc * feed, feed);
        (est.kc_hat() - kc).abs() <= rel * kc
    })
}

#[test]
fn normalized_estimator_converges_from_a_tenth_and_ten_times_at_every_feed() {
    let gain = EstimatorGain::Normalized { mu: 0.5 };
    let mut worst = 0;
    for feed in 10..=300 {
        let feed = f64::from(feed);
        for start in [KC / 10.0, 10.0 * KC] {
            let mut est = estimator_with(start, gain, true);
            let n = periods_to_converge(&mut est, KC, feed, 1e-6, 200)
                .unwrap_or_else(|| panic!("no convergence at {feed} mm/min from {start}"));
            worst = worst.max(n);
        }
    }
    // Contraction (1 − μ) per period whatever the feed: 0.5^k · 9 < 1e-6 ⇒ k = 24.
    assert_eq!(worst, 24);
}

proptest! {
    /// Any Kc over four decades and any feed 10 … 300 mm/min: same convergence speed.
    #[test]
    fn normalized_estimator_convergence_does_not_depend_on_feed(
        kc in 0.05f64..50.0, feed in 10.0f64..300.0, up in any::<bool>(),
    ) {
        let start = if up { 10.0 * kc } else { kc / 10.0 };
        let mut est = estimator_with(start, EstimatorGain::Normalized { mu: 0.5 }, true);
        let n = periods_to_converge(&mut est, kc, feed, 1e-6, 200);
        prop_assert!(n.is_some_and(|n| n <= 24), "{n:?}");
    }
}

#[test]
fn fixed_estimator_gain_depends_on_the_feed() {
    // g_c = 0.005: g_c·U = 0.05 at 10 mm/min (slow), 1.5 at 300 (oscillating), and > 2 at
    // 500 mm/min (diverges): the reason for the normalized option.
    let gain = EstimatorGain::Fixed { g_c: 0.005 };
    let slow = periods_to_converge(&mut estimator(KC / 10.0, gain), KC, 10.0, 1e-6, 200);
    assert!(slow.is_none(), "{slow:?}");
    let fast = periods_to_converge(&mut estimator(KC / 10.0, gain), KC, 300.0, 1e-6, 200);
    assert!(fast.is_some());
    let mut est = estimator(KC / 10.0, gain);
    for _ in 0..20 {
        est.update(KC * 500.0, 500.0);
    }
    assert!(
        est.kc_hat() >= 999.0 || est.kc_hat() <= 0.011,
        "{}",
        est.kc_hat()
    );
}

#[test]
fn estimator_does_not_move_during_air_cuts_or_below_thresholds() {
    let mut est = estimator(KC, EstimatorGain::Normalized { mu: 0.5 });
    let before = est.kc_hat();
    // Air cut at 150 %: no force.
    for _ in 0..50 {
        assert!(!est.update(0.0, 300.0));
    }
    // Force below min_force_n (100 N), feed below min_feed_mm_min (5), NaN, negative.
    assert!(!est.update(99.0, 200.0));
    assert!(!est.update(800.0, 4.0));
    assert!(!est.update(f64::NAN, 200.0));
    assert!(!est.update(800.0, f64::NAN));
    assert!(!est.update(800.0, -200.0));
    assert_eq!(est.kc_hat(), before);
    assert!(
        est.excitation() < 0.01,
        "health decays without cutting: {}",
        est.excitation()
    );
    // A real cut moves it, and the health indicator rises once predictions fit.
    for _ in 0..30 {
        assert!(est.update(6.0 * 200.0, 200.0));
    }
    assert!((est.kc_hat() - 6.0).abs() < 1e-6);
    assert!(est.excitation() > 0.8, "{}", est.excitation());
}

#[test]
fn estimator_stays_within_bounds() {
    let cfg = EstimatorConfig {
        kc_min: 1.0,
        kc_max: 10.0,
        ..EstimatorConfig::paper()
    };
    let mut est = KcEstimator::new(cfg, 1.0).unwrap();
    for _ in 0..100 {
        est.update(1.0e6, 10.0); // Kc would be 1e5
        assert!(est.kc_hat() <= 10.0);
    }
    assert_eq!(est.kc_hat(), 10.0);
    for _ in 0..100 {
        est.update(101.0, 300.0); // Kc would be 0.34
        assert!(est.kc_hat() >= 1.0);
    }
    assert_eq!(est.kc_hat(), 1.0);
}

#[test]
fn controller_estimator_holds_during_an_air_cut() {
    let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::I)).unwrap();
    // 3 s cut at Kc = 6, then 5 s air cut.
    let out = run(
        &mut ctl,
        FeedOverride(100),
        80,
        |i| if i < 30 { 6.0 } else { 0.0 },
        false,
    );
    let at_exit = out[30].0.trace.kc_hat;
    assert!((at_exit - 6.0).abs() < 1e-3, "{at_exit}");
    for (o, _) in &out[31..] {
        assert!(!o.trace.estimator_active);
        assert_eq!(o.trace.kc_hat, at_exit);
        assert_eq!(o.command, FeedOverride(150), "air cut goes to 150 %");
    }
}

/// Cut at Kc = 8 N/(mm/min) (4 mm) for 6 s, tool exit with the engagement (so Kc) falling
/// linearly to 0 over `exit` periods, 3 s of air cut, then the next cut at Kc = 8.
fn exit_then_air(confirm_periods: u16, exit: usize) -> Vec<(acc_core::StepOutput, f64)> {
    let cfg = ControllerConfig {
        estimator: EstimatorConfig {
            confirm_periods,
            ..EstimatorConfig::paper()
        },
        ..ControllerConfig::paper_case(PaperCase::I)
    };
    let mut ctl = Controller::new(cfg).unwrap();
    let (cut, air) = (60, 30);
    let kc = move |i: usize| match i {
        i if i < cut => 8.0,
        i if i < cut + exit => 8.0 * (1.0 - (i - cut) as f64 / exit as f64),
        i if i < cut + exit + air => 0.0,
        _ => 8.0,
    };
    run(
        &mut ctl,
        FeedOverride(100),
        cut + exit + air + 20,
        kc,
        false,
    )
}

#[test]
fn air_cut_after_a_tool_exit_restores_the_confirmed_estimate() {
    let (cut, air) = (60, 30);
    for exit in [15, 200] {
        let out = exit_then_air(EstimatorConfig::DEFAULT_CONFIRM_PERIODS, exit);
        // During the exit the estimate follows the partial engagement down (the gains must
        // fit the plant the controller actually has) ...
        let lowest = out[cut..cut + exit]
            .iter()
            .map(|(o, _)| o.trace.kc_hat)
            .fold(f64::MAX, f64::min);
        assert!(lowest < 3.0, "exit over {exit}: lowest Kc_hat {lowest}");
        // ... the air cut brings back the full-engagement estimate and holds it: a tool-wear
        // indicator, with eq. 14 gains of the cut just finished, not ten times higher.
        let air_out = &out[cut + exit + 1..cut + exit + air];
        let first = air_out[0].0.trace;
        assert!(
            (first.kc_hat / 8.0 - 1.0).abs() < 0.03,
            "exit over {exit}: air-cut Kc_hat {}",
            first.kc_hat
        );
        for (o, _) in air_out {
            assert_eq!(o.trace.kc_hat, first.kc_hat);
            assert_eq!(o.trace.ki, first.ki);
            assert!(!o.trace.estimator_active);
            assert_eq!(o.command, FeedOverride(150));
        }
        // The next cut enters with gains for Kc ≈ 8 and regulates to Fr.
        let tail = &out[out.len() - 5..];
        assert!(
            tail.iter().all(|(_, f)| (f - 800.0).abs() <= 80.0),
            "{:?}",
            tail.iter().map(|(_, f)| *f).collect::<Vec<_>>()
        );
    }
    // Without the rule (confirm_periods = 0) the air cut keeps the exit's last value.
    let out = exit_then_air(0, 15);
    let kept = out[cut + 15 + 1].0.trace.kc_hat;
    assert!(kept < 3.0, "rule off: air-cut Kc_hat {kept}");
}

#[test]
fn invalid_samples_do_not_restore_and_a_short_cut_keeps_the_older_confirmation() {
    let cfg = EstimatorConfig {
        kc_initial: 4.0,
        ..EstimatorConfig::paper()
    };
    let mut est = KcEstimator::new(cfg, 1.0).unwrap();
    for _ in 0..30 {
        est.update(6.0 * 200.0, 200.0);
    }
    assert!((est.kc_confirmed() - 6.0).abs() < 1e-6);
    // Partial engagement, then an invalid sample: hold, no restore.
    est.update(600.0, 200.0);
    let partial = est.kc_hat();
    assert!(partial < 5.0);
    est.hold();
    assert_eq!(est.kc_hat(), partial);
    // A cut too short to confirm (3 periods at Kc = 2), then air: back to the confirmed 6.
    for _ in 0..3 {
        est.update(2.0 * 200.0, 200.0);
    }
    assert!(!est.update(0.0, 300.0));
    assert!((est.kc_hat() - 6.0).abs() < 1e-6);
}

/// 5 s of air cut at 150 % (50 periods), then a cut whose Kc needs 60 %: 800 N at
/// 120 mm/min ⇒ Kc = 6.67 N/(mm/min). Returns (periods after entry spent above 1.1·Fr,
/// first period after entry from which the command stays at 60 %).
fn air_cut_then_cut(anti_windup: bool) -> (usize, Option<usize>) {
    let kc_cut = 800.0 / 120.0;
    let cfg = ControllerConfig {
        anti_windup,
        estimator: EstimatorConfig {
            kc_initial: kc_cut,
            ..EstimatorConfig::paper()
        },
        ..ControllerConfig::paper_case(PaperCase::III)
    };
    let mut ctl = Controller::new(cfg).unwrap();
    let entry = 50;
    let out = run(
        &mut ctl,
        FeedOverride(100),
        entry + 60,
        |i| if i < entry { 0.0 } else { kc_cut },
        false,
    );
    for (o, _) in &out[2..entry] {
        assert_eq!(o.command, FeedOverride(150));
        assert_eq!(o.trace.saturation, Saturation::High);
    }
    let after = &out[entry..];
    let over = after.iter().filter(|(_, f)| *f > 1.1 * 800.0).count();
    let settle = (0..after.len()).find(|&k| {
        after[k..]
            .iter()
            .all(|(o, _)| o.command == FeedOverride(60))
    });
    (over, settle)
}

#[test]
fn anti_windup_enters_the_cut_without_overshoot_and_windup_shows_without_it() {
    let (over_aw, settle_aw) = air_cut_then_cut(true);
    let (over_wound, settle_wound) = air_cut_then_cut(false);
    // With anti-windup only the entry period itself (fed at 150 % before the controller
    // could know) exceeds 1.1·Fr: its measurement already brings the override to 60 %
    // (case III is practically deadbeat), and it stays there.
    assert_eq!(over_aw, 1, "anti-windup overshoot periods");
    assert_eq!(settle_aw, Some(0));
    // The wound-up integrator keeps 150 % for seconds inside the cut.
    assert!(over_wound >= 20, "wound-up overshoot periods: {over_wound}");
    assert!(settle_wound.is_none_or(|s| s > 20), "{settle_wound:?}");
}

#[test]
fn bumpless_start_keeps_the_override_in_force() {
    for pct in [30u16, 80, 120] {
        let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::I)).unwrap();
        ctl.engage(FeedOverride(pct));
        // Force exactly at Fr: zero error, so the first command must equal the override.
        let feed = FeedOverride(pct).feed_mm_min(PROGRAMMED);
        let o = ctl.step(&Measurement {
            force_n: 800.0,
            feed_mm_min: feed,
            programmed_feed_mm_min: PROGRAMMED,
            valid: true,
        });
        assert_eq!(o.command, FeedOverride(pct));
        assert!((o.trace.integral_mm_min - feed).abs() < 1e-9);
    }
}

#[test]
fn invalid_samples_never_raise_the_feed_and_hold_the_state() {
    let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::I)).unwrap();
    let out = run(&mut ctl, FeedOverride(100), 30, |_| 5.0, false);
    let (last, _) = out[29];
    let integral = ctl.integral_mm_min();
    let kc_hat = ctl.kc_hat();
    for m in [
        Measurement {
            force_n: 0.0,
            feed_mm_min: 160.0,
            programmed_feed_mm_min: PROGRAMMED,
            valid: false,
        },
        Measurement {
            force_n: f64::NAN,
            feed_mm_min: 160.0,
            programmed_feed_mm_min: PROGRAMMED,
            valid: true,
        },
        Measurement {
            force_n: 10.0,
            feed_mm_min: 160.0,
            programmed_feed_mm_min: 0.0,
            valid: true,
        },
        Measurement {
            force_n: 10.0,
            feed_mm_min: 160.0,
            programmed_feed_mm_min: f64::NAN,
            valid: true,
        },
    ] {
        let o = ctl.step(&m);
        assert!(o.command <= last.command, "{m:?} raised the feed");
        assert!(!o.trace.estimator_active);
        assert_eq!(ctl.integral_mm_min(), integral);
        assert_eq!(ctl.kc_hat(), kc_hat);
    }
}

#[test]
fn frozen_controller_holds_its_integrator() {
    let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::III)).unwrap();
    ctl.engage(FeedOverride(100));
    ctl.set_frozen(true);
    let m = Measurement {
        force_n: 400.0,
        feed_mm_min: 200.0,
        programmed_feed_mm_min: PROGRAMMED,
        valid: true,
    };
    for _ in 0..10 {
        ctl.step(&m);
        assert_eq!(ctl.integral_mm_min(), 200.0);
    }
    ctl.set_frozen(false);
    ctl.step(&m);
    assert!(ctl.integral_mm_min() > 200.0);
}

#[test]
fn fixed_gain_loop_regulates_at_2mm_and_oscillates_at_3mm() {
    // Paper: Kc ≈ 4 at 2 mm (inside 0 < Kc < 5.71) regulates; Kc ≈ 6.5 at 3 mm does not.
    let mode = ModeConfig::PAPER_FIXED;
    let cfg = ControllerConfig {
        override_spec: acc_core::OverrideSpec::byte_board(),
        ..ControllerConfig::paper(mode)
    };
    let mut ctl = Controller::new(cfg).unwrap();
    let out = run(&mut ctl, FeedOverride(100), 100, |_| 3.5, true);
    let tail: Vec<f64> = out[80..].iter().map(|(_, f)| *f).collect();
    assert!(tail.iter().all(|f| (f - 800.0).abs() < 1.0), "{tail:?}");
    let mut ctl = Controller::new(cfg).unwrap();
    let out = run(&mut ctl, FeedOverride(100), 100, |_| 6.5, true);
    let swing = out[80..]
        .iter()
        .map(|(_, f)| (f - 800.0).abs())
        .fold(0.0, f64::max);
    assert!(
        swing > 200.0,
        "unstable loop should oscillate, swing {swing}"
    );
}

#[test]
fn step_output_trace_is_consistent() {
    let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::I)).unwrap();
    let out = run(&mut ctl, FeedOverride(100), 20, |_| 5.0, false);
    for (o, f) in &out {
        let t = o.trace;
        assert_eq!(t.error_n, 800.0 - f);
        assert!((t.unquantized_pct - 100.0 * t.feed_cmd_mm_min / PROGRAMMED).abs() < 1e-9);
        let gains =
            acc_core::poles::assign(acc_core::DesiredPoles::PAPER_CASE_I, 1.0, t.kc_hat, 0.1)
                .unwrap();
        assert!((t.kp - gains.kp).abs() < 1e-12 && (t.ki - gains.ki).abs() < 1e-12);
        assert_eq!(t.mode, acc_core::Mode::AdaptivePi);
    }
    assert_eq!(ctl.name(), "adaptive-pi");
}
