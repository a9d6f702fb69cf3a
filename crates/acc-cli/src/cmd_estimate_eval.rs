//! `acc estimate-eval`: accuracy of the spindle force estimators (seed 000, physics.md §2).
//!
//! 1. The simulated seed 000 experiment (`configs/calibration/seed000-sweep.toml`): air
//!    cuts, calibration cut, feed sweep; a table of RMS error and error rate per method
//!    against the true force, and a plot like the paper's Fig. 8 (forces and errors over
//!    the feed).
//! 2. The turning data set in `../shared/data/vicomtech-turning/`: leave-one-tool-out
//!    cross-validation (fit on six tools, validate on the seventh; the headline), then
//!    calibrate on one tool and validate on the others; MAPE against the dynamometer `F_c`.
//! 3. The wax-milling logs in `../shared/data/umich-cnc-mill/`: the estimator must report
//!    no cutting load above its noise floor.
//!
//! With `--stream` it instead runs the stream force source on a recorded or piped sample
//! stream and prints one CSV line per period.

use std::path::{Path, PathBuf};

use acc_core::spindle_force::{AdaptRule, EstimatorConfig, Method, NoLoadMode};
use acc_core::{ForceSource, PeriodInput};
use acc_plot::{time_series, xy_chart, Figure, HLine, Panel, Series, XyChart, PALETTE};
use acc_sim::motor::sweep::{self, SweepConfig, SweepResult};
use acc_spindle::calibrate::{calibrate_recording, CalPoint};
use acc_spindle::datasets::{read_calibration_periods, read_mill, read_turning, TurningRow};
use acc_spindle::eval::{min_median_max, wax_check, WaxSetup};
use acc_spindle::turning::{cross_tool, leave_one_tool_out, LotoFold, TurningModel};
use acc_spindle::{SampleFormat, SampleStream, SpindleCalibration, StreamForceSource};
use anyhow::{bail, Context as _};

/// Arguments of `acc estimate-eval`.
#[derive(Debug, clap::Args)]
pub struct EstimateEvalArgs {
    /// Sweep file of the simulated experiment.
    #[arg(long, default_value = "configs/calibration/seed000-sweep.toml")]
    pub sweep: PathBuf,
    /// Folder with the public data sets (`vicomtech-turning/`, `umich-cnc-mill/`).
    #[arg(long, default_value = "../shared/data")]
    pub data: PathBuf,
    /// The Fig. 8-like plot of the sweep (SVG + PNG); `turning.svg/.png` (estimate vs
    /// dynamometer on the real turning data) is written next to it.
    #[arg(
        long,
        value_name = "OUT.svg",
        default_value = "out/estimate-eval/fig8.svg"
    )]
    pub plot: PathBuf,
    /// Do not draw plots.
    #[arg(long)]
    pub no_plot: bool,
    /// Write the calibration fitted on the simulated calibration cut to this TOML file.
    #[arg(long, value_name = "CAL.toml")]
    pub save_calibration: Option<PathBuf>,
    /// Calibrate from a recording of periods instead (CSV `rpm,power_w,current_a,
    /// force_ref_n,air`) and write the calibration to `--save-calibration`.
    #[arg(long, value_name = "PERIODS.csv")]
    pub calibrate_from: Option<PathBuf>,
    /// Only the simulated sweep (skip the real data).
    #[arg(long)]
    pub sim_only: bool,
    /// Estimate from a sample stream instead: a file (`.csv`, `.f32`, `.f64`) or `-` for
    /// standard input. Needs `--calibration`.
    #[arg(long, value_name = "FILE|-")]
    pub stream: Option<PathBuf>,
    /// Stream format: `csv`, `f32le`, `f64le` (default: from the file extension, else csv).
    #[arg(long)]
    pub format: Option<String>,
    /// Stream sampling rate, Hz.
    #[arg(long, default_value_t = 10_000.0)]
    pub rate_hz: f64,
    /// Spindle speed during the stream, rpm.
    #[arg(long, default_value_t = 1500.0)]
    pub rpm: f64,
    /// Control period, s.
    #[arg(long, default_value_t = 0.1)]
    pub period_s: f64,
    /// Calibration file for `--stream`.
    #[arg(long, value_name = "CAL.toml")]
    pub calibration: Option<PathBuf>,
    /// Method for `--stream`: power, power-efficiency, current, motor-characteristics.
    #[arg(long, default_value = "power-efficiency")]
    pub method: String,
    /// Tool radius for `--stream`, mm.
    #[arg(long, default_value_t = 40.0)]
    pub tool_radius_mm: f64,
}

/// Seed 000's reported accuracy (RMS error N, error rate %), in [`Method::ALL`] order;
/// the paper has no separate efficiency-corrected power method.
const PAPER: [Option<(f64, f64)>; 4] = [
    Some((55.81, 19.42)),
    Some((10.73, 3.73)),
    Some((13.86, 4.82)),
    None,
];

/// Run the command.
pub fn run(args: &EstimateEvalArgs) -> anyhow::Result<()> {
    if let Some(stream) = &args.stream {
        return run_stream(args, stream);
    }
    if let Some(rec) = &args.calibrate_from {
        return run_calibrate(args, rec);
    }
    let sweep_path = crate::configs::find("calibration", &args.sweep.to_string_lossy());
    let (cfg, motor) = SweepConfig::load(&sweep_path)?;
    let r = sweep::run(&cfg, &motor)?;
    print_sweep(&cfg, &r);
    if let Some(path) = &args.save_calibration {
        r.calibration.save(path)?;
        println!("calibration written to {}", path.display());
    }
    let plot_dir = (!args.no_plot).then(|| {
        args.plot
            .parent()
            .map_or_else(PathBuf::new, Path::to_path_buf)
    });
    if !args.no_plot {
        let w = plot_fig8(&r, &args.plot)?;
        println!("plot: {} and {}", w.svg.display(), w.png.display());
    }
    if !args.sim_only {
        real_data(&args.data, plot_dir.as_deref())?;
    }
    Ok(())
}

fn print_sweep(cfg: &SweepConfig, r: &SweepResult) {
    println!(
        "Simulated seed 000 sweep: face cutter Ø{} mm, {} inserts, {} rpm, a_p {} mm, a_e {} mm, {} feeds",
        cfg.tool.diameter_mm,
        cfg.tool.teeth,
        cfg.sweep.rpm,
        cfg.cut.axial_mm,
        cfg.cut.lateral_mm,
        r.points.len()
    );
    println!(
        "calibration: {} rpm, feeds {:?} mm/min",
        cfg.calibration.rpm, cfg.calibration.feeds_mm_min
    );
    print!("Kt per calibration feed (N·m/A; seed 000 Table 2 analogue):");
    for (f, kt) in &r.kt_per_feed {
        print!(" {f:.0}: {kt:.3}");
    }
    println!();
    println!();
    println!("| method | RMS error [N] | error rate [%] | paper RMS [N] | paper rate [%] |");
    println!("| --- | ---: | ---: | ---: | ---: |");
    for (j, m) in Method::ALL.iter().enumerate() {
        let (pr, pp) = PAPER[j].map_or(("—".to_string(), "—".to_string()), |(a, b)| {
            (format!("{a:.2}"), format!("{b:.2}"))
        });
        println!(
            "| {} | {:.2} | {:.2} | {} | {} |",
            m.name(),
            r.rms_n[j],
            r.rate_pct[j],
            pr,
            pp
        );
    }
    println!(
        "| power, no-load model off | {:.2} | {:.2} | — | — |",
        r.no_load_off.0, r.no_load_off.1
    );
    println!();
    println!("| feed [mm/min] | true [N] | current | motor-char. | power | power-eff. |");
    println!("| ---: | ---: | ---: | ---: | ---: | ---: |");
    for p in &r.points {
        println!(
            "| {:.0} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            p.feed_mm_min, p.true_n, p.est_n[0], p.est_n[1], p.est_n[2], p.est_n[3]
        );
    }
    println!();
}

fn plot_fig8(r: &SweepResult, out: &Path) -> anyhow::Result<acc_plot::Written> {
    let pts = |f: &dyn Fn(&sweep::SweepPoint) -> f64| -> Vec<(f64, f64)> {
        r.points.iter().map(|p| (p.feed_mm_min, f(p))).collect()
    };
    let mut force =
        vec![Series::line("true (dynamometer)", pts(&|p| p.true_n)).with_color(PALETTE[0])];
    let mut error = Vec::new();
    for (j, m) in Method::ALL.iter().enumerate() {
        let c = PALETTE[(j + 1) % PALETTE.len()];
        force.push(Series::markers(m.name(), pts(&|p| p.est_n[j])).with_color(c));
        error.push(Series::line(m.name(), pts(&|p| p.est_n[j] - p.true_n)).with_color(c));
    }
    let fig = Figure {
        title: "Spindle force estimators on the simulated seed 000 sweep (cf. Fig. 8)".into(),
        x_label: "feed [mm/min]".into(),
        panels: vec![
            Panel {
                y_label: "tangential force [N]".into(),
                series: force,
                ..Panel::default()
            },
            Panel {
                y_label: "estimate − true [N]".into(),
                series: error,
                hlines: vec![HLine::new("", 0.0)],
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    create_parent(out)?;
    Ok(time_series(&fig, out)?)
}

fn create_parent(out: &Path) -> anyhow::Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}

/// Estimate vs dynamometer, every tool predicted by the model fitted on the other tools
/// (leave-one-tool-out), for plain power and the chosen model.
fn plot_turning(rows: &[TurningRow], out: &Path) -> anyhow::Result<acc_plot::Written> {
    let mut series = Vec::new();
    for (j, m) in [TurningModel::Plain, TurningModel::CHOSEN]
        .into_iter()
        .enumerate()
    {
        let mut pts = Vec::new();
        for fold in leave_one_tool_out(rows, m)? {
            pts.extend(
                rows.iter()
                    .filter(|r| r.tool == fold.held_out_tool)
                    .map(|r| (r.force_n, m.predict(fold.params, r))),
            );
        }
        series.push(Series::markers(m.label(), pts).with_color(PALETTE[j + 1]));
    }
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(r.force_n), b.max(r.force_n))
        });
    series.push(
        Series::line("estimate = dynamometer", vec![(lo, lo), (hi, hi)]).with_color(PALETTE[0]),
    );
    let chart = XyChart {
        title: "Turning data (Vicomtech, CC BY-SA 4.0): each tool estimated by the model \
                fitted on the other six"
            .into(),
        x_label: "dynamometer F_c [N]".into(),
        y_label: "estimated F_c [N]".into(),
        series,
        ..XyChart::default()
    };
    create_parent(out)?;
    Ok(xy_chart(&chart, out)?)
}

/// Print a markdown table: one row per model, one column per tool, then min/median/max
/// (and the mean when `with_mean`).
fn print_tool_table(head: &str, tools: &[u32], rows: &[(TurningModel, Vec<f64>)], mean: bool) {
    print!("| model |");
    for t in tools {
        print!(" {head} {t} |");
    }
    println!(" min | median | max |{}", if mean { " mean |" } else { "" });
    println!(
        "| --- |{} ---: | ---: | ---: |{}",
        " ---: |".repeat(tools.len()),
        if mean { " ---: |" } else { "" }
    );
    for (m, v) in rows {
        let (lo, med, hi) = min_median_max(v);
        print!("| {} |", m.label());
        for x in v {
            print!(" {x:.2} |");
        }
        print!(" {lo:.2} | {med:.2} | {hi:.2} |");
        if mean {
            print!(" {:.2} |", v.iter().sum::<f64>() / v.len().max(1) as f64);
        }
        println!();
    }
    println!();
}

/// The leave-one-tool-out table (the headline) and the chosen model's bias per tool.
fn print_loto(rows: &[TurningRow]) -> anyhow::Result<()> {
    let folds: Vec<(TurningModel, Vec<LotoFold>)> = TurningModel::ALL
        .iter()
        .map(|&m| leave_one_tool_out(rows, m).map(|f| (m, f)))
        .collect::<Result<_, _>>()?;
    let tools: Vec<u32> = folds
        .first()
        .map(|(_, f)| f.iter().map(|x| x.held_out_tool).collect())
        .unwrap_or_default();
    println!(
        "Leave-one-tool-out: fit on the other {} tools pooled, MAPE [%] vs dynamometer F_c on \
         the held-out tool.",
        tools.len().saturating_sub(1)
    );
    println!();
    let table: Vec<(TurningModel, Vec<f64>)> = folds
        .iter()
        .map(|(m, f)| (*m, f.iter().map(|x| x.mape_pct).collect()))
        .collect();
    print_tool_table("held out", &tools, &table, true);
    if let Some((m, f)) = folds.iter().find(|(m, _)| *m == TurningModel::CHOSEN) {
        print!(
            "Chosen: {}; mean signed error per held-out tool [%]:",
            m.label()
        );
        for x in f {
            print!(" {}: {:+.2}", x.held_out_tool, x.bias_pct);
        }
        println!();
        println!();
    }
    Ok(())
}

fn real_data(data: &Path, plot_dir: Option<&Path>) -> anyhow::Result<()> {
    let turning = data.join("vicomtech-turning/tool_wear_tools_3-10.csv");
    if turning.exists() {
        let (rows, skipped) = read_turning(&turning)?;
        println!(
            "Real turning data ({} segments, {} skipped with feed 0): Vicomtech / Mondragon \
             Unibertsitatea, CC BY-SA 4.0 (Ferrando Chacón et al., Int. J. Adv. Manuf. \
             Technol. 125:4027–4045, 2023).",
            rows.len(),
            skipped
        );
        print_loto(&rows)?;
        println!("Calibrate on one tool, validate on the others: MAPE [%] vs dynamometer F_c (mean over the validation tools).");
        println!();
        let results: Vec<(TurningModel, Vec<f64>)> = TurningModel::ALL
            .iter()
            .map(|&m| {
                cross_tool(&rows, m).map(|r| (m, r.iter().map(|x| x.mean_mape_pct).collect()))
            })
            .collect::<Result<_, _>>()?;
        let tools: Vec<u32> = rows
            .iter()
            .map(|r| r.tool)
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        print_tool_table("cal. tool", &tools, &results, false);
        if let Some(dir) = plot_dir {
            let w = plot_turning(&rows, &dir.join("turning.svg"))?;
            println!("plot: {} and {}", w.svg.display(), w.png.display());
            println!();
        }
    } else {
        println!("skipping the turning data: {} not found", turning.display());
    }
    let mill = data.join("umich-cnc-mill");
    if mill.is_dir() {
        let mut exps = Vec::new();
        for k in 1..=12 {
            let p = mill.join(format!("experiment_{k:02}.csv"));
            if p.exists() {
                exps.push(read_mill(&p)?);
            }
        }
        let w = wax_check(&exps, WaxSetup::default())?;
        println!(
            "Wax milling (University of Michigan SMART lab, CC0; {} experiments): no-load {:.1} W \
             (σ {:.1} W per 100 ms, {} air periods); {} valid cutting periods, {} above the \
             noise floor of {:.1} N; mean cutting power {:+.1} W, mean force {:+.2} N; \
             invalid: {:?}",
            exps.len(),
            w.no_load_power_w,
            w.sigma_power_w,
            w.air_periods,
            w.valid_cut_periods,
            w.above_floor,
            w.noise_floor_n,
            w.mean_cut_power_w,
            w.mean_force_n,
            w.invalid
        );
    } else {
        println!("skipping the wax data: {} not found", mill.display());
    }
    Ok(())
}

fn run_calibrate(args: &EstimateEvalArgs, rec: &Path) -> anyhow::Result<()> {
    let Some(out) = &args.save_calibration else {
        bail!("--calibrate-from needs --save-calibration <CAL.toml>");
    };
    let rows = read_calibration_periods(rec)?;
    let air: Vec<(f64, f64, f64)> = rows
        .iter()
        .filter(|r| r.air)
        .map(|r| (r.rpm, r.power_w, r.current_a))
        .collect();
    let cut: Vec<CalPoint> = rows
        .iter()
        .filter(|r| !r.air)
        .map(|r| CalPoint {
            rpm: r.rpm,
            power_w: r.power_w,
            current_a: r.current_a,
            force_ref_n: r.force_ref_n,
        })
        .collect();
    let cal = calibrate_recording(
        &air,
        &cut,
        args.tool_radius_mm,
        AdaptRule::default(),
        format!("calibrated from {}", rec.display()),
    )
    .with_context(|| format!("{}", rec.display()))?;
    cal.save(out)?;
    println!(
        "{} air periods, {} cutting periods -> {}",
        air.len(),
        cut.len(),
        out.display()
    );
    Ok(())
}

fn run_stream(args: &EstimateEvalArgs, stream: &Path) -> anyhow::Result<()> {
    let Some(cal_path) = &args.calibration else {
        bail!("--stream needs --calibration <CAL.toml>");
    };
    let cal = SpindleCalibration::load(cal_path)?;
    let method = Method::ALL
        .into_iter()
        .find(|m| m.name() == args.method)
        .with_context(|| {
            format!(
                "--method `{}`: allowed power, power-efficiency, current, motor-characteristics",
                args.method
            )
        })?;
    let format = match &args.format {
        Some(f) => SampleFormat::parse(f)
            .with_context(|| format!("--format `{f}`: allowed csv, f32le, f64le"))?,
        None => SampleFormat::from_path(stream).unwrap_or(SampleFormat::Csv),
    };
    let cfg = EstimatorConfig {
        method,
        tool_radius_mm: args.tool_radius_mm,
        no_load: NoLoadMode::Adaptive,
        ..EstimatorConfig::default()
    };
    let est = cal.estimator(cfg)?;
    let reader = SampleStream::open(stream, format)?;
    let mut src = StreamForceSource::new(reader, args.rate_hz, est)?;
    println!("t_s,force_n,power_w,valid,reason");
    let mut k = 0u64;
    loop {
        let input = PeriodInput {
            period_s: args.period_s,
            spindle_rpm: args.rpm,
            ..PeriodInput::default()
        };
        let s = src.estimate(&input);
        if let Some(e) = src.error() {
            if !matches!(e, acc_spindle::StreamError::End { .. }) {
                bail!("{}: {e}", stream.display());
            }
            break;
        }
        k += 1;
        let reason = match src.inner().last() {
            Some(Err(i)) => i.as_str(),
            _ => "",
        };
        println!(
            "{:.3},{:.3},{},{},{}",
            k as f64 * args.period_s,
            s.force_n,
            s.power_w.map_or(String::new(), |p| format!("{p:.2}")),
            s.valid,
            reason
        );
    }
    Ok(())
}
