//! `Controller::step` does not allocate: a counting global allocator (this test binary
//! only) sees zero allocations on the thread while it steps through cutting, air cut,
//! invalid samples and saturation.
#![allow(clippy::unwrap_used)]

use acc_core::{Controller, ControllerConfig, FeedOverride, Measurement, OverrideLaw, PaperCase};

use crate::counting_alloc::allocations;

#[test]
fn step_does_not_allocate() {
    // The counter sees allocations on this thread (so a zero below means something).
    let probe = allocations();
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > probe && v.len() == 16);
    // (case, quantizer hysteresis in percent, σ-Δ quantizer)
    for (case, h, sd) in [
        (PaperCase::FixedGain, 0.0, false),
        (PaperCase::I, 0.0, false),
        (PaperCase::III, 0.0, false),
        (PaperCase::III, 4.0, false),
        (PaperCase::III, 0.0, true),
    ] {
        let cfg = ControllerConfig::paper_case(case);
        let q = if sd {
            acc_core::Quantizer::SigmaDelta
        } else {
            acc_core::Quantizer::Round
        };
        let cfg = ControllerConfig {
            override_spec: cfg.override_spec.with_hysteresis(h).with_quantizer(q),
            ..cfg
        };
        let mut ctl = Controller::new(cfg).unwrap();
        ctl.engage(FeedOverride(100));
        let before = allocations();
        let mut feed = 200.0;
        let mut sum = 0u32;
        for i in 0..1000 {
            let kc = match i % 300 {
                0..=49 => 0.0, // air cut
                50..=199 => 4.0,
                _ => 6.0,
            };
            let m = Measurement {
                force_n: if i % 97 == 0 { f64::NAN } else { kc * feed },
                feed_mm_min: feed,
                programmed_feed_mm_min: 200.0,
                valid: i % 89 != 0,
            };
            let o = ctl.step(&m);
            feed = o.command.feed_mm_min(200.0);
            sum += u32::from(o.command.pct());
        }
        let after = allocations();
        assert!(sum > 0);
        assert_eq!(
            after - before,
            0,
            "{case:?}, h = {h}, σ-Δ {sd}: Controller::step allocated"
        );
    }
}
