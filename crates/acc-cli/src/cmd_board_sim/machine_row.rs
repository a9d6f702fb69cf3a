//! The machine log's row of one period: what the PMC inputs carried while the machine moved
//! (the board's side; the controller's side is logged by `acc run`), the plant's truth, and
//! the board's state as flags.

use acc_pmc::BoardStatus;
use acc_runtime::record::RunRecord;
use acc_runtime::Tick;
use acc_sim::board::SimBoard;
use acc_sim::truth::add_truth;

/// What the board showed at the period's start.
pub(super) struct BoardSide {
    pub status: BoardStatus,
    /// `OVERRIDE_CMD` as last written, %.
    pub command_pct: u16,
    pub unplugged: bool,
}

/// Advance the machine one period (`period_s`, s) and return its row: period index
/// `period`, the tick's lateness, the board's side and the plant's truth.
pub(super) fn advance_and_record(
    sim: &mut SimBoard,
    period_s: f64,
    period: u64,
    tick: &Tick,
    board: &BoardSide,
    force_ref_n: f64,
) -> RunRecord {
    let status = &board.status;
    let programmed = sim.machine().programmed_feed_mm_min();
    let rec = sim.advance_period(period_s);
    let mut row = RunRecord {
        t_s: rec.t_end_s,
        period,
        late_ms: tick.lateness.as_secs_f64() * 1e3,
        spindle_rpm: Some(rec.spindle_rpm),
        programmed_feed_mm_min: Some(programmed),
        feed_mm_min: Some(if status.feed_hold_active {
            0.0
        } else {
            programmed * f64::from(status.override_applied_pct) / 100.0
        }),
        power_w: Some(rec.power_mean_w),
        force_ref_n: Some(force_ref_n),
        override_cmd_pct: Some(board.command_pct),
        override_applied_pct: Some(status.override_applied_pct),
        override_operator_pct: Some(status.operator_override_pct),
        state: if status.acc_active {
            "acc_active"
        } else {
            "operator"
        }
        .into(),
        feed_hold: status.feed_hold_active,
        tool: status.is_v2().then_some(status.tool_number),
        program: status.is_v2().then_some(status.program_number),
        block: status.is_v2().then_some(status.block_number),
        x_mm: Some(rec.x_mm),
        ..RunRecord::default()
    };
    add_truth(&mut row, &rec, rec.force_mean_n);
    flag_board_state(&mut row, tick, board);
    row
}

/// The flags of docs/runlog.md for the machine log: the tick's lateness, the watchdog, the
/// clamp, a restart, the pulled cable.
fn flag_board_state(row: &mut RunRecord, tick: &Tick, board: &BoardSide) {
    let status = &board.status;
    if tick.overrun {
        row.flag("late");
    }
    if tick.skipped > 0 {
        row.flag(&format!("ticks_skipped:{}", tick.skipped));
    }
    if status.watchdog_tripped {
        row.flag("watchdog");
    }
    if status.fallback_active {
        row.flag(&format!("fallback:{}", status.fallback_override_pct));
    }
    if status.board_restarted {
        row.flag("restarted");
    }
    if board.unplugged {
        row.flag("unplugged");
    }
}
