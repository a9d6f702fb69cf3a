//! `acc what-if --log run.csv --scenario S --preset other.toml [--out DIR]`: what-if on a
//! recorded cut. The production loop with the other preset runs closed loop on the twin
//! (the scenario's machine, tool and measurement) whose cut geometry comes from the log
//! (`acc_sim::whatif`); the recorded and the what-if run are reported side by side.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use acc_plot::{time_series, Figure, HLine, Panel, Series};
use acc_runtime::record::{read_run_log, RunLogWriter, RunRecord};
use acc_sim::whatif::{
    cut_metrics, force_difference_rms_n, has_truth, run_what_if, side_by_side, CutGeometry,
};
use acc_sim::{Scenario, Workpiece};
use anyhow::{bail, Context as _};

use crate::cmd_sim::load_scenario;

/// Arguments of `acc what-if`.
#[derive(Debug, clap::Args)]
pub struct WhatIfArgs {
    /// The recorded run log (the one schema, docs/runlog.md).
    #[arg(long, value_name = "RUN.CSV")]
    pub log: PathBuf,
    /// The preset to try (configs/presets/*.toml): other gains, Fr, override limits or
    /// quantizer.
    #[arg(long, value_name = "PRESET.TOML")]
    pub preset: PathBuf,
    /// The twin: a scenario (file or name in configs/scenarios) giving the machine, tool,
    /// measurement channel, programmed feed and fault policy the log was recorded with.
    #[arg(long, value_name = "SCENARIO")]
    pub scenario: String,
    /// For a log without plant truth (`acc run`): the workpiece it cut; the engagement
    /// comes from it instead of the log's depth columns.
    #[arg(long, value_name = "WORKPIECE.TOML")]
    pub workpiece: Option<PathBuf>,
    /// With `--workpiece`: workpiece coordinate of the tool centre when the recorded run
    /// began (at `acc run`'s first read, as for `acc discrepancy`; 0 for `acc board-sim`), mm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub x0_mm: f64,
    /// The shop tool table of the what-if: a file (configs/tooltable.toml keys), or `none`
    /// to run the preset alone (its Fr and override range). Default: the scenario's own
    /// `[tools]` table, whose per-tool Fr and limits then take precedence over the preset's.
    #[arg(long, value_name = "TOOLTABLE.TOML|none")]
    pub tools: Option<String>,
    /// Output directory: `whatif.csv` (the what-if run log), `whatif.md` (the table),
    /// `whatif.svg/.png` (force and override along the path, recorded and what-if).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// The recorded rows of `path`; errors name the file.
pub fn read_log(path: &Path) -> anyhow::Result<Vec<RunRecord>> {
    read_log_of("--log", path)
}

/// The recorded rows of `path`, given by the option `option`; errors name both.
pub fn read_log_of(option: &str, path: &Path) -> anyhow::Result<Vec<RunRecord>> {
    let f =
        File::open(path).with_context(|| format!("{option} {}: cannot open", path.display()))?;
    let rows = read_run_log(f).with_context(|| format!("{option} {}", path.display()))?;
    if rows.is_empty() {
        bail!("{option} {}: the run log has no rows", path.display());
    }
    Ok(rows)
}

/// The twin's geometry for `args`: the workpiece if given, else the log's plant truth.
pub fn geometry(
    args: &WhatIfArgs,
    sc: &Scenario,
    rows: &[RunRecord],
) -> anyhow::Result<CutGeometry> {
    if let Some(wp) = &args.workpiece {
        if !(args.x0_mm.is_finite() && args.x0_mm.abs() <= 1e5) {
            bail!("--x0-mm {}: allowed -1e5 ..= 1e5 mm", args.x0_mm);
        }
        let workpiece = Workpiece::load(wp)?;
        workpiece.check_tool(wp, sc.tool.diameter_mm)?;
        return Ok(CutGeometry::Workpiece {
            workpiece,
            x0_mm: args.x0_mm,
        });
    }
    if args.x0_mm != 0.0 {
        bail!("--x0-mm {} needs --workpiece", args.x0_mm);
    }
    let law = acc_sim::process::ForceLaw::new(sc.tool.process);
    let p = acc_sim::whatif::profile_from_rows(&args.log, rows, &law)?;
    Ok(CutGeometry::Logged(Arc::new(p)))
}

/// Run `acc what-if`.
pub fn run_cmd(args: &WhatIfArgs) -> anyhow::Result<()> {
    let mut sc = load_scenario(&args.scenario, None)?;
    let controller = acc_config::load_controller(&args.preset)?;
    match args.tools.as_deref() {
        None => {}
        Some("none") => sc.tools = None,
        Some(p) => sc.tools = Some(acc_config::ToolTable::load(p).context("--tools")?),
    }
    let board = sc.machine.override_path.step_pct;
    if !controller.override_spec.step_pct.is_multiple_of(board) {
        bail!(
            "{}: key `override.step_pct` = {} is not a multiple of the twin's board step {board} % (scenario {}): allowed a multiple of {board}",
            args.preset.display(),
            controller.override_spec.step_pct,
            sc.path.display()
        );
    }
    let rows = read_log(&args.log)?;
    if let Some(table) = &sc.tools {
        let tool = rows.iter().find_map(|r| r.tool).unwrap_or(0);
        let fr = table.get(tool).fr_n;
        if fr != controller.force_ref_n {
            println!(
                "note: the tool table's Fr {fr} N (tool {tool}) applies, not the preset's {} N; `--tools none` runs the preset alone",
                controller.force_ref_n
            );
        }
    }
    let geo = geometry(args, &sc, &rows)?;
    let wi = run_what_if(&sc, &geo, controller)?;
    let by_truth = has_truth(&rows) && has_truth(&wi.rows);
    let rec_m = cut_metrics(&rows, by_truth);
    let wi_m = cut_metrics(&wi.rows, by_truth);
    let table = side_by_side(&rec_m, &wi_m);
    println!(
        "what-if: {} on the twin of `{}` (geometry: {}), closed loop",
        args.preset.display(),
        sc.path.display(),
        match &geo {
            CutGeometry::Logged(p) => format!("the log's plant truth, {} positions", p.len()),
            CutGeometry::Workpiece { workpiece, x0_mm } =>
                format!("workpiece `{}` from x0 = {x0_mm} mm", workpiece.name),
        }
    );
    println!(
        "in cut: {}",
        if by_truth {
            "radial depth > 0 (both runs have the plant truth)"
        } else {
            "measured force above Fr/4 (the recorded log has no plant truth)"
        }
    );
    print!("{table}");
    let diff = force_difference_rms_n(&rows, &wi.rows);
    println!("period-by-period RMS of the measured-force difference: {diff:.1} N");
    if !wi.finished {
        println!("note: the what-if run did not reach the end of the recorded path");
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)
            .with_context(|| format!("{}: cannot create", out.display()))?;
        let csv = out.join("whatif.csv");
        let f = File::create(&csv).with_context(|| format!("{}: cannot create", csv.display()))?;
        let mut w = RunLogWriter::new(BufWriter::new(f))?;
        for r in &wi.rows {
            w.write(r)?;
        }
        let md = format!(
            "# what-if: `{}` on `{}`\n\nRecorded: `{}`. Twin: `{}`.\n\n{table}\nPeriod-by-period RMS of the measured-force difference: {diff:.1} N.\n",
            args.preset.display(),
            args.log.display(),
            args.log.display(),
            sc.path.display()
        );
        std::fs::write(out.join("whatif.md"), md)
            .with_context(|| format!("{}: cannot write", out.display()))?;
        let w = plot(
            &rows,
            &wi.rows,
            rec_m.force_ref_n,
            wi_m.force_ref_n,
            &out.join("whatif.svg"),
        )?;
        println!(
            "wrote {}, {}, {} and {}",
            csv.display(),
            out.join("whatif.md").display(),
            w.svg.display(),
            w.png.display()
        );
    }
    Ok(())
}

fn along(rows: &[RunRecord], f: impl Fn(&RunRecord) -> Option<f64>) -> Vec<(f64, f64)> {
    rows.iter()
        .filter_map(|r| Some((r.x_true_mm.or(r.x_mm)?, f(r)?)))
        .collect()
}

/// Force and override along the path, recorded and what-if.
fn plot(
    rec: &[RunRecord],
    wi: &[RunRecord],
    fr_rec: f64,
    fr_wi: f64,
    out: &Path,
) -> anyhow::Result<acc_plot::Written> {
    let mut hlines = vec![HLine::new("Fr recorded", fr_rec)];
    if (fr_wi - fr_rec).abs() > 1e-9 {
        hlines.push(HLine::new("Fr what-if", fr_wi));
    }
    let fig = Figure {
        title: "recorded vs what-if along the path".into(),
        x_label: "path position x [mm]".into(),
        panels: vec![
            Panel {
                y_label: "force [N]".into(),
                series: vec![
                    Series::line("recorded", along(rec, |r| r.force_n)),
                    Series::line("what-if", along(wi, |r| r.force_n)),
                ],
                hlines,
                ..Panel::default()
            },
            Panel {
                y_label: "override [%]".into(),
                series: vec![
                    Series::line(
                        "recorded",
                        along(rec, |r| r.override_cmd_pct.map(f64::from)),
                    ),
                    Series::line("what-if", along(wi, |r| r.override_cmd_pct.map(f64::from))),
                ],
                ..Panel::default()
            },
        ],
        panel_height_px: 320,
        ..Figure::default()
    };
    Ok(time_series(&fig, out)?)
}
