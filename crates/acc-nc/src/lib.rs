//! `acc-nc`: the NC program interpreter.
//!
//! An NC program (RS274/NGC and the common Fanuc milling words) goes in; a stream of
//! canonical machining calls ([`Canon`]) comes out, as LinuxCNC's canon: whatever consumes a
//! program (the plant, a stock model, the oracle test, `acc nc`) reads that stream, never
//! the text. Positions are in mm in work coordinates, feeds in mm/min; every call carries
//! its source line and N number ([`CanonCall`]).
//!
//! Layers, as gcode-rs: the lexer (one line into words, each with its line and column) is
//! apart from the modal state machine ([`interpret`]); canned cycles G81–G83, O-word
//! subroutines and cutter radius compensation (G41/G42, as LinuxCNC computes it) happen
//! inside the state machine, so consumers see only traverses, feeds, arcs (in the plane of
//! G17/G18/G19, [`Plane`]) and dwells. [`Program::path`] linearizes the path into
//! straight pieces ([`PathSegment`]) within a chord tolerance; [`Program::summary`] totals
//! it.
//!
//! ```
//! use acc_nc::{interpret, Canon, Setup};
//! let text = "%\nG21 G17 G90\nN10 G0 X0 Y0 Z5\nN20 G1 Z-1 F100\nN30 G2 X20 R10\nM30\n%\n";
//! let p = interpret("slot.ngc", text, &Setup::default()).unwrap();
//! let arc = p.calls.iter().find(|c| matches!(c.call, Canon::Arc { .. })).unwrap();
//! assert_eq!(arc.block, Some(30));
//! if let Canon::Arc { center, to, .. } = arc.call {
//!     assert!((center[0] - 10.0).abs() < 1e-9 && center[1].abs() < 1e-9);
//!     assert_eq!(to, [20.0, 0.0, -1.0]);
//! }
//! let s = p.summary();
//! assert!((s.feed_length_mm - (6.0 + std::f64::consts::PI * 10.0)).abs() < 1e-9);
//! ```
//!
//! What is supported and refused, and the oracle test against LinuxCNC's `rs274`:
//! `docs/nc.md`.
#![deny(missing_docs)]

mod canon;
mod error;
mod expr;
mod interp;
mod lexer;
mod path;
mod tools;
mod words;

pub use canon::{shared_block_numbers, Canon, CanonCall, Modes, Plane, Units};
pub use error::{ErrorKind, NcError, Span};
pub use interp::interpret;
pub use path::{arc_angles, PathSegment, Summary};
pub use tools::{parse_work_offsets_var, Setup, ToolEntry, ToolTable};
pub use words::{line_words, LineWords, WordAt};

/// An interpreted program: its canonical calls in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// The file name the program was interpreted under.
    pub file: String,
    /// The canonical calls, in execution order.
    pub calls: Vec<CanonCall>,
}

/// Reads and interprets the program at `path` (errors name the file as given).
pub fn interpret_file(path: &std::path::Path, setup: &Setup) -> Result<Program, NcError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| NcError {
        file: name.clone(),
        span: Span { line: 0, column: 0 },
        word: String::new(),
        kind: ErrorKind::Missing {
            what: format!("a readable file ({e})"),
        },
    })?;
    interpret(&name, &String::from_utf8_lossy(&bytes), setup)
}
