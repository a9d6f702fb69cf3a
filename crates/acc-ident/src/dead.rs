//! Rows without a valid measurement: what a run log's flags and empty cells say about
//! each row's sample ([`RowFlags`]), and why a row cannot be compared on a channel
//! ([`DeadReason`]).
//!
//! A run log has a row for every control period ([`runlog.md`](../../../docs/runlog.md)),
//! also for the periods whose status read failed (the link lost, the board gone), that
//! the ticker skipped, or whose status was implausible. The reader carries the last known
//! value into such a row's empty cells, so the row still holds a number — one the machine
//! did not measure in that period. The discrepancy workflow replays every row (the plant
//! integrates through them) but leaves these rows out of selection, noise and the sealed
//! part, and its report counts them per reason. So it does with the rows of such a log
//! whose axial depth changed inside the period ([`dead_rows`]): the plant cut an NC
//! program's geometry, and one logged depth per period does not say where the tool met
//! the new one.

use crate::model::Channel;

/// What a run-log row's flags and cells say about its sample (a bit set).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RowFlags(pub u8);

impl RowFlags {
    /// The status read failed (`link:<kind>` in `flags`: the link lost, the board gone).
    pub const NO_STATUS: u8 = 1;
    /// The ticker skipped the period (`skipped`): no cycle ran.
    pub const SKIPPED: u8 = 1 << 1;
    /// `power_w` is empty.
    pub const NO_POWER: u8 = 1 << 2;
    /// `force_n` is empty (no usable force sample).
    pub const NO_FORCE: u8 = 1 << 3;
    /// A status value was out of range (`implausible:<register>`): the sample was not used.
    pub const IMPLAUSIBLE: u8 = 1 << 4;
    /// Feed hold requested (`feed_hold`) with the tool out of the material: nothing moves
    /// and nothing is cut, so the row says nothing about the process or the feed path.
    pub const FEED_HOLD_IN_AIR: u8 = 1 << 5;
    /// The line guard held the read for confirmation ([`guard_held`]): the loop used none
    /// of it, and its cells are a raw read the sequence does not place.
    pub const HELD: u8 = 1 << 6;

    /// Whether bit `b` is set.
    pub fn has(self, b: u8) -> bool {
        self.0 & b != 0
    }

    /// Why the row's sample cannot be compared on `channel`, the first reason in the order
    /// of [`DeadReason::ALL`]; `None` for a valid row.
    pub fn dead_on(self, channel: Channel) -> Option<DeadReason> {
        let missing = match channel {
            Channel::Power => Self::NO_POWER,
            Channel::Force => Self::NO_FORCE,
        };
        [
            (Self::NO_STATUS, DeadReason::LinkLost),
            (Self::SKIPPED, DeadReason::Skipped),
            (Self::IMPLAUSIBLE, DeadReason::Implausible),
            (Self::HELD, DeadReason::Held),
            (missing, DeadReason::NoSample),
            (Self::FEED_HOLD_IN_AIR, DeadReason::FeedHoldInAir),
        ]
        .into_iter()
        .find(|(b, _)| self.has(*b))
        .map(|(_, r)| r)
    }

    /// The flags of one run-log record; `cutting` says whether the tool was in the
    /// material in that period (the engagement the log carries or the workpiece gives).
    pub fn of_record(r: &acc_runtime::RunRecord, cutting: bool) -> RowFlags {
        let mut b = 0;
        for f in r.flags.split(';') {
            if f.starts_with("link:") {
                b |= Self::NO_STATUS;
            } else if f == "skipped" {
                b |= Self::SKIPPED;
            } else if f.starts_with("implausible:") {
                b |= Self::IMPLAUSIBLE;
            } else if guard_held(f) {
                b |= Self::HELD;
            }
        }
        if r.power_w.is_none() {
            b |= Self::NO_POWER;
        }
        if r.force_n.is_none() {
            b |= Self::NO_FORCE;
        }
        if r.feed_hold && !cutting {
            b |= Self::FEED_HOLD_IN_AIR;
        }
        RowFlags(b)
    }
}

/// The registers whose unconfirmed change makes the line guard hold the whole read
/// (`acc_runtime::guard`): a `STATUS` bit, `OVERRIDE_APPLIED`, the power, the spindle
/// speed, `SAMPLE_SEQ`. Other unconfirmed registers (the knob, the programmed feed, the
/// NC numbers) are debounced: the read is used with their old value.
pub const HELD_REGISTERS: [&str; 5] = [
    "status",
    "override_applied",
    "power",
    "spindle_rpm",
    "sample_seq",
];

/// Whether one run-log flag marks a read the line guard held: `unconfirmed:<register>` of
/// a [`HELD_REGISTERS`] register. The loop used nothing of such a read: its `SAMPLE_SEQ`
/// was not taken (the next used read's `seq_skip:<n>` counts from the last used one), and
/// its power and applied override are a raw reply the sequence does not place — on a
/// tight link timing a reply that arrived after its timeout and answered the next request.
pub fn guard_held(flag: &str) -> bool {
    flag.strip_prefix("unconfirmed:")
        .is_some_and(|reg| HELD_REGISTERS.contains(&reg))
}

/// A change of the logged axial depth from one row to the next that the replay's one
/// depth per period absorbs, relative to the larger of the two depths, −: the row's force
/// is off by at most this share (eq. 1: the force is proportional to the axial depth).
pub const AXIAL_CHANGE_TOLERANCE: f64 = 0.02;

/// Per row of a log written by `acc`, why it cannot be compared on `channel`: no valid
/// measurement ([`RowFlags::dead_on`]), or, where the tool cut in the row or the row before
/// (`radial_depth_mm` above 0), an axial depth `axial_depth_mm` that changed from the row
/// before by more than [`AXIAL_CHANGE_TOLERANCE`] ([`DeadReason::AxialDepthChange`]: the
/// plant cut the geometry, and the depth changed somewhere inside the period, which one
/// depth per period does not place). `None` for a row to compare.
pub fn dead_rows(
    flags: &[RowFlags],
    radial_depth_mm: &[f64],
    axial_depth_mm: &[f64],
    channel: Channel,
) -> Vec<Option<DeadReason>> {
    let mut dead: Vec<Option<DeadReason>> = flags.iter().map(|f| f.dead_on(channel)).collect();
    for i in 1..dead
        .len()
        .min(axial_depth_mm.len())
        .min(radial_depth_mm.len())
    {
        let (a0, a1) = (axial_depth_mm[i - 1], axial_depth_mm[i]);
        let cutting = radial_depth_mm[i - 1] > 0.0 || radial_depth_mm[i] > 0.0;
        let changed = (a1 - a0).abs() > AXIAL_CHANGE_TOLERANCE * a0.abs().max(a1.abs());
        if cutting && changed && dead[i].is_none() {
            dead[i] = Some(DeadReason::AxialDepthChange);
        }
    }
    dead
}

/// Why a row cannot be compared on the compared channel: no valid measurement, or an
/// engagement the replay cannot place.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DeadReason {
    /// The status read failed: the link lost or the board gone (`link:<kind>`).
    LinkLost,
    /// The ticker skipped the period (`skipped`).
    Skipped,
    /// A status value was implausible and not used (`implausible:<register>`).
    Implausible,
    /// The line guard held the read for confirmation (`unconfirmed:<register>` of a
    /// [`HELD_REGISTERS`] register): the loop did not use it.
    Held,
    /// The channel's cell is empty (no usable sample).
    NoSample,
    /// Feed hold with the tool in the air.
    FeedHoldInAir,
    /// The logged axial depth is more than [`AXIAL_CHANGE_TOLERANCE`] off the row before's
    /// while the tool cuts: it changed inside the period (an NC program's entry, exit or
    /// step to another depth level), and a log of one depth per period does not say where.
    /// The replay holds one depth over the period, which can be thousands of newtons off
    /// the force of a cutter that meets the new depth at one point of it ([`dead_rows`]).
    AxialDepthChange,
}

impl DeadReason {
    /// Every reason: those of [`RowFlags::dead_on`] in the order it tries them, then the
    /// one [`dead_rows`] adds.
    pub const ALL: [DeadReason; 7] = [
        DeadReason::LinkLost,
        DeadReason::Skipped,
        DeadReason::Implausible,
        DeadReason::Held,
        DeadReason::NoSample,
        DeadReason::FeedHoldInAir,
        DeadReason::AxialDepthChange,
    ];

    /// The reason in words, with the run-log evidence.
    pub fn text(self) -> &'static str {
        match self {
            DeadReason::LinkLost => {
                "link lost or board gone (`link:<kind>` in `flags`: the status read failed)"
            }
            DeadReason::Skipped => "period skipped by the ticker (`skipped`)",
            DeadReason::Implausible => {
                "implausible status value, sample not used (`implausible:<register>`)"
            }
            DeadReason::Held => {
                "read held by the line guard, not used (`unconfirmed:<register>` of a status bit, the power, the speed, `SAMPLE_SEQ` or the applied override)"
            }
            DeadReason::NoSample => "no sample on the compared channel (empty cell)",
            DeadReason::FeedHoldInAir => "feed hold with the tool in the air (`feed_hold`)",
            DeadReason::AxialDepthChange => {
                "axial depth changed inside the period (`axial_depth_mm` more than 2 % off the row before's while cutting: an entry, an exit or a new depth level, placed nowhere by one depth per period)"
            }
        }
    }

    /// Short name for reports (`link_lost`, `skipped`, `implausible`, `held`, `no_sample`,
    /// `feed_hold_in_air`, `axial_depth_change`).
    pub fn name(self) -> &'static str {
        match self {
            DeadReason::LinkLost => "link_lost",
            DeadReason::Skipped => "skipped",
            DeadReason::Implausible => "implausible",
            DeadReason::Held => "held",
            DeadReason::NoSample => "no_sample",
            DeadReason::FeedHoldInAir => "feed_hold_in_air",
            DeadReason::AxialDepthChange => "axial_depth_change",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(
        flags: &str,
        power: Option<f64>,
        force: Option<f64>,
        hold: bool,
    ) -> acc_runtime::RunRecord {
        acc_runtime::RunRecord {
            flags: flags.into(),
            power_w: power,
            force_n: force,
            feed_hold: hold,
            ..acc_runtime::RunRecord::default()
        }
    }

    #[test]
    fn a_row_is_dead_for_the_reason_its_log_gives() {
        let ok = RowFlags::of_record(&rec("late;seq_repeat", Some(700.0), Some(5.0), false), true);
        assert_eq!(ok.dead_on(Channel::Power), None);
        assert_eq!(ok.dead_on(Channel::Force), None);
        let gone = RowFlags::of_record(&rec("link:disconnected", None, None, false), true);
        assert_eq!(gone.dead_on(Channel::Power), Some(DeadReason::LinkLost));
        let no_force = RowFlags::of_record(&rec("force_invalid", Some(700.0), None, false), true);
        assert_eq!(no_force.dead_on(Channel::Power), None);
        assert_eq!(no_force.dead_on(Channel::Force), Some(DeadReason::NoSample));
        let bad = RowFlags::of_record(&rec("implausible:power", Some(9e9), None, false), true);
        assert_eq!(bad.dead_on(Channel::Power), Some(DeadReason::Implausible));
        let held = "unconfirmed:sample_seq;force_invalid;fault";
        let held = RowFlags::of_record(&rec(held, Some(1146.0), None, false), true);
        assert_eq!(held.dead_on(Channel::Power), Some(DeadReason::Held));
        // A debounced register (the knob, the block) leaves the read in use.
        let debounced = "unconfirmed:block_number";
        let debounced = RowFlags::of_record(&rec(debounced, Some(900.0), Some(300.0), false), true);
        assert_eq!(debounced.dead_on(Channel::Power), None);
        let skipped = RowFlags::of_record(&rec("skipped", None, None, false), false);
        assert_eq!(skipped.dead_on(Channel::Force), Some(DeadReason::Skipped));
        let hold_air = RowFlags::of_record(&rec("", Some(700.0), Some(0.0), true), false);
        assert_eq!(
            hold_air.dead_on(Channel::Power),
            Some(DeadReason::FeedHoldInAir)
        );
        let hold_cut = RowFlags::of_record(&rec("", Some(900.0), Some(300.0), true), true);
        assert_eq!(hold_cut.dead_on(Channel::Power), None);
    }

    #[test]
    fn a_logged_axial_depth_change_is_not_compared_in_a_log_written_by_acc() {
        // Air (a plunge's depth changes without a cut), an entry, a change within the
        // tolerance, a step to another level, an exit.
        let axial = vec![0.0, 3.0, 5.0, 5.0, 5.05, 10.0, 10.0, 0.0];
        let radial = vec![0.0, 0.0, 4.0, 4.0, 4.0, 4.0, 4.0, 0.0];
        let n = axial.len();
        let mut log = crate::RunLog {
            t_s: (1..=n).map(|i| 0.1 * i as f64).collect(),
            radial_depth_mm: radial,
            axial_depth_mm: axial,
            ..crate::RunLog::default()
        };
        // Built in code (no flags): each row's depth is its own over its period.
        assert!(log.dead_rows(Channel::Force).iter().all(Option::is_none));
        // Written by `acc`: the rows where the tool cut and the depth changed by more than
        // the tolerance are left out (the entry, the step, the exit; not the plunge in air
        // nor the 1 % change); a row without a sample keeps its own reason.
        let mut flags = vec![RowFlags::default(); n];
        flags[3] = RowFlags(RowFlags::NO_FORCE);
        log.row_flags = Some(flags);
        let change = Some(DeadReason::AxialDepthChange);
        assert_eq!(
            log.dead_rows(Channel::Force),
            vec![
                None,
                None,
                change,
                Some(DeadReason::NoSample),
                None,
                change,
                None,
                change
            ]
        );
    }
}
