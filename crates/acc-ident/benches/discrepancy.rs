//! Criterion benchmark: the whole workflow on a 10-minute log at 10 Hz (6 000 rows) with
//! a hidden tool wear — `cargo bench -p acc-ident --bench discrepancy`.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;

use acc_ident::synth::{self, Case, Hidden};
use acc_ident::{workflow, EffectKind};
use criterion::{criterion_group, criterion_main, Criterion};

fn ten_minutes(c: &mut Criterion) {
    let case = Case {
        duration_s: 600.0,
        ..Case::default()
    };
    let hidden = [Hidden {
        kind: EffectKind::ToolWear,
        value: 0.004,
    }];
    let (model, log, _) = synth::generate(&case, &hidden, 1);
    let opts = workflow::Options::default();
    let mut g = c.benchmark_group("discrepancy");
    g.sample_size(10);
    g.bench_function("analyse 10 min at 10 Hz (6000 rows)", |b| {
        b.iter(|| workflow::analyse(black_box(&model), black_box(&log), &opts))
    });
    g.finish();
}

criterion_group!(benches, ten_minutes);
criterion_main!(benches);
