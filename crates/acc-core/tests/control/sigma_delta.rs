//! The σ-Δ (error-feedback) override quantizer: time average, grid, range, one-step bound,
//! and its place in the controller (saturation, held steps).

use acc_core::{
    Controller, ControllerConfig, FeedOverride, Measurement, OverrideLaw, OverrideSpec, PaperCase,
    Quantizer, SigmaDelta,
};
use proptest::prelude::*;

fn board() -> impl Strategy<Value = OverrideSpec> {
    prop_oneof![
        Just(OverrideSpec::paper()),
        Just(OverrideSpec::byte_board()),
        Just(OverrideSpec {
            min_pct: 20,
            max_pct: 120,
            ..OverrideSpec::paper()
        }),
    ]
    .prop_map(|s| s.with_quantizer(Quantizer::SigmaDelta))
}

proptest! {
    /// Over N periods of any commands inside the range, the mean written override is within
    /// step/N of the mean command (from a reset: Σq = Σu − e_N, |e_N| ≤ step/2).
    #[test]
    fn time_average_follows_the_mean_command(
        spec in board(),
        us in prop::collection::vec(0.0f64..=1.0, 1..400),
    ) {
        let (lo, hi) = (f64::from(spec.min_pct), f64::from(spec.max_pct));
        let us: Vec<f64> = us.iter().map(|f| lo + f * (hi - lo)).collect();
        let mut sd = SigmaDelta::new();
        let n = us.len() as f64;
        let sum_q: f64 = us.iter().map(|&u| f64::from(sd.step(&spec, u).pct())).sum();
        let sum_u: f64 = us.iter().sum();
        let step = f64::from(spec.step_pct);
        prop_assert!(
            (sum_q / n - sum_u / n).abs() <= step / n + 1e-9,
            "mean q {} vs mean u {} over {} periods", sum_q / n, sum_u / n, n
        );
    }

    /// Any input (NaN, out of range, huge): the output is a board position in range, never
    /// more than one step above (or below) the clamped continuous command, and the residue
    /// stays within half a step.
    #[test]
    fn on_the_grid_in_range_and_within_one_step(
        spec in board(),
        us in prop::collection::vec(prop_oneof![
            -50.0f64..250.0,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
        ], 1..300),
    ) {
        let mut sd = SigmaDelta::new();
        let step = f64::from(spec.step_pct);
        for u in us {
            let q = sd.step(&spec, u).pct();
            prop_assert!((spec.min_pct..=spec.max_pct).contains(&q));
            prop_assert_eq!((q - spec.min_pct) % spec.step_pct, 0);
            prop_assert!(sd.residue_pct().abs() <= step / 2.0 + 1e-9);
            if u.is_nan() {
                prop_assert_eq!(q, spec.min_pct);
            } else {
                let uc = spec.clamp_pct(u);
                prop_assert!(f64::from(q) <= uc + step + 1e-9, "q {} u {}", q, uc);
                prop_assert!(f64::from(q) >= uc - step - 1e-9, "q {} u {}", q, uc);
            }
        }
    }
}

/// A constant 64 % on a 10 % board: only 60 and 70 are written, 4 of every 10 at 70.
#[test]
fn constant_command_dithers_between_its_neighbours() {
    let spec = OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta);
    let mut sd = SigmaDelta::new();
    let out: Vec<u16> = (0..100).map(|_| sd.step(&spec, 64.0).pct()).collect();
    assert!(out.iter().all(|&q| q == 60 || q == 70));
    assert_eq!(out.iter().filter(|&&q| q == 70).count(), 40);
    // Rounding would write 60 for ever: a 4 % (≈ 6 % of force) bias.
    assert_eq!(spec.quantize(64.0), FeedOverride(60));
}

/// In the controller: the command is never more than one step above the PI's continuous
/// command, a held step (invalid sample) never raises it, and the air cut writes the limit.
#[test]
fn controller_dither_is_bounded_and_held_steps_do_not_raise() {
    let mut cfg = ControllerConfig::paper_case(PaperCase::III);
    cfg.override_spec = cfg.override_spec.with_quantizer(Quantizer::SigmaDelta);
    let mut ctl = Controller::new(cfg).expect("valid");
    ctl.engage(FeedOverride(100));
    // Plant F = Kc·feed with Kc = 5.3: 800 N needs 150.9 mm/min = 75.5 %, between positions.
    let (kc, fp) = (5.3, 200.0);
    let mut feed = 200.0;
    let mut written = Vec::new();
    let mut last = FeedOverride(100);
    for i in 0..400 {
        let valid = i % 37 != 36;
        let m = Measurement {
            force_n: kc * feed,
            feed_mm_min: feed,
            programmed_feed_mm_min: fp,
            valid,
        };
        let o = ctl.step(&m);
        if valid {
            let u = o.trace.unquantized_pct.clamp(0.0, 150.0);
            assert!(
                f64::from(o.command.pct()) <= u + 10.0 + 1e-9,
                "{i}: {:?} u {u}",
                o.command
            );
        } else {
            assert!(
                o.command <= last,
                "{i}: held step raised {last:?} → {:?}",
                o.command
            );
        }
        last = o.command;
        feed = o.command.feed_mm_min(fp);
        if i >= 100 {
            written.push(f64::from(o.command.pct()));
        }
    }
    let mean = written.iter().sum::<f64>() / written.len() as f64;
    assert!((mean - 75.47).abs() < 0.5, "mean override {mean}");
    // Air cut (no force): saturates at 150 % at once.
    let o = ctl.step(&Measurement {
        force_n: 0.0,
        feed_mm_min: feed,
        programmed_feed_mm_min: fp,
        valid: true,
    });
    let o2 = ctl.step(&Measurement {
        force_n: 0.0,
        feed_mm_min: o.command.feed_mm_min(fp),
        programmed_feed_mm_min: fp,
        valid: true,
    });
    assert_eq!(o2.command, FeedOverride(150));
}

/// `for_board`: a 10 % preset on a 1 % board keeps 10 %; a 15 % preset on a 10 % board
/// takes 10 % with the limits on the new grid; the quantizer is kept.
#[test]
fn spec_follows_the_board_step() {
    let sd = OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta);
    assert_eq!(sd.for_board(1).expect("ok"), sd);
    let fifteen = OverrideSpec {
        step_pct: 15,
        min_pct: 15,
        max_pct: 150,
        ..sd
    };
    let s = fifteen.for_board(10).expect("ok");
    assert_eq!((s.step_pct, s.min_pct, s.max_pct), (10, 20, 150));
    assert_eq!(s.quantizer, Quantizer::SigmaDelta);
    assert!(s.validate().is_ok());
    assert!(fifteen.with_hysteresis(6.0).for_board(10).is_err());
    // σ-Δ and a hysteresis do not mix.
    assert!(OverrideSpec::paper()
        .with_hysteresis(2.0)
        .with_quantizer(Quantizer::SigmaDelta)
        .validate()
        .is_err());
}
