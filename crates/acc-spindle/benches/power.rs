//! Throughput of the Blondel power computation (`block_stats`), in sample instants per
//! second (4 channels each). Target: > 1000 × real time for 4 channels at 50 kS/s, i.e.
//! more than 5·10⁷ sample instants per second.

use acc_core::PhaseBlock;
use acc_spindle::power::block_stats;
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn bench_power(c: &mut Criterion) {
    // One 0.1 s period at 50 kS/s.
    let n = 5000;
    let fs = 50_000.0;
    let third = 2.0 * std::f64::consts::PI / 3.0;
    let mut ch = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for k in 0..n {
        let th = 2.0 * std::f64::consts::PI * 50.0 * k as f64 / fs;
        ch[0][k] = 40.0 * (th - 0.4).cos();
        ch[1][k] = 40.0 * (th - third - 0.4).cos();
        ch[2][k] = 280.0 * (th + 0.5).cos();
        ch[3][k] = 280.0 * (th - third + 0.5).cos();
    }
    let block = PhaseBlock {
        sample_rate_hz: fs,
        i_u: &ch[0],
        i_v: &ch[1],
        v_uw: &ch[2],
        v_vw: &ch[3],
    };
    let mut g = c.benchmark_group("blondel_power");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("block_stats_5000x4", |b| {
        b.iter(|| block_stats(black_box(&block)))
    });
    g.finish();
}

criterion_group!(benches, bench_power);
criterion_main!(benches);
