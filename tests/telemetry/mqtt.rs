//! The MQTT publisher of `acc sim --mqtt` against a real `mosquitto` broker the test starts
//! on a free port, with `mosquitto_sub` as the independent subscriber: the period messages
//! carry the run log's values, `online`/`offline` are published (retained) on the status
//! topic, and after the broker is killed and restarted mid-run publishing resumes.
//!
//! The test paces the run itself (`acc sim --step-stdin`): the broker goes down after
//! period 150 has arrived and comes back 100 periods later, whatever the machine's load.
//! That the loop never waits on the broker is the tap's property (a bounded queue that
//! drops, `crates/acc-telemetry`), measured by the loop-jitter benchmark.

use std::io::Write as _;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::e2e_support::{acc_bin, peer_ready, read_log, root};
use crate::mqtt_support::{free_port, mosquitto, Broker};

/// `mosquitto_sub -v` on `topic`, its output read on a thread (a full pipe would stall it).
struct Sub {
    child: Child,
    lines: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
    reader: std::thread::JoinHandle<()>,
}

impl Sub {
    /// Wait until a period message with `period` ≥ `k` has arrived (at most 30 s).
    fn wait_for_period(&self, k: u64) {
        let t0 = Instant::now();
        loop {
            let seen = self
                .lines
                .lock()
                .map(|l| {
                    l.iter().any(|line| {
                        line.strip_prefix("acctest/period ")
                            .and_then(|p| serde_json::from_str::<serde_json::Value>(p).ok())
                            .and_then(|m| m["period"].as_u64())
                            .is_some_and(|p| p >= k)
                    })
                })
                .unwrap_or(false);
            if seen {
                return;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "period {k} did not arrive"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn subscribe(port: u16, topic: &str) -> Sub {
    // Line-buffered (coreutils `stdbuf`): the subscriber is killed at the end. A persistent
    // session (`-c`, one client id, QoS 1): a broker restarted from its saved sessions keeps
    // the subscription and queues what is published before the subscriber is back.
    let mut child = Command::new("stdbuf")
        .args([
            "-oL",
            "mosquitto_sub",
            "-h",
            "127.0.0.1",
            "-p",
            &port.to_string(),
        ])
        .args(["-c", "-i", "acctest-sub", "-q", "1", "-v", "-t", topic])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("mosquitto_sub");
    let out = child.stdout.take().expect("stdout");
    let lines = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let sink = std::sync::Arc::clone(&lines);
    let reader = std::thread::spawn(move || {
        for line in std::io::BufRead::lines(std::io::BufReader::new(out)).map_while(Result::ok) {
            if let Ok(mut l) = sink.lock() {
                l.push(line);
            }
        }
    });
    Sub {
        child,
        lines,
        reader,
    }
}

/// Kill a subscriber and return its `topic payload` lines.
fn lines_of(mut s: Sub) -> Vec<(String, String)> {
    std::thread::sleep(Duration::from_millis(300));
    let _ = s.child.kill();
    let _ = s.child.wait();
    s.reader.join().expect("reader thread");
    let lines = std::mem::take(&mut *s.lines.lock().expect("lines"));
    lines
        .iter()
        .filter_map(|l| {
            let (t, p) = l.split_once(' ')?;
            Some((t.to_string(), p.to_string()))
        })
        .collect()
}

#[test]
fn acc_sim_mqtt_to_mosquitto_survives_a_broker_restart() {
    let has = |bin: &str| {
        let mut c = Command::new("sh");
        c.args(["-c", &format!("command -v {bin}")]);
        c
    };
    if !peer_ready(
        "mosquitto (apt package mosquitto)",
        Command::new("test").args(["-x", &mosquitto()]),
    ) || !peer_ready(
        "mosquitto_sub (apt package mosquitto-clients)",
        &mut has("mosquitto_sub"),
    ) {
        return;
    }
    let _ = acc_bin(); // built before the broker starts
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let conf = dir.path().join("mosquitto.conf");
    let mut f = std::fs::File::create(&conf).expect("conf");
    // Sessions saved on SIGTERM and restored at start, QoS 0 messages queued for them too:
    // what acc publishes between the restart and the subscriber's return is kept for it.
    writeln!(
        f,
        "listener {port} 127.0.0.1\nallow_anonymous true\npersistence true\npersistence_location {}/\nqueue_qos0_messages true",
        dir.path().display()
    )
    .expect("conf");
    drop(f);
    let mut broker = Broker::start(&conf, port);
    let sub1 = subscribe(port, "acctest/#");
    std::thread::sleep(Duration::from_millis(300));

    // The test paces the run: 150 periods, the broker down for the next 100, then the rest.
    let out_dir = dir.path().join("run");
    let url = format!("mqtt://127.0.0.1:{port}/acctest");
    let bin = acc_bin();
    let mut sim = Command::new(bin)
        .args([
            "sim",
            "paper_case1",
            "--no-plot",
            "--step-stdin",
            "--mqtt",
            &url,
        ])
        .arg("--out")
        .arg(&out_dir)
        .current_dir(root())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("acc sim");
    let mut steps = sim.stdin.take().expect("stdin piped");
    writeln!(steps, "150").expect("step");
    sub1.wait_for_period(149);
    broker.terminate();
    let before = lines_of(sub1);
    writeln!(steps, "100").expect("step");
    // The 100 periods run with the broker down (the publisher queues them).
    std::thread::sleep(Duration::from_millis(500));
    let broker = Broker::start(&conf, port);
    let sub2 = subscribe(port, "acctest/#");
    writeln!(steps, "50").expect("step");
    sub2.wait_for_period(299);
    // The rest at about 500 periods per second, well inside the publisher's queue.
    for _ in 0..200 {
        if writeln!(steps, "10").is_err() {
            break; // the run has ended
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = writeln!(steps, "all");
    drop(steps);
    let sim = sim.wait_with_output().expect("acc sim output");
    let stdout = String::from_utf8_lossy(&sim.stdout).to_string();
    assert!(
        sim.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let after = lines_of(sub2);
    // The status after the clean end: `offline`, retained.
    let st = Command::new("mosquitto_sub")
        .args([
            "-h",
            "127.0.0.1",
            "-p",
            &port.to_string(),
            "-t",
            "acctest/status",
        ])
        .args(["-C", "1", "-W", "3"])
        .output()
        .expect("mosquitto_sub status");
    drop(broker);

    let rows = read_log(&out_dir.join("run.csv"));
    let n = rows.len();
    assert!(n > 500, "{n} rows");
    let periods = |lines: &[(String, String)]| -> Vec<serde_json::Value> {
        lines
            .iter()
            .filter(|(t, _)| t == "acctest/period")
            .map(|(_, p)| serde_json::from_str(p).expect("period JSON"))
            .collect()
    };
    let (p1, p2) = (periods(&before), periods(&after));
    assert!(
        p1.len() > 50,
        "{} messages before the broker went down",
        p1.len()
    );
    assert!(p2.len() > 50, "{} messages after it came back", p2.len());
    assert!(
        before
            .iter()
            .any(|(t, p)| t == "acctest/status" && p == "online"),
        "no online status"
    );
    assert!(
        after
            .iter()
            .any(|(t, p)| t == "acctest/status" && p == "online"),
        "no online status after the reconnect: {:?}",
        after
            .iter()
            .filter(|(t, _)| t != "acctest/period")
            .collect::<Vec<_>>()
    );
    // The per-cut record, computed by the publisher with the same `CutRecorder` as
    // `acc report`, matches the one computed offline from the run log.
    let cuts: Vec<serde_json::Value> = before
        .iter()
        .chain(&after)
        .filter(|(t, _)| t == "acctest/cut")
        .map(|(_, p)| serde_json::from_str(p).expect("cut JSON"))
        .collect();
    let mut rec = acc_runtime::cuts::CutRecorder::new(0.1);
    let mut offline: Vec<_> = rows.iter().filter_map(|r| rec.push(r)).collect();
    offline.extend(rec.finish());
    assert!(!offline.is_empty(), "the run has a cut");
    assert_eq!(cuts.len(), offline.len(), "cut messages: {cuts:?}");
    for (m, c) in cuts.iter().zip(&offline) {
        let near = |key: &str, want: f64| {
            let got = m[key].as_f64().unwrap_or(f64::NAN);
            assert!(
                (got - want).abs() <= 0.02 * want.abs().max(1.0),
                "{key}: {got} published, {want} offline"
            );
        };
        near("time_in_cut_s", c.time_in_cut_s);
        near("force_mean_n", c.force_mean_n);
        near("time_saved_s", c.time_saved_s);
    }
    // What piled up while the broker was down (100 periods, under rumqttc's queue of 256)
    // went out after the reconnect: nearly every period arrived.
    let mut seen: Vec<u64> = p1
        .iter()
        .chain(&p2)
        .filter_map(|m| m["period"].as_u64())
        .collect();
    seen.sort_unstable();
    seen.dedup();
    assert!(
        seen.len() * 10 >= n * 9,
        "{} of {n} periods arrived",
        seen.len()
    );
    assert_eq!(
        p2.last().and_then(|m| m["period"].as_u64()),
        Some(rows[n - 1].period),
        "publishing resumed up to the last period"
    );
    // Every message carries its row's values.
    for m in p1.iter().chain(&p2) {
        let i = m["period"].as_u64().expect("period") as usize;
        let r = &rows[i];
        assert_eq!(r.period as usize, i);
        let close = |a: &serde_json::Value, b: Option<f64>| match (a.as_f64(), b) {
            (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * y.abs().max(1.0),
            (None, None) => true,
            _ => false,
        };
        assert!(close(&m["force_n"], r.force_n), "{m} vs {r:?}");
        assert!(close(&m["kc_hat"], r.kc_hat), "{m} vs {r:?}");
        assert_eq!(
            m["override_cmd_pct"].as_u64(),
            r.override_cmd_pct.map(u64::from),
            "{m}"
        );
        assert_eq!(m["acc_state"], r.state.as_str());
    }
    assert_eq!(String::from_utf8_lossy(&st.stdout).trim(), "offline");
    assert!(stdout.contains("telemetry: MQTT"), "{stdout}");
}

/// A broker that is not there (a port nothing listens on) is one line on stderr naming the
/// broker and the error, and the run is the run without MQTT: same rows, same forces.
#[test]
fn an_unreachable_broker_is_one_line_and_the_run_goes_on() {
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port(); // released: nothing listens on it
    let run = |out: &str, mqtt: Option<String>| {
        let mut c = Command::new(acc_bin());
        c.args(["sim", "paper_case1", "--no-plot", "--out"])
            .arg(dir.path().join(out))
            .current_dir(root());
        if let Some(url) = mqtt {
            c.args(["--mqtt", &url]);
        }
        let o = c.output().expect("acc sim");
        assert!(o.status.success(), "acc sim {out}: {o:?}");
        (
            String::from_utf8_lossy(&o.stderr).into_owned(),
            read_log(&dir.path().join(out).join("run.csv")),
        )
    };
    let (stderr, with) = run("with", Some(format!("mqtt://127.0.0.1:{port}/acctest")));
    let (_, without) = run("without", None);
    let named: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains(&format!("MQTT broker 127.0.0.1:{port}:")))
        .collect();
    assert_eq!(named.len(), 1, "one line per outage, got: {stderr}");
    assert!(
        named[0].contains("refused") && named[0].contains("retrying"),
        "names the error and the retry: {}",
        named[0]
    );
    assert_eq!(with.len(), without.len(), "rows with and without MQTT");
    for (a, b) in with.iter().zip(&without) {
        assert_eq!(a.force_n, b.force_n, "period {}", a.period);
        assert_eq!(
            a.override_cmd_pct, b.override_cmd_pct,
            "period {}",
            a.period
        );
    }
}
