//! The CAN link against a mock bus that implements `embedded_can::blocking::Can`: the
//! in-memory board emulator, on a manual clock for the board's watchdog.

use std::time::Duration;

use acc_pmc::can::{CanBoard, CanError, CanLinkConfig};
use acc_pmc::clock::ManualClock;
use acc_pmc::emu::{BoardLogic, CanBoardEmulator, MemFrame, SharedBoard};
use acc_pmc::regs::OverrideResolution;
use acc_pmc::{Board, BoardError, BoardErrorKind, ControlBits};
use embedded_can::blocking::Can;
use embedded_can::{Frame, StandardId};

const ARM: ControlBits = ControlBits {
    acc_request: true,
    feed_hold_request: false,
    alarm_reset: false,
};

fn setup() -> (CanBoard<CanBoardEmulator>, SharedBoard, ManualClock) {
    let mut logic = BoardLogic::new(OverrideResolution::Percent10);
    logic.set_acc_switch(true);
    logic.set_operator_override_pct(70);
    logic.push_power_sample(5_000);
    let board = logic.shared();
    let clock = ManualClock::default();
    let bus =
        CanBoardEmulator::with_clock(board.clone(), 1, Box::new(clock.clone())).expect("node 1");
    let cfg = CanLinkConfig {
        node: 1,
        timeout: Duration::from_millis(20),
    };
    (CanBoard::new(bus, cfg).expect("link"), board, clock)
}

fn sample(board: &SharedBoard, power_w: u32) {
    acc_pmc::emu::lock_board(board).push_power_sample(power_w);
}

#[test]
fn status_override_and_heartbeat_over_the_mock_bus() {
    let (mut link, board, _clock) = setup();
    let s = link.read_status().expect("status");
    assert!(s.acc_switch && !s.acc_active);
    assert_eq!(
        (
            s.override_applied_pct,
            s.override_step_pct,
            s.spindle_power_w
        ),
        (70, 10, 5_000)
    );
    link.write_control(ARM).expect("arm");
    link.write_override(120, 1).expect("override");
    sample(&board, 5_500);
    let s = link.read_status().expect("status");
    assert!(s.acc_active);
    assert_eq!((s.override_applied_pct, s.spindle_power_w), (120, 5_500));
    let b = acc_pmc::emu::lock_board(&board);
    assert_eq!(b.holding_registers(), [120, 1, 1, 500, 1]);
}

#[test]
fn newest_pair_wins_when_several_samples_queued() {
    let (mut link, board, _clock) = setup();
    link.read_status().expect("first");
    // Three samples arrive before the next read; the emulator queues one pair per poll,
    // the link keeps reading until the bus is quiet and returns the newest.
    for p in [6_000, 6_100, 6_200] {
        sample(&board, p);
        link.get_mut().emit_status();
    }
    assert_eq!(link.read_status().expect("status").spindle_power_w, 6_200);
}

#[test]
fn invalid_override_is_refused_locally_like_exception_03() {
    let (mut link, board, _clock) = setup();
    link.read_status().expect("learn the step");
    link.write_override(90, 1).expect("90 ok");
    for bad in [155u16, 35, 300] {
        let err = link.write_override(bad, 2).expect_err("refused");
        assert_eq!(err.kind(), BoardErrorKind::Exception(3), "{err}");
    }
    assert_eq!(acc_pmc::emu::lock_board(&board).override_cmd_pct(), 90);
    // A raw frame with 155 % (not through the link) is ignored by the board as a whole.
    let id = StandardId::new(0x201).expect("id");
    let frame = MemFrame::new(id, &[155, 1, 9, 0]).expect("frame");
    link.get_mut().transmit(&frame).expect("sent");
    let b = acc_pmc::emu::lock_board(&board);
    assert_eq!((b.override_cmd_pct(), b.heartbeat()), (90, 1));
    drop(b);
    assert_eq!(link.get_mut().stats().rejected, 1);
}

#[test]
fn watchdog_trips_on_the_board_clock_and_alarm_reset_is_one_shot() {
    let (mut link, board, clock) = setup();
    link.write_control(ARM).expect("arm");
    for hb in 1..=10u16 {
        link.write_override(130, hb).expect("cycle");
        clock.advance(Duration::from_millis(100));
    }
    sample(&board, 1);
    assert!(!link.read_status().expect("status").watchdog_tripped);
    clock.advance(Duration::from_millis(500));
    sample(&board, 2);
    let s = link.read_status().expect("status");
    assert!(s.watchdog_tripped && !s.acc_active);
    assert_eq!(s.override_applied_pct, 70);
    link.write_control(ControlBits {
        alarm_reset: true,
        ..ARM
    })
    .expect("reset");
    sample(&board, 3);
    let s = link.read_status().expect("status");
    assert!(!s.watchdog_tripped && s.acc_active);
    // The next command frame no longer carries ALARM_RESET: a new trip stays tripped.
    clock.advance(Duration::from_millis(600));
    link.write_override(130, 11).expect("cycle");
    sample(&board, 4);
    assert!(link.read_status().expect("status").watchdog_tripped);
}

#[test]
fn silence_is_a_timeout_and_frozen_seq_is_returned_as_read() {
    let (mut link, board, _clock) = setup();
    link.read_status().expect("first pair");
    // No new sample: the board sends nothing.
    let err = link.read_status().expect_err("silent bus");
    assert_eq!(err.kind(), BoardErrorKind::Timeout, "{err}");
    // A board that repeats its last sample: SAMPLE_SEQ frozen.
    // The link hands it over as received; the runtime policy judges staleness.
    let first = link.last_status().expect("a status");
    for _ in 0..3 {
        link.get_mut().emit_status();
        let s = link
            .read_status()
            .expect("unchanged SAMPLE_SEQ is not a link error");
        assert_eq!(s.sample_seq, first.sample_seq);
    }
    sample(&board, 9_000);
    assert_eq!(link.read_status().expect("fresh").spindle_power_w, 9_000);
}

#[test]
fn bus_errors_map_to_kinds_and_lost_pairs_time_out() {
    let (mut link, board, _clock) = setup();
    link.get_mut()
        .fail_next_receive(embedded_can::ErrorKind::Crc);
    assert_eq!(
        link.read_status().expect_err("crc").kind(),
        BoardErrorKind::Crc
    );
    link.get_mut()
        .fail_next_receive(embedded_can::ErrorKind::Acknowledge);
    assert_eq!(
        link.read_status().expect_err("ack").kind(),
        BoardErrorKind::Disconnected
    );
    link.read_status().expect("clean again");
    link.get_mut().drop_next_pairs(1);
    sample(&board, 1);
    assert_eq!(
        link.read_status().expect_err("lost").kind(),
        BoardErrorKind::Timeout
    );
    assert!(matches!(
        CanBoard::new(
            CanBoardEmulator::new(board, 1).expect("node"),
            CanLinkConfig {
                node: 0,
                ..Default::default()
            }
        ),
        Err(CanError::BadNode(0))
    ));
}
