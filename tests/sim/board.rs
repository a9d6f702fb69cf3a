//! The simulated board through the `Board` trait: registers, the override grid, v1 and
//! v2 protocols, the NC context.

use acc_pmc::emu::EmulatedProtocol;
use acc_pmc::{Board, ControlBits};
use acc_pmc::{BoardError, BoardErrorKind};
use acc_sim::board::NcContext;
use acc_sim::run::configs_dir;
use acc_sim::Scenario;
use acc_sim::SimBoard;

fn board() -> SimBoard {
    let sc = Scenario::load(configs_dir().join("scenarios/paper_case1.toml")).expect("scenario");
    sc.build_board()
}

#[test]
fn status_reports_the_machine_through_the_registers() {
    let mut b = board();
    let s = b.read_status().expect("status");
    assert!(s.acc_switch && s.cycle_active && !s.acc_active);
    assert_eq!(s.programmed_feed_mm_min, 200);
    assert_eq!(s.override_step_pct, 10);
    b.write_control(ControlBits {
        acc_request: true,
        ..ControlBits::default()
    })
    .expect("control");
    b.write_override(150, 1).expect("override");
    let s = b.read_status().expect("status");
    assert!(s.acc_active);
    assert_eq!(s.override_applied_pct, 150);
    let rec = b.advance_period(0.1);
    // The override path still carries the power-up 100 % for its 16 ms dead time (target
    // 200 mm/min), then 150 % (300 mm/min); the 8 ms lag from standstill loses about
    // τ·target: mean ≈ 300 − 0.16·100 − 0.08·250 = 264 mm/min.
    assert!(
        (rec.feed_mean_mm_min - 264.0).abs() < 5.0,
        "{}",
        rec.feed_mean_mm_min
    );
    let s = b.read_status().expect("status");
    assert_eq!(s.spindle_rpm, 600);
    // Air cut: the spindle draws its no-load power, 700 W.
    assert_eq!(s.spindle_power_w, 700);
    // One sample at power-up (the board has a reading before the first period), one per
    // period since.
    assert_eq!(s.sample_seq, 2);
}

#[test]
fn the_board_refuses_an_override_off_its_step() {
    let mut b = board();
    let err = b.write_override(125, 1).expect_err("not a multiple of 10");
    assert_eq!(err.kind(), BoardErrorKind::Exception(3));
    assert_eq!(b.read_status().expect("status").override_applied_pct, 100);
}

fn board_v(protocol: EmulatedProtocol) -> SimBoard {
    let sc = Scenario::load(configs_dir().join("scenarios/paper_case1.toml")).expect("scenario");
    sc.build_board_with(protocol)
}

fn arm(b: &mut SimBoard, cmd: u16) {
    b.write_control(ControlBits {
        acc_request: true,
        ..ControlBits::default()
    })
    .expect("control");
    b.write_override(cmd, 1).expect("override");
}

#[test]
fn a_silent_controller_on_a_v1_board_hands_the_feed_to_the_operator() {
    let mut b = board_v(EmulatedProtocol::V1Exception);
    b.logic_mut().set_operator_override_pct(70);
    arm(&mut b, 150);
    // No heartbeat for 0.6 s > WATCHDOG_MS = 500 ms.
    for _ in 0..6 {
        b.advance_period(0.1);
    }
    let s = b.read_status().expect("status");
    assert!(s.watchdog_tripped && !s.acc_active && !s.feed_hold_active);
    assert_eq!(s.override_applied_pct, 70);
    // The machine follows the operator's 70 % after the dead time and lag.
    let rec = b.advance_period(0.1);
    assert!(
        (rec.feed_mean_mm_min - 140.0).abs() < 1.0,
        "{}",
        rec.feed_mean_mm_min
    );
}

#[test]
fn a_silent_controller_on_a_v2_board_is_clamped_and_the_feed_held() {
    let mut b = board();
    // The knob at 150 %, above the last command: the clamp keeps 50 %, the watchdog's
    // feed hold (FALLBACK_MODE 1) stops the feed.
    b.logic_mut().set_operator_override_pct(150);
    arm(&mut b, 50);
    for _ in 0..6 {
        b.advance_period(0.1);
    }
    let s = b.read_status().expect("status");
    assert!(s.watchdog_tripped && s.fallback_active && s.feed_hold_active);
    assert_eq!((s.override_applied_pct, s.fallback_override_pct), (50, 50));
    b.advance_period(0.1);
    let rec = b.advance_period(0.1);
    assert!(rec.feed_mean_mm_min < 1.0, "{}", rec.feed_mean_mm_min);
    let s = b.read_status().expect("status");
    assert_eq!(s.actual_feed_mm_min, 0, "ACTUAL_FEED is 0 in feed hold");
    // ALARM_RESET without re-arming: the hold ends, the clamp stays (50 % = 100 mm/min).
    b.write_control(ControlBits {
        alarm_reset: true,
        ..ControlBits::default()
    })
    .expect("reset");
    for _ in 0..3 {
        b.advance_period(0.1);
    }
    let rec = b.advance_period(0.1);
    assert!(
        (rec.feed_mean_mm_min - 100.0).abs() < 1.0,
        "{}",
        rec.feed_mean_mm_min
    );
}

#[test]
fn a_restart_in_a_cycle_holds_the_feed_until_alarm_reset() {
    let mut b = board();
    arm(&mut b, 150);
    for hb in 2..6 {
        b.write_override(150, hb).expect("cycle");
        b.advance_period(0.1);
    }
    assert!(b.advance_period(0.1).feed_mean_mm_min > 250.0);
    b.logic_mut().power_cycle();
    for _ in 0..3 {
        b.advance_period(0.1);
    }
    let s = b.read_status().expect("status");
    assert!(s.board_restarted && s.feed_hold_active && !s.acc_active);
    let rec = b.advance_period(0.1);
    assert!(rec.feed_mean_mm_min < 1.0, "{}", rec.feed_mean_mm_min);
    // The controller re-arms: override first, then ALARM_RESET with ACC_REQUEST.
    b.write_override(60, 9).expect("cmd");
    b.write_control(ControlBits {
        acc_request: true,
        alarm_reset: true,
        ..ControlBits::default()
    })
    .expect("re-arm");
    for hb in 10..14 {
        b.write_override(60, hb).expect("cycle");
        b.advance_period(0.1);
    }
    let rec = b.advance_period(0.1);
    assert!(
        (rec.feed_mean_mm_min - 120.0).abs() < 1.0,
        "{}",
        rec.feed_mean_mm_min
    );
}

#[test]
fn the_nc_context_follows_the_machine_every_period() {
    let mut b = board();
    let s = b.read_status().expect("status");
    assert!(s.is_v2());
    assert_eq!(
        (s.tool_number, s.program_number, s.block_number),
        (1, 1000, 10)
    );
    b.set_nc_context(NcContext {
        tool_number: 12,
        program_number: 4711,
        block_step: 5,
        ..NcContext::default()
    });
    arm(&mut b, 150);
    let segments = b.machine().workpiece().segments.clone();
    let mut seen = std::collections::BTreeSet::new();
    let mut hb = 2;
    while !b.machine().finished() && b.machine().t_s() < 200.0 {
        b.write_override(150, hb).expect("cycle");
        hb = hb.wrapping_add(1);
        let (feed, x) = {
            let rec = b.advance_period(0.1);
            (rec.feed_mean_mm_min, rec.x_mm)
        };
        let s = b.read_status().expect("status");
        assert_eq!((s.tool_number, s.program_number), (12, 4711));
        assert_eq!(f64::from(s.actual_feed_mm_min), feed.round(), "x = {x}");
        let i = segments
            .iter()
            .position(|sg| x < sg.end_mm)
            .unwrap_or(segments.len() - 1);
        assert_eq!(s.block_number, 5 * (i as u16 + 1), "x = {x}");
        seen.insert(s.block_number);
    }
    assert_eq!(seen.len(), segments.len(), "every segment's block seen");
    // N65540 carried in 16 bits.
    assert_eq!(NcContext::default().block_number(6553), 4);
}

#[test]
fn a_v1_board_reports_no_nc_context() {
    let mut b = board_v(EmulatedProtocol::V1Zeros);
    b.advance_period(0.1);
    let s = b.read_status().expect("status");
    assert!(!s.is_v2());
    assert_eq!((s.tool_number, s.program_number, s.block_number), (0, 0, 0));
    assert_eq!(s.fallback_override_pct, 150);
}
