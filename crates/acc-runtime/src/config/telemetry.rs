//! `[telemetry]` of a run config: the MTConnect SHDR adapter and the MQTT publisher, parsed
//! and validated into a [`TelemetryConfig`] (docs/telemetry.md).

use std::path::Path;

use acc_config::{check_range, ConfigError};
use serde::Deserialize;

/// `[telemetry]`: what the shop-floor network hears (docs/telemetry.md). Every key optional;
/// nothing is published without them (or `--shdr` / `--mqtt`).
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct TelemetrySection {
    /// MTConnect SHDR adapter address, `host:port` (e.g. `"0.0.0.0:7878"`).
    pub shdr: Option<String>,
    /// Live view in the browser, listen address `host:port` (e.g. `"0.0.0.0:8080"`).
    pub live: Option<String>,
    /// MQTT publisher.
    pub mqtt: Option<MqttSection>,
    /// OPC UA server: `opcua = "opc.tcp://IP:PORT"` or the table `[telemetry.opcua]`
    /// (docs/opcua.md).
    pub opcua: Option<crate::opcua_config::OpcUaEntry>,
}

/// `[telemetry.mqtt]`.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct MqttSection {
    /// Broker, `mqtt://host[:port][/prefix]` (port 1883 by default).
    pub url: String,
    /// Topic prefix (replaces the URL's path; default `acc`).
    pub topic_prefix: Option<String>,
    /// QoS of the period and cut messages, 0 or 1 (default 0).
    pub qos: Option<u8>,
    /// MQTT client id (default `acc-<pid>`).
    pub client_id: Option<String>,
}

/// A validated MQTT destination (`--mqtt URL` or `[telemetry.mqtt]`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MqttSettings {
    /// Broker host.
    pub host: String,
    /// Broker port.
    pub port: u16,
    /// Topic prefix, no trailing `/`.
    pub prefix: String,
    /// QoS 0 or 1.
    pub qos: u8,
    /// Client id.
    pub client_id: String,
}

impl MqttSettings {
    /// Parse `mqtt://host[:port][/prefix]` (`tcp://` too); the error says what is allowed.
    pub fn from_url(url: &str) -> Result<Self, String> {
        let rest = url
            .strip_prefix("mqtt://")
            .or_else(|| url.strip_prefix("tcp://"))
            .ok_or_else(|| {
                format!("\"{url}\" is not an MQTT URL: allowed mqtt://host[:port][/prefix]")
            })?;
        let (hostport, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        let (host, port) = match hostport.rsplit_once(':') {
            Some((h, p)) => (
                h,
                p.parse::<u16>()
                    .ok()
                    .filter(|p| *p > 0)
                    .ok_or_else(|| format!("\"{url}\": port `{p}`: allowed 1 ..= 65535"))?,
            ),
            None => (hostport, 1883),
        };
        if host.is_empty() {
            return Err(format!(
                "\"{url}\" has no host: allowed mqtt://host[:port][/prefix]"
            ));
        }
        let prefix = prefix.trim_matches('/');
        Ok(Self {
            host: host.to_string(),
            port,
            prefix: if prefix.is_empty() {
                "acc".into()
            } else {
                prefix.to_string()
            },
            qos: 0,
            client_id: format!("acc-{}", std::process::id()),
        })
    }

    /// `<prefix>/<leaf>`.
    pub fn topic(&self, leaf: &str) -> String {
        format!("{}/{leaf}", self.prefix)
    }
}

/// The validated `[telemetry]` of a run config.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TelemetryConfig {
    /// SHDR adapter address.
    pub shdr: Option<std::net::SocketAddr>,
    /// Live view address (docs/telemetry.md "Live view").
    pub live: Option<std::net::SocketAddr>,
    /// MQTT destination.
    pub mqtt: Option<MqttSettings>,
    /// OPC UA server (docs/opcua.md).
    pub opcua: Option<crate::opcua_config::OpcUaSettings>,
}

/// Parse an SHDR listen address (`--shdr`, `[telemetry] shdr`): `host:port` with an IP
/// host, e.g. `0.0.0.0:7878` or `127.0.0.1:0`.
pub fn parse_shdr_addr(s: &str) -> Result<std::net::SocketAddr, String> {
    s.parse().map_err(|_| {
        format!("\"{s}\" is not a listen address: allowed IP:PORT, e.g. \"0.0.0.0:7878\" (port 0 ..= 65535)")
    })
}

impl TelemetrySection {
    /// Validate; an error names `file`, the key under `telemetry.`, the value and what is
    /// allowed.
    pub fn resolve_in(&self, file: &Path) -> Result<TelemetryConfig, ConfigError> {
        let invalid = |key: &str, message: String| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            message,
        };
        let shdr = match &self.shdr {
            Some(a) => {
                Some(parse_shdr_addr(a).map_err(|m| invalid("telemetry.shdr", format!("= {m}")))?)
            }
            None => None,
        };
        let live = match &self.live {
            Some(a) => Some(parse_shdr_addr(a).map_err(|m| {
                invalid("telemetry.live", format!("= {}", m.replace("7878", "8080")))
            })?),
            None => None,
        };
        let mqtt = match &self.mqtt {
            Some(m) => {
                let mut s = MqttSettings::from_url(&m.url)
                    .map_err(|e| invalid("telemetry.mqtt.url", format!("= {e}")))?;
                if let Some(p) = &m.topic_prefix {
                    let p = p.trim_matches('/');
                    if p.is_empty() || p.contains(['#', '+']) {
                        return Err(invalid(
                            "telemetry.mqtt.topic_prefix",
                            format!("= \"{p}\": allowed a non-empty topic without `#` or `+`"),
                        ));
                    }
                    s.prefix = p.to_string();
                }
                if let Some(q) = m.qos {
                    check_range(file, "telemetry.mqtt.qos", f64::from(q), 0.0, 1.0)?;
                    s.qos = q;
                }
                if let Some(id) = &m.client_id {
                    if id.is_empty() || id.len() > 23 {
                        return Err(invalid(
                            "telemetry.mqtt.client_id",
                            format!("= \"{id}\": allowed 1 ..= 23 characters"),
                        ));
                    }
                    s.client_id = id.clone();
                }
                Some(s)
            }
            None => None,
        };
        let opcua = match &self.opcua {
            Some(o) => Some(o.resolve_in(file)?),
            None => None,
        };
        Ok(TelemetryConfig {
            shdr,
            live,
            mqtt,
            opcua,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RUN_KEY_RANGES;

    fn section(text: &str) -> Result<TelemetryConfig, String> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct F {
            telemetry: TelemetrySection,
        }
        let p = Path::new("run.toml");
        let f: F =
            acc_config::parse_toml_with(p, text, RUN_KEY_RANGES).map_err(|e| e.to_string())?;
        f.telemetry.resolve_in(p).map_err(|e| e.to_string())
    }

    #[test]
    fn telemetry_section_resolves_and_every_error_names_file_key_value_and_range() {
        let ok = section(
            "[telemetry]\nshdr = \"0.0.0.0:7878\"\n[telemetry.mqtt]\nurl = \"mqtt://broker:1884/x\"\ntopic_prefix = \"shop/vmc1\"\nqos = 1\nclient_id = \"vmc1\"\n",
        )
        .expect("valid");
        assert_eq!(ok.shdr.map(|a| a.port()), Some(7878));
        let m = ok.mqtt.expect("mqtt");
        assert_eq!((m.host.as_str(), m.port, m.qos), ("broker", 1884, 1));
        assert_eq!(m.topic("period"), "shop/vmc1/period");
        assert_eq!(m.client_id, "vmc1");

        let e = section("[telemetry]\nshdr = \"localhost\"\n").expect_err("bad address");
        assert!(
            e.contains("run.toml")
                && e.contains("telemetry.shdr")
                && e.contains("localhost")
                && e.contains("IP:PORT"),
            "{e}"
        );
        let e = section("[telemetry.mqtt]\nurl = \"http://b\"\n").expect_err("bad url");
        assert!(
            e.contains("telemetry.mqtt.url") && e.contains("http://b") && e.contains("mqtt://host"),
            "{e}"
        );
        let e = section("[telemetry.mqtt]\nurl = \"mqtt://b\"\nqos = 2\n").expect_err("qos 2");
        assert!(
            e.contains("telemetry.mqtt.qos") && e.contains('2') && e.contains("0 ..= 1"),
            "{e}"
        );
        let e = section("[telemetry.mqtt]\nurl = \"mqtt://b\"\ntopic_prefix = \"a/#\"\n")
            .expect_err("wildcard");
        assert!(e.contains("telemetry.mqtt.topic_prefix"), "{e}");
        let ok = section("[telemetry]\nlive = \"127.0.0.1:8080\"\n").expect("live");
        assert_eq!(ok.live.map(|a| a.port()), Some(8080));
        let e = section("[telemetry]\nlive = \"localhost:80\"\n").expect_err("bad live address");
        assert!(
            e.contains("telemetry.live") && e.contains("localhost:80") && e.contains("IP:PORT"),
            "{e}"
        );
        let e = section("[telemetry]\nshdr_addr = \"0.0.0.0:7878\"\n").expect_err("unknown key");
        assert!(e.contains("shdr_addr") && e.contains("shdr"), "{e}");
    }
}
