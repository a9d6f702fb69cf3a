//! Tests of [`crate::runlog`].
use super::*;

/// A stall of `acc run` (found by `tests/e2e_twin_production.rs` on a loaded machine):
/// a failed read, two periods the ticker skipped, then a read two samples on. The
/// board ran two periods in the gap, on the register the next read finds; counting the
/// skipped periods as samples put the replayed tool two periods off for the rest of the
/// log (70 W at every later cut edge), and carrying the applied override forward ran
/// the gap on the one before the last write.
#[test]
fn a_stall_is_replayed_on_the_samples_the_board_took() {
    let row = |t: f64, flags: &str, applied: Option<u16>| acc_runtime::RunRecord {
        t_s: t,
        flags: flags.into(),
        spindle_rpm: Some(600.0),
        feed_mm_min: Some(120.0),
        radial_depth_mm: Some(4.0),
        axial_depth_mm: Some(5.0),
        power_w: applied.map(|_| 1150.0),
        override_cmd_pct: Some(70),
        override_applied_pct: applied,
        ..acc_runtime::RunRecord::default()
    };
    let rows = [
        row(7.9, "", Some(60)),
        row(8.0, "", Some(60)),
        row(8.1, "link:timeout;fault", None),
        row(8.2, "skipped", None),
        row(8.3, "skipped", None),
        row(8.4, "seq_skip:2;late", Some(70)),
        row(8.5, "", Some(70)),
    ];
    let log = from_records(&rows, Path::new("stall.csv")).expect("log");
    assert_eq!(log.sample_advance, Some(vec![1, 1, 0, 0, 0, 2, 1]));
    assert_eq!(
        log.override_applied_pct,
        Some(vec![60.0, 60.0, 70.0, 70.0, 70.0, 70.0, 70.0])
    );
}

#[test]
fn sample_advance_is_read_from_the_flags() {
    assert_eq!(sample_advance(""), 1);
    assert_eq!(sample_advance("late"), 1);
    assert_eq!(sample_advance("seq_repeat"), 0);
    assert_eq!(sample_advance("late;seq_skip:3;force_invalid"), 3);
    assert_eq!(sample_advance("seq_skip:x"), 1);
    assert_eq!(sample_advance("link:timeout;fault"), 0);
    // A period the ticker skipped read nothing: the next read's `seq_skip` counts it.
    assert_eq!(sample_advance("skipped"), 0);
}

/// A read the line guard held (`unconfirmed:sample_seq`, here the late reply to the failed
/// read before it) is no read: the loop took neither its `SAMPLE_SEQ` nor its override,
/// and the next used read's `seq_skip:4` counts from the last used one. Counted as one
/// sample, it put every later row of a 10x production log a board period ahead (1 054 of
/// 3 389 periods on the wrong override).
#[test]
fn a_read_the_line_guard_held_reads_no_sample() {
    let row = |t_s: f64, flags: &str, applied: Option<u16>| acc_runtime::RunRecord {
        t_s,
        flags: flags.into(),
        spindle_rpm: Some(600.0),
        radial_depth_mm: Some(3.0),
        axial_depth_mm: Some(16.0),
        power_w: applied.map(|_| 1146.0),
        override_applied_pct: applied,
        ..acc_runtime::RunRecord::default()
    };
    let rows = [
        row(15.5, "settle:70", Some(70)),
        row(15.6, "link:timeout;fault", None),
        row(
            15.7,
            "unconfirmed:sample_seq;force_invalid;fault;late",
            Some(70),
        ),
        row(15.8, "seq_skip:4;settle:70;late", Some(60)),
        row(15.9, "seq_repeat;settle:70", Some(60)),
        row(16.0, "unconfirmed:block_number", Some(60)),
    ];
    let log = from_records(&rows, Path::new("held.csv")).expect("log");
    assert_eq!(log.sample_advance, Some(vec![1, 0, 0, 4, 0, 1]));
    assert_eq!(
        log.override_applied_pct,
        Some(vec![70.0, 60.0, 60.0, 60.0, 60.0, 60.0])
    );
    let dead = log.dead_rows(crate::model::Channel::Power);
    assert_eq!(dead[2], Some(crate::dead::DeadReason::Held));
    assert_eq!(dead[5], None, "a debounced register leaves the read in use");
}
