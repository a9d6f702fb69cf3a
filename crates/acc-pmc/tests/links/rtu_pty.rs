//! Client ↔ server over a real pty pair (`serialport::TTYPort::pair()`), 8N1, with the
//! production link code on both ends, plus fault injection on the client's stream.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use acc_pmc::emu::{BoardLogic, Fault, FaultInjector, FaultyStream, PtyBoard};
use acc_pmc::regs::{holding, OverrideResolution};
use acc_pmc::rtu::codec::append_crc;
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::serial::{open_rtu_board, RtuConfig, POLL_SLICE};
use acc_pmc::{Board, BoardError, BoardErrorKind, ControlBits};
use serialport::TTYPort;

const ARM: ControlBits = ControlBits {
    acc_request: true,
    feed_hold_request: false,
    alarm_reset: false,
};

/// A board with the operator's ACC switch on at 70 %, a power sample, served on a pty.
fn spawn_board() -> PtyBoard {
    let mut logic = BoardLogic::new(OverrideResolution::Percent10);
    logic.set_acc_switch(true);
    logic.set_operator_override_pct(70);
    logic.set_cycle_active(true);
    logic.push_power_sample(5_000);
    match PtyBoard::spawn(logic, 1, 115_200) {
        Ok(p) => p,
        Err(e) => panic!("cannot create a pty pair: {e}"),
    }
}

fn link(pty: &mut PtyBoard, cfg: RtuLinkConfig) -> RtuBoard<TTYPort> {
    RtuBoard::new(pty.take_client_port().expect("client end"), cfg)
}

fn faulty_link(
    pty: &mut PtyBoard,
    cfg: RtuLinkConfig,
) -> (RtuBoard<FaultyStream<TTYPort>>, FaultInjector) {
    let faults = FaultInjector::default();
    let stream = FaultyStream::new(
        pty.take_client_port().expect("client end"),
        faults.clone(),
        POLL_SLICE,
    );
    (RtuBoard::new(stream, cfg), faults)
}

fn cfg(timeout_ms: u64, retries: u8, budget_ms: u64) -> RtuLinkConfig {
    RtuLinkConfig {
        slave: 1,
        timeout: Duration::from_millis(timeout_ms),
        retries,
        budget: Duration::from_millis(budget_ms),
    }
}

#[test]
fn controller_cycle_drives_the_override() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(200, 1, 1000));
    let s = b.read_status().expect("status");
    assert!(s.acc_switch && !s.acc_active && s.cycle_active);
    assert_eq!(
        (
            s.override_applied_pct,
            s.operator_override_pct,
            s.override_step_pct
        ),
        (70, 70, 10)
    );
    assert_eq!(s.spindle_power_w, 5_000);
    b.write_control(ARM).expect("arm");
    b.write_override(120, 1).expect("override");
    let s = b.read_status().expect("status");
    assert!(s.acc_active);
    assert_eq!(s.override_applied_pct, 120);
    // A v2 board: five holding registers, FALLBACK_MODE 1 (clamp and feed hold).
    assert_eq!(b.read_holding().expect("holding"), [120, 1, 1, 500, 1]);
    assert_eq!(
        pty.with_board(|l| (l.override_cmd_pct(), l.heartbeat())),
        (120, 1)
    );
    b.write_watchdog_ms(1000).expect("watchdog");
    assert_eq!(pty.with_board(|l| l.watchdog_ms()), 1000);
    // feed hold request is reported back
    b.write_control(ControlBits {
        feed_hold_request: true,
        ..ARM
    })
    .expect("hold");
    assert!(b.read_status().expect("status").feed_hold_active);
    assert_eq!(b.stats().retries, 0);
}

#[test]
fn production_open_path_talks_to_the_emulator_on_its_pty() {
    let pty = spawn_board();
    let mut cfg = RtuConfig::for_port(pty.path());
    cfg.parity = "none".into();
    cfg.baud = 115_200;
    let settings = cfg.validate("sim.toml", "board").expect("valid");
    let mut b = open_rtu_board(&settings).expect("open the pty by path");
    b.write_watchdog_ms(settings.watchdog_ms).expect("watchdog");
    let s = b.read_status().expect("status");
    assert_eq!((s.override_step_pct, s.spindle_power_w), (10, 5_000));
}

#[test]
fn exception_03_is_reported_as_exception_and_not_retried() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(200, 3, 1000));
    b.write_override(90, 1).expect("90 is fine");
    for bad in [155u16, 35] {
        let err = b.write_override(bad, 2).expect_err("must be refused");
        assert_eq!(err.kind(), BoardErrorKind::Exception(3), "{err}");
        assert!(err.to_string().contains("exception 03"), "{err}");
    }
    assert_eq!(b.stats().retries, 0);
    assert_eq!(b.stats().exceptions, 2);
    assert_eq!(
        pty.with_board(|l| l.override_cmd_pct()),
        90,
        "old value kept"
    );
    let err = b.write_watchdog_ms(50).expect_err("watchdog 50 ms");
    assert_eq!(err.kind(), BoardErrorKind::Exception(3));
}

#[test]
fn watchdog_trips_without_heartbeat_and_alarm_reset_clears_it() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(200, 1, 1000));
    b.write_watchdog_ms(300).expect("watchdog 300 ms");
    b.write_control(ARM).expect("arm");
    // Heartbeat changing every 30 ms keeps the board active for 2 × the watchdog time.
    for hb in 1..=20u16 {
        b.write_override(130, hb).expect("cycle");
        std::thread::sleep(Duration::from_millis(30));
    }
    let s = b.read_status().expect("status");
    assert!(s.acc_active && !s.watchdog_tripped);
    assert_eq!(s.override_applied_pct, 130);
    // No heartbeat change for > 300 ms: tripped, back to the operator's 70 %.
    std::thread::sleep(Duration::from_millis(450));
    let s = b.read_status().expect("status");
    assert!(s.watchdog_tripped && !s.acc_active);
    assert_eq!(s.override_applied_pct, 70);
    // Heartbeat alone does not re-arm; ALARM_RESET does.
    b.write_override(130, 21).expect("cycle");
    assert!(b.read_status().expect("status").watchdog_tripped);
    b.write_control(ControlBits {
        alarm_reset: true,
        ..ARM
    })
    .expect("reset");
    let s = b.read_status().expect("status");
    assert!(!s.watchdog_tripped && s.acc_active);
    assert_eq!(s.override_applied_pct, 130);
}

#[test]
fn frozen_sample_seq_is_returned_as_read() {
    // Staleness is the runtime policy's to judge: the link hands over every status as read.
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(200, 1, 1000));
    let first = b.read_status().expect("first read");
    for _ in 0..5 {
        let s = b
            .read_status()
            .expect("unchanged SAMPLE_SEQ is not a link error");
        assert_eq!((s.sample_seq, s.spindle_power_w), (first.sample_seq, 5_000));
    }
    pty.with_board(|l| l.push_power_sample(6_000));
    assert_eq!(
        b.read_status().expect("fresh sample").spindle_power_w,
        6_000
    );
}

#[test]
fn corrupted_crc_is_retried_then_reported() {
    let mut pty = spawn_board();
    let (mut b, faults) = faulty_link(&mut pty, cfg(200, 1, 1000));
    faults.push(Fault::CorruptCrc);
    assert_eq!(
        b.read_status().expect("retry succeeds").spindle_power_w,
        5_000
    );
    assert_eq!((b.stats().crc_errors, b.stats().retries), (1, 1));
    faults.push_n(Fault::CorruptCrc, 2);
    let err = b.read_status().expect_err("both attempts corrupted");
    assert_eq!(err.kind(), BoardErrorKind::Crc);
    assert_eq!(faults.pending(), 0);
    // The link is clean afterwards.
    b.write_override(100, 9).expect("next cycle");
    assert_eq!(pty.with_board(|l| l.heartbeat()), 9);
}

#[test]
fn dropped_reply_times_out_and_retry_recovers() {
    let mut pty = spawn_board();
    let (mut b, faults) = faulty_link(&mut pty, cfg(100, 1, 500));
    faults.push(Fault::DropReply);
    let t0 = Instant::now();
    b.write_override(110, 3).expect("retry succeeds");
    assert!(
        t0.elapsed() >= Duration::from_millis(100),
        "waited for the timeout"
    );
    assert_eq!((b.stats().timeouts, b.stats().retries), (1, 1));
    let mut pty0 = spawn_board();
    let (mut b0, faults0) = faulty_link(&mut pty0, cfg(30, 0, 200));
    faults0.push(Fault::DropReply);
    let err = b0.read_status().expect_err("no retries");
    assert_eq!(err.kind(), BoardErrorKind::Timeout);
    assert!(
        err.to_string().contains("no complete reply within 30 ms"),
        "{err}"
    );
}

#[test]
fn late_reply_is_a_timeout_and_is_not_taken_for_the_next_one() {
    let mut pty = spawn_board();
    let (mut b, faults) = faulty_link(&mut pty, cfg(60, 0, 200));
    pty.with_board(|l| l.push_power_sample(7_777));
    // The FC16 acknowledgement arrives 150 ms late (timeout 60 ms).
    faults.push(Fault::DelayReply(Duration::from_millis(150)));
    let err = b.write_override(120, 1).expect_err("late");
    assert_eq!(err.kind(), BoardErrorKind::Timeout);
    std::thread::sleep(Duration::from_millis(200));
    // The late FC16 ack is on the line now; the next FC04 must not be confused by it.
    let s = b.read_status().expect("status after resync");
    assert_eq!(s.spindle_power_w, 7_777);
    assert!(
        b.stats().bytes_discarded >= 8,
        "the 8-byte late ack was drained"
    );
}

#[test]
fn retries_stay_within_the_budget() {
    let mut pty = spawn_board();
    let (mut b, faults) = faulty_link(&mut pty, cfg(100, 5, 250));
    faults.push_n(Fault::DropReply, 10);
    let t0 = Instant::now();
    let err = b.read_status().expect_err("all dropped");
    let took = t0.elapsed();
    assert_eq!(err.kind(), BoardErrorKind::Timeout);
    // 100 ms + 100 ms fit in 250 ms, a third attempt would not (5 retries allowed).
    assert_eq!(b.stats().retries, 1);
    assert!(
        took >= Duration::from_millis(200) && took < Duration::from_millis(250 + 100),
        "took {took:?}"
    );
}

#[test]
fn board_side_faults_reach_a_client_that_only_has_the_device_path() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(60, 0, 200));
    pty.faults().push(Fault::CorruptCrc);
    assert_eq!(
        b.read_status().expect_err("crc").kind(),
        BoardErrorKind::Crc
    );
    pty.faults().push(Fault::DropReply);
    assert_eq!(
        b.write_override(100, 1).expect_err("dropped").kind(),
        BoardErrorKind::Timeout
    );
    pty.faults()
        .push(Fault::DelayReply(Duration::from_millis(150)));
    assert_eq!(
        b.read_status().expect_err("late").kind(),
        BoardErrorKind::Timeout
    );
    std::thread::sleep(Duration::from_millis(200));
    b.write_override(110, 2)
        .expect("late reply drained, link clean");
    assert_eq!(pty.with_board(|l| l.override_cmd_pct()), 110);
    assert_eq!(pty.faults().applied(), 3);
}

#[test]
fn garbage_before_the_reply_is_survived() {
    let mut pty = spawn_board();
    let (mut b, faults) = faulty_link(&mut pty, cfg(200, 1, 1000));
    faults.push(Fault::Garbage(vec![0xFF, 0x00, 0x42]));
    assert_eq!(b.read_status().expect("retry").override_applied_pct, 70);
    assert_eq!(b.stats().retries, 1);
}

#[test]
fn board_restart_is_visible_in_the_holding_registers() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(200, 1, 1000));
    b.write_watchdog_ms(1000).expect("wd");
    b.write_control(ARM).expect("arm");
    b.write_override(140, 5).expect("cycle");
    assert!(b.read_status().expect("status").acc_active);
    pty.with_board(|l| l.power_cycle());
    assert_eq!(b.read_holding().expect("holding"), [100, 0, 0, 500, 1]);
    let s = b.read_status().expect("status");
    assert!(!s.acc_active);
    assert_eq!(s.override_applied_pct, 70);
    // v2: the restart is flagged, and in a cycle the board holds the feed (it lost the last
    // override) until the controller writes ALARM_RESET.
    assert!(s.board_restarted && s.cycle_active && s.feed_hold_active);
    b.write_control(ControlBits {
        alarm_reset: true,
        ..ARM
    })
    .expect("re-arm");
    let s = b.read_status().expect("status");
    assert!(!s.board_restarted && !s.feed_hold_active && s.acc_active);
}

#[test]
fn closed_board_end_is_disconnected() {
    let mut pty = spawn_board();
    let mut b = link(&mut pty, cfg(30, 0, 100));
    b.read_status().expect("alive");
    drop(pty);
    let err = b.read_status().expect_err("board gone");
    assert_eq!(err.kind(), BoardErrorKind::Disconnected, "{err}");
}

// ------------------------------------------------------------------ raw server framing

/// Read whatever arrives until the line is silent for 30 ms (max 1 s).
fn read_reply(port: &mut TTYPort) -> Vec<u8> {
    let mut out = Vec::new();
    let mut last = Instant::now();
    let start = Instant::now();
    let mut buf = [0u8; 256];
    while last.elapsed() < Duration::from_millis(30) && start.elapsed() < Duration::from_secs(1) {
        match port.read(&mut buf) {
            Ok(n) if n > 0 => {
                out.extend_from_slice(&buf[..n]);
                last = Instant::now();
            }
            _ => {}
        }
    }
    out
}

fn framed(body: &[u8]) -> Vec<u8> {
    let mut f = body.to_vec();
    append_crc(&mut f);
    f
}

#[test]
fn server_skips_garbage_partial_frames_and_other_slaves() {
    let mut pty = spawn_board();
    let mut port = pty.take_client_port().expect("client");
    let read_step = framed(&[0x01, 0x04, 0x00, 0x03, 0x00, 0x01]); // FC04 OVERRIDE_STEP
    let expected = framed(&[0x01, 0x04, 0x02, 0x00, 0x0A]); // 1 register: 10 %

    // Garbage immediately followed by a frame.
    let mut bytes = vec![0x00, 0xFF, 0x13, 0x37];
    bytes.extend_from_slice(&read_step);
    port.write_all(&bytes).expect("write");
    assert_eq!(read_reply(&mut port), expected);

    // A frame in two pieces with a short pause.
    port.write_all(&read_step[..3]).expect("write");
    std::thread::sleep(Duration::from_millis(1));
    port.write_all(&read_step[3..]).expect("write");
    assert_eq!(read_reply(&mut port), expected);

    // A partial frame, silence, then a whole frame: only the whole frame is answered.
    port.write_all(&read_step[..5]).expect("write");
    std::thread::sleep(Duration::from_millis(30));
    port.write_all(&read_step).expect("write");
    assert_eq!(read_reply(&mut port), expected);

    // A frame for slave 2 is ignored.
    port.write_all(&framed(&[0x02, 0x04, 0x00, 0x03, 0x00, 0x01]))
        .expect("write");
    assert!(read_reply(&mut port).is_empty());

    // A frame with a bad CRC is ignored.
    let mut bad = read_step.clone();
    bad[7] ^= 0xFF;
    port.write_all(&bad).expect("write");
    assert!(read_reply(&mut port).is_empty());

    // Unknown function 0x2B (a 7-byte frame): exception 01.
    port.write_all(&framed(&[0x01, 0x2B, 0x0E, 0x01, 0x00]))
        .expect("write");
    assert_eq!(read_reply(&mut port), framed(&[0x01, 0xAB, 0x01]));

    // Coil read (FC01, not in the map): exception 01.
    port.write_all(&framed(&[0x01, 0x01, 0x00, 0x00, 0x00, 0x01]))
        .expect("write");
    assert_eq!(read_reply(&mut port), framed(&[0x01, 0x81, 0x01]));

    // Address outside the map: exception 02.
    port.write_all(&framed(&[0x01, 0x04, 0x00, 0x0F, 0x00, 0x01]))
        .expect("write");
    assert_eq!(read_reply(&mut port), framed(&[0x01, 0x84, 0x02]));

    // FC16 whose byte count disagrees with its register count: exception 03.
    port.write_all(&framed(&[
        0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x02, 0x00, 0x50,
    ]))
    .expect("write");
    assert_eq!(read_reply(&mut port), framed(&[0x01, 0x90, 0x03]));

    // Broadcast write of WATCHDOG_MS: applied, no reply.
    port.write_all(&framed(&[
        0x00,
        0x06,
        0x00,
        holding::WATCHDOG_MS as u8,
        0x03,
        0xE8,
    ]))
    .expect("write");
    assert!(read_reply(&mut port).is_empty());
    assert_eq!(pty.with_board(|l| l.watchdog_ms()), 1000);

    let stats = pty.stop().expect("server stats");
    assert_eq!(stats.other_slave, 1);
    assert_eq!(stats.broadcasts, 1);
    assert_eq!(stats.exceptions, 4);
    assert!(stats.bytes_discarded >= 4 + 5 + 8, "{stats:?}");
}
