#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Round-trip time of one controller cycle — read status (FC04, 9 registers) + write
//! override and heartbeat (FC16, 2 registers) — from our `RtuBoard` to our `RtuServer`
//! over a real pty pair, at 19 200 and 115 200 Bd, 8N1.
//!
//! A pty moves bytes instantly whatever baud rate is set, so each rate is measured twice:
//! `raw` (pty as is: software + kernel overhead only) and `paced` (both ends wrapped in
//! `emu::Paced`, which delivers each write after its UART wire time, 10 bits per
//! character). The paced figure is what a real line costs; the wire time alone of one
//! cycle is 52 bytes × 10 bit / baud (27.1 ms at 19 200 Bd, 4.5 ms at 115 200 Bd).
//!
//! Run: `cargo bench -p acc-pmc --bench cycle`.

use std::time::Duration;

use acc_pmc::emu::{BoardLogic, Paced, PtyBoard};
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::{Board, BoardError};
use criterion::{criterion_group, criterion_main, Criterion};

fn link_cfg() -> RtuLinkConfig {
    RtuLinkConfig {
        timeout: Duration::from_millis(200),
        budget: Duration::from_millis(200),
        ..RtuLinkConfig::default()
    }
}

fn board() -> BoardLogic {
    let mut b = BoardLogic::default();
    b.set_acc_switch(true);
    b.push_power_sample(5_000);
    b
}

fn cycle<P: Board>(link: &mut P, hb: &mut u16) {
    *hb = hb.wrapping_add(1);
    let status = link
        .read_status()
        .map_err(|e| e.kind())
        .expect("read status");
    link.write_override(status.override_applied_pct.clamp(10, 150) / 10 * 10, *hb)
        .map_err(|e| e.kind())
        .expect("write override");
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("controller_cycle_pty");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_millis(500));
    for baud in [19_200u32, 115_200] {
        let mut pty = PtyBoard::spawn(board(), 1, baud).expect("pty board");
        let mut link = RtuBoard::new(pty.take_client_port().expect("client"), link_cfg());
        let mut hb = 0u16;
        group.bench_function(format!("raw_{baud}"), |b| {
            b.iter(|| cycle(&mut link, &mut hb))
        });
        drop(link);
        drop(pty);

        let mut pty =
            PtyBoard::spawn_with(board().shared(), 1, baud, move |m| Paced::new(m, baud, 10))
                .expect("pty board");
        let port = Paced::new(pty.take_client_port().expect("client"), baud, 10);
        let mut link = RtuBoard::new(port, link_cfg());
        group.bench_function(format!("paced_{baud}"), |b| {
            b.iter(|| cycle(&mut link, &mut hb))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
