//! The lexer and parser: one program line into its words, each with its span.
//!
//! As in RS274/NGC, spaces and tabs outside comments are ignored (`G0 Z 10` is `G0Z10`),
//! letters are case-insensitive, comments are `( … )` and everything after `;`. A line is
//! an optional block delete `/`, an optional `N` number, then words (`letter value`) and
//! parameter settings (`#n=value`, `#<name>=value`), or an O word. Values are numbers,
//! parameters, `[expr]` or functions (`sin[…]`, `atan[…]/[…]`, `exists[…]`). Nothing here
//! looks at what a word means: that is the interpreter's job.

use crate::error::{At, ErrorKind, Span};
use crate::expr::{BinOp, Expr, Func, Param};

/// Deepest nesting of `[` and unary operators a value may have (a guard against stack
/// exhaustion on hostile input).
const MAX_DEPTH: usize = 64;

/// One word: `letter value`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Word {
    /// The letter, upper case.
    pub letter: char,
    pub value: Expr,
    pub span: Span,
    /// The word as written, spaces removed, letters upper case (for error messages).
    pub text: String,
    /// Column (1-based, in characters) of the word's last character.
    pub end_column: u32,
}

/// A parameter setting `#…=value`, applied after the line is read.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Assign {
    pub param: Param,
    pub value: Expr,
    pub span: Span,
    pub text: String,
}

/// An O word: `O1000` alone (a Fanuc program number) or `o100 sub|call|…`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OWord {
    /// The O number or `<name>` as written (numbers without leading zeros).
    pub name: String,
    /// The keyword after the O number (`sub`, `call`, `if`, …); empty for a program number.
    pub keyword: String,
    /// The `[expr]` arguments after the keyword (`o100 call [1] [2]`).
    pub args: Vec<Expr>,
    /// Characters follow the keyword and its arguments.
    pub trailing: bool,
    pub span: Span,
    pub text: String,
}

/// One program line, parsed.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Line {
    /// Line number in the file, 1-based.
    pub number: u32,
    /// The line starts with `/` (block delete).
    pub block_delete: bool,
    /// The N number, if any.
    pub n: Option<u32>,
    pub words: Vec<Word>,
    pub assigns: Vec<Assign>,
    pub oword: Option<OWord>,
    /// The line is a lone `%`.
    pub percent: bool,
}

/// Parse line `number` (1-based) of the text.
pub(crate) fn parse_line(number: u32, text: &str) -> Result<Line, At> {
    let mut line = Line {
        number,
        ..Line::default()
    };
    if text.trim() == "%" {
        line.percent = true;
        return Ok(line);
    }
    let chars = strip(number, text)?;
    let mut p = Cursor {
        c: &chars,
        i: 0,
        line: number,
        depth: 0,
    };
    if p.peek() == Some('/') {
        line.block_delete = true;
        p.i += 1;
    }
    if p.peek() == Some('n') {
        let start = p.i;
        p.i += 1;
        let digits = p.take_while(|c| c.is_ascii_digit());
        let n = digits
            .parse::<u32>()
            .map_err(|_| p.err(start, "an N number (digits)"))?;
        line.n = Some(n);
    }
    if p.peek() == Some('o') {
        let start = p.i;
        p.i += 1;
        let name = if p.peek() == Some('<') {
            let name = p.take_while(|c| c != '>');
            if p.peek() != Some('>') {
                return Err(p.err(start, "`>` closing the O word name"));
            }
            p.i += 1;
            format!("{name}>")
        } else {
            let digits = p.take_while(|c| c.is_ascii_digit());
            match digits.parse::<u64>() {
                Ok(n) => n.to_string(),
                Err(_) => return Err(p.err(start, "an O number (digits) or O<name>")),
            }
        };
        let keyword = p.take_while(|c| c.is_ascii_alphabetic());
        let mut args = Vec::new();
        while keyword == "call" && p.peek() == Some('[') {
            args.push(p.bracket()?);
        }
        line.oword = Some(OWord {
            name,
            keyword,
            args,
            trailing: p.i < p.c.len(),
            span: p.span(start),
            text: p.text(start, p.c.len()),
        });
        return Ok(line);
    }
    while let Some(c) = p.peek() {
        let start = p.i;
        if c == '#' {
            let param = p.param()?;
            if p.peek() != Some('=') {
                return Err(p.err(start, "`=` after the parameter (a parameter setting)"));
            }
            p.i += 1;
            let value = p.value()?;
            line.assigns.push(Assign {
                param,
                value,
                span: p.span(start),
                text: p.text(start, p.i),
            });
        } else if c.is_ascii_alphabetic() {
            p.i += 1;
            let value = p.value()?;
            line.words.push(Word {
                letter: c.to_ascii_uppercase(),
                value,
                span: p.span(start),
                text: p.text(start, p.i),
                end_column: p.span(p.i.saturating_sub(1)).column,
            });
        } else {
            return Err(p.err(start, "a word (a letter and a value) or `#` parameter"));
        }
    }
    Ok(line)
}

/// The line without comments and blanks: each kept character (lower case) with its column.
fn strip(number: u32, text: &str) -> Result<Vec<(char, u32)>, At> {
    let mut out = Vec::with_capacity(text.len());
    let mut open: Option<u32> = None;
    for (i, c) in text.chars().enumerate() {
        let col = u32::try_from(i + 1).unwrap_or(u32::MAX);
        if open.is_some() {
            if c == ')' {
                open = None;
            }
            continue;
        }
        match c {
            '(' => open = Some(col),
            ';' => break,
            ' ' | '\t' | '\r' => {}
            c if c.is_ascii_graphic() => out.push((c.to_ascii_lowercase(), col)),
            _ => {
                return Err(At::new(
                    Span {
                        line: number,
                        column: col,
                    },
                    c.escape_default().to_string(),
                    ErrorKind::Syntax {
                        expected: "printable ASCII outside comments".into(),
                    },
                ))
            }
        }
    }
    if let Some(col) = open {
        return Err(At::new(
            Span {
                line: number,
                column: col,
            },
            "(",
            ErrorKind::Syntax {
                expected: "`)` closing the comment on the same line".into(),
            },
        ));
    }
    Ok(out)
}

struct Cursor<'a> {
    c: &'a [(char, u32)],
    i: usize,
    line: u32,
    depth: usize,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<char> {
        self.c.get(self.i).map(|x| x.0)
    }

    fn peek_at(&self, k: usize) -> Option<char> {
        self.c.get(self.i + k).map(|x| x.0)
    }

    fn span(&self, at: usize) -> Span {
        let column = self.c.get(at).or_else(|| self.c.last()).map_or(1, |x| x.1);
        Span {
            line: self.line,
            column,
        }
    }

    fn text(&self, from: usize, to: usize) -> String {
        let to = to.min(self.c.len());
        let from = from.min(to);
        self.c[from..to]
            .iter()
            .map(|x| x.0.to_ascii_uppercase())
            .collect()
    }

    /// A syntax error at `start` whose word runs to the current position (at least one
    /// character).
    fn err(&self, start: usize, expected: &str) -> At {
        let end = (self.i + 1).max(start + 1);
        At::new(
            self.span(start),
            self.text(start, end),
            ErrorKind::Syntax {
                expected: expected.into(),
            },
        )
    }

    fn take_while(&mut self, f: impl Fn(char) -> bool) -> String {
        let mut s = String::new();
        while let Some(c) = self.peek() {
            if !f(c) {
                break;
            }
            s.push(c);
            self.i += 1;
        }
        s
    }

    fn deeper(&mut self, start: usize) -> Result<(), At> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err(start, "fewer than 64 nested brackets or signs"));
        }
        Ok(())
    }

    /// A real value: number, parameter, `[expr]`, function, or a signed one of these.
    fn value(&mut self) -> Result<Expr, At> {
        let start = self.i;
        self.deeper(start)?;
        let v = match self.peek() {
            Some('[') => self.bracket(),
            Some('#') => Ok(Expr::Param(self.param()?)),
            Some('-') => {
                self.i += 1;
                Ok(Expr::Neg(Box::new(self.value()?)))
            }
            Some('+') => {
                self.i += 1;
                self.value()
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() => self.function(),
            _ => Err(self.err(
                start,
                "a value: a number, #parameter, [expression] or function",
            )),
        };
        self.depth -= 1;
        v
    }

    fn number(&mut self) -> Result<Expr, At> {
        let start = self.i;
        let s = self.take_while(|c| c.is_ascii_digit() || c == '.');
        match s.parse::<f64>() {
            Ok(v) if s.chars().any(|c| c.is_ascii_digit()) => Ok(Expr::Num(v)),
            _ => Err(self.err(start, "a number (digits with at most one `.`)")),
        }
    }

    fn param(&mut self) -> Result<Param, At> {
        let start = self.i;
        self.i += 1; // '#'
        if self.peek() == Some('<') {
            self.i += 1;
            let name = self.take_while(|c| c != '>');
            if self.peek() != Some('>') || name.is_empty() {
                return Err(self.err(start, "a parameter name closed by `>`"));
            }
            self.i += 1;
            return Ok(Param::Named(name));
        }
        Ok(Param::Numbered(Box::new(self.value()?)))
    }

    /// `[expr]`, with binary operators by LinuxCNC precedence.
    fn bracket(&mut self) -> Result<Expr, At> {
        let start = self.i;
        self.i += 1; // '['
        let e = self.binary(0)?;
        if self.peek() != Some(']') {
            return Err(self.err(start, "`]` closing the expression, or an operator"));
        }
        self.i += 1;
        Ok(e)
    }

    fn binary(&mut self, min_prec: u8) -> Result<Expr, At> {
        let mut lhs = self.value()?;
        loop {
            let (op, len) = match self.operator() {
                Some(x) => x,
                None => return Ok(lhs),
            };
            let prec = op.precedence();
            if prec < min_prec {
                return Ok(lhs);
            }
            self.i += len;
            let start = self.i;
            self.deeper(start)?;
            let rhs = self.binary(prec + 1);
            self.depth -= 1;
            lhs = Expr::Bin(op, Box::new(lhs), Box::new(rhs?));
        }
    }

    /// The operator at the cursor and its length in characters.
    fn operator(&self) -> Option<(BinOp, usize)> {
        match self.peek()? {
            '*' if self.peek_at(1) == Some('*') => Some((BinOp::Pow, 2)),
            '*' => Some((BinOp::Mul, 1)),
            '/' => Some((BinOp::Div, 1)),
            '+' => Some((BinOp::Add, 1)),
            '-' => Some((BinOp::Sub, 1)),
            c if c.is_ascii_alphabetic() => {
                for len in [3, 2] {
                    let name: String = (0..len).filter_map(|k| self.peek_at(k)).collect();
                    if name.len() == len {
                        if let Some(op) = BinOp::named(&name) {
                            return Some((op, len));
                        }
                    }
                }
                None
            }
            _ => None,
        }
    }

    fn function(&mut self) -> Result<Expr, At> {
        let start = self.i;
        let name = self.take_while(|c| c.is_ascii_alphabetic());
        if self.peek() != Some('[') {
            self.i = start;
            return Err(self.err(
                start,
                "a value: a number, #parameter, [expression] or function",
            ));
        }
        match name.as_str() {
            "atan" => {
                let y = self.bracket()?;
                if self.peek() != Some('/') || self.peek_at(1) != Some('[') {
                    return Err(self.err(start, "ATAN[y]/[x]"));
                }
                self.i += 1;
                let x = self.bracket()?;
                Ok(Expr::Atan(Box::new(y), Box::new(x)))
            }
            "exists" => {
                self.i += 1;
                let p = self.param();
                let ok = matches!(p, Ok(Param::Named(_))) && self.peek() == Some(']');
                match p {
                    Ok(Param::Named(n)) if ok => {
                        self.i += 1;
                        Ok(Expr::Exists(n))
                    }
                    _ => Err(self.err(start, "EXISTS[#<name>]")),
                }
            }
            _ => match Func::named(&name) {
                Some(f) => Ok(Expr::Func(f, Box::new(self.bracket()?))),
                None => Err(self.err(
                    start,
                    "a function: ABS ACOS ASIN ATAN COS EXISTS EXP FIX FUP LN ROUND SIN SQRT TAN",
                )),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::Params;

    fn val(e: &Expr) -> f64 {
        e.eval(&Params::default()).expect("ok")
    }

    #[test]
    fn words_have_columns_and_spaces_are_ignored() {
        let l = parse_line(3, "N10 G0 Z 10 (comment) X-1.5 ; rest").expect("ok");
        assert_eq!(l.n, Some(10));
        assert_eq!(l.words.len(), 3);
        assert_eq!(l.words[1].letter, 'Z');
        assert_eq!(l.words[1].span, Span { line: 3, column: 8 });
        assert_eq!(l.words[1].text, "Z10");
        assert_eq!(val(&l.words[2].value), -1.5);
    }

    #[test]
    fn expressions_follow_precedence() {
        let l = parse_line(1, "X[1+2*3**2] Y[-2-3] Z[7 mod 4] F[1 lt 2]").expect("ok");
        let v: Vec<f64> = l.words.iter().map(|w| val(&w.value)).collect();
        assert_eq!(v, vec![19.0, -5.0, 3.0, 1.0]);
    }

    #[test]
    fn assignments_and_owords_parse() {
        let l = parse_line(1, "#<xs> = [2*3] #5=1").expect("ok");
        assert_eq!(l.assigns.len(), 2);
        let o = parse_line(2, "o100 sub").expect("ok");
        assert_eq!(o.oword.expect("ok").keyword, "sub");
        let o = parse_line(2, "O0100 call [1+1] [#2]")
            .expect("ok")
            .oword
            .expect("ok");
        assert_eq!(
            (o.name.as_str(), o.keyword.as_str(), o.args.len()),
            ("100", "call", 2)
        );
        let prog = parse_line(3, "O1000").expect("ok");
        assert_eq!(prog.oword.expect("ok").keyword, "");
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse_line(7, "G1 X1 Y(open").expect_err("must fail");
        assert_eq!(e.span, Span { line: 7, column: 8 });
        let e = parse_line(2, "G1 X[1+").expect_err("must fail");
        assert_eq!(e.span.line, 2);
        assert!(parse_line(1, "G").is_err());
        assert!(parse_line(1, "GX1").is_err());
    }
}
