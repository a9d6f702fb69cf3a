//! `acc report RUN_LOG --out DIR`: one self-contained HTML page of a run — force along the
//! path with Fr and the limit lines, override (commanded and applied), Kc_hat and its trend,
//! the per-cut table and the alarms. The plots are inline SVG (acc-plot); the page loads
//! nothing from anywhere (no scripts, no fonts, no URLs), so it opens without a network.
//!
//! The cuts, trend points and alarms come from the same code that runs live beside `acc run`
//! ([`acc_runtime::history::Watch`] over the log's records); with `--history` the tools'
//! stored Kc trend across runs is drawn too.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use acc_plot::{time_series, Figure, HLine, Panel, Series, Style, XyChart};
use acc_runtime::cuts::{log_bin_pct, log_period_s, CutRecord};
use acc_runtime::history::{History, Watch, WatchItem};
use acc_runtime::record::{read_run_log, RunRecord};
use acc_runtime::watch::{WatchLimits, WearSample};
use anyhow::Context as _;

/// Arguments of `acc report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Run log (CSV, the one schema: `acc sim`'s `run.csv`, `acc run --log`).
    pub run_log: PathBuf,
    /// Output directory: `report.html` (self-contained) and the plots as SVG/PNG files.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Tool-history database (SQLite) whose stored Kc trend of the log's tools is drawn
    /// (default: `acc-history.sqlite` beside the log, when it exists).
    #[arg(long, value_name = "FILE")]
    pub history: Option<PathBuf>,
    /// Overload limit drawn on the force plot, N (default 2 × Fr, the fault policy's).
    #[arg(long)]
    pub overload_force_n: Option<f64>,
}

/// What the report is built from.
#[derive(Debug, Clone)]
pub struct ReportData {
    /// The log's records.
    pub rows: Vec<RunRecord>,
    /// Cuts.
    pub cuts: Vec<CutRecord>,
    /// Kc trend points of this run.
    pub wear: Vec<WearSample>,
    /// Alarms `(tool, t_s, kind, detail)`.
    pub alarms: Vec<(u16, f64, String, String)>,
    /// Period of the log, s.
    pub period_s: f64,
}

impl ReportData {
    /// Analyse `rows` with the watch (default limits).
    pub fn of(rows: Vec<RunRecord>) -> Self {
        let period_s = log_period_s(&rows);
        let mut watch = Watch::new(WatchLimits::default(), period_s);
        watch.cuts = watch.cuts.with_bin_pct(log_bin_pct(&rows));
        let items = watch.run_all(&rows);
        let mut d = ReportData {
            rows,
            cuts: Vec::new(),
            wear: Vec::new(),
            alarms: Vec::new(),
            period_s,
        };
        for i in items {
            match i {
                WatchItem::Cut(c) => d.cuts.push(c),
                WatchItem::Wear(w) => d.wear.push(w),
                WatchItem::Alarm {
                    tool,
                    t_s,
                    kind,
                    detail,
                } => d.alarms.push((tool, t_s, kind, detail)),
            }
        }
        d
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The SVG file's text without its XML declaration, for inlining.
fn inline_svg(path: &Path) -> anyhow::Result<String> {
    let s = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the plot", path.display()))?;
    let start = s.find("<svg").unwrap_or(0);
    Ok(s[start..].to_string())
}

fn along_path(rows: &[RunRecord], f: impl Fn(&RunRecord) -> Option<f64>) -> Vec<(f64, f64)> {
    rows.iter().filter_map(|r| Some((r.x_mm?, f(r)?))).collect()
}

/// Run `acc report`.
pub fn run(args: &ReportArgs) -> anyhow::Result<()> {
    let file = std::fs::File::open(&args.run_log)
        .with_context(|| format!("{}: cannot open the run log", args.run_log.display()))?;
    let rows = read_run_log(std::io::BufReader::new(file))
        .with_context(|| format!("{}", args.run_log.display()))?;
    if rows.is_empty() {
        anyhow::bail!("{}: the run log has no rows", args.run_log.display());
    }
    let history = args.history.clone().or_else(|| {
        let p = args
            .run_log
            .with_file_name(acc_runtime::history::DEFAULT_FILE);
        p.is_file().then_some(p)
    });
    let data = ReportData::of(rows);
    let page = write_report(
        &data,
        &args.run_log,
        &args.out,
        history.as_deref(),
        args.overload_force_n,
    )?;
    println!(
        "report: {} ({} cuts, {} alarms, {} trend points)",
        page.display(),
        data.cuts.len(),
        data.alarms.len(),
        data.wear.len()
    );
    Ok(())
}

/// Write `report.html` and its plots into `out`; returns the page's path.
pub fn write_report(
    d: &ReportData,
    log: &Path,
    out: &Path,
    history: Option<&Path>,
    overload_force_n: Option<f64>,
) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let rows = &d.rows;
    let fr = rows
        .iter()
        .rev()
        .find_map(|r| r.force_ref_n)
        .unwrap_or(f64::NAN);
    let overload = overload_force_n.unwrap_or(2.0 * fr);
    let mut hl = vec![HLine::new("Fr", fr), HLine::new("1.1·Fr", 1.1 * fr)];
    if overload.is_finite() {
        hl.push(HLine::new("overload limit", overload));
    }
    let trend: Vec<(f64, f64)> = d
        .wear
        .iter()
        .filter(|w| w.x_mm.is_finite())
        .map(|w| (w.x_mm, w.kc))
        .collect();
    let fig = Figure {
        title: format!("run {}", log.display()),
        x_label: "path [mm]".into(),
        panels: vec![
            Panel {
                y_label: "force [N]".into(),
                series: vec![Series::line("measured Fc", along_path(rows, |r| r.force_n))],
                hlines: hl,
                ..Panel::default()
            },
            Panel {
                y_label: "override [%]".into(),
                series: vec![
                    Series::line(
                        "commanded",
                        along_path(rows, |r| r.override_cmd_pct.map(f64::from)),
                    ),
                    Series::line(
                        "applied",
                        along_path(rows, |r| r.override_applied_pct.map(f64::from)),
                    )
                    .with_style(Style::Dashed),
                ],
                ..Panel::default()
            },
            Panel {
                y_label: "Kc_hat [N/(mm/min)]".into(),
                series: vec![
                    Series::line("Kc_hat", along_path(rows, |r| r.kc_hat)),
                    Series::markers("trend (median of steady windows)", trend),
                ],
                ..Panel::default()
            },
        ],
        panel_height_px: 230,
        ..Figure::default()
    };
    let run_plot = time_series(&fig, out.join("report_run.svg"))?;
    let mut svgs = vec![("run", inline_svg(&run_plot.svg)?)];

    // The stored trend across runs, per tool of this log.
    let mut history_note = String::new();
    if let Some(h) = history {
        match History::open(h) {
            Ok(h) => {
                let tools: std::collections::BTreeSet<u16> =
                    rows.iter().map(|r| r.tool.unwrap_or(0)).collect();
                let mut series = Vec::new();
                for t in tools {
                    let pts = h.wear_trend(t)?;
                    if pts.is_empty() {
                        continue;
                    }
                    series.push(Series::markers(
                        format!("tool {t}"),
                        pts.iter()
                            .enumerate()
                            .map(|(i, p)| (i as f64, p.rise_pct))
                            .collect(),
                    ));
                }
                if !series.is_empty() {
                    let chart = XyChart {
                        title: format!("Kc trend across runs ({})", h.path().display()),
                        x_label: "trend point (oldest first)".into(),
                        y_label: "Kc_hat rise over the fresh reference [%]".into(),
                        series,
                        width_px: 1000,
                        height_px: 400,
                        ..XyChart::default()
                    };
                    let w = acc_plot::xy_chart(&chart, out.join("report_trend.svg"))?;
                    svgs.push(("trend", inline_svg(&w.svg)?));
                }
                history_note = format!("tool history: {}", esc(&h.path().display().to_string()));
            }
            Err(e) => history_note = format!("tool history not read: {}", esc(&e.to_string())),
        }
    }

    let mut html = String::new();
    let saved: f64 = d.cuts.iter().map(|c| c.time_saved_s).sum();
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>acc report</title>\n<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse}}td,th{{border:1px solid #999;padding:2px 6px;text-align:right}}th{{background:#eee}}.plot svg{{max-width:100%;height:auto}}</style></head><body>\n<h1>acc report</h1>\n<p>run log: <code>{}</code>; {} periods of {:.3} s; {} cuts; time saved against the programmed feed {:+.1} s. {}</p>\n",
        esc(&log.display().to_string()),
        rows.len(),
        d.period_s,
        d.cuts.len(),
        saved,
        history_note
    );
    for (id, svg) in &svgs {
        let _ = writeln!(html, "<div class=\"plot\" id=\"plot-{id}\">{svg}</div>");
    }
    html.push_str("<h2>Cuts</h2>\n<table id=\"cuts\"><thead><tr><th>#</th><th>tool</th><th>program</th><th>blocks</th><th>t start [s]</th><th>t end [s]</th><th>x start [mm]</th><th>x end [mm]</th><th>time in cut [s]</th><th>F mean [N]</th><th>F max [N]</th><th>RMS F−Fr [N]</th><th>override histogram [% : periods]</th><th>alarms</th><th>time saved [s]</th></tr></thead><tbody>\n");
    for (i, c) in d.cuts.iter().enumerate() {
        let hist: Vec<String> = c
            .override_hist
            .iter()
            .enumerate()
            .filter(|(_, n)| **n > 0)
            .map(|(b, n)| format!("{}:{n}", b * usize::from(c.hist_bin_pct)))
            .collect();
        let alarms = c.alarms().join(", ");
        let _ = writeln!(
            html,
            "<tr class=\"cut\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{:+.1}</td></tr>",
            i + 1,
            c.tool,
            c.program,
            esc(&c.block_range()),
            c.t_start_s,
            c.t_end_s,
            c.x_start_mm,
            c.x_end_mm,
            c.time_in_cut_s,
            c.force_mean_n,
            c.force_max_n,
            c.force_rms_error_n,
            hist.join(" "),
            if alarms.is_empty() { "—".into() } else { esc(&alarms) },
            c.time_saved_s
        );
    }
    html.push_str("</tbody></table>\n<h2>Alarms</h2>\n<table id=\"alarms\"><thead><tr><th>tool</th><th>t [s]</th><th>alarm</th><th>detail</th></tr></thead><tbody>\n");
    for (tool, t, kind, detail) in &d.alarms {
        let _ = writeln!(
            html,
            "<tr class=\"alarm\"><td>{tool}</td><td>{t:.1}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>",
            esc(kind),
            esc(detail)
        );
    }
    html.push_str("</tbody></table>\n<h2>Kc trend</h2>\n<table id=\"trend\"><thead><tr><th>tool</th><th>block</th><th>t [s]</th><th>Kc_hat [N/(mm/min)]</th><th>reference</th><th>rise [%]</th><th>level</th></tr></thead><tbody>\n");
    for w in &d.wear {
        let _ = writeln!(
            html,
            "<tr class=\"wear\"><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.3}</td><td>{:.3}</td><td>{:+.1}</td><td>{}</td></tr>",
            w.tool,
            w.block,
            w.t_s,
            w.kc,
            w.kc_ref,
            w.rise_pct,
            w.level.as_str()
        );
    }
    html.push_str("</tbody></table>\n</body></html>\n");
    let page = out.join("report.html");
    std::fs::write(&page, html).with_context(|| format!("{}: cannot write", page.display()))?;
    Ok(page)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_run_log_is_an_error_naming_file_line_and_column() {
        let dir = tempfile::tempdir().expect("tmp");
        let log = dir.path().join("bad.csv");
        let header = acc_runtime::record::columns().join(",");
        let mut row = vec![""; acc_runtime::record::columns().len()];
        row[0] = "0.1";
        row[1] = "x";
        std::fs::write(&log, format!("{header}\n{}\n", row.join(","))).expect("write");
        let args = ReportArgs {
            run_log: log.clone(),
            out: dir.path().join("r"),
            history: None,
            overload_force_n: None,
        };
        let e = format!("{:#}", run(&args).expect_err("bad log"));
        assert!(
            e.contains("bad.csv") && e.contains("line 2") && e.contains("period"),
            "{e}"
        );
        std::fs::write(&log, "a,b\n1,2\n").expect("write");
        let e = format!("{:#}", run(&args).expect_err("not a run log"));
        assert!(e.contains("not an acc run log"), "{e}");
    }

    #[test]
    fn the_page_has_one_row_per_cut_and_no_external_reference() {
        let row = |t: f64, f: f64| RunRecord {
            t_s: t,
            period: (t * 10.0).round() as u64,
            tool: Some(4),
            program: Some(7),
            block: Some(30),
            x_mm: Some(t * 5.0),
            force_n: Some(f),
            force_valid: true,
            force_ref_n: Some(800.0),
            kc_hat: Some(6.0),
            override_cmd_pct: Some(80),
            override_applied_pct: Some(80),
            ..RunRecord::default()
        };
        let mut rows = Vec::new();
        for i in 0..100 {
            let t = f64::from(i) * 0.1;
            let f = if (30..60).contains(&i) { 0.0 } else { 800.0 };
            rows.push(row(t, f));
        }
        let dir = tempfile::tempdir().expect("tmp");
        let d = ReportData::of(rows);
        assert_eq!(d.cuts.len(), 2);
        let page = write_report(&d, Path::new("run.csv"), dir.path(), None, None).expect("page");
        let html = std::fs::read_to_string(page).expect("html");
        assert_eq!(html.matches("<tr class=\"cut\">").count(), 2);
        assert!(html.contains("<svg") && !html.contains("<script"));
        assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
    }
}
