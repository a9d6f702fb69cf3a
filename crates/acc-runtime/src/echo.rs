//! The loop delay measured on the line, every period: from each override command to its
//! echo in `OVERRIDE_APPLIED` and in `ACTUAL_FEED`, and from the sample's `SAMPLE_SEQ` to the
//! loop's own period count.
//!
//! The board applies `OVERRIDE_CMD` as it is written, so a command written in period k is
//! read back in `OVERRIDE_APPLIED` at period k + 1: an echo delay of 1 period, the delay the
//! control design assumes (physics.md §1, eq. 6). A line that delivers the board's replies
//! late — a buffering gateway answers every read with the reply of N reads earlier, with a
//! valid CRC and a `SAMPLE_SEQ` that still advances by one per period — shows as an echo
//! delay of N + 1. The estimate is the shortest delay `d` (1 ..= [`MAX_ECHO_PERIODS`])
//! whose prediction "applied at k = command in force after k − d" has the fewest mismatches
//! over the last `WINDOW` informative periods (periods in which the candidates disagree).
//! Only a board on its regular cadence is judged ([`Cadence`]): after a link error, or a
//! run of repeated or skipped samples (a stall, a board working through queued requests),
//! the echo is judged again once the cadence has held for the whole history examined. A
//! lone repeat or skip — the board's sample tick and the loop's read a hair apart, so that
//! jitter of either moves the sample across the read — keeps the cadence but is not
//! judged itself (a CAN board's status frame is the sample's: its echo is one sample old).
//! `ACTUAL_FEED` (v2 boards) is matched the same way against programmed ×
//! command, within the feed drive's lag (`FEED_TOLERANCE`).
//!
//! `SAMPLE_SEQ` against the period count: the sequence unwrapped, less the period index, is
//! the board's sample offset; its drop below the highest offset seen is the sample's lag in
//! periods (a buffering line drops it by N at once; a board restart starts it again).
//!
//! The tracker does not keep the commands: the loop books the command in force after each
//! period once the policy has decided it (a skipped period keeps the last one, a period out
//! of ACC books none, a failed write marks it unknown) and hands that history, with what
//! happened since ([`Booked`]: a release, a broken line), to [`LoopDelay::period`] once per
//! period, before the force source runs.

use acc_pmc::BoardStatus;

/// Largest echo delay examined, periods.
pub const MAX_ECHO_PERIODS: usize = 8;
/// Informative periods the mismatch counts look back over.
const WINDOW: usize = 8;
/// An `ACTUAL_FEED` within this fraction (or 3 mm/min) of programmed × command matches.
const FEED_TOLERANCE: f64 = 0.05;
/// An offset of `SAMPLE_SEQ` against the period count must hold this many periods to be
/// the baseline (a sample that happens to be one tick fresher is jitter, not the line).
const STEADY_PERIODS: u32 = 3;
/// Informative periods needed before an estimate is reported.
const MIN_INFORMATIVE: u32 = 2;

/// How a read's `SAMPLE_SEQ` advanced against the loop's period count since the read
/// before it (the drift: the sequence's advance less the periods' advance).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Cadence {
    /// One new sample per period (drift 0).
    Regular,
    /// A lone repeated or skipped sample (drift ±1 after a regular read, or the skip that
    /// makes good the repeat before it): the sample tick and the read close together.
    Jitter,
    /// Anything else: the first read, a run of repeats or skips, a jump, a sequence that
    /// went back.
    Broken,
}

impl Cadence {
    /// This read's cadence from its drift and the previous read's drift (`None`: no
    /// previous read on the unbroken line).
    fn of(drift: Option<i64>, previous: Option<i64>) -> Self {
        match (drift, previous) {
            (Some(0), _) => Cadence::Regular,
            (Some(d @ (-1 | 1)), Some(p)) if p == 0 || p == -d => Cadence::Jitter,
            _ => Cadence::Broken,
        }
    }
}

/// One period's measurement.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DelayReading {
    /// Echo delay of the override in `OVERRIDE_APPLIED`, periods (1 = as designed).
    pub echo_periods: Option<u32>,
    /// Echo delay of the override in `ACTUAL_FEED`, periods (v2 boards).
    pub feed_echo_periods: Option<u32>,
    /// How far this sample's `SAMPLE_SEQ` lags the freshest offset seen, periods.
    pub seq_lag_periods: Option<u32>,
    /// Consecutive informative periods (up to now) in which the estimate was later than
    /// the designed 1 period.
    pub late_streak: u32,
    /// The line guard confirmed this period that `SAMPLE_SEQ` went back with no restart:
    /// the line replays the board's past this many periods late ([`crate::guard`]).
    pub replay_lag_periods: Option<u32>,
}

impl DelayReading {
    /// The loop runs as designed this period: the command's echo one period late (or not
    /// yet measured), no late periods, no lagging or replayed samples.
    pub fn as_designed(&self) -> bool {
        self.echo_periods.is_none_or(|e| e <= 1)
            && self.late_streak == 0
            && self.seq_lag_periods.is_none_or(|l| l == 0)
            && self.replay_lag_periods.is_none()
    }
}

/// Mismatches per candidate delay over the last [`WINDOW`] informative periods.
#[derive(Debug, Clone, Copy, Default)]
struct Scores {
    /// Bit `d` set: delay `d` mismatched in that informative period (a ring).
    misses: [u16; WINDOW],
    next: usize,
    informative: u32,
    estimate: Option<u32>,
    late_streak: u32,
}

impl Scores {
    fn observe(&mut self, preds: &[u16; MAX_ECHO_PERIODS], matches: impl Fn(u16) -> bool) {
        if preds.iter().all(|p| *p == preds[0]) {
            return;
        }
        let mut mask = 0u16;
        for (d, p) in preds.iter().enumerate() {
            if !matches(*p) {
                mask |= 1 << (d + 1);
            }
        }
        self.misses[self.next] = mask;
        self.next = (self.next + 1) % WINDOW;
        self.informative = self.informative.saturating_add(1);
        if self.informative < MIN_INFORMATIVE {
            return;
        }
        let count = |d: usize| self.misses.iter().filter(|m| *m & (1 << d) != 0).count();
        let best = (1..=MAX_ECHO_PERIODS)
            .min_by_key(|d| (count(*d), *d))
            .unwrap_or(1);
        self.estimate = Some(best as u32);
        self.late_streak = if best > 1 {
            self.late_streak.saturating_add(1)
        } else {
            0
        };
    }
}

/// The loop-delay tracker.
#[derive(Debug, Clone, Default)]
pub struct LoopDelay {
    applied: Scores,
    feed: Scores,
    seq_unwrapped: Option<i64>,
    last_seq: Option<u16>,
    /// The period of the last read, and how its sample drifted from the one before
    /// ([`Cadence`]); `None` after a break of the line.
    last_read: Option<(u64, Option<i64>)>,
    /// Reads on the board's cadence ([`Cadence::Regular`] or [`Cadence::Jitter`]) since it
    /// last broke.
    on_cadence: u32,
    /// The freshest offset that held for [`STEADY_PERIODS`] periods in a row.
    best_offset: Option<i64>,
    /// The current offset and for how many periods it has held.
    run: Option<(i64, u32)>,
    last: DelayReading,
}

impl LoopDelay {
    /// A tracker that has seen nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// The last reading.
    pub fn last(&self) -> DelayReading {
        self.last
    }

    /// Period `index`, before this period's write: what the loop booked since the last
    /// call (`booked`), then the accepted status `status`, if any (`None`: a link error, a
    /// status the guard refused or held: the last reading stands).
    pub fn period(
        &mut self,
        index: u64,
        booked: &Booked,
        status: Option<&BoardStatus>,
    ) -> DelayReading {
        if booked.line_broke || booked.released {
            // A release: a new engagement is judged on its own echoes (what was measured
            // before it, perhaps on a line that has since been fixed, does not carry over).
            // A broken line: the replies that follow may be shifted until it
            // resynchronises, so nothing measured so far is kept.
            self.applied = Scores::default();
            self.feed = Scores::default();
        }
        if booked.line_broke {
            self.on_cadence = 0;
            self.last_read = None;
        }
        match status {
            Some(s) => self.observe(index, s, booked.in_force),
            None => self.last,
        }
    }

    fn observe(
        &mut self,
        index: u64,
        s: &BoardStatus,
        in_force: &[Option<u16>; MAX_ECHO_PERIODS],
    ) -> DelayReading {
        // Only a board on its cadence is judged: after a stall or a run of repeated or
        // skipped samples the board may still be working through queued requests, and its
        // echo says nothing about the line; it is judged once it has kept its cadence for
        // the whole history examined.
        let drift = match (self.last_read, self.last_seq) {
            (Some((k, _)), Some(l)) => {
                Some(i64::from(s.sample_seq.wrapping_sub(l) as i16) - (index as i64 - k as i64))
            }
            _ => None,
        };
        let cadence = Cadence::of(drift, self.last_read.and_then(|(_, d)| d));
        self.last_read = Some((index, drift));
        if cadence == Cadence::Broken {
            self.applied = Scores::default();
            self.feed = Scores::default();
            self.on_cadence = 0;
        } else {
            self.on_cadence = self.on_cadence.saturating_add(1);
        }
        let driven = s.acc_active && !s.override_locked && !s.feed_hold_active;
        let settled = self.on_cadence as usize >= MAX_ECHO_PERIODS;
        let judged = driven && settled && cadence == Cadence::Regular;
        if let (true, Some(preds)) = (judged, predictions(in_force)) {
            let applied = s.override_applied_pct;
            self.applied.observe(&preds, |p| p == applied);
            if s.is_v2() && s.programmed_feed_mm_min > 0 {
                let prog = f64::from(s.programmed_feed_mm_min);
                let actual = f64::from(s.actual_feed_mm_min);
                self.feed.observe(&preds, |p| {
                    let want = prog * f64::from(p) / 100.0;
                    (actual - want).abs() <= (FEED_TOLERANCE * want).max(3.0)
                });
            }
        }
        // SAMPLE_SEQ against the period count.
        let seq = match (self.last_seq, self.seq_unwrapped) {
            (Some(l), Some(u)) => {
                let adv = i64::from(s.sample_seq.wrapping_sub(l) as i16);
                u + adv
            }
            _ => i64::from(s.sample_seq),
        };
        if s.board_restarted {
            self.best_offset = None;
        }
        self.last_seq = Some(s.sample_seq);
        self.seq_unwrapped = Some(seq);
        let offset = seq - index as i64;
        let held = match self.run {
            Some((o, n)) if o == offset => n + 1,
            _ => 1,
        };
        self.run = Some((offset, held));
        if held >= STEADY_PERIODS {
            self.best_offset = Some(self.best_offset.map_or(offset, |b| b.max(offset)));
        }
        let best = self.best_offset.unwrap_or(offset).max(offset);
        self.last = DelayReading {
            echo_periods: self.applied.estimate,
            feed_echo_periods: self.feed.estimate,
            seq_lag_periods: u32::try_from(best - offset).ok(),
            late_streak: self.applied.late_streak,
            replay_lag_periods: None,
        };
        self.last
    }
}

/// What the loop booked about its commands up to a period ([`LoopDelay::period`]).
#[derive(Debug, Clone, Copy)]
pub struct Booked<'a> {
    /// The command in force on the board after each of the last periods, newest first
    /// (`None`: not driven by ACC, or unknown: a failed write, a broken line).
    pub in_force: &'a [Option<u16>; MAX_ECHO_PERIODS],
    /// ACC was not driving the override in a period booked since the last call.
    pub released: bool,
    /// The line or the board lost its cadence this period (a lost, late or garbled reply,
    /// a failed write).
    pub line_broke: bool,
}

/// The echo each candidate delay predicts: the command in force `d` periods back, if all
/// are known.
fn predictions(in_force: &[Option<u16>; MAX_ECHO_PERIODS]) -> Option<[u16; MAX_ECHO_PERIODS]> {
    let mut p = [0; MAX_ECHO_PERIODS];
    for (slot, c) in p.iter_mut().zip(in_force.iter()) {
        *slot = (*c)?;
    }
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control_loop::InForce;

    fn status(applied: u16, seq: u16) -> BoardStatus {
        BoardStatus {
            acc_switch: true,
            acc_active: true,
            cycle_active: true,
            override_applied_pct: applied,
            override_step_pct: 10,
            sample_seq: seq,
            protocol_version: 2,
            programmed_feed_mm_min: 200,
            actual_feed_mm_min: 2 * applied,
            ..BoardStatus::default()
        }
    }

    /// The tracker and the loop's booking of its commands, as `ControlLoop` drives them.
    #[derive(Default)]
    struct Rig {
        t: LoopDelay,
        f: InForce,
    }

    impl Rig {
        /// Period `k` reads `s` (`None`: no accepted status) on an unbroken line.
        fn read(&mut self, k: u64, s: Option<BoardStatus>) -> DelayReading {
            self.t.period(k, &self.f.take(false), s.as_ref())
        }
    }

    const DITHER: [u16; 7] = [50, 60, 60, 70, 50, 50, 60];

    /// A board whose replies reach the loop `lag` reads late, driven by a dithering command.
    fn run(lag: usize, periods: usize) -> DelayReading {
        let mut rig = Rig::default();
        let cmds: Vec<u16> = (0..periods).map(|k| DITHER[k % 7]).collect();
        // applied on the board after period k = cmds[k]; the read of period k sees the
        // board as it was after period k − 1 − lag.
        let mut r = DelayReading::default();
        for k in 0..periods {
            let seen = k.checked_sub(1 + lag).map_or(50, |j| cmds[j]);
            r = rig.read(k as u64, Some(status(seen, (k.saturating_sub(lag)) as u16)));
            rig.f.book(true, Some(cmds[k]));
        }
        r
    }

    #[test]
    fn the_designed_delay_reads_one_period() {
        let r = run(0, 100);
        assert_eq!(r.echo_periods, Some(1));
        assert_eq!(r.feed_echo_periods, Some(1));
        assert_eq!(r.late_streak, 0);
    }

    #[test]
    fn a_buffering_line_reads_its_delay() {
        for lag in [1, 2, 3, 5] {
            let r = run(lag, 100);
            assert_eq!(r.echo_periods, Some(1 + lag as u32), "lag {lag}");
            assert!(r.late_streak >= 2, "lag {lag}: {r:?}");
        }
    }

    #[test]
    fn a_failed_write_is_not_judged_and_a_release_starts_afresh() {
        let mut rig = Rig::default();
        for k in 0..60usize {
            let seen = k.checked_sub(1).map_or(50, |j| DITHER[j % 7]);
            rig.read(k as u64, Some(status(seen, k as u16)));
            rig.f.book(true, Some(DITHER[k % 7]));
            if k == 30 {
                // The write's reply was garbled, but the board took the command.
                rig.f.cmds[0] = None;
            }
            let r = rig.t.last();
            assert!(r.echo_periods.is_none_or(|e| e == 1), "k {k}: {r:?}");
        }
        assert_eq!(rig.t.last().echo_periods, Some(1));
        rig.f.book(false, None);
        rig.read(60, Some(status(60, 60)));
        assert_eq!(
            rig.t.last().echo_periods,
            None,
            "a new engagement starts without one"
        );
    }

    /// Drive the designed delay for `periods`, skipping period `skip` the way
    /// `ControlLoop::skip` does (no read, nothing written, the command booked as kept while
    /// `driving`). The board's sample sequence advances in the skipped period when
    /// `seq_moves` (the board's tick) and not otherwise (a board sampling per read). Returns
    /// every reading after the skip.
    fn run_with_skip(skip: usize, driving: bool, seq_moves: bool) -> Vec<DelayReading> {
        let mut rig = Rig::default();
        let mut on_board = 50;
        let mut after = Vec::new();
        let mut seq = 0u16;
        for k in 0..80 {
            if k == skip {
                rig.f.book(driving, None);
                seq += u16::from(seq_moves);
                continue;
            }
            let r = rig.read(k as u64, Some(status(on_board, seq)));
            seq += 1;
            if k > skip {
                after.push(r);
            }
            on_board = DITHER[k % 7];
            rig.f.book(true, Some(on_board));
        }
        after
    }

    #[test]
    fn a_skipped_period_keeps_the_command_in_force() {
        for seq_moves in [false, true] {
            let after = run_with_skip(30, true, seq_moves);
            assert!(
                after.iter().all(|r| r.echo_periods.is_none_or(|e| e == 1)),
                "seq_moves {seq_moves}: {after:?}"
            );
            assert_eq!(after.last().and_then(|r| r.echo_periods), Some(1));
            // The board's tick in the skipped period keeps its cadence against the period
            // count; a board that did not tick is one lone repeat: the estimate carries on
            // through the skip either way.
            assert_eq!(after[0].echo_periods, Some(1), "seq_moves {seq_moves}");
        }
    }

    /// A board whose replies reach the loop `lag` reads late, driven by a dithering command,
    /// its sample tick and the loop's read so close that the sample seen jitters: at the
    /// periods in `repeats` the read still finds the sample before (a repeat), and the
    /// next read finds the one after (a skip). Returns every reading.
    fn run_jittered(lag: usize, periods: usize, repeats: &[usize]) -> Vec<DelayReading> {
        let mut rig = Rig::default();
        let cmds: Vec<u16> = (0..periods).map(|k| DITHER[k % 7]).collect();
        let mut out = Vec::new();
        for k in 0..periods {
            let seen = k.checked_sub(1 + lag).map_or(50, |j| cmds[j]);
            let seq = k.saturating_sub(lag) - usize::from(repeats.contains(&k));
            out.push(rig.read(k as u64, Some(status(seen, seq as u16))));
            rig.f.book(true, Some(cmds[k]));
        }
        out
    }

    #[test]
    fn lone_repeats_and_skips_of_the_sample_keep_the_delay_judged() {
        // Every third read sees its sample one tick late, as when board and loop sample at
        // the same instant: the buffering line is found all the same.
        let jitter: Vec<usize> = (10..200).step_by(3).collect();
        for lag in [0, 2, 5] {
            let r = run_jittered(lag, 200, &jitter);
            let last = r.last().copied().unwrap_or_default();
            assert_eq!(
                last.echo_periods,
                Some(1 + lag as u32),
                "lag {lag}: {last:?}"
            );
            if lag == 0 {
                assert!(r.iter().all(|x| x.late_streak == 0), "no false delay");
            } else {
                assert!(last.late_streak >= 2, "lag {lag}: {last:?}");
            }
        }
    }

    #[test]
    fn a_run_of_repeated_samples_breaks_the_cadence() {
        // Reads 40–42 find the same sample (a stalled board), then it goes on: the
        // estimate starts again from scratch.
        let mut rig = Rig::default();
        for k in 0..60usize {
            let seen = k.checked_sub(1).map_or(50, |j| DITHER[j % 7]);
            let seq = if (40..=42).contains(&k) { 39 } else { k };
            let r = rig.read(k as u64, Some(status(seen, seq as u16)));
            rig.f.book(true, Some(DITHER[k % 7]));
            if k == 39 {
                assert_eq!(r.echo_periods, Some(1));
            }
            if k == 42 {
                assert_eq!(r.echo_periods, None, "judged again from scratch");
            }
        }
        assert_eq!(rig.t.last().echo_periods, Some(1));
    }

    #[test]
    fn a_skipped_period_out_of_acc_starts_afresh_at_the_next_read() {
        // Same cadence as the first case above: only the release clears the estimate.
        let after = run_with_skip(30, false, false);
        assert_eq!(after[0].echo_periods, None, "{:?}", after[0]);
        assert_eq!(after.last().and_then(|r| r.echo_periods), Some(1));
    }

    #[test]
    fn a_period_without_an_accepted_status_keeps_the_last_reading() {
        let mut rig = Rig::default();
        for k in 0..40usize {
            let seen = k.checked_sub(1).map_or(50, |j| DITHER[j % 7]);
            rig.read(k as u64, Some(status(seen, k as u16)));
            rig.f.book(true, Some(DITHER[k % 7]));
        }
        let before = rig.t.last();
        assert_eq!(before.echo_periods, Some(1));
        assert_eq!(rig.read(40, None), before);
        // A broken line forgets the estimate even without a status.
        let broke = rig.t.period(41, &rig.f.take(true), None);
        assert_eq!(broke, before, "the reading stands until the next status");
        let s = status(DITHER[39 % 7], 42);
        assert_eq!(rig.read(42, Some(s)).echo_periods, None);
    }

    #[test]
    fn a_constant_command_tells_nothing() {
        let mut rig = Rig::default();
        for k in 0..50 {
            rig.read(k, Some(status(70, k as u16)));
            rig.f.book(true, Some(70));
        }
        assert_eq!(rig.t.last().echo_periods, None);
    }

    #[test]
    fn the_sequence_lag_follows_a_stale_line() {
        let mut rig = Rig::default();
        for k in 0..20u64 {
            rig.read(k, Some(status(70, 100 + k as u16)));
        }
        assert_eq!(rig.t.last().seq_lag_periods, Some(0));
        // From period 20 the line delivers the reply of three reads earlier.
        for k in 20..30u64 {
            rig.read(k, Some(status(70, 100 + (k - 3) as u16)));
        }
        assert_eq!(rig.t.last().seq_lag_periods, Some(3));
    }
}
