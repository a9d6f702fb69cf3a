//! `--shdr ADDR` and `--mqtt URL` of `acc run`, `acc sim` and `acc board-sim`: the runtime's
//! [`Tap`] with the MTConnect SHDR adapter and the MQTT publisher subscribed to it
//! (docs/telemetry.md). The loop only ever calls [`Tap::publish`], which never waits.

use std::net::SocketAddr;

use acc_runtime::config::{parse_shdr_addr, MqttSettings, TelemetryConfig};
use acc_runtime::tap::Tap;
use acc_telemetry::{MqttPublisher, ShdrServer};
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
}

impl TelemetryArgs {
    /// The command line over a config's `[telemetry]` (a `--mqtt` URL keeps the config's
    /// QoS and client id).
    pub fn over(&self, cfg: &TelemetryConfig) -> TelemetryConfig {
        TelemetryConfig {
            shdr: self.shdr.or(cfg.shdr),
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
}

/// A status line on stdout, or on stderr (`acc board-sim`: its stdout carries the pty path
/// only).
fn say(stderr: bool, line: &str) {
    if stderr {
        eprintln!("{line}");
    } else {
        println!("{line}");
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
        Ok(Self {
            tap,
            shdr,
            mqtt,
            stderr,
        })
    }

    /// Stop the adapters (queued records go out first) and print their counters.
    pub fn finish(self) {
        let Telemetry {
            tap,
            shdr,
            mqtt,
            stderr,
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
    }
}
