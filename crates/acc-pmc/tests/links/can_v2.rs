//! The CAN client's protocol v2 decoding (`0x300+n` NC context with every status pair,
//! `0x380+n` identity once a second) and its protocol detection, on a bus of hand-made
//! frames (`../shared/docs/pmc-board.md`, "CAN variant").

use std::collections::VecDeque;
use std::time::Duration;

use acc_pmc::can::codec::{encode_context, encode_identity, encode_status};
use acc_pmc::can::{CanBoard, CanLinkConfig};
use acc_pmc::emu::{MemBusError, MemFrame};
use acc_pmc::{Board, BoardProtocol, BoardStatus};
use embedded_can::{Frame, StandardId};

/// A bus that hands out queued frames and then reports a receive timeout.
#[derive(Default)]
struct FrameBus {
    rx: VecDeque<MemFrame>,
}

impl FrameBus {
    fn push(&mut self, id: u16, data: &[u8]) {
        let id = StandardId::new(id).expect("11-bit id");
        self.rx
            .push_back(MemFrame::new(id, data).expect("≤ 8 bytes"));
    }
}

impl embedded_can::blocking::Can for FrameBus {
    type Frame = MemFrame;
    type Error = MemBusError;
    fn transmit(&mut self, _frame: &MemFrame) -> Result<(), MemBusError> {
        Ok(())
    }
    fn receive(&mut self) -> Result<MemFrame, MemBusError> {
        self.rx.pop_front().ok_or(MemBusError::Timeout)
    }
}

fn link() -> CanBoard<FrameBus> {
    let cfg = CanLinkConfig {
        node: 1,
        timeout: Duration::from_millis(20),
    };
    CanBoard::new(FrameBus::default(), cfg).expect("node 1")
}

fn v2_status() -> BoardStatus {
    BoardStatus {
        acc_switch: true,
        acc_active: true,
        cycle_active: true,
        override_applied_pct: 90,
        operator_override_pct: 100,
        override_step_pct: 10,
        spindle_power_w: 4_321,
        spindle_rpm: 600,
        sample_seq: 7,
        programmed_feed_mm_min: 200,
        fallback_active: false,
        board_restarted: true,
        protocol_version: 2,
        tool_number: 12,
        program_number: 4711,
        block_number: 130,
        actual_feed_mm_min: 180,
        fallback_override_pct: 150,
        ..BoardStatus::default()
    }
}

fn push_pair(bus: &mut FrameBus, s: &BoardStatus) {
    let (a, b) = encode_status(s).expect("encodes");
    bus.push(0x181, &a);
    bus.push(0x281, &b);
}

#[test]
fn a_v2_board_s_context_and_identity_frames_are_decoded() {
    let mut l = link();
    assert_eq!(l.protocol(), None, "nothing known before the first status");
    let s = v2_status();
    let bus = l.get_mut();
    bus.push(0x381, &encode_identity(&s));
    push_pair(bus, &s);
    bus.push(0x301, &encode_context(&s).expect("encodes"));
    let got = l.read_status().expect("status");
    assert_eq!(got, s, "every v2 field decoded");
    assert!(got.board_restarted && got.is_v2());
    assert_eq!(l.protocol(), Some(BoardProtocol::V2));

    // The identity frame comes once a second: later pairs keep its program number; a
    // context frame sent before the pair is merged too; the clamp travels in it.
    let mut s2 = s;
    s2.board_restarted = false;
    s2.fallback_active = true;
    s2.fallback_override_pct = 80;
    s2.block_number = 140;
    let bus = l.get_mut();
    bus.push(0x301, &encode_context(&s2).expect("encodes"));
    push_pair(bus, &s2);
    let got = l.read_status().expect("status");
    assert_eq!(got, s2);
    assert_eq!(got.program_number, 4711);
}

#[test]
fn a_pair_without_a_context_frame_is_a_v1_board() {
    let mut l = link();
    let v1 = BoardStatus {
        protocol_version: 0,
        tool_number: 0,
        program_number: 0,
        block_number: 0,
        actual_feed_mm_min: 0,
        fallback_override_pct: 150,
        board_restarted: false,
        ..v2_status()
    };
    push_pair(l.get_mut(), &v1);
    let got = l.read_status().expect("status");
    assert_eq!(got, v1);
    assert!(!got.is_v2());
    assert_eq!(l.protocol(), Some(BoardProtocol::V1));
    // A board that then sends v2 frames is a v2 board from then on (the version from its
    // identity frame, or 2 until that arrives).
    let s = v2_status();
    push_pair(l.get_mut(), &s);
    l.get_mut()
        .push(0x301, &encode_context(&s).expect("encodes"));
    let got = l.read_status().expect("status");
    assert_eq!(l.protocol(), Some(BoardProtocol::V2));
    assert_eq!((got.protocol_version, got.tool_number), (2, 12));
}

#[test]
fn a_short_context_frame_is_a_protocol_error() {
    let mut l = link();
    let s = v2_status();
    push_pair(l.get_mut(), &s);
    l.get_mut().push(0x301, &[1, 2, 3]);
    let e = l.read_status().expect_err("3 bytes");
    assert!(e.to_string().contains("0x301"), "{e}");
}
