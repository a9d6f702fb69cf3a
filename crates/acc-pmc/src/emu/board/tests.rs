//! Tests of the emulated board against `pmc-board.md`: register validation, the watchdog,
//! the fallback clamp and feed holds, v1 and v2.

use super::*;
use crate::regs::{control_bits, holding, status_bits, FallbackMode, OverrideResolution};
use crate::BoardStatus;

fn write1(b: &mut BoardLogic, addr: u16, value: u16, now: u64) -> Result<Reply, Exception> {
    b.handle(Request::WriteSingle { addr, value }, now)
}

fn read_inputs(b: &mut BoardLogic, now: u64) -> Vec<u16> {
    match b.handle(Request::ReadInput { addr: 0, count: 9 }, now) {
        Ok(Reply::Registers(r)) => r,
        other => panic!("read failed: {other:?}"),
    }
}

/// A board with the operator's switch on at 70 % and the controller holding ACC_REQUEST.
fn armed(res: OverrideResolution) -> BoardLogic {
    let mut b = BoardLogic::new(res);
    b.set_acc_switch(true);
    b.set_operator_override_pct(70);
    write1(&mut b, holding::CONTROL, control_bits::ACC_REQUEST, 0).expect("control");
    b
}

#[test]
fn power_up_defaults() {
    let mut b = BoardLogic::new(OverrideResolution::Percent10);
    let r = b.handle(Request::ReadHolding { addr: 0, count: 4 }, 0);
    assert_eq!(r, Ok(Reply::Registers(vec![100, 0, 0, 500])));
    assert!(!b.acc_active());
    assert_eq!(b.status().override_step_pct, 10);
    assert_eq!(
        BoardLogic::new(OverrideResolution::Percent1)
            .status()
            .override_step_pct,
        1
    );
}

#[test]
fn acc_active_needs_switch_request_no_trip_no_lock() {
    let mut b = BoardLogic::new(OverrideResolution::Percent10);
    b.set_operator_override_pct(60);
    b.write_holding(holding::OVERRIDE_CMD, &[130], 0)
        .expect("write");
    // request without switch: not active, applied follows the operator.
    write1(&mut b, holding::CONTROL, 1, 0).expect("control");
    assert!(!b.acc_active());
    assert_eq!(b.override_applied_pct(), 60);
    b.set_acc_switch(true);
    assert!(b.acc_active());
    assert_eq!(b.override_applied_pct(), 130);
    b.set_override_locked(true);
    assert!(!b.acc_active());
    assert_eq!(b.override_applied_pct(), 60);
    b.set_override_locked(false);
    write1(&mut b, holding::CONTROL, 0, 1).expect("control");
    assert!(!b.acc_active());
    assert_eq!(b.override_applied_pct(), 60);
    let regs = read_inputs(&mut b, 1);
    assert_eq!(regs[0] & status_bits::ACC_ACTIVE, 0);
    assert_eq!(regs[0] & status_bits::ACC_SWITCH, status_bits::ACC_SWITCH);
}

#[test]
fn override_validation_step_10() {
    let mut b = armed(OverrideResolution::Percent10);
    for ok in [0u16, 10, 90, 150] {
        assert!(write1(&mut b, holding::OVERRIDE_CMD, ok, 1).is_ok(), "{ok}");
        assert_eq!(b.override_cmd_pct(), ok);
    }
    for bad in [155u16, 35, 160, 1, 65535] {
        let before = b.override_cmd_pct();
        assert_eq!(
            write1(&mut b, holding::OVERRIDE_CMD, bad, 2),
            Err(Exception::IllegalDataValue),
            "{bad}"
        );
        assert_eq!(b.override_cmd_pct(), before, "old value kept after {bad}");
    }
}

#[test]
fn override_validation_step_1() {
    let mut b = armed(OverrideResolution::Percent1);
    assert!(write1(&mut b, holding::OVERRIDE_CMD, 35, 1).is_ok());
    assert_eq!(b.override_applied_pct(), 35);
    assert_eq!(
        write1(&mut b, holding::OVERRIDE_CMD, 151, 1),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(b.override_cmd_pct(), 35);
}

#[test]
fn write_multiple_is_all_or_nothing() {
    let mut b = armed(OverrideResolution::Percent10);
    let req = Request::WriteMultiple {
        addr: 0,
        values: vec![120, 7],
    };
    assert_eq!(
        b.handle(req, 1),
        Ok(Reply::WroteMultiple { addr: 0, count: 2 })
    );
    assert_eq!((b.override_cmd_pct(), b.heartbeat()), (120, 7));
    // bad override with a new heartbeat: neither is applied.
    let req = Request::WriteMultiple {
        addr: 0,
        values: vec![125, 8],
    };
    assert_eq!(b.handle(req, 2), Err(Exception::IllegalDataValue));
    assert_eq!((b.override_cmd_pct(), b.heartbeat()), (120, 7));
    // bad watchdog in the last register of a 4-register write.
    let req = Request::WriteMultiple {
        addr: 0,
        values: vec![50, 9, 1, 50],
    };
    assert_eq!(b.handle(req, 3), Err(Exception::IllegalDataValue));
    assert_eq!(b.holding_registers(), [120, 7, 1, 500, 1]);
}

#[test]
fn addresses_outside_the_map_are_exception_02() {
    let mut b = BoardLogic::default();
    let cases = [
        Request::ReadInput { addr: 15, count: 1 },
        Request::ReadInput { addr: 0, count: 16 },
        Request::ReadInput { addr: 14, count: 2 },
        Request::ReadHolding { addr: 5, count: 1 },
        Request::ReadHolding {
            addr: 65535,
            count: 2,
        },
        Request::WriteSingle { addr: 5, value: 0 },
        Request::WriteMultiple {
            addr: 4,
            values: vec![1, 0],
        },
    ];
    for req in cases {
        assert_eq!(
            b.handle(req.clone(), 0),
            Err(Exception::IllegalDataAddress),
            "{req:?}"
        );
    }
    assert_eq!(b.holding_registers(), [100, 0, 0, 500, 1]);
}

#[test]
fn bad_counts_and_unknown_functions() {
    let mut b = BoardLogic::default();
    assert_eq!(
        b.handle(Request::ReadInput { addr: 0, count: 0 }, 0),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(
        b.handle(
            Request::ReadInput {
                addr: 0,
                count: 126
            },
            0
        ),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(
        b.handle(
            Request::WriteMultiple {
                addr: 0,
                values: vec![]
            },
            0
        ),
        Err(Exception::IllegalDataValue)
    );
    for f in [0x01u8, 0x02, 0x05, 0x0F, 0x17, 0x2B, 0x7F] {
        assert_eq!(
            b.handle(Request::Other { function: f }, 0),
            Err(Exception::IllegalFunction)
        );
    }
    assert_eq!(Exception::IllegalFunction.code(), 1);
    assert_eq!(Exception::IllegalDataAddress.code(), 2);
    assert_eq!(Exception::IllegalDataValue.code(), 3);
}

#[test]
fn control_and_watchdog_register_validation() {
    let mut b = BoardLogic::default();
    assert_eq!(
        write1(&mut b, holding::CONTROL, 0x08, 0),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(
        write1(&mut b, holding::WATCHDOG_MS, 99, 0),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(
        write1(&mut b, holding::WATCHDOG_MS, 5001, 0),
        Err(Exception::IllegalDataValue)
    );
    assert!(write1(&mut b, holding::WATCHDOG_MS, 100, 0).is_ok());
    assert!(write1(&mut b, holding::WATCHDOG_MS, 5000, 0).is_ok());
    assert_eq!(b.watchdog_ms(), 5000);
    // ALARM_RESET reads back 0, the other bits read back as written.
    assert!(write1(&mut b, holding::CONTROL, 0b111, 0).is_ok());
    assert_eq!(b.holding_registers()[2], 0b011);
}

#[test]
fn watchdog_trips_without_heartbeat_change_and_falls_back() {
    let mut b = armed(OverrideResolution::Percent10);
    b.write_holding(0, &[140, 1], 0).expect("write");
    assert_eq!(b.override_applied_pct(), 140);
    // heartbeat changing every 100 ms keeps it alive far beyond 500 ms.
    for k in 1..20u16 {
        b.write_holding(holding::HEARTBEAT, &[k + 1], u64::from(k) * 100)
            .expect("hb");
    }
    assert!(!b.status().watchdog_tripped);
    // the same heartbeat value written again does not count as a change.
    let last = 1900;
    b.write_holding(0, &[140, 20], last + 300).expect("same hb");
    b.tick(last + 499);
    assert!(!b.status().watchdog_tripped, "499 ms after the last change");
    b.tick(last + 500);
    let s = b.status();
    assert!(s.watchdog_tripped && !s.acc_active);
    assert_eq!(
        s.override_applied_pct, 70,
        "falls back to the operator's switch"
    );
    // heartbeat resumes: still tripped until ALARM_RESET.
    b.write_holding(holding::HEARTBEAT, &[99], last + 600)
        .expect("hb");
    assert!(b.status().watchdog_tripped);
    write1(
        &mut b,
        holding::CONTROL,
        control_bits::ACC_REQUEST | control_bits::ALARM_RESET,
        last + 700,
    )
    .expect("reset");
    let s = b.status();
    assert!(!s.watchdog_tripped && s.acc_active);
    assert_eq!(s.override_applied_pct, 140);
    assert_eq!(b.holding_registers()[2], control_bits::ACC_REQUEST);
    // the interval restarted at the reset.
    b.tick(last + 700 + 499);
    assert!(!b.status().watchdog_tripped);
    b.tick(last + 700 + 500);
    assert!(b.status().watchdog_tripped);
}

#[test]
fn watchdog_only_runs_while_acc_requested_and_uses_configured_time() {
    let mut b = BoardLogic::default();
    b.tick(0);
    b.tick(100_000);
    assert!(!b.status().watchdog_tripped, "no ACC_REQUEST, no watchdog");
    write1(&mut b, holding::WATCHDOG_MS, 200, 100_000).expect("wd");
    write1(&mut b, holding::CONTROL, 1, 100_050).expect("request");
    b.tick(100_249);
    assert!(
        !b.status().watchdog_tripped,
        "interval starts at the request edge"
    );
    b.tick(100_250);
    assert!(b.status().watchdog_tripped);
}

#[test]
fn feed_hold_request_and_operator_feed_hold() {
    let mut b = BoardLogic::default();
    write1(&mut b, holding::CONTROL, control_bits::FEED_HOLD_REQUEST, 0).expect("fh");
    assert!(b.status().feed_hold_active);
    assert_eq!(
        read_inputs(&mut b, 0)[0] & status_bits::FEED_HOLD_ACTIVE,
        status_bits::FEED_HOLD_ACTIVE
    );
    write1(&mut b, holding::CONTROL, 0, 0).expect("release");
    assert!(!b.status().feed_hold_active);
    b.set_operator_feed_hold(true);
    assert!(b.status().feed_hold_active);
}

#[test]
fn power_cycle_restores_defaults_and_keeps_machine_side() {
    let mut b = armed(OverrideResolution::Percent10);
    b.write_holding(0, &[50, 3, 3, 1000], 0).expect("write");
    b.push_power_sample(12_345);
    b.tick(2000);
    assert!(b.status().watchdog_tripped);
    b.power_cycle();
    assert_eq!(b.holding_registers(), [100, 0, 0, 500, 1]);
    let s = b.status();
    assert!(!s.watchdog_tripped && !s.acc_active && !s.feed_hold_active);
    assert!(s.acc_switch);
    assert_eq!(
        (s.spindle_power_w, s.sample_seq, s.override_applied_pct),
        (12_345, 1, 70)
    );
}

#[test]
fn machine_side_registers() {
    let mut b = BoardLogic::default();
    b.set_spindle_power_w(0x0001_86A0); // 100 000 W
    b.set_spindle_rpm(6000);
    b.set_programmed_feed_mm_min(1200);
    b.set_cycle_active(true);
    b.set_cnc_alarm(true);
    b.set_override_locked(true);
    b.set_operator_override_pct(400);
    b.set_sample_seq(u16::MAX);
    b.push_power_sample(2500);
    let r = read_inputs(&mut b, 0);
    let st = status_bits::CYCLE_ACTIVE | status_bits::CNC_ALARM | status_bits::OVERRIDE_LOCKED;
    assert_eq!(r, vec![st, 150, 150, 10, 0, 2500, 6000, 0, 1200]);
    b.set_spindle_power_w(0x0001_86A0);
    assert_eq!(read_inputs(&mut b, 0)[4..6], [0x0001, 0x86A0]);
    match b.handle(Request::ReadInput { addr: 6, count: 3 }, 0) {
        Ok(Reply::Registers(r)) => assert_eq!(r, vec![6000, 0, 1200]),
        other => panic!("{other:?}"),
    }
}

// ------------------------------------------------------------------ protocol v2

const ACC: u16 = control_bits::ACC_REQUEST;
const RESET: u16 = control_bits::ALARM_RESET;

/// A board in a cycle, operator switch on, knob at `knob` %, the controller active at
/// `cmd` % (heartbeat 1) at time 0.
fn cutting(protocol: EmulatedProtocol, knob: u16, cmd: u16) -> BoardLogic {
    let mut b = BoardLogic::with_protocol(OverrideResolution::Percent10, protocol);
    b.set_acc_switch(true);
    b.set_cycle_active(true);
    b.set_operator_override_pct(knob);
    b.write_holding(0, &[cmd, 1, ACC], 0).expect("arm");
    assert!(b.acc_active());
    assert_eq!(b.override_applied_pct(), cmd);
    b
}

fn read_all_inputs(b: &mut BoardLogic) -> Result<Reply, Exception> {
    b.handle(Request::ReadInput { addr: 0, count: 15 }, 0)
}

#[test]
fn v2_reports_version_context_and_fallback_registers() {
    let mut b = BoardLogic::default();
    assert_eq!(b.protocol(), EmulatedProtocol::V2);
    b.set_tool_number(12);
    b.set_program_number(4711);
    b.set_block_number(230);
    b.set_actual_feed_mm_min(720);
    match read_all_inputs(&mut b) {
        Ok(Reply::Registers(r)) => assert_eq!(r[9..], [2, 12, 4711, 230, 720, 150]),
        other => panic!("{other:?}"),
    }
    let s = b.status();
    assert!(s.is_v2() && !s.fallback_active && !s.board_restarted);
    assert_eq!(
        (s.tool_number, s.program_number, s.block_number),
        (12, 4711, 230)
    );
    assert_eq!(s.actual_feed_mm_min, 720);
    assert_eq!(
        b.handle(Request::ReadHolding { addr: 0, count: 5 }, 0),
        Ok(Reply::Registers(vec![100, 0, 0, 500, 1]))
    );
}

#[test]
fn fallback_mode_register_accepts_0_and_1_and_resets_on_power_cycle() {
    let mut b = BoardLogic::default();
    assert_eq!(b.fallback_mode(), FallbackMode::ClampAndFeedHold);
    assert!(write1(&mut b, holding::FALLBACK_MODE, 0, 0).is_ok());
    assert_eq!(b.holding_registers()[4], 0);
    for bad in [2u16, 3, 255, 65535] {
        assert_eq!(
            write1(&mut b, holding::FALLBACK_MODE, bad, 0),
            Err(Exception::IllegalDataValue),
            "{bad}"
        );
    }
    assert_eq!(b.fallback_mode(), FallbackMode::ClampOnly, "old value kept");
    // A bad FALLBACK_MODE in an FC16 write refuses the whole write.
    assert_eq!(
        b.write_holding(3, &[1000, 7], 0),
        Err(Exception::IllegalDataValue)
    );
    assert_eq!(b.watchdog_ms(), 500);
    b.power_cycle();
    assert_eq!(b.fallback_mode(), FallbackMode::ClampAndFeedHold);
}

#[test]
fn v1_exception_board_has_no_registers_9_to_14_and_no_fallback_mode() {
    let mut b =
        BoardLogic::with_protocol(OverrideResolution::Percent10, EmulatedProtocol::V1Exception);
    b.set_tool_number(5);
    for req in [
        Request::ReadInput { addr: 0, count: 15 },
        Request::ReadInput { addr: 9, count: 1 },
        Request::ReadInput { addr: 14, count: 1 },
        Request::ReadHolding { addr: 0, count: 5 },
        Request::ReadHolding { addr: 4, count: 1 },
        Request::WriteSingle { addr: 4, value: 1 },
        Request::WriteMultiple {
            addr: 3,
            values: vec![500, 1],
        },
    ] {
        assert_eq!(
            b.handle(req.clone(), 0),
            Err(Exception::IllegalDataAddress),
            "{req:?}"
        );
    }
    assert_eq!(
        b.handle(Request::ReadInput { addr: 0, count: 9 }, 0)
            .map(|r| match r {
                Reply::Registers(r) => r.len(),
                _ => 0,
            }),
        Ok(9)
    );
    let s = b.status();
    assert_eq!(
        s,
        BoardStatus::from_v1_input_registers(&s.to_v1_input_registers())
    );
    assert_eq!((s.protocol_version, s.tool_number), (0, 0));
}

#[test]
fn v1_zeros_board_reads_zeros_for_registers_9_to_14() {
    let mut b = BoardLogic::with_protocol(OverrideResolution::Percent10, EmulatedProtocol::V1Zeros);
    b.set_tool_number(5);
    b.set_actual_feed_mm_min(300);
    match read_all_inputs(&mut b) {
        Ok(Reply::Registers(r)) => assert_eq!(r[9..], [0; 6]),
        other => panic!("{other:?}"),
    }
    // FALLBACK_MODE reads 0; a write is accepted and changes nothing.
    assert!(write1(&mut b, holding::FALLBACK_MODE, 7, 0).is_ok());
    assert_eq!(
        b.handle(Request::ReadHolding { addr: 0, count: 5 }, 0),
        Ok(Reply::Registers(vec![100, 0, 0, 500, 0]))
    );
    assert!(!b.status().is_v2());
}

#[test]
fn watchdog_trip_clamps_to_the_override_of_the_moment_and_holds_the_feed() {
    let mut b = cutting(EmulatedProtocol::V2, 100, 60);
    b.tick(500);
    let s = b.status();
    assert!(s.watchdog_tripped && !s.acc_active);
    assert!(s.fallback_active && s.feed_hold_active);
    assert_eq!((s.override_applied_pct, s.fallback_override_pct), (60, 60));
    let r = b.input_registers();
    assert_eq!(
        r[0] & (status_bits::FALLBACK_ACTIVE | status_bits::FEED_HOLD_ACTIVE),
        status_bits::FALLBACK_ACTIVE | status_bits::FEED_HOLD_ACTIVE
    );
    assert_eq!(r[14], 60);
    // ALARM_RESET without ACC_REQUEST clears the trip and the feed hold, not the clamp.
    write1(&mut b, holding::CONTROL, RESET, 600).expect("reset");
    let s = b.status();
    assert!(!s.watchdog_tripped && !s.feed_hold_active && s.fallback_active);
    assert_eq!(s.override_applied_pct, 60);
    // The same knob position written again is no turn of the knob.
    b.set_operator_override_pct(100);
    assert_eq!(b.override_applied_pct(), 60);
    // A knob below the clamp wins (min), but turning it is a deliberate act: clamp ends.
    b.set_operator_override_pct(40);
    assert_eq!(b.override_applied_pct(), 40);
    assert!(!b.fallback_active());
    assert_eq!(b.fallback_override_pct(), 150);
    b.set_operator_override_pct(120);
    assert_eq!(b.override_applied_pct(), 120);
}

#[test]
fn clamp_applies_the_lower_of_knob_and_clamp() {
    let mut b = cutting(EmulatedProtocol::V2, 50, 80);
    write1(&mut b, holding::CONTROL, 0, 10).expect("release");
    let s = b.status();
    assert!(
        s.fallback_active && !s.feed_hold_active,
        "a release holds nothing"
    );
    assert_eq!((s.override_applied_pct, s.fallback_override_pct), (50, 80));
}

#[test]
fn watchdog_trip_with_fallback_mode_0_clamps_without_feed_hold() {
    let mut b = cutting(EmulatedProtocol::V2, 150, 90);
    write1(&mut b, holding::FALLBACK_MODE, 0, 0).expect("mode");
    b.tick(499);
    assert!(b.acc_active());
    b.tick(500);
    let s = b.status();
    assert!(s.watchdog_tripped && s.fallback_active && !s.feed_hold_active);
    assert_eq!(s.override_applied_pct, 90);
}

#[test]
fn controller_release_clamps_and_the_clamp_is_taken_in_register_order() {
    // CONTROL = 0 in the same FC16 write as a new command: the command is applied first
    // (register order), so the clamp is the new command.
    let mut b = cutting(EmulatedProtocol::V2, 100, 90);
    b.write_holding(0, &[30, 2, 0], 10).expect("write");
    let s = b.status();
    assert!(!s.acc_active && s.fallback_active);
    assert_eq!((s.override_applied_pct, s.fallback_override_pct), (30, 30));
    // The controller re-arms: ACC active again ends the clamp.
    b.write_holding(0, &[110, 3, ACC], 20).expect("re-arm");
    let s = b.status();
    assert!(s.acc_active && !s.fallback_active);
    assert_eq!(
        (s.override_applied_pct, s.fallback_override_pct),
        (110, 150)
    );
}

#[test]
fn operator_switch_off_and_override_lock_do_not_clamp() {
    let mut b = cutting(EmulatedProtocol::V2, 100, 50);
    b.set_acc_switch(false);
    assert!(!b.fallback_active());
    assert_eq!(b.override_applied_pct(), 100, "the operator took over");
    b.set_acc_switch(true);
    assert!(b.acc_active());
    b.set_override_locked(true);
    assert!(!b.acc_active() && !b.fallback_active());
    assert_eq!(b.override_applied_pct(), 100);
}

#[test]
fn clamp_ends_when_the_cycle_ends_and_is_not_engaged_outside_a_cycle() {
    let mut b = cutting(EmulatedProtocol::V2, 100, 40);
    write1(&mut b, holding::CONTROL, 0, 10).expect("release");
    assert_eq!(b.override_applied_pct(), 40);
    b.set_cycle_active(false);
    assert!(!b.fallback_active());
    assert_eq!(b.override_applied_pct(), 100);
    // Out of a cycle a release has nothing to protect: no clamp.
    write1(&mut b, holding::CONTROL, ACC, 20).expect("arm");
    write1(&mut b, holding::OVERRIDE_CMD, 40, 20).expect("cmd");
    write1(&mut b, holding::CONTROL, 0, 30).expect("release");
    assert!(!b.fallback_active());
    assert_eq!(b.override_applied_pct(), 100);
}

#[test]
fn clamp_survives_the_operator_switch_off_and_alarm_reset() {
    let mut b = cutting(EmulatedProtocol::V2, 100, 70);
    b.tick(500);
    b.set_acc_switch(false);
    write1(&mut b, holding::CONTROL, RESET, 600).expect("reset");
    assert!(b.fallback_active());
    assert_eq!(b.override_applied_pct(), 70);
}

#[test]
fn power_cycle_in_a_cycle_sets_restarted_and_holds_the_feed_until_alarm_reset() {
    let mut b = cutting(EmulatedProtocol::V2, 100, 60);
    b.power_cycle();
    let s = b.status();
    assert!(s.board_restarted && s.feed_hold_active && !s.acc_active);
    assert!(!s.fallback_active, "the board lost the last override");
    assert_eq!(
        b.input_registers()[0] & status_bits::BOARD_RESTARTED,
        status_bits::BOARD_RESTARTED
    );
    // The controller re-arms: override first, then ALARM_RESET with ACC_REQUEST.
    b.write_holding(0, &[60, 1], 100).expect("cmd");
    assert!(b.status().feed_hold_active, "feed hold until ALARM_RESET");
    write1(&mut b, holding::CONTROL, ACC | RESET, 100).expect("reset");
    let s = b.status();
    assert!(!s.board_restarted && !s.feed_hold_active && s.acc_active);
    assert_eq!(s.override_applied_pct, 60);
    // Out of a cycle: restarted, but no feed hold.
    b.set_cycle_active(false);
    b.power_cycle();
    let s = b.status();
    assert!(s.board_restarted && !s.feed_hold_active);
}

#[test]
fn v1_board_hands_the_feed_to_the_knob_after_a_watchdog_trip() {
    // Why a controller on a v1 board must never release mid-cut: last command 40 %, the
    // knob at 100 %, the link dies: the board drives 100 %, no feed hold.
    for protocol in [EmulatedProtocol::V1Exception, EmulatedProtocol::V1Zeros] {
        let mut b = cutting(protocol, 100, 40);
        b.tick(500);
        let s = b.status();
        assert!(s.watchdog_tripped && !s.fallback_active && !s.feed_hold_active);
        assert_eq!(s.override_applied_pct, 100, "{protocol:?}");
        assert_eq!(s.fallback_override_pct, 150);
        // A release raises the feed the same way.
        let mut b = cutting(protocol, 100, 40);
        write1(&mut b, holding::CONTROL, 0, 10).expect("release");
        assert_eq!(b.override_applied_pct(), 100);
        // A power cycle in a cycle: no restarted bit, no feed hold.
        b.power_cycle();
        let s = b.status();
        assert!(!s.board_restarted && !s.feed_hold_active);
        assert_eq!(b.input_registers()[0] & 0x180, 0);
    }
}

mod props {
    use super::*;
    use proptest::prelude::*;

    /// What the controller, the clock and the power supply do to the board.
    #[derive(Debug, Clone)]
    enum Op {
        /// FC16 `OVERRIDE_CMD`, `HEARTBEAT` (a new heartbeat).
        Override(u16),
        /// FC06 `HEARTBEAT` (a new value).
        Heartbeat,
        /// FC06 `CONTROL` with any defined bits (clearing `ACC_REQUEST`, `ALARM_RESET`…).
        Control(u16),
        /// FC06 `FALLBACK_MODE`.
        FallbackMode(u16),
        /// Time passes with no request: link silence (watchdog trips).
        Silence(u64),
        /// A power cycle of the board.
        PowerCycle,
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            3 => (0u16..=15).prop_map(|k| Op::Override(k * 10)),
            2 => Just(Op::Heartbeat),
            3 => (0u16..8).prop_map(Op::Control),
            1 => (0u16..2).prop_map(Op::FallbackMode),
            3 => (0u64..1500).prop_map(Op::Silence),
            1 => Just(Op::PowerCycle),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// The knob stays where it is and the cycle runs: whatever the controller
        /// writes, however long the link is silent, however often the board restarts,
        /// the override a v2 board applies while ACC is not active never exceeds the
        /// last override it applied while ACC was active, and after a power cycle the
        /// feed is held until the controller writes ALARM_RESET.
        #[test]
        fn v2_never_raises_the_feed_above_the_last_acc_override(
            knob in (0u16..=15).prop_map(|k| k * 10),
            first in (0u16..=15).prop_map(|k| k * 10),
            ops in proptest::collection::vec(op(), 1..60),
        ) {
            let mut b = cutting(EmulatedProtocol::V2, knob, first);
            let mut now = 0u64;
            let mut hb = 1u16;
            let mut last_acc = first;
            // Power cycled, and the controller has not written ALARM_RESET since.
            let mut restarted_unreset = false;
            // Power cycled, and ACC has not been active since: the board lost the last
            // command, the controller must re-arm (its job; see the spec).
            let mut restarted = false;
            // A watchdog trip in FALLBACK_MODE 1 not yet reset.
            let mut wd_hold = false;
            for op in ops {
                now += 1;
                let tripped_before = b.status().watchdog_tripped;
                let mode_before = b.fallback_mode();
                match op {
                    Op::Override(v) => {
                        hb = hb.wrapping_add(1);
                        b.handle(Request::WriteMultiple { addr: 0, values: vec![v, hb] }, now)
                            .expect("valid write");
                    }
                    Op::Heartbeat => {
                        hb = hb.wrapping_add(1);
                        write1(&mut b, holding::HEARTBEAT, hb, now).expect("hb");
                    }
                    Op::Control(v) => {
                        write1(&mut b, holding::CONTROL, v, now).expect("control");
                        if v & RESET != 0 {
                            restarted_unreset = false;
                            wd_hold = false;
                        }
                    }
                    Op::FallbackMode(v) => {
                        write1(&mut b, holding::FALLBACK_MODE, v, now).expect("mode");
                    }
                    Op::Silence(ms) => {
                        now += ms;
                        b.tick(now);
                    }
                    Op::PowerCycle => {
                        b.power_cycle();
                        restarted_unreset = true;
                        restarted = true;
                        wd_hold = false;
                    }
                }
                let s = b.status();
                prop_assert_eq!(s.operator_override_pct, knob);
                if s.acc_active {
                    last_acc = s.override_applied_pct;
                    restarted = false;
                } else if !restarted {
                    prop_assert!(
                        s.override_applied_pct <= last_acc,
                        "applied {} > last ACC override {} ({:?})",
                        s.override_applied_pct, last_acc, s
                    );
                    if s.fallback_active {
                        prop_assert_eq!(
                            s.override_applied_pct,
                            knob.min(s.fallback_override_pct)
                        );
                    }
                }
                if restarted_unreset {
                    prop_assert!(s.feed_hold_active && s.board_restarted, "{:?}", s);
                }
                if !tripped_before && s.watchdog_tripped && mode_before == FallbackMode::ClampAndFeedHold {
                    wd_hold = true;
                }
                if wd_hold {
                    prop_assert!(s.feed_hold_active, "watchdog feed hold: {:?}", s);
                }
            }
        }
    }
}
