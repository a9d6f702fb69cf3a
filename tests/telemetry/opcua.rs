//! The OPC UA server of `acc sim --opcua` and `acc run --opcua` against two clients we did not
//! write: Python `asyncua` (PyPI; tests/peers/opcua_asyncua.py) and node-opcua (npm;
//! tests/peers/node-opcua/client.js). Each browses the model (docs/opcua.md), reads the
//! values, subscribes to FeedOverride, Acc/Force and Acc/Period and to the events, and every
//! period's override and force it received equal the run log's row of that period.
//!
//! The test paces `acc sim --step-stdin` (one period per line, as tests/live_view.rs) so the
//! client is subscribed before the first period. Skips with a printed reason without a peer;
//! fails under `CI` (`bash .ci/deps` installs both).

use std::io::{BufRead, BufReader, Write as _};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::e2e_support::{
    acc_bin, load_tolerant_config, one_at_a_time, peer_ready, read_log, root, spawn_board_sim,
    spawn_run_for, Proc,
};
use acc_runtime::RunRecord;

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Wait until `proc` accepts connections on `port` (its OPC UA server logs that it started
/// before the socket takes connections, so the port itself is the signal). The deadline only
/// guards a hang (a loaded host starts slowly); a process that ends first fails at once with
/// its stderr.
fn wait_listening(proc: &mut Proc, port: u16, what: &str) {
    let t0 = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        if let Ok(Some(st)) = proc.child.try_wait() {
            proc.drain();
            panic!(
                "{what} ended ({st}) before listening on port {port}: {:?}",
                proc.err_lines
            );
        }
        assert!(
            t0.elapsed() < Duration::from_secs(180),
            "{what} did not listen on port {port} within 180 s"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn asyncua_ready() -> bool {
    peer_ready(
        "python3 with asyncua (pip install asyncua)",
        Command::new("python3").args(["-c", "import asyncua"]),
    )
}

fn node_opcua_ready() -> bool {
    peer_ready(
        "node with node-opcua (npm ci --prefix tests/peers/node-opcua)",
        Command::new("node").current_dir(root()).args([
            "-e",
            "require('./tests/peers/node-opcua/node_modules/node-opcua')",
        ]),
    )
}

/// A peer client whose stdout JSON lines are read on a thread.
struct Peer {
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Peer {
    fn spawn(mut cmd: Command) -> Self {
        let mut child = cmd
            .current_dir(root())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn the peer client");
        let out = child.stdout.take().expect("stdout");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for l in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        Self { child, lines }
    }

    /// The next JSON line with key `key` (at most `within`).
    fn json_with(&mut self, key: &str, within: Duration) -> serde_json::Value {
        let end = Instant::now() + within;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            let line = self
                .lines
                .recv_timeout(left)
                .unwrap_or_else(|_| panic!("the peer printed no `{key}` line in {within:?}"));
            if let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) {
                if v.get(key).is_some() {
                    return v;
                }
            }
        }
    }

    fn exit_code(&mut self) -> Option<i32> {
        let t0 = Instant::now();
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return s.code();
            }
            if t0.elapsed() > Duration::from_secs(60) {
                let _ = self.child.kill();
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Peer {
    /// A failed assertion must not leave the client running (it holds the test's stderr).
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn asyncua(url: &str, until: u64, extra: &[&str]) -> Command {
    let mut c = Command::new("python3");
    c.arg("tests/peers/opcua_asyncua.py")
        .arg(url)
        .args(["--until", &until.to_string()])
        .args(extra);
    c
}

fn node_opcua(url: &str, until: u64, extra: &[&str]) -> Command {
    let mut c = Command::new("node");
    c.arg("tests/peers/node-opcua/client.js")
        .arg(url)
        .args(["--until", &until.to_string()])
        .args(extra);
    c
}

/// The browse result: the 40501 path, the AnalogUnitRange with EURange 0..150, the spindle
/// and the Acc object's variables.
fn check_browse(b: &serde_json::Value) {
    assert!(
        b["feed_override"]
            .as_str()
            .is_some_and(|s| s.ends_with("s=MachineTool/Monitoring/Channel1/FeedOverride")),
        "{b}"
    );
    // asyncua prints `i=17570`, node-opcua `ns=0;i=17570`.
    assert_eq!(
        b["feed_override_type"]
            .as_str()
            .map(|t| t.trim_start_matches("ns=0;")),
        Some("i=17570"),
        "AnalogUnitRangeType: {b}"
    );
    let eurange: Vec<f64> = b["eurange"]
        .as_array()
        .map(|v| v.iter().filter_map(serde_json::Value::as_f64).collect())
        .unwrap_or_default();
    assert_eq!(eurange, [0.0, 150.0], "EURange: {b}");
    let names = |k: &str| -> Vec<String> {
        b[k].as_array()
            .expect("names")
            .iter()
            .map(|v| v.as_str().unwrap_or("").to_string())
            .collect()
    };
    for n in ["Override", "IsRotating", "ActPower"] {
        assert!(names("spindle").contains(&n.to_string()), "spindle {b}");
    }
    for n in [
        "Force",
        "ForceRef",
        "KcHat",
        "OverrideCommanded",
        "OverrideOperator",
        "State",
        "Tool",
        "Program",
        "Block",
        "Period",
    ] {
        assert!(names("acc").contains(&n.to_string()), "Acc lacks {n}: {b}");
    }
}

/// Every sample equals the run log's row of its period; the periods are consecutive.
/// Returns the periods seen.
fn check_samples(result: &serde_json::Value, rows: &[RunRecord]) -> Vec<u64> {
    let samples = result["samples"].as_array().expect("samples");
    let mut periods = Vec::new();
    for s in samples {
        let p = s["period"].as_u64().expect("period");
        let row = rows
            .iter()
            .find(|r| r.period == p)
            .unwrap_or_else(|| panic!("period {p} is not in the run log"));
        let want_fo = row.override_applied_pct.map(f64::from);
        assert_eq!(
            s["feed_override"].as_f64(),
            want_fo,
            "period {p}: FeedOverride {s} against the run log's {want_fo:?}"
        );
        // The peers print the double they received in its shortest round-trip form;
        // serde_json's default parser (no `float_roundtrip`) may land one ulp off it.
        let want_f = row.force_n.filter(|f| f.is_finite());
        let same = match (s["force"].as_f64(), want_f) {
            (Some(a), Some(b)) => (a - b).abs() <= 4.0 * f64::EPSILON * b.abs(),
            (a, b) => a == b,
        };
        assert!(
            same,
            "period {p}: Force {s} against the run log's {want_f:?}"
        );
        periods.push(p);
    }
    assert!(
        periods.windows(2).all(|w| w[1] == w[0] + 1),
        "a period is missing or repeated: {periods:?}"
    );
    periods
}

/// `acc sim overload_alarm --step-stdin --opcua …` and one peer: the peer subscribes, then the
/// test lets `periods` periods run one line at a time, waits for the peer's result, lets the
/// run finish and compares with the run log.
fn peer_against_paced_sim(peer: fn(&str, u64, &[&str]) -> Command, periods: u64) {
    let _ = acc_bin();
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let out = dir.path().join("run");
    let out_s = out.to_string_lossy().into_owned();
    let mut sim = Proc::spawn_with_stdin(
        &[
            "sim",
            "overload_alarm",
            "--no-plot",
            "--step-stdin",
            "--opcua",
            &url,
            "--out",
            &out_s,
        ],
        false,
        Stdio::piped(),
    );
    let mut steps = sim.child.stdin.take().expect("stdin piped");
    wait_listening(&mut sim, port, "acc sim --opcua");
    let mut client = Peer::spawn(peer(&url, periods - 1, &[]));
    let ready = client.json_with("ready", Duration::from_secs(180));
    check_browse(&ready["browse"]);
    assert_eq!(
        ready["browse"]["tool_read"], "BadWaitingForInitialData",
        "before the first period"
    );
    for _ in 0..periods {
        writeln!(steps, "1").expect("step");
        std::thread::sleep(Duration::from_millis(15));
    }
    let result = client.json_with("samples", Duration::from_secs(90));
    assert_eq!(client.exit_code(), Some(0), "the peer failed");
    // The run may have ended already (the scenario's last period): then the pipe is closed.
    let _ = writeln!(steps, "all");
    drop(steps);
    let (code, stdout, err) = sim.finish(Duration::from_secs(120));
    assert_eq!(code, Some(0), "acc sim: {stdout}\n{err:?}");
    assert!(
        stdout.contains("telemetry: OPC UA server on opc.tcp://127.0.0.1:")
            && stdout.contains("SecurityPolicy None, anonymous"),
        "{stdout}"
    );
    assert!(stdout.contains("telemetry: OPC UA "), "{stdout}");
    let rows = read_log(&out.join("run.csv"));
    let got = check_samples(&result, &rows);
    // Every period the test let run arrived, from the first.
    assert_eq!(
        got,
        (0..periods).collect::<Vec<_>>(),
        "periods received against the periods run"
    );
    let events: Vec<String> = result["events"]
        .as_array()
        .expect("events")
        .iter()
        .filter_map(|e| e["message"].as_str().map(str::to_string))
        .collect();
    assert!(
        events.iter().any(|m| m.starts_with("state - -> ")),
        "no state event: {events:?}"
    );
    // The overload alarm of the scenario comes at period 230.
    if rows
        .iter()
        .take(periods as usize)
        .any(|r| r.alarms & (1 << 4) != 0)
    {
        assert!(
            events.iter().any(|m| m.starts_with("OVERLOAD raised")),
            "no OVERLOAD event: {events:?}"
        );
    }
    eprintln!(
        "{} periods, {} events: {:?}",
        got.len(),
        events.len(),
        &events[..events.len().min(6)]
    );
}

/// Periods the paced tests let run: past the scenario's overload alarm (period 230), before
/// its end (249 periods).
const PACED_PERIODS: u64 = 240;

#[test]
fn asyncua_browses_reads_and_receives_every_period_of_acc_sim() {
    if !asyncua_ready() {
        return;
    }
    peer_against_paced_sim(asyncua, PACED_PERIODS);
}

#[test]
fn node_opcua_browses_reads_and_receives_every_period_of_acc_sim() {
    if !node_opcua_ready() {
        return;
    }
    peer_against_paced_sim(node_opcua, PACED_PERIODS);
}

/// `acc run --opcua` with `acc board-sim --opcua` over a pty: the client subscribed while the
/// run went on receives consecutive periods equal to the run log; board-sim serves too.
fn peer_against_acc_run(peer: fn(&str, u64, &[&str]) -> Command) {
    let _ = acc_bin();
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let (p_run, p_board) = (free_port(), free_port());
    let board_url = format!("opc.tcp://127.0.0.1:{p_board}");
    let (mut board, pty) = spawn_board_sim(&["--opcua", &board_url, "--pace", "controller"]);
    assert!(
        board.wait_for("telemetry: OPC UA server on", Duration::from_secs(20)),
        "board-sim: {:?}",
        board.err_lines
    );
    let log = dir.path().join("run.csv");
    let url = format!("opc.tcp://127.0.0.1:{p_run}");
    let config = load_tolerant_config(dir.path(), "");
    let mut run = spawn_run_for(
        &config.to_string_lossy(),
        &pty,
        &log,
        "30",
        &["--opcua", &url],
    );
    wait_listening(&mut run, p_run, "acc run --opcua");
    let mut client = Peer::spawn(peer(&url, u64::MAX >> 12, &["--timeout", "8"]));
    // Hang guards only: 30 s of machine time is 15 s of wall time on an idle host (2×).
    client.json_with("ready", Duration::from_secs(180));
    let result = client.json_with("samples", Duration::from_secs(240));
    let (code, out, err) = run.finish(Duration::from_secs(240));
    assert_eq!(code, Some(0), "{out}\n{err:?}");
    drop(board);
    let rows = read_log(&log);
    let got = check_samples(&result, &rows);
    assert!(got.len() >= 20, "{} periods received", got.len());
    assert!(
        out.contains("telemetry: OPC UA server on"),
        "acc run: {out}"
    );
}

#[test]
fn asyncua_against_acc_run_with_board_sim_over_a_pty() {
    if !asyncua_ready() {
        return;
    }
    peer_against_acc_run(asyncua);
}

#[test]
fn node_opcua_against_acc_run_with_board_sim_over_a_pty() {
    if !node_opcua_ready() {
        return;
    }
    peer_against_acc_run(node_opcua);
}

/// Basic256Sha256 with a user: a wrong password is refused and logged, the right one reads.
#[test]
fn secure_endpoint_refuses_a_wrong_password_and_logs_it() {
    if !asyncua_ready() {
        return;
    }
    let _ = acc_bin();
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let (good, bad) = (dir.path().join("pw"), dir.path().join("wrong"));
    std::fs::write(&good, "s3cret-opcua\n").expect("pw");
    std::fs::write(&bad, "guess\n").expect("pw");
    let out = dir.path().join("run");
    let out_s = out.to_string_lossy().into_owned();
    let good_s = good.to_string_lossy().into_owned();
    let mut sim = Proc::spawn_with_stdin(
        &[
            "sim",
            "overload_alarm",
            "--no-plot",
            "--step-stdin",
            "--opcua",
            &url,
            "--opcua-user",
            "shop",
            "--opcua-password-file",
            &good_s,
            "--out",
            &out_s,
        ],
        false,
        Stdio::piped(),
    );
    let mut steps = sim.child.stdin.take().expect("stdin piped");
    wait_listening(&mut sim, port, "acc sim --opcua (secure)");
    let certs = dir.path().join("client-pki");
    let certs_s = certs.to_string_lossy().into_owned();
    let pw_arg = |p: &Path| p.to_string_lossy().into_owned();
    let bad_s = pw_arg(&bad);
    let mut wrong = Peer::spawn(asyncua(
        &url,
        5,
        &[
            "--user",
            "shop",
            "--password-file",
            &bad_s,
            "--cert-dir",
            &certs_s,
        ],
    ));
    let refused = wrong.json_with("refused", Duration::from_secs(60));
    assert_eq!(wrong.exit_code(), Some(3), "{refused}");
    assert!(
        sim.wait_for("OPC UA refused user `shop`", Duration::from_secs(10)),
        "no refusal logged: {:?}",
        sim.err_lines
    );
    let mut right = Peer::spawn(asyncua(
        &url,
        9,
        &[
            "--user",
            "shop",
            "--password-file",
            &good_s,
            "--cert-dir",
            &certs_s,
        ],
    ));
    right.json_with("ready", Duration::from_secs(60));
    writeln!(steps, "10").expect("step");
    let result = right.json_with("samples", Duration::from_secs(60));
    assert_eq!(right.exit_code(), Some(0));
    writeln!(steps, "all").expect("finish");
    drop(steps);
    let (code, stdout, err) = sim.finish(Duration::from_secs(120));
    assert_eq!(code, Some(0), "{stdout}\n{err:?}");
    assert!(stdout.contains("Basic256Sha256 SignAndEncrypt"), "{stdout}");
    assert!(stdout.contains("1 identities refused"), "{stdout}");
    let rows = read_log(&out.join("run.csv"));
    assert_eq!(check_samples(&result, &rows), (0..10).collect::<Vec<_>>());
    // The server's certificate was made on first start, in the run's folder.
    assert!(
        out.join("pki/own/cert.der").is_file(),
        "no server certificate"
    );
    assert!(out.join("pki/private/private.pem").is_file(), "no key");
}

/// A port already taken: one clear line naming it, before any period runs.
#[test]
fn opcua_port_in_use_is_one_clear_line() {
    let _ = acc_bin();
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = taken.local_addr().expect("addr").port();
    let dir = tempfile::tempdir().expect("tempdir");
    let out_s = dir.path().join("run").to_string_lossy().into_owned();
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let sim = Proc::spawn(
        &[
            "sim",
            "paper_case3",
            "--no-plot",
            "--opcua",
            &url,
            "--out",
            &out_s,
        ],
        false,
    );
    let (code, _out, err) = sim.finish(Duration::from_secs(60));
    assert_ne!(code, Some(0));
    let text = err.join("\n");
    assert!(
        text.contains(&format!("cannot listen on 127.0.0.1:{port}")),
        "{text}"
    );
}
