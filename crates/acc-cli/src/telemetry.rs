//! `--shdr ADDR`, `--mqtt URL`, `--live ADDR` and `--opcua URL` of `acc run`, `acc sim` and
//! `acc board-sim`: the runtime's [`Tap`] with the MTConnect SHDR adapter, the MQTT publisher,
//! the live view and the OPC UA server subscribed to it (docs/telemetry.md, docs/opcua.md).
//! The loop only ever calls [`Tap::publish`], which never waits.

use std::io::Write as _;
use std::net::SocketAddr;

use std::path::{Path, PathBuf};

use acc_runtime::config::{parse_shdr_addr, MqttSettings, TelemetryConfig};
use acc_runtime::opcua_config::{OpcUaSettings, OpcUaUser};
use acc_runtime::tap::Tap;
use acc_telemetry::{LiveInfo, LiveServer, MqttPublisher, OpcUaServer, ShdrServer};
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
    /// OPC UA server on this URL, `opc.tcp://IP:PORT` (replaces `[telemetry] opcua`'s URL;
    /// docs/opcua.md). Anonymous with SecurityPolicy None unless a user is given.
    #[arg(long, value_name = "URL", value_parser = OpcUaSettings::from_url)]
    pub opcua: Option<OpcUaSettings>,
    /// OPC UA user: the only endpoint is then Basic256Sha256 SignAndEncrypt with this user
    /// (needs `--opcua-password-file`).
    #[arg(long, value_name = "NAME", requires = "opcua_password_file")]
    pub opcua_user: Option<String>,
    /// File whose first line is the OPC UA user's password (never the password in argv).
    #[arg(long, value_name = "FILE", requires = "opcua_user")]
    pub opcua_password_file: Option<PathBuf>,
    /// Folder of the OPC UA certificates (created on first start; default: the command's
    /// output folder + `/pki`, docs/opcua.md "Folders").
    #[arg(long, value_name = "DIR")]
    pub opcua_pki: Option<PathBuf>,
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
            opcua: self.opcua_over(cfg.opcua.as_ref()),
        }
    }

    /// `--opcua` and its `--opcua-*` options over `[telemetry.opcua]`: the command line's URL
    /// keeps the config's security keys unless the command line gives its own.
    fn opcua_over(&self, cfg: Option<&OpcUaSettings>) -> Option<OpcUaSettings> {
        let mut s = match (&self.opcua, cfg) {
            (Some(a), Some(c)) => OpcUaSettings {
                addr: a.addr,
                ..c.clone()
            },
            (a, c) => a.clone().or_else(|| c.cloned())?,
        };
        if let (Some(name), Some(pw)) = (&self.opcua_user, &self.opcua_password_file) {
            s.user = Some(OpcUaUser {
                name: name.clone(),
                password_file: pw.clone(),
            });
        }
        if let Some(p) = &self.opcua_pki {
            s.pki_dir = Some(p.clone());
        }
        Some(s)
    }
}

/// `cfg` with `dir` as the OPC UA certificate folder unless one is configured.
pub fn with_default_pki(mut cfg: TelemetryConfig, dir: &Path) -> TelemetryConfig {
    if let Some(o) = cfg.opcua.as_mut() {
        if o.pki_dir.is_none() {
            o.pki_dir = Some(dir.to_path_buf());
        }
    }
    cfg
}

/// The running telemetry of one command.
pub struct Telemetry {
    /// Where the loop publishes every period's record.
    pub tap: Tap,
    shdr: Option<(ShdrServer, acc_runtime::tap::Subscriber)>,
    mqtt: Option<(MqttPublisher, acc_runtime::tap::Subscriber)>,
    stderr: bool,
    live: Option<LiveServer>,
    opcua: Option<OpcUaServer>,
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
    /// Start what `cfg` asks for (nothing: a tap without subscribers) for a loop of period
    /// `period_s` (s); status lines on stderr if `stderr`.
    pub fn start(cfg: &TelemetryConfig, stderr: bool, period_s: f64) -> anyhow::Result<Self> {
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
                let p = MqttPublisher::start(m.clone(), sub.clone(), period_s)
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
        let opcua = match &cfg.opcua {
            Some(o) => {
                let pki = o
                    .pki_dir
                    .clone()
                    .unwrap_or_else(|| std::env::temp_dir().join("acc-opcua-pki"));
                let srv = OpcUaServer::start(o, &pki, tap.subscribe(SUBSCRIBER_QUEUE))
                    .with_context(|| format!("--opcua {}", OpcUaSettings::url_for(o.addr)))?;
                say(
                    stderr,
                    &format!(
                        "telemetry: OPC UA server on {} ({}; certificates in {})",
                        srv.url(),
                        if srv.is_secure() {
                            "Basic256Sha256 SignAndEncrypt, user and password"
                        } else {
                            "SecurityPolicy None, anonymous"
                        },
                        srv.pki_dir().display()
                    ),
                );
                if !srv.is_secure() && !o.addr.ip().is_loopback() {
                    say(stderr, "telemetry: warning: OPC UA without security on a non-loopback address: set [telemetry.opcua] user and password_file");
                }
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
            opcua,
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
            opcua,
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
        if let Some(o) = opcua {
            let (records, events, dropped) = {
                let st = o.stats();
                (
                    st.records.load(std::sync::atomic::Ordering::Relaxed),
                    st.events.load(std::sync::atomic::Ordering::Relaxed),
                    st.records_dropped
                        .load(std::sync::atomic::Ordering::Relaxed),
                )
            };
            let c = o.stop();
            say(stderr, &format!(
                "telemetry: OPC UA {records} records, {events} events, {} sessions, {} timed out (dead clients), {} identities refused, {dropped} records dropped (queue full)",
                c.cumulated, c.timed_out, c.auth_refused
            ));
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
