//! O-word subroutines: `o<n> sub` … `o<n> endsub`, `o<n> call [args]`, `o<n> return`.
//! A call sets #1–#30 to its arguments and hides the caller's local named parameters
//! (names without a leading `_`); the return restores both, as LinuxCNC.

use super::State;
use crate::error::{At, ErrorKind};
use crate::lexer::{parse_line, OWord};

/// Most executed blocks (a guard against endless recursion).
pub(super) const MAX_BLOCKS: u64 = 10_000_000;
/// Deepest subroutine nesting.
const MAX_CALL_DEPTH: usize = 64;

/// Subroutines seen and the call stack.
#[derive(Default)]
pub(super) struct Flow {
    /// O name → line index of its `sub`.
    subs: std::collections::HashMap<String, usize>,
    stack: Vec<Frame>,
}

/// A subroutine call: where to return, the caller's #1–#30 and named parameters.
struct Frame {
    return_pc: usize,
    locals: Vec<f64>,
    named: std::collections::HashMap<String, f64>,
}

/// Index of the first line after `from` that is `o<name> <keyword>`.
fn find_oword(lines: &[&str], from: usize, name: &str, keyword: &str) -> Option<usize> {
    (from + 1..lines.len()).find(|&k| {
        let number = u32::try_from(k + 1).unwrap_or(u32::MAX);
        parse_line(number, lines[k])
            .ok()
            .and_then(|l| l.oword)
            .is_some_and(|o| o.name == name && o.keyword == keyword)
    })
}

impl State<'_> {
    /// Runs an O word at line index `pc`; returns the index of the next line to run.
    pub(super) fn oword(
        &mut self,
        o: &OWord,
        pc: usize,
        lines: &[&str],
        flow: &mut Flow,
    ) -> Result<usize, At> {
        let err = |kind| At::new(o.span, o.text.clone(), kind);
        let syntax = |what: &str| {
            err(ErrorKind::Syntax {
                expected: what.into(),
            })
        };
        match o.keyword.as_str() {
            "" if !o.trailing => Ok(pc + 1), // a Fanuc program number
            "sub" if !o.trailing => {
                flow.subs.insert(o.name.clone(), pc);
                let end = find_oword(lines, pc, &o.name, "endsub").ok_or_else(|| {
                    err(ErrorKind::Missing {
                        what: format!("o{} endsub closing the subroutine", o.name),
                    })
                })?;
                Ok(end + 1)
            }
            "endsub" | "return" if !o.trailing => {
                let frame = flow.stack.pop().ok_or_else(|| {
                    err(ErrorKind::Syntax {
                        expected: "endsub/return only inside a called subroutine".into(),
                    })
                })?;
                let globals: Vec<(String, f64)> = self
                    .params
                    .named
                    .iter()
                    .filter(|(k, _)| k.starts_with('_'))
                    .map(|(k, v)| (k.clone(), *v))
                    .collect();
                self.params.named = frame.named;
                self.params.named.extend(globals);
                for (i, v) in frame.locals.into_iter().enumerate() {
                    self.params.numbered.insert(i as i64 + 1, v);
                }
                Ok(frame.return_pc)
            }
            "call" if !o.trailing => {
                let start = match flow.subs.get(&o.name) {
                    Some(&k) => k,
                    None => find_oword(lines, pc, &o.name, "sub").ok_or_else(|| {
                        err(ErrorKind::Missing {
                            what: format!("o{} sub defining the subroutine", o.name),
                        })
                    })?,
                };
                if flow.stack.len() >= MAX_CALL_DEPTH || o.args.len() > 30 {
                    return Err(err(ErrorKind::Range {
                        allowed: format!("calls nested at most {MAX_CALL_DEPTH} deep, 30 arguments"),
                    }));
                }
                let mut args = Vec::with_capacity(o.args.len());
                for a in &o.args {
                    args.push(a.eval(&self.params).map_err(|d| err(ErrorKind::Expression { detail: d }))?);
                }
                let locals = (1..=30)
                    .map(|i| self.params.numbered.get(&i).copied().unwrap_or(0.0))
                    .collect();
                let named = self.params.named.clone();
                self.params.named.retain(|k, _| k.starts_with('_'));
                for i in 1..=30 {
                    let v = args.get(i as usize - 1).copied().unwrap_or(0.0);
                    self.params.numbered.insert(i, v);
                }
                flow.stack.push(Frame {
                    return_pc: pc + 1,
                    locals,
                    named,
                });
                Ok(start + 1)
            }
            "" | "sub" | "endsub" | "return" | "call" => Err(syntax("nothing after the O word")),
            _ => Err(err(ErrorKind::Unsupported {
                reason: "O-word control flow (if/else/while/do/repeat/break/continue);                          o… sub/endsub/return/call are supported"
                    .into(),
            })),
        }
    }
}
