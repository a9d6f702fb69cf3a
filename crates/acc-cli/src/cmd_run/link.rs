//! The links `acc run` drives the PMC interface board over, one opener each: Modbus RTU on a
//! serial port ([`open_rtu`]), CAN over SocketCAN ([`open_can`]) and LinuxCNC's HAL
//! ([`open_hal`]: acc is a HAL component, the board is `acc_linuxcnc::HalBoard`).
//!
//! An opener returns the board it opened with what differs between links ([`OpenLink`]):
//! the first status (after the link's own start-up transactions), the banner, how the link
//! reopens after its device vanished and its counters after the run. `run_on_link` does the
//! rest once for every link; a new link is one more opener and one arm of `run_cmd`'s match
//! on the config's link.

use acc_pmc::regs::FallbackMode;
use acc_pmc::rtu::RtuBoard;
use acc_pmc::{Board, BoardProtocol, BoardStatus};
use acc_runtime::config::RunConfig;
use anyhow::Context;

use super::protocol_name;
use crate::exit::{ExitAs, RunExit};

/// A link to the board, opened: the board `acc run` drives, and what the run needs of the
/// link.
pub struct OpenLink<'a, B> {
    /// The board.
    pub board: B,
    /// Its first status (which settled the protocol).
    pub status: BoardStatus,
    /// The device in messages: the serial port, the CAN interface.
    pub device: &'a str,
    /// The line printed once the board answered: the link, its settings and the protocol.
    pub banner: String,
    /// Open the link again after its device vanished (the driver's reopen).
    pub reopen: Box<dyn FnMut() -> anyhow::Result<B> + 'a>,
    /// The link's counters after the run, if it keeps any.
    pub counters: fn(&B) -> Option<String>,
}

/// Attempts of each start-up transaction (`WATCHDOG_MS`, the first status, `FALLBACK_MODE`),
/// each within the link's own timeout, retries and budget: nothing is driven yet, so a reply
/// lost or late at start (a board powering up, a loaded host) costs another attempt, not
/// the run.
const START_ATTEMPTS: u32 = 3;

/// `transaction`, tried up to [`START_ATTEMPTS`] times until it succeeds; the last error.
fn at_start<T, E>(mut transaction: impl FnMut() -> Result<T, E>) -> Result<T, E> {
    let mut result = transaction();
    for _ in 1..START_ATTEMPTS {
        if result.is_ok() {
            break;
        }
        result = transaction();
    }
    result
}

/// The config's name of a fallback mode (`board.fallback_mode`).
fn fallback_mode_name(m: FallbackMode) -> &'static str {
    match m {
        FallbackMode::ClampOnly => "clamp",
        FallbackMode::ClampAndFeedHold => "clamp_and_feed_hold",
    }
}

/// The serial board: the port (framing verified, nothing sent), then the first
/// transaction: the watchdog time; then the status (which settles the protocol), and
/// `FALLBACK_MODE` on a v2 board. The same at start and to reopen.
fn start_rtu(
    cfg: &RunConfig,
    rtu_cfg: &acc_pmc::serial::RtuSettings,
) -> anyhow::Result<(RtuBoard<acc_pmc::serialport::TTYPort>, BoardStatus)> {
    let port = acc_pmc::serial::open_port(rtu_cfg).exit_as(RunExit::Usage)?;
    let mut rtu = RtuBoard::new(port, rtu_cfg.link);
    at_start(|| rtu.write_watchdog_ms(rtu_cfg.watchdog_ms))
        .with_context(|| {
            format!(
                "{}: writing WATCHDOG_MS = {} ms to slave {} on {}",
                cfg.path.display(),
                rtu_cfg.watchdog_ms,
                rtu_cfg.link.slave,
                rtu_cfg.port
            )
        })
        .exit_as(RunExit::BoardNotAnswering)?;
    let status = at_start(|| rtu.read_status())
        .with_context(|| format!("reading the board status on {}", rtu_cfg.port))
        .exit_as(RunExit::BoardNotAnswering)?;
    if rtu.protocol() == Some(BoardProtocol::V2) {
        at_start(|| rtu.write_fallback_mode(cfg.fallback_mode))
            .with_context(|| {
                format!(
                    "{}: writing `board.fallback_mode` = \"{}\" (FALLBACK_MODE) to slave {} on {}",
                    cfg.path.display(),
                    fallback_mode_name(cfg.fallback_mode),
                    rtu_cfg.link.slave,
                    rtu_cfg.port
                )
            })
            .exit_as(RunExit::BoardNotAnswering)?;
    }
    Ok((rtu, status))
}

/// Modbus RTU on a serial port (`[board]`, `--port`): [`start_rtu`] at start and to reopen;
/// the link's transaction counters after the run.
pub fn open_rtu<'a>(
    cfg: &'a RunConfig,
    rtu_cfg: &'a acc_pmc::serial::RtuSettings,
) -> anyhow::Result<OpenLink<'a, RtuBoard<acc_pmc::serialport::TTYPort>>> {
    let (board, status) = start_rtu(cfg, rtu_cfg)?;
    let banner = format!(
        "board: Modbus RTU slave {} on {} at {} baud; watchdog {} ms; protocol {}{}",
        rtu_cfg.link.slave,
        rtu_cfg.port,
        rtu_cfg.serial.baud,
        rtu_cfg.watchdog_ms,
        protocol_name(board.protocol()),
        if board.protocol() == Some(BoardProtocol::V2) {
            format!(
                "; FALLBACK_MODE = {}",
                fallback_mode_name(cfg.fallback_mode)
            )
        } else {
            String::new()
        }
    );
    Ok(OpenLink {
        board,
        status,
        device: &rtu_cfg.port,
        banner,
        reopen: Box::new(move || start_rtu(cfg, rtu_cfg).map(|(b, _)| b)),
        counters: |b| {
            let st = b.stats();
            Some(format!(
                "link: {} transactions, {} retries, {} timeouts, {} CRC errors, {} protocol errors, {} exceptions",
                st.transactions, st.retries, st.timeouts, st.crc_errors, st.protocol_errors, st.exceptions
            ))
        },
    })
}

/// CAN over SocketCAN (`[can]`, `--can`): the interface, then the first status (no start-up
/// writes: the board keeps its own watchdog time and fallback mode); the interface alone
/// to reopen.
pub fn open_can<'a>(
    cfg: &'a RunConfig,
    iface: &'a str,
    link: acc_pmc::can::CanLinkConfig,
) -> anyhow::Result<OpenLink<'a, impl Board + Send>> {
    let open = move || {
        acc_pmc::can::open_socketcan(iface, link).map_err(|e| {
            anyhow::anyhow!(
                "{}: key `can.iface` (--can {iface}): cannot open the CAN interface: {e}",
                cfg.path.display()
            )
        })
    };
    let mut board = open().exit_as(RunExit::Usage)?;
    let status = board
        .read_status()
        .map_err(|e| anyhow::anyhow!("reading the board status on {iface}: {e}"))
        .exit_as(RunExit::BoardNotAnswering)?;
    let banner = format!(
        "board: CAN node {} on {iface} (board watchdog at its own setting); protocol {}{}",
        link.node,
        protocol_name(board.protocol()),
        if board.protocol() == Some(BoardProtocol::V2) {
            " (FALLBACK_MODE cannot be written over CAN: the board keeps its own)"
        } else {
            ""
        }
    );
    Ok(OpenLink {
        board,
        status,
        device: iface,
        banner,
        reopen: Box::new(open),
        counters: |_| None,
    })
}

/// LinuxCNC's HAL (`--hal [COMPONENT]`): registers the userspace component `component`
/// with its pins (`acc_linuxcnc::HalPins`, made ready: `loadusr -Wn` returns), then reads
/// the first status from them. HAL does not vanish as a serial port does: a reopen is an
/// error. `HalBoard` answers as a v2 board; `board.fallback_mode` has no register here (the
/// realtime `watchdog` in the HAL file holds the feed, docs/linuxcnc.md).
pub fn open_hal<'a>(
    cfg: &'a RunConfig,
    component: &'a str,
) -> anyhow::Result<OpenLink<'a, acc_linuxcnc::HalBoard<acc_linuxcnc::HalPins>>> {
    let hal = |e: acc_hal::HalError| {
        anyhow::anyhow!(
            "{}: --hal {component}: cannot create the HAL component: {e}",
            cfg.path.display()
        )
    };
    let comp = acc_hal::HalComponent::new(component)
        .map_err(hal)
        .exit_as(RunExit::BoardNotAnswering)?;
    let pins = acc_linuxcnc::HalPins::new(comp)
        .map_err(hal)
        .exit_as(RunExit::BoardNotAnswering)?;
    // The heartbeat's toggles spaced on the wall clock (LinuxCNC runs in real time only).
    let mut board = acc_linuxcnc::HalBoard::new(pins)
        .with_clock(std::sync::Arc::new(acc_runtime::SystemClock::new()));
    let status = match board.read_status() {
        Ok(s) => s,
        Err(e) => return Err(anyhow::anyhow!("reading the HAL pins of {component}: {e}")),
    };
    let banner = format!(
        "board: LinuxCNC HAL component `{component}` (pins {component}.*); protocol {}; adaptive feed = override / 150 %",
        protocol_name(board.protocol())
    );
    Ok(OpenLink {
        board,
        status,
        device: component,
        banner,
        reopen: Box::new(move || {
            Err(anyhow::anyhow!(
                "HAL component `{component}`: HAL does not vanish; nothing to reopen"
            ))
        }),
        counters: |_| None,
    })
}
