//! Errors: every one names the file, the line and column, the word, and what is allowed.

use std::fmt;

/// A place in the program text: 1-based line and column (in characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// Line number, 1-based (the first line of the file is 1).
    pub line: u32,
    /// Column, 1-based, in characters from the start of the line.
    pub column: u32,
}

/// What went wrong (the structured part of an [`NcError`]).
#[derive(Debug, Clone, PartialEq)]
pub enum ErrorKind {
    /// The text does not follow the word syntax (a letter and a value, `#n=value`, ...).
    Syntax {
        /// What was expected at this place.
        expected: String,
    },
    /// A letter that is no word of the supported dialect (`E`, `A`, ...).
    UnknownWord,
    /// A G or M code that no interpreter knows.
    UnknownCode,
    /// A G or M code of RS274/NGC that this interpreter refuses (G84, G93, G28, ...).
    Unsupported {
        /// What the code does, and what is supported instead.
        reason: String,
    },
    /// Two codes of one modal group in one block (`G0 G1`), or a word given twice.
    Conflict {
        /// The modal group or the repeated word.
        what: String,
    },
    /// A word that needs another word (`I` without `G2`/`G3`, `G4` without `P`, ...).
    Missing {
        /// What is missing.
        what: String,
    },
    /// A feed move while the feed rate is zero (no `F` yet).
    NoFeed,
    /// An arc that cannot be cut: radii to start and end differ, radius too small for R,
    /// zero radius.
    BadArc {
        /// What is wrong, with the numbers (mm).
        detail: String,
    },
    /// A tool number that is not in the tool table.
    ToolNotInTable {
        /// The tool number asked for.
        tool: u32,
    },
    /// An expression that cannot be evaluated (division by zero, unknown parameter, ...).
    Expression {
        /// What failed.
        detail: String,
    },
    /// A value out of its allowed range (a negative feed, a dwell below zero, ...).
    Range {
        /// The allowed range.
        allowed: String,
    },
    /// Cutter radius compensation (G41/G42) cannot make this move or allow this word: an
    /// entry move not longer than the tool radius, a tool radius not less than the radius of
    /// an arc it is inside, a concave corner the tool cannot reach without gouging, a change
    /// of plane, units, offsets or tool while it is on, ...
    Compensation {
        /// What is wrong, with the numbers (mm).
        detail: String,
    },
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorKind::Syntax { expected } => write!(f, "syntax error: expected {expected}"),
            ErrorKind::UnknownWord => write!(
                f,
                "unknown word; supported words: D F G H I J K M N O P Q R S T X Y Z, \
                 #parameters and comments"
            ),
            ErrorKind::UnknownCode => write!(
                f,
                "unknown code; supported: G0 G1 G2 G3 G4 G17 G18 G19 G20 G21 G40 G41 G42 \
                 G41.1 G42.1 G43 G49 G54-G59 G61 G61.1 G64 G80 G81 G82 G83 G90 G91 G90.1 \
                 G91.1 G94 G98 G99, M0 M1 M2 M3 M4 M5 M6 M7 M8 M9 M30 M48 M49"
            ),
            ErrorKind::Unsupported { reason } => write!(f, "not supported: {reason}"),
            ErrorKind::Conflict { what } => write!(f, "conflict: {what}"),
            ErrorKind::Missing { what } => write!(f, "missing: {what}"),
            ErrorKind::NoFeed => write!(
                f,
                "feed move with zero feed rate: give F (> 0) on or before the first G1/G2/G3"
            ),
            ErrorKind::BadArc { detail } => write!(f, "bad arc: {detail}"),
            ErrorKind::ToolNotInTable { tool } => write!(
                f,
                "tool {tool} is not in the tool table (give one with the tool number, \
                 e.g. `--tools FILE.tbl`)"
            ),
            ErrorKind::Expression { detail } => write!(f, "expression: {detail}"),
            ErrorKind::Range { allowed } => write!(f, "out of range: allowed {allowed}"),
            ErrorKind::Compensation { detail } => {
                write!(f, "cutter radius compensation: {detail}")
            }
        }
    }
}

/// An error in an NC program: `file:line:column: word: what (and what is allowed)`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{}:{}: `{word}`: {kind}", span.line, span.column)]
pub struct NcError {
    /// The program's file name as given to the interpreter.
    pub file: String,
    /// Where the offending word starts.
    pub span: Span,
    /// The offending word as written (letters upper-cased, spaces removed), e.g. `G18`.
    pub word: String,
    /// What went wrong.
    pub kind: ErrorKind,
}

/// An error without the file name yet (the lexer and interpreter fill the file in last).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct At {
    pub span: Span,
    pub word: String,
    pub kind: ErrorKind,
}

impl At {
    pub(crate) fn new(span: Span, word: impl Into<String>, kind: ErrorKind) -> Self {
        At {
            span,
            word: word.into(),
            kind,
        }
    }

    pub(crate) fn in_file(self, file: &str) -> NcError {
        NcError {
            file: file.to_string(),
            span: self.span,
            word: self.word,
            kind: self.kind,
        }
    }
}
