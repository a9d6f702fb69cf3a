//! The per-block path does not allocate: block statistics, the estimator with the adaptive
//! no-load model, and the three-phase force source, through cutting, air (adapting),
//! garbage blocks and speed transients. A counting global allocator (this test binary
//! only) sees zero allocations on the thread.
#![allow(clippy::unwrap_used)]

use acc_core::spindle_force::{
    Constants, EstimatorConfig, Method, NoLoadMode, NoLoadModel, PhaseSamples, PowerEfficiency,
    SpindleEstimator, SpindleInput, SpindleSource,
};
use acc_core::{ForceSource, PeriodInput};

use crate::counting_alloc::allocations;

#[test]
fn per_block_path_does_not_allocate() {
    let probe = allocations();
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > probe && v.len() == 16);

    let mut nl = NoLoadModel::new(Default::default());
    nl.learn(1500.0, 600.0, 10.0).unwrap();
    nl.learn(1500.0, 604.0, 10.0).unwrap();
    let c = Constants {
        power_efficiency: Some(PowerEfficiency {
            gain: 1.0,
            loss_w_per_nm2: 0.1,
        }),
        ..Constants::default()
    };
    let cfg = EstimatorConfig {
        method: Method::PowerEfficiency,
        no_load: NoLoadMode::Adaptive,
        ..EstimatorConfig::default()
    };
    let mut src = SpindleSource::new(
        SpindleInput::Phases,
        SpindleEstimator::new(cfg, c, nl).unwrap(),
    )
    .unwrap();
    let air = PhaseSamples::with_power(1000, 1e4, 601.0);
    let cut = PhaseSamples::with_power(1000, 1e4, 2600.0);
    let mut bad = cut.clone();
    bad.i_v[500] = f64::NAN;
    let before = allocations();
    let mut valid = 0;
    for i in 0..1000 {
        let ch = match i % 100 {
            0..=39 => &air,
            40..=89 => &cut,
            _ => &bad,
        };
        let rpm = if i % 250 == 0 { 1000.0 } else { 1500.0 };
        let input = PeriodInput {
            period_s: 0.1,
            spindle_rpm: rpm,
            phases: Some(ch.block()),
            ..PeriodInput::default()
        };
        valid += usize::from(src.estimate(&input).valid);
    }
    let after = allocations();
    assert_eq!(after - before, 0, "allocations on the per-block path");
    // The run exercised valid, invalid and adapting periods.
    assert!(valid > 700 && valid < 950, "{valid} valid");
    assert!(src.estimator().no_load().adaptations() > 0);
}
