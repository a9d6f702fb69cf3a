//! What one LinuxCNC row measured ([`LcncRow`]) and the windows its figures are taken
//! over.

use super::program_event::EventFigures;

/// The window before the fault for the reference force, s.
pub(super) const BEFORE_S: f64 = 1.0;
/// The window after the fault for the largest force, s (a 2 s pause and 3 s of cut after).
pub(super) const AFTER_S: f64 = 5.0;
/// Silence of acc's heartbeat that counts as a dead or frozen acc, s (its period is 0.1 s).
pub(super) const SILENT_S: f64 = 0.15;
/// After the fault, the run log's rows from this on are judged for a raise, s.
pub(super) const RAISE_GRACE_S: f64 = 0.25;
/// The longest stop after a dead or frozen acc, s (docs/linuxcnc.md: 0.216 s measured).
pub(super) const MAX_STOP_S: f64 = 0.3;
/// The force that marks the tool in the stock: this share of Fr.
pub(super) const CONTACT_SHARE: f64 = 0.02;

/// The measured outcome of one LinuxCNC row.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LcncRow {
    /// Row name (`--fault`'s KIND).
    pub fault: String,
    /// What the fault is.
    pub what: String,
    /// The true force that triggered it, N.
    pub at_force_n: f64,
    /// The fault came this long after that force, s.
    pub delay_s: f64,
    /// The fault's moment on the machine log's clock, s.
    pub t_fault_s: Option<f64>,
    /// What acc last allowed before the fault: feed override × adaptive feed, percent.
    pub allowed_pct: Option<f64>,
    /// acc's last command before the fault (run log), percent.
    pub last_cmd_pct: Option<u16>,
    /// Largest applied override after the fault, in the stock, feed moving, acc not
    /// driving or silent, percent (`None`: no such period).
    pub max_applied_not_driving_pct: Option<f64>,
    /// Largest applied override after the fault in the stock, feed moving, whoever drove.
    pub max_applied_in_cut_pct: Option<f64>,
    /// acc's largest command from [`RAISE_GRACE_S`] after the fault, and its last command
    /// up to then (rows where acc must not raise).
    pub max_cmd_after_pct: Option<u16>,
    /// acc's last command up to [`RAISE_GRACE_S`] after the fault.
    pub cmd_at_grace_pct: Option<u16>,
    /// Largest true force in the [`BEFORE_S`] before the fault, N.
    pub force_before_n: f64,
    /// Largest true force in the [`AFTER_S`] after it, N (`None`: the machine log ends with
    /// the fault).
    pub force_after_n: Option<f64>,
    /// From the fault to the feed at 0, s.
    pub stop_s: Option<f64>,
    /// From the fault to the feed at most the knob's share of the programmed feed (+ 10 %),
    /// s (the operator's row).
    pub knob_s: Option<f64>,
    /// The run log's states after the fault, in order, repeats dropped.
    pub states_after: Vec<String>,
    /// Run-log rows.
    pub log_rows: usize,
    /// Run-log periods consecutive.
    pub log_complete: bool,
    /// How the program ended (`ui.log`).
    pub program: String,
    /// `acc linuxcnc`'s exit.
    pub exit: String,
    /// The outcome in words.
    pub outcome: String,
    /// Every criterion met.
    pub ok: bool,
    /// `pass`, or `FAIL: why`.
    pub verdict: String,
    /// The figures of a program's own event (m52-off, abort-restart, tool-change).
    pub event: Option<EventFigures>,
}
