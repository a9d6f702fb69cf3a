//! The never-raise invariant on an `acc run` log.

use acc_runtime::record::RunRecord;

/// The never-raise invariant on an `acc run` log: the periods in which ACC drove the
/// override with an unusable force sample (or a link fault) and its command rose above the
/// one before. Must be 0.
pub fn fault_periods_raising(rows: &[RunRecord]) -> usize {
    let mut raised = 0;
    let mut prev: Option<u16> = None;
    for x in rows {
        if x.state != "active" {
            prev = None;
            continue;
        }
        let Some(c) = x.override_cmd_pct else {
            continue;
        };
        let faulty = !x.force_valid || x.flags.contains("link:");
        if faulty && prev.is_some_and(|p| c > p) {
            raised += 1;
        }
        prev = Some(c);
    }
    raised
}
