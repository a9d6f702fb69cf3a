//! Throughput of the Blondel power computation (`block_stats`), in sample instants per
//! second (4 channels each). Target: > 1000 × real time for 4 channels at 50 kS/s, i.e.
//! more than 5·10⁷ sample instants per second.
#![allow(missing_docs)]

use acc_core::spindle_force::power::{block_stats, PhaseSamples};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn bench_power(c: &mut Criterion) {
    // One 0.1 s period at 50 kS/s.
    let n = 5000;
    let fs = 50_000.0;
    // 40 A at 280 V, PF cos(0.9).
    let w = PhaseSamples::balanced(n, fs, 280.0, 40.0, 0.9);
    let block = w.block();
    let mut g = c.benchmark_group("blondel_power");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("block_stats_5000x4", |b| {
        b.iter(|| block_stats(black_box(&block)))
    });
    g.finish();
}

criterion_group!(benches, bench_power);
criterion_main!(benches);
