//! The feed optimizer of `acc optimize`: a program's F words rewritten per block from the
//! planner's predicted force, with blocks split where their engagement changes.
//!
//! It reads the same intervals the planner reads ([`crate::plan::intervals`]: the path cut
//! at the stock's engagement steps, the largest force of each at 100 % from the plant's
//! mean-force law, seed 002 eq. 1) and gives each interval the feed that predicts Fr,
//! `f = f_prog · (Fr / F₁₀₀)^(1/β)` (eq. 1 solved for the feed), at most the tool's air
//! feed and the machine's rapid rate; an interval without engagement gets the tool's air
//! feed. A plunge (a vertical move down into the stock: axial engagement only, which the
//! side-milling force law does not cover) keeps at most its programmed feed. Feeds are put
//! on a ladder of levels [`LEVEL_RATIO`] apart (rounded down), so that
//! an engagement that varies a little does not split a block at every stock cell.
//!
//! A feed block (G1, G2, G3) is split into pieces of at least `min_segment_mm` where its
//! feed level changes; a piece's feed is the lowest of its intervals', so the predicted
//! force stays ≤ Fr over the whole piece. Lines split into lines, arcs into arcs about the
//! same centre, in the block's plane (written with the plane's centre words: I J in G17,
//! K I in G18, J K in G19; in the block's G90.1/G91.1 mode), in the block's units and
//! G90/G91 mode. The first piece is the original line with its axis, arc and F
//! words replaced (every other word, its N number and its comments kept, so every
//! non-motion word still acts before the motion); the others are new lines
//! `[N…] G1|G2|G3 X Y Z [I J | K I | J K] F`, numbered above every N word and line number of the
//! program when its blocks carry N words ([`piece_numbers`]), so that the look-ahead never
//! takes one block for another. A block is not split, only its F word set to the lowest feed
//! of its path, when splitting could change what it does: it runs more than once (a
//! subroutine, a loop) or makes more than one motion (a canned cycle), sets parameters,
//! has a G or M word that reads a parameter, a dwell, a stop (M0 M1 M2 M30 M60), a
//! multi-turn arc, G64 on an arc, or a block delete; or cutter radius compensation shapes
//! its motion (G41/G42 in force, or the move after G40: [`acc_nc::Modes::cutter_comp`]),
//! where the compensated path depends on the neighbouring blocks' words and a split would
//! add corners to it. Rapids and every other line are copied as they are.

use std::fmt::Write as _;

use acc_nc::{Canon, CanonCall, LineWords, Units};

use crate::plan::{Interval, PlanParams};
use crate::program::{ProgramPath, CHORD_TOL_MM};

/// Ratio between two neighbouring feed levels: a feed is rounded down to `1.05^k` mm/min.
pub const LEVEL_RATIO: f64 = 1.05;

/// Default shortest piece a block is split into, mm.
pub const DEFAULT_MIN_SEGMENT_MM: f64 = 1.0;

/// Allowed range of the shortest piece, mm.
pub const MIN_SEGMENT_RANGE_MM: (f64, f64) = (0.01, 1000.0);

/// The optimizer's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizeParams {
    /// The planner's constants (tool, force law, Fr).
    pub plan: PlanParams,
    /// Shortest piece a block is split into, mm ([`MIN_SEGMENT_RANGE_MM`], default
    /// [`DEFAULT_MIN_SEGMENT_MM`]).
    pub min_segment_mm: f64,
    /// Highest feed written, mm/min (the machine's rapid rate).
    pub max_feed_mm_min: f64,
}

/// The rewritten program and what was done to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimized {
    /// The program text.
    pub text: String,
    /// Feed lines whose F word was rewritten.
    pub lines_rewritten: usize,
    /// Feed lines split into pieces.
    pub lines_split: usize,
    /// Lines added by the splits.
    pub lines_added: usize,
    /// Feed lines kept whole although their feed level changes along them (see the module
    /// doc for why), with the lowest feed of their path.
    pub kept_whole: usize,
    /// The N numbers given to the added lines (first, last), when the program numbers its
    /// blocks ([`piece_numbers`]).
    pub added_numbers: Option<(u32, u32)>,
}

/// The first N number of the added lines of `file` (its text `text`) whose lines carry N
/// words: above every N word of its text (whether the line runs or not) and above the
/// optimized program's line count `output_lines`, so that no block number the board
/// reports (`BLOCK_NUMBER`: the N word, else the line number) names two blocks. `None`
/// when no line carries an N word: every block is then known by its line number, which
/// the added lines keep unique by themselves.
pub fn piece_numbers(file: &str, text: &str, output_lines: usize) -> Option<u32> {
    let largest = text
        .lines()
        .enumerate()
        .filter_map(|(k, l)| acc_nc::line_words(file, u32::try_from(k + 1).ok()?, l).ok())
        .filter_map(|w| w.n)
        .max()?;
    let lines = u32::try_from(output_lines).unwrap_or(u32::MAX);
    Some(largest.max(lines).saturating_add(1))
}

/// The largest block number the board's `BLOCK_NUMBER` register holds (16 bits).
pub const MAX_BLOCK_NUMBER: u32 = 65_535;

/// Why a program could not be optimized.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptimizeError {
    /// A setting out of its range.
    #[error("{name} {value}: allowed {allowed}")]
    Range {
        /// The setting.
        name: String,
        /// Its value.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// The text does not parse (file:line:column).
    #[error("{0}")]
    Nc(#[from] acc_nc::NcError),
    /// The added lines would be numbered above [`MAX_BLOCK_NUMBER`]: the board would report
    /// them modulo 65 536, and the look-ahead could take one block for another.
    #[error(
        "{file}: the {count} added lines would be numbered N{first} .. N{last}, above the \
         board's BLOCK_NUMBER range 0 ..= 65535; renumber the program's blocks lower \
         (its largest N word or line count sets the first) and optimize it again"
    )]
    Numbering {
        /// The program.
        file: String,
        /// Lines added.
        count: usize,
        /// First number.
        first: u32,
        /// Last number.
        last: u32,
    },
    /// The program's path and its canonical calls do not match (a bug).
    #[error("{file}: {detail}")]
    Mismatch {
        /// The program.
        file: String,
        /// What did not match.
        detail: String,
    },
}

/// One piece of a feed block: path positions (mm, along the program) and feed (mm/min).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    a: f64,
    b: f64,
    feed: f64,
}

/// A feed call and its path range.
struct FeedCall<'a> {
    call: &'a CanonCall,
    a: f64,
    b: f64,
    pieces: Vec<Piece>,
}

/// The feed on the ladder at or below `v` (mm/min).
fn level(v: f64) -> f64 {
    let k = (v.ln() / LEVEL_RATIO.ln() + 1e-9).floor();
    LEVEL_RATIO.powf(k).min(v)
}

/// The feed of an interval: air feed without engagement, else the feed that predicts Fr on
/// the ladder, at most `cap` (mm/min).
fn interval_feed(iv: &Interval, p: &OptimizeParams, air: f64, cap: f64) -> f64 {
    if iv.f100 <= 0.0 {
        return air;
    }
    let beta = p.plan.law.spec.beta;
    let exact = acc_core::force_law::feed_for_force(iv.feed, iv.f100, p.plan.force_ref_n, beta);
    level(exact.min(cap))
}

/// The pieces of a block from its intervals' feeds: equal neighbours merged, then every
/// piece shorter than `min_mm` grown to `min_mm` into the neighbour with the nearer feed, at
/// the lower feed of the two (the neighbour keeps its feed on the rest; a neighbour left
/// shorter than `min_mm` is merged whole).
fn pieces(ivs: &[Piece], min_mm: f64) -> Vec<Piece> {
    let merge_equal = |v: &mut Vec<Piece>| {
        let mut w: Vec<Piece> = Vec::with_capacity(v.len());
        for q in v.drain(..) {
            match w.last_mut() {
                Some(l) if l.feed == q.feed => l.b = q.b,
                _ => w.push(q),
            }
        }
        *v = w;
    };
    let mut out = ivs.to_vec();
    merge_equal(&mut out);
    while out.len() > 1 {
        let short = |q: &Piece| q.b - q.a < min_mm - 1e-9;
        let Some(k) = out.iter().position(short) else {
            break;
        };
        let ratio = |i: usize| {
            let (f0, f1) = (out[k].feed, out[i].feed);
            f0.max(f1) / f0.min(f1).max(1e-12)
        };
        let right = match (k.checked_sub(1), (k + 1 < out.len()).then_some(k + 1)) {
            (Some(l), Some(r)) => ratio(r) < ratio(l),
            (Some(_), None) => false,
            (None, _) => true,
        };
        let nb = if right { k + 1 } else { k - 1 };
        let feed = out[k].feed.min(out[nb].feed);
        // What the short piece lacks moves from the neighbour into it.
        let lack = min_mm - (out[k].b - out[k].a);
        if out[nb].b - out[nb].a - lack < min_mm {
            let (lo, hi) = (k.min(nb), k.max(nb));
            out[lo] = Piece {
                a: out[lo].a,
                b: out[hi].b,
                feed,
            };
            out.remove(hi);
        } else if right {
            out[k].b += lack;
            out[nb].a = out[k].b;
            out[k].feed = feed;
        } else {
            out[k].a -= lack;
            out[nb].b = out[k].a;
            out[k].feed = feed;
        }
        merge_equal(&mut out);
    }
    out
}

/// `v` with at most `decimals` decimals, trailing zeros dropped (`-0` is `0`).
fn num(v: f64, decimals: usize) -> String {
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// The F word for `feed_mm_min` in `units`, rounded down (0.1 mm/min, 0.001 in/min; at
/// least that).
fn f_word(feed_mm_min: f64, units: Units) -> String {
    let (res, dec) = match units {
        Units::Mm => (0.1, 1),
        Units::Inch => (0.001, 3),
    };
    let v = feed_mm_min / units.mm_per_unit();
    let q = ((v / res + 1e-9).floor() * res).max(res);
    format!("F{}", num(q, dec))
}

/// The motion words of the pieces of `fc` (the first piece's words separately, for the
/// original line): `(first, [next lines])`.
fn piece_words(fc: &FeedCall<'_>) -> (String, Vec<String>) {
    let m = fc.call.modes;
    let u = m.units.mm_per_unit();
    let dec = if m.units == Units::Inch { 7 } else { 6 };
    let (code, center) = match &fc.call.call {
        Canon::Arc {
            clockwise,
            center,
            plane,
            ..
        } => (
            if *clockwise { "G2" } else { "G3" },
            Some((*center, *plane)),
        ),
        _ => ("G1", None),
    };
    let from = match &fc.call.call {
        Canon::Arc { from, .. } | Canon::Feed { from, .. } => *from,
        _ => [0.0; 3],
    };
    // Where the interpreter will be: the start, then each written end point.
    let mut cur = from;
    let len = (fc.b - fc.a).max(1e-12);
    let mut words = Vec::with_capacity(fc.pieces.len());
    for (i, q) in fc.pieces.iter().enumerate() {
        let t = if i + 1 == fc.pieces.len() {
            1.0
        } else {
            (q.b - fc.a) / len
        };
        let end = fc.call.call.point_at(t).unwrap_or(from);
        let mut w = String::new();
        let mut next = cur;
        for (k, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            let v = if m.absolute {
                end[k] / u
            } else {
                (end[k] - cur[k]) / u
            };
            let s = num(v, dec);
            let written: f64 = s.parse().unwrap_or(v);
            next[k] = if m.absolute {
                written * u
            } else {
                cur[k] + written * u
            };
            let _ = write!(w, "{l}{s} ");
        }
        if let Some((c, plane)) = center {
            // The centre words of the plane, on its first and second axis.
            let [first, second, _] = plane.centre_letters();
            let letters = [first, second];
            let start = plane.project(cur);
            for ((l, ck), sk) in letters.into_iter().zip(c).zip(start) {
                let v = if m.arc_absolute {
                    ck / u
                } else {
                    (ck - sk) / u
                };
                let _ = write!(w, "{l}{} ", num(v, dec));
            }
        }
        w.push_str(&f_word(q.feed, m.units));
        words.push(w);
        cur = next;
    }
    let first = words.remove(0);
    let rest = words.into_iter().map(|w| format!("{code} {w}")).collect();
    (first, rest)
}

/// Whether a line may be split (see the module doc).
fn splittable(text: &str, w: &LineWords, arc: bool) -> bool {
    const G_OK: &[f64] = &[
        1.0, 2.0, 3.0, 17.0, 18.0, 19.0, 20.0, 21.0, 40.0, 43.0, 49.0, 54.0, 55.0, 56.0, 57.0,
        58.0, 59.0, 61.0, 61.1, 90.0, 91.0, 90.1, 91.1, 94.0, 98.0, 99.0,
    ];
    const M_STOP: &[f64] = &[0.0, 1.0, 2.0, 30.0, 60.0];
    let g_ok = w.values('G').all(|g| {
        g.is_some_and(|g| G_OK.iter().any(|c| (c - g).abs() < 1e-6) || (!arc && g == 64.0))
    });
    let m_ok = w
        .values('M')
        .all(|m| m.is_some_and(|m| !M_STOP.iter().any(|c| (c - m).abs() < 1e-6)));
    // G40 (compensation off) makes the block's motion the exit move, which the caller keeps
    // whole; G41/G42 and G4 (dwell) are not in the list.
    let turns_ok = !arc || w.values('P').all(|p| p == Some(1.0));
    g_ok && m_ok && turns_ok && !w.assigns && !w.oword && !text.trim_start().starts_with('/')
}

/// `line` with the words of `drop` removed and `insert` put after its last word (or at
/// its end), the N number and comments kept.
fn rewrite_line(line: &str, w: &LineWords, drop: &[char], insert: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let at = w
        .words
        .last()
        .map_or(chars.len(), |x| x.end.min(chars.len()));
    let removed = |i: usize| {
        w.words
            .iter()
            .any(|x| drop.contains(&x.letter) && (x.start..x.end).contains(&i))
    };
    let mut out = String::with_capacity(line.len() + insert.len() + 2);
    for (i, c) in chars.iter().enumerate() {
        if i == at {
            if !out.ends_with(' ') && !out.is_empty() {
                out.push(' ');
            }
            out.push_str(insert);
        }
        if !removed(i) {
            out.push(*c);
        }
    }
    if at >= chars.len() {
        if !out.ends_with(' ') && !out.is_empty() {
            out.push(' ');
        }
        out.push_str(insert);
    }
    // Removed words leave runs of spaces: keep one (outside comments nothing else changes).
    let mut tidy = String::with_capacity(out.len());
    let mut depth = 0_i32;
    for c in out.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = (depth - 1).max(0),
            _ => {}
        }
        if c == ' ' && depth == 0 && tidy.ends_with(' ') {
            continue;
        }
        tidy.push(c);
    }
    tidy.trim_end().to_string()
}

/// The path ranges of the program's motion calls (index into `path.calls()`, start, end;
/// mm), from the pieces each call made.
fn call_ranges(file: &str, path: &ProgramPath) -> Result<Vec<(usize, f64, f64)>, OptimizeError> {
    let segs = path.segments();
    let starts = path.piece_starts_mm();
    let mut k = 0;
    let mut out = Vec::new();
    for (i, c) in path.calls().iter().enumerate() {
        if c.call.end().is_none() {
            continue;
        }
        let one = acc_nc::Program {
            file: file.to_string(),
            calls: vec![c.clone()],
        };
        let n = one
            .path(CHORD_TOL_MM)
            .iter()
            .filter(|s| s.length_mm() > 1e-9)
            .count();
        if n == 0 {
            continue;
        }
        let last = k + n - 1;
        let (Some(s0), Some(sl)) = (starts.get(k), segs.get(last)) else {
            return Err(OptimizeError::Mismatch {
                file: file.into(),
                detail: format!("line {}: the path has fewer pieces than the calls", c.line),
            });
        };
        if segs[k].line != c.line || sl.line != c.line {
            return Err(OptimizeError::Mismatch {
                file: file.into(),
                detail: format!("line {}: path piece from line {}", c.line, segs[k].line),
            });
        }
        out.push((i, *s0, starts[last] + sl.length_mm()));
        k += n;
    }
    Ok(out)
}

/// Optimize the program `text` (named `file`) whose path through its stock is `path` (the
/// same program, interpreted by [`ProgramPath::build`]), with `air_feed(tool)` the air feed
/// of tool `tool` (mm/min).
pub fn optimize(
    file: &str,
    text: &str,
    path: &ProgramPath,
    p: &OptimizeParams,
    air_feed: &dyn Fn(u32) -> f64,
) -> Result<Optimized, OptimizeError> {
    let (lo, hi) = MIN_SEGMENT_RANGE_MM;
    if !(p.min_segment_mm.is_finite() && (lo..=hi).contains(&p.min_segment_mm)) {
        return Err(OptimizeError::Range {
            name: "--min-segment".into(),
            value: p.min_segment_mm,
            allowed: format!("{lo} ..= {hi} mm"),
        });
    }
    if !(p.max_feed_mm_min.is_finite() && p.max_feed_mm_min > 0.0) {
        return Err(OptimizeError::Range {
            name: "rapid rate".into(),
            value: p.max_feed_mm_min,
            allowed: "> 0 mm/min".into(),
        });
    }
    let intervals = path.intervals(&p.plan);
    let ranges = call_ranges(file, path)?;
    // Path positions of the plunge steps: the force law does not cover them.
    let plunges: Vec<f64> = path
        .steps()
        .iter()
        .filter(|(_, s)| s.kind == acc_stock::StepKind::Plunge)
        .map(|(x, _)| *x)
        .collect();
    let plunging = |a: f64, b: f64| {
        let k = plunges.partition_point(|x| *x < a);
        plunges.get(k).is_some_and(|x| *x <= b)
    };
    let calls = path.calls();
    // Feed calls with their intervals' feeds, in path order.
    let mut feed_calls: Vec<FeedCall<'_>> = Vec::new();
    let mut j = 0;
    for (i, a, b) in ranges {
        let call = &calls[i];
        let mut ivs = Vec::new();
        while j < intervals.len() && 0.5 * (intervals[j].a + intervals[j].b) < b {
            let iv = &intervals[j];
            j += 1;
            if iv.rapid || iv.b <= a {
                continue;
            }
            let air = air_feed(iv.tool).min(p.max_feed_mm_min);
            let feed = if plunging(iv.a, iv.b) {
                iv.feed.min(interval_feed(iv, p, air, air))
            } else {
                interval_feed(iv, p, air, air)
            };
            ivs.push(Piece {
                a: iv.a.max(a),
                b: iv.b.min(b),
                feed,
            });
        }
        if matches!(call.call, Canon::Feed { .. } | Canon::Arc { .. }) && !ivs.is_empty() {
            feed_calls.push(FeedCall {
                call,
                a,
                b,
                pieces: ivs,
            });
        }
    }
    // Motion calls per line: a line is split only when it made exactly one motion.
    let mut motions_per_line: std::collections::HashMap<u32, usize> = Default::default();
    for c in calls.iter().filter(|c| c.call.end().is_some()) {
        *motions_per_line.entry(c.line).or_default() += 1;
    }
    let lines: Vec<&str> = text.lines().collect();
    let mut edits: std::collections::BTreeMap<u32, Vec<String>> = Default::default();
    let mut lowest: std::collections::BTreeMap<u32, (f64, bool)> = Default::default();
    let mut out = Optimized {
        text: String::new(),
        lines_rewritten: 0,
        lines_split: 0,
        lines_added: 0,
        kept_whole: 0,
        added_numbers: None,
    };
    for mut fc in feed_calls {
        let line_no = fc.call.line;
        let Some(raw) = lines.get(line_no.saturating_sub(1) as usize) else {
            continue;
        };
        let words = acc_nc::line_words(file, line_no, raw)?;
        let arc = matches!(fc.call.call, Canon::Arc { .. });
        fc.pieces = pieces(&fc.pieces, p.min_segment_mm);
        let single = motions_per_line.get(&line_no) == Some(&1);
        let comp = fc.call.modes.cutter_comp;
        if single && !comp && fc.pieces.len() > 1 && splittable(raw, &words, arc) {
            let (first, rest) = piece_words(&fc);
            let mut drop = vec!['X', 'Y', 'Z', 'I', 'J', 'K', 'R', 'F'];
            if arc {
                drop.push('P');
            }
            let mut new = vec![rewrite_line(raw, &words, &drop, &first)];
            out.lines_added += rest.len();
            new.extend(rest);
            edits.insert(line_no, new);
            out.lines_split += 1;
            continue;
        }
        let low = fc
            .pieces
            .iter()
            .map(|q| q.feed)
            .fold(f64::INFINITY, f64::min);
        let varies = fc.pieces.len() > 1;
        let e = lowest.entry(line_no).or_insert((f64::INFINITY, false));
        e.0 = e.0.min(low);
        e.1 |= varies;
        let f = f_word(e.0, fc.call.modes.units);
        let new = rewrite_line(raw, &words, &['F'], &f);
        edits.insert(line_no, vec![new]);
    }
    out.kept_whole = lowest.values().filter(|(_, v)| *v).count();
    out.lines_rewritten = edits.len();
    let total = lines.len() + out.lines_added;
    let mut next_n = piece_numbers(file, text, total);
    // The added lines' numbers: their N words, or (without N words) the line numbers they
    // push the program's end to.
    let count = u32::try_from(out.lines_added).unwrap_or(u32::MAX);
    let (first, last) = match next_n {
        Some(first) => (first, first.saturating_add(count).saturating_sub(1)),
        None => {
            let last = u32::try_from(total).unwrap_or(u32::MAX);
            (last.saturating_sub(count).saturating_add(1), last)
        }
    };
    let fitted = u32::try_from(lines.len()).is_ok_and(|n| n <= MAX_BLOCK_NUMBER);
    if out.lines_added > 0 && last > MAX_BLOCK_NUMBER && (next_n.is_some() || fitted) {
        return Err(OptimizeError::Numbering {
            file: file.into(),
            count: out.lines_added,
            first,
            last,
        });
    }
    for (k, raw) in lines.iter().enumerate() {
        let n = u32::try_from(k + 1).unwrap_or(u32::MAX);
        match edits.get(&n) {
            Some(new) => {
                for (i, l) in new.iter().enumerate() {
                    if let (true, Some(num)) = (i > 0, next_n.as_mut()) {
                        let _ = write!(out.text, "N{num} ");
                        out.added_numbers = Some((out.added_numbers.map_or(*num, |r| r.0), *num));
                        *num = num.saturating_add(1);
                    }
                    out.text.push_str(l);
                    out.text.push('\n');
                }
            }
            None => {
                out.text.push_str(raw);
                out.text.push('\n');
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(a: f64, b: f64, feed: f64) -> Piece {
        Piece { a, b, feed }
    }

    #[test]
    fn levels_round_down_on_the_ladder() {
        for v in [1.0, 13.3, 200.0, 999.9, 3000.0] {
            let l = level(v);
            assert!(l <= v && l > v / LEVEL_RATIO - 1e-9, "{v} -> {l}");
        }
    }

    #[test]
    fn short_pieces_merge_into_the_nearer_feed_at_the_lower_feed() {
        // 0.4 mm at 500 between 300 and 480: grown to 1 mm into the 480 piece, at 480.
        let p = pieces(
            &[q(0.0, 5.0, 300.0), q(5.0, 5.4, 500.0), q(5.4, 9.0, 480.0)],
            1.0,
        );
        assert_eq!(p, vec![q(0.0, 5.0, 300.0), q(5.0, 9.0, 480.0)]);
        // 0.5 mm of cut at 200 before 30 mm of air at 3000: the air keeps its feed after
        // the first millimetre.
        let p = pieces(&[q(0.0, 0.5, 200.0), q(0.5, 30.5, 3000.0)], 1.0);
        assert_eq!(p, vec![q(0.0, 1.0, 200.0), q(1.0, 30.5, 3000.0)]);
        // A block shorter than the minimum stays one piece at its lowest feed.
        let p = pieces(&[q(0.0, 0.3, 300.0), q(0.3, 0.6, 100.0)], 1.0);
        assert_eq!(p, vec![q(0.0, 0.6, 100.0)]);
    }

    #[test]
    fn added_lines_are_numbered_above_every_n_word_of_the_text() {
        // N9000 runs nothing (a comment line) and still counts; so does the line count.
        let text = "N10 G1 X1 F100\nN9000 (no motion)\nG1 X2\n";
        assert_eq!(piece_numbers("t.ngc", text, 5), Some(9001));
        assert_eq!(piece_numbers("t.ngc", "N10 G1 X1\n", 20_000), Some(20_001));
        assert_eq!(piece_numbers("t.ngc", "G1 X1\nG1 X2\n", 5), None);
    }

    #[test]
    fn arcs_in_xz_and_yz_split_with_their_planes_centre_words() {
        let setup = acc_nc::Setup::default();
        for (plane, text) in [
            ("G18", "G21 G18 G0 X10 Y3 Z0\nG2 X0 Y5 Z10 I-10 K0 F100\n"),
            ("G19", "G21 G19 G0 X3 Y10 Z0\nG3 X5 Y0 Z10 J-10 K0 F100\n"),
        ] {
            let p = acc_nc::interpret("a.ngc", text, &setup).expect("ok");
            let call = p.calls.last().expect("the arc");
            let len = call.call.length_mm();
            let fc = FeedCall {
                call,
                a: 0.0,
                b: len,
                pieces: vec![q(0.0, len / 3.0, 100.0), q(len / 3.0, len, 200.0)],
            };
            let (first, rest) = piece_words(&fc);
            let code = if plane == "G18" { "G2" } else { "G3" };
            let split = format!(
                "{}\n{code} {first}\n{}\n",
                text.lines().next().unwrap_or(""),
                rest.join("\n")
            );
            let q = acc_nc::interpret("b.ngc", &split, &setup).expect("split parses");
            let arcs: Vec<_> = q.calls.iter().filter(|c| c.call.end().is_some()).collect();
            assert_eq!(arcs.len(), 3, "{split}");
            let end = arcs[2].call.end().expect("end");
            let want = call.call.end().expect("end");
            assert!((0..3).all(|k| (end[k] - want[k]).abs() < 1e-5), "{split}");
            let mid = arcs[1].call.end().expect("end");
            let on = call.call.point_at(1.0 / 3.0).expect("point");
            assert!((0..3).all(|k| (mid[k] - on[k]).abs() < 1e-5), "{split}");
            assert!(
                (arcs[1].call.length_mm() + arcs[2].call.length_mm() - len).abs() < 1e-4,
                "{split}"
            );
        }
    }

    #[test]
    fn lines_keep_their_other_words_and_comments() {
        let raw = "N30 G1 X20 Y10 F300 M8 (cut) ; end";
        let w = acc_nc::line_words("a.ngc", 1, raw).expect("parses");
        let out = rewrite_line(raw, &w, &['X', 'Y', 'F'], "X5 Y2.5 Z0 F120");
        assert_eq!(out, "N30 G1 M8 X5 Y2.5 Z0 F120 (cut) ; end");
        assert_eq!(f_word(123.456, Units::Mm), "F123.4");
        assert_eq!(f_word(254.0, Units::Inch), "F10");
        assert_eq!(num(-0.00000001, 6), "0");
    }
}
