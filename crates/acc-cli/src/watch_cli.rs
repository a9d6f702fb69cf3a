//! The wear and breakage watch and the tool history in the commands: `acc sim` stores the
//! run's cuts, Kc trend and alarms after the run; `acc run` runs the watch on its logger
//! thread and stores through the history writer thread (never on the control thread).

use std::path::{Path, PathBuf};

use acc_runtime::history::{History, HistoryWriter, Watch, WatchItem, WatchSummary, DEFAULT_FILE};
use acc_runtime::record::RunRecord;
use acc_runtime::watch::WatchLimits;
use anyhow::Context as _;

/// The history file: `explicit` (from `--history` or a config), else `acc-history.sqlite`
/// beside `log`.
pub fn history_path(explicit: Option<&Path>, log: &Path) -> PathBuf {
    explicit.map_or_else(|| log.with_file_name(DEFAULT_FILE), Path::to_path_buf)
}

/// The watch's limits: `base` (`[watch]`), with the tool table's wear and breakage levels
/// per tool and its `[default]` for the tools it does not list.
pub fn watch_for(base: WatchLimits, tools: Option<&acc_config::ToolTable>, period_s: f64) -> Watch {
    let Some(table) = tools else {
        return Watch::new(base, period_s);
    };
    let mut watch = Watch::new(base.with_tool(&table.default), period_s);
    for (n, t) in &table.tools {
        watch.wear.set_tool_limits(*n, base.with_tool(t));
    }
    watch
}

/// Open the history at `path` (refusing a newer schema), start a run labelled `label`, and
/// a watch (limits: [`watch_for`]) that continues the stored trend.
pub fn open(
    path: &Path,
    label: &str,
    limits: WatchLimits,
    tools: Option<&acc_config::ToolTable>,
    period_s: f64,
) -> anyhow::Result<(Watch, History, i64)> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create its folder", path.display()))?;
    }
    let mut h = History::open(path)?;
    let mut watch = watch_for(limits, tools, period_s);
    watch.continue_from(&h)?;
    let run = h.begin_run(label)?;
    Ok((watch, h, run))
}

/// Live: the watch and a writer thread on the history (for [`acc_runtime::history::WatchSink`]).
pub fn open_live(
    path: &Path,
    label: &str,
    limits: WatchLimits,
    tools: Option<&acc_config::ToolTable>,
    period_s: f64,
) -> anyhow::Result<(Watch, HistoryWriter)> {
    let (watch, h, run) = open(path, label, limits, tools, period_s)?;
    Ok((watch, HistoryWriter::spawn(h, run)))
}

/// Offline: run the watch over a whole run and store its items; returns them.
pub fn store_run(
    path: &Path,
    label: &str,
    limits: WatchLimits,
    tools: Option<&acc_config::ToolTable>,
    period_s: f64,
    rows: &[RunRecord],
) -> anyhow::Result<Vec<WatchItem>> {
    let (mut watch, mut h, run) = open(path, label, limits, tools, period_s)?;
    let items = watch.run_all(rows);
    for it in &items {
        h.add(run, it)?;
    }
    Ok(items)
}

/// Print what the watch found: cuts, time saved, last trend point per tool, alarms.
pub fn print_summary(s: &WatchSummary, history: &Path) {
    println!(
        "watch: {} cuts, time saved against the programmed feed {:+.1} s; {} trend points, {} alarms; history {}",
        s.cuts,
        s.time_saved_s,
        s.wear_samples,
        s.alarm_count,
        history.display()
    );
    for (tool, t_s, kind, detail) in &s.alarms {
        println!("watch alarm: tool {tool} at {t_s:.1} s: {kind} ({detail})");
    }
    for w in s.last_wear.values() {
        println!(
            "wear: tool {}: Kc_hat {:.3} N/(mm/min), {:+.1} % over the fresh reference {:.3} ({})",
            w.tool,
            w.kc,
            w.rise_pct,
            w.kc_ref,
            w.level.as_str()
        );
    }
}
