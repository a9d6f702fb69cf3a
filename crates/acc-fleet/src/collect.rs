//! `acc collect`: subscribe to `PREFIX/+/period` and `PREFIX/+/cut` on an MQTT broker
//! (`+` is the machine id: a machine publishes with `--mqtt mqtt://host:port/PREFIX/MACHINE`)
//! and write the messages into the fleet store, the same partitions and schema as
//! `--fleet` ([`crate::store`]).
//!
//! Delivery: the collector's session is persistent (clean session off, a fixed client id),
//! it subscribes at QoS 1 and acknowledges a cut only after the file holding it is
//! committed, so a cut is either in the store or still held by the broker (redelivered
//! after a collector restart). The machines publish cuts at QoS 1, and rumqttc resends
//! an unacknowledged one after a reconnection. Periods are published at the machine's QoS
//! (0 by default): a period sent while the broker is down is lost to the store, not to the
//! machine's run log.
//!
//! Buffers are committed every [`CollectOptions::commit_every`], when
//! [`CollectOptions::max_unacked`] cuts wait for their commit, and at the end.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use acc_runtime::{Clock, SystemClock};

use rumqttc::{Client, Event, MqttOptions, Packet, Publish, QoS};
use serde::Deserialize;

use crate::schema::{CutRow, PeriodRow};
use crate::store::{check_machine_id, StoreWriter};
use crate::FleetError;

/// Pause between two connection attempts while the broker is down.
pub const RECONNECT_DELAY: Duration = Duration::from_millis(500);

/// What to collect and where.
#[derive(Debug, Clone)]
pub struct CollectOptions {
    /// Broker host.
    pub host: String,
    /// Broker port.
    pub port: u16,
    /// Topic prefix (no trailing `/`).
    pub prefix: String,
    /// Client id of the persistent session.
    pub client_id: String,
    /// The store.
    pub out: PathBuf,
    /// Commit the buffers at least this often.
    pub commit_every: Duration,
    /// Commit as soon as this many cuts wait for their acknowledgement.
    pub max_unacked: usize,
}

/// Counters of a running collector.
#[derive(Debug, Default)]
pub struct CollectStats {
    /// Period messages stored.
    pub periods: AtomicU64,
    /// Cut messages stored.
    pub cuts: AtomicU64,
    /// Cut messages received again (QoS 1 redelivery) and not stored twice.
    pub duplicates: AtomicU64,
    /// Messages that were not valid (topic or JSON); each logged.
    pub rejected: AtomicU64,
    /// Connections acknowledged by the broker.
    pub connects: AtomicU64,
    /// Connection errors (each followed by a retry).
    pub conn_errors: AtomicU64,
    /// Rows committed to Parquet (periods + cuts).
    pub committed: AtomicU64,
    /// Lag of the committed periods from the machine's publish (`sent_us`) to the commit.
    pub lag: std::sync::Mutex<LagHistogram>,
}

/// Lags in whole milliseconds, 0 ..= [`LagHistogram::MAX_MS`] (longer ones in the last
/// bucket).
#[derive(Debug, Clone)]
pub struct LagHistogram {
    counts: Vec<u64>,
    n: u64,
    max_ms: u64,
}

impl Default for LagHistogram {
    fn default() -> Self {
        Self {
            counts: vec![0; Self::MAX_MS as usize + 1],
            n: 0,
            max_ms: 0,
        }
    }
}

impl LagHistogram {
    /// The longest lag with its own bucket, ms.
    pub const MAX_MS: u64 = 600_000;

    /// Add one lag, µs (negative, from clocks that disagree, counts as 0).
    pub fn add_us(&mut self, lag_us: i64) {
        let ms = u64::try_from(lag_us.max(0) / 1000).unwrap_or(0);
        self.max_ms = self.max_ms.max(ms);
        self.counts[ms.min(Self::MAX_MS) as usize] += 1;
        self.n += 1;
    }

    /// Lags added.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// No lag added.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The `q`-quantile (0 ..= 1), ms; `None` when empty.
    pub fn quantile_ms(&self, q: f64) -> Option<u64> {
        if self.n == 0 {
            return None;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.n as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (ms, c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return Some(ms as u64);
            }
        }
        Some(self.max_ms)
    }

    /// The longest lag, ms.
    pub fn max_ms(&self) -> u64 {
        self.max_ms
    }
}

/// The fields of a `<prefix>/<machine>/period` message the store keeps (the publisher's
/// `acc_telemetry::mqtt::PeriodJson`).
#[derive(Debug, Deserialize)]
struct PeriodMsg {
    #[serde(default)]
    run_start_us: i64,
    #[serde(default)]
    sent_us: i64,
    period: u64,
    t_s: f64,
    #[serde(default)]
    flags: String,
    acc_state: String,
    tool: Option<u16>,
    program: Option<u16>,
    block: Option<u16>,
    spindle_rpm: Option<f64>,
    #[serde(default)]
    programmed_feed_mm_min: Option<f64>,
    feed_mm_min: Option<f64>,
    spindle_power_w: Option<f64>,
    force_n: Option<f64>,
    #[serde(default)]
    force_valid: bool,
    force_ref_n: Option<f64>,
    kc_hat: Option<f64>,
    override_cmd_pct: Option<u16>,
    override_applied_pct: Option<u16>,
    override_operator_pct: Option<u16>,
    feed_hold: bool,
    alarm_bits: u8,
}

impl PeriodMsg {
    fn row(self) -> PeriodRow {
        let int = |v: Option<u16>| v.map(i32::from);
        PeriodRow {
            run_start_us: self.run_start_us,
            period: i64::try_from(self.period).unwrap_or(i64::MAX),
            t_s: self.t_s,
            flags: self.flags,
            state: self.acc_state,
            tool: int(self.tool),
            program: int(self.program),
            block: int(self.block),
            spindle_rpm: self.spindle_rpm,
            programmed_feed_mm_min: self.programmed_feed_mm_min,
            feed_mm_min: self.feed_mm_min,
            power_w: self.spindle_power_w,
            force_n: self.force_n,
            force_valid: self.force_valid,
            force_ref_n: self.force_ref_n,
            kc_hat: self.kc_hat,
            override_cmd_pct: int(self.override_cmd_pct),
            override_applied_pct: int(self.override_applied_pct),
            override_operator_pct: int(self.override_operator_pct),
            feed_hold: self.feed_hold,
            alarms: i32::from(self.alarm_bits),
        }
    }
}

/// The fields of a `<prefix>/<machine>/cut` message (`acc_telemetry::mqtt::CutJson`).
#[derive(Debug, Deserialize)]
struct CutMsg {
    #[serde(default)]
    run_start_us: i64,
    tool: Option<u16>,
    program: Option<u16>,
    block_first: Option<u16>,
    block_last: Option<u16>,
    t_start_s: f64,
    time_in_cut_s: f64,
    force_mean_n: f64,
    force_max_n: f64,
    time_saved_s: f64,
    #[serde(default)]
    alarms: Vec<String>,
}

impl CutMsg {
    fn row(self) -> CutRow {
        let int = |v: Option<u16>| v.map(i32::from);
        CutRow {
            run_start_us: self.run_start_us,
            tool: int(self.tool),
            program: int(self.program),
            block_first: int(self.block_first),
            block_last: int(self.block_last),
            t_start_s: self.t_start_s,
            time_in_cut_s: self.time_in_cut_s,
            force_mean_n: self.force_mean_n,
            force_max_n: self.force_max_n,
            time_saved_s: self.time_saved_s,
            alarms: self
                .alarms
                .iter()
                .map(|a| run_log_alarm_name(a))
                .collect::<Vec<_>>()
                .join(";"),
        }
    }
}

/// The run log's name of an alarm as the MQTT cut message names it (`link` →
/// `link_lost`, `power` → `power_invalid`; the others are the same), so the store's `alarms`
/// are the same whichever way the cut came.
fn run_log_alarm_name(mqtt: &str) -> &str {
    match mqtt {
        "link" => "link_lost",
        "power" => "power_invalid",
        other => other,
    }
}

/// A message, parsed: the machine and its row.
#[derive(Debug)]
enum Parsed {
    /// The machine, the row and the publish time (µs since the epoch; 0: not sent).
    Period(String, PeriodRow, i64),
    Cut(String, CutRow),
}

/// Parse one message of `prefix/<machine>/period|cut`; the error says what is wrong.
fn parse(prefix: &str, topic: &str, payload: &[u8]) -> Result<Option<Parsed>, String> {
    let Some(rest) = topic.strip_prefix(prefix).and_then(|r| r.strip_prefix('/')) else {
        return Ok(None);
    };
    let Some((machine, leaf)) = rest.split_once('/') else {
        return Ok(None);
    };
    if leaf != "period" && leaf != "cut" {
        return Ok(None);
    }
    check_machine_id(machine).map_err(|e| format!("topic {topic}: {e}"))?;
    let bad = |e: serde_json::Error| format!("topic {topic}: not a {leaf} message: {e}");
    Ok(Some(if leaf == "period" {
        let m: PeriodMsg = serde_json::from_slice(payload).map_err(bad)?;
        let sent_us = m.sent_us;
        Parsed::Period(machine.to_string(), m.row(), sent_us)
    } else {
        let m: CutMsg = serde_json::from_slice(payload).map_err(bad)?;
        Parsed::Cut(machine.to_string(), m.row())
    }))
}

/// Run the collector until `stop` is set; then commit and return the totals. Never fails
/// for a broker that is down: it keeps trying (each failure counted, the first one logged).
pub fn run(
    opts: &CollectOptions,
    stop: &AtomicBool,
    stats: &CollectStats,
) -> Result<(), FleetError> {
    let tag = format!("collect-{}-{}", crate::schema::now_us(), std::process::id());
    let mut store = StoreWriter::new(&opts.out, &tag)?;
    let mut mqtt = MqttOptions::new(opts.client_id.clone(), opts.host.clone(), opts.port);
    mqtt.set_keep_alive(Duration::from_secs(5));
    mqtt.set_clean_session(false);
    mqtt.set_manual_acks(true);
    let (client, mut connection) = Client::new(mqtt, 1024);
    let (tx, rx) = crossbeam_channel::bounded::<Publish>(4096);
    let addr = format!("{}:{}", opts.host, opts.port);
    std::thread::scope(|scope| {
        let sub = client.clone();
        let conn = scope.spawn(move || {
            let mut down = false;
            loop {
                match connection.recv() {
                    Ok(Ok(Event::Incoming(Packet::ConnAck(_)))) => {
                        stats.connects.fetch_add(1, Ordering::SeqCst);
                        down = false;
                        tracing::info!(broker = %addr, "collector connected");
                        for leaf in ["period", "cut"] {
                            let topic = format!("{}/+/{leaf}", opts.prefix);
                            let _ = sub.try_subscribe(topic, QoS::AtLeastOnce);
                        }
                    }
                    Ok(Ok(Event::Incoming(Packet::Publish(p)))) => {
                        if tx.send(p).is_err() {
                            break;
                        }
                    }
                    Ok(Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect))) => break,
                    Ok(Ok(_)) => {}
                    Ok(Err(e)) => {
                        stats.conn_errors.fetch_add(1, Ordering::SeqCst);
                        if !down {
                            eprintln!(
                                "acc collect: broker {addr}: {e}; retrying every {} ms",
                                RECONNECT_DELAY.as_millis()
                            );
                            down = true;
                        }
                        if stop.load(Ordering::SeqCst) {
                            break;
                        }
                        let clock = SystemClock::new();
                        clock.sleep_until(RECONNECT_DELAY);
                    }
                    Err(_) => break,
                }
            }
        });
        let result = consume(opts, stop, stats, &client, &rx, &mut store);
        let _ = client.try_disconnect();
        drop(client);
        drop(rx);
        let _ = conn.join();
        result
    })
}

fn consume(
    opts: &CollectOptions,
    stop: &AtomicBool,
    stats: &CollectStats,
    client: &Client,
    rx: &crossbeam_channel::Receiver<Publish>,
    store: &mut StoreWriter,
) -> Result<(), FleetError> {
    let mut unacked: Vec<Publish> = Vec::new();
    let mut seen_cuts: HashSet<(String, i64, i64)> = HashSet::new();
    let clock = SystemClock::new();
    let mut last_commit = clock.now();
    // Publish times of the periods not yet committed (the lag histogram's input).
    let mut sent: Vec<i64> = Vec::new();
    let commit = |store: &mut StoreWriter,
                  unacked: &mut Vec<Publish>,
                  sent: &mut Vec<i64>|
     -> Result<(), FleetError> {
        let before = store.committed();
        store.commit()?;
        let now = crate::schema::now_us();
        let mut lag = stats
            .lag
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        for s in sent.drain(..) {
            lag.add_us(now - s);
        }
        drop(lag);
        let after = store.committed();
        stats.committed.fetch_add(
            (after.periods + after.cuts) - (before.periods + before.cuts),
            Ordering::SeqCst,
        );
        for p in unacked.drain(..) {
            let _ = client.try_ack(&p);
        }
        Ok(())
    };
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(p) => match parse(&opts.prefix, &p.topic, &p.payload) {
                Ok(Some(Parsed::Period(m, row, sent_us))) => {
                    store.push_period(&m, row)?;
                    if sent_us > 0 {
                        sent.push(sent_us);
                    }
                    stats.periods.fetch_add(1, Ordering::Relaxed);
                    if p.qos != QoS::AtMostOnce {
                        unacked.push(p);
                    }
                }
                Ok(Some(Parsed::Cut(m, row))) => {
                    let key = (
                        m.clone(),
                        row.run_start_us,
                        crate::schema::secs_to_us(row.t_start_s),
                    );
                    if seen_cuts.insert(key) {
                        store.push_cut(&m, row)?;
                        stats.cuts.fetch_add(1, Ordering::Relaxed);
                    } else {
                        stats.duplicates.fetch_add(1, Ordering::Relaxed);
                    }
                    if p.qos != QoS::AtMostOnce {
                        unacked.push(p);
                    }
                }
                Ok(None) => {}
                Err(e) => {
                    if stats.rejected.fetch_add(1, Ordering::Relaxed) < 10 {
                        eprintln!("acc collect: rejected: {e}");
                    }
                    if p.qos != QoS::AtMostOnce {
                        unacked.push(p);
                    }
                }
            },
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
        }
        if unacked.len() >= opts.max_unacked || clock.now() - last_commit >= opts.commit_every {
            commit(store, &mut unacked, &mut sent)?;
            last_commit = clock.now();
        }
        if stop.load(Ordering::SeqCst) && rx.is_empty() {
            break;
        }
    }
    commit(store, &mut unacked, &mut sent)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_quantiles_count_whole_milliseconds() {
        let mut h = LagHistogram::default();
        assert_eq!(h.quantile_ms(0.5), None);
        for ms in 1..=100 {
            h.add_us(ms * 1000 + 999);
        }
        h.add_us(-5_000);
        assert_eq!(h.len(), 101);
        assert_eq!(h.quantile_ms(0.5), Some(50), "rank 51 of 0, 1, …, 100");
        assert_eq!(h.quantile_ms(0.99), Some(99));
        assert_eq!(h.max_ms(), 100);
        h.add_us(3_600_000_000);
        assert_eq!(
            h.max_ms(),
            3_600_000,
            "beyond the last bucket: the max is kept"
        );
        assert_eq!(h.quantile_ms(1.0), Some(LagHistogram::MAX_MS));
    }

    #[test]
    fn messages_parse_by_topic_and_bad_ones_name_the_topic() {
        let body = br#"{"run_start_us":5,"period":3,"t_s":0.3,"flags":"late","acc_state":"active",
            "tool":12,"program":null,"block":7,"spindle_rpm":3000.0,"feed_mm_min":400.0,
            "spindle_power_w":900.0,"force_n":800.0,"force_valid":true,"force_ref_n":800.0,
            "kc_hat":2.5,"override_cmd_pct":110,"override_applied_pct":110,
            "override_operator_pct":100,"feed_hold":false,"alarm_bits":16,"alarms":[]}"#;
        match parse("fleet", "fleet/m1/period", body) {
            Ok(Some(Parsed::Period(m, r, sent_us))) => {
                assert_eq!((m.as_str(), sent_us), ("m1", 0), "no sent_us: not timed");
                assert_eq!(
                    (r.period, r.tool, r.program, r.alarms),
                    (3, Some(12), None, 16)
                );
                assert_eq!(r.ts_us(), 300_005);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(parse("fleet", "other/m1/period", body), Ok(None)));
        assert!(matches!(
            parse("fleet", "fleet/m1/status", b"online"),
            Ok(None)
        ));
        let e = parse("fleet", "fleet/m1/cut", b"{}").expect_err("bad cut");
        assert!(
            e.contains("fleet/m1/cut") && e.contains("not a cut message"),
            "{e}"
        );
        let e = parse("fleet", "fleet/.x/cut", b"{}").expect_err("bad id");
        assert!(e.contains("machine id"), "{e}");
    }

    #[test]
    fn the_publishers_messages_give_the_rows_of_the_direct_writer() {
        use acc_runtime::cuts::CutRecord;
        use acc_telemetry::mqtt::{CutJson, PeriodJson};
        let r = acc_runtime::RunRecord {
            period: 41,
            t_s: 4.1,
            flags: "late".into(),
            tool: Some(12),
            block: Some(30),
            spindle_rpm: Some(3000.0),
            programmed_feed_mm_min: Some(400.0),
            feed_mm_min: Some(440.0),
            power_w: Some(950.0),
            force_n: Some(805.5),
            force_valid: true,
            force_ref_n: Some(800.0),
            kc_hat: Some(1.83),
            override_cmd_pct: Some(110),
            override_applied_pct: Some(110),
            override_operator_pct: Some(100),
            state: "active".into(),
            alarms: 1 << 4,
            ..acc_runtime::RunRecord::default()
        };
        let json = PeriodJson {
            run_start_us: 7_000_000,
            ..PeriodJson::of(&r)
        };
        let body = serde_json::to_vec(&json).expect("json");
        match parse("p", "p/m/period", &body) {
            Ok(Some(Parsed::Period(_, row, _))) => assert_eq!(row, PeriodRow::of(&r, 7_000_000)),
            other => panic!("{other:?}"),
        }
        let c = CutRecord {
            tool: 12,
            program: 0,
            block_first: 20,
            block_last: 40,
            t_start_s: 1.5,
            t_end_s: 3.0,
            x_start_mm: 0.0,
            x_end_mm: 10.0,
            time_in_cut_s: 1.5,
            force_mean_n: 790.0,
            force_max_n: 900.0,
            force_rms_error_n: 12.0,
            force_ref_n: 800.0,
            hist_bin_pct: 10,
            override_hist: vec![0; 16],
            alarm_bits: 1 | 1 << 4,
            watch_alarms: vec!["wear_warn".into()],
            feed_hold_periods: 0,
            time_saved_s: 0.2,
        };
        let json = CutJson {
            run_start_us: 7_000_000,
            ..CutJson::of(&c)
        };
        let body = serde_json::to_vec(&json).expect("json");
        match parse("p", "p/m/cut", &body) {
            Ok(Some(Parsed::Cut(_, row))) => assert_eq!(row, CutRow::of(&c, 7_000_000)),
            other => panic!("{other:?}"),
        }
    }
}
