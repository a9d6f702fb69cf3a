//! Simulated time per wall-clock second of `acc sim` as it runs: the production
//! `ControlLoop` + `FaultPolicy` on the simulated board (`acc_sim::run` against `SimBoard`,
//! stepped clock), with the scenario's own measurement channel in its `RunSetup`, on
//! paper case III (steps 2-3-4 mm, 60.7 s simulated):
//!
//! * `paper_case3/spindle-power` — `configs/scenarios/paper_case3.toml` as shipped: force
//!   from the spindle power of the induction-motor model (10 kS/s three-phase signals,
//!   two-wattmeter power, power-based estimator), mean-force model at 1 kHz;
//! * `paper_case3_dynamometer/mean-force` — `paper_case3_dynamometer.toml`: the mean-force
//!   model (1 kHz) read by the dynamometer channel;
//! * `paper_case3_tooth/tooth-level` — `paper_case3_tooth.toml`: the tooth-level model
//!   (10 kHz, 4 flutes × 16 axial slices), dynamometer channel.
//!
//! Each iteration is one whole run of the loop (no log file) with a freshly built law and
//! channel; building the channel — for the spindle-power channel, the start-up calibration
//! cut (a one-off commissioning step, ≈ 1/5 of the loop's cost) — is set-up, not timed.
//! Criterion reports the throughput in "elements" per second, one element being one
//! simulated millisecond: 10 Kelem/s = 10 simulated seconds per wall second = 10× real time,
//! 10 Melem/s = 10 000× real time.
//! Run: `cargo bench -p acc-sim --bench sim_speed`.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;

use acc_sim::run::{configs_dir, run, RunSetup};
use acc_sim::{LawKind, Scenario};
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};

fn bench_sim(c: &mut Criterion) {
    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    for (file, name) in [
        ("paper_case3", "spindle-power"),
        ("paper_case3_dynamometer", "mean-force"),
        ("paper_case3_tooth", "tooth-level"),
    ] {
        let path = configs_dir().join(format!("scenarios/{file}.toml"));
        let Ok(sc) = Scenario::load(path) else {
            continue;
        };
        // Simulated time of one run, in ms.
        let Ok((r, _)) = sc.run_law(LawKind::Ours) else {
            continue;
        };
        let sim_ms = r.rows.last().map_or(0.0, |x| x.t_s) * 1000.0;
        group.throughput(Throughput::Elements(sim_ms.round() as u64));
        group.bench_function(format!("{file}/{name}"), |b| {
            b.iter_batched(
                || {
                    let law = sc.build_law(LawKind::Ours).ok();
                    let channel = sc.build_channel().ok();
                    law.zip(channel)
                },
                |parts| {
                    let Some((mut law, mut channel)) = parts else {
                        return;
                    };
                    black_box(
                        run(
                            black_box(&sc),
                            law.as_mut(),
                            RunSetup {
                                channel: Some(channel.as_mut()),
                                ..RunSetup::default()
                            },
                        )
                        .ok(),
                    );
                },
                BatchSize::PerIteration,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench_sim);
criterion_main!(benches);
