//! The OPC UA server's settings: `--opcua opc.tcp://IP:PORT`, `[telemetry] opcua = "…"` or
//! the table `[telemetry.opcua]` with the security keys (docs/opcua.md "Security").
//!
//! ```
//! use acc_runtime::opcua_config::OpcUaSettings;
//! let s = OpcUaSettings::from_url("opc.tcp://127.0.0.1:4840").expect("url");
//! assert_eq!(s.addr.port(), 4840);
//! assert!(s.user.is_none(), "anonymous, SecurityPolicy None by default");
//! assert!(OpcUaSettings::from_url("http://127.0.0.1:4840").is_err());
//! ```

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use acc_config::{resolve_relative, ConfigError};
use serde::Deserialize;

/// The IANA port of OPC UA over TCP, used when the URL names none.
pub const DEFAULT_PORT: u16 = 4840;

/// `[telemetry] opcua`: either the URL alone or the table with the security keys.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum OpcUaEntry {
    /// `opcua = "opc.tcp://IP:PORT"`: anonymous, SecurityPolicy None.
    Url(String),
    /// `[telemetry.opcua]`.
    Table(OpcUaSection),
}

/// `[telemetry.opcua]`.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct OpcUaSection {
    /// Listen URL, `opc.tcp://IP[:PORT]` (port 4840 by default).
    pub url: String,
    /// User name: with it, the only endpoint is Basic256Sha256 SignAndEncrypt with user name
    /// and password (no anonymous access, no SecurityPolicy None).
    pub user: Option<String>,
    /// File holding the user's password (first line; relative to the config file). Never the
    /// password itself: it must not appear in a config that is shared or in argv.
    pub password_file: Option<String>,
    /// Folder of the server's certificate and private key and of the trusted / rejected
    /// client certificates (relative to the config file; default `<run log folder>/pki`).
    pub pki_dir: Option<String>,
    /// Trust every client certificate on first contact (default `true`; with `false` a new
    /// client's certificate lands in `<pki_dir>/rejected` until it is moved to `trusted`).
    pub trust_client_certs: Option<bool>,
}

/// A user allowed on the secure endpoint.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpcUaUser {
    /// User name.
    pub name: String,
    /// File whose first line is the password (read when the server starts).
    pub password_file: PathBuf,
}

/// The validated OPC UA settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpcUaSettings {
    /// Listen address (`127.0.0.1:0` picks a free port).
    pub addr: SocketAddr,
    /// The user of the secure endpoint; `None`: anonymous with SecurityPolicy None.
    pub user: Option<OpcUaUser>,
    /// Certificate folder; `None`: the command's default (docs/opcua.md "Folders").
    pub pki_dir: Option<PathBuf>,
    /// Trust every client certificate on first contact.
    pub trust_client_certs: bool,
}

impl OpcUaSettings {
    /// Parse `opc.tcp://IP[:PORT][/]` (`localhost` stands for 127.0.0.1); the error says what
    /// is allowed.
    pub fn from_url(url: &str) -> Result<Self, String> {
        let allowed = "allowed opc.tcp://IP[:PORT], e.g. opc.tcp://127.0.0.1:4840";
        let rest = url
            .strip_prefix("opc.tcp://")
            .ok_or_else(|| format!("\"{url}\" is not an OPC UA URL: {allowed}"))?;
        let hostport = rest.trim_end_matches('/');
        if hostport.contains('/') {
            return Err(format!("\"{url}\": no path is served: {allowed}"));
        }
        // `[v6]:port`, `[v6]`, `v4:port`, `v4`, `localhost[:port]`.
        let (host, port) = match hostport.strip_prefix('[') {
            Some(v6) => match v6.split_once(']') {
                Some((h, "")) => (h, None),
                Some((h, p)) => (h, Some(p.strip_prefix(':').unwrap_or(p))),
                None => (v6, None),
            },
            None => match hostport.rsplit_once(':') {
                Some((h, p)) => (h, Some(p)),
                None => (hostport, None),
            },
        };
        let port = match port {
            Some(p) => p
                .parse::<u16>()
                .map_err(|_| format!("\"{url}\": port `{p}`: allowed 0 ..= 65535"))?,
            None => DEFAULT_PORT,
        };
        let host = if host.eq_ignore_ascii_case("localhost") {
            "127.0.0.1"
        } else {
            host
        };
        let ip: std::net::IpAddr = host
            .parse()
            .map_err(|_| format!("\"{url}\": host `{host}` is not an IP address: {allowed}"))?;
        Ok(Self {
            addr: SocketAddr::new(ip, port),
            user: None,
            pki_dir: None,
            trust_client_certs: true,
        })
    }

    /// The URL clients use (`opc.tcp://IP:PORT/`), for the actual port once bound.
    pub fn url_for(addr: SocketAddr) -> String {
        format!("opc.tcp://{addr}/")
    }
}

impl OpcUaEntry {
    /// Validate; an error names `file`, the key under `telemetry.opcua`, the value and what is
    /// allowed. Relative paths are taken from `file`'s folder.
    pub fn resolve_in(&self, file: &Path) -> Result<OpcUaSettings, ConfigError> {
        let invalid = |key: &str, message: String| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            message,
        };
        match self {
            OpcUaEntry::Url(u) => {
                OpcUaSettings::from_url(u).map_err(|e| invalid("telemetry.opcua", format!("= {e}")))
            }
            OpcUaEntry::Table(t) => {
                let mut s = OpcUaSettings::from_url(&t.url)
                    .map_err(|e| invalid("telemetry.opcua.url", format!("= {e}")))?;
                s.user = match (&t.user, &t.password_file) {
                    (Some(u), Some(p)) if !u.is_empty() => Some(OpcUaUser {
                        name: u.clone(),
                        password_file: resolve_relative(file, p),
                    }),
                    (Some(_), Some(_)) => {
                        return Err(invalid(
                            "telemetry.opcua.user",
                            "= \"\": allowed a non-empty user name".into(),
                        ))
                    }
                    (Some(u), None) => {
                        return Err(invalid(
                            "telemetry.opcua.password_file",
                            format!("missing: user \"{u}\" needs a password_file (a file whose first line is the password)"),
                        ))
                    }
                    (None, Some(_)) => {
                        return Err(invalid(
                            "telemetry.opcua.user",
                            "missing: password_file is set but no user".into(),
                        ))
                    }
                    (None, None) => None,
                };
                s.pki_dir = t.pki_dir.as_ref().map(|p| resolve_relative(file, p));
                s.trust_client_certs = t.trust_client_certs.unwrap_or(true);
                Ok(s)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct T {
        opcua: OpcUaEntry,
    }

    fn entry(text: &str) -> Result<OpcUaSettings, String> {
        let t: T = toml::from_str(text).map_err(|e| e.to_string())?;
        t.opcua
            .resolve_in(Path::new("/etc/acc/run.toml"))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn url_or_table_and_every_error_names_the_key() {
        let s = entry("opcua = \"opc.tcp://0.0.0.0:4841\"").expect("url");
        assert_eq!(s.addr.to_string(), "0.0.0.0:4841");
        let s = entry("opcua = \"opc.tcp://localhost\"").expect("default port");
        assert_eq!(s.addr.to_string(), "127.0.0.1:4840");
        let s = entry(
            "[opcua]\nurl = \"opc.tcp://127.0.0.1:0\"\nuser = \"shop\"\npassword_file = \"pw.txt\"\npki_dir = \"pki\"\n",
        )
        .expect("table");
        let u = s.user.expect("user");
        assert_eq!(u.name, "shop");
        assert_eq!(u.password_file, Path::new("/etc/acc/pw.txt"));
        assert_eq!(s.pki_dir.as_deref(), Some(Path::new("/etc/acc/pki")));
        let e = entry("[opcua]\nurl = \"opc.tcp://127.0.0.1:0\"\nuser = \"shop\"\n")
            .expect_err("no pw");
        assert!(e.contains("telemetry.opcua.password_file"), "{e}");
        let e = entry("opcua = \"opc.tcp://plc.local:4840\"").expect_err("host name");
        assert!(
            e.contains("telemetry.opcua") && e.contains("plc.local"),
            "{e}"
        );
        let e = entry("opcua = \"opc.tcp://127.0.0.1:99999\"").expect_err("port");
        assert!(e.contains("99999") && e.contains("0 ..= 65535"), "{e}");
    }
}
