//! MTConnect SHDR adapter: a TCP server (conventionally port 7878) that an MTConnect agent
//! (or any SHDR reader) connects to.
//!
//! Lines (`\n`-terminated, UTF-8):
//! - data items: `<timestamp>|<item>|<value>|<item>|<value>…` — on connect one line with
//!   every item of [`crate::items::ITEMS`] (the full snapshot), then per period one line
//!   with the items that changed;
//! - conditions, one per line: `<timestamp>|<name>|NORMAL||||` or
//!   `<timestamp>|<name>|WARNING|<code>|||<text>` / `…|FAULT|<code>|||<text>`; all of them in
//!   the snapshot, then when they change;
//! - heartbeat: a client's `* PING` is answered `* PONG <ms>` ([`PONG_MS`]).
//!
//! Timestamps are UTC wall time, ISO 8601 with milliseconds (`2026-11-24T09:47:17.123Z`).
//!
//! Threads: the hub (reads the records from a [`Subscriber`] of the runtime's tap, keeps the
//! last values, fans the lines out), the acceptor, and one thread per client. A client gets
//! its lines through a bounded queue: a slow client loses lines (counted in
//! [`ShdrStats::lines_dropped`]) and is disconnected when its socket write times out; the
//! control loop never sees any of it (the tap itself never blocks).

use std::io::{BufRead, BufReader, ErrorKind, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use acc_runtime::tap::Subscriber;
use acc_runtime::RunRecord;
use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender, TrySendError};

use crate::items::{levels, values, Level, CONDITIONS, ITEMS};

/// Heartbeat announced in `* PONG <ms>`: the agent considers the adapter gone after twice
/// this without data or a PONG.
pub const PONG_MS: u64 = 10_000;

/// Lines queued per client before it starts losing them.
pub const CLIENT_QUEUE: usize = 1024;

/// Counters of a running adapter.
#[derive(Debug, Default)]
pub struct ShdrStats {
    /// Clients connected now.
    pub clients: AtomicUsize,
    /// Clients accepted since the start.
    pub accepted: AtomicU64,
    /// Records received from the tap.
    pub records: AtomicU64,
    /// Lines not sent because a client's queue was full.
    pub lines_dropped: AtomicU64,
}

/// A running SHDR adapter; [`ShdrServer::stop`] (or drop) ends its threads.
#[derive(Debug)]
pub struct ShdrServer {
    addr: SocketAddr,
    stats: Arc<ShdrStats>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

/// UTC ISO 8601 timestamp with milliseconds of `t`.
pub fn timestamp(t: SystemTime) -> String {
    let d = t.duration_since(UNIX_EPOCH).unwrap_or_default();
    let secs = d.as_secs();
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60,
        d.subsec_millis()
    )
}

/// Escape a value for SHDR: `|` and newlines would break the line.
fn clean(v: &str) -> String {
    v.replace(['|', '\n', '\r'], " ")
}

/// The SHDR lines of a condition.
fn condition_line(ts: &str, idx: usize, level: Level) -> String {
    let (name, _, _, code, text) = CONDITIONS[idx];
    match level {
        Level::Normal => format!("{ts}|{name}|NORMAL||||"),
        l => format!("{ts}|{name}|{}|{code}|||{}", l.name(), clean(text)),
    }
}

/// What the hub knows: the last values sent.
struct State {
    values: Vec<String>,
    levels: Vec<Level>,
}

impl State {
    fn unavailable() -> Self {
        Self {
            values: vec![crate::items::UNAVAILABLE.to_string(); ITEMS.len()],
            levels: vec![Level::Normal; CONDITIONS.len()],
        }
    }

    /// Full snapshot lines (conditions start UNAVAILABLE-free: NORMAL unless an alarm is on).
    fn snapshot(&self, ts: &str) -> Vec<String> {
        let mut line = ts.to_string();
        for (n, v) in ITEMS.iter().zip(&self.values) {
            line.push('|');
            line.push_str(n);
            line.push('|');
            line.push_str(&clean(v));
        }
        let mut out = vec![line];
        out.extend((0..CONDITIONS.len()).map(|i| condition_line(ts, i, self.levels[i])));
        out
    }

    /// Apply `r`; the lines of what changed.
    fn update(&mut self, ts: &str, r: &RunRecord) -> Vec<String> {
        let mut out = Vec::new();
        let mut line = ts.to_string();
        for (i, v) in values(r).into_iter().enumerate() {
            if self.values[i] != v {
                line.push('|');
                line.push_str(ITEMS[i]);
                line.push('|');
                line.push_str(&clean(&v));
                self.values[i] = v;
            }
        }
        if line.len() > ts.len() {
            out.push(line);
        }
        for (i, l) in levels(r).into_iter().enumerate() {
            if self.levels[i] != l {
                self.levels[i] = l;
                out.push(condition_line(ts, i, l));
            }
        }
        out
    }
}

struct Client {
    tx: Sender<Arc<str>>,
    gone: Arc<AtomicBool>,
}

impl ShdrServer {
    /// Bind `addr` (e.g. `0.0.0.0:7878`, or port 0 for any free port) and serve the records
    /// of `sub`. Errors only if the address cannot be bound.
    pub fn start(addr: &str, sub: Subscriber) -> std::io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let local = listener.local_addr()?;
        let stats = Arc::new(ShdrStats::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (new_tx, new_rx) = bounded::<TcpStream>(16);
        let mut threads = Vec::new();
        {
            let (stop, stats) = (stop.clone(), stats.clone());
            threads.push(
                std::thread::Builder::new()
                    .name("shdr-accept".into())
                    .spawn(move || accept_loop(listener, new_tx, stop, stats))?,
            );
        }
        {
            let (stop, stats) = (stop.clone(), stats.clone());
            threads.push(
                std::thread::Builder::new()
                    .name("shdr-hub".into())
                    .spawn(move || hub_loop(sub, new_rx, stop, stats))?,
            );
        }
        tracing::info!(addr = %local, "MTConnect SHDR adapter listening");
        Ok(Self {
            addr: local,
            stats,
            stop,
            threads,
        })
    }

    /// The bound address (the real port when started on port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Counters.
    pub fn stats(&self) -> &ShdrStats {
        &self.stats
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.stats.clients.load(Ordering::SeqCst)
    }

    /// Stop: the hub sends what it has queued, the client connections close.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for ShdrServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}

fn accept_loop(
    listener: TcpListener,
    new_tx: Sender<TcpStream>,
    stop: Arc<AtomicBool>,
    stats: Arc<ShdrStats>,
) {
    while !stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((s, peer)) => {
                tracing::info!(%peer, "SHDR client connected");
                stats.accepted.fetch_add(1, Ordering::SeqCst);
                if new_tx.send(s).is_err() {
                    return;
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!(error = %e, "SHDR accept failed");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

fn hub_loop(
    sub: Subscriber,
    new_rx: Receiver<TcpStream>,
    stop: Arc<AtomicBool>,
    stats: Arc<ShdrStats>,
) {
    let mut state = State::unavailable();
    let mut clients: Vec<(Client, JoinHandle<()>)> = Vec::new();
    let send = |clients: &mut Vec<(Client, JoinHandle<()>)>, lines: &[String]| {
        clients.retain(|(c, _)| !c.gone.load(Ordering::SeqCst));
        for (c, _) in clients.iter() {
            for l in lines {
                match c.tx.try_send(Arc::from(l.as_str())) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => {
                        stats.lines_dropped.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(TrySendError::Disconnected(_)) => {}
                }
            }
        }
    };
    loop {
        for s in new_rx.try_iter() {
            let (tx, rx) = bounded::<Arc<str>>(CLIENT_QUEUE);
            let gone = Arc::new(AtomicBool::new(false));
            for l in state.snapshot(&timestamp(SystemTime::now())) {
                let _ = tx.try_send(Arc::from(l.as_str()));
            }
            let (g, st) = (gone.clone(), stats.clone());
            st.clients.fetch_add(1, Ordering::SeqCst);
            match std::thread::Builder::new()
                .name("shdr-client".into())
                .spawn(move || {
                    client_loop(s, rx, &g);
                    g.store(true, Ordering::SeqCst);
                    st.clients.fetch_sub(1, Ordering::SeqCst);
                }) {
                Ok(h) => clients.push((Client { tx, gone }, h)),
                Err(e) => {
                    stats.clients.fetch_sub(1, Ordering::SeqCst);
                    tracing::warn!(error = %e, "cannot start an SHDR client thread");
                }
            }
        }
        match sub.recv_timeout(Duration::from_millis(20)) {
            Ok(r) => {
                stats.records.fetch_add(1, Ordering::Relaxed);
                let ts = timestamp(SystemTime::now());
                let mut lines = state.update(&ts, &r);
                // Whatever else is queued goes out in the same pass.
                for r in sub.try_iter() {
                    stats.records.fetch_add(1, Ordering::Relaxed);
                    lines.extend(state.update(&ts, &r));
                }
                send(&mut clients, &lines);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                // The run ended: keep serving the last values until stopped.
                if stop.load(Ordering::SeqCst) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        if stop.load(Ordering::SeqCst) && sub.receiver().is_empty() {
            break;
        }
    }
    // Closing the queues ends the client threads once they have written what is queued.
    let handles: Vec<JoinHandle<()>> = clients
        .into_iter()
        .map(|(c, h)| {
            drop(c);
            h
        })
        .collect();
    for h in handles {
        let _ = h.join();
    }
}

fn client_loop(stream: TcpStream, rx: Receiver<Arc<str>>, gone: &AtomicBool) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(Duration::from_secs(2)));
    let _ = stream.set_read_timeout(Some(Duration::from_millis(5)));
    let Ok(read_half) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(read_half);
    let mut out = std::io::BufWriter::new(stream);
    let mut inbuf = String::new();
    loop {
        // Lines to send (waits at most 20 ms, then looks for a PING).
        let first = rx.recv_timeout(Duration::from_millis(20));
        let closed = matches!(first, Err(RecvTimeoutError::Disconnected));
        let mut batch: Vec<Arc<str>> = first.into_iter().collect();
        batch.extend(rx.try_iter());
        for l in &batch {
            if out
                .write_all(l.as_bytes())
                .and_then(|()| out.write_all(b"\n"))
                .is_err()
            {
                gone.store(true, Ordering::SeqCst);
                return;
            }
        }
        if out.flush().is_err() {
            return;
        }
        if closed {
            return;
        }
        match reader.read_line(&mut inbuf) {
            Ok(0) => return, // the client closed
            Ok(_) => {
                if inbuf.ends_with('\n') {
                    if inbuf.trim_end().starts_with("* PING") {
                        let pong = format!("* PONG {PONG_MS}\n");
                        if out
                            .write_all(pong.as_bytes())
                            .and_then(|()| out.flush())
                            .is_err()
                        {
                            return;
                        }
                    }
                    inbuf.clear();
                }
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use acc_runtime::tap::Tap;

    #[test]
    fn timestamps_are_iso_utc() {
        let t = UNIX_EPOCH + Duration::from_millis(1_795_996_037_123);
        assert_eq!(timestamp(t), "2026-11-29T23:47:17.123Z");
        assert_eq!(timestamp(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
    }

    #[test]
    fn snapshot_then_changes_only() {
        let mut s = State::unavailable();
        let snap = s.snapshot("T");
        assert!(snap[0].starts_with("T|avail|UNAVAILABLE|execution|UNAVAILABLE"));
        assert_eq!(snap.len(), 1 + CONDITIONS.len());
        assert_eq!(snap[1], "T|link_cond|NORMAL||||");
        let r = RunRecord {
            period: 1,
            force_n: Some(800.0),
            state: "active".into(),
            ..RunRecord::default()
        };
        let l = s.update("T", &r);
        assert!(l[0].contains("|Fc|800.0"), "{l:?}");
        // Same values again: only the period changes.
        let r2 = RunRecord { period: 2, ..r };
        assert_eq!(s.update("T", &r2), vec!["T|acc_period|2".to_string()]);
        let r3 = RunRecord {
            alarms: 1 << 4,
            ..r2
        };
        let l = s.update("T", &r3);
        assert_eq!(
            l,
            vec!["T|overload_cond|FAULT|OVERLOAD|||cutting force above the overload limit: feed hold".to_string()]
        );
    }

    #[test]
    fn serves_snapshot_changes_and_pong_over_tcp() {
        let tap = Tap::new();
        let srv = ShdrServer::start("127.0.0.1:0", tap.subscribe(64)).expect("bind");
        let mut c = TcpStream::connect(srv.local_addr()).expect("connect");
        c.set_read_timeout(Some(Duration::from_secs(5)))
            .expect("timeout");
        let mut rd = BufReader::new(c.try_clone().expect("clone"));
        let mut line = String::new();
        rd.read_line(&mut line).expect("snapshot");
        assert!(line.contains("|avail|UNAVAILABLE|"), "{line}");
        for _ in 0..CONDITIONS.len() {
            line.clear();
            rd.read_line(&mut line).expect("condition");
        }
        tap.publish(&RunRecord {
            period: 7,
            force_n: Some(640.5),
            ..RunRecord::default()
        });
        line.clear();
        rd.read_line(&mut line).expect("change");
        assert!(
            line.contains("|Fc|640.5|") && line.contains("|acc_period|7"),
            "{line}"
        );
        c.write_all(b"* PING\n").expect("ping");
        line.clear();
        rd.read_line(&mut line).expect("pong");
        assert_eq!(line.trim_end(), format!("* PONG {PONG_MS}"));
        srv.stop();
    }

    #[test]
    fn a_client_that_never_reads_does_not_slow_the_publisher() {
        let tap = Tap::new();
        let sub = tap.subscribe(64);
        let srv = ShdrServer::start("127.0.0.1:0", sub.clone()).expect("bind");
        let _stalled = TcpStream::connect(srv.local_addr()).expect("connect");
        let t0 = std::time::Instant::now();
        while srv.clients() == 0 && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
        }
        let t0 = std::time::Instant::now();
        for p in 0..50_000u64 {
            tap.publish(&RunRecord {
                period: p,
                force_n: Some(p as f64),
                kc_hat: Some(p as f64 / 7.0),
                ..RunRecord::default()
            });
        }
        let took = t0.elapsed();
        assert!(
            took < Duration::from_secs(2),
            "50 000 publishes took {took:?}"
        );
        // The stalled client's queue and socket filled up: lines or records were dropped.
        std::thread::sleep(Duration::from_millis(200));
        let lost = srv.stats().lines_dropped.load(Ordering::Relaxed) + sub.dropped();
        assert!(lost > 0, "nothing dropped for a client that never reads");
        drop(sub);
        let t1 = std::time::Instant::now();
        drop(tap);
        srv.stop();
        assert!(
            t1.elapsed() < Duration::from_secs(5),
            "stop took {:?}",
            t1.elapsed()
        );
    }
}
