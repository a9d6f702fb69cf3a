//! `SAMPLE_SEQ` staleness detection, shared by the RTU and CAN links.

/// Counts status reads in a row whose `SAMPLE_SEQ` did not change.
///
/// ```
/// use acc_pmc::stale::SeqWatch;
/// let mut w = SeqWatch::new(2);
/// assert_eq!(w.observe(7), None); // first read
/// assert_eq!(w.observe(7), None); // 1 unchanged
/// assert_eq!(w.observe(7), Some(2)); // 2 unchanged: stale
/// assert_eq!(w.observe(8), None); // a new sample
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeqWatch {
    limit: u16,
    last: Option<u16>,
    unchanged: u32,
}

impl SeqWatch {
    /// Stale after `limit` unchanged reads in a row; 0 disables the check.
    pub fn new(limit: u16) -> Self {
        Self {
            limit,
            last: None,
            unchanged: 0,
        }
    }

    /// Record one read of `SAMPLE_SEQ`; `Some(unchanged_reads)` when the power is stale.
    pub fn observe(&mut self, seq: u16) -> Option<u32> {
        if self.last == Some(seq) {
            self.unchanged = self.unchanged.saturating_add(1);
        } else {
            self.unchanged = 0;
        }
        self.last = Some(seq);
        (self.limit > 0 && self.unchanged >= u32::from(self.limit)).then_some(self.unchanged)
    }

    /// Forget the history (after a board restart or a pause).
    pub fn reset(&mut self) {
        self.last = None;
        self.unchanged = 0;
    }
}
