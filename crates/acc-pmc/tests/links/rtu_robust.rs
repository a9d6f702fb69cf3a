//! The board's RTU server under abuse, over a real pty pair: every malformed write answers
//! exception 03, and a flood of requests whose replies nobody reads never kills the serving
//! thread (replies are dropped and counted, new requests are answered once the client reads).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use acc_pmc::emu::{BoardLogic, PtyBoard};
use acc_pmc::regs::OverrideResolution;
use acc_pmc::rtu::codec::{append_crc, crc_ok};
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::Board;
use serialport::TTYPort;

fn spawn_board() -> PtyBoard {
    let mut logic = BoardLogic::new(OverrideResolution::Percent10);
    logic.set_acc_switch(true);
    logic.set_cycle_active(true);
    logic.set_operator_override_pct(70);
    logic.push_power_sample(5_000);
    match PtyBoard::spawn(logic, 1, 115_200) {
        Ok(p) => p,
        Err(e) => panic!("cannot create a pty pair: {e}"),
    }
}

fn frame(body: &[u8]) -> Vec<u8> {
    let mut f = body.to_vec();
    append_crc(&mut f);
    f
}

/// Write all of `bytes`, retrying while the pty's buffer is full (the port's write timeout).
fn write_all_patiently(port: &mut TTYPort, bytes: &[u8]) {
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut off = 0;
    while off < bytes.len() {
        match port.write(&bytes[off..]) {
            Ok(n) => off += n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) => panic!("write to the board failed: {e}"),
        }
        assert!(
            Instant::now() < deadline,
            "the board stopped reading requests"
        );
    }
}

/// Read until the line has been silent for `quiet`; returns the bytes.
fn read_until_quiet(port: &mut TTYPort, quiet: Duration) -> Vec<u8> {
    let mut out = Vec::new();
    let mut last = Instant::now();
    let mut chunk = [0u8; 4096];
    while last.elapsed() < quiet {
        match port.read(&mut chunk) {
            Ok(n) if n > 0 => {
                out.extend_from_slice(&chunk[..n]);
                last = Instant::now();
            }
            _ => {}
        }
    }
    out
}

/// Send one raw request and return the raw reply (read until silence).
fn transact(port: &mut TTYPort, request: &[u8]) -> Vec<u8> {
    write_all_patiently(port, request);
    read_until_quiet(port, Duration::from_millis(150))
}

fn exception_reply(function: u8, code: u8) -> Vec<u8> {
    frame(&[1, function | 0x80, code])
}

/// FC16 header: slave 1, address 0, `quantity`, `byte_count`, then `data`.
fn fc16(quantity: u16, byte_count: u8, data: &[u8]) -> Vec<u8> {
    let mut b = vec![1, 16, 0, 0];
    b.extend_from_slice(&quantity.to_be_bytes());
    b.push(byte_count);
    b.extend_from_slice(data);
    frame(&b)
}

#[test]
fn malformed_writes_answer_exception_03_and_leave_the_registers() {
    let mut pty = spawn_board();
    let mut port = pty.take_client_port().expect("client end");
    let cases: Vec<(&str, Vec<u8>)> = vec![
        // 124 registers, 248 data bytes: a 257-byte frame, beyond the Modbus maximum.
        ("quantity 124", fc16(124, 248, &[0; 248])),
        ("quantity 124, short data", fc16(124, 8, &[0; 8])),
        (
            "byte count 6 for 2 registers",
            fc16(2, 6, &[0, 50, 0, 9, 0, 0]),
        ),
        ("byte count 2 for 2 registers", fc16(2, 2, &[0, 50])),
        // The byte count claims 4 bytes, 6 follow: the frame ends at the silence.
        (
            "byte count 4, 6 bytes sent",
            fc16(2, 4, &[0, 50, 0, 9, 0, 0]),
        ),
        ("quantity 0", fc16(0, 0, &[])),
    ];
    for (what, req) in cases {
        let reply = transact(&mut port, &req);
        assert_eq!(reply, exception_reply(16, 3), "{what}: {reply:02X?}");
    }
    // Nothing was written.
    assert_eq!(
        pty.with_board(|b| (b.override_cmd_pct(), b.heartbeat())),
        (100, 0)
    );
    // A well-formed write still works and the bad CRC and other slaves stay silent.
    let ok = fc16(2, 4, &[0, 50, 0, 9]);
    let reply = transact(&mut port, &ok);
    assert_eq!(reply, frame(&[1, 16, 0, 0, 0, 2]));
    let mut bad_crc = fc16(124, 8, &[0; 8]);
    let n = bad_crc.len();
    bad_crc[n - 1] ^= 0xFF;
    assert!(
        transact(&mut port, &bad_crc).is_empty(),
        "bad CRC: no answer"
    );
    let mut other = fc16(0, 0, &[]);
    other[0] = 2;
    let other = frame(&other[..other.len() - 2]);
    assert!(
        transact(&mut port, &other).is_empty(),
        "other slave: no answer"
    );
    // Reads with a zero count: exception 03 too.
    let reply = transact(&mut port, &frame(&[1, 4, 0, 0, 0, 0]));
    assert_eq!(reply, exception_reply(4, 3));
    assert_eq!(
        pty.with_board(|b| (b.override_cmd_pct(), b.heartbeat())),
        (50, 9)
    );
    let stats = pty.stop().expect("server alive");
    assert_eq!(stats.exceptions, 7, "{stats:?}");
    assert_eq!(stats.requests, 8, "{stats:?}");
    assert_eq!(stats.other_slave, 1, "{stats:?}");
}

#[test]
fn a_flood_of_unread_requests_never_kills_the_server() {
    const FLOOD: usize = 5_000;
    let mut pty = spawn_board();
    let mut port = pty.take_client_port().expect("client end");
    // 5 000 reads of the 15 input registers (35-byte replies), none of them read back.
    let request = frame(&[1, 4, 0, 0, 0, 15]);
    let mut all = Vec::with_capacity(request.len() * FLOOD);
    for _ in 0..FLOOD {
        all.extend_from_slice(&request);
    }
    let started = Instant::now();
    write_all_patiently(&mut port, &all);
    // Let the server work through what is queued, then take the replies that got through.
    std::thread::sleep(Duration::from_millis(300));
    let delivered = read_until_quiet(&mut port, Duration::from_millis(200));
    let flood_time = started.elapsed();
    assert!(
        flood_time < Duration::from_secs(30),
        "the flood took {flood_time:?}"
    );
    // The server is alive: new requests get correct answers through the production client.
    pty.with_board(|b| b.push_power_sample(7_777));
    let mut link = RtuBoard::new(port, RtuLinkConfig::default());
    let s = link.read_status().expect("answered after the flood");
    assert_eq!(s.spindle_power_w, 7_777);
    assert!(s.is_v2());
    link.write_override(120, 3).expect("write after the flood");
    assert_eq!(pty.with_board(|b| b.override_cmd_pct()), 120);
    let stats = pty
        .stop()
        .expect("the serving thread is alive and ends cleanly");
    // Every request of the flood was answered or dropped (and counted): none got lost in
    // the framing.
    assert!(stats.requests >= FLOOD as u64 + 2, "{stats:?}");
    assert!(
        stats.replies_dropped > 0,
        "the flood filled the pty: {stats:?}"
    );
    assert_eq!(stats.bytes_discarded, 0, "{stats:?}");
    // What was delivered are correct 35-byte replies (a reply cut short when the buffer
    // filled counts as dropped: skip its bytes).
    let (mut whole, mut i) = (0u64, 0);
    while i + 35 <= delivered.len() {
        let r = &delivered[i..i + 35];
        if crc_ok(r) && r[..3] == [1, 4, 30] {
            whole += 1;
            i += 35;
        } else {
            i += 1;
        }
    }
    assert!(whole > 0);
    assert_eq!(
        whole + stats.replies_dropped + 2,
        stats.requests,
        "delivered + dropped + the two new requests = answered: {stats:?}"
    );
}
