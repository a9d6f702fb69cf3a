//! The rows an analysis compares: rows without a valid measurement
//! ([`crate::dead::DeadReason`]) counted per reason and cut out of the segments.

#[allow(unused_imports)]
use super::*;

use crate::dead::DeadReason;

/// `v` on `rows`, in that order.
pub(super) fn pick(v: &[f64], rows: &[usize]) -> Vec<f64> {
    rows.iter().map(|&i| v[i]).collect()
}

/// `segs` with the rows `dead` marks cut out: each segment split into its runs of valid
/// rows (a run keeps the segment's regime and its place in it).
pub(super) fn without_dead(segs: &[Segment], dead: &[Option<DeadReason>]) -> Vec<Segment> {
    let mut out = Vec::with_capacity(segs.len());
    for s in segs {
        let mut a = s.start;
        while a < s.end {
            while a < s.end && dead[a].is_some() {
                a += 1;
            }
            let mut b = a;
            while b < s.end && dead[b].is_none() {
                b += 1;
            }
            if b > a {
                out.push(Segment {
                    start: a,
                    end: b,
                    ..*s
                });
            }
            a = b;
        }
    }
    out
}

/// Rows without a valid measurement on the compared channel, per reason: (reason, rows,
/// first and last 1-based line of the log file, the header being line 1).
#[derive(Debug, Clone, Default)]
pub(super) struct Excluded(pub Vec<(DeadReason, usize, usize, usize)>);

impl Excluded {
    /// Count `dead` per reason.
    pub(super) fn of(dead: &[Option<DeadReason>]) -> Excluded {
        let mut v = Vec::new();
        for r in DeadReason::ALL {
            let rows: Vec<usize> = (0..dead.len()).filter(|&i| dead[i] == Some(r)).collect();
            if let (Some(&a), Some(&b)) = (rows.first(), rows.last()) {
                v.push((r, rows.len(), a + 2, b + 2));
            }
        }
        Excluded(v)
    }

    /// Rows excluded in all.
    pub(super) fn total(&self) -> usize {
        self.0.iter().map(|e| e.1).sum()
    }

    /// "120 link lost or board gone (… lines 700..=819), 3 …", or "none".
    pub(super) fn text(&self) -> String {
        if self.0.is_empty() {
            return "none".into();
        }
        self.0
            .iter()
            .map(|(r, k, a, b)| format!("{k} {} (lines {a}..={b})", r.text()))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The report's entries.
    pub(super) fn report(&self) -> Vec<crate::report::ExcludedRows> {
        self.0
            .iter()
            .map(|(r, k, a, b)| crate::report::ExcludedRows {
                reason: r.name().into(),
                rows: *k,
                first_line: *a,
                last_line: *b,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::Regime;

    #[test]
    fn dead_rows_are_cut_out_of_segments_and_counted() {
        let seg = |start, end| Segment {
            start,
            end,
            regime: Regime::SteadyCut,
        };
        let mut dead = vec![None; 20];
        for d in dead.iter_mut().take(8).skip(5) {
            *d = Some(DeadReason::LinkLost);
        }
        dead[19] = Some(DeadReason::NoSample);
        let out = without_dead(&[seg(0, 10), seg(10, 20)], &dead);
        let spans: Vec<(usize, usize)> = out.iter().map(|s| (s.start, s.end)).collect();
        assert_eq!(spans, vec![(0, 5), (8, 10), (10, 19)]);
        let e = Excluded::of(&dead);
        assert_eq!(e.total(), 4);
        assert_eq!(e.0[0], (DeadReason::LinkLost, 3, 7, 9));
        assert!(e.text().contains("1 no sample"), "{}", e.text());
    }
}
