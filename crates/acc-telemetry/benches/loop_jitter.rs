//! Period jitter of the production threaded loop with and without telemetry: `acc_runtime::run` — the real-time runner with its ticker, the adaptive
//! controller, the fault policy, the logger thread writing the CSV run log through the
//! `TapSink` exactly as `acc run` does — against an in-process emulated board
//! (`acc_runtime::testing::ScriptedBoard`: acc-pmc's `BoardLogic`), for N periods at a short
//! period, in alternating rounds:
//!
//! - **off**: the tap has no subscriber;
//! - **on**: the live view, the SHDR adapter and the MQTT publisher subscribed, with three
//!   SSE clients (plain TCP readers of `/events`) and three SHDR clients connected, and a
//!   real `mosquitto` broker started on a free port when one is installed (else the MQTT
//!   publisher runs against a closed port: it keeps reconnecting, which is its worst case);
//! - **opcua**: the OPC UA server subscribed (docs/opcua.md), with three Python `asyncua`
//!   clients (tests/peers/opcua_asyncua.py) each subscribed to FeedOverride, Acc/Force and
//!   Acc/Period (every period's value) and to the events, when asyncua is installed (else the
//!   server runs without clients and the row says so).
//!
//! Prints the lateness of the ticks against their deadlines (p50, p99, max) per round and
//! pooled per configuration. Run (docs/telemetry.md "Live view", README):
//!
//! ```text
//! cargo bench -p acc-telemetry --bench loop_jitter -- --periods 1000 --period-ms 10 --rounds 2
//! ```

use std::io::{BufWriter, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use acc_core::{Controller, ControllerConfig};
use acc_pmc::{Board, BoardStatus, ControlBits};
use acc_runtime::config::MqttSettings;
use acc_runtime::opcua_config::OpcUaSettings;
use acc_runtime::policy::{FaultPolicy, PolicyConfig};
use acc_runtime::record::RunLogWriter;
use acc_runtime::tap::{Tap, TapSink};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard};
use acc_runtime::SystemClock;
use acc_runtime::{run, ControlLoop, LogSink, RunOptions, RunRecord};
use acc_telemetry::{LiveInfo, LiveServer, MqttPublisher, OpcUaServer, ShdrServer};

/// The emulated board as a live machine: board time follows the wall clock, and the spindle
/// power follows the applied override (a plant with Kc, so the controller regulates).
struct Machine {
    b: ScriptedBoard,
    t0: Instant,
}

impl Board for Machine {
    type Error = <ScriptedBoard as Board>::Error;
    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        self.b.now_ms = self.t0.elapsed().as_millis() as u64;
        let o = self.b.override_writes.last().map_or(100, |w| w.0);
        self.b
            .board
            .push_power_sample(600 + 12 * u32::from(o.min(150)));
        self.b.override_writes.clear();
        self.b.control_writes.clear();
        self.b.read_status()
    }
    fn write_override(&mut self, o: u16, hb: u16) -> Result<(), Self::Error> {
        self.b.write_override(o, hb)
    }
    fn write_control(&mut self, c: ControlBits) -> Result<(), Self::Error> {
        self.b.write_control(c)
    }
    fn protocol(&self) -> Option<acc_pmc::BoardProtocol> {
        self.b.protocol()
    }
}

/// The run log as `acc run` writes it: CSV through a buffered file.
struct CsvSink(RunLogWriter<BufWriter<std::fs::File>>);

impl LogSink for CsvSink {
    type Error = acc_runtime::record::RunLogError;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.0.write(rec)
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

struct Args {
    periods: u64,
    period_ms: u64,
    rounds: u32,
}

fn args() -> Args {
    let mut a = Args {
        periods: 1000,
        period_ms: 10,
        rounds: 2,
    };
    let v: Vec<String> = std::env::args().collect();
    for (i, k) in v.iter().enumerate() {
        let next = || v.get(i + 1).and_then(|s| s.parse::<u64>().ok());
        match k.as_str() {
            "--periods" => a.periods = next().unwrap_or(a.periods),
            "--period-ms" => a.period_ms = next().unwrap_or(a.period_ms),
            "--rounds" => a.rounds = next().map_or(a.rounds, |x| x as u32),
            _ => {}
        }
    }
    a
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// A client reading everything from `port` after sending `req`, until `stop`.
fn reader(port: u16, req: &'static [u8], stop: Arc<AtomicBool>) -> std::thread::JoinHandle<u64> {
    std::thread::spawn(move || {
        let mut s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
        s.write_all(req).expect("request");
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .expect("timeout");
        let mut buf = [0u8; 16384];
        let mut n = 0u64;
        while !stop.load(Ordering::Relaxed) {
            match s.read(&mut buf) {
                Ok(0) => break,
                Ok(k) => n += k as u64,
                Err(_) => {}
            }
        }
        n
    })
}

/// `mosquitto` on a free port, if installed.
fn broker(dir: &std::path::Path) -> Option<(Child, u16)> {
    let bin = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
        .into_iter()
        .find(|p| std::path::Path::new(p).is_file())?;
    let port = free_port();
    let conf = dir.join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"),
    )
    .ok()?;
    let child = Command::new(bin)
        .arg("-c")
        .arg(&conf)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let t0 = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        if t0.elapsed() > Duration::from_secs(5) {
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Some((child, port))
}

struct Round {
    p50: Duration,
    p99: Duration,
    max: Duration,
    overruns: u64,
    skipped: u64,
}

/// Which telemetry runs in a round.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Off,
    On,
    OpcUa,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::On => "on",
            Mode::OpcUa => "opcua",
        }
    }
}

/// Whether python3 imports asyncua (the OPC UA clients of the `opcua` rows).
fn asyncua_installed() -> bool {
    Command::new("python3")
        .args(["-c", "import asyncua"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The OPC UA server on a free port with `n` asyncua clients subscribed (waits until each
/// printed its `ready` line).
fn opcua_with_clients(tap: &Tap, dir: &std::path::Path, n: usize) -> (OpcUaServer, Vec<Child>) {
    let cfg = OpcUaSettings::from_url("opc.tcp://127.0.0.1:0").expect("url");
    let srv = OpcUaServer::start(&cfg, &dir.join("pki"), tap.subscribe(256)).expect("opcua");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut kids = Vec::new();
    for _ in 0..n {
        let mut c = Command::new("python3")
            .arg(root.join("tests/peers/opcua_asyncua.py"))
            .arg(srv.url())
            .args(["--until", "1000000000000", "--timeout", "3600"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("python3 asyncua client");
        let out = c.stdout.take().expect("stdout");
        let mut line = String::new();
        let _ = std::io::BufRead::read_line(&mut std::io::BufReader::new(out), &mut line);
        assert!(line.contains("\"ready\""), "asyncua client: {line}");
        kids.push(c);
    }
    (srv, kids)
}

fn one_round(a: &Args, mode: Mode, dir: &std::path::Path, mqtt_port: u16) -> Round {
    let tap = Tap::new();
    let stop_clients = Arc::new(AtomicBool::new(false));
    let mut servers = None;
    let mut clients = Vec::new();
    let mut opcua = None;
    if mode == Mode::OpcUa {
        let n = if asyncua_installed() { 3 } else { 0 };
        opcua = Some(opcua_with_clients(&tap, dir, n));
    }
    if mode == Mode::On {
        let live = LiveServer::start("127.0.0.1:0", tap.subscribe(256), LiveInfo::default())
            .expect("live view");
        let shdr_sub = tap.subscribe(256);
        let shdr = ShdrServer::start("127.0.0.1:0", shdr_sub).expect("shdr");
        let mut m =
            MqttSettings::from_url(&format!("mqtt://127.0.0.1:{mqtt_port}/bench")).expect("url");
        m.client_id = format!("acc-bench-{}", std::process::id());
        let mqtt = MqttPublisher::start(m, tap.subscribe(256), 0.1).expect("mqtt");
        for _ in 0..3 {
            clients.push(reader(
                live.local_addr().port(),
                b"GET /events HTTP/1.1\r\n\r\n",
                stop_clients.clone(),
            ));
            clients.push(reader(
                shdr.local_addr().port(),
                b"* PING\n",
                stop_clients.clone(),
            ));
        }
        // Let the clients connect before the loop starts.
        let t0 = Instant::now();
        while live.stats().clients.load(Ordering::Relaxed) < 3 && t0.elapsed().as_secs() < 5 {
            std::thread::sleep(Duration::from_millis(10));
        }
        servers = Some((live, shdr, mqtt));
    }
    let cfg = ControllerConfig {
        period_s: a.period_ms as f64 / 1000.0,
        ..ControllerConfig::default()
    };
    let law = Controller::new(cfg).expect("controller");
    let mut control = ControlLoop::new(
        FaultPolicy::new(PolicyConfig {
            period_s: cfg.period_s,
            ..PolicyConfig::default()
        }),
        law,
        LinearPowerForce { n_per_w: 0.5 },
        cfg.period_s,
    );
    let mut board = Machine {
        b: ScriptedBoard::new(),
        t0: Instant::now(),
    };
    let f = std::fs::File::create(dir.join(format!("{}.csv", mode.name()))).expect("log");
    let mut sink = TapSink {
        inner: CsvSink(RunLogWriter::new(BufWriter::new(f)).expect("writer")),
        tap: tap.clone(),
    };
    let stop = AtomicBool::new(false);
    let opts = RunOptions {
        max_periods: Some(a.periods),
        ..RunOptions::new(Duration::from_millis(a.period_ms))
    };
    let s = run(
        &mut board,
        &mut control,
        SystemClock::new(),
        &mut sink,
        &stop,
        opts,
    )
    .expect("run");
    drop(sink);
    drop(tap);
    stop_clients.store(true, Ordering::Relaxed);
    let read: u64 = clients.into_iter().map(|c| c.join().unwrap_or(0)).sum();
    if let Some((live, shdr, mqtt)) = servers {
        let st = live.stop();
        eprintln!(
            "  on: clients read {} kB; live view {} records, {} dropped; MQTT {} messages",
            read / 1000,
            st.records.load(Ordering::Relaxed),
            st.dropped.load(Ordering::Relaxed),
            mqtt.stats().queued.load(Ordering::Relaxed),
        );
        shdr.stop();
        mqtt.stop();
    }
    if let Some((srv, kids)) = opcua {
        let records = srv.stats().records.load(Ordering::Relaxed);
        let dropped = srv.stats().records_dropped.load(Ordering::Relaxed);
        let c = srv.stop();
        for mut k in kids {
            let _ = k.kill();
            let _ = k.wait();
        }
        eprintln!(
            "  opcua: {records} records, {dropped} dropped, {} client sessions",
            c.cumulated
        );
    }
    let j = &s.ticker.jitter;
    Round {
        p50: j.quantile(0.5),
        p99: j.quantile(0.99),
        max: j.max(),
        overruns: s.ticker.overruns,
        skipped: s.skipped,
    }
}

fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

fn main() {
    let a = args();
    let dir = std::env::temp_dir().join(format!("acc-loop-jitter-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let broker = broker(&dir);
    let mqtt_port = broker.as_ref().map_or_else(free_port, |b| b.1);
    println!(
        "loop jitter: {} periods of {} ms per round, {} rounds per configuration; MQTT broker: {}",
        a.periods,
        a.period_ms,
        a.rounds,
        if broker.is_some() {
            "mosquitto"
        } else {
            "none (publisher reconnecting)"
        }
    );
    println!(
        "OPC UA clients: {}",
        if asyncua_installed() {
            "3 asyncua, subscribed"
        } else {
            "none (asyncua not installed)"
        }
    );
    println!("round  telemetry  p50 [us]  p99 [us]  max [us]  overruns  skipped");
    let mut p99s: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    for r in 0..a.rounds {
        for (i, mode) in [Mode::Off, Mode::On, Mode::OpcUa].into_iter().enumerate() {
            let x = one_round(&a, mode, &dir, mqtt_port);
            println!(
                "{:>5}  {:>9}  {:>8.0}  {:>8.0}  {:>8.0}  {:>8}  {:>7}",
                r + 1,
                mode.name(),
                us(x.p50),
                us(x.p99),
                us(x.max),
                x.overruns,
                x.skipped
            );
            p99s[i].push(us(x.p99));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            0.0
        } else if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        }
    };
    for (what, f) in [
        ("mean", &mean as &dyn Fn(&[f64]) -> f64),
        ("median", &median),
    ] {
        let (off, on, ua) = (f(&p99s[0]), f(&p99s[1]), f(&p99s[2]));
        println!(
            "p99 lateness, {what} of rounds: off {off:.0} us, on {on:.0} us, opcua {ua:.0} us; on/off = {:.2}, opcua/off = {:.2}",
            on / off.max(1e-9),
            ua / off.max(1e-9)
        );
    }
    if let Some((mut c, _)) = broker {
        let _ = c.kill();
        let _ = c.wait();
    }
    let _ = std::fs::remove_dir_all(&dir);
}
