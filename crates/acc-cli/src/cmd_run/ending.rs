//! The end of `acc run`: the sinks closed, the summary printed, and the exit that says how
//! the run ended ([`crate::exit::RunExit`]).

use acc_runtime::config::{DeviceLostAction, RunConfig};
use acc_runtime::history::{HistoryWriter, WatchSink, WatchSummary};
use acc_runtime::{ControlLoop, Ended, RunSummary};

use super::{
    fault_feed_hold, protocol_name, ExitWith, ProductionSink, RunArgs, EXIT_DEVICE_LOST,
    EXIT_FAULT_FEED_HOLD, EXIT_FEED_HOLD,
};
use crate::exit::{ExitAs, RunExit};

/// The run log and the tap closed (the fleet store's figures printed first); what the
/// watch leaves for [`print_summary`]: the history writer and the watch's summary.
pub(super) fn close_sinks(
    sink: ProductionSink,
    tel: crate::telemetry::Telemetry,
) -> (Option<HistoryWriter>, WatchSummary) {
    let WatchSink {
        inner,
        writer,
        summary,
        ..
    } = sink;
    if let Some(f) = &inner.inner.feed {
        let c = f.store.committed();
        println!(
            "fleet store: {} periods, {} cuts of machine {} in {} files under {}",
            c.periods,
            c.cuts,
            f.machine,
            c.files,
            f.store.root().display()
        );
    }
    drop(inner);
    tel.finish();
    (writer, summary)
}

/// The periods, the ticker's jitter, the line guard and loop delay, the run log's and the
/// history's counts, the watch's findings, the final state and the board's protocol.
pub(super) fn print_summary<L: acc_core::OverrideLaw, F: acc_core::ForceSource>(
    s: &RunSummary,
    control: &ControlLoop<L, F>,
    (writer, summary): (Option<HistoryWriter>, WatchSummary),
    args: &RunArgs,
    cfg: &RunConfig,
    history: &std::path::Path,
) {
    // Summary.
    // Every period has a run-log row: the cycles run plus the ones the ticker skipped.
    println!("periods: {}", s.periods + s.skipped);
    println!("cycles run: {}; skipped periods: {}", s.periods, s.skipped);
    println!(
        "period jitter: {} ; overruns {} ; skipped {}",
        s.ticker.jitter.summary(),
        s.ticker.overruns,
        s.ticker.skipped
    );
    println!("cycle round trip: {}", s.cycle_rtt.summary());
    let g = control.guard_counts();
    let d = control.delay_reading();
    let show = |v: Option<u32>| v.map_or_else(|| "?".to_string(), |v| v.to_string());
    println!(
        "line guard: {} implausible reads, {} held for confirmation ({} were bad frames), {} debounced values, {} replays of the board's past; loop delay: echo {} periods (designed 1), margin of the gains {} extra",
        g.implausible,
        g.held,
        g.discarded,
        g.debounced,
        g.replays,
        show(d.echo_periods),
        show(acc_core::OverrideLaw::delay_margin_periods(control.law()))
    );
    println!(
        "run log: {} rows written to {}, {} dropped (queue full), {} write errors",
        s.logged - s.log_errors.min(s.logged),
        args.log.display(),
        s.log_dropped,
        s.log_errors
    );
    if let Some(mut w) = writer {
        match w.finish() {
            Ok(n) => println!(
                "history: {n} items stored, {} dropped (queue full)",
                w.dropped()
            ),
            Err(e) => eprintln!("history: {e}"),
        }
    }
    crate::watch_cli::print_summary(&summary, history);
    println!(
        "final state: {}; alarms: {}",
        s.final_state.name(),
        s.alarms.names()
    );
    println!(
        "board protocol: {}; reconnects: {}; longest time without the device: {:.1} s",
        protocol_name(s.protocol),
        s.reconnects,
        s.longest_device_loss.as_secs_f64() * cfg.runtime.time_scale
    );
}

/// How the run ended, as the exit: `Ok` when ACC_REQUEST was cleared with the operator in
/// control; otherwise the exit code of a lost device, a feed hold at shutdown, a fault's
/// feed hold or a final write that failed, with the message the operator needs.
pub(super) fn exit_of(
    s: &RunSummary,
    cfg: &RunConfig,
    device: &str,
    device_lost_periods: u32,
) -> anyhow::Result<()> {
    if s.shutdown_feed_hold && !matches!(s.ended, Ended::FeedHold { .. }) {
        println!(
            "shutdown: still cutting on a board without the fallback clamp: feed hold requested before the release; the NC needs cycle start"
        );
    }
    match (s.shutdown_ok, s.ended) {
        (ok, Ended::DeviceLost) => Err(ExitWith {
            code: EXIT_DEVICE_LOST,
            message: format!(
                "the board's device {device} is gone ({}: port or cable): run ended, run log flushed; final CONTROL write {}; the board's watchdog takes the override",
                match cfg.runtime.on_device_lost {
                    DeviceLostAction::Exit =>
                        format!("{device_lost_periods} periods in a row without it"),
                    DeviceLostAction::Reconnect => format!(
                        "not back within reconnect_timeout_s = {} s, reopened every period",
                        cfg.runtime.reconnect_timeout_s
                    ),
                },
                if ok.is_ok() { "sent" } else { "not possible" }
            ),
        }
        .into()),
        (Ok(()), Ended::FeedHold { reason }) => {
            let why = match reason {
                "second_signal" => "a second stop signal came".to_string(),
                "drain_timeout" => format!(
                    "the cut had not ended after the {} s drain",
                    cfg.shutdown.drain_s
                ),
                other => other.to_string(),
            };
            Err(ExitWith {
                code: EXIT_FEED_HOLD,
                message: format!(
                    "shutdown: still cutting ({why}): feed hold requested, then ACC_REQUEST cleared with the feed hold kept; the NC needs cycle start"
                ),
            }
            .into())
        }
        (Ok(()), Ended::Released | Ended::Completed | Ended::Finished) if fault_feed_hold(s) => {
            Err(ExitWith {
            code: EXIT_FAULT_FEED_HOLD,
            message: format!(
                "shutdown: ACC_REQUEST cleared; a fault had requested feed hold (final state {}, alarms: {}): the NC needs cycle start",
                s.final_state.name(),
                s.alarms.names()
            ),
        }
        .into())
        }
        (Ok(()), Ended::Released) => {
            println!(
                "shutdown: out of the cut; ACC_REQUEST cleared, the operator has the override"
            );
            Ok(())
        }
        (Ok(()), Ended::Completed | Ended::Finished) => {
            println!("shutdown: ACC_REQUEST cleared, the operator has the override");
            Ok(())
        }
        (Err(k), _) => Err(anyhow::anyhow!(
            "shutdown: could not write CONTROL ({k:?}); the board's watchdog releases the override"
        ))
        .exit_as(RunExit::FinalWriteFailed),
    }
}
