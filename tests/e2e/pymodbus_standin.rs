//! Interoperability: `acc run` (the production binary) drives a PMC board stand-in written
//! with pymodbus (`tests/fixtures/board_standin.py`, a Modbus implementation we did not
//! write) over real ptys: override values, heartbeat, `ACC_REQUEST` cleared at the end, and
//! the stand-in's watchdog tripping when `acc run` dies without its orderly stop.
//!
//! The stand-in and `acc run` each open a pty device by path; a bridge thread copies bytes
//! between the two pty masters (what a null-modem cable does). pymodbus is installed by
//! `.ci/deps`; when it is missing the test prints why and returns — unless `CI` is set.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crate::e2e_support::{field, one_at_a_time, read_log, root, Proc};
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::serial::{configure_pty, open_port, RtuConfig};
use acc_pmc::serialport::{SerialPort, TTYPort};
use acc_pmc::Board;

fn pymodbus_ready() -> bool {
    crate::e2e_support::peer_ready(
        "python3 with pymodbus",
        Command::new("python3").args(["-c", "import pymodbus, serial"]),
    )
}

/// A pty pair whose slave path a process opens; returns (master, slave kept open, path).
fn pty() -> (TTYPort, TTYPort, String) {
    let (mut m, mut s) = TTYPort::pair().expect("pty pair");
    configure_pty(&mut m, 19_200).expect("configure");
    configure_pty(&mut s, 19_200).expect("configure");
    let path = s.name().expect("pty path");
    (m, s, path)
}

/// Copy bytes from `a` to `b` until `stop`.
fn pump(mut a: TTYPort, mut b: TTYPort, stop: Arc<AtomicBool>) {
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while !stop.load(Ordering::Relaxed) {
            match a.read(&mut buf) {
                Ok(n) if n > 0 => {
                    let _ = b.write_all(&buf[..n]);
                }
                _ => {}
            }
        }
    });
}

/// The run config for the stand-in: the paper VMC's, 8N1 (pty), T = 0.1 s, 60 ms timeout.
fn config(dir: &std::path::Path) -> PathBuf {
    let cfgs = root().join("configs");
    let text = std::fs::read_to_string(cfgs.join("runtime/paper_vmc_run.toml"))
        .expect("paper_vmc_run.toml")
        .replace("\"../presets/", &format!("\"{}/presets/", cfgs.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/runtime/paper_vmc_power.toml\"", cfgs.display()),
        )
        .replace("parity = \"even\"", "parity = \"none\"")
        .replace("timeout_ms = 40", "timeout_ms = 60")
        .replace("retries = 1", "retries = 0");
    let p = dir.join("standin_run.toml");
    std::fs::write(&p, text).expect("write config");
    p
}

/// Our own client on the `acc run` side of the bridge (after `acc run` has closed it).
fn our_client(path: &str) -> RtuBoard<TTYPort> {
    let mut cfg = RtuConfig::for_port(path);
    cfg.parity = "none".into();
    let settings = cfg.validate("test", "board").expect("settings");
    let link = RtuLinkConfig {
        timeout: Duration::from_millis(300),
        budget: Duration::from_millis(300),
        retries: 0,
        ..settings.link
    };
    RtuBoard::new(open_port(&settings).expect("open"), link)
}

#[test]
fn acc_run_drives_the_pymodbus_standin() {
    if !pymodbus_ready() {
        return;
    }
    // `acc run` on the wall clock against the stand-in: no other closed loop beside it.
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let (board_master, _board_slave, board_path) = pty();
    let (acc_master, _acc_slave, acc_path) = pty();
    let stop = Arc::new(AtomicBool::new(false));
    pump(
        board_master.try_clone_native().expect("clone"),
        acc_master.try_clone_native().expect("clone"),
        Arc::clone(&stop),
    );
    pump(acc_master, board_master, Arc::clone(&stop));

    // 1000 W at 600 rpm is about 510 N: below Fr, so ACC raises the feed to its maximum.
    let mut standin = Command::new("python3")
        .arg(root().join("tests/fixtures/board_standin.py"))
        .args(["--port", &board_path, "--acc-switch", "--operator", "70"])
        .args(["--power", "1000", "--rpm", "600", "--feed", "200"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn python3");
    let mut line = String::new();
    BufReader::new(standin.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("READY line");
    assert!(line.starts_with("READY"), "stand-in said {line:?}");

    let cfg = config(dir.path());
    let log = dir.path().join("run.csv");
    let cfg_s = cfg.to_string_lossy().to_string();
    let log_s = log.to_string_lossy().to_string();
    let args = [
        "run", "--config", &cfg_s, "--port", &acc_path, "--log", &log_s,
    ];

    // 1. A 3 s run that ends on its own (orderly stop).
    let mut a = args.to_vec();
    a.extend(["--duration-s", "3"]);
    let (code, out, err) = Proc::spawn(&a, false).finish(Duration::from_secs(30));
    assert_eq!(code, Some(0), "stdout:\n{out}\nstderr:\n{err:?}");
    assert!(out.contains("OVERRIDE_STEP = 10 %"), "{out}");
    // The stand-in is a v1 board (exception 02 for registers 9…14): announced exactly once,
    // with what it cannot do, and recorded in the summary.
    let warnings: Vec<&String> = err
        .iter()
        .filter(|l| l.starts_with("warning: ") && l.contains("speaks protocol v1"))
        .collect();
    assert_eq!(warnings.len(), 1, "stderr: {err:#?}");
    assert!(
        warnings[0].contains(acc_pmc::BoardProtocol::V1.limitations()),
        "{warnings:?}"
    );
    assert!(out.contains("protocol v1"), "{out}");
    assert!(out.contains("board protocol: v1;"), "{out}");
    assert!(
        !out.contains("FALLBACK_MODE"),
        "not written to a v1 board: {out}"
    );
    assert!(
        out.contains("ACC switch on") && out.contains("operator 70 %"),
        "{out}"
    );
    let rows = read_log(&log);
    assert_eq!(
        Some(rows.len()),
        field(&out, "periods").and_then(|v| v.parse().ok())
    );
    assert!(rows
        .iter()
        .filter_map(|r| r.override_cmd_pct)
        .all(|c| c % 10 == 0 && c <= 150));
    let last = rows.last().expect("rows");
    assert_eq!(
        (last.override_cmd_pct, last.override_applied_pct),
        (Some(150), Some(150)),
        "{last:?}"
    );
    assert!(
        rows.iter().skip(1).all(|r| r.mode == "adaptive_pi"),
        "never released"
    );
    let mut ours = our_client(&acc_path);
    let h = ours.read_holding().expect("holding registers");
    assert_eq!(h[0], 150, "OVERRIDE_CMD");
    assert!(
        h[1] as usize >= rows.len() - 1,
        "HEARTBEAT changed every period: {h:?}"
    );
    // The stand-in is always cutting and has no fallback clamp: the end of the run requests
    // feed hold before it clears ACC_REQUEST (a release there hands the feed to the knob).
    assert_eq!(
        h[2], 2,
        "ACC_REQUEST cleared, FEED_HOLD_REQUEST kept at the end"
    );
    assert!(
        out.contains("feed hold requested before the release"),
        "{out}"
    );
    assert_eq!(h[3], 500, "WATCHDOG_MS written at start");
    let s = ours.read_status().expect("status");
    assert!(!s.acc_active && !s.watchdog_tripped);
    assert_eq!(s.override_applied_pct, 70, "the operator's override again");
    drop(ours);

    // 2. acc run killed mid-run (no orderly stop): the heartbeat stops, the watchdog trips.
    let mut p = Proc::spawn(&args, false);
    std::thread::sleep(Duration::from_millis(1500));
    p.child.kill().expect("kill acc run");
    let _ = p.child.wait();
    std::thread::sleep(Duration::from_millis(800));
    let mut ours = our_client(&acc_path);
    let s = ours.read_status().expect("status");
    assert!(s.watchdog_tripped && !s.acc_active, "{s:?}");
    assert_eq!(s.override_applied_pct, 70, "fell back to the operator");
    drop(ours);

    // 3. A new acc run sees the tripped board and does not take over by itself.
    let mut a = args.to_vec();
    a.extend(["--duration-s", "1"]);
    let (code, out, err) = Proc::spawn(&a, false).finish(Duration::from_secs(30));
    assert_eq!(code, Some(0), "stdout:\n{out}\nstderr:\n{err:?}");
    assert!(out.contains("watchdog TRIPPED"), "{out}");
    let rows = read_log(&log);
    assert!(
        rows.iter().all(|r| r.state == "watchdog"),
        "latched until the switch cycles"
    );
    assert!(
        out.contains("final state: watchdog; alarms: watchdog\n"),
        "{out}"
    );

    stop.store(true, Ordering::Relaxed);
    let _ = standin.kill();
    let _ = standin.wait();
}
