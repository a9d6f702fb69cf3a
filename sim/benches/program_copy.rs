//! The cost of one copy of the simulated machine running an NC program
//! (`Machine::try_clone` with a `ProgramPath` as its engagement source): the oracle of a
//! program (`acc sim --program … --oracle`, docs/programs.md) copies the plant for every
//! grid override it tries, about ten times per control period.
//!
//! * `program_copy/pocket_rect` — `tests/nc/pocket_rect.ngc` on the box stock
//!   `-20,-20,-10,60,50,0` (0.25 mm cells: 320 × 280), the paper's machine and tool
//!   (`paper_case3`).
//!
//! Run: `cargo bench -p acc-sim --bench program_copy` (release), or
//! `cargo bench --profile dev -p acc-sim --bench program_copy` on the dev profile.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;

use acc_sim::engagement::ToolGeometry;
use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
use acc_sim::run::configs_dir;
use acc_sim::Scenario;
use criterion::{criterion_group, criterion_main, Criterion};

fn bench_copy(c: &mut Criterion) {
    let Ok(sc) = Scenario::load(configs_dir().join("scenarios/paper_case3.toml")) else {
        return;
    };
    let root = configs_dir().join("..");
    let Ok(stock) = "-20,-20,-10,60,50,0".parse() else {
        return;
    };
    let spec = ProgramSpec {
        program: root.join("tests/nc/pocket_rect.ngc"),
        stock: StockSource::Box(stock, 0.25),
        tools: None,
    };
    let Ok(path) = ProgramPath::build(
        &spec,
        &ToolGeometry::of(&sc.tool),
        sc.machine.spindle.rpm,
        sc.machine.feed_drive.rapid_mm_min,
    ) else {
        return;
    };
    let mut machine = path.scenario_for(&sc).build_machine();
    machine.set_engagement_source(Some(Box::new(path)));
    let mut group = c.benchmark_group("program_copy");
    group.bench_function("pocket_rect", |b| {
        b.iter(|| black_box(black_box(&machine).try_clone()))
    });
    group.finish();
}

criterion_group!(benches, bench_copy);
criterion_main!(benches);
