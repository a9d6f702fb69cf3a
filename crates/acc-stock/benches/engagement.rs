//! The issue 28 target: the engagement of a 10 000-block program over a 200 × 200 mm stock
//! in under 10 s on the 2-core machine. A zig-zag pocket (rows split into short blocks,
//! two levels, a finishing contour per level) over a 200 × 200 × 30 mm box on 0.25 mm cells,
//! Ø10 mm 4-flute end mill, default options (path step = cell, 180 angular bins).
//! The same program with a Ø10 mm ball nose is timed too.
//! Run: `cargo bench -p acc-stock --bench engagement`.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use std::hint::black_box;
use std::time::Duration;

use acc_stock::{zigzag_pocket, Cutter, Move, Spindle, Sweep, SweepOptions, ZMap, ZigZag};
use criterion::{criterion_group, criterion_main, Criterion};

/// The benchmark program: 10 073 blocks, 17.0 m of path.
pub fn program() -> Vec<Move> {
    zigzag_pocket(&ZigZag {
        min_mm: [5.0, 5.0],
        max_mm: [195.0, 195.0],
        levels_mm: vec![-2.0, -4.0],
        stepover_mm: 5.0,
        block_mm: 190.0 / 128.0,
        feed_mm_min: 800.0,
        plunge_mm_min: 150.0,
        clearance_mm: 5.0,
    })
}

fn bench_engagement(c: &mut Criterion) {
    let Ok(stock) = ZMap::from_box([0.0, 0.0, -30.0], [200.0, 200.0, 0.0], 0.25) else {
        return;
    };
    let (Ok(flat), Ok(ball)) = (Cutter::flat(10.0, 4, 25.0), Cutter::ball(10.0, 4, 25.0)) else {
        return;
    };
    let moves = program();
    let path_mm: f64 = moves.iter().map(Move::length_mm).sum();
    let run = |cutter: Cutter| {
        let mut sweep = Sweep::new(
            stock.clone(),
            cutter,
            Spindle::cw(3000.0),
            SweepOptions::default(),
        )
        .ok()?;
        let mut out = Vec::with_capacity(70_000);
        for m in &moves {
            sweep.cut(m, &mut out);
        }
        Some(out)
    };
    if let Some(out) = run(flat) {
        let removed: f64 = out.iter().map(|e| e.removed_mm3).sum();
        eprintln!(
            "program: {} blocks, {:.0} mm of path, {} steps, {:.0} mm³ removed, {} cells",
            moves.len(),
            path_mm,
            out.len(),
            removed,
            stock.heights().len()
        );
    }
    let mut g = c.benchmark_group("stock");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));
    g.bench_function("engagement/10k-block zig-zag 200x200 cell 0.25", |b| {
        b.iter(|| black_box(run(flat)))
    });
    // The same program with a ball nose: 20 probe rings per bin instead of one.
    g.bench_function(
        "engagement/10k-block zig-zag 200x200 cell 0.25 ball nose",
        |b| b.iter(|| black_box(run(ball))),
    );
    g.finish();
}

criterion_group!(benches, bench_engagement);
criterion_main!(benches);
