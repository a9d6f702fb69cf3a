//! Where a controller's run log was on an NC program's path.
//!
//! A log of `acc run` under a CNC controller (LinuxCNC: `acc linuxcnc`, or a v2 board) has
//! no path position of its own that follows the program: its `x_mm` integrates the actual
//! feed through homing, tool changes and restarts. It has the block (`block`: the N word,
//! else the line, as `motion.program-line` reports it) and the controller's actual path
//! speed (`feed_mm_min`). [`BlockVisits::positions`] rebuilds each row's position on the
//! program's path ([`ProgramPath`]) from them: where the block changes it is the start of
//! the block's next visit (a subroutine, a loop or a repeat runs the same lines again; the
//! visit is the first one that starts where the row before left the tool or after it) plus
//! half the period's travel at the row's feed (the change fell somewhere in the period; one
//! period more when the read before found it and the line guard held it, flag
//! `unconfirmed:`), and inside a block the trapezoidal integral of the logged feed, held
//! within the block. `acc discrepancy --program` replays the model on the engagement there;
//! `acc plan --measured` compares the plan's force with the log's there.

use std::collections::BTreeMap;

use acc_runtime::record::RunRecord;

use crate::program::ProgramPath;

/// Where a block lies on the path.
#[derive(Debug, Clone, Copy)]
struct Span {
    start_mm: f64,
    end_mm: f64,
    rapid: bool,
}

/// Every visit of each block of a program's path, in path order.
#[derive(Debug, Clone)]
pub struct BlockVisits {
    /// The visits of each block (the N word, else the line).
    blocks: BTreeMap<u32, Vec<Span>>,
}

/// One row's place on the path ([`BlockVisits::positions`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPlace {
    /// Path position, mm.
    pub at_mm: f64,
    /// The tool rapids or stands there: a rapid's block, or at its block's end (in
    /// exact-path mode, `G61`, the planner comes to rest at every block's end).
    pub stands: bool,
}

/// How far before the position a visit of the next block may start, mm: the rebuilt
/// position stops at its block's end, which is where the next block starts.
const VISIT_TOLERANCE_MM: f64 = 1e-6;

impl BlockVisits {
    /// The visits of every block of `path`.
    pub fn of(path: &ProgramPath) -> Self {
        let mut blocks: BTreeMap<u32, Vec<Span>> = BTreeMap::new();
        let mut last: Option<u32> = None;
        for (s, &x0) in path.segments().iter().zip(path.piece_starts_mm()) {
            let b = s.block.unwrap_or(s.line);
            let end = x0 + s.length_mm();
            let visits = blocks.entry(b).or_default();
            match visits.last_mut() {
                // The next piece of the same visit (an arc's chords, a block's pieces).
                Some(v) if last == Some(b) => v.end_mm = v.end_mm.max(end),
                _ => visits.push(Span {
                    start_mm: x0,
                    end_mm: end,
                    rapid: s.rapid,
                }),
            }
            last = Some(b);
        }
        Self { blocks }
    }

    /// The visit of `block` that starts where the tool is or after it (`at_mm`, the path
    /// position before the block changed), the first such; the block's first visit when
    /// none does (the program was restarted).
    fn next_visit(&self, block: u32, at_mm: f64) -> Option<&Span> {
        let visits = self.blocks.get(&block)?;
        visits
            .iter()
            .find(|v| v.start_mm >= at_mm - VISIT_TOLERANCE_MM)
            .or_else(|| visits.first())
    }

    /// The place of every row of a controller's run log on the path (see the module).
    /// Rows before the first block of the program keep position 0.
    pub fn positions(&self, rows: &[RunRecord]) -> Vec<PathPlace> {
        let mut out = Vec::with_capacity(rows.len());
        let (mut s, mut block, mut rapid) = (0.0, None::<u32>, false);
        let mut span: Option<&Span> = None;
        for (k, r) in rows.iter().enumerate() {
            let v = r.feed_mm_min.unwrap_or(0.0) / 60.0;
            let dt = if k == 0 { 0.0 } else { r.t_s - rows[k - 1].t_s };
            let b = r.block.map(u32::from);
            if b != block {
                span = b.and_then(|b| self.next_visit(b, s));
            }
            match span {
                Some(sp) if b != block => {
                    // The line guard logs a new block one read late: the read before
                    // found it and held it (`unconfirmed:`).
                    let held = k > 0 && rows[k - 1].flags.contains("unconfirmed:");
                    let periods = if held { 1.5 } else { 0.5 };
                    s = (sp.start_mm + periods * v * dt).min(sp.end_mm);
                    rapid = sp.rapid;
                }
                Some(sp) => {
                    let v0 = rows[k - 1].feed_mm_min.unwrap_or(0.0) / 60.0;
                    s = (s + 0.5 * (v0 + v) * dt).clamp(sp.start_mm, sp.end_mm);
                }
                None => {}
            }
            block = b;
            let at_end = span.is_some_and(|sp| s >= sp.end_mm - 1e-9);
            out.push(PathPlace {
                at_mm: s,
                stands: rapid || at_end,
            });
        }
        out
    }
}
