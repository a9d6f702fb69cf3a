//! Canned drilling cycles G81 (drill), G82 (drill with dwell) and G83 (peck drill), as
//! LinuxCNC's `convert_cycle_xy` expands them into traverses, feeds and dwells.
//!
//! Per block, as LinuxCNC 2.9's `convert_cycle_xy` and `CYCLE_MACRO`: the initial level
//! IL is the Z where the series of cycle blocks began (kept until a non-cycle motion or
//! G80). If IL is below the R plane, a rapid up to R in place. Then a rapid to the hole's XY
//! — at the current height followed by a rapid down to R when the tool is above R, else at
//! the clearance height — the feed to the bottom (Z; G83 in pecks of Q with a full retract
//! to R and a rapid back to 0.010 in = 0.254 mm above the last depth; G82 dwells P s), and a
//! rapid to the clearance height: R after G99 (the default), IL (or R if higher) after G98.
//! R, Z, P and Q stay in force for the following blocks of the same cycle. In G91, R is
//! relative to IL and Z to R.

use super::{Block, State, Val};
use crate::canon::Canon;
use crate::error::{At, ErrorKind};

/// LinuxCNC's G83 rapid approach above the previous peck depth: 0.010 in = 0.254 mm.
const G83_RAPID_DELTA_MM: f64 = 0.254;
/// Most pecks per hole (a guard against a tiny Q).
const MAX_PECKS: f64 = 100_000.0;

/// The cycle in force: initial level, R and Z as programmed (mm; absolute or, in G91,
/// incremental), peck (mm) and dwell (s).
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct CycleMemory {
    /// Initial level IL, mm; `None` outside a series of cycle blocks.
    pub(super) il_mm: Option<f64>,
    r_mm: Option<f64>,
    z_mm: Option<f64>,
    q_mm: Option<f64>,
    p_s: Option<f64>,
}

impl State<'_> {
    fn rapid_to(&mut self, to: [f64; 3]) {
        self.emit(Canon::Traverse { from: self.pos, to });
        self.pos = to;
    }

    fn feed_to(&mut self, to: [f64; 3]) {
        let feed_mm_min = self.feed_mm_min;
        self.emit(Canon::Feed {
            from: self.pos,
            to,
            feed_mm_min,
        });
        self.pos = to;
    }

    /// One block of a canned cycle `m` (810, 820, 830) with the hole at `to` (x, y);
    /// `previous` is the motion mode before the block (R, Z, P, Q carry over within one
    /// cycle).
    pub(super) fn cycle(
        &mut self,
        m: u16,
        b: &Block,
        to: [f64; 3],
        at: &Val,
        previous: Option<u16>,
    ) -> Result<(), At> {
        let f = self.units.mm_per_unit();
        let same = previous == Some(m);
        let current = self.pos[2];
        let il = *self.cycle.il_mm.get_or_insert(current);
        let memory = if same {
            self.cycle
        } else {
            CycleMemory::default()
        };
        let r_word = match (b.word('R'), memory.r_mm) {
            (Some(w), _) => w.v * f,
            (None, Some(r)) => r,
            (None, None) => return Err(Self::missing(at, "R (retract plane) for the cycle")),
        };
        let z_word = match (b.word('Z'), memory.z_mm) {
            (Some(w), _) => w.v * f,
            (None, Some(z)) => z,
            (None, None) => return Err(Self::missing(at, "Z (hole bottom) for the cycle")),
        };
        let (r, bottom) = if self.absolute {
            (r_word, z_word)
        } else {
            (il + r_word, il + r_word + z_word)
        };
        if bottom > r {
            let w = b.word('Z').unwrap_or(at);
            return Err(w.err(ErrorKind::Range {
                allowed: format!("hole bottom Z ({bottom:.4} mm) at or below R ({r:.4} mm)"),
            }));
        }
        let p = match (b.word('P'), memory.p_s) {
            (Some(w), _) if w.v < 0.0 => {
                return Err(w.err(ErrorKind::Range {
                    allowed: "P >= 0 s".into(),
                }))
            }
            (Some(w), _) => Some(w.v),
            (None, p) => p,
        };
        let q = match (b.word('Q'), memory.q_mm) {
            (Some(w), _) if w.v <= 0.0 => {
                return Err(w.err(ErrorKind::Range {
                    allowed: "Q (peck depth) > 0".into(),
                }))
            }
            (Some(w), _) => Some(w.v * f),
            (None, q) => q,
        };
        if m == 820 && p.is_none() {
            return Err(Self::missing(at, "P (dwell at the bottom, s) for G82"));
        }
        let peck = match q {
            Some(q) if m == 830 => {
                if (r - bottom) / q > MAX_PECKS {
                    let w = b.word('Q').unwrap_or(at);
                    return Err(w.err(ErrorKind::Range {
                        allowed: format!("at most {MAX_PECKS} pecks per hole"),
                    }));
                }
                q
            }
            None if m == 830 => return Err(Self::missing(at, "Q (peck depth) for G83")),
            _ => 0.0,
        };
        self.cycle = CycleMemory {
            il_mm: Some(il),
            r_mm: Some(r_word),
            z_mm: Some(z_word),
            q_mm: q,
            p_s: p,
        };
        let (mut old_cc, mut current_cc) = (il, current);
        if old_cc < r {
            self.rapid_to([self.pos[0], self.pos[1], r]);
            old_cc = r;
            current_cc = r;
        }
        let clear = if self.retract_old_z { old_cc } else { r };
        let (x, y) = (to[0], to[1]);
        if current_cc > r {
            self.rapid_to([x, y, current_cc]);
            self.rapid_to([x, y, r]);
        } else {
            self.rapid_to([x, y, clear]);
            if clear > r {
                self.rapid_to([x, y, r]);
            }
        }
        if m == 830 {
            let mut depth = r - peck;
            while depth > bottom {
                self.feed_to([x, y, depth]);
                self.rapid_to([x, y, r]);
                self.rapid_to([x, y, depth + G83_RAPID_DELTA_MM]);
                depth -= peck;
            }
        }
        self.feed_to([x, y, bottom]);
        if let (820, Some(seconds)) = (m, p) {
            self.emit(Canon::Dwell { seconds });
        }
        self.rapid_to([x, y, clear]);
        Ok(())
    }
}
