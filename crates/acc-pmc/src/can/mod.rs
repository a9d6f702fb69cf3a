//! The board's CAN variant: [`CanBoard`] over any bus implementing the standard
//! [`embedded_can::blocking::Can`] trait (a `socketcan::CanSocket` in production, the
//! in-memory `emu::CanBoardEmulator` in tests and simulations, feature `emulator`).
//!
//! The board broadcasts its status (`0x180+n`, then `0x280+n`) with every new power sample;
//! the PC sends one command frame (`0x200+n`) per cycle. A v2 board adds the NC-context frame
//! `0x300+n` to every status pair and the identity frame `0x380+n` once a second; the link
//! decodes both into [`BoardStatus`] and reports [`BoardProtocol::V2`] once it has seen them,
//! [`BoardProtocol::V1`] when a status pair arrives without a `0x300+n` frame from a board
//! that never sent one. There are no replies and no
//! exceptions on CAN, so [`CanBoard`] refuses an override the board would refuse (above
//! 150 % or not a multiple of the last reported step) locally, with the same
//! [`BoardErrorKind::Exception`]`(3)` the RTU board answers.
//!
//! The bus's `receive` must return after a short time when no frame arrives, with an error
//! for which [`ReceiveTimeout::is_receive_timeout`] is true (socketcan: set a read timeout
//! on the socket; it reports `io::ErrorKind::WouldBlock`/`TimedOut`).

pub mod codec;

use std::time::Duration;

use embedded_can::{Frame, Id, StandardId};

use crate::clock::{Clock, SystemClock};
use crate::regs::{OVERRIDE_MAX_PCT, PROTOCOL_V2};
use crate::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};
use codec::{
    decode_context, decode_identity, decode_status, encode_command, CanCodecError, Command, NodeIds,
};

/// Tells a receive timeout (no frame yet) apart from a real bus error.
pub trait ReceiveTimeout {
    /// `true` if the error only means that no frame arrived within the bus's timeout.
    fn is_receive_timeout(&self) -> bool;
}

impl ReceiveTimeout for std::io::Error {
    fn is_receive_timeout(&self) -> bool {
        matches!(
            self.kind(),
            std::io::ErrorKind::WouldBlock
                | std::io::ErrorKind::TimedOut
                | std::io::ErrorKind::Interrupted
        )
    }
}

#[cfg(feature = "socketcan")]
impl ReceiveTimeout for socketcan::Error {
    fn is_receive_timeout(&self) -> bool {
        match self {
            socketcan::Error::Io(e) => e.is_receive_timeout(),
            _ => false,
        }
    }
}

/// Link parameters of [`CanBoard`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CanLinkConfig {
    /// Node id `n`, 1…127. Default 1.
    pub node: u8,
    /// Time `read_status` waits for a fresh status pair. Default 40 ms.
    pub timeout: Duration,
}

impl Default for CanLinkConfig {
    fn default() -> Self {
        Self {
            node: 1,
            timeout: Duration::from_millis(40),
        }
    }
}

/// Errors of the CAN link.
#[derive(Debug, thiserror::Error)]
pub enum CanError<E: std::error::Error + 'static> {
    /// The bus reported an error (from the driver; see [`BoardError::kind`] for the mapping).
    #[error("CAN bus error: {0}")]
    Bus(#[source] E),
    /// No complete status pair within the timeout.
    #[error("node {node}: no status frames 0x{:03x}/0x{:03x} within {timeout_ms} ms", 0x180 + u16::from(*node), 0x280 + u16::from(*node))]
    Timeout {
        /// Node id.
        node: u8,
        /// The timeout, ms.
        timeout_ms: u64,
    },
    /// A status frame with a payload that does not fit the layout.
    #[error(transparent)]
    Codec(#[from] CanCodecError),
    /// An override the board would refuse (above 150 % or not a multiple of its step).
    #[error("override {value} % refused: must be 0..=150 and a multiple of the board's step {step} % (as exception 03)")]
    InvalidOverride {
        /// Requested override, percent.
        value: u16,
        /// The board's step, percent.
        step: u16,
    },
    /// The node id is outside 1…127.
    #[error("CAN node id {0} is out of range: allowed 1 ..= 127")]
    BadNode(u8),
}

impl<E> BoardError for CanError<E>
where
    E: std::error::Error + embedded_can::Error + Send + Sync + 'static,
{
    /// The [`BoardErrorKind`] the runtime acts on. Bus errors: `Bit`, `Stuff`, `Crc`, `Form`
    /// → `Crc` (corrupted frames); `Acknowledge` (nobody acknowledged) and `Other` (driver
    /// or interface failure) → `Disconnected`; `Overrun` → `Protocol`.
    fn kind(&self) -> BoardErrorKind {
        use embedded_can::ErrorKind as K;
        match self {
            CanError::Bus(e) => match e.kind() {
                K::Bit | K::Stuff | K::Crc | K::Form => BoardErrorKind::Crc,
                K::Acknowledge | K::Other => BoardErrorKind::Disconnected,
                _ => BoardErrorKind::Protocol,
            },
            CanError::Timeout { .. } => BoardErrorKind::Timeout,
            CanError::Codec(_) | CanError::BadNode(_) => BoardErrorKind::Protocol,
            CanError::InvalidOverride { .. } => BoardErrorKind::Exception(3),
        }
    }
}

/// The board over CAN on bus `B`.
pub struct CanBoard<B: embedded_can::blocking::Can> {
    bus: B,
    cfg: CanLinkConfig,
    ids: NodeIds,
    clock: Box<dyn Clock>,
    pending_a: Option<[u8; 8]>,
    last: Option<BoardStatus>,
    command: Command,
    /// `(PROTOCOL_VERSION, PROGRAM_NUMBER)` of the last identity frame (`0x380+n`).
    identity: Option<(u16, u16)>,
    /// A v2 frame (`0x300+n` or `0x380+n`) has been seen on this link.
    v2_seen: bool,
    protocol: Option<BoardProtocol>,
}

impl<B: embedded_can::blocking::Can> std::fmt::Debug for CanBoard<B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanBoard")
            .field("cfg", &self.cfg)
            .field("command", &self.command)
            .finish()
    }
}

impl<B> CanBoard<B>
where
    B: embedded_can::blocking::Can,
    B::Error: std::error::Error + ReceiveTimeout + Send + Sync + 'static,
{
    /// A link to node `cfg.node` on `bus`, deadlines on the system monotonic clock. The
    /// first command frame carries `OVERRIDE_CMD` = 100, `CONTROL` = 0, `HEARTBEAT` = 0.
    pub fn new(bus: B, cfg: CanLinkConfig) -> Result<Self, CanError<B::Error>> {
        Self::with_clock(bus, cfg, Box::new(SystemClock::default()))
    }

    /// As [`CanBoard::new`] with an injected clock.
    pub fn with_clock(
        bus: B,
        cfg: CanLinkConfig,
        clock: Box<dyn Clock>,
    ) -> Result<Self, CanError<B::Error>> {
        let ids = NodeIds::new(cfg.node).ok_or(CanError::BadNode(cfg.node))?;
        Ok(Self {
            bus,
            cfg,
            ids,
            clock,
            pending_a: None,
            last: None,
            identity: None,
            v2_seen: false,
            protocol: None,
            command: Command {
                override_pct: 100,
                control: ControlBits::default(),
                heartbeat: 0,
            },
        })
    }

    /// The bus.
    pub fn get_mut(&mut self) -> &mut B {
        &mut self.bus
    }

    /// The last complete status received, if any.
    pub fn last_status(&self) -> Option<BoardStatus> {
        self.last
    }

    fn standard_id(frame: &B::Frame) -> Option<u16> {
        match frame.id() {
            Id::Standard(id) if frame.is_data_frame() => Some(id.as_raw()),
            _ => None,
        }
    }

    /// Receive until a fresh status pair has arrived and the bus is quiet (the newest pair
    /// wins), or the timeout passes. A v2 context frame (`0x300+n`) is merged into the pair it
    /// follows (or precedes), the last identity frame (`0x380+n`) into every status.
    fn receive_status(&mut self) -> Result<BoardStatus, CanError<B::Error>> {
        let deadline = self.clock.now() + self.cfg.timeout;
        // The newest pair and whether a context frame came with it.
        let mut fresh: Option<(BoardStatus, bool)> = None;
        // A context frame that arrived before its pair was complete.
        let mut pending_context: Option<Vec<u8>> = None;
        loop {
            match self.bus.receive() {
                Ok(frame) => match Self::standard_id(&frame) {
                    Some(id) if id == self.ids.status_a => {
                        let data = frame.data();
                        let a: [u8; 8] = data.try_into().map_err(|_| CanCodecError::Length {
                            id,
                            expected: 8,
                            received: data.len(),
                        })?;
                        self.pending_a = Some(a);
                    }
                    Some(id) if id == self.ids.status_b => {
                        if let Some(a) = self.pending_a.take() {
                            let mut s = decode_status(self.ids, &a, frame.data())?;
                            let with_context = match pending_context.take() {
                                Some(c) => {
                                    decode_context(self.ids, &c, &mut s)?;
                                    true
                                }
                                None => false,
                            };
                            fresh = Some((s, with_context));
                        }
                    }
                    Some(id) if id == self.ids.context => {
                        self.v2_seen = true;
                        match fresh.as_mut() {
                            Some((s, with_context)) if !*with_context => {
                                decode_context(self.ids, frame.data(), s)?;
                                *with_context = true;
                            }
                            _ => pending_context = Some(frame.data().to_vec()),
                        }
                    }
                    Some(id) if id == self.ids.identity => {
                        self.v2_seen = true;
                        self.identity = Some(decode_identity(self.ids, frame.data())?);
                    }
                    _ => {} // other nodes, our own command frames, remote/extended frames
                },
                Err(e) if e.is_receive_timeout() => {
                    if let Some(f) = fresh {
                        return Ok(self.finish(f));
                    }
                }
                Err(e) => return Err(CanError::Bus(e)),
            }
            if self.clock.now() >= deadline {
                return fresh.map(|f| self.finish(f)).ok_or(CanError::Timeout {
                    node: self.cfg.node,
                    timeout_ms: u64::try_from(self.cfg.timeout.as_millis()).unwrap_or(u64::MAX),
                });
            }
        }
    }

    /// Add the identity to a received pair and settle the protocol: v2 once a v2 frame has
    /// been seen, v1 when a pair came without a context frame from a board that never sent
    /// one.
    fn finish(&mut self, (mut s, with_context): (BoardStatus, bool)) -> BoardStatus {
        if self.v2_seen || with_context {
            let (version, program) = self.identity.unwrap_or((PROTOCOL_V2, 0));
            s.protocol_version = version.max(PROTOCOL_V2);
            s.program_number = program;
            self.protocol = Some(BoardProtocol::V2);
        } else {
            self.protocol = Some(BoardProtocol::V1);
        }
        s
    }

    fn send_command(&mut self) -> Result<(), CanError<B::Error>> {
        let id = StandardId::new(self.ids.command).ok_or(CanError::BadNode(self.cfg.node))?;
        let payload = encode_command(&self.command);
        // Frame::new only fails for more than 8 data bytes.
        let frame = B::Frame::new(id, &payload).ok_or(CanError::BadNode(self.cfg.node))?;
        let result = self.bus.transmit(&frame).map_err(CanError::Bus);
        // ALARM_RESET is a one-shot request: later frames must not keep resetting.
        self.command.control.alarm_reset = false;
        result
    }
}

impl<B> Board for CanBoard<B>
where
    B: embedded_can::blocking::Can,
    B::Error: std::error::Error + embedded_can::Error + ReceiveTimeout + Send + Sync + 'static,
{
    type Error = CanError<B::Error>;

    /// The newest status pair (`0x180+n`, `0x280+n`), as received (`SAMPLE_SEQ` staleness
    /// is the fault policy's to judge).
    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        let status = self.receive_status()?;
        self.last = Some(status);
        Ok(status)
    }

    /// One command frame with the new override and heartbeat and the current `CONTROL`.
    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error> {
        let step = self
            .last
            .map(|s| s.override_step_pct)
            .filter(|s| *s > 0)
            .unwrap_or(1);
        if override_pct > OVERRIDE_MAX_PCT || override_pct % step != 0 {
            return Err(CanError::InvalidOverride {
                value: override_pct,
                step,
            });
        }
        self.command.override_pct = override_pct as u8;
        self.command.heartbeat = heartbeat;
        self.send_command()
    }

    /// One command frame with the new `CONTROL` and the last override and heartbeat.
    /// `ALARM_RESET` is sent in this frame only.
    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error> {
        self.command.control = control;
        self.send_command()
    }

    /// V2 once a `0x300+n` / `0x380+n` frame has been seen, V1 when a status pair arrived
    /// without a `0x300+n` frame; `None` before the first status pair.
    fn protocol(&self) -> Option<BoardProtocol> {
        self.protocol
    }
}

/// CAN settings as written in a config (`[board]` table with `can_iface` etc.), numbers
/// read wide so that out-of-range values get a range error.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct CanConfig {
    /// SocketCAN interface, e.g. `can0` or `vcan0`.
    pub iface: String,
    /// Node id `n`, 1…127. Default 1.
    #[serde(default = "default_node")]
    pub node: i64,
    /// Status wait per read, ms, 5…2000. Default 40.
    #[serde(default = "default_can_timeout_ms")]
    pub timeout_ms: i64,
}

fn default_node() -> i64 {
    1
}
fn default_can_timeout_ms() -> i64 {
    40
}

impl CanConfig {
    /// A config for `iface` with defaults (node 1, 40 ms).
    pub fn for_iface(iface: impl Into<String>) -> Self {
        Self {
            iface: iface.into(),
            node: default_node(),
            timeout_ms: default_can_timeout_ms(),
        }
    }

    /// Check every key; errors name `file`, `prefix.key` and the allowed range.
    pub fn validate(
        &self,
        file: impl AsRef<std::path::Path>,
        prefix: &str,
    ) -> Result<CanLinkConfig, acc_config::ConfigError> {
        let file = file.as_ref();
        let key = |k: &str| crate::serial::dotted(prefix, k);
        if self.iface.trim().is_empty() {
            return Err(acc_config::ConfigError::Invalid {
                file: file.to_path_buf(),
                key: key("iface"),
                message: "must name a CAN interface, e.g. \"can0\"".into(),
            });
        }
        let node = crate::serial::int_in(file, &key("node"), self.node, 1, 127)? as u8;
        let timeout_ms =
            crate::serial::int_in(file, &key("timeout_ms"), self.timeout_ms, 5, 2000)? as u64;
        Ok(CanLinkConfig {
            node,
            timeout: Duration::from_millis(timeout_ms),
        })
    }
}

/// Open SocketCAN interface `iface` (read timeout 5 ms, so `receive` returns when the bus
/// is quiet) and put a [`CanBoard`] on it. Nothing is sent.
#[cfg(feature = "socketcan")]
pub fn open_socketcan(
    iface: &str,
    cfg: CanLinkConfig,
) -> Result<CanBoard<socketcan::CanSocket>, CanError<socketcan::Error>> {
    use socketcan::Socket;
    let sock =
        socketcan::CanSocket::open(iface).map_err(|e| CanError::Bus(socketcan::Error::Io(e)))?;
    sock.set_read_timeout(crate::serial::POLL_SLICE)
        .map_err(|e| CanError::Bus(socketcan::Error::Io(e)))?;
    CanBoard::new(sock, cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn can_config_validation_names_key_and_range() {
        let ok = CanConfig::for_iface("can0")
            .validate("m.toml", "board")
            .expect("valid");
        assert_eq!(ok, CanLinkConfig::default());
        let mut bad = CanConfig::for_iface("can0");
        bad.node = 0;
        let err = bad.validate("m.toml", "board").expect_err("node 0");
        assert_eq!(
            err.to_string(),
            "m.toml: key `board.node` = 0 is out of range: allowed 1 ..= 127"
        );
        bad = CanConfig::for_iface(" ");
        assert!(bad.validate("m.toml", "board").is_err());
    }
}
