//! The man in the middle of the hostile-line rows (`tests/peers/mitm_proxy.py`) checked on
//! real ptys with `acc board-sim` behind it, before the fault matrix and the soak trust it:
//!
//! - with its faults off it is transparent: every reply through it is byte for byte the
//!   reply the board gives directly, to a raw client here and to `mbpoll` (libmodbus, a
//!   Modbus client we did not write);
//! - with `--corrupt 1 --kinds flip` every reply differs from the board's by exactly one
//!   bit of a data register (of the echoed address or value of a write) and carries a valid
//!   Modbus CRC, computed here independently of the proxy; its events file names that bit;
//! - with `--delay-reads 3` every status read is handed the reply of three reads earlier:
//!   the `SAMPLE_SEQ` the client sees lags the board's by three reads, and is fresh again
//!   when the delay is switched off.
//!
//! The proxy needs `python3` (standard library only), `mbpoll` is installed by `.ci/deps`.
//! When one is missing the test prints `SKIP: …` and returns, unless `CI` is set.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::e2e_support::{peer_ready, root, spawn_board_sim};
use acc_pmc::serial::configure_pty;
use acc_pmc::serialport::TTYPort;

/// Modbus CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF), bit by bit: written here,
/// not taken from the proxy or from acc-pmc.
fn crc16(data: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &b in data {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

fn with_crc(body: &[u8]) -> Vec<u8> {
    let c = crc16(body);
    let mut f = body.to_vec();
    f.extend([(c & 0xFF) as u8, (c >> 8) as u8]);
    f
}

fn crc_valid(frame: &[u8]) -> bool {
    frame.len() >= 4 && with_crc(&frame[..frame.len() - 2]) == frame
}

/// Register `i` of an FC03/FC04 reply.
fn reg(frame: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([frame[3 + 2 * i], frame[4 + 2 * i]])
}

const SAMPLE_SEQ: usize = 7;

/// A raw Modbus RTU client on a pty: one request, one reply, framed by function code.
struct Raw(TTYPort);

impl Raw {
    fn open(path: &str) -> Raw {
        let mut port = acc_pmc::serialport::new(path, 115_200)
            .open_native()
            .unwrap_or_else(|e| panic!("open {path}: {e}"));
        configure_pty(&mut port, 115_200).expect("configure");
        Raw(port)
    }

    /// Send `body` (slave, function, data) with its CRC; the whole reply, or what came
    /// within a second.
    fn transact(&mut self, body: &[u8]) -> Vec<u8> {
        self.0.write_all(&with_crc(body)).expect("write request");
        let end = Instant::now() + Duration::from_secs(1);
        let mut got = Vec::new();
        let mut buf = [0u8; 256];
        while Instant::now() < end {
            let want = match got.get(1) {
                Some(fc) if fc & 0x80 != 0 => 5,
                Some(3 | 4) => got.get(2).map_or(usize::MAX, |&n| 5 + usize::from(n)),
                Some(_) => 8,
                None => usize::MAX,
            };
            if got.len() >= want {
                break;
            }
            match self.0.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => panic!("read: {e}"),
            }
        }
        got
    }

    /// FC04: input registers 0…14.
    fn read_input(&mut self) -> Vec<u8> {
        self.transact(&[1, 4, 0, 0, 0, 15])
    }

    /// FC03: holding registers 0…4.
    fn read_holding(&mut self) -> Vec<u8> {
        self.transact(&[1, 3, 0, 0, 0, 5])
    }

    /// FC06: `WATCHDOG_MS` = 500 (its value at power-up: the board does not change).
    fn write_watchdog(&mut self) -> Vec<u8> {
        self.transact(&WRITE_WATCHDOG)
    }
}

const WRITE_WATCHDOG: [u8; 6] = [1, 6, 0, 3, 0x01, 0xF4];

/// The proxy process, stopped with SIGTERM (it then writes its counters) on drop.
struct Proxy {
    child: Child,
    pty: String,
}

impl Proxy {
    fn start(upstream: &str, args: &[&str]) -> Proxy {
        let mut child = Command::new("python3")
            .arg(root().join("tests/peers/mitm_proxy.py"))
            .args(["--upstream", upstream])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn python3");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("the proxy's first line");
        let pty = line
            .trim()
            .strip_prefix("PTY ")
            .unwrap_or_else(|| panic!("the proxy said {line:?}, not `PTY <path>`"))
            .to_string();
        Proxy { child, pty }
    }

    fn signal(&self, sig: &str) {
        let ok = Command::new("kill")
            .args(["-s", sig, &self.child.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "kill -s {sig}");
        // The handler runs between two of the proxy's loop turns (20 ms at most).
        std::thread::sleep(Duration::from_millis(100));
    }

    /// Stop it and return its counters.
    fn stop(mut self, stats: &Path) -> serde_json::Value {
        self.signal("TERM");
        let _ = self.child.wait();
        let text = std::fs::read_to_string(stats).expect("the proxy's stats file");
        serde_json::from_str(&text).expect("stats JSON")
    }
}

impl Drop for Proxy {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn python_ready() -> bool {
    peer_ready("python3", Command::new("python3").arg("--version"))
}

fn events(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .expect("events file")
        .lines()
        .map(|l| serde_json::from_str(l).expect("event JSON"))
        .collect()
}

/// `mbpoll` (RTU, slave 1, 8N1, PDU addressing, one poll) on `path`: the values read.
fn mbpoll_values(path: &str, table: &str, count: &str) -> Vec<i64> {
    let out = Command::new("mbpoll")
        .args(["-m", "rtu", "-a", "1", "-b", "19200", "-P", "none"])
        .args(["-d", "8", "-s", "1", "-0", "-1", "-o", "1"])
        .args(["-t", table, "-r", "0", "-c", count])
        .arg(path)
        .output()
        .expect("run mbpoll");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "mbpoll on {path}: {text}");
    text.lines()
        .filter(|l| l.trim_start().starts_with('['))
        .filter_map(|l| l.split(':').nth(1))
        .filter_map(|v| v.split_whitespace().next())
        .filter_map(|v| v.parse().ok())
        .collect()
}

fn tmp() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let stats = dir.path().join("stats.json");
    let ev = dir.path().join("events.jsonl");
    (dir, stats, ev)
}

#[test]
fn with_its_faults_off_the_proxy_is_transparent() {
    if !python_ready() {
        return;
    }
    let mbpoll = peer_ready("mbpoll", Command::new("mbpoll").arg("-V"));
    // Machine time waits for ACC_REQUEST, which nobody sets: every register stays put.
    let (_board, board_pty) = spawn_board_sim(&[]);
    let (direct4, direct3) = {
        let mut raw = Raw::open(&board_pty);
        (raw.read_input(), raw.read_holding())
    };
    assert!(crc_valid(&direct4) && direct4.len() == 35, "{direct4:?}");
    assert!(crc_valid(&direct3) && direct3.len() == 15, "{direct3:?}");
    let mb_direct = mbpoll.then(|| {
        (
            mbpoll_values(&board_pty, "3", "15"),
            mbpoll_values(&board_pty, "4", "5"),
        )
    });

    // Every fault armed, but off until SIGUSR1.
    let (_dir, stats, ev) = tmp();
    let proxy = Proxy::start(
        &board_pty,
        &[
            "--corrupt",
            "1",
            "--delay-reads",
            "2",
            "--start",
            "off",
            "--stats",
            stats.to_str().expect("utf-8"),
            "--events",
            ev.to_str().expect("utf-8"),
        ],
    );
    assert_ne!(proxy.pty, board_pty);
    {
        let mut raw = Raw::open(&proxy.pty);
        for _ in 0..5 {
            assert_eq!(raw.read_input(), direct4, "FC04 through the proxy");
            assert_eq!(raw.read_holding(), direct3, "FC03 through the proxy");
            assert_eq!(raw.write_watchdog(), with_crc(&WRITE_WATCHDOG), "FC06 echo");
        }
    }
    if let Some((input, holding)) = &mb_direct {
        assert_eq!(input.len(), 15);
        assert_eq!(&mbpoll_values(&proxy.pty, "3", "15"), input);
        assert_eq!(&mbpoll_values(&proxy.pty, "4", "5"), holding);
    }
    assert!(events(&ev).is_empty(), "nothing altered while off");
    // Switched on, the same faults do act (the switch is what kept them off).
    proxy.signal("USR1");
    {
        let mut raw = Raw::open(&proxy.pty);
        let altered = (0..5).filter(|_| raw.read_holding() != direct3).count();
        assert_eq!(altered, 5, "--corrupt 1 alters every reply once on");
    }
    let s = proxy.stop(&stats);
    let reads = if mb_direct.is_some() { 6 } else { 5 };
    assert_eq!(s["fc04_reads"], reads, "{s}");
    assert_eq!(s["requests"], s["replies"], "{s}");
    assert_eq!(s["no_reply"], 0, "{s}");
    assert_eq!(s["altered_replies"], 5, "{s}");
    assert_eq!(s["episodes"], 1, "{s}");
}

#[test]
fn every_flipped_reply_differs_by_one_bit_and_has_a_valid_crc() {
    if !python_ready() {
        return;
    }
    let (_board, board_pty) = spawn_board_sim(&[]);
    let (direct4, direct3, echo) = {
        let mut raw = Raw::open(&board_pty);
        (raw.read_input(), raw.read_holding(), raw.write_watchdog())
    };
    assert_eq!(echo, with_crc(&WRITE_WATCHDOG));
    let (_dir, stats, ev) = tmp();
    let proxy = Proxy::start(
        &board_pty,
        &[
            "--corrupt",
            "1",
            "--kinds",
            "flip",
            "--seed",
            "7",
            "--start",
            "on",
            "--stats",
            stats.to_str().expect("utf-8"),
            "--events",
            ev.to_str().expect("utf-8"),
        ],
    );
    // (reply, the board's reply, first data byte) per request, in order.
    let mut seen = Vec::new();
    {
        let mut raw = Raw::open(&proxy.pty);
        for _ in 0..10 {
            seen.push((raw.read_input(), &direct4, 3));
            seen.push((raw.read_holding(), &direct3, 3));
            seen.push((raw.write_watchdog(), &echo, 2));
        }
    }
    let log = events(&ev);
    assert_eq!(log.len(), seen.len(), "one event per reply: {log:?}");
    let mut reads = 0;
    for (k, ((got, board, data_from), e)) in seen.iter().zip(&log).enumerate() {
        assert_eq!(got.len(), board.len(), "reply {k}: {got:?}");
        assert!(crc_valid(got), "reply {k}: CRC not valid: {got:?}");
        let body = got.len() - 2;
        let diff: Vec<(usize, u32)> = (0..body)
            .filter(|&i| got[i] != board[i])
            .map(|i| (i, (got[i] ^ board[i]).count_ones()))
            .collect();
        assert_eq!(diff.len(), 1, "reply {k}: one byte differs: {diff:?}");
        let (byte, bits) = diff[0];
        assert_eq!(bits, 1, "reply {k}: one bit differs");
        assert!(byte >= *data_from, "reply {k}: the header is kept ({byte})");
        // The event names that bit.
        assert_eq!(e["kind"], "flip", "{e}");
        assert_eq!(e["fc"], u64::from(board[1]), "{e}");
        let field = (byte - data_from) / 2;
        let bit = (got[byte] ^ board[byte]).trailing_zeros() as u64
            + if (byte - data_from) % 2 == 0 { 8 } else { 0 };
        assert_eq!(e["bit"], bit, "reply {k}: {e}");
        if board[1] == 6 {
            assert_eq!(e["register"], 3, "the echoed address: {e}");
            assert!(e["read_index"].is_null(), "{e}");
        } else {
            assert_eq!(e["register"], field as u64, "reply {k}: {e}");
            assert_eq!(e["before"], u64::from(reg(board, field)), "{e}");
            assert_eq!(e["after"], u64::from(reg(got, field)), "{e}");
            if board[1] == 4 {
                assert_eq!(e["read_index"], reads, "{e}");
                reads += 1;
            } else {
                assert!(e["read_index"].is_null(), "{e}");
            }
        }
    }
    let s = proxy.stop(&stats);
    assert_eq!(s["altered"]["flip"], 30, "{s}");
    assert_eq!(s["altered_fc04_replies"], 10, "{s}");
}

#[test]
fn a_delay_of_three_reads_hands_over_the_reply_of_three_reads_earlier() {
    if !python_ready() {
        return;
    }
    let (_board, board_pty) = spawn_board_sim(&[]);
    let (_dir, stats, ev) = tmp();
    let proxy = Proxy::start(
        &board_pty,
        &[
            "--delay-reads",
            "3",
            "--start",
            "off",
            "--stats",
            stats.to_str().expect("utf-8"),
            "--events",
            ev.to_str().expect("utf-8"),
        ],
    );
    let mut raw = Raw::open(&proxy.pty);
    // ACC_REQUEST starts the machine: a new power sample (SAMPLE_SEQ) every 25 ms of wall
    // time at 4x; reads 60 ms apart see it move.
    assert_eq!(
        raw.transact(&[1, 6, 0, 2, 0, 1]),
        with_crc(&[1, 6, 0, 2, 0, 1])
    );
    std::thread::sleep(Duration::from_millis(200));
    let mut read = || {
        std::thread::sleep(Duration::from_millis(60));
        let r = raw.read_input();
        assert!(crc_valid(&r) && r.len() == 35, "{r:?}");
        r
    };
    let fresh: Vec<Vec<u8>> = (0..6).map(|_| read()).collect();
    let seq = |f: &Vec<u8>| reg(f, SAMPLE_SEQ);
    assert!(
        fresh.windows(2).all(|w| seq(&w[1]) >= seq(&w[0])) && seq(&fresh[5]) > seq(&fresh[0]),
        "SAMPLE_SEQ moves: {:?}",
        fresh.iter().map(seq).collect::<Vec<_>>()
    );
    proxy.signal("USR1");
    let delayed: Vec<Vec<u8>> = (0..8).map(|_| read()).collect();
    // The first three delayed reads are the replies of reads 3, 4, 5, byte for byte.
    assert_eq!(
        delayed[..3],
        fresh[3..],
        "the replies of three reads earlier"
    );
    assert!(
        seq(&delayed[3]) >= seq(&fresh[5]),
        "then the ones the client never saw"
    );
    proxy.signal("USR2");
    let after = read();
    let log = events(&ev);
    assert_eq!(log.len(), 8, "one delay event per read while on: {log:?}");
    for (k, e) in log.iter().enumerate() {
        assert_eq!(e["kind"], "delay", "{e}");
        assert_eq!(e["read_index"], 6 + k as u64, "{e}");
        assert_eq!(e["register"], SAMPLE_SEQ as u64, "{e}");
        assert_eq!(e["after"], u64::from(seq(&delayed[k])), "delivered: {e}");
        // What the client is handed now, the board gave three reads ago.
        if k >= 3 {
            assert_eq!(e["after"], log[k - 3]["before"], "{e}");
        } else {
            assert_eq!(e["after"], u64::from(seq(&fresh[3 + k])), "{e}");
        }
    }
    // SAMPLE_SEQ lags by three reads while on, and is fresh again once off.
    let lag_seen = seq(&delayed[7]);
    let fresh_then = log[7]["before"].as_u64().expect("before");
    assert!(
        u64::from(lag_seen) < fresh_then,
        "seen {lag_seen}, board {fresh_then}"
    );
    assert!(
        u64::from(seq(&after)) >= fresh_then,
        "fresh after SIGUSR2: {} < {fresh_then}",
        seq(&after)
    );
    drop(raw);
    let s = proxy.stop(&stats);
    assert_eq!(s["altered"]["delay"], 8, "{s}");
    assert_eq!(s["fc04_reads"], 15, "{s}");
}
