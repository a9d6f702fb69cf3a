//! The live view: a small HTTP server (std only, its own threads) that serves one page
//! embedded in the binary and streams every period's record to it over Server-Sent Events.
//!
//! Routes:
//! - `GET /` — the page (`live/index.html`, `include_str!`: no CDN, works with no network):
//!   force against time with Fr and the overload line, override commanded / applied /
//!   operator, the Kc_hat trend, the state (air / entry / cut / hold / alarm) as colour, the
//!   active tool and its Fr, the alarms with an acknowledge button, and the count of
//!   records dropped for that client;
//! - `GET /events` — `text/event-stream`: a `hello` event (server settings), then the
//!   last [`HISTORY`] records as one batch, then one batch per [`BATCH_MS`] at most (every
//!   record, as they come: ≥ 10 Hz while the loop runs at T = 0.1 s), each
//!   `data: {"dropped":N,"recs":[…]}`; `ack` events when someone acknowledges; an `end`
//!   event when the run is over;
//! - `POST /ack` (body `alarms=<bits>&period=<p>`) — acknowledge the alarms **in the
//!   view only**: the server holds no handle to the control loop (it only reads a tap
//!   [`Subscriber`]), so an acknowledge cannot change the machine;
//! - `GET /status` — the counters as JSON ([`LiveStats`]).
//!
//! Threads: the hub (reads the tap subscriber every [`BATCH_MS`], keeps the history, fans
//! the records out),
//! the acceptor, and one thread per connection. Each SSE client has a bounded queue of
//! [`CLIENT_QUEUE`] records: a slow client loses records (counted, and shown on its page)
//! and never holds up the hub; the control loop only ever calls `Tap::publish`, which
//! never waits.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use acc_runtime::tap::Subscriber;
use acc_runtime::RunRecord;
use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender, TrySendError};

/// The page, embedded in the binary.
pub const PAGE: &str = include_str!("live/index.html");

/// Records replayed to a client when it connects (60 s at T = 0.1 s).
pub const HISTORY: usize = 600;

/// Messages queued per SSE client before it starts losing records.
pub const CLIENT_QUEUE: usize = 256;

/// Shortest time between two SSE events to one client, ms (at most 20 events/s; each
/// event carries every record that came meanwhile).
pub const BATCH_MS: u64 = 50;

/// How long a write to a client may block before the client is dropped, s.
const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// Counters of a running live view.
#[derive(Debug, Default)]
pub struct LiveStats {
    /// SSE clients connected now.
    pub clients: AtomicUsize,
    /// SSE clients accepted since the start.
    pub accepted: AtomicU64,
    /// Records received from the tap.
    pub records: AtomicU64,
    /// Records not delivered to a client because its queue was full (all clients).
    pub dropped: AtomicU64,
    /// Acknowledges received (view only).
    pub acks: AtomicU64,
}

/// Settings the page shows beside the records.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveInfo {
    /// What runs (scenario name, config file), shown as the page's subtitle.
    pub title: String,
    /// The fault policy's overload limit, N (the overload line); `None`: 2 × Fr, the
    /// policy's default.
    pub overload_n: Option<f64>,
}

/// One message to an SSE client.
#[derive(Debug, Clone)]
enum Msg {
    /// A record, already JSON.
    Rec(Arc<str>),
    /// An acknowledge, JSON.
    Ack(Arc<str>),
    /// The run is over.
    End,
}

struct Client {
    tx: Sender<Msg>,
    dropped: Arc<AtomicU64>,
}

struct Shared {
    history: VecDeque<Arc<str>>,
    clients: Vec<Client>,
    info: LiveInfo,
    /// Alarms acknowledged in the view (bits) and the period of that acknowledge.
    ack: Option<(u8, u64)>,
    ended: bool,
}

struct Ctx {
    shared: Mutex<Shared>,
    stats: Arc<LiveStats>,
    stop: AtomicBool,
    /// Records the tap dropped for the hub (its own queue full).
    tap_dropped: Box<dyn Fn() -> u64 + Send + Sync>,
}

impl Ctx {
    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A running live view; [`LiveServer::stop`] (or drop) ends its threads.
pub struct LiveServer {
    addr: SocketAddr,
    ctx: Arc<Ctx>,
    threads: Vec<JoinHandle<()>>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("addr", &self.addr)
            .field("stats", &self.ctx.stats)
            .finish_non_exhaustive()
    }
}

fn num(v: Option<f64>) -> serde_json::Value {
    match v {
        Some(x) if x.is_finite() => serde_json::Value::from((x * 1000.0).round() / 1000.0),
        _ => serde_json::Value::Null,
    }
}

/// The JSON of one record as the page reads it (short keys; `null` when unknown): `p`
/// period, `t` s, `f` force N, `fr` Fr N, `oc` / `oa` / `oo` override commanded / applied /
/// operator %, `kc` Kc_hat N/(mm/min), `st` policy state, `fl` flags, `al` alarm bits,
/// `fh` feed hold, `tool`, `prog`, `blk`.
pub fn point_json(r: &RunRecord) -> String {
    serde_json::json!({
        "p": r.period,
        "t": num(Some(r.t_s)),
        "f": num(r.force_n),
        "fr": num(r.force_ref_n),
        "oc": r.override_cmd_pct,
        "oa": r.override_applied_pct,
        "oo": r.override_operator_pct,
        "kc": r.kc_hat.filter(|x| x.is_finite()),
        "st": r.state,
        "fl": r.flags,
        "al": r.alarms,
        "fh": r.feed_hold,
        "tool": r.tool,
        "prog": r.program,
        "blk": r.block,
    })
    .to_string()
}

impl LiveServer {
    /// Listen on `addr` (e.g. `127.0.0.1:8080`; port 0 picks a free one) and serve the
    /// records `sub` receives.
    pub fn start(addr: &str, sub: Subscriber, info: LiveInfo) -> std::io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        listener.set_nonblocking(true)?;
        let tap_sub = sub.clone();
        let ctx = Arc::new(Ctx {
            shared: Mutex::new(Shared {
                history: VecDeque::with_capacity(HISTORY),
                clients: Vec::new(),
                info,
                ack: None,
                ended: false,
            }),
            stats: Arc::new(LiveStats::default()),
            stop: AtomicBool::new(false),
            tap_dropped: Box::new(move || tap_sub.dropped()),
        });
        let hub = {
            let ctx = ctx.clone();
            std::thread::Builder::new()
                .name("live-hub".into())
                .spawn(move || hub(&ctx, &sub))?
        };
        let acceptor = {
            let ctx = ctx.clone();
            std::thread::Builder::new()
                .name("live-accept".into())
                .spawn(move || accept(&ctx, &listener))?
        };
        Ok(Self {
            addr,
            ctx,
            threads: vec![hub, acceptor],
        })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Its counters.
    pub fn stats(&self) -> &LiveStats {
        &self.ctx.stats
    }

    /// Replace the settings the page shows (clients connecting from now on get them).
    pub fn set_info(&self, info: LiveInfo) {
        self.ctx.lock().info = info;
    }

    /// Stop serving and join the threads (connection threads end at their next write). When
    /// the tap is gone (the run is over), the clients first get the last records and the
    /// `end` event. Returns the final counters.
    pub fn stop(mut self) -> Arc<LiveStats> {
        self.shutdown();
        self.ctx.stats.clone()
    }

    fn shutdown(&mut self) {
        if self.threads.is_empty() {
            return;
        }
        // Once the run is over (every tap clone dropped), let the hub hand out the last
        // records and the clients write them and the `end` event (at most ~0.6 s).
        let t0 = Instant::now();
        while !self.ctx.lock().ended && t0.elapsed() < Duration::from_millis(500) {
            std::thread::sleep(Duration::from_millis(10));
        }
        if self.ctx.lock().ended {
            std::thread::sleep(Duration::from_millis(2 * BATCH_MS));
        }
        self.ctx.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Offer `msg` to every client without waiting; a full queue loses it (counted).
fn fan_out(ctx: &Ctx, sh: &mut Shared, msg: &Msg) {
    sh.clients.retain(|c| match c.tx.try_send(msg.clone()) {
        Ok(()) => true,
        Err(TrySendError::Full(_)) => {
            c.dropped.fetch_add(1, Ordering::Relaxed);
            ctx.stats.dropped.fetch_add(1, Ordering::Relaxed);
            true
        }
        Err(TrySendError::Disconnected(_)) => false,
    });
}

fn hub(ctx: &Ctx, sub: &Subscriber) {
    while !ctx.stop.load(Ordering::Relaxed) {
        match sub.recv_timeout(Duration::from_millis(100)) {
            Ok(first) => {
                // Everything queued now, fanned out at once; then wait a batch interval:
                // the hub and the clients wake at most 20 times a second, whatever T is
                // (fewer wake-ups competing with the control thread for the CPUs).
                let recs: Vec<_> = std::iter::once(first).chain(sub.try_iter()).collect();
                ctx.stats
                    .records
                    .fetch_add(recs.len() as u64, Ordering::Relaxed);
                let js: Vec<Arc<str>> = recs.iter().map(|r| point_json(r).into()).collect();
                let mut sh = ctx.lock();
                for j in js {
                    if sh.history.len() == HISTORY {
                        sh.history.pop_front();
                    }
                    sh.history.push_back(j.clone());
                    fan_out(ctx, &mut sh, &Msg::Rec(j));
                }
                drop(sh);
                std::thread::sleep(Duration::from_millis(BATCH_MS));
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                // The run is over: tell the clients, keep serving the history.
                let mut sh = ctx.lock();
                sh.ended = true;
                fan_out(ctx, &mut sh, &Msg::End);
                drop(sh);
                while !ctx.stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
        }
    }
}

fn accept(ctx: &Arc<Ctx>, listener: &TcpListener) {
    while !ctx.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((s, _)) => {
                let ctx = ctx.clone();
                let _ = std::thread::Builder::new()
                    .name("live-conn".into())
                    .spawn(move || {
                        if let Err(e) = connection(&ctx, s) {
                            tracing::debug!("live view connection: {e}");
                        }
                    });
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!("live view accept: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// A parsed request: method, path, body.
fn read_request(s: &TcpStream) -> std::io::Result<(String, String, String)> {
    let mut r = BufReader::new(s.try_clone()?);
    let mut line = String::new();
    r.read_line(&mut line)?;
    let mut it = line.split_whitespace();
    let method = it.next().unwrap_or("").to_string();
    let path = it.next().unwrap_or("").to_string();
    let mut len = 0usize;
    loop {
        let mut h = String::new();
        if r.read_line(&mut h)? == 0 || h.trim().is_empty() {
            break;
        }
        if let Some((k, v)) = h.split_once(':') {
            if k.trim().eq_ignore_ascii_case("content-length") {
                len = v.trim().parse().unwrap_or(0).min(4096);
            }
        }
    }
    let mut body = vec![0; len];
    r.read_exact(&mut body)?;
    Ok((method, path, String::from_utf8_lossy(&body).into_owned()))
}

fn respond(s: &mut TcpStream, status: &str, ctype: &str, body: &str) -> std::io::Result<()> {
    write!(
        s,
        "HTTP/1.1 {status}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )?;
    s.flush()
}

fn connection(ctx: &Ctx, mut s: TcpStream) -> std::io::Result<()> {
    s.set_nonblocking(false)?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    s.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let _ = s.set_nodelay(true);
    let (method, path, body) = read_request(&s)?;
    let path = path.split('?').next().unwrap_or("");
    match (method.as_str(), path) {
        ("GET", "/" | "/index.html") => respond(&mut s, "200 OK", "text/html; charset=utf-8", PAGE),
        ("GET", "/events") => events(ctx, s),
        ("GET", "/status") => {
            let st = &ctx.stats;
            let body = serde_json::json!({
                "clients": st.clients.load(Ordering::Relaxed),
                "accepted": st.accepted.load(Ordering::Relaxed),
                "records": st.records.load(Ordering::Relaxed),
                "dropped": st.dropped.load(Ordering::Relaxed),
                "tap_dropped": (ctx.tap_dropped)(),
                "acks": st.acks.load(Ordering::Relaxed),
            })
            .to_string();
            respond(&mut s, "200 OK", "application/json", &body)
        }
        ("POST", "/ack") => {
            let field = |k: &str| {
                body.split('&')
                    .filter_map(|kv| kv.split_once('='))
                    .find(|(a, _)| a.trim() == k)
                    .and_then(|(_, v)| v.trim().parse::<u64>().ok())
            };
            let (Some(alarms), Some(period)) = (field("alarms"), field("period")) else {
                return respond(
                    &mut s,
                    "400 Bad Request",
                    "text/plain",
                    "expected alarms=<bits 0..=255>&period=<period>\n",
                );
            };
            let alarms = u8::try_from(alarms).unwrap_or(u8::MAX);
            ctx.stats.acks.fetch_add(1, Ordering::Relaxed);
            tracing::info!(
                alarms,
                period,
                "live view: alarms acknowledged in the view (the machine is not changed)"
            );
            let j: Arc<str> = serde_json::json!({ "alarms": alarms, "period": period })
                .to_string()
                .into();
            let mut sh = ctx.lock();
            sh.ack = Some((alarms, period));
            fan_out(ctx, &mut sh, &Msg::Ack(j));
            drop(sh);
            respond(&mut s, "204 No Content", "text/plain", "")
        }
        ("GET", _) => respond(&mut s, "404 Not Found", "text/plain", "not found\n"),
        _ => respond(
            &mut s,
            "405 Method Not Allowed",
            "text/plain",
            "GET /, /events, /status; POST /ack\n",
        ),
    }
}

/// Serve one SSE client until it goes away or the server stops.
fn events(ctx: &Ctx, mut s: TcpStream) -> std::io::Result<()> {
    let (tx, rx): (Sender<Msg>, Receiver<Msg>) = bounded(CLIENT_QUEUE);
    let dropped = Arc::new(AtomicU64::new(0));
    // Register and take the history under one lock: nothing is lost or sent twice.
    let (history, hello, ack, ended) = {
        let mut sh = ctx.lock();
        sh.clients.push(Client {
            tx,
            dropped: dropped.clone(),
        });
        let hello = serde_json::json!({
            "title": sh.info.title,
            "overload_n": sh.info.overload_n,
            "history": sh.history.len(),
        })
        .to_string();
        let ack = sh
            .ack
            .map(|(a, p)| serde_json::json!({ "alarms": a, "period": p }).to_string());
        (
            sh.history.iter().cloned().collect::<Vec<_>>(),
            hello,
            ack,
            sh.ended,
        )
    };
    ctx.stats.accepted.fetch_add(1, Ordering::Relaxed);
    ctx.stats.clients.fetch_add(1, Ordering::Relaxed);
    let r = stream(ctx, &mut s, &rx, &dropped, (history, hello, ack, ended));
    ctx.stats.clients.fetch_sub(1, Ordering::Relaxed);
    r
}

type Greeting = (Vec<Arc<str>>, String, Option<String>, bool);

fn batch(out: &mut String, recs: &[Arc<str>], dropped: u64) {
    out.push_str("data: {\"dropped\":");
    out.push_str(&dropped.to_string());
    out.push_str(",\"recs\":[");
    for (i, r) in recs.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push_str(r);
    }
    out.push_str("]}\n\n");
}

fn stream(
    ctx: &Ctx,
    s: &mut TcpStream,
    rx: &Receiver<Msg>,
    dropped: &AtomicU64,
    (history, hello, ack, ended): Greeting,
) -> std::io::Result<()> {
    let count = || dropped.load(Ordering::Relaxed) + (ctx.tap_dropped)();
    let mut out = String::from(
        "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\nX-Accel-Buffering: no\r\n\r\nretry: 1000\n\n",
    );
    out.push_str(&format!("event: hello\ndata: {hello}\n\n"));
    batch(&mut out, &history, count());
    if let Some(a) = ack {
        out.push_str(&format!("event: ack\ndata: {a}\n\n"));
    }
    if ended {
        out.push_str("event: end\ndata: {}\n\n");
    }
    s.write_all(out.as_bytes())?;
    s.flush()?;
    let mut last = Instant::now();
    while !ctx.stop.load(Ordering::Relaxed) {
        let first = match rx.recv_timeout(Duration::from_secs(1)) {
            Ok(m) => m,
            Err(RecvTimeoutError::Timeout) => {
                // Keep-alive: also finds a client that went away.
                s.write_all(b": keepalive\n\n")?;
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => return Ok(()),
        };
        // At most one event per BATCH_MS: what comes meanwhile joins the batch.
        let wait = Duration::from_millis(BATCH_MS).saturating_sub(last.elapsed());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        let mut recs = Vec::new();
        let mut out = String::new();
        for m in std::iter::once(first).chain(rx.try_iter()) {
            match m {
                Msg::Rec(j) => recs.push(j),
                Msg::Ack(j) => out.push_str(&format!("event: ack\ndata: {j}\n\n")),
                Msg::End => out.push_str("event: end\ndata: {}\n\n"),
            }
        }
        let mut all = String::new();
        if !recs.is_empty() {
            batch(&mut all, &recs, count());
        }
        all.push_str(&out);
        s.write_all(all.as_bytes())?;
        s.flush()?;
        last = Instant::now();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use acc_runtime::tap::Tap;

    fn get(addr: SocketAddr, req: &str) -> String {
        let mut s = TcpStream::connect(addr).expect("connect");
        s.write_all(req.as_bytes()).expect("write");
        let mut out = String::new();
        s.read_to_string(&mut out).expect("read");
        out
    }

    fn rec(p: u64, alarms: u8) -> RunRecord {
        RunRecord {
            period: p,
            t_s: p as f64 * 0.1,
            force_n: Some(700.0 + p as f64),
            force_ref_n: Some(800.0),
            state: "active".into(),
            alarms,
            ..RunRecord::default()
        }
    }

    /// Read SSE text from `s` until `pred` holds on what came so far (or 5 s pass).
    fn read_until(s: &mut TcpStream, pred: impl Fn(&str) -> bool) -> String {
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .expect("timeout");
        let mut got = String::new();
        let t0 = Instant::now();
        let mut buf = [0u8; 4096];
        while !pred(&got) && t0.elapsed() < Duration::from_secs(5) {
            match s.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => got.push_str(&String::from_utf8_lossy(&buf[..n])),
                Err(_) => {}
            }
        }
        got
    }

    /// Read what is there until nothing comes for 300 ms.
    fn drain(s: &mut TcpStream) {
        s.set_read_timeout(Some(Duration::from_millis(300)))
            .expect("timeout");
        let mut buf = [0u8; 65536];
        while matches!(s.read(&mut buf), Ok(n) if n > 0) {}
    }

    #[test]
    fn serves_the_page_history_live_records_acks_and_counts_a_slow_clients_drops() {
        let tap = Tap::new();
        let srv = LiveServer::start(
            "127.0.0.1:0",
            tap.subscribe(1024),
            LiveInfo {
                title: "unit".into(),
                overload_n: Some(1600.0),
            },
        )
        .expect("listen");
        let a = srv.local_addr();
        let page = get(a, "GET / HTTP/1.1\r\nHost: x\r\n\r\n");
        assert!(
            page.starts_with("HTTP/1.1 200 OK") && page.contains("<canvas"),
            "{page:.200}"
        );
        assert!(page.contains("does not change the machine"));
        assert!(get(a, "GET /nope HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));

        for p in 0..5 {
            tap.publish(&rec(p, 0));
        }
        // Wait for the hub to take the 5 records into its history.
        let t0 = Instant::now();
        while srv.stats().records.load(Ordering::Relaxed) < 5 && t0.elapsed().as_secs() < 5 {
            std::thread::sleep(Duration::from_millis(10));
        }
        let mut sse = TcpStream::connect(a).expect("connect");
        sse.write_all(b"GET /events HTTP/1.1\r\n\r\n")
            .expect("write");
        let got = read_until(&mut sse, |g| g.contains("\"p\":4"));
        assert!(got.contains("text/event-stream"), "{got}");
        assert!(got.contains("\"overload_n\":1600.0") && got.contains("\"title\":\"unit\""));
        assert!(
            got.contains("\"p\":0") && got.contains("\"p\":4"),
            "history: {got}"
        );

        tap.publish(&rec(5, 0b1_0000));
        let got = read_until(&mut sse, |g| g.contains("\"p\":5"));
        assert!(got.contains("\"al\":16"), "live record: {got}");

        let ack = get(
            a,
            "POST /ack HTTP/1.1\r\nContent-Length: 19\r\n\r\nalarms=16&period=5\n",
        );
        assert!(ack.starts_with("HTTP/1.1 204"), "{ack}");
        let got = read_until(&mut sse, |g| g.contains("event: ack"));
        assert!(got.contains("\"alarms\":16"), "{got}");
        assert_eq!(srv.stats().acks.load(Ordering::Relaxed), 1);
        let bad = get(a, "POST /ack HTTP/1.1\r\nContent-Length: 3\r\n\r\nx=1");
        assert!(bad.starts_with("HTTP/1.1 400"), "{bad}");

        // A client that never reads: publishing stays immediate, its records are dropped
        // and counted, the first client still gets the newest record.
        let mut slow = TcpStream::connect(a).expect("connect");
        slow.write_all(b"GET /events HTTP/1.1\r\n\r\n")
            .expect("write");
        let t0 = Instant::now();
        while srv.stats().clients.load(Ordering::Relaxed) < 2 && t0.elapsed().as_secs() < 5 {
            std::thread::sleep(Duration::from_millis(10));
        }
        let t0 = Instant::now();
        for p in 6..20_006 {
            tap.publish(&rec(p, 0));
        }
        assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
        // The flood overran the queues (20 000 records in far less than one batch
        // interval); once it is over, the reading client gets the next record at once.
        std::thread::sleep(Duration::from_millis(300));
        drain(&mut sse);
        tap.publish(&rec(99_999, 0));
        let got = read_until(&mut sse, |g| g.contains("\"p\":99999"));
        assert!(
            got.contains("\"p\":99999"),
            "reading client lags: {got:.300}"
        );
        let t0 = Instant::now();
        while srv.stats().dropped.load(Ordering::Relaxed) == 0 && t0.elapsed().as_secs() < 10 {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(srv.stats().dropped.load(Ordering::Relaxed) > 0);
        let status = get(a, "GET /status HTTP/1.1\r\n\r\n");
        assert!(status.contains("\"acks\":1"), "{status}");

        // The run ends: the clients are told.
        drop(tap);
        let got = read_until(&mut sse, |g| g.contains("event: end"));
        assert!(got.contains("event: end"), "{got:.300}");
        drop(slow);
        srv.stop();
    }
}
