//! The board's end of the link: a new pseudo-terminal (its path printed) or a given serial
//! port, served by acc-pmc's RTU server through the fault-injecting line of [`super::line`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use acc_pmc::emu::{spawn_server, PtyBoard, ServerStats, SharedBoard};
use anyhow::{bail, Context};

use super::line::{wrap, CommandPace, FaultQueue};
use super::BoardSimArgs;

/// What the line does to the replies: the queued reply faults, the pulled cable, the wire
/// time at a baud rate, the controller's pace.
pub(super) struct LineFaults {
    pub queue: FaultQueue,
    pub unplugged: Arc<AtomicBool>,
    pub paced_baud: Option<u32>,
    pub pace: Option<Arc<CommandPace>>,
}

/// The served link: a pty or a serial port's server thread.
pub(super) struct Served {
    pty: Option<PtyBoard>,
    server: Option<JoinHandle<std::io::Result<ServerStats>>>,
    stop_server: Arc<AtomicBool>,
}

/// Serve `board` on `--port`, or on a new pty; prints the device's path on stdout.
pub(super) fn open(
    args: &BoardSimArgs,
    board: &SharedBoard,
    line: &LineFaults,
    clock: &Arc<dyn acc_pmc::clock::Clock>,
) -> anyhow::Result<Served> {
    let stop_server = Arc::new(AtomicBool::new(false));
    let (queue, unplugged, paced, pace) = (
        Arc::clone(&line.queue),
        Arc::clone(&line.unplugged),
        line.paced_baud,
        line.pace.clone(),
    );
    let served = match &args.port {
        None => {
            let pty = PtyBoard::spawn_with_clock(
                Arc::clone(board),
                args.slave,
                args.baud,
                move |p| wrap(p, queue, unplugged, paced, pace),
                Box::new(Arc::clone(clock)),
            )
            .context("creating the pseudo-terminal")?;
            println!("{}", pty.path());
            Served {
                pty: Some(pty),
                server: None,
                stop_server,
            }
        }
        Some(dev) => {
            let port = open_port(dev, args.baud, &args.parity)?;
            let h = spawn_server(
                wrap(port, queue, unplugged, paced, pace),
                args.slave,
                Arc::clone(board),
                Arc::clone(&stop_server),
                Box::new(Arc::clone(clock)),
            );
            println!("{dev}");
            Served {
                pty: None,
                server: Some(h),
                stop_server,
            }
        }
    };
    Ok(served)
}

/// A real serial port, 8 data bits, one stop bit, `parity` (none, even, odd).
fn open_port(dev: &str, baud: u32, parity: &str) -> anyhow::Result<acc_pmc::serialport::TTYPort> {
    let parity = match parity {
        "none" => acc_pmc::serialport::Parity::None,
        "even" => acc_pmc::serialport::Parity::Even,
        "odd" => acc_pmc::serialport::Parity::Odd,
        p => bail!("--parity {p}: allowed none, even, odd"),
    };
    acc_pmc::serialport::new(dev, baud)
        .parity(parity)
        .data_bits(acc_pmc::serialport::DataBits::Eight)
        .stop_bits(acc_pmc::serialport::StopBits::One)
        .timeout(acc_pmc::serial::POLL_SLICE)
        .open_native()
        .with_context(|| format!("--port {dev}: cannot open"))
}

impl Served {
    /// The device disappears (`vanish`): a pty's master end is closed (the controller's
    /// reads fail with EIO); a real port is no longer served (the controller sees silence).
    pub(super) fn vanish(&mut self, t: f64) -> anyhow::Result<()> {
        if let Some(p) = self.pty.take() {
            let st = p.stop()?;
            eprintln!(
                "board-sim: t = {t:.1} s: device gone (pty closed after {} requests)",
                st.requests
            );
        } else {
            self.stop_server.store(true, Ordering::SeqCst);
        }
        Ok(())
    }

    /// Stop serving and print what was served.
    pub(super) fn close(self) -> anyhow::Result<()> {
        self.stop_server.store(true, Ordering::SeqCst);
        let stats = match (self.pty, self.server) {
            (Some(p), _) => Some(p.stop()?),
            (None, Some(h)) => match h.join() {
                Ok(Ok(s)) => Some(s),
                Ok(Err(e)) => {
                    eprintln!("board-sim: server stopped: {e}");
                    None
                }
                Err(_) => bail!("board-sim: server thread panicked"),
            },
            (None, None) => None,
        };
        if let Some(s) = stats {
            eprintln!(
                "board-sim: served {} requests ({} exceptions, {} replies dropped undelivered, {} read errors)",
                s.requests, s.exceptions, s.replies_dropped, s.io_errors
            );
        }
        Ok(())
    }
}
