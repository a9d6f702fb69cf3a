//! Serial-port configuration of the RTU link: typed, validated once at start-up, and opened
//! with the `serialport` crate only after validation, so that a bad config never sends a
//! byte to the board.
//!
//! ```
//! use acc_pmc::serial::RtuConfig;
//! let cfg: RtuConfig = toml::from_str("port = \"/dev/ttyUSB0\"\nslave = 0").unwrap();
//! let err = cfg.validate("machine.toml", "board").unwrap_err();
//! assert_eq!(err.to_string(), "machine.toml: key `board.slave` = 0 is out of range: allowed 1 ..= 247");
//! ```
//!
//! Parity on pseudo-terminals: the Linux pty driver does not keep `PARENB`. The `serialport`
//! crate (4.x) sets the termios with `TCSETS2` and does **not** report this (measured on
//! this kernel: opening a pty with even parity succeeds and the port reads back parity
//! none), whereas pyserial's `tcsetattr` path reports `EINVAL`. [`open_port`] therefore
//! reads every setting back and refuses a port whose framing differs from the config
//! ([`OpenError::SettingRefused`]). Tests over ptys use 8N1.

use std::path::{Path, PathBuf};
use std::time::Duration;

use acc_config::ConfigError;
use acc_config::RangeError;
use serialport::{DataBits, Parity, SerialPort, StopBits, TTYPort};

use crate::regs::{WATCHDOG_DEFAULT_MS, WATCHDOG_RANGE_MS};
use crate::rtu::{RtuBoard, RtuLinkConfig};

/// Read timeout of an opened port: a read with no byte returns after this long. The client
/// measures its own deadlines across reads; the server treats one silent slice as the end
/// of a frame (the Modbus 3.5-character gap, widened for ptys and USB adapters).
pub const POLL_SLICE: Duration = Duration::from_millis(5);

/// Baud rates the link accepts.
pub const BAUD_RATES: [u32; 8] = [1200, 2400, 4800, 9600, 19_200, 38_400, 57_600, 115_200];

/// The `[board]` table of a machine config, or a `configs/boards/*.toml` file, as written.
/// Numbers are read wide so that an out-of-range value gets a range error, not a type error.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct RtuConfig {
    /// Serial device, e.g. `/dev/ttyUSB0` or the pty path `acc board-sim` prints.
    pub port: String,
    /// Baud rate, one of [`BAUD_RATES`]. Default 19 200.
    #[serde(default = "default_baud")]
    pub baud: i64,
    /// `"none"`, `"even"` or `"odd"`. Default `"even"` (the Modbus RTU default).
    #[serde(default = "default_parity")]
    pub parity: String,
    /// Data bits: Modbus RTU uses 8. Default 8.
    #[serde(default = "default_data_bits")]
    pub data_bits: i64,
    /// Stop bits, 1 or 2. Default 1.
    #[serde(default = "default_stop_bits")]
    pub stop_bits: i64,
    /// Modbus slave address, 1…247. Default 1.
    #[serde(default = "default_slave")]
    pub slave: i64,
    /// Reply timeout per attempt, ms, 5…2000. Default 40.
    #[serde(default = "default_timeout_ms")]
    pub timeout_ms: i64,
    /// Extra attempts after a timeout/CRC/protocol error, 0…5. Default 1.
    #[serde(default = "default_retries")]
    pub retries: i64,
    /// Time budget of one call including retries, ms, `timeout_ms`…5000. Default 90.
    #[serde(default = "default_budget_ms")]
    pub budget_ms: i64,
    /// Board watchdog `WATCHDOG_MS` to program at start, ms, 100…5000. Default 500.
    #[serde(default = "default_watchdog_ms")]
    pub watchdog_ms: i64,
}

fn default_baud() -> i64 {
    19_200
}
fn default_parity() -> String {
    "even".into()
}
fn default_data_bits() -> i64 {
    8
}
fn default_stop_bits() -> i64 {
    1
}
fn default_slave() -> i64 {
    1
}
fn default_timeout_ms() -> i64 {
    40
}
fn default_retries() -> i64 {
    1
}
fn default_budget_ms() -> i64 {
    90
}
fn default_watchdog_ms() -> i64 {
    i64::from(WATCHDOG_DEFAULT_MS)
}

/// Validated serial framing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialParams {
    /// Baud rate.
    pub baud: u32,
    /// Parity.
    pub parity: Parity,
    /// Data bits (8).
    pub data_bits: DataBits,
    /// Stop bits.
    pub stop_bits: StopBits,
}

/// A validated RTU configuration: what [`open_port`] and [`open_rtu_board`] take.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RtuSettings {
    /// Serial device path.
    pub port: String,
    /// Dotted key of `port` in its file (for errors at open time), e.g. `board.port`.
    pub port_key: String,
    /// File the settings came from (for errors at open time).
    pub file: PathBuf,
    /// Serial framing.
    pub serial: SerialParams,
    /// Link parameters (slave, timeout, retries, budget).
    pub link: RtuLinkConfig,
    /// `WATCHDOG_MS` to program into the board at start, ms.
    pub watchdog_ms: u16,
}

/// `prefix.key`, or `key` without a prefix.
pub(crate) fn dotted(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// Check `lo <= value <= hi` for an integer key; the error names file, key and range.
pub(crate) fn int_in(
    file: &Path,
    key: &str,
    value: i64,
    lo: i64,
    hi: i64,
) -> Result<i64, ConfigError> {
    if (lo..=hi).contains(&value) {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange(
            RangeError::new(key.to_string(), value.to_string(), format!("{lo} ..= {hi}"))
                .in_file(file),
        ))
    }
}

impl RtuConfig {
    /// A config for `port` with every other key at its default (19 200 8E1, slave 1).
    pub fn for_port(port: impl Into<String>) -> Self {
        Self {
            port: port.into(),
            baud: default_baud(),
            parity: default_parity(),
            data_bits: default_data_bits(),
            stop_bits: default_stop_bits(),
            slave: default_slave(),
            timeout_ms: default_timeout_ms(),
            retries: default_retries(),
            budget_ms: default_budget_ms(),
            watchdog_ms: default_watchdog_ms(),
        }
    }

    /// Load a stand-alone board file (keys at top level), e.g. `configs/boards/pmc-rtu.toml`.
    pub fn load(path: impl AsRef<Path>) -> Result<RtuSettings, ConfigError> {
        let path = path.as_ref();
        let cfg: RtuConfig = acc_config::load_toml(path)?;
        cfg.validate(path, "")
    }

    /// Check every key; errors name `file`, the dotted key (`prefix.key`) and the allowed
    /// range. Nothing is opened or sent.
    pub fn validate(
        &self,
        file: impl AsRef<Path>,
        prefix: &str,
    ) -> Result<RtuSettings, ConfigError> {
        let file = file.as_ref();
        let key = |k: &str| dotted(prefix, k);
        let invalid = |k: &str, message: String| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key(k),
            message,
        };
        if self.port.trim().is_empty() {
            return Err(invalid(
                "port",
                "must name a serial device, e.g. \"/dev/ttyUSB0\"".into(),
            ));
        }
        let baud = BAUD_RATES
            .iter()
            .copied()
            .find(|b| i64::from(*b) == self.baud)
            .ok_or_else(|| {
                ConfigError::OutOfRange(
                    RangeError::new(
                        key("baud"),
                        self.baud.to_string(),
                        format!("one of {BAUD_RATES:?}"),
                    )
                    .in_file(file),
                )
            })?;
        let parity = match self.parity.to_ascii_lowercase().as_str() {
            "none" => Parity::None,
            "even" => Parity::Even,
            "odd" => Parity::Odd,
            other => {
                return Err(invalid(
                    "parity",
                    format!("\"{other}\" is not one of \"none\", \"even\", \"odd\""),
                ))
            }
        };
        if self.data_bits != 8 {
            return Err(ConfigError::OutOfRange(
                RangeError::new(
                    key("data_bits"),
                    self.data_bits.to_string(),
                    "8 (Modbus RTU frames are 8-bit)",
                )
                .in_file(file),
            ));
        }
        let stop_bits = match int_in(file, &key("stop_bits"), self.stop_bits, 1, 2)? {
            1 => StopBits::One,
            _ => StopBits::Two,
        };
        let slave = int_in(file, &key("slave"), self.slave, 1, 247)? as u8;
        let timeout_ms = int_in(file, &key("timeout_ms"), self.timeout_ms, 5, 2000)? as u64;
        let retries = int_in(file, &key("retries"), self.retries, 0, 5)? as u8;
        let budget_ms = int_in(
            file,
            &key("budget_ms"),
            self.budget_ms,
            timeout_ms as i64,
            5000,
        )? as u64;
        let (wd_lo, wd_hi) = (
            i64::from(*WATCHDOG_RANGE_MS.start()),
            i64::from(*WATCHDOG_RANGE_MS.end()),
        );
        let watchdog_ms = int_in(file, &key("watchdog_ms"), self.watchdog_ms, wd_lo, wd_hi)? as u16;
        Ok(RtuSettings {
            port: self.port.clone(),
            port_key: key("port"),
            file: file.to_path_buf(),
            serial: SerialParams {
                baud,
                parity,
                data_bits: DataBits::Eight,
                stop_bits,
            },
            link: RtuLinkConfig {
                slave,
                timeout: Duration::from_millis(timeout_ms),
                retries,
                budget: Duration::from_millis(budget_ms),
            },
            watchdog_ms,
        })
    }
}

/// Why a validated port could not be opened as configured. Raised before any byte is sent.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The device could not be opened (missing, busy, no permission).
    #[error(transparent)]
    Open(Box<OpenFailed>),
    /// The device accepted the open but not the framing (e.g. a pty refusing even parity).
    #[error(transparent)]
    SettingRefused(Box<SettingRefused>),
}

/// Details of [`OpenError::Open`].
#[derive(Debug, thiserror::Error)]
#[error("{}: key `{key}`: cannot open serial port \"{port}\": {reason}", file.display())]
pub struct OpenFailed {
    /// Config file.
    pub file: PathBuf,
    /// Dotted key of the port.
    pub key: String,
    /// Device path.
    pub port: String,
    /// The OS / serialport message.
    pub reason: String,
}

/// Details of [`OpenError::SettingRefused`].
#[derive(Debug, thiserror::Error)]
#[error("{}: key `{key}`: serial port \"{port}\" refused {setting} = {requested} (it reads back {actual}); configure a framing the port supports (ptys only do parity \"none\")", file.display())]
pub struct SettingRefused {
    /// Config file.
    pub file: PathBuf,
    /// Dotted key of the refused setting, e.g. `board.parity`.
    pub key: String,
    /// Device path.
    pub port: String,
    /// Setting name.
    pub setting: &'static str,
    /// Value asked for.
    pub requested: String,
    /// Value the port reports.
    pub actual: String,
}

fn parity_name(p: Parity) -> &'static str {
    match p {
        Parity::None => "none",
        Parity::Even => "even",
        Parity::Odd => "odd",
    }
}

/// Check that `port` reads back exactly the framing in `params`.
pub fn verify_framing(port: &TTYPort, settings: &RtuSettings) -> Result<(), OpenError> {
    let params = settings.serial;
    let key_of = |k: &str| match settings.port_key.rsplit_once('.') {
        Some((prefix, _)) => format!("{prefix}.{k}"),
        None => k.to_string(),
    };
    let refused = |setting: &'static str, requested: String, actual: String| {
        OpenError::SettingRefused(Box::new(SettingRefused {
            file: settings.file.clone(),
            key: key_of(setting),
            port: settings.port.clone(),
            setting,
            requested,
            actual,
        }))
    };
    let read_err = |setting: &'static str, e: serialport::Error| {
        refused(
            setting,
            "a readable setting".into(),
            format!("an error: {e}"),
        )
    };
    let parity = port.parity().map_err(|e| read_err("parity", e))?;
    if parity != params.parity {
        return Err(refused(
            "parity",
            parity_name(params.parity).into(),
            parity_name(parity).into(),
        ));
    }
    let data_bits = port.data_bits().map_err(|e| read_err("data_bits", e))?;
    if data_bits != params.data_bits {
        return Err(refused(
            "data_bits",
            params.data_bits.to_string(),
            data_bits.to_string(),
        ));
    }
    let stop_bits = port.stop_bits().map_err(|e| read_err("stop_bits", e))?;
    if stop_bits != params.stop_bits {
        return Err(refused(
            "stop_bits",
            params.stop_bits.to_string(),
            stop_bits.to_string(),
        ));
    }
    let baud = port.baud_rate().map_err(|e| read_err("baud", e))?;
    if baud != params.baud {
        return Err(refused("baud", params.baud.to_string(), baud.to_string()));
    }
    Ok(())
}

/// Open the configured port with `serialport`, set the read timeout to [`POLL_SLICE`], and
/// verify that the framing took ([`verify_framing`]). Nothing is written.
pub fn open_port(settings: &RtuSettings) -> Result<TTYPort, OpenError> {
    let p = settings.serial;
    let port = serialport::new(&settings.port, p.baud)
        .parity(p.parity)
        .data_bits(p.data_bits)
        .stop_bits(p.stop_bits)
        .flow_control(serialport::FlowControl::None)
        .timeout(POLL_SLICE)
        .open_native()
        .map_err(|e| {
            OpenError::Open(Box::new(OpenFailed {
                file: settings.file.clone(),
                key: settings.port_key.clone(),
                port: settings.port.clone(),
                reason: e.to_string(),
            }))
        })?;
    verify_framing(&port, settings)?;
    Ok(port)
}

/// Open the port ([`open_port`]) and wrap it in an [`RtuBoard`]. The board's
/// `WATCHDOG_MS` is **not** written here: the runtime does that as its first transaction
/// (`RtuBoard::write_watchdog_ms(settings.watchdog_ms)`).
pub fn open_rtu_board(settings: &RtuSettings) -> Result<RtuBoard<TTYPort>, OpenError> {
    Ok(RtuBoard::new(open_port(settings)?, settings.link))
}

/// Configure one end of a [`TTYPort::pair`] for tests and the emulator: raw 8N1 at `baud`,
/// read timeout [`POLL_SLICE`].
pub fn configure_pty(port: &mut TTYPort, baud: u32) -> serialport::Result<()> {
    port.set_baud_rate(baud)?;
    port.set_parity(Parity::None)?;
    port.set_data_bits(DataBits::Eight)?;
    port.set_stop_bits(StopBits::One)?;
    port.set_flow_control(serialport::FlowControl::None)?;
    port.set_timeout(POLL_SLICE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> RtuConfig {
        match toml::from_str(text) {
            Ok(c) => c,
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn defaults_are_the_modbus_defaults() {
        let s = parse("port = \"/dev/ttyS0\"")
            .validate("b.toml", "board")
            .expect("valid");
        assert_eq!(s.serial.baud, 19_200);
        assert_eq!(s.serial.parity, Parity::Even);
        assert_eq!(s.serial.stop_bits, StopBits::One);
        assert_eq!(s.link.slave, 1);
        assert_eq!(s.watchdog_ms, 500);
        assert_eq!(s.port_key, "board.port");
        assert_eq!(
            RtuConfig::for_port("/dev/ttyS0"),
            parse("port = \"/dev/ttyS0\"")
        );
    }

    #[test]
    fn bad_values_name_key_and_range() {
        let cases = [
            ("slave = 0", "b.toml: key `board.slave` = 0 is out of range: allowed 1 ..= 247"),
            ("slave = 248", "b.toml: key `board.slave` = 248 is out of range: allowed 1 ..= 247"),
            ("watchdog_ms = 50", "b.toml: key `board.watchdog_ms` = 50 is out of range: allowed 100 ..= 5000"),
            (
                "baud = 1000000",
                "b.toml: key `board.baud` = 1000000 is out of range: allowed one of [1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200]",
            ),
            ("data_bits = 7", "b.toml: key `board.data_bits` = 7 is out of range: allowed 8 (Modbus RTU frames are 8-bit)"),
            ("stop_bits = 3", "b.toml: key `board.stop_bits` = 3 is out of range: allowed 1 ..= 2"),
            ("timeout_ms = 1", "b.toml: key `board.timeout_ms` = 1 is out of range: allowed 5 ..= 2000"),
            ("timeout_ms = 100\nbudget_ms = 50", "b.toml: key `board.budget_ms` = 50 is out of range: allowed 100 ..= 5000"),
            ("parity = \"mark\"", "b.toml: key `board.parity`: \"mark\" is not one of \"none\", \"even\", \"odd\""),
        ];
        for (extra, msg) in cases {
            let cfg = parse(&format!("port = \"/dev/ttyS0\"\n{extra}"));
            let err = cfg.validate("b.toml", "board").expect_err(extra);
            assert_eq!(err.to_string(), msg);
        }
        let err = parse("port = \"\"")
            .validate("b.toml", "")
            .expect_err("empty port");
        assert!(
            err.to_string()
                .starts_with("b.toml: key `port`: must name a serial device"),
            "{err}"
        );
    }

    #[test]
    fn shipped_board_configs_are_valid() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/boards");
        let rtu = RtuConfig::load(dir.join("pmc-rtu.toml")).expect("pmc-rtu.toml");
        assert_eq!(
            (rtu.serial.baud, rtu.serial.parity, rtu.link.slave),
            (19_200, Parity::Even, 1)
        );
        assert_eq!(
            (rtu.link.timeout, rtu.link.budget),
            (Duration::from_millis(40), Duration::from_millis(90))
        );
        let sim = RtuConfig::load(dir.join("pmc-sim-pty.toml")).expect("pmc-sim-pty.toml");
        assert_eq!(
            (sim.serial.baud, sim.serial.parity),
            (115_200, Parity::None)
        );
    }

    #[test]
    fn unknown_keys_are_refused_with_file_and_line() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("board.toml");
        std::fs::write(&path, "port = \"/dev/ttyS0\"\nbaudrate = 9600\n").expect("write");
        let err = RtuConfig::load(&path).expect_err("unknown key");
        let msg = err.to_string();
        assert!(
            msg.contains("board.toml") && msg.contains("baudrate") && msg.contains("line 2"),
            "{msg}"
        );
    }

    #[test]
    fn unknown_port_is_an_open_error_naming_the_key() {
        let s = RtuConfig::for_port("/dev/does-not-exist-acc")
            .validate("m.toml", "board")
            .expect("valid");
        let err = open_port(&s).expect_err("missing device");
        let msg = err.to_string();
        assert!(
            msg.starts_with(
                "m.toml: key `board.port`: cannot open serial port \"/dev/does-not-exist-acc\""
            ),
            "{msg}"
        );
    }

    #[test]
    fn pty_refusing_even_parity_is_a_clear_error() {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        master
            .set_timeout(Duration::from_millis(20))
            .expect("timeout");
        let path = slave.name().expect("pty name");
        let mut cfg = RtuConfig::for_port(&path);
        cfg.parity = "even".into();
        let s = cfg.validate("m.toml", "board").expect("valid");
        match open_port(&s) {
            Err(OpenError::SettingRefused(r)) => {
                assert_eq!(
                    (r.key.as_str(), r.requested.as_str(), r.actual.as_str()),
                    ("board.parity", "even", "none")
                );
            }
            Err(e) => panic!("unexpected error {e}"),
            // A kernel whose ptys keep PARENB passes verification: then it really is even.
            Ok(port) => assert_eq!(port.parity().ok(), Some(Parity::Even)),
        }
        // Nothing reached the board's end of the line.
        let mut buf = [0u8; 16];
        assert!(
            std::io::Read::read(&mut master, &mut buf).is_err(),
            "no byte may be sent"
        );
        cfg.parity = "none".into();
        let s = cfg.validate("m.toml", "board").expect("valid");
        assert!(open_port(&s).is_ok());
    }
}
