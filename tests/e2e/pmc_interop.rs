//! Interoperability with Modbus implementations we did not write, over real pty pairs:
//! (a) our RTU client drives a pymodbus board stand-in (`tests/fixtures/board_standin.py`);
//! (b) `mbpoll` (libmodbus) reads and writes our board emulator (`RtuServer`).
//!
//! The peers are installed by `.ci/deps`. When one is missing the test prints why and
//! returns — unless the environment variable `CI` is set, then it fails.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use acc_pmc::emu::{BoardLogic, PtyBoard};
use acc_pmc::regs::OverrideResolution;
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::serial::configure_pty;
use acc_pmc::serialport::{SerialPort, TTYPort};
use acc_pmc::{Board, BoardError, BoardErrorKind, ControlBits};

use crate::e2e_support::peer_ready;

const ARM: ControlBits = ControlBits {
    acc_request: true,
    feed_hold_request: false,
    alarm_reset: false,
};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("fixtures")
        .join(name)
}

/// The stand-in process, killed on drop.
struct StandIn(Child);

impl Drop for StandIn {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Start the pymodbus stand-in on the slave end of a new pty pair; return our end (8N1,
/// 19 200 Bd), the slave end (kept open so the pty never hangs up) and the process.
fn start_standin(extra: &[&str]) -> (TTYPort, TTYPort, StandIn) {
    let (mut ours, mut theirs) = TTYPort::pair().expect("pty pair");
    configure_pty(&mut ours, 19_200).expect("configure");
    configure_pty(&mut theirs, 19_200).expect("configure");
    let path = theirs.name().expect("pty path");
    let mut child = Command::new("python3")
        .arg(fixture("board_standin.py"))
        .args([
            "--port",
            &path,
            "--baud",
            "19200",
            "--acc-switch",
            "--operator",
            "70",
            "--power",
            "5000",
        ])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn python3");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let standin = StandIn(child);
    let line = rx
        .recv_timeout(Duration::from_secs(10))
        .expect("stand-in did not start within 10 s");
    assert!(line.starts_with("READY"), "stand-in said {line:?}");
    (ours, theirs, standin)
}

fn python_cfg() -> RtuLinkConfig {
    // Python's asyncio answers in a few ms; allow 300 ms, no retries (errors must not hide).
    RtuLinkConfig {
        slave: 1,
        timeout: Duration::from_millis(300),
        retries: 0,
        budget: Duration::from_millis(300),
    }
}

#[test]
fn our_client_drives_the_pymodbus_standin() {
    if !peer_ready(
        "python3 with pymodbus",
        Command::new("python3").args(["-c", "import pymodbus, serial"]),
    ) {
        return;
    }
    let (port, _theirs, _standin) = start_standin(&[]);
    let mut b = RtuBoard::new(port, python_cfg());

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
    assert_eq!(
        b.read_holding().expect("holding"),
        [100, 0, 0, 500],
        "power-up defaults"
    );

    // Override values: accepted multiples of 10, refused 155 and 35 with exception 03.
    b.write_watchdog_ms(300).expect("watchdog 300 ms");
    b.write_control(ARM).expect("arm");
    b.write_override(120, 1).expect("override 120");
    let s = b.read_status().expect("status");
    assert!(s.acc_active);
    assert_eq!(s.override_applied_pct, 120);
    for bad in [155u16, 35] {
        let err = b.write_override(bad, 2).expect_err("refused");
        assert_eq!(err.kind(), BoardErrorKind::Exception(3), "{err}");
    }
    assert_eq!(
        b.read_holding().expect("holding"),
        [120, 1, 1, 300],
        "old override kept"
    );

    // Heartbeat: changing it every 50 ms keeps the 300 ms watchdog quiet for 600 ms.
    for hb in 2..14u16 {
        b.write_override(130, hb).expect("cycle");
        std::thread::sleep(Duration::from_millis(50));
    }
    let s = b.read_status().expect("status");
    assert!(s.acc_active && !s.watchdog_tripped);
    assert_eq!(s.override_applied_pct, 130);

    // Watchdog: no heartbeat change for > 300 ms trips it; the stand-in falls back to 70 %.
    std::thread::sleep(Duration::from_millis(400));
    let s = b.read_status().expect("status");
    assert!(s.watchdog_tripped && !s.acc_active, "{s:?}");
    assert_eq!(s.override_applied_pct, 70);
    b.write_control(ControlBits {
        alarm_reset: true,
        ..ARM
    })
    .expect("alarm reset");
    let s = b.read_status().expect("status");
    assert!(!s.watchdog_tripped && s.acc_active);
    assert_eq!(
        b.read_holding().expect("holding")[2],
        1,
        "ALARM_RESET reads back 0"
    );
    assert_eq!(
        b.stats().retries + b.stats().timeouts + b.stats().crc_errors,
        0
    );
}

#[test]
fn frozen_sample_seq_of_the_standin_is_returned_as_read() {
    if !peer_ready(
        "python3 with pymodbus",
        Command::new("python3").args(["-c", "import pymodbus, serial"]),
    ) {
        return;
    }
    let (port, _theirs, _standin) = start_standin(&["--freeze-seq"]);
    let mut b = RtuBoard::new(port, python_cfg());
    // The link hands over every status as read; the runtime policy judges staleness.
    let first = b.read_status().expect("first read");
    for _ in 0..4 {
        let s = b
            .read_status()
            .expect("unchanged SAMPLE_SEQ is not a link error");
        assert_eq!(s.sample_seq, first.sample_seq);
    }
}

// ------------------------------------------------------------------ mbpoll

/// Run mbpoll on `path` (RTU, slave 1, 19 200 8N1, PDU addressing, one poll, 1 s timeout)
/// with `args`; `values` (if any) are written.
fn mbpoll_run(path: &str, args: &[&str], values: &[&str]) -> (bool, String) {
    let out = Command::new("mbpoll")
        .args([
            "-m", "rtu", "-a", "1", "-b", "19200", "-P", "none", "-d", "8", "-s", "1",
        ])
        .args(["-0", "-1", "-o", "1"])
        .args(args)
        .arg(path)
        .args(values)
        .output()
        .expect("run mbpoll");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

fn mbpoll(path: &str, args: &[&str]) -> (bool, String) {
    mbpoll_run(path, args, &[])
}

/// Write holding registers from `reg` (one value: FC06, several: FC16).
fn mbpoll_write(path: &str, reg: &str, values: &[&str]) -> (bool, String) {
    mbpoll_run(path, &["-t", "4", "-r", reg], values)
}

/// Values of mbpoll's `[ref]: value` lines, in order.
fn values(text: &str) -> Vec<i64> {
    text.lines()
        .filter(|l| l.trim_start().starts_with('['))
        .filter_map(|l| l.split(':').nth(1))
        .filter_map(|v| v.split_whitespace().next())
        .filter_map(|v| v.parse().ok())
        .collect()
}

#[test]
fn mbpoll_reads_and_writes_our_board_emulator() {
    if !peer_ready("mbpoll", Command::new("mbpoll").arg("-V")) {
        return;
    }
    let mut logic = BoardLogic::new(OverrideResolution::Percent10);
    logic.set_acc_switch(true);
    logic.set_operator_override_pct(80);
    logic.set_cycle_active(true);
    logic.set_spindle_power_w(70_000); // 0x0001_1170
    logic.set_spindle_rpm(6000);
    logic.set_sample_seq(41);
    logic.set_programmed_feed_mm_min(1200);
    let pty = PtyBoard::spawn(logic, 1, 19_200).expect("pty board");
    let path = pty.path().to_string();

    // Input registers 0…8 with the spec's meaning.
    let (ok, text) = mbpoll(&path, &["-t", "3", "-r", "0", "-c", "9"]);
    assert!(ok, "{text}");
    assert_eq!(
        values(&text),
        vec![0b101, 80, 80, 10, 1, 0x1170, 6000, 41, 1200],
        "{text}"
    );

    // Holding registers: power-up defaults.
    let (ok, text) = mbpoll(&path, &["-t", "4", "-r", "0", "-c", "4"]);
    assert!(ok, "{text}");
    assert_eq!(values(&text), vec![100, 0, 0, 500], "{text}");

    // ACC_REQUEST (FC06), then OVERRIDE_CMD + HEARTBEAT (FC16): the board drives 120 %.
    let (ok, text) = mbpoll_write(&path, "2", &["1"]);
    assert!(ok, "{text}");
    let (ok, text) = mbpoll_write(&path, "0", &["120", "7"]);
    assert!(ok, "{text}");
    assert_eq!(
        pty.with_board(|b| (b.override_cmd_pct(), b.heartbeat(), b.acc_active())),
        (120, 7, true)
    );
    let (ok, text) = mbpoll(&path, &["-t", "3", "-r", "0", "-c", "2"]);
    assert!(ok, "{text}");
    assert_eq!(values(&text), vec![0b111, 120], "{text}");

    // Exception 03 for 155 and 35; the old value stays.
    for bad in ["155", "35"] {
        let (ok, text) = mbpoll_write(&path, "0", &[bad]);
        assert!(!ok, "override {bad} must be refused: {text}");
        assert!(text.to_lowercase().contains("illegal data value"), "{text}");
    }
    // Exception 02 outside the map.
    let (ok, text) = mbpoll(&path, &["-t", "3", "-r", "16", "-c", "1"]);
    assert!(
        !ok && text.to_lowercase().contains("illegal data address"),
        "{text}"
    );
    assert_eq!(pty.with_board(|b| b.override_cmd_pct()), 120);
    let stats = pty.stop().expect("server");
    assert_eq!(stats.exceptions, 3);
}
