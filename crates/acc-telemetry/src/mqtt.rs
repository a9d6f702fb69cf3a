//! MQTT publisher (rumqttc): the data items of every period as one JSON message on
//! `<prefix>/period`, the per-cut records on `<prefix>/cut` (always QoS 1), and `online` / `offline`
//! (retained; `offline` is also the broker-sent last will) on `<prefix>/status`.
//!
//! Threads: the publisher reads a [`Subscriber`] of the runtime's tap and hands each message
//! to rumqttc's bounded request queue with `try_publish` (a full queue — broker down, slow
//! network — drops a period and counts it, [`MqttStats::dropped`]; a cut waits in a
//! [`CutOutbox`] instead); the connection thread drives
//! rumqttc's event loop and, when the broker is gone, retries every
//! [`RECONNECT_DELAY`] until it is back (then `online` is published again).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use acc_runtime::tap::Subscriber;
use acc_runtime::RunRecord;
use crossbeam_channel::RecvTimeoutError;
use rumqttc::{Client, Event, LastWill, MqttOptions, Packet, QoS};
use serde::Serialize;

use crate::items::{available, execution, levels, Level, CONDITIONS};
use crate::mqtt_outbox::CutOutbox;

/// Pause between two connection attempts while the broker is down.
pub const RECONNECT_DELAY: Duration = Duration::from_millis(500);

/// Messages rumqttc queues before `try_publish` drops.
pub const REQUEST_QUEUE: usize = 256;

/// Where and how to publish (`--mqtt URL`, `[telemetry.mqtt]`): the run config's
/// validated settings.
pub use acc_runtime::config::MqttSettings as MqttConfig;

fn qos(c: &MqttConfig) -> QoS {
    if c.qos >= 1 {
        QoS::AtLeastOnce
    } else {
        QoS::AtMostOnce
    }
}

/// Now, µs since the Unix epoch.
fn now_us() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(i64::MAX))
}

/// One alarm in a period message.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct AlarmJson {
    /// Condition name (`overload_cond`, …).
    pub name: &'static str,
    /// `WARNING` or `FAULT`.
    pub level: &'static str,
    /// Native code (`OVERLOAD`, …).
    pub code: &'static str,
}

/// The JSON of `<prefix>/period`: the same items as the SHDR adapter, with units in the
/// names; `null` when unknown.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PeriodJson {
    /// Wall-clock start of the run, µs since the Unix epoch (the publisher's start; 0 when
    /// not set). With `t_s` it dates the period (`acc collect`).
    pub run_start_us: i64,
    /// Wall-clock time the publisher handed the message on, µs since the Unix epoch (0 when
    /// not set): `acc collect` measures the lag from here to the Parquet commit.
    pub sent_us: i64,
    /// Period index.
    pub period: u64,
    /// Machine time of the period, s since the run began.
    pub t_s: f64,
    /// `AVAILABLE` / `UNAVAILABLE` (the board link).
    pub availability: &'static str,
    /// MTConnect execution: `ACTIVE`, `FEED_HOLD`, `READY`.
    pub execution: &'static str,
    /// ACC policy state (`active`, `idle`, latched reason).
    pub acc_state: String,
    /// The run log's `flags` (`;`-separated: `skipped`, `late`, `link:…`, …).
    pub flags: String,
    /// Override in force on the PMC, %.
    pub override_applied_pct: Option<u16>,
    /// Override ACC commanded, %.
    pub override_cmd_pct: Option<u16>,
    /// Operator's knob, %.
    pub override_operator_pct: Option<u16>,
    /// Programmed feed of the active block, mm/min.
    pub programmed_feed_mm_min: Option<f64>,
    /// Actual path feed, mm/min.
    pub feed_mm_min: Option<f64>,
    /// Spindle speed, rpm.
    pub spindle_rpm: Option<f64>,
    /// Spindle power (spindle load), W.
    pub spindle_power_w: Option<f64>,
    /// Estimated cutting force, N.
    pub force_n: Option<f64>,
    /// The fault policy used the force sample as valid.
    pub force_valid: bool,
    /// Force reference Fr, N.
    pub force_ref_n: Option<f64>,
    /// Estimated process gain Kc_hat, N/(mm/min).
    pub kc_hat: Option<f64>,
    /// Tool number.
    pub tool: Option<u16>,
    /// Program number.
    pub program: Option<u16>,
    /// Block number.
    pub block: Option<u16>,
    /// Feed hold requested by ACC.
    pub feed_hold: bool,
    /// Alarm bit code (as the run log).
    pub alarm_bits: u8,
    /// Alarms in force.
    pub alarms: Vec<AlarmJson>,
}

impl PeriodJson {
    /// The message of record `r`.
    pub fn of(r: &RunRecord) -> Self {
        let alarms = levels(r)
            .into_iter()
            .zip(CONDITIONS)
            .filter(|(l, _)| *l != Level::Normal)
            .map(|(l, (name, _, _, code, _))| AlarmJson {
                name,
                level: l.name(),
                code,
            })
            .collect();
        let fin = |v: Option<f64>| v.filter(|x| x.is_finite());
        Self {
            run_start_us: 0,
            sent_us: 0,
            period: r.period,
            t_s: r.t_s,
            availability: if available(r) {
                "AVAILABLE"
            } else {
                "UNAVAILABLE"
            },
            execution: execution(r),
            acc_state: r.state.clone(),
            flags: r.flags.clone(),
            override_applied_pct: r.override_applied_pct,
            override_cmd_pct: r.override_cmd_pct,
            override_operator_pct: r.override_operator_pct,
            programmed_feed_mm_min: fin(r.programmed_feed_mm_min),
            feed_mm_min: fin(r.feed_mm_min),
            spindle_rpm: fin(r.spindle_rpm),
            spindle_power_w: fin(r.power_w),
            force_n: fin(r.force_n),
            force_valid: r.force_valid,
            force_ref_n: fin(r.force_ref_n),
            kc_hat: fin(r.kc_hat),
            tool: r.tool,
            program: r.program,
            block: r.block,
            feed_hold: r.feed_hold,
            alarm_bits: r.alarms,
            alarms,
        }
    }
}

/// A per-cut record as published on `<prefix>/cut`: the publisher's thread computes them
/// from the records it receives ([`CutJson::of`]); [`MqttPublisher::publish_cut`] publishes
/// one from elsewhere.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct CutJson {
    /// Wall-clock start of the run, µs since the Unix epoch (as in the period messages).
    pub run_start_us: i64,
    /// Tool number.
    pub tool: Option<u16>,
    /// Program number.
    pub program: Option<u16>,
    /// First block of the cut.
    pub block_first: Option<u16>,
    /// Last block of the cut.
    pub block_last: Option<u16>,
    /// Start, s of machine time.
    pub t_start_s: f64,
    /// Time in cut, s.
    pub time_in_cut_s: f64,
    /// Mean force, N.
    pub force_mean_n: f64,
    /// Peak force, N.
    pub force_max_n: f64,
    /// Time saved against the programmed feed, s.
    pub time_saved_s: f64,
    /// Alarms raised in the cut (names).
    pub alarms: Vec<String>,
}

impl CutJson {
    /// The published form of a per-cut record (0 = unknown becomes `null`; alarm names from
    /// the run log's alarm bits, then the watch's).
    pub fn of(c: &acc_runtime::cuts::CutRecord) -> Self {
        let known = |v: u16| (v != 0).then_some(v);
        let names = [
            "link",
            "power",
            "watchdog",
            "board_reset",
            "overload",
            "breakage",
        ];
        let mut alarms: Vec<String> = names
            .iter()
            .enumerate()
            .filter(|(i, _)| c.alarm_bits & (1 << i) != 0)
            .map(|(_, n)| (*n).to_string())
            .collect();
        alarms.extend(c.watch_alarms.iter().cloned());
        CutJson {
            run_start_us: 0,
            tool: known(c.tool),
            program: known(c.program),
            block_first: known(c.block_first),
            block_last: known(c.block_last),
            t_start_s: c.t_start_s,
            time_in_cut_s: c.time_in_cut_s,
            force_mean_n: c.force_mean_n,
            force_max_n: c.force_max_n,
            time_saved_s: c.time_saved_s,
            alarms,
        }
    }
}

/// Counters of a running publisher.
#[derive(Debug, Default)]
pub struct MqttStats {
    /// Messages handed to rumqttc.
    pub queued: AtomicU64,
    /// Messages dropped (rumqttc's queue full: broker down or slow).
    pub dropped: AtomicU64,
    /// Connections acknowledged by the broker (1 + reconnects).
    pub connects: AtomicU64,
    /// Connection errors seen (each followed by a retry).
    pub conn_errors: AtomicU64,
    /// Connected now.
    pub connected: AtomicBool,
    /// `online` still to be published after a (re)connection.
    pub online_pending: AtomicBool,
}

/// A running MQTT publisher; [`MqttPublisher::stop`] publishes `offline` and disconnects.
pub struct MqttPublisher {
    cfg: MqttConfig,
    run_start_us: i64,
    client: Option<Client>,
    stats: Arc<MqttStats>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl std::fmt::Debug for MqttPublisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MqttPublisher")
            .field("cfg", &self.cfg)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl MqttPublisher {
    /// Start publishing the records of `sub` to the broker of `cfg`; `period_s` is the
    /// loop's period T (s), which the per-cut records count time in cut with. Never fails for
    /// a broker that is down: the connection thread keeps trying.
    pub fn start(cfg: MqttConfig, sub: Subscriber, period_s: f64) -> std::io::Result<Self> {
        let mut opts = MqttOptions::new(cfg.client_id.clone(), cfg.host.clone(), cfg.port);
        opts.set_keep_alive(Duration::from_secs(5));
        opts.set_last_will(LastWill::new(
            cfg.topic("status"),
            "offline",
            QoS::AtLeastOnce,
            true,
        ));
        let (client, mut connection) = Client::new(opts, REQUEST_QUEUE);
        let stats = Arc::new(MqttStats::default());
        let stop = Arc::new(AtomicBool::new(false));
        let run_start_us = now_us();
        let mut threads = Vec::new();
        {
            let (stats, stop) = (stats.clone(), stop.clone());
            threads.push(std::thread::Builder::new().name("mqtt-conn".into()).spawn(
                move || {
                    // Blocking `recv`: a timeout would cancel a connection attempt half-way
                    // (the broker then publishes the will, `offline`, for it).
                    loop {
                        match connection.recv() {
                            Ok(Ok(Event::Incoming(Packet::ConnAck(_)))) => {
                                stats.connects.fetch_add(1, Ordering::SeqCst);
                                stats.connected.store(true, Ordering::SeqCst);
                                tracing::info!("MQTT broker connected");
                                // The publisher thread sends `online` first thing (the
                                // request queue may still be full of what piled up while
                                // the broker was down).
                                stats.online_pending.store(true, Ordering::SeqCst);
                            }
                            Ok(Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect))) => break,
                            Ok(Ok(_)) => {}
                            Ok(Err(e)) => {
                                if stats.connected.swap(false, Ordering::SeqCst) {
                                    tracing::warn!(error = %e, "MQTT broker lost: retrying");
                                }
                                stats.conn_errors.fetch_add(1, Ordering::SeqCst);
                                if stop.load(Ordering::SeqCst) {
                                    break;
                                }
                                std::thread::sleep(RECONNECT_DELAY);
                            }
                            // Every client handle is gone.
                            Err(_) => break,
                        }
                    }
                },
            )?);
        }
        {
            let (client, stats, stop, cfg) =
                (client.clone(), stats.clone(), stop.clone(), cfg.clone());
            threads.push(
                std::thread::Builder::new()
                    .name("mqtt-pub".into())
                    .spawn(move || {
                        let topic = cfg.topic("period");
                        let cut_topic = cfg.topic("cut");
                        let status = cfg.topic("status");
                        // The per-cut records, from the records this thread receives (the
                        // same `CutRecorder` as `acc report` and the tool history).
                        let mut cuts = acc_runtime::cuts::CutRecorder::new(period_s);
                        // Cuts wait here while the request queue is full (crate::mqtt_outbox).
                        let mut outbox = CutOutbox::default();
                        let flush = |outbox: &mut CutOutbox| {
                            let sent = outbox.flush(|body| {
                                client
                                    .try_publish(
                                        cut_topic.clone(),
                                        QoS::AtLeastOnce,
                                        false,
                                        body.clone(),
                                    )
                                    .map_err(|_| body)
                            });
                            stats.queued.fetch_add(sent as u64, Ordering::Relaxed);
                        };
                        let cut_body = |c: &acc_runtime::cuts::CutRecord| {
                            let json = CutJson {
                                run_start_us,
                                ..CutJson::of(c)
                            };
                            serde_json::to_vec(&json).ok()
                        };
                        loop {
                            if stats.online_pending.load(Ordering::SeqCst)
                                && client
                                    .try_publish(status.clone(), QoS::AtLeastOnce, true, "online")
                                    .is_ok()
                            {
                                stats.online_pending.store(false, Ordering::SeqCst);
                            }
                            match sub.recv_timeout(Duration::from_millis(50)) {
                                Ok(r) => {
                                    if let Some(body) = cuts.push(&r).as_ref().and_then(cut_body) {
                                        outbox.push(body);
                                    }
                                    flush(&mut outbox);
                                    let json = PeriodJson {
                                        run_start_us,
                                        sent_us: now_us(),
                                        ..PeriodJson::of(&r)
                                    };
                                    let Ok(body) = serde_json::to_vec(&json) else {
                                        continue;
                                    };
                                    match client.try_publish(topic.clone(), qos(&cfg), false, body)
                                    {
                                        Ok(()) => stats.queued.fetch_add(1, Ordering::Relaxed),
                                        Err(_) => stats.dropped.fetch_add(1, Ordering::Relaxed),
                                    };
                                }
                                Err(e) => {
                                    flush(&mut outbox);
                                    if stop.load(Ordering::SeqCst) {
                                        if let Some(body) =
                                            cuts.finish().as_ref().and_then(cut_body)
                                        {
                                            outbox.push(body);
                                        }
                                        flush(&mut outbox);
                                        let lost = outbox.len() as u64 + outbox.overflowed;
                                        stats.dropped.fetch_add(lost, Ordering::Relaxed);
                                        break;
                                    }
                                    if e == RecvTimeoutError::Disconnected {
                                        std::thread::sleep(Duration::from_millis(50));
                                    }
                                }
                            }
                        }
                    })?,
            );
        }
        tracing::info!(host = %cfg.host, port = cfg.port, prefix = %cfg.prefix, "MQTT publisher started");
        Ok(Self {
            cfg,
            run_start_us,
            client: Some(client),
            stats,
            stop,
            threads,
        })
    }

    /// Publish one per-cut record on `<prefix>/cut` (never waits: a full queue drops).
    pub fn publish_cut(&self, cut: &CutJson) -> bool {
        let json = CutJson {
            run_start_us: self.run_start_us,
            ..cut.clone()
        };
        let Ok(body) = serde_json::to_vec(&json) else {
            return false;
        };
        let ok = self.client.as_ref().is_some_and(|c| {
            c.try_publish(self.cfg.topic("cut"), QoS::AtLeastOnce, false, body)
                .is_ok()
        });
        let c = if ok {
            &self.stats.queued
        } else {
            &self.stats.dropped
        };
        c.fetch_add(1, Ordering::Relaxed);
        ok
    }

    /// Counters.
    pub fn stats(&self) -> &MqttStats {
        &self.stats
    }

    /// Stop: the queued records are handed on, `offline` is published (retained) and the
    /// client disconnects.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if self.stop.swap(true, Ordering::SeqCst) {
            return;
        }
        // The publisher first (it drains its queue), then `offline` and DISCONNECT.
        if let Some(p) = self.threads.pop() {
            let _ = p.join();
        }
        if let Some(c) = self.client.take() {
            let _ = c.try_publish(self.cfg.topic("status"), QoS::AtLeastOnce, true, "offline");
            let _ = c.try_disconnect();
            // Dropping the last handle ends the event loop once it has sent what is queued.
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for MqttPublisher {
    fn drop(&mut self) {
        self.shutdown();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_json_carries_values_and_alarms() {
        let r = RunRecord {
            period: 3,
            force_n: Some(f64::NAN),
            kc_hat: Some(6.5),
            alarms: 1 << 4,
            ..RunRecord::default()
        };
        let v = serde_json::to_value(PeriodJson::of(&r)).expect("json");
        assert_eq!(v["period"], 3);
        assert!(v["force_n"].is_null());
        assert_eq!(v["kc_hat"], 6.5);
        assert_eq!(v["alarms"][0]["code"], "OVERLOAD");
    }
}
