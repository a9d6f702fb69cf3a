//! `--shdr ADDR`, `--mqtt URL` and `--live ADDR` of `acc run`, `acc sim` and `acc board-sim`: the runtime's
//! [`Tap`] with the MTConnect SHDR adapter, the MQTT publisher and the live view subscribed to it
//! (docs/telemetry.md). The loop only ever calls [`Tap::publish`], which never waits.

use std::io::Write as _;
use std::net::SocketAddr;

use acc_runtime::config::{parse_shdr_addr, MqttSettings, TelemetryConfig};
use acc_runtime::tap::Tap;
use acc_telemetry::{LiveInfo, LiveServer, MqttPublisher, ShdrServer};
use anyhow::Context as _;

/// Queue of the SHDR and MQTT subscribers, records (25 s at T = 0.1 s).
pub const SUBSCRIBER_QUEUE: usize = 256;

/// The telemetry options shared by `acc run`, `acc sim` and `acc board-sim`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct TelemetryArgs {
    /// MTConnect SHDR adapter on this address, e.g. `0.0.0.0:7878` (replaces
    /// `[telemetry] shdr`).
    #[arg(long, value_name = "IP:PORT", value_parser = parse_shdr_addr)]
    pub shdr: Option<SocketAddr>,
    /// Publish to this MQTT broker, `mqtt://host[:port][/prefix]` (replaces
    /// `[telemetry.mqtt] url`).
    #[arg(long, value_name = "URL", value_parser = MqttSettings::from_url)]
    pub mqtt: Option<MqttSettings>,
    /// Live view in the browser on this address, e.g. `127.0.0.1:8080` (replaces
    /// `[telemetry] live`; docs/telemetry.md "Live view").
    #[arg(long, value_name = "IP:PORT", value_parser = parse_shdr_addr)]
    pub live: Option<SocketAddr>,
}

impl TelemetryArgs {
    /// The command line over a config's `[telemetry]` (a `--mqtt` URL keeps the config's
    /// QoS and client id).
    pub fn over(&self, cfg: &TelemetryConfig) -> TelemetryConfig {
        TelemetryConfig {
            shdr: self.shdr.or(cfg.shdr),
            live: self.live.or(cfg.live),
            mqtt: match (&self.mqtt, &cfg.mqtt) {
                (Some(a), Some(c)) => Some(MqttSettings {
                    qos: c.qos,
                    client_id: c.client_id.clone(),
                    ..a.clone()
                }),
                (a, c) => a.clone().or_else(|| c.clone()),
            },
        }
    }
}

/// The running telemetry of one command.
pub struct Telemetry {
    /// Where the loop publishes every period's record.
    pub tap: Tap,
    shdr: Option<(ShdrServer, acc_runtime::tap::Subscriber)>,
    mqtt: Option<(MqttPublisher, acc_runtime::tap::Subscriber)>,
    stderr: bool,
    live: Option<LiveServer>,
}

/// A status line on stdout, or on stderr (`acc board-sim`: its stdout carries the pty path
/// only). Never panics: a reader that took what it needed and closed the pipe must not stop
/// the machine.
fn say(stderr: bool, line: &str) {
    if stderr {
        let _ = writeln!(std::io::stderr(), "{line}");
    } else {
        let _ = writeln!(std::io::stdout(), "{line}");
    }
}

impl Telemetry {
    /// Start what `cfg` asks for (nothing: a tap without subscribers); status lines on
    /// stderr if `stderr`.
    pub fn start(cfg: &TelemetryConfig, stderr: bool) -> anyhow::Result<Self> {
        let tap = Tap::new();
        let shdr = match cfg.shdr {
            Some(a) => {
                let sub = tap.subscribe(SUBSCRIBER_QUEUE);
                let srv = ShdrServer::start(&a.to_string(), sub.clone())
                    .with_context(|| format!("--shdr {a}: cannot listen"))?;
                say(
                    stderr,
                    &format!("telemetry: MTConnect SHDR adapter on {}", srv.local_addr()),
                );
                Some((srv, sub))
            }
            None => None,
        };
        let mqtt = match &cfg.mqtt {
            Some(m) => {
                let sub = tap.subscribe(SUBSCRIBER_QUEUE);
                let p = MqttPublisher::start(m.clone(), sub.clone())
                    .context("starting the MQTT publisher")?;
                say(
                    stderr,
                    &format!(
                        "telemetry: MQTT to {}:{} under `{}/` (period, cut, status)",
                        m.host, m.port, m.prefix
                    ),
                );
                Some((p, sub))
            }
            None => None,
        };
        let live = match cfg.live {
            Some(a) => {
                let srv = LiveServer::start(
                    &a.to_string(),
                    tap.subscribe(SUBSCRIBER_QUEUE),
                    LiveInfo::default(),
                )
                .with_context(|| format!("--live {a}: cannot listen"))?;
                say(
                    stderr,
                    &format!("telemetry: live view on http://{}/", srv.local_addr()),
                );
                Some(srv)
            }
            None => None,
        };
        Ok(Self {
            tap,
            shdr,
            mqtt,
            stderr,
            live,
        })
    }

    /// Whether the live view runs (`acc sim` then paces to real time by default).
    pub fn has_live(&self) -> bool {
        self.live.is_some()
    }

    /// What the live view shows beside the records (title, overload line).
    pub fn set_live_info(&self, info: LiveInfo) {
        if let Some(l) = &self.live {
            l.set_info(info);
        }
    }

    /// Stop the adapters (queued records go out first) and print their counters.
    pub fn finish(self) {
        self.finish_lingering(0.0);
    }

    /// [`Telemetry::finish`], but a live view keeps serving `secs` after the run (its pages
    /// keep their plots and say the run ended) before it stops.
    pub fn finish_lingering(self, secs: f64) {
        let Telemetry {
            tap,
            shdr,
            mqtt,
            stderr,
            live,
        } = self;
        drop(tap);

        if let Some((srv, sub)) = shdr {
            let st = srv.stats();
            say(stderr, &format!(
                "telemetry: SHDR {} records, {} clients served, {} lines dropped (slow client), {} records dropped (queue full)",
                st.records.load(std::sync::atomic::Ordering::Relaxed),
                st.accepted.load(std::sync::atomic::Ordering::Relaxed),
                st.lines_dropped.load(std::sync::atomic::Ordering::Relaxed),
                sub.dropped()
            ));
            drop(sub);
            srv.stop();
        }
        if let Some((p, sub)) = mqtt {
            drop(sub);
            let st = p.stats();
            let (q, d, c) = (
                st.queued.load(std::sync::atomic::Ordering::Relaxed),
                st.dropped.load(std::sync::atomic::Ordering::Relaxed),
                st.connects.load(std::sync::atomic::Ordering::Relaxed),
            );
            p.stop();
            say(
                stderr,
                &format!("telemetry: MQTT {q} messages queued, {d} dropped, {c} connections"),
            );
        }
        if let Some(l) = live {
            if secs > 0.0 {
                say(stderr, &format!("telemetry: live view stays up {secs} s"));
                std::thread::sleep(std::time::Duration::from_secs_f64(secs));
            }
            let st = l.stop();
            say(stderr, &format!(
                "telemetry: live view {} records, {} clients served, {} records dropped (slow clients), {} acknowledges (view only)",
                st.records.load(std::sync::atomic::Ordering::Relaxed),
                st.accepted.load(std::sync::atomic::Ordering::Relaxed),
                st.dropped.load(std::sync::atomic::Ordering::Relaxed),
                st.acks.load(std::sync::atomic::Ordering::Relaxed),
            ));
        }
    }
}
