//! Fleet load: N simulated machines (`acc sim two_tools --time-scale X --mqtt …`, the path
//! users run) publish through one `mosquitto` into one `acc collect`; measures the periods
//! lost (run-log rows of every machine against the rows the collector stored), the lag from
//! publish to the Parquet commit (the collector's own histogram, from each message's
//! `sent_us`), and the collector's peak memory and CPU time.
//!
//! ```text
//! cargo build --release -p acc-cli --features fleet
//! cargo bench -p acc-tests --bench fleet_load -- [--machines 50] [--time-scale 1] [--commit-s 1]
//! ```
//!
//! `ACC_BIN=path` runs another build of `acc`. Figures: docs/fleet.md ("Load").

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Options {
    machines: usize,
    time_scale: f64,
    commit_s: f64,
}

fn options() -> Options {
    let mut o = Options {
        machines: 50,
        time_scale: 1.0,
        commit_s: 1.0,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = |i: usize| -> f64 {
            args.get(i + 1)
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{}: a number is expected", args[i]))
        };
        match args[i].as_str() {
            "--machines" => o.machines = value(i) as usize,
            "--time-scale" => o.time_scale = value(i),
            "--commit-s" => o.commit_s = value(i),
            // cargo bench passes `--bench`.
            _ => {
                i += 1;
                continue;
            }
        }
        i += 2;
    }
    assert!(
        (1..=500).contains(&o.machines),
        "--machines: allowed 1 ..= 500"
    );
    o
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `acc` binary: `ACC_BIN`, else the release build; `None` (the reason printed) when
/// it is not built, so `cargo bench --workspace` skips this bench rather than failing.
fn acc_bin() -> Option<PathBuf> {
    let p = std::env::var_os("ACC_BIN")
        .map_or_else(|| root().join("target/release/acc"), PathBuf::from);
    if !p.exists() {
        println!(
            "fleet_load skipped: {} is not built (cargo build --release -p acc-cli --features fleet)",
            p.display()
        );
        return None;
    }
    Some(p)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Resident and peak memory of a process, kB (`VmRSS`, `VmHWM`).
fn memory_kb(pid: u32) -> (u64, u64) {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let field = |name: &str| {
        text.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// CPU time of a process (user + system), s.
fn cpu_s(pid: u32) -> f64 {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    let after = text.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields 14 and 15 of stat (utime, stime) are 12 and 13 after the command name.
    (ticks(11) + ticks(12)) / 100.0
}

fn rows_of(log: &Path) -> usize {
    std::fs::read_to_string(log)
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

fn number_after(text: &str, prefix: &str) -> Option<u64> {
    let i = text.find(prefix)? + prefix.len();
    text[i..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

fn main() {
    let o = options();
    let Some(acc) = acc_bin() else { return };
    if !Path::new("/usr/sbin/mosquitto").exists() {
        println!(
            "fleet_load skipped: /usr/sbin/mosquitto is not installed (apt package mosquitto)"
        );
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let conf = dir.path().join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"),
    )
    .expect("conf");
    let mut broker = Command::new("/usr/sbin/mosquitto")
        .arg("-c")
        .arg(&conf)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mosquitto (apt package mosquitto)");
    let t0 = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "mosquitto did not start"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let store = dir.path().join("store");
    let mut collect = Command::new(&acc)
        .args([
            "collect",
            "--mqtt",
            &format!("mqtt://127.0.0.1:{port}/fleet"),
        ])
        .arg("--out")
        .arg(&store)
        .args(["--commit-s", &o.commit_s.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("acc collect");
    let pid = collect.id();
    let mut err = BufReader::new(collect.stderr.take().expect("stderr"));
    let mut line = String::new();
    while !line.contains("collector connected") {
        line.clear();
        if err.read_line(&mut line).unwrap_or(0) == 0 {
            panic!("acc collect ended before it connected");
        }
    }
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    eprintln!(
        "{} machines at {}x time ({} periods/s in all) into one collector …",
        o.machines,
        o.time_scale,
        o.machines as f64 * 10.0 * o.time_scale
    );
    let started = Instant::now();
    let machines: Vec<(PathBuf, Child)> = (0..o.machines)
        .map(|i| {
            let out = dir.path().join(format!("m{i:03}"));
            let child = Command::new(&acc)
                .args([
                    "sim",
                    "two_tools",
                    "--no-plot",
                    "--seed",
                    &(100 + i).to_string(),
                ])
                .args(["--time-scale", &o.time_scale.to_string()])
                .args(["--mqtt", &format!("mqtt://127.0.0.1:{port}/fleet/m{i:03}")])
                .arg("--out")
                .arg(&out)
                .arg("--history")
                .arg(out.join("history.sqlite"))
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .expect("acc sim");
            (out, child)
        })
        .collect();
    let mut peak_rss = 0;
    let mut per_machine: Vec<(String, usize)> = Vec::new();
    let mut published = 0usize;
    let mut dropped = 0u64;
    let mut late_rows = 0usize;
    for (out, mut child) in machines {
        while child.try_wait().ok().flatten().is_none() {
            peak_rss = peak_rss.max(memory_kb(pid).0);
            std::thread::sleep(Duration::from_millis(100));
        }
        let mut text = String::new();
        if let Some(mut s) = child.stdout.take() {
            let _ = s.read_to_string(&mut text);
        }
        dropped += number_after(&text, "messages queued, ").unwrap_or(0);
        let log = out.join("run.csv");
        published += rows_of(&log);
        let name = out
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        per_machine.push((name, rows_of(&log)));
        late_rows += std::fs::read_to_string(&log)
            .map(|t| t.lines().filter(|l| l.contains("late")).count())
            .unwrap_or(0);
    }
    let wall = started.elapsed().as_secs_f64();
    // Let the last commit happen, then stop the collector.
    std::thread::sleep(Duration::from_secs_f64(3.0 * o.commit_s + 1.0));
    let (_, hwm) = memory_kb(pid);
    let cpu = cpu_s(pid);
    let _ = Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status();
    let mut summary = String::new();
    if let Some(mut s) = collect.stdout.take() {
        let _ = s.read_to_string(&mut summary);
    }
    let _ = collect.wait();
    let _ = broker.kill();
    let _ = broker.wait();
    let stored = number_after(&summary, "collected: ").unwrap_or(0);
    let lag = summary
        .lines()
        .find(|l| l.starts_with("lag from publish"))
        .unwrap_or("lag: none measured");
    println!("| machines | time scale | periods/s | run-log rows | stored | lost | machines' MQTT drops | late rows | collector peak RSS | collector CPU | wall |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    println!(
        "| {} | {}x | {:.0} | {published} | {stored} | {} | {dropped} | {late_rows} | {:.1} MB | {cpu:.1} s | {wall:.1} s |",
        o.machines,
        o.time_scale,
        o.machines as f64 * 10.0 * o.time_scale,
        published as i64 - stored as i64,
        hwm.max(peak_rss) as f64 / 1024.0,
    );
    println!("{lag}");
    if published as u64 != stored {
        let text = Command::new(&acc)
            .args(["history", "query"])
            .arg(&store)
            .args([
                "SELECT machine, count(*) FROM period GROUP BY machine",
                "--csv",
            ])
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default();
        for (m, rows) in &per_machine {
            let got = text
                .lines()
                .find(|l| l.starts_with(&format!("{m},")))
                .and_then(|l| l.split(',').nth(1))
                .and_then(|v| v.parse::<usize>().ok())
                .unwrap_or(0);
            if got != *rows {
                println!("{m}: run log {rows} rows, stored {got}");
            }
        }
    }
    println!("{}", summary.lines().next().unwrap_or_default());
}
