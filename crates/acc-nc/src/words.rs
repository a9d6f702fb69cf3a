//! The words of one program line and where they stand in its text: for a tool that
//! rewrites a program's words in place (`acc optimize` rewrites F words and splits motion
//! blocks) and must keep every other word, comment and parameter setting as written.

use crate::error::NcError;
use crate::lexer::parse_line;

/// One word of a line.
#[derive(Debug, Clone, PartialEq)]
pub struct WordAt {
    /// The letter, upper case.
    pub letter: char,
    /// Character index (0-based) in the line where the word starts.
    pub start: usize,
    /// Character index one past the word's last character.
    pub end: usize,
    /// The word's value when it reads no parameter (a number or an expression of
    /// numbers); `None` when it reads one.
    pub constant: Option<f64>,
}

/// The words of a line.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineWords {
    /// The words in order (the N number is not one).
    pub words: Vec<WordAt>,
    /// The line's N number, if it has one.
    pub n: Option<u32>,
    /// The line sets parameters (`#1=…`, applied after the line).
    pub assigns: bool,
    /// The line is an O word (`o100 sub`, `o100 call`, …).
    pub oword: bool,
}

impl LineWords {
    /// The constant values of the words with `letter` (a word that reads a parameter is
    /// `None`).
    pub fn values(&self, letter: char) -> impl Iterator<Item = Option<f64>> + '_ {
        self.words
            .iter()
            .filter(move |w| w.letter == letter)
            .map(|w| w.constant)
    }
}

/// The words of line `number` (1-based, for errors) of `file`, text `text`.
///
/// ```
/// let w = acc_nc::line_words("a.ngc", 3, "N30 G1 X[2*5] Y#1 F300 (cut)").unwrap();
/// let letters: Vec<char> = w.words.iter().map(|w| w.letter).collect();
/// assert_eq!(letters, vec!['G', 'X', 'Y', 'F']);
/// assert_eq!(w.n, Some(30));
/// assert_eq!(w.words[1].constant, Some(10.0));
/// assert_eq!(w.words[2].constant, None);
/// let f = &w.words[3];
/// assert_eq!(&"N30 G1 X[2*5] Y#1 F300 (cut)"[f.start..f.end], "F300");
/// ```
pub fn line_words(file: &str, number: u32, text: &str) -> Result<LineWords, NcError> {
    let line = parse_line(number, text).map_err(|e| e.in_file(file))?;
    let words = line
        .words
        .iter()
        .map(|w| WordAt {
            letter: w.letter,
            start: w.span.column.saturating_sub(1) as usize,
            end: w.end_column as usize,
            constant: w.value.constant(),
        })
        .collect();
    Ok(LineWords {
        words,
        n: line.n,
        assigns: !line.assigns.is_empty(),
        oword: line.oword.is_some(),
    })
}
