//! Quantizer hysteresis (`[override] hysteresis_pct`): with h = 0 it is round-to-nearest for
//! every input; with h > 0 it is a valid position within one step of round-to-nearest, it
//! does not switch while the command stays within ±h of a midpoint, and it is
//! round-to-nearest whenever the command is a step or more away from the last position. In
//! the controller a limit (saturation) is written at once, held steps never raise the
//! feed, and the integrator (anti-windup included) is the same as without hysteresis.
#![allow(clippy::unwrap_used)]

use crate::common::{run, PROGRAMMED};
use acc_core::{
    Controller, ControllerConfig, FeedOverride, Measurement, OverrideLaw, OverrideSpec, PaperCase,
    Quantizer, Saturation,
};
use proptest::prelude::*;

/// A valid spec: step from the boards in scope, limits on its grid, `h` in 0 ..= step/2
/// (`h_frac` is h as a fraction of step/2).
fn spec_strategy() -> impl Strategy<Value = (OverrideSpec, f64)> {
    (
        prop::sample::select(vec![1u16, 2, 5, 10, 25, 50]),
        0u16..=150,
        0u16..=150,
        0.0..=1.0f64,
    )
        .prop_map(|(step, a, b, h_frac)| {
            let (lo, hi) = (a.min(b), a.max(b));
            let spec = OverrideSpec {
                step_pct: step,
                min_pct: lo - lo % step,
                max_pct: hi - hi % step,
                hysteresis_pct: h_frac * f64::from(step) / 2.0,
                quantizer: Quantizer::Round,
            };
            (spec, h_frac)
        })
}

/// Any board position of `spec`, chosen by `k` (wrapped onto the grid).
fn position(spec: &OverrideSpec, k: u16) -> FeedOverride {
    FeedOverride(spec.min_pct + (k % spec.positions()) * spec.step_pct)
}

/// Inputs that include the awkward ones: NaN, infinities, far outside the range, exact
/// midpoints.
fn pct_strategy() -> impl Strategy<Value = f64> {
    prop_oneof![
        -50.0..250.0f64,
        (0u16..=30).prop_map(|k| f64::from(k) * 5.0),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(1e300),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn zero_hysteresis_is_round_to_nearest(
        (spec, _) in spec_strategy(),
        pct in pct_strategy(),
        k in any::<u16>(),
        off_grid in any::<u16>(),
    ) {
        let spec = spec.with_hysteresis(0.0);
        prop_assert!(spec.validate().is_ok());
        for prev in [position(&spec, k), FeedOverride(off_grid % 200)] {
            prop_assert_eq!(spec.quantize_hysteresis(pct, prev), spec.quantize(pct));
        }
    }

    #[test]
    fn hysteresis_output_is_a_position_within_one_step_of_nearest(
        (spec, _) in spec_strategy(),
        pct in pct_strategy(),
        k in any::<u16>(),
    ) {
        prop_assert!(spec.validate().is_ok());
        let prev = position(&spec, k);
        let q = spec.quantize_hysteresis(pct, prev).pct();
        let nearest = spec.quantize(pct).pct();
        prop_assert!((spec.min_pct..=spec.max_pct).contains(&q), "{q} outside {spec:?}");
        prop_assert_eq!((q - spec.min_pct) % spec.step_pct, 0, "{} off the grid", q);
        prop_assert!(q.abs_diff(nearest) <= spec.step_pct, "{q} vs nearest {nearest}");
        // A step or more away from the last position: plain rounding.
        let u = spec.clamp_pct(pct);
        if u.is_nan() || (u - f64::from(prev.pct())).abs() >= f64::from(spec.step_pct) {
            prop_assert_eq!(q, nearest);
        }
        // At or beyond a limit: the limit, whatever the last position.
        if pct <= f64::from(spec.min_pct) {
            prop_assert_eq!(q, spec.min_pct);
        }
        if pct >= f64::from(spec.max_pct) {
            prop_assert_eq!(q, spec.max_pct);
        }
    }

    #[test]
    fn no_switch_while_the_command_stays_within_h_of_a_midpoint(
        (spec, h_frac) in spec_strategy(),
        k in any::<u16>(),
        upper in any::<bool>(),
        amp_frac in 0.0..0.999f64,
        cycles in 1.0..20.0f64,
        phase in 0.0..std::f64::consts::TAU,
    ) {
        prop_assume!(spec.positions() >= 2 && h_frac > 1e-3);
        // Midpoint between position q and q + step, both inside the range.
        let q = position(&spec, k).pct().min(spec.max_pct - spec.step_pct);
        let mid = f64::from(q) + f64::from(spec.step_pct) / 2.0;
        let amp = amp_frac * spec.hysteresis_pct; // 2·amp < 2h peak to peak
        // Start on either neighbour (the position written when the command arrived).
        let mut prev = FeedOverride(if upper { q + spec.step_pct } else { q });
        let start = prev;
        let n = 500;
        let mut switches = 0;
        for i in 0..n {
            let t = i as f64 / n as f64;
            let u = mid + amp * (std::f64::consts::TAU * cycles * t + phase).sin();
            let next = spec.quantize_hysteresis(u, prev);
            if next != prev {
                switches += 1;
            }
            prev = next;
        }
        prop_assert_eq!(switches, 0, "start {:?}, amplitude {}", start, amp);
    }
}

#[test]
fn round_to_nearest_dithers_on_the_same_sinusoid() {
    // The comparison the property above is about: the same small wobble around 65 %
    // switches the plain quantizer every half period.
    let spec = OverrideSpec::paper();
    let hyst = spec.with_hysteresis(2.0);
    let (mut plain, mut held) = (FeedOverride(60), FeedOverride(60));
    let (mut n_plain, mut n_held) = (0, 0);
    for i in 0..200 {
        let u = 65.0 + 1.5 * (f64::from(i) * 0.3).sin();
        let (p, h) = (spec.quantize(u), hyst.quantize_hysteresis(u, held));
        n_plain += usize::from(p != plain);
        n_held += usize::from(h != held);
        (plain, held) = (p, h);
    }
    assert!(
        n_plain > 10,
        "plain quantizer switched only {n_plain} times"
    );
    assert_eq!(n_held, 0);
}

/// Deterministic pseudo-random noise in [−1, 1) (a 64-bit LCG; no dependency).
fn noise(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Closed loop on the eq. 6 plant with Kc such that Fr = 800 N needs 65 % (a midpoint of
/// the paper board) and ±`noise_n` of measurement noise; returns (switches, RMS force error).
fn dithering_loop(h: f64, noise_n: f64) -> (usize, f64) {
    let cfg = ControllerConfig {
        override_spec: OverrideSpec::paper().with_hysteresis(h),
        ..ControllerConfig::paper_case(PaperCase::III)
    };
    let mut ctl = Controller::new(cfg).unwrap();
    ctl.engage(FeedOverride(60));
    let kc = 800.0 / (0.65 * PROGRAMMED);
    let mut feed = 0.6 * PROGRAMMED;
    let mut last = FeedOverride(60);
    let (mut switches, mut sq, n) = (0, 0.0, 2000);
    let mut rng = 7u64;
    for _ in 0..n {
        let force = kc * feed;
        sq += (force - 800.0).powi(2);
        let m = Measurement {
            force_n: force + noise_n * noise(&mut rng),
            feed_mm_min: feed,
            programmed_feed_mm_min: PROGRAMMED,
            valid: true,
        };
        let o = ctl.step(&m);
        switches += usize::from(o.command != last);
        last = o.command;
        feed = o.command.feed_mm_min(PROGRAMMED);
    }
    (switches, (sq / f64::from(n)).sqrt())
}

#[test]
fn hysteresis_cuts_override_switches_in_a_dithering_loop() {
    // The deadbeat case-III loop limit-cycles between 60 % and 70 % (every period without
    // noise); the deadband makes each position last longer, the force error barely moves.
    for noise_n in [0.0, 20.0] {
        let (plain, rms_plain) = dithering_loop(0.0, noise_n);
        let (held, rms_held) = dithering_loop(4.0, noise_n);
        assert!(
            plain > 1500,
            "noise {noise_n}: plain switched only {plain} times"
        );
        assert!(
            held * 2 < plain,
            "noise {noise_n}: hysteresis 4 %: {held} switches vs {plain} without"
        );
        assert!(
            rms_held < 1.1 * rms_plain,
            "noise {noise_n}: RMS force error {rms_held} N vs {rms_plain} N"
        );
    }
}

/// The same measurements (open loop) through controllers with and without hysteresis.
fn both(h: f64, meas: &[Measurement]) -> Vec<(acc_core::StepOutput, acc_core::StepOutput)> {
    let plain = ControllerConfig::paper_case(PaperCase::FixedGain);
    let hyst = ControllerConfig {
        override_spec: plain.override_spec.with_hysteresis(h),
        ..plain
    };
    let (mut a, mut b) = (
        Controller::new(plain).unwrap(),
        Controller::new(hyst).unwrap(),
    );
    a.engage(FeedOverride(100));
    b.engage(FeedOverride(100));
    meas.iter().map(|m| (a.step(m), b.step(m))).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Any sequence of forces (cutting, overload, air cut) and invalid samples: the
    /// integrator and saturation are those of the plain controller (the anti-windup acts
    /// on the limits, which are written at once), a saturated step writes the plain
    /// command, the command is within one step of it, and an invalid sample never raises
    /// the command.
    #[test]
    fn controller_hysteresis_never_delays_a_limit(
        h in 0.5..=5.0f64,
        forces in prop::collection::vec((0.0..3000.0f64, prop::bool::weighted(0.9)), 1..120),
    ) {
        let meas: Vec<Measurement> = forces
            .iter()
            .map(|&(force_n, valid)| Measurement {
                force_n,
                feed_mm_min: PROGRAMMED,
                programmed_feed_mm_min: PROGRAMMED,
                valid,
            })
            .collect();
        let mut last = FeedOverride(100);
        for ((p, q), m) in both(h, &meas).iter().zip(&meas) {
            prop_assert_eq!(p.trace.integral_mm_min, q.trace.integral_mm_min);
            prop_assert_eq!(p.trace.saturation, q.trace.saturation);
            if q.trace.saturation != Saturation::None {
                prop_assert_eq!(q.command, p.command);
            }
            prop_assert!(q.command.pct().abs_diff(p.command.pct()) <= 10);
            if !m.valid {
                prop_assert!(q.command <= last, "invalid sample raised {:?} -> {:?}", last, q.command);
            }
            last = q.command;
        }
    }
}

#[test]
fn an_overload_lowers_to_the_minimum_in_the_same_step() {
    // Cutting at 60 %, then a hard inclusion: the demand drops below 0 % and the board
    // gets 0 % in that very step with the largest hysteresis, as without it.
    let cfg = ControllerConfig {
        override_spec: OverrideSpec::paper().with_hysteresis(5.0),
        ..ControllerConfig::paper_case(PaperCase::III)
    };
    let mut ctl = Controller::new(cfg).unwrap();
    let out = run(
        &mut ctl,
        FeedOverride(60),
        40,
        |i| if i < 30 { 800.0 / 120.0 } else { 60.0 },
        false,
    );
    let hit = &out[30].0;
    assert_eq!(hit.trace.saturation, Saturation::Low);
    assert_eq!(hit.command, FeedOverride(0));
}
