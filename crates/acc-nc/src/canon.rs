//! The interpreter's only output: canonical machining calls, as LinuxCNC's canon.
//!
//! Positions are in mm in the **work coordinate system** of the call (the program's
//! coordinates with G20 converted to mm): exactly the frame `rs274` prints its
//! STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED in. The offsets that lead to the machine
//! frame come in the same stream ([`Canon::WorkOffset`], [`Canon::ToolLengthOffset`]), so a
//! consumer that tracks them has the machine position: `machine = work + work offset +
//! (0, 0, tool length offset)`; [`crate::Program::path`] does this for the tool tip.

/// Length units of the program text (G20 / G21).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Units {
    /// Millimetres (G21), the default.
    #[default]
    Mm,
    /// Inches (G20): every length word is multiplied by 25.4 mm/in.
    Inch,
}

impl Units {
    /// Millimetres per unit: 1 for mm, 25.4 for inches.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Inch => 25.4,
        }
    }
}

/// The plane of arcs and cutter radius compensation (G17, G18, G19; as rs274's
/// SELECT_PLANE). Arcs are given in the plane's axis order, as rs274's ARC_FEED: XY is (X, Y)
/// about Z, XZ is (Z, X) about Y, YZ is (Y, Z) about X, so that in every plane a positive
/// turn is counter-clockwise seen from the positive end of the plane's normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Plane {
    /// G17: arcs in X and Y, helix along Z (the default).
    #[default]
    Xy,
    /// G18: arcs in Z and X (first axis Z), helix along Y.
    Xz,
    /// G19: arcs in Y and Z, helix along X.
    Yz,
}

impl Plane {
    /// Indices into `[x, y, z]` of the plane's first axis, second axis and normal (the
    /// helix axis): XY `[0, 1, 2]`, XZ `[2, 0, 1]`, YZ `[1, 2, 0]`.
    pub fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Xz => [2, 0, 1],
            Plane::Yz => [1, 2, 0],
        }
    }

    /// The arc centre words on the plane's first axis, second axis and normal (the letters
    /// of the axes `I J K` stand for): XY `I J K`, XZ `K I J`, YZ `J K I`.
    pub fn centre_letters(self) -> [char; 3] {
        self.axes().map(|k| ['I', 'J', 'K'][k])
    }

    /// A point's coordinates on the plane's first and second axis.
    pub fn project(self, p: [f64; 3]) -> [f64; 2] {
        let [a, b, _] = self.axes();
        [p[a], p[b]]
    }

    /// The point `[x, y, z]` with `uv` on the plane's first and second axis and `w` along its
    /// normal.
    pub fn point(self, uv: [f64; 2], w: f64) -> [f64; 3] {
        let [a, b, n] = self.axes();
        let mut p = [0.0; 3];
        p[a] = uv[0];
        p[b] = uv[1];
        p[n] = w;
        p
    }

    /// The G code that selects the plane (`G17`, `G18`, `G19`).
    pub fn code(self) -> &'static str {
        match self {
            Plane::Xy => "G17",
            Plane::Xz => "G18",
            Plane::Yz => "G19",
        }
    }
}

/// One canonical call.
#[derive(Debug, Clone, PartialEq)]
pub enum Canon {
    /// Length units of the following words changed (G20/G21; emitted whenever one is
    /// programmed, as rs274's USE_LENGTH_UNITS).
    Units {
        /// The new units.
        units: Units,
    },
    /// The active work coordinate system (G54 … G59) and its offset (emitted at the start
    /// and on every change; as rs274's SET_G5X_OFFSET).
    WorkOffset {
        /// 1 = G54 … 6 = G59.
        index: u8,
        /// Offset of the work origin in the machine frame, mm (x, y, z).
        offset_mm: [f64; 3],
    },
    /// Tool length offset along Z (G43 / G43 H / G49; as USE_TOOL_LENGTH_OFFSET), mm.
    ToolLengthOffset {
        /// The offset, mm (0 after G49).
        z_mm: f64,
    },
    /// Programmed feed rate (an F word; as SET_FEED_RATE).
    FeedRate {
        /// The feed rate, mm/min.
        feed_mm_min: f64,
        /// The F value as written, in program units per minute (mm/min or in/min).
        programmed: f64,
    },
    /// Programmed spindle speed (an S word; as SET_SPINDLE_SPEED), rev/min.
    SpindleSpeed {
        /// Speed, rev/min.
        rpm: f64,
    },
    /// Spindle on (M3 clockwise, M4 counter-clockwise) at the programmed speed.
    SpindleOn {
        /// Speed, rev/min.
        rpm: f64,
        /// M3: true; M4: false.
        clockwise: bool,
    },
    /// Spindle off (M5).
    SpindleOff,
    /// Tool change to `tool` (T… M6; as CHANGE_TOOL). Preceded by [`Canon::SpindleOff`]:
    /// the spindle stays off until the next M3/M4.
    ToolChange {
        /// The new tool number (0 = no tool).
        tool: u32,
    },
    /// Coolant on (M7 mist, M8 flood) or off (M9).
    Coolant {
        /// True for M7/M8, false for M9.
        on: bool,
    },
    /// Dwell (G4 P…), s.
    Dwell {
        /// Dwell time, s.
        seconds: f64,
    },
    /// Rapid move in a straight line (G0; as STRAIGHT_TRAVERSE). Not overridden.
    Traverse {
        /// Start, work coordinates, mm.
        from: [f64; 3],
        /// End, work coordinates, mm.
        to: [f64; 3],
    },
    /// Feed move in a straight line (G1; as STRAIGHT_FEED).
    Feed {
        /// Start, work coordinates, mm.
        from: [f64; 3],
        /// End, work coordinates, mm.
        to: [f64; 3],
        /// Programmed feed, mm/min.
        feed_mm_min: f64,
    },
    /// Circular or helical feed move in `plane` (G2/G3; as ARC_FEED).
    Arc {
        /// Start, work coordinates, mm.
        from: [f64; 3],
        /// End, work coordinates, mm (x, y, z; the coordinate along the plane's normal is
        /// the helix end).
        to: [f64; 3],
        /// Centre on the plane's first and second axis ([`Plane::axes`]: (x, y) in G17,
        /// (z, x) in G18, (y, z) in G19), work coordinates, mm.
        center: [f64; 2],
        /// The plane of the arc.
        plane: Plane,
        /// G2: true (clockwise seen from the positive end of the plane's normal); G3: false.
        clockwise: bool,
        /// Number of turns (1 = up to the end point the short way in the given direction,
        /// or one full circle when the end equals the start; `P` adds turns).
        turns: u32,
        /// Programmed feed, mm/min.
        feed_mm_min: f64,
    },
    /// Program pause (M0, M1 optional stop).
    Pause {
        /// M1: true.
        optional: bool,
    },
    /// Program end (M2; M30 also rewinds). Nothing follows.
    End {
        /// M30: true.
        rewind: bool,
    },
}

/// A canonical call and where it comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct CanonCall {
    /// The call.
    pub call: Canon,
    /// Source line, 1-based (0 for the calls the interpreter makes at start).
    pub line: u32,
    /// The block's N number, if it has one.
    pub block: Option<u32>,
    /// The modes the block's words were read in (not part of rs274's canon: what a tool
    /// that rewrites the block's words needs, `acc optimize`).
    pub modes: Modes,
}

/// The modes that decide how a block's length words are read, as in force for its motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Modes {
    /// Length units (G20 / G21).
    pub units: Units,
    /// G90 (absolute axis words): true; G91 (incremental): false.
    pub absolute: bool,
    /// G90.1 (absolute arc centre I J K): true; G91.1 (centre relative to the start, the
    /// default): false.
    pub arc_absolute: bool,
    /// The plane (G17 / G18 / G19): which words give an arc's centre.
    pub plane: Plane,
    /// Cutter radius compensation shaped the motion: it was made while G41/G42 was in force
    /// (its end, or its start, moved by the compensation, or an arc added at a corner), or
    /// it is the move after G40 that starts from the compensated end. Its path is not the
    /// programmed one, and changing its block's words can change the neighbours' paths.
    pub cutter_comp: bool,
}

impl CanonCall {
    /// The block number a board reports (BLOCK_NUMBER): the N word, else the line number.
    pub fn block_number(&self) -> u32 {
        self.block.unwrap_or(self.line)
    }
}

/// Block numbers that name motions of more than one program line, as a board reports them
/// (`BLOCK_NUMBER`, a 16-bit register: [`CanonCall::block_number`]'s low 16 bits), each with
/// its lines in order; sorted by number. A program whose N words repeat (numbered in tens
/// up to N9990 and again from N1, or copied blocks) gives the board's block number more than
/// one meaning, and whatever places the tool by it (the plan's look-ahead) can only tell the
/// visits apart by the path position. A line run more than once (a subroutine) is one line.
///
/// ```
/// use acc_nc::{interpret, shared_block_numbers, Setup};
/// // N10 twice; line 4 has no N word, so the board reports its line number, 4.
/// let text = "G21 G90\nN10 G0 X0 Y0\nN4 G1 X5 F100\nG1 X6\nN10 G1 X10\nM2\n";
/// let p = interpret("twice.ngc", text, &Setup::default()).unwrap();
/// assert_eq!(shared_block_numbers(&p.calls), vec![(4, vec![3, 4]), (10, vec![2, 5])]);
/// ```
pub fn shared_block_numbers(calls: &[CanonCall]) -> Vec<(u16, Vec<u32>)> {
    let mut lines: std::collections::BTreeMap<u16, std::collections::BTreeSet<u32>> =
        std::collections::BTreeMap::new();
    for c in calls.iter().filter(|c| c.call.end().is_some()) {
        lines
            .entry((c.block_number() & 0xFFFF) as u16)
            .or_default()
            .insert(c.line);
    }
    lines
        .into_iter()
        .filter(|(_, l)| l.len() > 1)
        .map(|(n, l)| (n, l.into_iter().collect()))
        .collect()
}

impl Canon {
    /// End point of a motion (work coordinates, mm); `None` for other calls.
    pub fn end(&self) -> Option<[f64; 3]> {
        match self {
            Canon::Traverse { to, .. } | Canon::Feed { to, .. } | Canon::Arc { to, .. } => {
                Some(*to)
            }
            _ => None,
        }
    }

    /// Short name of the call (`traverse`, `feed`, `arc-cw`, …) for tables.
    pub fn kind(&self) -> &'static str {
        match self {
            Canon::Units { .. } => "units",
            Canon::WorkOffset { .. } => "work-offset",
            Canon::ToolLengthOffset { .. } => "tool-length",
            Canon::FeedRate { .. } => "feed-rate",
            Canon::SpindleSpeed { .. } => "spindle-speed",
            Canon::SpindleOn { .. } => "spindle-on",
            Canon::SpindleOff => "spindle-off",
            Canon::ToolChange { .. } => "tool-change",
            Canon::Coolant { .. } => "coolant",
            Canon::Dwell { .. } => "dwell",
            Canon::Traverse { .. } => "traverse",
            Canon::Feed { .. } => "feed",
            Canon::Arc {
                clockwise: true, ..
            } => "arc-cw",
            Canon::Arc { .. } => "arc-ccw",
            Canon::Pause { .. } => "pause",
            Canon::End { .. } => "end",
        }
    }
}
