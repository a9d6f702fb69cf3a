//! Whether `acc run` saw what the man in the middle did: the altered status reads it must
//! flag, the flags that show it did, and the proxy's reads matched to `acc run`'s rows.

use std::collections::HashMap;

use acc_runtime::record::RunRecord;

use crate::proxy::{ProxyEvent, ProxyRead};

/// `acc run` did not take the period's status read at face value: its row's `flags` carry
/// `link:` (the client rejected the frame), `implausible:<register>`,
/// `unconfirmed:<register>` (a change held a period for confirmation), `force_invalid`, or
/// `echo…` / `delay…` (the loop delay measured from the override's echo).
pub fn suspicious(flags: &str) -> bool {
    flags.split(';').any(|f| {
        f.starts_with("link:")
            || f.starts_with("implausible:")
            || f.starts_with("unconfirmed:")
            || f == "force_invalid"
            || f.starts_with("echo")
            || f.starts_with("delay")
    })
}

/// Whether an alteration of an FC04 reply changed something the controller acts on and
/// can tell from the frame alone, so that `acc run` must flag its period: every frame-level
/// kind (another slave, an exception, a wrong byte count, a truncated frame: the client must
/// reject them) and random contents; a flipped bit of a discrete or enumerated input
/// (`STATUS` bits 0…8, `OVERRIDE_APPLIED`, `OPERATOR_OVERRIDE`, `OVERRIDE_STEP`,
/// `PROTOCOL_VERSION`, `FALLBACK_OVERRIDE`) or one that takes the spindle power above
/// `max_power_w` (every `POWER_HI` bit). Not required: a flip of an analog value within its
/// range (the low power bits, `SPINDLE_RPM`, `SAMPLE_SEQ`, `PROGRAMMED_FEED`: nothing in
/// one frame tells it from a real change), of the NC context the loop only records
/// (registers 10…13), or of a reserved `STATUS` bit; and a delayed reply (well-formed and
/// consistent: only the measured loop delay can tell it).
pub fn must_be_flagged(e: &ProxyEvent, max_power_w: f64) -> bool {
    match e.kind.as_str() {
        "delay" => false,
        "flip" => match e.register {
            Some(0) => e.bit.is_some_and(|b| b <= 8),
            Some(1 | 2 | 3 | 4 | 9 | 14) => true,
            Some(5) => e.after.is_some_and(|a| a as f64 > max_power_w),
            _ => false,
        },
        _ => true,
    }
}

/// The proxy's FC04 reads matched to `acc run`'s rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Alignment {
    /// Row index in the run log of each read index that has one.
    pub row_of_read: HashMap<u64, usize>,
    /// Rows with a logged power that were checked against the power the proxy handed over.
    pub checked: usize,
    /// Of which the power agreed.
    pub agreed: usize,
    /// Reads acc run made before its first logged period (the protocol probe).
    pub offset: u64,
}

impl Alignment {
    /// The match is trustworthy: at least 20 rows checked and 95 % of them agree.
    pub fn reliable(&self) -> bool {
        trustworthy(self.checked, self.agreed)
    }

    /// (checked, agreed) over the rows in `range` only: a long log may lose its match
    /// for a while (a row that logs a held power rather than the one read) and be matched
    /// well where it matters.
    pub fn agreement_in(
        &self,
        rows: &[RunRecord],
        reads: &[ProxyRead],
        range: std::ops::Range<usize>,
    ) -> (usize, usize) {
        let power: HashMap<u64, f64> = reads
            .iter()
            .filter_map(|r| Some((r.i?, r.power?)))
            .collect();
        let (mut checked, mut agreed) = (0, 0);
        for (read, &row) in &self.row_of_read {
            let Some(logged) = rows
                .get(row)
                .filter(|_| range.contains(&row))
                .and_then(|x| x.power_w)
            else {
                continue;
            };
            checked += 1;
            agreed += usize::from(power.get(read).is_some_and(|p| (p - logged).abs() < 0.5));
        }
        (checked, agreed)
    }
}

/// At least 20 rows checked and 95 % of them agree.
pub fn trustworthy(checked: usize, agreed: usize) -> bool {
    checked >= 20 && agreed * 100 >= checked * 95
}

/// Match the proxy's FC04 reads to `acc run`'s rows in order. Every row does one status
/// read, except the rows flagged `skipped` (no cycle ran); acc run reads before its first
/// period (one read on a v2 board, two on a v1 board that answers registers 9…14 with an
/// exception), and a client that falls back to the v1 register block re-reads within the
/// period. So row `j` (of those that read) is read `j + offset`, the offset starting at 0
/// … [`MAX_OFFSET`] and only growing, by one extra read at a time: the offsets are chosen
/// (dynamic programming) to make the fewest rows disagree with the power the proxy handed
/// over for their read, each change of offset costing as much as [`SHIFT_COST`]
/// disagreeing rows (a logged power repeats from period to period, so a single agreeing row
/// proves nothing). A row without a logged power (the read failed) agrees with any read.
pub fn align_reads(rows: &[RunRecord], reads: &[ProxyRead]) -> Alignment {
    let n = reads.iter().filter_map(|r| r.i).max().map_or(0, |m| m + 1) as usize;
    let mut power: Vec<Option<f64>> = vec![None; n];
    for r in reads {
        if let Some(i) = r.i {
            power[i as usize] = r.power;
        }
    }
    let with_read: Vec<usize> = (0..rows.len())
        .filter(|&j| !rows[j].flags.split(';').any(|f| f == "skipped"))
        .collect();
    let agrees = |row: usize, read: usize| -> Option<bool> {
        let logged = rows[row].power_w?;
        Some(matches!(power.get(read).copied().flatten(), Some(b) if (logged - b).abs() < 0.5))
    };
    // cost[k]: fewest disagreements (plus shift costs) up to this row with offset k now.
    const K: usize = MAX_OFFSET + 1;
    let mut cost = [0usize; K];
    let mut from: Vec<[usize; K]> = Vec::with_capacity(with_read.len());
    for (j, &row) in with_read.iter().enumerate() {
        let mut next = [usize::MAX; K];
        let mut back = [0usize; K];
        for k in 0..K {
            // Stay at k, or come from a smaller offset (extra reads in this period).
            let (best, prev) = (0..=k)
                .map(|p| {
                    let shift = if j > 0 && p < k {
                        SHIFT_COST * (k - p)
                    } else {
                        0
                    };
                    (cost[p].saturating_add(shift), p)
                })
                .min()
                .unwrap_or((usize::MAX, k));
            let miss = usize::from(agrees(row, j + k) == Some(false));
            next[k] = best.saturating_add(miss);
            back[k] = prev;
        }
        cost = next;
        from.push(back);
    }
    let mut a = Alignment::default();
    let Some(mut k) = (0..K).min_by_key(|&k| (cost[k], k)) else {
        return a;
    };
    for (j, &row) in with_read.iter().enumerate().rev() {
        let read = j + k;
        a.row_of_read.insert(read as u64, row);
        if let Some(agree) = agrees(row, read) {
            a.checked += 1;
            a.agreed += usize::from(agree);
        }
        if j == 0 {
            a.offset = k as u64;
        }
        k = from[j][k];
    }
    a
}

/// Largest offset between the proxy's read count and `acc run`'s rows [`align_reads`]
/// considers (start-up reads plus re-reads within a period).
pub const MAX_OFFSET: usize = 8;
/// Cost of one extra read in [`align_reads`], in disagreeing rows.
pub const SHIFT_COST: usize = 4;

#[cfg(test)]
mod tests {
    use super::*;

    fn row(power: Option<f64>, flags: &str) -> RunRecord {
        RunRecord {
            power_w: power,
            flags: flags.into(),
            ..RunRecord::default()
        }
    }

    fn read(i: u64, power: Option<f64>) -> ProxyRead {
        ProxyRead {
            i: Some(i),
            power,
            applied: None,
            altered: false,
        }
    }

    #[test]
    fn reads_align_with_the_start_up_read_a_failed_read_and_a_re_read() {
        // Powers repeat (1176 over and over) as in a steady cut.
        let p = [
            700.0, 1176.0, 1176.0, 1103.0, 1153.0, 1176.0, 1176.0, 1176.0, 1103.0, 1153.0, 1176.0,
            1176.0, 1103.0, 1081.0, 1154.0, 1176.0, 1176.0, 1103.0,
        ];
        // Read 0 is the start-up read; read 6 is garbage (the row logs the last good power);
        // read 10 got exception 02 and the client re-read at once (read 11).
        let mut reads: Vec<ProxyRead> = p
            .iter()
            .enumerate()
            .map(|(i, &w)| read(i as u64, Some(w)))
            .collect();
        reads[6].power = Some(2_647_218_006.0);
        reads[10].power = None;
        let mut rows = Vec::new();
        for (i, &w) in p.iter().enumerate().skip(1) {
            if i == 10 {
                continue; // the re-read's row is the next one
            }
            let logged = if i == 6 { Some(1176.0) } else { Some(w) };
            rows.push(row(logged, ""));
        }
        rows.insert(3, row(None, "skipped"));
        let a = align_reads(&rows, &reads);
        assert_eq!(a.offset, 1);
        assert_eq!(a.row_of_read[&1], 0);
        assert_eq!(a.row_of_read[&3], 2);
        assert_eq!(a.row_of_read[&4], 4, "the skipped row did not read");
        assert_eq!(a.row_of_read[&6], 6);
        assert_eq!(a.row_of_read[&11], 10, "the re-read within the period");
        assert_eq!(a.row_of_read[&17], rows.len() - 1);
        assert!(!a.row_of_read.contains_key(&10));
        assert_eq!((a.checked, a.agreed), (16, 15));
        assert!(!a.reliable(), "fewer than 20 rows checked");
    }

    #[test]
    fn suspicious_flags_and_the_alterations_that_must_be_flagged() {
        assert!(suspicious("link:timeout"));
        assert!(suspicious("seq_skip:2;implausible:power"));
        assert!(suspicious("unconfirmed:status;fault"));
        assert!(suspicious("force_invalid"));
        assert!(suspicious("delay:4/3"));
        assert!(!suspicious("seq_skip:2;late;write:timeout;fault"));
        assert!(!suspicious(""));
        let ev =
            |kind: &str, register: Option<u16>, bit: Option<u8>, after: Option<i64>| ProxyEvent {
                t: 0.0,
                read_index: Some(1),
                fc: 4,
                kind: kind.into(),
                register,
                bit,
                before: None,
                after,
            };
        for kind in ["slave", "exception", "bytecount", "truncate", "random"] {
            assert!(must_be_flagged(&ev(kind, None, None, None), 30_000.0));
        }
        assert!(!must_be_flagged(
            &ev("delay", Some(7), None, Some(3)),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(0), Some(0), None),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(0), Some(12), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(2), Some(0), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(4), Some(0), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(5), Some(15), Some(33_000)),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(5), Some(3), Some(1_184)),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(7), Some(3), None),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(12), Some(3), None),
            30_000.0
        ));
    }
}
