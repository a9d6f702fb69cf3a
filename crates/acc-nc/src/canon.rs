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
    /// Circular or helical feed move in the XY plane (G2/G3; as ARC_FEED).
    Arc {
        /// Start, work coordinates, mm.
        from: [f64; 3],
        /// End, work coordinates, mm; `to[2]` is the end on the helix axis (Z).
        to: [f64; 3],
        /// Centre (x, y), work coordinates, mm.
        center: [f64; 2],
        /// G2: true (clockwise seen from +Z); G3: false.
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
    /// G90.1 (absolute arc centre I J): true; G91.1 (centre relative to the start, the
    /// default): false.
    pub arc_absolute: bool,
}

impl CanonCall {
    /// The block number a board reports (BLOCK_NUMBER): the N word, else the line number.
    pub fn block_number(&self) -> u32 {
        self.block.unwrap_or(self.line)
    }
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
