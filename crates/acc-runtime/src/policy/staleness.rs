//! Staleness judge: *is the power sensor stale?* The only place `SAMPLE_SEQ` staleness is
//! judged: the board's sample sequence unchanged for `stale_seq_periods` accepted reads in a
//! row means the power register holds an old sample.

/// The last `SAMPLE_SEQ` and how long it has not moved.
#[derive(Debug, Clone, Default)]
pub(crate) struct Staleness {
    last_seq: Option<u16>,
    unchanged: u32,
}

impl Staleness {
    /// One accepted read with `SAMPLE_SEQ` = `seq`: how far the sequence moved since the
    /// last accepted read (wrapping; `None` for the first), and whether the sample is stale
    /// (unchanged for `stale_periods` reads).
    pub(crate) fn observe(&mut self, seq: u16, stale_periods: u32) -> (Option<u16>, bool) {
        let advance = self.last_seq.map(|l| seq.wrapping_sub(l));
        if advance == Some(0) {
            self.unchanged = self.unchanged.saturating_add(1);
        } else {
            self.unchanged = 0;
        }
        self.last_seq = Some(seq);
        (advance, self.unchanged >= stale_periods)
    }
}
