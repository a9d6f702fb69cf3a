//! Criterion benchmark of one `Controller::step` (adaptive PI, paper case I) in a closed loop
//! with the plant of eq. 6, so that the estimator and the PI both do real work.
//! Run: `cargo bench -p acc-core --bench step`.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;

use acc_core::{Controller, ControllerConfig, Measurement, OverrideLaw, PaperCase};
use criterion::{criterion_group, criterion_main, Criterion};

fn bench_step(c: &mut Criterion) {
    for (name, case) in [
        ("step/adaptive-pi case I", PaperCase::I),
        ("step/fixed-pi", PaperCase::FixedGain),
    ] {
        let Ok(mut ctl) = Controller::new(ControllerConfig::paper_case(case)) else {
            return;
        };
        let programmed = 200.0;
        let mut feed = programmed;
        let mut i: u32 = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                // Process gain stepping between 4 and 6 N/(mm/min) every 64 periods.
                i = i.wrapping_add(1);
                let kc = if (i >> 6) & 1 == 0 { 4.0 } else { 6.0 };
                let m = Measurement {
                    force_n: kc * feed,
                    feed_mm_min: feed,
                    programmed_feed_mm_min: programmed,
                    valid: true,
                };
                let out = ctl.step(black_box(&m));
                feed = out.command.feed_mm_min(programmed);
                black_box(out)
            })
        });
    }
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
