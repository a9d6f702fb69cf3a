//! HARDWARE TEST (feature `vcan`): needs a Linux virtual CAN interface, by default `vcan0`
//! (override with env `ACC_VCAN_IFACE`). Set it up once with
//! `sudo modprobe vcan && sudo ip link add dev vcan0 type vcan && sudo ip link set up vcan0`,
//! then run `cargo test -p acc-pmc --features vcan --test can_vcan`.
//!
//! Our `CanBoard<socketcan::CanSocket>` talks over the interface to a board bridged from a
//! second socket (the board's frames encoded with the same pure codec).
#![cfg(feature = "vcan")]

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use acc_pmc::can::codec::{decode_command, encode_status, NodeIds};
use acc_pmc::can::{CanBoard, CanLinkConfig};
use acc_pmc::emu::{lock_board, BoardLogic};
use acc_pmc::regs::OverrideResolution;
use acc_pmc::{Board, ControlBits};
use embedded_can::{Frame, Id, StandardId};
use socketcan::{CanFrame, CanSocket, Socket};

fn iface() -> String {
    std::env::var("ACC_VCAN_IFACE").unwrap_or_else(|_| "vcan0".into())
}

#[test]
fn can_board_over_vcan() {
    let name = iface();
    let link_sock = CanSocket::open(&name).unwrap_or_else(|e| {
        panic!("cannot open CAN interface {name}: {e} (see this file's first lines)")
    });
    link_sock
        .set_read_timeout(Duration::from_millis(5))
        .expect("read timeout");
    let board_sock = CanSocket::open(&name).expect("second socket");
    board_sock
        .set_read_timeout(Duration::from_millis(5))
        .expect("read timeout");

    let mut logic = BoardLogic::new(OverrideResolution::Percent10);
    logic.set_acc_switch(true);
    logic.set_operator_override_pct(70);
    let board = logic.shared();
    let stop = Arc::new(AtomicBool::new(false));
    let ids = NodeIds::new(1).expect("node");

    // The board side: apply command frames, send a status pair every 10 ms with a new sample.
    let bridge = {
        let board = board.clone();
        let stop = stop.clone();
        std::thread::spawn(move || {
            let t0 = std::time::Instant::now();
            let mut power = 1000u32;
            while !stop.load(Ordering::Relaxed) {
                if let Ok(frame) = board_sock.read_frame() {
                    if frame.id() == Id::Standard(StandardId::new(ids.command).expect("id")) {
                        if let Ok(c) = decode_command(ids, frame.data()) {
                            let now = t0.elapsed().as_millis() as u64;
                            let v = [
                                u16::from(c.override_pct),
                                c.heartbeat,
                                c.control.to_register(),
                            ];
                            let _ = lock_board(&board).write_holding(0, &v, now);
                        }
                    }
                }
                power += 10;
                let status = {
                    let mut b = lock_board(&board);
                    b.tick(t0.elapsed().as_millis() as u64);
                    b.push_power_sample(power);
                    b.status()
                };
                let (a, b) = encode_status(&status).expect("encode");
                for (id, data) in [(ids.status_a, a), (ids.status_b, b)] {
                    let f = CanFrame::new(StandardId::new(id).expect("id"), &data).expect("frame");
                    let _ = board_sock.write_frame(&f);
                }
                std::thread::sleep(Duration::from_millis(10));
            }
        })
    };

    let cfg = CanLinkConfig {
        node: 1,
        timeout: Duration::from_millis(100),
    };
    let mut link = CanBoard::new(link_sock, cfg).expect("link");
    let s = link.read_status().expect("status");
    assert!(s.acc_switch && !s.acc_active);
    assert_eq!(s.override_applied_pct, 70);
    link.write_control(ControlBits {
        acc_request: true,
        ..ControlBits::default()
    })
    .expect("arm");
    link.write_override(120, 1).expect("override");
    std::thread::sleep(Duration::from_millis(30));
    let s = link.read_status().expect("status");
    assert!(s.acc_active);
    assert_eq!(s.override_applied_pct, 120);
    stop.store(true, Ordering::Relaxed);
    bridge.join().expect("bridge");
}
