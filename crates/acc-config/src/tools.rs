//! The shop's tool table: per tool number the force reference, the override range, the
//! air-cut and entry overrides, the overload reaction, wear and breakage thresholds and the
//! material; plus the entry-control settings (`[entry]`). A setter edits one TOML file
//! (`configs/tooltable.toml` is the example); the loop picks the entry by the board's
//! `TOOL_NUMBER` (v2) every period, `[default]` for tools not listed and for `TOOL_NUMBER` 0
//! (v1 boards, or unknown).
//!
//! ```toml
//! [entry]
//! enabled = true
//!
//! [default]
//! fr_n = 800.0
//!
//! [tool.12]
//! fr_n = 600.0
//! max_override_pct = 120
//! material = "42CrMo4"
//! ```
//!
//! Every key of a `[tool.N]` table is optional: a key not given takes `[default]`'s value.
//! Every error names the file, the dotted key (`tool.12.fr_n`), the value and the allowed
//! range; an unknown key gets the nearest known one as a suggestion (see [`crate::diagnose`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::{check_range, parse_toml_with, ConfigError, KeyRange};

/// What the loop does when the force stays above the tool's overload limit for the
/// qualifying time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OverloadReaction {
    /// Raise the overload alarm only; ACC keeps regulating.
    Warning,
    /// Feed hold (the fault policy's reaction today), release and latch.
    FeedHold,
    /// Feed hold and a spindle-stop request to the NC.
    SpindleStop,
}

impl OverloadReaction {
    /// Name as written in the file.
    pub fn as_str(self) -> &'static str {
        match self {
            OverloadReaction::Warning => "warning",
            OverloadReaction::FeedHold => "feed_hold",
            OverloadReaction::SpindleStop => "spindle_stop",
        }
    }
}

/// One tool's limits, as resolved (every field set; `[default]`'s value where the tool's
/// table did not give one).
#[derive(Debug, Clone, PartialEq)]
pub struct ToolLimits {
    /// Tool number (0 for the `[default]` entry).
    pub tool: u16,
    /// Force reference Fr, N (1 ..= 100 000).
    pub fr_n: f64,
    /// Lowest override while cutting, percent (0 ..= `max_override_pct`).
    pub min_override_pct: u16,
    /// Highest override, percent (1 ..= 150).
    pub max_override_pct: u16,
    /// Highest override in an air cut, percent (1 ..= `max_override_pct`; default = max).
    pub air_override_pct: u16,
    /// Override to enter the cut at when nothing was learned yet for this tool, percent
    /// (`None`: no entry cap until an entry was learned; 1 ..= `max_override_pct`).
    pub entry_override_pct: Option<u16>,
    /// Overload force limit, N (`overload_n`, or `overload_x_fr` × Fr; default 2 × Fr).
    pub overload_n: f64,
    /// Time above the overload limit before the reaction, s (0 ..= 60, default 0.3).
    pub overload_time_s: f64,
    /// Reaction to an overload (default `feed_hold`).
    pub overload_reaction: OverloadReaction,
    /// Kc rise over the tool's first settled value that raises a wear warning, percent
    /// (0 ..= 1000, default 30).
    pub wear_warn_pct: f64,
    /// Kc rise that marks the tool worn out, percent (`wear_warn_pct` ..= 1000, default 50).
    pub wear_limit_pct: f64,
    /// Breakage: a sudden force drop by this much against the tool's own level, percent
    /// (1 ..= 100, default 60).
    pub breakage_drop_pct: f64,
    /// Breakage: a sudden force spike to this multiple of the tool's own level, × (1 ..= 20,
    /// default 2).
    pub breakage_spike_x: f64,
    /// Initial Kc_hat for this tool when it is first seen in a run, N/(mm/min) (optional,
    /// 1e-6 ..= 1e6; without it the estimate carries over from the previous tool).
    pub kc_init: Option<f64>,
    /// Feed for the air moves of a program `acc optimize` rewrites (feed moves that engage
    /// no stock), mm/min (1 ..= 100 000, default [`DEFAULT_AIR_FEED_MM_MIN`]; `acc optimize`
    /// also keeps it at or below the machine's rapid rate). The production loop does not
    /// read it.
    pub air_feed_mm_min: f64,
    /// Material this entry was set up for (free text, default empty).
    pub material: String,
}

/// Default air feed of a tool (`air_feed_mm_min`), mm/min: a third of the paper machine's
/// 10 000 mm/min rapid rate, far below any rapid, so a feed move that the plan thinks is in
/// air is still a feed move the operator can stop with the override.
pub const DEFAULT_AIR_FEED_MM_MIN: f64 = 3000.0;

/// Entry and exit control settings (`[entry]`), see `docs/shop.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntrySpec {
    /// Entry control on (default false: the tool table only switches limits).
    pub enabled: bool,
    /// Air → cut when the estimated force rises above this share of Fr, percent
    /// (1 ..= 90, default 15).
    pub detect_pct: f64,
    /// Cut → air when the force falls below this share of Fr, percent
    /// (0.5 ..= `detect_pct`, default 8).
    pub air_pct: f64,
    /// Length of the entry state after air → cut, s (0.2 ..= 30, default 1.5): the
    /// predictive limiter extrapolates the engagement's growth during it; the settled
    /// engagement is learned from its second half to the exit (docs/shop.md).
    pub settle_s: f64,
    /// Force limit while cutting, percent over Fr (0 ..= 100, default 3): the predictive
    /// limiter keeps the next period's predicted force under Fr × (1 + `limit_pct`/100),
    /// and above it the override is cut at once to applied × Fr / F (the limiter only
    /// lowers; docs/shop.md).
    pub limit_pct: f64,
    /// The limiter on (default true).
    pub limiter: bool,
}

impl Default for EntrySpec {
    fn default() -> Self {
        Self {
            enabled: false,
            detect_pct: 15.0,
            air_pct: 8.0,
            settle_s: 1.5,
            limit_pct: 3.0,
            limiter: true,
        }
    }
}

/// A loaded, validated tool table.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolTable {
    /// The file it came from.
    pub file: PathBuf,
    /// Entry control settings.
    pub entry: EntrySpec,
    /// The `[default]` entry (tool 0).
    pub default: ToolLimits,
    /// The listed tools, by number.
    pub tools: BTreeMap<u16, ToolLimits>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolFile {
    fr_n: Option<f64>,
    min_override_pct: Option<i64>,
    max_override_pct: Option<i64>,
    air_override_pct: Option<i64>,
    entry_override_pct: Option<i64>,
    overload_n: Option<f64>,
    overload_x_fr: Option<f64>,
    overload_time_s: Option<f64>,
    overload_reaction: Option<OverloadReaction>,
    wear_warn_pct: Option<f64>,
    wear_limit_pct: Option<f64>,
    breakage_drop_pct: Option<f64>,
    breakage_spike_x: Option<f64>,
    kc_init: Option<f64>,
    air_feed_mm_min: Option<f64>,
    material: Option<String>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    enabled: Option<bool>,
    detect_pct: Option<f64>,
    air_pct: Option<f64>,
    settle_s: Option<f64>,
    limit_pct: Option<f64>,
    limiter: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    #[serde(default)]
    entry: EntryFile,
    default: ToolFile,
    #[serde(default)]
    tool: BTreeMap<String, ToolFile>,
}

/// Allowed ranges of the numeric keys (shown when a value does not deserialize).
pub const TOOL_KEY_RANGES: &[KeyRange] = &[];

fn int_range(file: &Path, key: &str, v: i64, lo: i64, hi: i64) -> Result<u16, ConfigError> {
    if (lo..=hi).contains(&v) {
        Ok(v as u16)
    } else {
        Err(ConfigError::OutOfRange(
            crate::RangeError::new(key.to_string(), v.to_string(), format!("{lo} ..= {hi}"))
                .in_file(file),
        ))
    }
}

impl ToolTable {
    /// Read and validate a tool table.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
            file: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        Self::parse(path, &text)
    }

    /// Validate tool-table text that came from `path` (used in errors).
    pub fn parse(path: impl AsRef<Path>, text: &str) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let f: TableFile = parse_toml_with(path, text, TOOL_KEY_RANGES)?;
        let entry = resolve_entry(path, &f.entry)?;
        let builtin = ToolFile::default();
        let default = resolve_tool(path, "default", 0, &f.default, &builtin)?;
        let mut tools = BTreeMap::new();
        for (name, t) in &f.tool {
            let key = format!("tool.{name}");
            let n: u16 = match name.trim().parse::<u16>() {
                Ok(n) if n > 0 => n,
                _ => {
                    return Err(ConfigError::Invalid {
                        file: path.to_path_buf(),
                        key,
                        message: format!(
                            "\"{name}\" is not a tool number: allowed 1 ..= 65535 (tool 0 is `[default]`)"
                        ),
                    })
                }
            };
            tools.insert(n, resolve_tool(path, &key, n, t, &f.default)?);
        }
        Ok(ToolTable {
            file: path.to_path_buf(),
            entry,
            default,
            tools,
        })
    }

    /// The limits for `TOOL_NUMBER` `tool` (`[default]` for 0 and for tools not listed).
    pub fn get(&self, tool: u16) -> &ToolLimits {
        self.tools.get(&tool).unwrap_or(&self.default)
    }
}

fn resolve_entry(file: &Path, e: &EntryFile) -> Result<EntrySpec, ConfigError> {
    let d = EntrySpec::default();
    let detect_pct = check_range(
        file,
        "entry.detect_pct",
        e.detect_pct.unwrap_or(d.detect_pct),
        1.0,
        90.0,
    )?;
    let air_pct = check_range(
        file,
        "entry.air_pct",
        e.air_pct.unwrap_or(d.air_pct),
        0.5,
        detect_pct,
    )?;
    Ok(EntrySpec {
        enabled: e.enabled.unwrap_or(d.enabled),
        detect_pct,
        air_pct,
        settle_s: check_range(
            file,
            "entry.settle_s",
            e.settle_s.unwrap_or(d.settle_s),
            0.2,
            30.0,
        )?,
        limit_pct: check_range(
            file,
            "entry.limit_pct",
            e.limit_pct.unwrap_or(d.limit_pct),
            0.0,
            100.0,
        )?,
        limiter: e.limiter.unwrap_or(d.limiter),
    })
}

/// Resolve one tool table `t` (keys under `prefix`), falling back to `base` for keys not
/// given, then to the built-in defaults.
fn resolve_tool(
    file: &Path,
    prefix: &str,
    tool: u16,
    t: &ToolFile,
    base: &ToolFile,
) -> Result<ToolLimits, ConfigError> {
    let k = |name: &str| format!("{prefix}.{name}");
    let fr_n = match t.fr_n.or(base.fr_n) {
        Some(v) => check_range(file, &k("fr_n"), v, 1.0, 1e5)?,
        None => {
            return Err(ConfigError::Invalid {
                file: file.to_path_buf(),
                key: k("fr_n"),
                message: "missing (required in `[default]`): force reference, N, 1 ..= 100000"
                    .into(),
            })
        }
    };
    let max = int_range(
        file,
        &k("max_override_pct"),
        t.max_override_pct.or(base.max_override_pct).unwrap_or(150),
        1,
        150,
    )?;
    let min = int_range(
        file,
        &k("min_override_pct"),
        t.min_override_pct.or(base.min_override_pct).unwrap_or(0),
        0,
        i64::from(max),
    )?;
    let air = int_range(
        file,
        &k("air_override_pct"),
        // Inherited from `[default]`: at most this tool's maximum; given here: checked.
        t.air_override_pct.unwrap_or_else(|| {
            base.air_override_pct
                .unwrap_or(i64::from(max))
                .min(i64::from(max))
        }),
        1,
        i64::from(max),
    )?;
    let inherited_entry = base.entry_override_pct.map(|v| v.min(i64::from(max)));
    let entry = match t.entry_override_pct.or(inherited_entry) {
        Some(v) => Some(int_range(
            file,
            &k("entry_override_pct"),
            v,
            1,
            i64::from(max),
        )?),
        None => None,
    };
    // An explicit limit of this table wins over the other form inherited from `[default]`.
    if t.overload_n.is_some() && t.overload_x_fr.is_some() {
        return Err(ConfigError::Invalid {
            file: file.to_path_buf(),
            key: k("overload_n"),
            message: "give either `overload_n` (N) or `overload_x_fr` (× Fr), not both".into(),
        });
    }
    let overload_n = if let Some(n) = t.overload_n {
        check_range(file, &k("overload_n"), n, fr_n, 1e6)?
    } else if let Some(x) = t.overload_x_fr {
        check_range(file, &k("overload_x_fr"), x, 1.0, 10.0)? * fr_n
    } else if let Some(n) = base.overload_n {
        check_range(file, &k("overload_n"), n, fr_n, 1e6)?
    } else {
        check_range(
            file,
            &k("overload_x_fr"),
            base.overload_x_fr.unwrap_or(2.0),
            1.0,
            10.0,
        )? * fr_n
    };
    let overload_time_s = check_range(
        file,
        &k("overload_time_s"),
        t.overload_time_s.or(base.overload_time_s).unwrap_or(0.3),
        0.0,
        60.0,
    )?;
    let wear_warn_pct = check_range(
        file,
        &k("wear_warn_pct"),
        t.wear_warn_pct.or(base.wear_warn_pct).unwrap_or(25.0),
        1.0,
        1000.0,
    )?;
    let wear_limit_pct = check_range(
        file,
        &k("wear_limit_pct"),
        t.wear_limit_pct.or(base.wear_limit_pct).unwrap_or(50.0),
        wear_warn_pct,
        1000.0,
    )?;
    let breakage_drop_pct = check_range(
        file,
        &k("breakage_drop_pct"),
        t.breakage_drop_pct
            .or(base.breakage_drop_pct)
            .unwrap_or(60.0),
        1.0,
        99.0,
    )?;
    let breakage_spike_x = check_range(
        file,
        &k("breakage_spike_x"),
        t.breakage_spike_x.or(base.breakage_spike_x).unwrap_or(3.0),
        1.1,
        20.0,
    )?;
    let kc_init = match t.kc_init {
        Some(v) => Some(check_range(file, &k("kc_init"), v, 1e-6, 1e6)?),
        None => None,
    };
    let air_feed_mm_min = check_range(
        file,
        &k("air_feed_mm_min"),
        t.air_feed_mm_min
            .or(base.air_feed_mm_min)
            .unwrap_or(DEFAULT_AIR_FEED_MM_MIN),
        1.0,
        1e5,
    )?;
    Ok(ToolLimits {
        tool,
        air_feed_mm_min,
        fr_n,
        min_override_pct: min,
        max_override_pct: max,
        air_override_pct: air,
        entry_override_pct: entry,
        overload_n,
        overload_time_s,
        overload_reaction: t
            .overload_reaction
            .or(base.overload_reaction)
            .unwrap_or(OverloadReaction::FeedHold),
        wear_warn_pct,
        wear_limit_pct,
        breakage_drop_pct,
        breakage_spike_x,
        kc_init,
        material: t
            .material
            .clone()
            .or_else(|| base.material.clone())
            .unwrap_or_default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[entry]
enabled = true
detect_pct = 20.0

[default]
fr_n = 800.0
max_override_pct = 150
material = "SB40"

[tool.1]
fr_n = 800.0

[tool.2]
fr_n = 500.0
max_override_pct = 120
overload_x_fr = 1.5
overload_reaction = "warning"
"#;

    fn err(text: &str) -> String {
        ToolTable::parse("t.toml", text)
            .expect_err("fails")
            .to_string()
    }

    #[test]
    fn parses_and_inherits_the_default() {
        let t = ToolTable::parse("t.toml", GOOD).expect("ok");
        assert!(t.entry.enabled);
        assert_eq!(t.entry.detect_pct, 20.0);
        assert_eq!(t.get(2).fr_n, 500.0);
        assert_eq!(t.get(2).max_override_pct, 120);
        assert_eq!(t.get(2).air_override_pct, 120);
        assert_eq!(t.get(2).overload_n, 750.0);
        assert_eq!(t.get(2).overload_reaction, OverloadReaction::Warning);
        assert_eq!(t.get(2).material, "SB40");
        assert_eq!(t.get(1).overload_n, 1600.0);
        // Unknown tool and tool 0 fall back to [default].
        assert_eq!(t.get(7).tool, 0);
        assert_eq!(t.get(0).fr_n, 800.0);
        assert_eq!(t.get(1).air_feed_mm_min, DEFAULT_AIR_FEED_MM_MIN);
    }

    #[test]
    fn air_feed_inherits_and_is_bounded() {
        let t = ToolTable::parse(
            "t.toml",
            "[default]\nfr_n = 800.0\nair_feed_mm_min = 2500.0\n[tool.4]\nair_feed_mm_min = 900.0\n",
        )
        .expect("ok");
        assert_eq!(t.get(1).air_feed_mm_min, 2500.0);
        assert_eq!(t.get(4).air_feed_mm_min, 900.0);
        let e = err("[default]\nfr_n = 800.0\n[tool.4]\nair_feed_mm_min = 0.0\n");
        assert!(
            e.contains("tool.4.air_feed_mm_min") && e.contains("1 ..= 100000"),
            "{e}"
        );
    }

    #[test]
    fn errors_name_file_key_value_and_range() {
        let e = err("[default]\nfr_n = 800.0\n[tool.12]\nfr_n = -3.0\n");
        assert!(e.contains("t.toml") && e.contains("tool.12.fr_n"), "{e}");
        assert!(e.contains("-3") && e.contains("1 ..= 100000"), "{e}");
        let e = err("[default]\nfr_n = 800.0\nmax_override_pct = 200\n");
        assert!(
            e.contains("default.max_override_pct") && e.contains("200"),
            "{e}"
        );
        assert!(e.contains("1 ..= 150"), "{e}");
        let e = err(
            "[default]\nfr_n = 800.0\n[tool.3]\nmax_override_pct = 100\nair_override_pct = 120\n",
        );
        assert!(
            e.contains("tool.3.air_override_pct") && e.contains("1 ..= 100"),
            "{e}"
        );
        let e = err("[default]\nfr_n = 800.0\n[tool.x]\nfr_n = 3.0\n");
        assert!(e.contains("tool.x") && e.contains("1 ..= 65535"), "{e}");
        let e = err("[default]\nfr_n = 800.0\n[entry]\nair_pct = 40.0\n");
        assert!(
            e.contains("entry.air_pct") && e.contains("0.5 ..= 15"),
            "{e}"
        );
        let e = err("[default]\nmax_override_pct = 100\n");
        assert!(e.contains("default.fr_n") && e.contains("missing"), "{e}");
    }

    #[test]
    fn unknown_keys_are_suggested() {
        let e = err("[default]\nfr_n = 800.0\n[tool.12]\nfr = 600.0\n");
        assert!(e.contains("tool.12.fr"), "{e}");
        assert!(e.contains("did you mean `tool.12.fr_n`"), "{e}");
        let e = err("[default]\nfr_n = 800.0\noverload_reaction = \"stop\"\n");
        assert!(e.contains("default.overload_reaction"), "{e}");
        assert!(e.contains("feed_hold"), "{e}");
    }
}
