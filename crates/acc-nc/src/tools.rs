//! The interpreter's setup: the tool table (tool length offsets for G43) and the work
//! offsets of G54–G59.

use std::collections::BTreeMap;

use crate::canon::Units;
use crate::error::{ErrorKind, NcError, Span};

/// One tool of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolEntry {
    /// Tool number (the T word).
    pub tool: u32,
    /// Pocket number (P in the .tbl file; informational).
    pub pocket: u32,
    /// Tool length offset along Z, mm (G43 applies it).
    pub length_mm: f64,
    /// Diameter, mm (0 when not given).
    pub diameter_mm: f64,
    /// The comment after `;` in the .tbl file.
    pub comment: String,
}

/// The tool table: tool number → entry. Empty by default (then only T0 is valid).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ToolTable {
    entries: BTreeMap<u32, ToolEntry>,
}

impl ToolTable {
    /// Adds or replaces an entry.
    pub fn insert(&mut self, entry: ToolEntry) {
        self.entries.insert(entry.tool, entry);
    }

    /// The entry of tool `tool`, if present.
    pub fn get(&self, tool: u32) -> Option<&ToolEntry> {
        self.entries.get(&tool)
    }

    /// All entries in tool-number order.
    pub fn entries(&self) -> impl Iterator<Item = &ToolEntry> {
        self.entries.values()
    }

    /// Parses a LinuxCNC tool table (`.tbl`): one tool a line, `T<n> P<pocket> Z<length>
    /// D<diameter> ;comment`; other offsets (X Y A B C U V W I J Q) are read and ignored.
    /// Lengths are in `units` (LinuxCNC reads the table in the machine's units; the
    /// stand-alone `rs274` without an INI file reads it in inches).
    ///
    /// ```
    /// use acc_nc::{ToolTable, Units};
    /// let t = ToolTable::parse_tbl("t.tbl", "T1 P1 Z10.5 D6 ;end mill\n", Units::Mm).expect("ok");
    /// assert_eq!(t.get(1).expect("ok").length_mm, 10.5);
    /// assert_eq!(t.get(1).expect("ok").comment, "end mill");
    /// ```
    pub fn parse_tbl(file: &str, text: &str, units: Units) -> Result<ToolTable, NcError> {
        let mut table = ToolTable::default();
        for (i, raw) in text.lines().enumerate() {
            let line = u32::try_from(i + 1).unwrap_or(u32::MAX);
            let (body, comment) = match raw.split_once(';') {
                Some((b, c)) => (b, c.trim().to_string()),
                None => (raw, String::new()),
            };
            if body.trim().is_empty() {
                continue;
            }
            let mut entry = ToolEntry {
                tool: u32::MAX,
                pocket: 0,
                length_mm: 0.0,
                diameter_mm: 0.0,
                comment,
            };
            let mut column = 1;
            for field in body.split_whitespace() {
                let col = raw[column - 1..].find(field).map_or(column, |k| column + k);
                column = col + field.len();
                let err = |allowed: &str| NcError {
                    file: file.to_string(),
                    span: Span {
                        line,
                        column: u32::try_from(col).unwrap_or(u32::MAX),
                    },
                    word: field.to_string(),
                    kind: ErrorKind::Range {
                        allowed: allowed.into(),
                    },
                };
                let mut cs = field.chars();
                let letter = cs.next().map(|c| c.to_ascii_uppercase());
                let rest = cs.as_str();
                match letter {
                    Some('T') | Some('P') => {
                        let n = rest
                            .parse::<u32>()
                            .map_err(|_| err("T and P: a whole number >= 0"))?;
                        if letter == Some('T') {
                            entry.tool = n;
                        } else {
                            entry.pocket = n;
                        }
                    }
                    Some(c) if "XYZABCUVWDIJQ".contains(c) => {
                        let v = rest
                            .parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .ok_or_else(|| err("a number after the letter"))?;
                        match c {
                            'Z' => entry.length_mm = v * units.mm_per_unit(),
                            'D' => entry.diameter_mm = v * units.mm_per_unit(),
                            _ => {}
                        }
                    }
                    _ => return Err(err("fields T P X Y Z A B C U V W D I J Q")),
                }
            }
            if entry.tool == u32::MAX {
                return Err(NcError {
                    file: file.to_string(),
                    span: Span { line, column: 1 },
                    word: body.trim().to_string(),
                    kind: ErrorKind::Missing {
                        what: "the tool number T on every tool-table line".into(),
                    },
                });
            }
            table.insert(entry);
        }
        Ok(table)
    }
}

/// Reads the G54–G59 work offsets from a LinuxCNC parameter file (`.var`: one
/// `number value` pair a line; G54 X Y Z are #5221–#5223, each next system 20 higher, up to
/// G59 at #5321–#5323). Other parameters are ignored; missing offsets are zero. Values are
/// in `units` (the machine's; the stand-alone `rs274` reads inches).
///
/// ```
/// use acc_nc::{parse_work_offsets_var, Units};
/// let o = parse_work_offsets_var("p.var", "5220 1\n5241 10\n5243 -2.5\n", Units::Mm).unwrap();
/// assert_eq!(o[1], [10.0, 0.0, -2.5]); // G55
/// ```
pub fn parse_work_offsets_var(
    file: &str,
    text: &str,
    units: Units,
) -> Result<[[f64; 3]; 6], NcError> {
    let mut offsets = [[0.0; 3]; 6];
    for (i, raw) in text.lines().enumerate() {
        let mut fields = raw.split_whitespace();
        let (Some(n), Some(v)) = (fields.next(), fields.next()) else {
            continue;
        };
        let bad = || NcError {
            file: file.to_string(),
            span: Span {
                line: u32::try_from(i + 1).unwrap_or(u32::MAX),
                column: 1,
            },
            word: raw.trim().to_string(),
            kind: ErrorKind::Syntax {
                expected: "`number value` (a parameter number and a finite number)".into(),
            },
        };
        let n: u32 = n.parse().map_err(|_| bad())?;
        let v: f64 = v
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(bad)?;
        if (5221..=5323).contains(&n) {
            let (system, axis) = ((n - 5221) / 20, (n - 5221) % 20);
            if axis < 3 {
                offsets[system as usize][axis as usize] = v * units.mm_per_unit();
            }
        }
    }
    Ok(offsets)
}

/// What the interpreter needs besides the program: tools, work offsets, tolerances.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// The tool table (default: empty).
    pub tools: ToolTable,
    /// Work offsets of G54 … G59 (index 0 … 5) in the machine frame, mm. Default: all zero.
    pub work_offsets_mm: [[f64; 3]; 6],
    /// Largest difference between the radius at an arc's start and at its end (I/J/K
    /// arcs), mm. Default 0.005 mm (LinuxCNC's former `TOLERANCE_MM`; enough for centres and
    /// ends written to 4 decimals of an inch).
    pub arc_radius_tolerance_mm: f64,
}

impl Default for Setup {
    fn default() -> Self {
        Setup {
            tools: ToolTable::default(),
            work_offsets_mm: [[0.0; 3]; 6],
            arc_radius_tolerance_mm: 0.005,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inch_table_is_converted_and_bad_fields_are_named() {
        let t = ToolTable::parse_tbl("t.tbl", "T2 P3 Z1 D0.5\n\n", Units::Inch).expect("ok");
        let e = t.get(2).expect("ok");
        assert_eq!((e.pocket, e.length_mm, e.diameter_mm), (3, 25.4, 12.7));
        let err =
            ToolTable::parse_tbl("t.tbl", "T1 P1\nT2 Zx\n", Units::Mm).expect_err("must fail");
        assert_eq!((err.span.line, err.span.column), (2, 4));
        assert!(err.to_string().starts_with("t.tbl:2:4: `Zx`"), "{err}");
    }
}
