//! Simulated seconds per wall-clock second of the closed loop on the simulated machine:
//! paper case III (steps 2-3-4 mm, 60.6 s of machining) with the mean-force model
//! (1 kHz internal rate) and the tooth-level model (10 kHz, 4 flutes × 16 axial slices).
//! Criterion reports the throughput in "elements" per second, one element being one
//! simulated millisecond: 1 Kelem/s = 1 simulated second per wall second.
//! Run: `cargo bench -p acc-sim --bench sim_speed`.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;

use acc_sim::run::configs_dir;
use acc_sim::{run, ForceModel, LawKind, Scenario};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn bench_sim(c: &mut Criterion) {
    let Ok(base) = Scenario::load(configs_dir().join("scenarios/paper_case3.toml")) else {
        return;
    };
    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    for (name, model) in [
        ("mean-force", ForceModel::Mean),
        ("tooth-level", ForceModel::Tooth),
    ] {
        let sc = Scenario {
            force_model: model,
            ..base.clone()
        };
        // Simulated time of one run, in ms.
        let Ok((r, _)) = sc.run_law(LawKind::Ours) else {
            return;
        };
        let sim_ms = r.rows.last().map_or(0.0, |x| x.t_s) * 1000.0;
        group.throughput(Throughput::Elements(sim_ms.round() as u64));
        group.bench_function(name, |b| {
            b.iter(|| {
                let Ok(mut law) = sc.build_law(LawKind::Ours) else {
                    return;
                };
                black_box(run::<std::io::Sink>(black_box(&sc), law.as_mut(), None).ok());
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_sim);
criterion_main!(benches);
