//! [`HalBoard`] against a fake pin backend: the status it derives from LinuxCNC's pins, the
//! adaptive feed it writes (150 % mapping, rapids, the operator's priority), the v2
//! fallback clamp, the heartbeat and the state pins.

use acc_linuxcnc::{AccOutputs, HalBoard, HalBoardError, MachineInputs, PinBackend};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};

/// A machine whose pins the test sets; it keeps the last outputs written.
#[derive(Debug, Default)]
struct FakePins {
    machine: MachineInputs,
    written: AccOutputs,
}

impl PinBackend for FakePins {
    fn read(&mut self) -> MachineInputs {
        self.machine
    }
    fn write(&mut self, outputs: &AccOutputs) {
        self.written = *outputs;
    }
}

/// A machine cutting under `M52 P1` at a 150 % feed override, ACC switched on, watchdog ok.
fn cutting() -> MachineInputs {
    MachineInputs {
        spindle_power_w: 3_456.4,
        spindle_speed_rpm: 12_000.0,
        program_line: 42,
        motion_type: 2,
        tool_number: 3,
        requested_vel_mm_s: 10.0,
        current_vel_mm_s: 12.0,
        feed_override: 1.5,
        machine_on: true,
        estop: false,
        program_running: true,
        program_paused: false,
        mode_auto: true,
        adaptive_enabled: true,
        acc_switch: true,
        watchdog_ok: true,
        sample_seq: 0,
        sample_seq_used: false,
    }
}

/// `CONTROL` with only `ACC_REQUEST` = `request`.
fn request(request: bool) -> ControlBits {
    ControlBits {
        acc_request: request,
        ..ControlBits::default()
    }
}

/// A board over a cutting machine with ACC requested and the law at `law_pct`.
fn driving(law_pct: u16) -> HalBoard<FakePins> {
    let mut board = HalBoard::new(FakePins {
        machine: cutting(),
        ..FakePins::default()
    });
    board.write_control(request(true)).expect("control");
    board.read_status().expect("status");
    board.write_override(law_pct, 1).expect("override");
    board
}

/// Changes the fake machine's inputs with `change`, then reads the status.
fn read_after(
    board: &mut HalBoard<FakePins>,
    change: impl FnOnce(&mut MachineInputs),
) -> BoardStatus {
    change(&mut board.pins_mut().machine);
    board.read_status().expect("status")
}

#[test]
fn the_status_block_comes_from_linuxcncs_pins() {
    let mut board = driving(120);
    let s = board.read_status().expect("status");
    assert!(s.acc_switch && s.acc_active && s.cycle_active);
    assert!(!s.feed_hold_active && !s.watchdog_tripped && !s.override_locked && !s.cnc_alarm);
    assert_eq!(s.spindle_power_w, 3_456);
    assert_eq!(s.spindle_rpm, 12_000);
    assert_eq!(s.block_number, 42);
    assert_eq!(s.tool_number, 3);
    assert_eq!(s.programmed_feed_mm_min, 600);
    assert_eq!(s.actual_feed_mm_min, 720);
    assert_eq!(s.operator_override_pct, 150);
    assert_eq!(s.override_applied_pct, 120);
    assert_eq!(s.override_step_pct, 1);
    assert_eq!((s.protocol_version, s.fallback_override_pct), (2, 150));
    assert_eq!(board.protocol(), Some(BoardProtocol::V2));
    let seq = s.sample_seq;
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        seq.wrapping_add(1)
    );
}

#[test]
fn machine_states_map_onto_the_boards_bits() {
    let mut board = driving(100);
    let s = read_after(&mut board, |m| m.adaptive_enabled = false);
    assert!(
        s.override_locked && !s.acc_active,
        "M52 P0 locks the override"
    );
    let s = read_after(&mut board, |m| {
        m.adaptive_enabled = true;
        m.watchdog_ok = false;
    });
    assert!(s.watchdog_tripped && !s.acc_active);
    assert!(board.pins().written.alarm);
    let s = read_after(&mut board, |m| {
        m.watchdog_ok = true;
        m.estop = true;
    });
    assert!(s.cnc_alarm);
    let s = read_after(&mut board, |m| {
        m.estop = false;
        m.program_paused = true;
    });
    assert!(s.feed_hold_active);
}

#[test]
fn the_adaptive_feed_is_the_laws_override_over_150_percent_and_rapids_are_not_slowed() {
    let mut board = driving(120);
    assert_eq!(board.pins().written.adaptive_feed, 0.8);
    board.write_override(150, 2).expect("override");
    assert_eq!(board.pins().written.adaptive_feed, 1.0);
    board.write_override(30, 3).expect("override");
    assert_eq!(board.pins().written.adaptive_feed, 0.2);
    read_after(&mut board, |m| m.motion_type = 1);
    board.write_override(30, 4).expect("override");
    assert_eq!(
        board.pins().written.adaptive_feed,
        1.0,
        "a traverse runs at 1.0"
    );
    // OVERRIDE_APPLIED is the command the next feed move gets: it echoes as on a board (a
    // traverse reported at 150 % read as a late echo to acc's loop-delay judge, found on
    // LinuxCNC: a `delay` release on the rapids of a restarted program).
    assert_eq!(
        board.read_status().expect("status").override_applied_pct,
        30
    );
    // A release during the rapid clamps at that command, not at the rapid's 1.0.
    board.write_control(request(false)).expect("release");
    let s = board.read_status().expect("status");
    assert!(s.fallback_active && s.fallback_override_pct == 30, "{s:?}");
    assert_eq!(
        board.pins().written.adaptive_feed,
        1.0,
        "still no slower rapid"
    );
    let s = read_after(&mut board, |m| m.motion_type = 2);
    assert_eq!(s.override_applied_pct, 30);
    assert_eq!(board.pins().written.adaptive_feed, 0.2);
    board.write_control(request(true)).expect("request");
    let err = board.write_override(151, 5).expect_err("above 150 %");
    assert_eq!(err, HalBoardError::OverrideOutOfRange { pct: 151 });
    assert_eq!(err.kind(), BoardErrorKind::Exception(3));
}

#[test]
fn the_operators_knob_lowers_the_feed_at_once() {
    let mut board = driving(120);
    let s = read_after(&mut board, |m| m.feed_override = 0.3);
    assert_eq!(s.operator_override_pct, 30);
    // 0.3 × 0.8: the knob and the adaptive feed multiply.
    assert_eq!(s.override_applied_pct, 24);
}

#[test]
fn a_release_mid_cut_clamps_the_feed_until_the_knob_turns() {
    let mut board = driving(90);
    board.write_control(request(false)).expect("release");
    let s = board.read_status().expect("status");
    assert!(!s.acc_active && s.fallback_active);
    assert_eq!(s.fallback_override_pct, 90);
    assert_eq!(
        s.override_applied_pct, 90,
        "the release does not raise the feed"
    );
    let out = board.pins().written;
    assert!(out.handed_back && !out.active);
    // The operator turns the knob: the clamp ends, the knob rules.
    let s = read_after(&mut board, |m| m.feed_override = 1.0);
    assert!(!s.fallback_active);
    assert_eq!(board.pins().written.adaptive_feed, 1.0);
}

#[test]
fn under_m52_p0_the_pin_holds_the_laws_command_for_the_moment_m52_p1_returns() {
    // Found on LinuxCNC (the fault matrix's m52-off row): with 1.0 on the pin while M52 P0
    // was in force, M52 P1 ran the heavy slot at 150 % until acc's next write (2 249 N =
    // 2.8 Fr for 30 ms). The pin keeps the held command instead.
    let mut board = driving(40);
    let s = read_after(&mut board, |m| m.adaptive_enabled = false);
    assert!(s.override_locked && !s.acc_active && !s.fallback_active);
    assert_eq!(
        s.override_applied_pct, 150,
        "the motion ignores the pin: the knob alone"
    );
    // The policy holds its command while locked.
    board.write_override(40, 2).expect("held");
    let held = board.pins().written.adaptive_feed;
    assert!((held - 40.0 / 150.0).abs() < 1e-12, "{held}");
    // M52 P1 takes effect before acc's next read: the pin already says 40 %.
    change_only(&mut board, |m| m.adaptive_enabled = true);
    assert_eq!(board.pins().written.adaptive_feed, held);
    let s = board.read_status().expect("status");
    assert!(s.acc_active && !s.override_locked);
    assert_eq!(s.override_applied_pct, 40);
    // The operator's switch off under M52 P0: acc lets go, the knob alone (no clamp).
    let s = read_after(&mut board, |m| {
        m.adaptive_enabled = false;
        m.acc_switch = false;
    });
    assert!(!s.fallback_active);
    assert_eq!(board.pins().written.adaptive_feed, 1.0);
}

#[test]
fn a_watchdog_that_has_not_run_yet_is_no_trip_but_acc_does_not_drive() {
    // HAL still loading after acc's `loadusr -W`: watchdog.ok-out not netted / not run.
    let mut board = HalBoard::new(FakePins {
        machine: MachineInputs {
            watchdog_ok: false,
            ..cutting()
        },
        ..FakePins::default()
    });
    let s = board.read_status().expect("status");
    assert!(!s.watchdog_tripped, "not run yet: no trip to latch on");
    board.write_control(request(true)).expect("control");
    assert!(!board.read_status().expect("status").acc_active);
    // The threads start: ok; then a trip is a trip.
    assert!(read_after(&mut board, |m| m.watchdog_ok = true).acc_active);
    let s = read_after(&mut board, |m| m.watchdog_ok = false);
    assert!(s.watchdog_tripped && !s.acc_active);
    assert!(board.pins().written.alarm);
}

#[test]
fn an_abort_and_an_mdi_retract_between_two_reads_end_the_cycle_through_the_retract() {
    let mut board = driving(60);
    // The operator aborts and retracts by MDI: the program was idle for a few ms between
    // acc's reads, and `halui.program.is-running` is set again by the MDI command.
    let s = read_after(&mut board, |m| m.mode_auto = false);
    assert!(!s.cycle_active, "the program's run in AUTO ended");
    // The retract runs on: the cycle stays ended (a fall the line guard can confirm).
    for _ in 0..3 {
        assert!(!board.read_status().expect("status").cycle_active);
    }
    // MDI idle; the next MDI command is a cycle (acc drives an MDI cut too).
    // (The same when a read found the program idle before the retract:
    // `acc_linuxcnc::cycle`'s unit tests.)
    assert!(!read_after(&mut board, |m| m.program_running = false).cycle_active);
    assert!(read_after(&mut board, |m| m.program_running = true).cycle_active);
    // Idle, then the program run again in AUTO.
    assert!(!read_after(&mut board, |m| m.program_running = false).cycle_active);
    let s = read_after(&mut board, |m| {
        m.program_running = true;
        m.mode_auto = true;
    });
    assert!(s.cycle_active);
    // An integrator who has not netted `acc.mode-auto`: the program running alone.
    let mut board = HalBoard::new(FakePins {
        machine: MachineInputs {
            mode_auto: false,
            ..cutting()
        },
        ..FakePins::default()
    });
    for _ in 0..3 {
        assert!(board.read_status().expect("status").cycle_active);
    }
}

/// Changes the fake machine's inputs without a read (LinuxCNC moving between acc's reads).
fn change_only(board: &mut HalBoard<FakePins>, change: impl FnOnce(&mut MachineInputs)) {
    change(&mut board.pins_mut().machine);
}

#[test]
fn the_operators_switch_releases_without_a_clamp() {
    let mut board = driving(90);
    let s = read_after(&mut board, |m| m.acc_switch = false);
    assert!(!s.acc_active && !s.fallback_active);
    assert_eq!(board.pins().written.adaptive_feed, 1.0);
}

#[test]
fn the_heartbeat_bit_toggles_every_period_driving_or_not_and_the_feed_hold_reaches_its_pin() {
    let mut board = driving(100);
    let mut bits = Vec::new();
    for beat in 2..6u16 {
        board.read_status().expect("status");
        board.write_override(100, beat).expect("override");
        let out = board.pins().written;
        assert_eq!(out.heartbeat, i32::from(beat));
        bits.push(out.heartbeat_bit);
    }
    assert_eq!(bits[0], !bits[1]);
    assert_eq!(bits[1], !bits[2]);
    assert_eq!(bits[2], !bits[3]);
    // Not driving (no override written): the bit still toggles at each period's read.
    let idle = board.pins().written.heartbeat_bit;
    board.read_status().expect("status");
    assert_eq!(board.pins().written.heartbeat_bit, !idle);
    board
        .write_control(ControlBits {
            acc_request: true,
            feed_hold_request: true,
            alarm_reset: false,
        })
        .expect("control");
    assert!(board.pins().written.feed_hold);
    assert!(board.read_status().expect("status").feed_hold_active);
}

#[test]
fn sample_seq_stands_still_when_the_power_sources_counter_does() {
    let mut board = driving(100);
    let a = board.read_status().expect("status").sample_seq;
    let b = board.read_status().expect("status").sample_seq;
    assert_eq!(b, a.wrapping_add(1), "no counter: SAMPLE_SEQ counts reads");
    // The process's counter netted (`setp acc.sample-seq-used 1`): one step per read that
    // finds it moved, however far; none while it stands still (a frozen power source),
    // which the policy's staleness judge sees.
    board.pins_mut().machine.sample_seq_used = true;
    board.pins_mut().machine.sample_seq = 70_001;
    let s1 = board.read_status().expect("status").sample_seq;
    assert_eq!(s1, b.wrapping_add(1), "a new counter value is a new sample");
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        s1,
        "frozen"
    );
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        s1,
        "frozen"
    );
    board.pins_mut().machine.sample_seq = 70_051;
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        s1.wrapping_add(1),
        "50 samples since: one step"
    );
}

#[test]
fn heartbeat_toggles_are_spaced_so_that_the_watchdog_sees_each() {
    use std::sync::Arc;
    use std::time::Duration;

    use acc_linuxcnc::MIN_BEAT_SPACING;
    use acc_pmc::clock::ManualClock;

    let clock = Arc::new(ManualClock::new());
    let mut board = HalBoard::new(FakePins {
        machine: cutting(),
        ..FakePins::default()
    })
    .with_clock(clock.clone());
    let mut bits = Vec::new();
    // Periods 0.1 s apart; the third runs 95 ms late and the fourth 5 ms after it.
    for at_ms in [0, 100, 295, 300, 400, 500] {
        clock.set(Duration::from_millis(at_ms));
        board.read_status().expect("status");
        bits.push(board.pins().written.heartbeat_bit);
    }
    // The read 5 ms after a toggle leaves the bit; every other read toggles it.
    let toggled: Vec<bool> = std::iter::once(bits[0])
        .chain(bits.windows(2).map(|w| w[0] != w[1]))
        .collect();
    assert_eq!(toggled, [true, true, true, false, true, true], "{bits:?}");
    assert!(MIN_BEAT_SPACING >= Duration::from_millis(10));
    // Without a clock every read toggles (a fake backend's reads are not timed).
    let mut plain = driving(100);
    let before = plain.pins().written.heartbeat_bit;
    plain.read_status().expect("status");
    assert_ne!(plain.pins().written.heartbeat_bit, before);
}
