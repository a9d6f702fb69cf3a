//! Writes that raced the board's tick, told apart by the board's `ACTUAL_FEED`.
//!
//! `acc run` reads the board's status, then writes the next override. The board takes a
//! period at its tick with `OVERRIDE_CMD` as it is then. A tick late by a few milliseconds
//! can fall between the loop's read and its write: the read finds the sample before, as
//! usual, and the period the tick starts runs on the old override, but the next read finds
//! the new one in `OVERRIDE_APPLIED`. Nothing in the flags shows it (docs/twin.md,
//! "Limits"): the replay would run that period on the new override, one row off by a whole
//! override step and the tool a step's travel off from then on.
//!
//! A v2 board's `ACTUAL_FEED`, read with the sample (run-log `board_feed_mm_min`), is the
//! NC's feed over the sampled period. After an override step at a period's start the
//! model's override path and feed drive move a share φ of the step within that period
//! ([`first_period_share`]); a period that ran on the old override moves none of it, and
//! the period after a step that landed a period early shows the whole step. [`retime`]
//! places each board period on the override that explains the board's feeds best: the
//! override the row read, or (a raced write) the one the row before read, or for a period
//! no row read (a late read or a late tick) either neighbour's.
//!
//! A period moves only where its new placement explains the board's feed to the feed's
//! rounding ([`FIT_TOLERANCE_MM_MIN`]) in the period and the one after, and the log's
//! placement does not in one of them. A simulator's log is not re-timed (its board runs
//! in lockstep: `RunLog::board_feed_mm_min`). An override path
//! slower or faster than the model's (a dead time the machine has, which the model and the
//! twin's `override_dead_time` describe) moves the feed by a share of the step that fits
//! neither placement, and the log's placement stands. When the model's drive moves less
//! than [`MIN_FIRST_SHARE`] of a step in its first period, nothing is changed.

/// A period is re-timed only where its new placement explains the board's feed in it and
/// in the period after to within this, mm/min, plus [`FIT_TOLERANCE_SHARE`] of the step
/// (the feed's rounding is half of [`FEED_RESOLUTION_MM_MIN`]).
pub const FIT_TOLERANCE_MM_MIN: f64 = 1.5;
/// The share of the override step added to [`FIT_TOLERANCE_MM_MIN`], −.
pub const FIT_TOLERANCE_SHARE: f64 = 0.05;
/// The test needs a drive that moves at least this share of a step in the step's first
/// period (override path dead time and drive lag well inside one period).
pub const MIN_FIRST_SHARE: f64 = 0.4;
/// `ACTUAL_FEED` is a whole number of mm/min: its rounding, mm/min.
pub const FEED_RESOLUTION_MM_MIN: f64 = 1.0;

/// Share of an override step that the mean feed of the step's first period shows, for an
/// override path with dead time `delay_s` and a feed drive of one or two first-order lags
/// `tau_s`, `tau2_s` (seed 002 eq. 5), over a period `period_s`, −. Integrated on a
/// 10 µs grid.
pub fn first_period_share(delay_s: f64, tau_s: f64, tau2_s: f64, period_s: f64) -> f64 {
    if period_s <= 0.0 {
        return 0.0;
    }
    let n = (period_s / 1e-5).round().max(1.0) as usize;
    let dt = period_s / n as f64;
    let (mut y1, mut y2, mut sum) = (0.0_f64, 0.0_f64, 0.0_f64);
    let step = |y: f64, u: f64, tau: f64| {
        if tau > 0.0 {
            y + (u - y) * (1.0 - (-dt / tau).exp())
        } else {
            u
        }
    };
    for k in 0..n {
        let u = if (k as f64 + 0.5) * dt >= delay_s {
            1.0
        } else {
            0.0
        };
        y1 = step(y1, u, tau_s);
        y2 = if tau2_s > 0.0 {
            step(y2, y1, tau2_s)
        } else {
            y1
        };
        sum += y2;
    }
    sum / n as f64
}

/// What [`retime`] found (`report.json`'s `input.retimed`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct RaceCount {
    /// Periods whose override steps from the period before (as the log places them).
    pub steps: usize,
    /// Periods the board's feed placed on the other override (and the replay runs so).
    pub retimed: usize,
}

impl RaceCount {
    /// The report's sentence on it; `None` when the board's feed moved nothing.
    pub fn text(&self) -> Option<String> {
        (self.retimed > 0).then(|| {
            format!(
                "the board's feed (`board_feed_mm_min`) ran {} of the log's {} override steps a period off where the log's reads place them (a write that raced the board's tick, a late tick): the replay runs them where the feed puts them",
                self.retimed, self.steps
            )
        })
    }
}

/// Which rows stand for each board period: `from`, the row whose override, programmed
/// feed and speed drove it as the log places it, and `row`, the first row that read it or
/// a later one (its engagement). A period no row read lies between rows k−1 and k: if row
/// k−1 read the same sample as the row before it, the board's tick was late and fired just
/// after row k−1's read, most likely before that row's write landed, so the period ran on
/// what row k−1 read; if not, row k read late, and the period ran on what row k reads.
/// `sample` is the board's sample each row read ([`super::Inputs::board_sample`]).
pub fn board_periods(sample: &[usize]) -> Vec<(usize, usize)> {
    let periods = sample.last().map_or(0, |&s| s + 1);
    let mut out = Vec::with_capacity(periods);
    let mut row = 0;
    for s in 0..periods {
        while sample[row] < s {
            row += 1;
        }
        let late_tick = row >= 2 && sample[row] > s && sample[row - 1] == sample[row - 2];
        out.push((if late_tick { row - 1 } else { row }, row));
    }
    out
}

/// Squared feed error a period's other override must save before the board's feed moves
/// it there, (mm/min)²: twice [`FEED_RESOLUTION_MM_MIN`], squared.
const SWITCH_COST: f64 = 4.0 * FEED_RESOLUTION_MM_MIN * FEED_RESOLUTION_MM_MIN;

/// The override that drove each board period, with the periods the board's feed places
/// on the other candidate re-timed (see the module docs).
///
/// `override_pct`, `programmed_mm_min` and `board_feed_mm_min` are per row (the register
/// at the read, the programmed feed, the board's `ACTUAL_FEED`; `None`: no used read);
/// `sample` is the board's sample each row read (`None`: row k read sample k, and the
/// periods are the rows); `share` the model's [`first_period_share`]. A period read by a
/// row may have run on the override the row before read (a raced write), a period no row
/// read on either neighbour's ([`board_periods`]). The most likely sequence is found by
/// dynamic programming over the periods: a period's mean feed is the commanded feed before
/// plus `share` of its step, compared with the board's feed where a row read it; choosing
/// the other candidate costs [`SWITCH_COST`].
pub fn retime(
    override_pct: &[f64],
    programmed_mm_min: &[f64],
    board_feed_mm_min: &[Option<f64>],
    sample: Option<&[usize]>,
    share: f64,
) -> (Vec<f64>, RaceCount) {
    let identity: Vec<usize>;
    let sample = match sample {
        Some(s) => s,
        None => {
            identity = (0..override_pct.len()).collect();
            &identity
        }
    };
    let periods = board_periods(sample);
    let logged: Vec<f64> = periods.iter().map(|&(f, _)| override_pct[f]).collect();
    let mut count = RaceCount {
        steps: logged.windows(2).filter(|w| w[0] != w[1]).count(),
        retimed: 0,
    };
    if share < MIN_FIRST_SHARE || periods.len() < 2 {
        return (logged, count);
    }
    // The row that read each period (`None`: no row did), and each period's candidates:
    // [as logged, the other].
    let mut read_by: Vec<Option<usize>> = vec![None; periods.len()];
    for (k, &s) in sample.iter().enumerate() {
        if k == 0 || sample[k - 1] != s {
            read_by[s] = Some(k);
        }
    }
    // The last row before each row with a used read (the board's feed known): a failed or
    // held read carries the next read's override, not the one the board last ran on.
    let mut last_read: Vec<Option<usize>> = vec![None; override_pct.len()];
    for k in 1..override_pct.len() {
        last_read[k] = if board_feed_mm_min.get(k - 1).copied().flatten().is_some() {
            Some(k - 1)
        } else {
            last_read[k - 1]
        };
    }
    let cand: Vec<[(f64, f64); 2]> = periods
        .iter()
        .map(|&(from, row)| {
            // The other candidate: the override of the last read before (a raced write, a
            // stall's first periods), else the next read's (a late read).
            let other = [last_read[row], Some(row)]
                .into_iter()
                .flatten()
                .find(|&r| override_pct[r] != override_pct[from])
                .unwrap_or(from);
            let c = |r: usize| {
                (
                    override_pct[r],
                    programmed_mm_min[r] * override_pct[r] / 100.0,
                )
            };
            [c(from), c(other)]
        })
        .collect();
    // The board's feed of each period a row read (0: a feed hold, which tells nothing).
    let feed_at = |s: usize| {
        read_by[s]
            .and_then(|k| board_feed_mm_min.get(k).copied().flatten())
            .filter(|&f| f > 0.0)
    };
    // cost[j]: the least cost of periods 0..=s with period s on candidate j.
    let mut cost = [0.0, f64::INFINITY];
    let mut back: Vec<[usize; 2]> = vec![[0, 0]; periods.len()];
    for s in 1..periods.len() {
        let observed = feed_at(s);
        let mut next = [f64::INFINITY; 2];
        for j in 0..2 {
            let (_, now) = cand[s][j];
            for (i, &before_cost) in cost.iter().enumerate() {
                let (_, before) = cand[s - 1][i];
                let fit = observed.map_or(0.0, |f| {
                    let predicted = before + share * (now - before);
                    (f - predicted).powi(2)
                });
                let c = before_cost + fit + if j == 1 { SWITCH_COST } else { 0.0 };
                if c < next[j] {
                    next[j] = c;
                    back[s][j] = i;
                }
            }
        }
        cost = next;
    }
    let mut j = usize::from(cost[1] < cost[0]);
    let mut pick = vec![0usize; periods.len()];
    for s in (0..periods.len()).rev() {
        pick[s] = j;
        j = back[s][j];
    }
    // A period moves to its other candidate only where that explains the board's feed, in
    // the period and the one after, to the feed's rounding: an override path slower or
    // faster than the model's (a dead time the machine has, for the model to describe)
    // fits neither placement, and stays where the log puts it.
    for s in 1..periods.len() {
        if pick[s] == 0 {
            continue;
        }
        let step = (cand[s][1].1 - cand[s][0].1).abs();
        let tolerance = FIT_TOLERANCE_MM_MIN + FIT_TOLERANCE_SHARE * step;
        let explained = |t: usize| {
            let (before, now) = (cand[t - 1][pick[t - 1]].1, cand[t][pick[t]].1);
            feed_at(t).map(|f| (f - before - share * (now - before)).abs() <= tolerance)
        };
        let checks: Vec<bool> = [s, s + 1]
            .into_iter()
            .filter(|&t| t < periods.len())
            .filter_map(explained)
            .collect();
        // And the log's placement must miss the feed beyond the same tolerance, in the
        // period or the next.
        pick[s] = 0;
        let missed = [s, s + 1]
            .into_iter()
            .filter(|&t| t < periods.len())
            .filter_map(|t| {
                let (before, now) = (cand[t - 1][pick[t - 1]].1, cand[t][pick[t]].1);
                feed_at(t).map(|f| (f - before - share * (now - before)).abs())
            })
            .any(|miss| miss > tolerance);
        if missed && !checks.is_empty() && !checks.contains(&false) {
            pick[s] = 1;
        }
    }
    let out: Vec<f64> = pick.iter().zip(&cand).map(|(&j, c)| c[j].0).collect();
    count.retimed = out.iter().zip(&logged).filter(|(a, b)| a != b).count();
    (out, count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_period_share_of_a_first_order_drive_has_its_closed_form() {
        // Mean over [0, T] of 1 − e^(−(t−d)/τ) for t > d: (T − d − τ(1 − e^(−(T−d)/τ))) / T.
        let (d, tau, t) = (0.016_f64, 0.008_f64, 0.1_f64);
        let exact = (t - d - tau * (1.0 - (-(t - d) / tau).exp())) / t;
        assert!((first_period_share(d, tau, 0.0, t) - exact).abs() < 1e-4);
        assert!((first_period_share(0.0, 0.0, 0.0, t) - 1.0).abs() < 1e-9);
        assert_eq!(first_period_share(0.2, 0.0, 0.0, t), 0.0);
        // A second lag moves less.
        assert!(first_period_share(d, tau, 0.02, t) < exact - 0.1);
    }

    /// The mean feed of each period of a drive that moves `share` of a step in its first
    /// period and settles in it, for the overrides that drove them (whole mm/min).
    fn board_feed(drove: &[f64], prog: f64, share: f64) -> Vec<Option<f64>> {
        (0..drove.len())
            .map(|k| {
                let before = if k == 0 { drove[0] } else { drove[k - 1] };
                let f = prog * (before + share * (drove[k] - before)) / 100.0;
                Some(f.round())
            })
            .collect()
    }

    #[test]
    fn a_raced_write_is_retimed_and_the_others_are_kept() {
        let share = first_period_share(0.016, 0.008, 0.0, 0.1);
        // The loop alternates 10 % steps; at row 5 the write raced the tick: the period
        // ran on 110 while the register read 120.
        let logged = [
            100., 110., 110., 120., 110., 120., 120., 130., 120., 110., 120., 130.,
        ];
        let mut drove = logged.to_vec();
        drove[5] = 110.0;
        let feed = board_feed(&drove, 200.0, share);
        let prog = vec![200.0; logged.len()];
        let (ov, c) = retime(&logged, &prog, &feed, None, share);
        assert_eq!(ov, drove, "{c:?}");
        assert_eq!(c.retimed, 1);
        assert_eq!(c.steps, 9);
        // Without the race the log is kept as it is.
        let (ov, c) = retime(
            &logged,
            &prog,
            &board_feed(&logged, 200.0, share),
            None,
            share,
        );
        assert_eq!((ov.as_slice(), c.retimed), (logged.as_slice(), 0));
    }

    #[test]
    fn a_period_no_row_read_goes_where_the_next_feed_puts_it() {
        let share = first_period_share(0.016, 0.008, 0.0, 0.1);
        // Rows 0..=5 read samples 0, 1, 2, 2 (a repeat), 4, 5: period 3 was read by
        // nobody. The late-tick rule runs it on row 3's 50 %; the machine ran it on the 60 %
        // that row 4 reads, so that period 4's feed is settled at 60 %.
        // The loop goes on stepping, as it does.
        let sample = [0, 1, 2, 2, 4, 5, 6, 7, 8, 9, 10];
        let logged = [50., 50., 50., 50., 60., 60., 50., 60., 50., 60., 50.];
        let drove = [50., 50., 50., 60., 60., 60., 50., 60., 50., 60., 50.];
        let feed_of_period = board_feed(&drove, 200.0, share);
        let feed: Vec<Option<f64>> = sample.iter().map(|&s| feed_of_period[s]).collect();
        let (ov, c) = retime(&logged, &[200.0; 11], &feed, Some(&sample), share);
        assert_eq!(ov, drove, "{c:?}");
        assert_eq!((c.retimed, c.steps), (1, 6));
        assert_eq!(board_periods(&sample)[3], (3, 4));
    }

    /// The board's feeds of a machine whose override path has `dead_s` more dead time
    /// than the model's 16 ms, for the overrides that drove each period.
    fn feed_of_a_slower_path(drove: &[f64], dead_s: f64) -> Vec<Option<f64>> {
        // The feed of period k: the override of k−2, k−1 and k, each landing `delay` into
        // its period, a first-order drive of 8 ms.
        let (t, tau, delay) = (0.1_f64, 0.008_f64, 0.016 + dead_s);
        let n = 10_000;
        let dt = t / n as f64;
        let mut y = 200.0 * drove[0] / 100.0;
        let mut out = Vec::new();
        for k in 0..drove.len() {
            let mut sum = 0.0;
            for i in 0..n {
                let at = k as f64 * t + (i as f64 + 0.5) * dt - delay;
                let j = (at / t).floor().max(0.0) as usize;
                let u = 200.0 * drove[j.min(k)] / 100.0;
                y += (u - y) * (1.0 - (-dt / tau).exp());
                sum += y;
            }
            out.push(Some((sum / n as f64).round()));
        }
        out
    }

    #[test]
    fn a_dead_time_the_machine_has_is_left_for_the_model() {
        let share = first_period_share(0.016, 0.008, 0.0, 0.1);
        let logged = [
            100., 110., 120., 110., 120., 130., 120., 110., 100., 110., 110., 110.,
        ];
        // The twin library's override dead times: 0.05 s and 0.12 s more than the model.
        for dead_s in [0.05, 0.12] {
            let feed = feed_of_a_slower_path(&logged, dead_s);
            let (ov, c) = retime(&logged, &[200.0; 12], &feed, None, share);
            assert_eq!(ov, logged, "+{dead_s} s: {c:?} {feed:?}");
        }
        // A whole period late from a race, on every step: each step is re-timed.
        let drove: Vec<f64> = std::iter::once(logged[0])
            .chain(logged[..logged.len() - 1].iter().copied())
            .collect();
        let (ov, c) = retime(
            &logged,
            &[200.0; 12],
            &board_feed(&drove, 200.0, share),
            None,
            share,
        );
        assert_eq!(ov, drove, "{c:?}");
    }

    #[test]
    fn steps_within_the_feeds_rounding_and_a_slow_drive_tell_nothing() {
        // 1 % steps at 100 mm/min: 1 mm/min a step, within the rounding.
        let logged = [100., 101., 102., 101., 100.];
        let feed = vec![Some(100.0); logged.len()];
        let (ov, c) = retime(&logged, &[100.0; 5], &feed, None, 0.76);
        assert_eq!((ov.as_slice(), c.retimed), (logged.as_slice(), 0));
        // A drive that moves a fifth of a step in the first period cannot tell a race.
        let (ov, _) = retime(&[100., 120.], &[200.0; 2], &[Some(200.0); 2], None, 0.2);
        assert_eq!(ov[1], 120.0);
    }

    #[test]
    fn rows_without_a_read_are_not_judged() {
        let logged = [100., 110., 120., 130.];
        let feed = [Some(200.0), None, None, None];
        let (ov, c) = retime(&logged, &[200.0; 4], &feed, None, 0.76);
        assert_eq!((ov.as_slice(), c.retimed), (logged.as_slice(), 0));
    }
}
