//! Turning toml/serde errors into [`ConfigError`]s that name the file, the full dotted key,
//! the value as written and the allowed range.
//!
//! toml's own messages point at a line and column and say what serde expected (`invalid
//! value: integer `-1`, expected u32`); they do not say which key (beyond the span), nor
//! the range the program accepts. Here the key path is recovered from the span (by walking
//! the document's spanned tree), or from the key list a `Value::try_into` error carries,
//! and the range comes from the caller's table of [`KeyRange`]s.

use std::ops::Range;
use std::path::Path;

use toml::de::{DeTable, DeValue};

use crate::{ConfigError, RangeError};

/// The allowed range of one numeric key, in words: shown when the value does not even
/// deserialize (a negative or huge number for an unsigned key, a string for a number).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyRange {
    /// Full dotted key, e.g. `policy.link_hold_periods`.
    pub key: &'static str,
    /// Allowed values in words, e.g. `1 ..= 1000`.
    pub allowed: &'static str,
}

impl KeyRange {
    /// `key` accepts `allowed`.
    pub const fn new(key: &'static str, allowed: &'static str) -> Self {
        Self { key, allowed }
    }
}

/// The allowed range of `key` in `ranges`, if listed.
pub fn allowed_for<'a>(ranges: &'a [KeyRange], key: &str) -> Option<&'a str> {
    ranges.iter().find(|r| r.key == key).map(|r| r.allowed)
}

/// Line and column (1-based) of byte `at` in `text`.
pub fn line_col(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map_or(before, |i| &before[i + 1..])
        .chars()
        .count()
        + 1;
    (line, col)
}

/// The full dotted key at byte range `span` of the document `text` (the deepest key whose
/// name or value contains the span), or `None` when the span is not inside any key.
pub fn key_at(text: &str, span: &Range<usize>) -> Option<String> {
    if span.is_empty() {
        return None;
    }
    let doc = DeTable::parse(text).ok()?;
    let mut path = Vec::new();
    walk_table(doc.get_ref(), span, &mut path).then(|| path.join("."))
}

fn contains(outer: &Range<usize>, inner: &Range<usize>) -> bool {
    outer.start <= inner.start && inner.end <= outer.end && outer.start < outer.end
}

/// Push the keys down to the one at `span`; `true` if one was found. A table's span is
/// only its header (`[policy]`), so every table is searched, and the header matches only
/// when none of its keys does.
fn walk_table(t: &DeTable<'_>, span: &Range<usize>, path: &mut Vec<String>) -> bool {
    for (k, v) in t.iter() {
        path.push(k.get_ref().to_string());
        if contains(&k.span(), span) {
            return true;
        }
        let inside = match v.get_ref() {
            DeValue::Table(inner) => walk_table(inner, span, path),
            DeValue::Array(a) => a.into_iter().enumerate().any(|(i, item)| {
                path.push(i.to_string());
                let hit = match item.get_ref() {
                    DeValue::Table(inner) => walk_table(inner, span, path),
                    _ => false,
                } || contains(&item.span(), span);
                if !hit {
                    path.pop();
                }
                hit
            }),
            _ => false,
        };
        if inside || contains(&v.span(), span) {
            return true;
        }
        path.pop();
    }
    false
}

/// The text between the first pair of backticks after `prefix` in `message`.
fn ticked_after<'a>(message: &'a str, prefix: &str) -> Option<&'a str> {
    let rest = message.strip_prefix(prefix)?;
    let rest = rest.strip_prefix('`')?;
    rest.split('`').next()
}

/// The names serde lists after `expected one of` / `expected` in an unknown-field message.
fn expected_names(message: &str) -> Vec<&str> {
    let Some(i) = message.find("expected") else {
        return Vec::new();
    };
    message[i..].split('`').skip(1).step_by(2).collect()
}

/// Edit distance (Levenshtein) of two short names.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The known name nearest to `name`, if it is close (a typo, not another word).
pub fn nearest<'a>(name: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| (distance(name, k), *k))
        .filter(|(d, k)| *d <= (k.chars().count() / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

/// The allowed range of a primitive type serde expected (`u32`, `i64`, `usize`, `f64`, …).
fn type_range(ty: &str) -> Option<String> {
    let r = match ty {
        "u8" => format!("0 ..= {}", u8::MAX),
        "u16" => format!("0 ..= {}", u16::MAX),
        "u32" => format!("0 ..= {}", u32::MAX),
        "u64" | "usize" => format!("0 ..= {}", u64::MAX),
        "i8" => format!("{} ..= {}", i8::MIN, i8::MAX),
        "i16" => format!("{} ..= {}", i16::MIN, i16::MAX),
        "i32" => format!("{} ..= {}", i32::MIN, i32::MAX),
        "i64" => format!("{} ..= {}", i64::MIN, i64::MAX),
        "f32" | "f64" => "a number".to_string(),
        "a boolean" | "bool" => "true or false".to_string(),
        _ => return None,
    };
    Some(r)
}

fn dotted(prefix: &str, key: &str) -> String {
    match (prefix.is_empty(), key.is_empty()) {
        (true, _) => key.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) => format!("{prefix}.{key}"),
    }
}

/// What a deserialization error is about, before it becomes a [`ConfigError`].
#[derive(Debug, Clone, Default)]
pub struct ErrorSite<'a> {
    /// The whole document, if the error's span refers to it.
    pub text: Option<&'a str>,
    /// Byte range of the error in `text`.
    pub span: Option<Range<usize>>,
    /// Table the deserialized value sits in (`board` for a `[board]` table deserialized on
    /// its own), prefixed to every key found.
    pub prefix: &'a str,
    /// Keys the error carries (from `in `a.b`` of a `Value::try_into` error).
    pub keys: Option<String>,
}

/// Turn toml's error `message` at `site` in `file` into a [`ConfigError`] naming the full
/// key, the value and the allowed range (`ranges`, else the type's range).
pub fn describe(
    file: &Path,
    message: &str,
    site: &ErrorSite<'_>,
    ranges: &[KeyRange],
) -> ConfigError {
    let message = message.trim();
    // Where: line and column, the key at the span, the value's text.
    let at = match (site.text, &site.span) {
        (Some(t), Some(s)) => {
            let (l, c) = line_col(t, s.start);
            format!(" (line {l}, column {c})")
        }
        _ => String::new(),
    };
    let found = match (site.text, &site.span) {
        (Some(t), Some(s)) => key_at(t, s),
        _ => site.keys.clone(),
    };
    let written = match (site.text, &site.span) {
        (Some(t), Some(s)) if s.end <= t.len() && s.start < s.end => {
            Some(t[s.clone()].trim().to_string())
        }
        _ => None,
    };

    // Unknown key: the span is the key itself (or, from try_into, the table).
    if let Some(name) = ticked_after(message, "unknown field ") {
        let known = expected_names(message);
        let table = match &found {
            Some(k) if k.rsplit('.').next() == Some(name) => k
                .rsplit_once('.')
                .map(|(t, _)| t.to_string())
                .unwrap_or_default(),
            Some(k) => k.clone(),
            None => String::new(),
        };
        let table = dotted(site.prefix, &table);
        let key = dotted(&table, name);
        let hint = nearest(name, &known)
            .map(|k| format!("; did you mean `{}`?", dotted(&table, k)))
            .unwrap_or_default();
        let list = if known.is_empty() {
            String::new()
        } else {
            format!(
                "; allowed keys{}: {}",
                if table.is_empty() {
                    String::new()
                } else {
                    format!(" in `{table}`")
                },
                known.join(", ")
            )
        };
        return ConfigError::Invalid {
            file: file.to_path_buf(),
            key,
            message: format!("unknown key{at}{hint}{list}"),
        };
    }
    // Missing key: the span (if any) is the table that lacks it.
    if let Some(name) = ticked_after(message, "missing field ") {
        let table = dotted(site.prefix, found.as_deref().unwrap_or(""));
        return ConfigError::Invalid {
            file: file.to_path_buf(),
            key: dotted(&table, name),
            message: format!("missing (required key){at}"),
        };
    }

    let Some(key) = found.map(|k| dotted(site.prefix, &k)) else {
        return ConfigError::Parse {
            file: file.to_path_buf(),
            message: format!("{message}{at}"),
        };
    };
    // `invalid value: integer `-1`, expected u32`: a number outside the type's range.
    if let Some(v) = ticked_after(message, "invalid value: integer ") {
        let ty = message.rsplit("expected ").next().unwrap_or("");
        let allowed = allowed_for(ranges, &key)
            .map(str::to_string)
            .or_else(|| type_range(ty))
            .unwrap_or_else(|| ty.to_string());
        return ConfigError::OutOfRange(RangeError::new(key, v, allowed).in_file(file));
    }
    // `invalid type: string "x", expected u32`: the wrong kind of value.
    if let Some(rest) = message.strip_prefix("invalid type: ") {
        let (got, expected) = rest.split_once(", expected ").unwrap_or((rest, ""));
        let kind = got.split_whitespace().next().unwrap_or(got);
        let value = written.unwrap_or_else(|| got.to_string());
        let allowed = allowed_for(ranges, &key)
            .map(str::to_string)
            .or_else(|| type_range(expected))
            .unwrap_or_else(|| expected.to_string());
        return ConfigError::Invalid {
            file: file.to_path_buf(),
            key,
            message: format!("{value} is a {kind}, expected {expected}{at}; allowed {allowed}"),
        };
    }
    // Anything else (unknown variant, custom messages): key, value, serde's words.
    let value = written.map(|v| format!("{v}: ")).unwrap_or_default();
    let allowed = allowed_for(ranges, &key)
        .filter(|_| !message.contains("expected"))
        .map(|a| format!("; allowed {a}"))
        .unwrap_or_default();
    ConfigError::Invalid {
        file: file.to_path_buf(),
        key,
        message: format!("{value}{message}{at}{allowed}"),
    }
}

/// [`describe`] for an error of `toml::from_str` on the whole document `text`.
pub fn from_toml_error(
    file: &Path,
    text: &str,
    e: &toml::de::Error,
    ranges: &[KeyRange],
) -> ConfigError {
    // A syntax error: toml's own report (line, column, the line itself) is the best there is.
    if DeTable::parse(text).is_err() {
        return ConfigError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        };
    }
    let site = ErrorSite {
        text: Some(text),
        span: e.span(),
        ..ErrorSite::default()
    };
    describe(file, e.message(), &site, ranges)
}

/// Deserialize `table` (the table `prefix` of `file`, possibly changed by the caller, e.g.
/// `--port` put in) into `T`; an error names `prefix.key`, the value and the allowed range
/// (`ranges`, full dotted keys).
pub fn from_table<T: serde::de::DeserializeOwned>(
    file: &Path,
    prefix: &str,
    table: toml::Table,
    ranges: &[KeyRange],
) -> Result<T, ConfigError> {
    let original = table.clone();
    toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| {
            // The key path of a try_into error is only in its Display (`in `a.b``).
            let shown = e.to_string();
            let keys = shown
                .lines()
                .find_map(|l| l.strip_prefix("in `"))
                .map(|k| k.trim_end_matches('`').to_string());
            let mut err = describe(
                file,
                e.message(),
                &ErrorSite {
                    prefix,
                    keys: keys.clone(),
                    ..ErrorSite::default()
                },
                ranges,
            );
            // The value as written, from the table.
            if let (Some(k), ConfigError::Invalid { message, .. }) = (&keys, &mut err) {
                let mut v: Option<&toml::Value> = None;
                let mut t = Some(&original);
                for part in k.split('.') {
                    v = t.and_then(|t| t.get(part));
                    t = v.and_then(toml::Value::as_table);
                }
                if let Some(v) = v {
                    *message = match message.split_once(" is a ") {
                        Some((_, tail)) => format!("{v} is a {tail}"),
                        None => format!("{v}: {message}"),
                    };
                }
            }
            err
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Doc {
        name: String,
        policy: Policy,
        #[serde(default)]
        rows: Vec<Row>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Policy {
        link_hold_periods: Option<u32>,
        gain: Option<f64>,
        inner: Option<Inner>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Inner {
        count: u16,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Row {
        rpm: f64,
    }

    const RANGES: &[KeyRange] = &[KeyRange::new("policy.link_hold_periods", "1 ..= 1000")];

    fn err(text: &str) -> String {
        let e = toml::from_str::<Doc>(text).expect_err("bad doc");
        from_toml_error(Path::new("m.toml"), text, &e, RANGES).to_string()
    }

    #[test]
    fn a_negative_unsigned_value_shows_the_key_and_its_range() {
        let e = err("name = \"x\"\n[policy]\nlink_hold_periods = -1\n");
        assert_eq!(
            e,
            "m.toml: key `policy.link_hold_periods` = -1 is out of range: allowed 1 ..= 1000"
        );
        // A key without a listed range: the type's range.
        let e = err("name = \"x\"\n[policy.inner]\ncount = 70000\n");
        assert_eq!(
            e,
            "m.toml: key `policy.inner.count` = 70000 is out of range: allowed 0 ..= 65535"
        );
    }

    #[test]
    fn a_type_error_names_the_key_not_only_the_table() {
        let e = err("name = \"x\"\n[policy]\nlink_hold_periods = \"five\"\n");
        assert!(
            e == "m.toml: key `policy.link_hold_periods`: \"five\" is a string, expected u32 (line 3, column 21); allowed 1 ..= 1000",
            "{e}"
        );
        let e = err("name = \"x\"\n[policy]\ngain = true\n");
        assert!(
            e.contains("key `policy.gain`: true is a boolean, expected f64"),
            "{e}"
        );
        let e = err("name = \"x\"\npolicy = {}\n[[rows]]\nrpm = \"fast\"\n");
        assert!(e.contains("key `rows.0.rpm`: \"fast\" is a string"), "{e}");
    }

    #[test]
    fn an_unknown_key_is_named_in_full_with_the_nearest_known_one() {
        let e = err("name = \"x\"\n[policy]\nlink_hold_period = 5\n");
        assert!(
            e.starts_with("m.toml: key `policy.link_hold_period`: unknown key (line 3, column 1); did you mean `policy.link_hold_periods`?"),
            "{e}"
        );
        let e = err("nme = \"x\"\n[policy]\n");
        assert!(
            e.contains("key `nme`: unknown key") && e.contains("`name`"),
            "{e}"
        );
        // Nothing near: no suggestion, the list of known keys.
        let e = err("name = \"x\"\n[policy]\nzzzzzzzzzz = 1\n");
        assert!(!e.contains("did you mean"), "{e}");
        assert!(
            e.contains("allowed keys in `policy`: link_hold_periods"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_key_is_named_with_its_table() {
        let e = err("name = \"x\"\n[policy.inner]\n");
        assert!(e.contains("key `policy.inner.count`: missing"), "{e}");
        let e = err("[policy]\n");
        assert!(e.contains("key `name`: missing"), "{e}");
    }

    #[test]
    fn a_syntax_error_keeps_toml_s_report() {
        let e = err("name = \n");
        assert!(e.contains("line 1"), "{e}");
    }

    #[test]
    fn a_table_deserialized_on_its_own_names_its_keys_under_the_table() {
        let mut t = toml::Table::new();
        t.insert("count".into(), toml::Value::String("x".into()));
        let e = from_table::<Inner>(Path::new("m.toml"), "policy.inner", t, &[])
            .expect_err("type")
            .to_string();
        assert!(
            e.starts_with("m.toml: key `policy.inner.count`: \"x\" is a string, expected u16"),
            "{e}"
        );
        let mut t = toml::Table::new();
        t.insert("count".into(), toml::Value::Integer(1));
        t.insert("cuont".into(), toml::Value::Integer(1));
        let e = from_table::<Inner>(Path::new("m.toml"), "b", t, &[])
            .expect_err("unknown")
            .to_string();
        assert!(
            e.contains("key `b.cuont`: unknown key; did you mean `b.count`?"),
            "{e}"
        );
    }

    #[test]
    fn nearest_finds_typos_only() {
        let known = ["link_hold_periods", "ack_periods", "time_scale"];
        assert_eq!(
            nearest("link_hold_period", &known),
            Some("link_hold_periods")
        );
        assert_eq!(nearest("time_scal", &known), Some("time_scale"));
        assert_eq!(nearest("colour", &known), None);
    }
}
