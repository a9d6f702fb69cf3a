//! The modal state machine: blocks in, canonical calls out.
//!
//! Each block runs in RS274/NGC order (LinuxCNC's `execute_block`): feed mode, F, S, T, M6,
//! spindle, coolant, dwell, plane, units, cutter compensation, tool length offset, work
//! offset, path control, distance modes, motion, then stops (M0/M1/M2/M30). Parameter
//! settings on a line take effect after the line. Arcs (`arcs.rs`) are in the plane of
//! G17/G18/G19; cutter radius compensation (`comp.rs`) holds each compensated move back
//! until the next one decides its end.

use crate::canon::{Canon, CanonCall, Plane, Units};
use crate::error::{At, ErrorKind, NcError, Span};
use crate::expr::Params;
use crate::lexer::{parse_line, Line, Word};
use crate::tools::Setup;
use crate::Program;

mod arcs;
mod comp;
mod cycles;
mod flow;
mod plane_geometry;
use flow::{Flow, MAX_BLOCKS};

/// Interprets the program `text` (named `file` in errors) with `setup`: the canonical
/// calls, or the first error (file:line:column, the word, what is allowed).
///
/// ```
/// use acc_nc::{interpret, Canon, Setup};
/// let p = interpret("demo.ngc", "G21 G90\nG0 X10 Y5\nG1 Z-1 F200\nM2\n", &Setup::default())
///     .unwrap();
/// let ends: Vec<_> = p.calls.iter().filter_map(|c| c.call.end()).collect();
/// assert_eq!(ends, vec![[10.0, 5.0, 0.0], [10.0, 5.0, -1.0]]);
/// let err = interpret("bad.ngc", "G21\nG93 G1 X1\n", &Setup::default()).unwrap_err();
/// assert!(err.to_string().starts_with("bad.ngc:2:1: `G93`"));
/// ```
pub fn interpret(file: &str, text: &str, setup: &Setup) -> Result<Program, NcError> {
    let mut st = State::new(setup);
    st.run(text).map_err(|e| e.in_file(file))?;
    Ok(Program {
        file: file.to_string(),
        calls: st.out,
    })
}

/// A word's value, evaluated.
#[derive(Debug, Clone)]
struct Val {
    v: f64,
    span: Span,
    text: String,
}

impl Val {
    fn err(&self, kind: ErrorKind) -> At {
        At::new(self.span, self.text.clone(), kind)
    }
}

/// A block after evaluation: G and M codes (in tenths: G41.1 = 411) and the other words.
#[derive(Debug, Default)]
struct Block {
    g: Vec<(u16, Val)>,
    m: Vec<(u16, Val)>,
    words: Vec<(char, Val)>,
}

impl Block {
    fn word(&self, letter: char) -> Option<&Val> {
        self.words.iter().find(|w| w.0 == letter).map(|w| &w.1)
    }
    fn g_in(&self, codes: &[u16]) -> Option<(u16, &Val)> {
        self.g
            .iter()
            .find(|g| codes.contains(&g.0))
            .map(|g| (g.0, &g.1))
    }
    fn m_in(&self, codes: &[u16]) -> Option<(u16, &Val)> {
        self.m
            .iter()
            .find(|m| codes.contains(&m.0))
            .map(|m| (m.0, &m.1))
    }
}

/// Modal group of a supported G code (tenths), or the error for a refused/unknown one.
fn g_group(code: u16, val: &Val) -> Result<u8, At> {
    let refuse = |reason: &str| {
        Err(val.err(ErrorKind::Unsupported {
            reason: reason.into(),
        }))
    };
    Ok(match code {
        0 | 10 | 20 | 30 | 800 | 810 | 820 | 830 => 1,
        840..=890 => {
            return refuse(
                "canned cycles G84–G89 (tapping, boring); G81 G82 G83 are supported, \
                 or write the holes as G0/G1 moves",
            )
        }
        50 | 51 | 52 | 53 | 330 | 331 | 380..=389 | 730 | 760 | 761 => {
            return refuse("splines, threading, probing and lathe cycles; use G0 G1 G2 G3")
        }
        170 | 180 | 190 => 2,
        171 | 181 | 191 => {
            return refuse("the planes of the U V W axes (G17.1 G18.1 G19.1); use G17 G18 G19")
        }
        900 | 910 => 3,
        901 | 911 => 4,
        940 => 5,
        930 | 950 => {
            return refuse("inverse-time and per-revolution feed; only G94 (mm/min or in/min)")
        }
        200 | 210 => 6,
        400 | 410 | 420 | 411 | 421 => 7,
        430 | 490 => 8,
        431 | 432 => return refuse("dynamic tool length offsets; use G43 [H] and G49"),
        540 | 550 | 560 | 570 | 580 | 590 => 12,
        591..=593 => return refuse("work offsets G59.1–G59.3; use G54–G59"),
        610 | 611 | 640 => 13,
        980 | 990 => 10,
        40 => 0,
        100 | 280 | 281 | 300 | 301 | 530 | 920..=923 | 520 => {
            return refuse(
                "G10, G28, G30, G52, G53 and G92 (machine-frame moves and offset setting); \
                 work offsets come from the setup",
            )
        }
        _ => return Err(val.err(ErrorKind::UnknownCode)),
    })
}

/// Modal group of a supported M code.
fn m_group(code: u16, val: &Val) -> Result<u8, At> {
    Ok(match code {
        0 | 1 | 2 | 30 | 60 => 4,
        6 => 6,
        3..=5 => 7,
        7..=9 => 8,
        48 | 49 => 9,
        _ => return Err(val.err(ErrorKind::UnknownCode)),
    })
}

struct State<'a> {
    setup: &'a Setup,
    out: Vec<CanonCall>,
    /// Current position, work coordinates, mm.
    pos: [f64; 3],
    units: Units,
    absolute: bool,
    arc_absolute: bool,
    /// Modal motion (tenths: 0, 10, 20, 30); `None` after G80 and at start.
    motion: Option<u16>,
    feed_mm_min: f64,
    rpm: f64,
    tool: u32,
    selected: Option<u32>,
    tlo_mm: f64,
    coord: usize,
    params: Params,
    line: u32,
    n: Option<u32>,
    /// G98: canned cycles retract to the Z they started at (or R if higher); G99 (default):
    /// to R.
    retract_old_z: bool,
    cycle: cycles::CycleMemory,
    /// The plane of arcs and cutter compensation (G17 / G18 / G19).
    plane: Plane,
    /// Cutter radius compensation (G40 / G41 / G42) and its held-back moves.
    comp: comp::Comp,
    /// Where the tool is, work coordinates, mm: the end of the last motion given out, the
    /// start of the next. `pos` is the programmed position the next block's words are read
    /// from; the two differ only around cutter compensation.
    at: [f64; 3],
}

impl<'a> State<'a> {
    fn new(setup: &'a Setup) -> Self {
        State {
            setup,
            out: Vec::new(),
            pos: [0.0; 3],
            units: Units::Mm,
            absolute: true,
            arc_absolute: false,
            motion: None,
            feed_mm_min: 0.0,
            rpm: 0.0,
            tool: 0,
            selected: None,
            tlo_mm: 0.0,
            coord: 0,
            params: Params::default(),
            line: 0,
            n: None,
            retract_old_z: false,
            cycle: cycles::CycleMemory::default(),
            plane: Plane::Xy,
            comp: comp::Comp::default(),
            at: [0.0; 3],
        }
    }

    /// The call, made by the current block, with its modes.
    fn canon_call(&self, call: Canon) -> CanonCall {
        CanonCall {
            call,
            line: self.line,
            block: self.n,
            modes: crate::canon::Modes {
                units: self.units,
                absolute: self.absolute,
                arc_absolute: self.arc_absolute,
                plane: self.plane,
                cutter_comp: self.comp.shapes_motion(),
            },
        }
    }

    /// Gives out `call`, or queues it behind a compensated move that is held back (as
    /// LinuxCNC's interpreter queue), so that the calls keep their order.
    fn emit(&mut self, call: Canon) {
        let c = self.canon_call(call);
        if self.comp.holds_back() {
            self.comp.queue_other(c);
        } else {
            self.push_out(c);
        }
    }

    /// Appends `c` to the output; a motion starts where the tool is (`at`).
    fn push_out(&mut self, mut c: CanonCall) {
        if let Some(to) = c.call.end() {
            if let Canon::Traverse { from, .. }
            | Canon::Feed { from, .. }
            | Canon::Arc { from, .. } = &mut c.call
            {
                *from = self.at;
            }
            self.at = to;
        }
        self.out.push(c);
    }

    /// A traverse (`rapid`) or a feed at the feed in force from `pos` to `to`.
    fn line_to(&self, rapid: bool, to: [f64; 3]) -> Canon {
        let from = self.pos;
        if rapid {
            Canon::Traverse { from, to }
        } else {
            Canon::Feed {
                from,
                to,
                feed_mm_min: self.feed_mm_min,
            }
        }
    }

    /// Shifts the programmed and the tool position by `d` (an offset changed).
    fn shift(&mut self, d: [f64; 3]) {
        for (a, d) in d.into_iter().enumerate() {
            self.pos[a] += d;
            self.at[a] += d;
        }
    }

    fn run(&mut self, text: &str) -> Result<(), At> {
        self.emit(Canon::WorkOffset {
            index: 1,
            offset_mm: self.setup.work_offsets_mm[0],
        });
        let lines: Vec<&str> = text.lines().collect();
        let mut flow = Flow::default();
        let mut seen_code = false;
        let mut percent_open = false;
        let mut pc = 0;
        let mut steps = 0_u64;
        while let Some(raw) = lines.get(pc) {
            let number = u32::try_from(pc + 1).unwrap_or(u32::MAX);
            let line = parse_line(number, raw)?;
            steps += 1;
            if steps > MAX_BLOCKS {
                return Err(At::new(
                    Span {
                        line: number,
                        column: 1,
                    },
                    raw.trim(),
                    ErrorKind::Range {
                        allowed: format!(
                            "at most {MAX_BLOCKS} executed blocks (endless recursion?)"
                        ),
                    },
                ));
            }
            if line.percent {
                if !seen_code && !percent_open {
                    percent_open = true;
                    pc += 1;
                    continue;
                }
                break;
            }
            if !raw.trim().is_empty() {
                seen_code = true;
            }
            self.line = number;
            self.n = line.n;
            if let Some(o) = &line.oword {
                pc = self.oword(o, pc, &lines, &mut flow)?;
                continue;
            }
            if self.block(&line)? {
                break;
            }
            pc += 1;
        }
        // A move still held back (no M2) is given out as it is.
        self.comp_dequeue();
        Ok(())
    }

    /// Runs one line; `Ok(true)` at program end (M2/M30).
    fn block(&mut self, line: &Line) -> Result<bool, At> {
        let b = self.evaluate(&line.words)?;
        // Parameter settings are evaluated with the old values and applied after the line.
        let mut sets = Vec::with_capacity(line.assigns.len());
        for a in &line.assigns {
            let err =
                |d: String| At::new(a.span, a.text.clone(), ErrorKind::Expression { detail: d });
            let v = a.value.eval(&self.params).map_err(err)?;
            let target = match &a.param {
                crate::expr::Param::Numbered(e) => Ok(self.params.index(e).map_err(err)?),
                crate::expr::Param::Named(n) => Err(n.clone()),
            };
            sets.push((target, v));
        }
        let end = self.execute(&b)?;
        for (target, v) in sets {
            match target {
                Ok(i) => self.params.numbered.insert(i, v),
                Err(n) => self.params.named.insert(n, v),
            };
        }
        Ok(end)
    }

    /// Evaluates the words and checks letters, codes and modal groups.
    fn evaluate(&self, words: &[Word]) -> Result<Block, At> {
        let mut b = Block::default();
        let mut g_groups: Vec<(u8, u16)> = Vec::new();
        let mut m_groups: Vec<(u8, u16)> = Vec::new();
        for w in words {
            let v = w.value.eval(&self.params).map_err(|d| {
                At::new(w.span, w.text.clone(), ErrorKind::Expression { detail: d })
            })?;
            let val = Val {
                v,
                span: w.span,
                text: w.text.clone(),
            };
            match w.letter {
                'G' | 'M' => {
                    let tenths = (v * 10.0).round();
                    let whole = w.letter == 'M' && tenths % 10.0 != 0.0;
                    if (v * 10.0 - tenths).abs() > 1e-6
                        || !(0.0..=9999.0).contains(&tenths)
                        || whole
                    {
                        return Err(val.err(ErrorKind::UnknownCode));
                    }
                    let code = tenths as u16;
                    let (groups, group) = if w.letter == 'G' {
                        (&mut g_groups, g_group(code, &val)?)
                    } else {
                        (&mut m_groups, m_group(code / 10, &val)?)
                    };
                    // G80 beside another motion code is dropped (LinuxCNC and Fanuc
                    // headers such as `G00 G17 G40 G49 G80 G90`).
                    if w.letter == 'G' && group == 1 {
                        if code == 800 && groups.iter().any(|(g, _)| *g == 1) {
                            continue;
                        }
                        if let Some(k) = b.g.iter().position(|g| g.0 == 800) {
                            b.g.remove(k);
                            groups.retain(|(g, _)| *g != 1);
                        }
                    }
                    if let Some((_, other)) = groups.iter().find(|(g, _)| *g == group) {
                        let (l, o) = (w.letter, f64::from(*other) / 10.0);
                        return Err(val.err(ErrorKind::Conflict {
                            what: format!("{l}{o} and {} are in one modal group", val.text),
                        }));
                    }
                    groups.push((group, code));
                    if w.letter == 'G' {
                        b.g.push((code, val));
                    } else {
                        b.m.push((code / 10, val));
                    }
                }
                'D' | 'F' | 'H' | 'I' | 'J' | 'K' | 'P' | 'Q' | 'R' | 'S' | 'T' | 'X' | 'Y'
                | 'Z' => {
                    if b.word(w.letter).is_some() {
                        return Err(val.err(ErrorKind::Conflict {
                            what: format!("{} given twice in one block", w.letter),
                        }));
                    }
                    b.words.push((w.letter, val));
                }
                'L' => {
                    return Err(val.err(ErrorKind::Unsupported {
                        reason: "L (G10 and canned-cycle repeats are not supported)".into(),
                    }))
                }
                'A' | 'B' | 'C' | 'U' | 'V' | 'W' => {
                    return Err(val.err(ErrorKind::Unsupported {
                        reason: "rotary and extra axes; only X Y Z".into(),
                    }))
                }
                'N' => {
                    return Err(val.err(ErrorKind::Syntax {
                        expected: "the N number at the start of the line".into(),
                    }))
                }
                _ => return Err(val.err(ErrorKind::UnknownWord)),
            }
        }
        Ok(b)
    }

    fn missing(val: &Val, what: &str) -> At {
        val.err(ErrorKind::Missing { what: what.into() })
    }

    /// Executes one evaluated block; `Ok(true)` at program end.
    fn execute(&mut self, b: &Block) -> Result<bool, At> {
        let axes = ['X', 'Y', 'Z'].map(|l| b.word(l));
        let has_axis = axes.iter().any(Option::is_some);
        let arc_words = ['I', 'J', 'K', 'R'].map(|l| b.word(l));
        let explicit = b.g_in(&[0, 10, 20, 30, 800, 810, 820, 830]);
        let previous = self.motion;
        let motion = match explicit {
            Some((800, g)) if has_axis => {
                return Err(g.err(ErrorKind::Conflict {
                    what: "axis words with G80 (motion cancelled)".into(),
                }))
            }
            Some((800, _)) => None,
            Some((code, _)) => Some(code),
            None if has_axis || arc_words.iter().any(Option::is_some) => Some(
                self.modal_motion(
                    axes.iter()
                        .chain(arc_words.iter())
                        .flatten()
                        .next()
                        .copied(),
                )?,
            ),
            None => None,
        };
        let is_arc = matches!(motion, Some(20) | Some(30));
        let is_cycle = matches!(motion, Some(810) | Some(820) | Some(830));
        for (w, l) in arc_words.iter().zip(['I', 'J', 'K', 'R']) {
            if let (Some(w), false) = (w, is_arc || (l == 'R' && is_cycle)) {
                let users = if l == 'R' {
                    "G2, G3 or G81–G83"
                } else {
                    "G2 or G3"
                };
                return Err(Self::missing(w, &format!("{users} to use the {l} word")));
            }
        }
        let dwell = b.g_in(&[40]);
        let g64 = b.g_in(&[640]);
        if let Some(p) = b.word('P') {
            if dwell.is_none() && g64.is_none() && !is_arc && motion != Some(820) {
                return Err(Self::missing(p, "G4, G64, G2, G3 or G82 to use the P word"));
            }
        }
        if let Some(q) = b.word('Q') {
            if g64.is_none() && motion != Some(830) {
                return Err(Self::missing(q, "G64 or G83 to use the Q word"));
            }
        }
        if let (Some(h), None) = (b.word('H'), b.g_in(&[430])) {
            return Err(Self::missing(h, "G43 to use the H word"));
        }
        let block_units = match b.g_in(&[200, 210]) {
            Some((200, _)) => Units::Inch,
            Some(_) => Units::Mm,
            None => self.units,
        };
        if let Some(f) = b.word('F') {
            if f.v < 0.0 {
                return Err(f.err(ErrorKind::Range {
                    allowed: "F >= 0".into(),
                }));
            }
            self.feed_mm_min = f.v * block_units.mm_per_unit();
            self.emit(Canon::FeedRate {
                feed_mm_min: self.feed_mm_min,
                programmed: f.v,
            });
        }
        if let Some(s) = b.word('S') {
            if s.v < 0.0 {
                return Err(s.err(ErrorKind::Range {
                    allowed: "S >= 0 rev/min".into(),
                }));
            }
            self.rpm = s.v;
            self.emit(Canon::SpindleSpeed { rpm: s.v });
        }
        if let Some(t) = b.word('T') {
            let tool = self.tool_number(t)?;
            self.selected = Some(tool);
        }
        if let Some((_, m6)) = b.m_in(&[6]) {
            self.comp_refuses(m6, "a tool change (M6)")?;
            let tool = self.selected.unwrap_or(self.tool);
            self.tool = tool;
            // A tool change stops the spindle (rs274: STOP_SPINDLE_TURNING, CHANGE_TOOL).
            self.emit(Canon::SpindleOff);
            self.emit(Canon::ToolChange { tool });
        }
        match b.m_in(&[3, 4, 5]) {
            Some((5, _)) => self.emit(Canon::SpindleOff),
            Some((m, _)) => self.emit(Canon::SpindleOn {
                rpm: self.rpm,
                clockwise: m == 3,
            }),
            None => {}
        }
        if let Some((m, _)) = b.m_in(&[7, 8, 9]) {
            self.emit(Canon::Coolant { on: m != 9 });
        }
        if let Some((_, g)) = dwell {
            let p = b
                .word('P')
                .ok_or_else(|| Self::missing(g, "P (dwell time, s) for G4"))?;
            if p.v < 0.0 {
                return Err(p.err(ErrorKind::Range {
                    allowed: "P >= 0 s".into(),
                }));
            }
            self.emit(Canon::Dwell { seconds: p.v });
        }
        if let Some((code, g)) = b.g_in(&[170, 180, 190]) {
            let plane = [Plane::Xy, Plane::Xz, Plane::Yz][usize::from(code - 170) / 10];
            if plane != self.plane {
                self.comp_refuses(g, "a change of plane")?;
            }
            self.plane = plane;
        }
        if let Some((code, g)) = b.g_in(&[200, 210]) {
            let units = if code == 200 { Units::Inch } else { Units::Mm };
            if units != self.units {
                self.comp_refuses(g, "a change of units")?;
            }
            self.units = units;
            self.emit(Canon::Units { units: self.units });
        }
        self.cutter_comp(b)?;
        if let Some((code, g)) = b.g_in(&[430, 490]) {
            self.comp_refuses(g, "a change of the tool length offset")?;
            let new = if code == 490 {
                0.0
            } else {
                let tool = match b.word('H') {
                    Some(h) => self.tool_number(h)?,
                    None => self.tool,
                };
                self.tool_length(tool, g)?
            };
            self.shift([0.0, 0.0, self.tlo_mm - new]);
            self.tlo_mm = new;
            self.emit(Canon::ToolLengthOffset { z_mm: new });
        }
        if let Some((code, g)) = b.g_in(&[540, 550, 560, 570, 580, 590]) {
            self.comp_refuses(g, "a change of work coordinate system")?;
            let idx = usize::from((code - 540) / 10);
            if idx != self.coord {
                let (old, new) = (
                    self.setup.work_offsets_mm[self.coord],
                    self.setup.work_offsets_mm[idx],
                );
                self.shift([0, 1, 2].map(|a| old[a] - new[a]));
                self.coord = idx;
                self.emit(Canon::WorkOffset {
                    index: idx as u8 + 1,
                    offset_mm: new,
                });
            }
        }
        if let Some((code, _)) = b.g_in(&[900, 910]) {
            self.absolute = code == 900;
        }
        if let Some((code, _)) = b.g_in(&[901, 911]) {
            self.arc_absolute = code == 901;
        }
        if let Some((code, _)) = b.g_in(&[980, 990]) {
            self.retract_old_z = code == 980;
        }
        if let Some((code, _)) = explicit {
            self.motion = if code == 800 { None } else { Some(code) };
            if !matches!(self.motion, Some(810 | 820 | 830)) {
                self.cycle.il_mm = None; // a series of cycle blocks ends
            }
        }
        if let Some(m) = motion {
            self.motion_block(m, b, explicit.map(|e| e.1), previous)?;
        }
        let stop = b.m_in(&[0, 1, 2, 30, 60]);
        if let Some((_, m)) = stop {
            // A stop gives out the move held back by compensation as it is.
            self.comp_flush_here(m)?;
        }
        Ok(match stop {
            Some((m @ (0 | 1 | 60), _)) => {
                self.emit(Canon::Pause { optional: m == 1 });
                false
            }
            Some((m, _)) => {
                self.emit(Canon::End { rewind: m == 30 });
                self.comp = comp::Comp::default();
                true
            }
            None => false,
        })
    }

    fn tool_number(&self, w: &Val) -> Result<u32, At> {
        let t = w.v.round();
        if (w.v - t).abs() > 1e-6 || !(0.0..=f64::from(u32::MAX - 1)).contains(&t) {
            return Err(w.err(ErrorKind::Range {
                allowed: "a whole tool number >= 0".into(),
            }));
        }
        let tool = t as u32;
        if tool != 0 && self.setup.tools.get(tool).is_none() {
            return Err(w.err(ErrorKind::ToolNotInTable { tool }));
        }
        Ok(tool)
    }

    fn tool_length(&self, tool: u32, at: &Val) -> Result<f64, At> {
        if tool == 0 {
            return Ok(0.0);
        }
        self.setup
            .tools
            .get(tool)
            .map(|e| e.length_mm)
            .ok_or_else(|| at.err(ErrorKind::ToolNotInTable { tool }))
    }

    /// The modal motion for a block with axis words but no motion code; `w` is its first
    /// axis word (for the error when G80 is active).
    fn modal_motion(&self, w: Option<&Val>) -> Result<u16, At> {
        self.motion.ok_or_else(|| match w {
            Some(w) => Self::missing(
                w,
                "a motion mode (G0 G1 G2 G3 G81 G82 G83) for the axis words (G80 is active)",
            ),
            None => At::new(
                Span {
                    line: self.line,
                    column: 1,
                },
                "",
                ErrorKind::Missing {
                    what: "a motion mode".into(),
                },
            ),
        })
    }

    /// The motion of a block (tenths: 0, 10, 20, 30, 810, 820, 830); `explicit` is its G
    /// word, if any; `previous` the motion mode before the block.
    fn motion_block(
        &mut self,
        m: u16,
        b: &Block,
        explicit: Option<&Val>,
        previous: Option<u16>,
    ) -> Result<(), At> {
        let f = self.units.mm_per_unit();
        // Words left out and G91 increments are read from the programmed point (which
        // cutter compensation keeps apart from the tool's).
        let base = self.comp.programmed().unwrap_or(self.pos);
        let mut to = base;
        for (a, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if let Some(w) = b.word(l) {
                to[a] = if self.absolute {
                    w.v * f
                } else {
                    base[a] + w.v * f
                };
            }
        }
        let at = explicit
            .or_else(|| {
                ['X', 'Y', 'Z', 'I', 'J', 'K', 'R']
                    .iter()
                    .find_map(|&l| b.word(l))
            })
            .cloned()
            .unwrap_or(Val {
                v: 0.0,
                span: Span {
                    line: self.line,
                    column: 1,
                },
                text: format!("G{}", m / 10),
            });
        let from = self.pos;
        if m != 0 && self.feed_mm_min <= 0.0 {
            return Err(at.err(ErrorKind::NoFeed));
        }
        if m >= 810 {
            if self.plane != Plane::Xy {
                return Err(at.err(ErrorKind::Unsupported {
                    reason: format!(
                        "canned cycles in {} ({}); only in G17",
                        arcs::plane_name(self.plane),
                        self.plane.code()
                    ),
                }));
            }
            self.comp_refuses(&at, "canned cycles")?;
            // A canned cycle is not the move after G40 (as rs274): that one is still to come
            // and must be straight.
            self.cycle(m, b, to, &at, previous)?;
            return Ok(());
        }
        let arc = m == 20 || m == 30;
        self.comp_allows_motion(arc, &at)?;
        if self.comp.active() {
            return self.comp_motion(m, b, to, &at);
        }
        let call = if arc {
            self.arc(m == 20, from, to, b, &at)?
        } else {
            self.line_to(m == 0, to)
        };
        self.emit(call);
        self.comp.exit_done();
        self.pos = to;
        Ok(())
    }
}
