//! The end of a run: the final `CONTROL` write. Out of the cut, `ACC_REQUEST` and
//! `FEED_HOLD_REQUEST` are cleared (the operator has the override); still cutting, feed hold
//! is requested first and the release keeps it. On a board without the fallback clamp (v1,
//! or not known) a run that ends while ACC drives the override in the cut holds the feed
//! too: a release there would hand the feed to the operator's knob.

use std::sync::atomic::Ordering;

use acc_core::{ForceSource, OverrideLaw};
use acc_pmc::{Board, BoardErrorKind, BoardProtocol};

use crate::control_loop::ControlLoop;

use super::{Ended, Flags, RunOptions};

/// What the shutdown did.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShutdownOutcome {
    /// The final `CONTROL` write reached the board.
    pub ok: Result<(), BoardErrorKind>,
    /// Feed hold was requested before the release.
    pub feed_hold: bool,
    /// The board's protocol as the link (else the policy) knows it.
    pub protocol: Option<BoardProtocol>,
}

/// Release the board after a run that ended `ended`: feed hold first when the run ended in
/// the cut for a reason that asks it, or on a board without the fallback clamp; then the
/// release, in `opts.shutdown_attempts` attempts; traced either way.
pub(super) fn release_board<P: Board, L: OverrideLaw, F: ForceSource>(
    pmc: &mut P,
    control: &mut ControlLoop<L, F>,
    ended: Ended,
    flags: &Flags,
    opts: &RunOptions,
) -> ShutdownOutcome {
    let protocol = pmc.protocol().or(control.policy().protocol());
    let in_cut = !flags.out_of_cut.load(Ordering::SeqCst);
    let feed_hold = match ended {
        Ended::FeedHold { .. } => true,
        Ended::Completed | Ended::Finished | Ended::DeviceLost => {
            in_cut && protocol != Some(BoardProtocol::V2)
        }
        Ended::Released => false,
    };
    let ok = if feed_hold {
        control.hold_and_release(pmc, opts.shutdown_attempts)
    } else {
        control.shutdown(pmc, opts.shutdown_attempts)
    };
    trace(ok, ended, feed_hold);
    ShutdownOutcome {
        ok,
        feed_hold,
        protocol,
    }
}

/// Say what the shutdown write did.
fn trace(ok: Result<(), BoardErrorKind>, ended: Ended, feed_hold: bool) {
    match (ok, ended) {
        (Ok(()), Ended::FeedHold { reason }) => tracing::warn!(
            reason,
            "still cutting: feed hold requested, then ACC_REQUEST cleared with the hold kept"
        ),
        (Ok(()), _) if feed_hold => tracing::warn!(
            "still cutting on a board without the fallback clamp: feed hold requested, then ACC_REQUEST cleared with the hold kept"
        ),
        (Ok(()), _) => tracing::info!("ACC_REQUEST cleared; the operator has the override"),
        (Err(k), _) => {
            tracing::error!(kind = ?k, "could not write CONTROL; the board watchdog will release")
        }
    }
}
