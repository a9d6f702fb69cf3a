//! Columns of `acc`'s run-log records with their empty cells filled: [`carry`] forward,
//! [`carry_back`] from the next read (the override a stall ran on).

/// Column `f` of the records; an empty cell carries the previous row's value (the first
/// known value before it, 0 when the column is empty throughout).
pub(super) fn carry(
    rows: &[acc_runtime::RunRecord],
    f: impl Fn(&acc_runtime::RunRecord) -> Option<f64>,
) -> Vec<f64> {
    let mut last = rows.iter().find_map(&f).unwrap_or(0.0);
    rows.iter()
        .map(|r| {
            if let Some(v) = f(r) {
                last = v;
            }
            last
        })
        .collect()
}

/// Column `f` of the records; an empty cell takes the next row's value (the last known
/// value after the last one). For the override the board applied: a row without a read
/// (a failed read, a skipped period) does not know it, and through such a stretch the
/// board ran on its register, which the next read finds; the value before the stretch is
/// the one the register held before the last write.
pub(super) fn carry_back(
    rows: &[acc_runtime::RunRecord],
    f: impl Fn(&acc_runtime::RunRecord) -> Option<f64>,
) -> Vec<f64> {
    let mut v = carry(rows, &f);
    let mut next: Option<f64> = None;
    for (i, r) in rows.iter().enumerate().rev() {
        match f(r) {
            Some(x) => next = Some(x),
            None => {
                if let Some(x) = next {
                    v[i] = x;
                }
            }
        }
    }
    v
}
