//! The live view of `acc sim --live` in a real headless browser (Chromium): the page loads
//! from the binary, its plot and counters update from the SSE stream (the period shown
//! advances between two loads, each load takes several updates), the overload alarm of
//! `configs/scenarios/overload_alarm.toml` appears, and an acknowledge shows as
//! "acknowledged (view only)". A screenshot of the last page goes to the test's temp dir
//! (`LIVE_VIEW_SCREENSHOT=path` writes it there instead: that is how docs/img/live_view.png
//! is regenerated, see docs/telemetry.md "Live view").
//!
//! Chromium `--dump-dom` / `--screenshot` wait until the page's network is idle: the page's
//! `?updates=N` closes its event stream after N updates (or the stream ends with the run).
//! The test paces the run itself (`acc sim --step-stdin`): one period every 150 ms while a
//! page loads, never past the alarm until the pages before it are read, so a slow browser
//! on a loaded machine cannot let the run overtake it.
//! Skips with a printed reason without Chromium; fails under `CI`.
//!
//! `acc run --live` (the logger thread publishes through `TapSink`) and `acc board-sim
//! --live` over a pty are checked with plain SSE readers (no browser needed): every period
//! of the run log reaches the view, in order, then the `end` event.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::e2e_support::{
    acc_bin, one_at_a_time, read_log, root, spawn_board_sim, spawn_run_for, Proc,
};

fn chromium() -> Option<PathBuf> {
    let cands = [
        std::env::var("CHROMIUM").unwrap_or_default(),
        "/usr/bin/chromium".into(),
        "/usr/bin/chromium-browser".into(),
    ];
    let found = cands
        .iter()
        .filter(|c| !c.is_empty())
        .map(PathBuf::from)
        .find(|p| p.is_file());
    if found.is_none() {
        if std::env::var_os("CI").is_some() {
            panic!("chromium is not installed but CI is set: run `bash .ci/deps`");
        }
        eprintln!("SKIP: chromium is not installed (run `bash .ci/deps`); live view test not run");
    }
    found
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Run headless Chromium on `url` with `what` (`--dump-dom` or `--screenshot=…`); stdout.
fn browse(chromium: &Path, profile: &Path, url: &str, what: &str) -> String {
    let mut child = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--window-size=1280,900",
            "--virtual-time-budget=20000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(what)
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start chromium");
    let mut out = String::new();
    let mut so = child.stdout.take().expect("stdout");
    let reader = std::thread::spawn(move || {
        let _ = so.read_to_string(&mut out);
        out
    });
    let end = Instant::now() + Duration::from_secs(60);
    while child.try_wait().ok().flatten().is_none() {
        if Instant::now() > end {
            let _ = child.kill();
            panic!("chromium on {url} did not finish in 60 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    reader.join().expect("reader")
}

/// The text of the element with `id` in a dumped DOM.
fn by_id<'a>(dom: &'a str, id: &str) -> &'a str {
    let key = format!("id=\"{id}\"");
    let at = dom
        .find(&key)
        .unwrap_or_else(|| panic!("no #{id} in {dom:.2000}"));
    let start = at + dom[at..].find('>').expect("tag end") + 1;
    let end = start + dom[start..].find('<').expect("text end");
    &dom[start..end]
}

fn num(dom: &str, id: &str) -> u64 {
    by_id(dom, id)
        .trim()
        .parse()
        .unwrap_or_else(|_| panic!("#{id} = {:?} is not a number", by_id(dom, id)))
}

fn post(port: u16, path: &str, body: &str) -> String {
    let mut s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    write!(
        s,
        "POST {path} HTTP/1.1\r\nHost: x\r\nContent-Type: application/x-www-form-urlencoded\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .expect("write");
    let mut out = String::new();
    s.read_to_string(&mut out).expect("read");
    out
}

/// Load a page (`load`) while stepping the `acc sim --step-stdin` run one period every
/// 150 ms, never past `cap` periods in all (`sent` counts them): the page sees the run go on,
/// and however slow the browser is, the run does not pass `cap`.
fn load_paced(
    steps: &mut std::process::ChildStdin,
    sent: &mut u32,
    cap: u32,
    load: impl FnOnce() -> String + Send,
) -> String {
    std::thread::scope(|sc| {
        let page = sc.spawn(load);
        while !page.is_finished() {
            if *sent < cap {
                writeln!(steps, "1").expect("step the run");
                *sent += 1;
            }
            std::thread::sleep(Duration::from_millis(150));
        }
        page.join().expect("page load")
    })
}

#[test]
fn live_view_in_headless_chromium_updates_and_shows_the_alarm() {
    let Some(chromium) = chromium() else {
        return;
    };
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let out = dir.path().join("run");
    let out_s = out.to_string_lossy().into_owned();
    // The test paces the run (`--step-stdin`): the overload alarm comes at 23 s of machine
    // time (period 230), and the run never gets there before the test says so.
    let mut sim = Proc::spawn_with_stdin(
        &[
            "sim",
            "overload_alarm",
            "--no-plot",
            "--step-stdin",
            "--live",
            &addr,
            "--live-keep",
            "120",
            "--out",
            &out_s,
        ],
        false,
        Stdio::piped(),
    );
    let mut steps = sim.child.stdin.take().expect("stdin piped");
    let t0 = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the live view did not listen on {addr}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // Into the part (air, entry): 50 periods at once.
    writeln!(steps, "50").expect("step");
    let mut sent = 50u32;
    let url = format!("http://{addr}/");
    let profile = dir.path().join("profile");

    // 1. The page loads from the binary and updates from the stream, while the run goes on.
    let dom1 = load_paced(&mut steps, &mut sent, 120, || {
        browse(
            &chromium,
            &profile,
            &format!("{url}?updates=6"),
            "--dump-dom",
        )
    });
    assert!(dom1.contains("acc live view") && dom1.contains("<canvas id=\"cForce\""));
    assert!(num(&dom1, "updates") >= 6, "{}", by_id(&dom1, "updates"));
    let p1 = num(&dom1, "period");
    assert_eq!(by_id(&dom1, "fr"), "800");
    assert_eq!(by_id(&dom1, "tool"), "T1");
    assert_eq!(by_id(&dom1, "ovl"), "950", "the scenario's overload limit");
    assert!(by_id(&dom1, "title").contains("overload alarm"));
    let dom2 = load_paced(&mut steps, &mut sent, 210, || {
        browse(
            &chromium,
            &profile,
            &format!("{url}?updates=6"),
            "--dump-dom",
        )
    });
    assert!(
        sent < 230,
        "the test kept the run before the alarm ({sent} periods)"
    );
    let p2 = num(&dom2, "period");
    assert!(p2 > p1, "the period shown did not advance: {p1} then {p2}");
    assert!(
        ["air", "entry", "cut"].contains(&by_id(&dom2, "state")),
        "state before the alarm: {}",
        by_id(&dom2, "state")
    );
    assert_eq!(num(&dom2, "dropped"), 0, "a reading client lost records");

    // 2. The alarm appears: the run goes on to its end, and a load without `?updates` ends
    //    with the run's `end` event.
    writeln!(steps, "all").expect("let the run finish");
    drop(steps);
    let dom3 = browse(&chromium, &profile, &url, "--dump-dom");
    assert_eq!(by_id(&dom3, "conn"), "run ended");
    assert_eq!(by_id(&dom3, "state"), "alarm");
    assert!(
        dom3.contains("data-alarm=\"overload\"") && dom3.contains("not acknowledged"),
        "{dom3:.3000}"
    );
    assert!(num(&dom3, "period") > p2);

    // 3. Acknowledge (view only): the page shows it; the run log is the machine's record.
    let ack = post(port, "/ack", "alarms=16&period=1");
    assert!(ack.starts_with("HTTP/1.1 204"), "{ack}");
    let shot = std::env::var_os("LIVE_VIEW_SCREENSHOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| dir.path().join("live_view.png"));
    let dom4 = browse(&chromium, &profile, &url, "--dump-dom");
    assert!(
        dom4.contains("acknowledged (view only)"),
        "{:.3000}",
        by_id(&dom4, "alarmList")
    );
    browse(
        &chromium,
        &profile,
        &url,
        &format!("--screenshot={}", shot.display()),
    );
    let png = std::fs::read(&shot).expect("screenshot written");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 10_000,
        "{} bytes",
        png.len()
    );
    eprintln!("screenshot: {}", shot.display());

    // The run log has the alarm the page showed.
    let log = std::fs::read_to_string(out.join("run.csv")).expect("run log");
    assert!(log.contains("overload"), "no overload in the run log");
    let _ = sim.child.kill();
    let _ = sim.child.wait();
    let _ = root();
}

/// A plain SSE reader of `http://127.0.0.1:port/events` (retrying until it listens): all it
/// read when the stream ended or `within` passed.
fn sse_reader(port: u16, within: Duration) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let end = Instant::now() + within;
        let mut s = loop {
            match TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => break s,
                Err(_) if Instant::now() < end => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => panic!("live view on {port}: {e}"),
            }
        };
        s.write_all(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")
            .expect("request");
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .expect("timeout");
        let mut got = Vec::new();
        let mut buf = [0u8; 16384];
        while Instant::now() < end {
            match s.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(_) => {}
            }
            if got.windows(10).any(|w| w == b"event: end") {
                break;
            }
        }
        String::from_utf8_lossy(&got).into_owned()
    })
}

/// The periods of the records in an SSE transcript, in order.
fn periods(sse: &str) -> Vec<u64> {
    sse.lines()
        .filter_map(|l| l.strip_prefix("data: "))
        .filter_map(|d| serde_json::from_str::<serde_json::Value>(d).ok())
        .filter_map(|v| v["recs"].as_array().cloned())
        .flatten()
        .filter_map(|r| r["p"].as_u64())
        .collect()
}

#[test]
fn acc_run_and_board_sim_serve_every_period_to_the_live_view() {
    let _ = acc_bin();
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let (p_run, p_board) = (free_port(), free_port());
    let board_addr = format!("127.0.0.1:{p_board}");
    let (board, pty) = spawn_board_sim(&["--live", &board_addr]);
    let r_board = sse_reader(p_board, Duration::from_secs(20));
    let r_run = sse_reader(p_run, Duration::from_secs(40));
    let log = dir.path().join("run.csv");
    let run_addr = format!("127.0.0.1:{p_run}");
    let run = spawn_run_for(
        "configs/runtime/board_sim_fast.toml",
        &pty,
        &log,
        "8",
        &["--live", &run_addr],
    );
    let (code, out, err) = run.finish(Duration::from_secs(30));
    assert_eq!(code, Some(0), "{out}\n{err:?}");
    drop(board);
    let sse = r_run.join().expect("run reader");
    assert!(sse.contains("text/event-stream") && sse.contains("event: hello"));
    assert!(sse.contains("\"title\":\"acc run:"), "{sse:.400}");
    assert!(
        sse.contains("event: end"),
        "no end event: {:.400}",
        &sse[sse.len().saturating_sub(400)..]
    );
    let rows = read_log(&log);
    let n = rows.len();
    assert!(n >= 50, "{n} rows");
    let got = periods(&sse);
    // The reader connected while the run started: it has the history, then every period,
    // in order, up to the run log's last.
    let want: Vec<u64> = rows.iter().map(|r| r.period).collect();
    let first = got.first().copied().expect("records");
    assert_eq!(
        got,
        want.into_iter()
            .skip_while(|p| *p < first)
            .collect::<Vec<_>>(),
        "the view's periods against the run log"
    );
    assert!(out.contains("telemetry: live view"), "{out}");
    // The machine side: board-sim's records, the period advancing.
    let b = periods(&r_board.join().expect("board reader"));
    assert!(
        b.len() > 20 && b.windows(2).all(|w| w[1] > w[0]),
        "{} board-sim records",
        b.len()
    );
}
