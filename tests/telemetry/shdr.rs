//! The MTConnect SHDR adapter of `acc sim --shdr` against an independent SHDR reader
//! (`tests/peers/shdr_reader.py`, written from the SHDR line format, not from our code):
//! the snapshot has every item, each period's values equal the run log's row, the tool
//! change shows, conditions parse, and `* PING` is answered `* PONG 10000`.
//!
//! The `acc sim` test paces the run itself (`--step-stdin`): the run does not pass its
//! first period before the reader has connected, whatever the machine's load.

use std::io::Write as _;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::e2e_support::{
    acc_bin, load_tolerant_config, one_at_a_time, peer_ready, read_log, root, spawn_board_sim,
    spawn_run_for,
};

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

const CONDITIONS: &str = "link_cond,power_cond,watchdog_cond,board_reset_cond,overload_cond";

#[test]
fn acc_sim_shdr_against_an_independent_reader() {
    if !peer_ready("python3", Command::new("python3").arg("--version")) {
        return;
    }
    let _serial = one_at_a_time();
    let bin = acc_bin();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    // The reader first (it retries until the adapter listens and says `connected` on
    // stderr), then the run, paced by the test: one period, then the rest once the reader
    // is connected, about 500 periods per second.
    let mut reader = Command::new("python3")
        .arg(root().join("tests/peers/shdr_reader.py"))
        .args(["127.0.0.1", &port.to_string(), "--conditions", CONDITIONS])
        .args(["--seconds", "60"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 reader");
    let reader_err = reader.stderr.take().expect("stderr piped");
    let (tx, said) = std::sync::mpsc::channel();
    let reader_log = std::thread::spawn(move || {
        let mut all = String::new();
        for line in
            std::io::BufRead::lines(std::io::BufReader::new(reader_err)).map_while(Result::ok)
        {
            let _ = tx.send(line.clone());
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let mut sim = Command::new(&bin)
        .args([
            "sim",
            "two_tools",
            "--no-plot",
            "--step-stdin",
            "--shdr",
            &addr,
        ])
        .arg("--out")
        .arg(dir.path())
        .current_dir(root())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("acc sim");
    let mut steps = sim.stdin.take().expect("stdin piped");
    writeln!(steps, "1").expect("step");
    let t0 = Instant::now();
    loop {
        let left = Duration::from_secs(30).saturating_sub(t0.elapsed());
        match said.recv_timeout(left) {
            Ok(line) if line.trim() == "connected" => break,
            Ok(_) => {}
            Err(e) => panic!("the SHDR reader did not connect: {e}"),
        }
    }
    for _ in 0..1000 {
        if writeln!(steps, "10").is_err() {
            break; // the run has ended
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = writeln!(steps, "all");
    drop(steps);
    let sim = sim.wait_with_output().expect("acc sim");
    let stdout = String::from_utf8_lossy(&sim.stdout);
    assert!(
        sim.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let out = reader.wait_with_output().expect("reader output");
    let text = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value = serde_json::from_str(text.trim()).unwrap_or_else(|e| {
        panic!(
            "reader printed no JSON ({e}): {text}\n{}",
            reader_log.join().unwrap_or_default()
        )
    });
    let rows = read_log(&dir.path().join("run.csv"));
    let n = rows.len();
    assert!(n > 300, "{n} rows");

    assert_eq!(v["errors"].as_array().map(Vec::len), Some(0), "{v}");
    assert_eq!(v["pong_ms"], 10000, "{v}");
    // The snapshot: every item.
    let first = v["first"].as_object().expect("snapshot line");
    for item in [
        "avail",
        "execution",
        "acc_state",
        "Fovr",
        "Fovr_cmd",
        "Fovr_op",
        "path_feedrate",
        "Srpm",
        "Spower",
        "Fc",
        "Fr",
        "Kc",
        "Tool",
        "program",
        "line",
        "feed_hold",
        "acc_period",
    ] {
        assert!(first.contains_key(item), "snapshot lacks {item}: {first:?}");
    }
    // Every condition was sent (in the snapshot at least) with a valid level.
    for c in CONDITIONS.split(',') {
        let levels = v["conditions"][c].as_array().expect("condition sent");
        assert!(levels
            .iter()
            .all(|l| ["NORMAL", "WARNING", "FAULT"].contains(&l[0].as_str().unwrap_or(""))));
    }
    // The states after each period, rebuilt from the changes, equal the run log.
    let periods: Vec<u64> = v["items"]["acc_period"]
        .as_array()
        .expect("periods")
        .iter()
        .filter_map(|p| p.as_str()?.parse().ok())
        .collect();
    assert!(
        periods.len() * 10 >= n * 9,
        "{} of {n} periods seen",
        periods.len()
    );
    // No period lost after the reader connected: consecutive indices.
    let tail = &periods[1..];
    assert!(
        tail.windows(2).all(|w| w[1] == w[0] + 1),
        "periods not consecutive"
    );
    assert_eq!(*periods.last().expect("last"), rows[n - 1].period);
    // The last value of each item equals the last row.
    let last = |item: &str| -> String {
        v["items"][item]
            .as_array()
            .and_then(|a| a.last())
            .and_then(|x| x.as_str())
            .unwrap_or("")
            .to_string()
    };
    let r = &rows[n - 1];
    let f1 = |x: Option<f64>| x.map_or("UNAVAILABLE".to_string(), |x| format!("{x:.1}"));
    assert_eq!(last("Fc"), f1(r.force_n));
    assert_eq!(last("Fr"), f1(r.force_ref_n));
    assert_eq!(
        last("Fovr_cmd"),
        r.override_cmd_pct
            .map_or("UNAVAILABLE".into(), |x| x.to_string())
    );
    // Both tools of the program appeared, in the log's order.
    let tools_seen: Vec<String> = v["items"]["Tool"]
        .as_array()
        .expect("tool")
        .iter()
        .filter_map(|x| Some(x.as_str()?.to_string()))
        .collect();
    let mut log_tools: Vec<String> = Vec::new();
    for t in rows.iter().filter_map(|r| r.tool) {
        if log_tools.last() != Some(&t.to_string()) {
            log_tools.push(t.to_string());
        }
    }
    assert!(
        log_tools.len() >= 2,
        "two_tools has a tool change: {log_tools:?}"
    );
    assert!(
        tools_seen.ends_with(&log_tools[1..]),
        "SHDR tools {tools_seen:?} vs log {log_tools:?}"
    );
    // Value by value: the number of Fc changes equals the number of distinct consecutive
    // Fc values in the rows the reader saw.
    let seen_from = periods[0] as usize;
    let mut changes = 0;
    let mut prev: Option<String> = None;
    for r in &rows[seen_from..] {
        let s = f1(r.force_n);
        if prev.as_ref() != Some(&s) {
            changes += 1;
            prev = Some(s);
        }
    }
    let got = v["items"]["Fc"].as_array().map_or(0, Vec::len);
    // The snapshot's value counts once more when it equals the first row's.
    assert!(
        got == changes || got == changes + 1,
        "{got} Fc values over SHDR, {changes} in the log"
    );
    assert!(stdout.contains("telemetry: SHDR"), "{stdout}");
}

/// Start the independent reader on `port` for at most `seconds`.
fn reader(port: u16, seconds: u32) -> std::process::Child {
    Command::new("python3")
        .arg(root().join("tests/peers/shdr_reader.py"))
        .args(["127.0.0.1", &port.to_string(), "--conditions", CONDITIONS])
        .args(["--seconds", &seconds.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 reader")
}

fn reader_json(c: std::process::Child) -> serde_json::Value {
    let out = c.wait_with_output().expect("reader output");
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.trim()).unwrap_or_else(|e| {
        panic!(
            "reader printed no JSON ({e}): {text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

/// `acc run --shdr` (the threaded runtime: the logger thread publishes on the tap) against
/// `acc board-sim --shdr` over a pty, 4× time, 12 s of machine time: both adapters serve the
/// reader; the controller's adapter ends on the run log's last row; `--mqtt` to a port
/// where no broker listens does not cost the run a period.
#[test]
fn acc_run_and_board_sim_shdr_over_a_pty() {
    if !peer_ready("python3", Command::new("python3").arg("--version")) {
        return;
    }
    // Alone (a pty closed loop at 4× is timing-sensitive on 2 cores).
    let _serial = one_at_a_time();
    let _ = acc_bin();
    let dir = tempfile::tempdir().expect("tempdir");
    let (p_run, p_board) = (free_port(), free_port());
    let board_addr = format!("127.0.0.1:{p_board}");
    let (board, pty) = spawn_board_sim(&["--shdr", &board_addr, "--pace", "controller"]);
    let r_board = reader(p_board, 8);
    let r_run = reader(p_run, 30);
    let log = dir.path().join("run.csv");
    let run_addr = format!("127.0.0.1:{p_run}");
    let no_broker = format!("mqtt://127.0.0.1:{}/acc", free_port());
    // No broker at --mqtt: the run keeps its period, telemetry keeps retrying.
    let config = load_tolerant_config(dir.path(), "");
    let run = spawn_run_for(
        &config.to_string_lossy(),
        &pty,
        &log,
        "12",
        &["--shdr", &run_addr, "--mqtt", &no_broker],
    );
    // A hang guard: 12 s of machine time is 3 s of wall time on an idle host.
    let (code, out, err) = run.finish(Duration::from_secs(120));
    assert_eq!(code, Some(0), "{out}\n{err:?}");
    drop(board);
    let v = reader_json(r_run);
    let rows = read_log(&log);
    let n = rows.len();
    assert!(n >= 100, "{n} rows");
    assert_eq!(v["errors"].as_array().map(Vec::len), Some(0), "{v}");
    assert_eq!(v["pong_ms"], 10000);
    let periods: Vec<u64> = v["items"]["acc_period"]
        .as_array()
        .expect("periods")
        .iter()
        .filter_map(|p| p.as_str()?.parse().ok())
        .collect();
    // The reader (a Python process) connects when it gets to: counted from the first
    // period it saw, so the figure does not depend on how fast it started.
    let first = periods.first().copied().unwrap_or(u64::MAX);
    let expected = rows.iter().filter(|r| r.period >= first).count();
    assert!(
        periods.len() * 10 >= expected * 9 && expected * 2 >= n,
        "{} of the {expected} periods from period {first} on ({n} in all)",
        periods.len()
    );
    assert_eq!(periods.last().copied(), Some(rows[n - 1].period));
    let last = |item: &str| {
        v["items"][item]
            .as_array()
            .and_then(|a| a.last())
            .and_then(|x| x.as_str())
            .unwrap_or("")
            .to_string()
    };
    let r = &rows[n - 1];
    assert_eq!(
        last("Fovr"),
        r.override_applied_pct
            .map_or("UNAVAILABLE".into(), |x| x.to_string())
    );
    assert_eq!(
        last("Tool"),
        r.tool.map_or("UNAVAILABLE".into(), |x| x.to_string())
    );
    assert!(
        v["items"]["execution"]
            .as_array()
            .is_some_and(|a| a.iter().any(|x| x == "ACTIVE")),
        "ACC drove the override: {v}"
    );
    assert!(out.contains("telemetry: SHDR"), "{out}");
    // Every period has its row with the broker absent.
    let periods_line: usize = crate::e2e_support::field(&out, "periods")
        .and_then(|v| v.parse().ok())
        .expect("summary line `periods: N`");
    assert_eq!(n, periods_line);
    // Counted in machine time, not wall time: one row per period of the clock (a period the
    // loaded host skipped has its flagged row), and the run ends with the first period at
    // 12 s.
    assert!(
        rows.iter().enumerate().all(|(i, r)| r.period == i as u64),
        "one row per period"
    );
    let ran: Vec<_> = rows
        .iter()
        .filter(|r| !r.flags.contains("skipped"))
        .collect();
    assert!(ran.len() >= 60, "{} of {n} periods ran", ran.len());
    let (last, before) = (ran[ran.len() - 1].t_s, ran[ran.len() - 2].t_s);
    assert!(
        last > 11.95 && before < 11.95,
        "the run ended at t = {last} s (the period before at {before} s), not at 12 s"
    );
    assert!(out.contains(", 0 connections"), "{out}");
    // The machine side served the reader too (board registers every period).
    let b = reader_json(r_board);
    assert_eq!(b["errors"].as_array().map(Vec::len), Some(0), "{b}");
    let bp = b["items"]["acc_period"].as_array().map_or(0, Vec::len);
    assert!(bp > 50, "{bp} board-sim periods over SHDR");
}
