//! The plant's truth in the run log: the simulator-only columns of a [`RunRecord`]
//! (`x_true_mm`, `radial_depth_mm`, `axial_depth_mm`, `force_true_n`, `feed_true_mm_min`).

use acc_plant::board::PlantTruth;
use acc_plant::PeriodRecord;
use acc_runtime::RunRecord;

/// Fill the simulator-only columns of `row` with `truth`.
pub fn apply(truth: &PlantTruth, row: &mut RunRecord) {
    row.x_true_mm = Some(truth.x_mm);
    row.radial_depth_mm = Some(truth.radial_depth_mm);
    row.axial_depth_mm = Some(truth.axial_depth_mm);
    row.force_true_n = Some(truth.force_n);
    row.feed_true_mm_min = Some(truth.feed_mm_min);
}

/// Fill the simulator-only columns of a run-log record with the plant's truth for the period
/// `rec` (true position, depths, true mean force over `true_force_n`'s window, the drive's
/// actual feed).
pub fn add_truth(row: &mut RunRecord, rec: &PeriodRecord<'_>, true_force_n: f64) {
    apply(&PlantTruth::of(rec, true_force_n), row);
}

/// `row` as `acc run` logs it: the simulator-only columns emptied (a production log for
/// the twin, written by the simulator).
pub fn without_truth(row: RunRecord) -> RunRecord {
    RunRecord {
        x_true_mm: None,
        radial_depth_mm: None,
        axial_depth_mm: None,
        force_true_n: None,
        feed_true_mm_min: None,
        ..row
    }
}
