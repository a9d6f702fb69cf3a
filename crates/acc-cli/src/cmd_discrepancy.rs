//! `acc discrepancy`: compare a model with a measured run log, name the missing effect,
//! write the updated model and show the gap shrink on a sealed part of the log.

use std::path::{Path, PathBuf};

use acc_ident::engagement::PathEngagement;
use acc_ident::model::Channel;
use acc_ident::{import, workflow, EffectKind, Model, RunLog};
use acc_plot::{
    grouped_bars, time_series, xy_chart, Figure, GroupedBars, Panel, Series, Shade, XyChart,
};
use anyhow::{bail, Context};

/// Arguments of `acc discrepancy`.
#[derive(clap::Args, Debug)]
pub struct DiscrepancyArgs {
    /// Model file (machine + tool sections of the simulator, `[measurement]`, `[effects]`).
    /// Optional with `--import`: the importer's nominal model is used (turning: constant
    /// Ks calibrated on the first 20 % of the tool's rows).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Measured run log (CSV in the run-log schema), or a file for `--import`.
    #[arg(long)]
    pub measured: PathBuf,
    /// Output directory (created): report.json, report.md, model.updated.toml,
    /// machine.updated.toml, tool.updated.toml, plots (SVG + PNG).
    #[arg(long)]
    pub out: PathBuf,
    /// Read `--measured` with an importer: `vicomtech-turning` or `umich-mill`.
    #[arg(long)]
    pub import: Option<String>,
    /// Tool id for `--import vicomtech-turning` (3, 4, 5, 6, 7, 9, 10).
    #[arg(long)]
    pub tool: Option<u32>,
    /// Compared channel, overriding the model's `measurement.channel`: `power` or `force`.
    #[arg(long)]
    pub channel: Option<String>,
    /// Contiguous cross-validation folds (2..=20).
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Fraction of the log sealed at its end (0.05..=0.5).
    #[arg(long, default_value_t = 0.2)]
    pub sealed: f64,
    /// At most this many effects are added (0..=8).
    #[arg(long, default_value_t = 3)]
    pub max_effects: usize,
    /// Comma-separated candidate effects, to narrow the library (default: all 13, the set
    /// the twin's evaluation measures — docs/twin.md): tool_wear, motor_efficiency,
    /// feed_drive_lag, sensor_lowpass, override_dead_time, feed_exponent, runout,
    /// noload_drift, sensor_gain_drift, measurement_delay, depth_exponent, ks_step,
    /// second_order_drive. A candidate the log cannot separate is skipped with the reason.
    #[arg(long)]
    pub effects: Option<String>,
    /// Also fit the speed exponent γ with every candidate when the speed varies.
    #[arg(long)]
    pub fit_speed_exponent: bool,
    /// Below this effect-to-noise ratio (the change an effect makes to the prediction
    /// against the noise, the log's rounding and the model error it leaves) an effect is
    /// named only if no other candidate passes in its round and it is the first name.
    /// 1 (the default, measured in docs/twin.md) ..= 10: raise it to name fewer.
    #[arg(long, default_value_t = workflow::MIN_EFFECT_TO_NOISE)]
    pub min_enr: f64,
    /// Workpiece the measured run cut (`configs/workpieces/*.toml`, or the scenario file
    /// that names it): the engagement of a production log (`acc run`, no depth columns) is
    /// rebuilt from it at the logged path position `x_mm`, for the model's tool diameter.
    #[arg(long, conflicts_with = "program")]
    pub workpiece: Option<PathBuf>,
    /// With `--workpiece`: workpiece coordinate of the tool centre when `acc run` first read
    /// the machine (the end of the first row's period), mm (-1e5..=1e5). 0 = the start of
    /// the workpiece's first segment, where the simulated machine waits for the controller
    /// (`acc board-sim --wait-for-controller`), whatever the programmed feed. The replay is
    /// anchored there and the logged path `x_mm` is counted from it. Without it the start
    /// is searched within ±3 mm of 0 from the log's entries and depth changes, and used
    /// where it fits clearly better (report line "Path start"; docs/twin.md).
    #[arg(long, allow_negative_numbers = true)]
    pub x0_mm: Option<f64>,
    /// Judge the effects against the model's spindle as given: without it, on the power
    /// channel of a model without a motor curve, the spindle's no-load power, efficiency,
    /// copper loss and power window are first calibrated from the log's selection part
    /// (report section "Spindle calibration", docs/twin.md).
    #[arg(long)]
    pub no_spindle_calibration: bool,
    /// The NC program the measured run ran (`--program`, `--stock-box`/`--stock`, `--cell`,
    /// `--tools`, as `acc sim --program`): a log of `acc run` under a CNC controller that
    /// reports its block, e.g. `acc linuxcnc`'s `run.csv`. Each row's engagement is the
    /// program's sweep through the stock at the row's path position
    /// ([`crate::cmd_discrepancy_program`]).
    #[command(flatten)]
    pub program: crate::cmd_sim_program::ProgramArgs,
}

/// The engagement source of `--workpiece` (with `--x0-mm`) for `model`'s tool, if given.
fn path_engagement(
    args: &DiscrepancyArgs,
    model: Option<&Model>,
) -> anyhow::Result<Option<PathEngagement>> {
    let Some(wp) = &args.workpiece else {
        if let Some(x0) = args.x0_mm {
            bail!("--x0-mm {x0} needs --workpiece (the offset is along the workpiece)");
        }
        return Ok(None);
    };
    let x0_mm = args.x0_mm.unwrap_or(acc_ident::engagement::DEFAULT_X0_MM);
    if args.import.is_some() {
        bail!("--workpiece applies to run logs written by `acc`, not to --import");
    }
    let Some(model) = model else {
        bail!("--workpiece needs --model (the engagement uses the model's tool diameter)");
    };
    let eng = PathEngagement::load(wp, model.tool.diameter_mm, x0_mm)?;
    eprintln!(
        "engagement: from `{}` ({}), tool centre at {:+} mm of the workpiece at `acc run`'s first read{} (a simulator's log places itself by x_true_mm), tool diameter {} mm (the log's own depth columns, if any, are not used)",
        wp.display(),
        eng.workpiece.name,
        x0_mm,
        if args.x0_mm.is_some() {
            ""
        } else {
            ", the start searched from there"
        },
        eng.tool_diameter_mm
    );
    if eng.has_material_changes() {
        eprintln!(
            "engagement: note: `{}` has segments with ks_factor != 1; the model has one Ks, so a material change shows up as an unexplained discrepancy",
            wp.display()
        );
    }
    Ok(Some(eng))
}

fn load_inputs(args: &DiscrepancyArgs) -> anyhow::Result<(Model, RunLog, Option<Program>)> {
    // The model first: a production log's engagement needs its tool diameter.
    let given_model = args.model.as_deref().map(Model::load).transpose()?;
    let engagement = path_engagement(args, given_model.as_ref())?;
    let program = match (&args.program.program, &given_model) {
        (None, _) => None,
        (Some(_), _) if args.import.is_some() => {
            bail!("--program applies to run logs written by `acc`, not to --import")
        }
        (Some(_), None) => bail!("--program needs --model (its tool cuts the stock)"),
        (Some(_), Some(m)) => crate::cmd_discrepancy_program::ProgramLog::load(&args.program, m)?,
    };
    if let Some(p) = &program {
        let (log, blocks) = crate::cmd_discrepancy_program::read_log(&args.measured, p)?;
        let model = given_model.context("--program needs --model")?;
        let model = with_channel(model, args)?;
        return Ok((model, log.clone(), Some((p.entries_mm(), log, blocks))));
    }
    let (log, default_model) = match args.import.as_deref() {
        None => (
            acc_ident::runlog::read_csv_with(&args.measured, engagement.as_ref())?,
            None,
        ),
        Some("vicomtech-turning") => {
            let tools = import::vicomtech_turning(&args.measured)?;
            let ids: Vec<u32> = tools.keys().copied().collect();
            let Some(id) = args.tool else {
                bail!("--import vicomtech-turning needs --tool <id>; tools in the file: {ids:?}");
            };
            let Some(mut log) = tools.get(&id).cloned() else {
                bail!(
                    "{}: no tool {id}; tools in the file: {ids:?}",
                    args.measured.display()
                );
            };
            log.wear_vb_um = None; // withheld: the workflow must find the wear itself
            let m = import::turning_model(&log, 0.2);
            (log, Some(m))
        }
        Some("umich-mill") => {
            let log = import::umich_mill(&args.measured)?;
            let m = import::umich_model(&log);
            (log, Some(m))
        }
        Some(other) => bail!("--import `{other}`: allowed `vicomtech-turning`, `umich-mill`"),
    };
    let model = match (given_model, default_model) {
        (Some(m), _) => m,
        (None, Some(m)) => m,
        (None, None) => bail!("--model is required unless --import gives a nominal model"),
    };
    let model = with_channel(model, args)?;
    Ok((production_measurement(model, &log), log, None))
}

/// `model` as it measures a production log's channel: `acc run`'s `force_n` is its
/// estimate from the board's power register, so the force channel averages over the power
/// channel's window (`power_window_s`), whatever a dynamometer's `force_window_s` the
/// model file gives (`configs/models/paper_vmc.toml`: the last 0.05 s). A model with a
/// `[measurement.force_estimator]` already replays the estimator on the power.
fn production_measurement(mut model: Model, log: &RunLog) -> Model {
    let m = &mut model.measurement;
    if log.is_production()
        && m.channel == Channel::Force
        && m.force_estimator.is_none()
        && m.force_window_s != m.power_window_s
    {
        eprintln!(
            "measurement: the log is `acc run`'s, its force_n the estimate from the board's power register: the force channel is compared over the power's window, {} s (power_window_s), not the model's force_window_s = {} s (a dynamometer's)",
            m.power_window_s, m.force_window_s
        );
        m.force_window_s = m.power_window_s;
    }
    model
}

/// The entries of a `--program` run's path (mm), its log as analysed and each row's block.
type Program = (Vec<f64>, RunLog, Vec<Option<u16>>);

/// `model` compared on `--channel` if given.
fn with_channel(mut model: Model, args: &DiscrepancyArgs) -> anyhow::Result<Model> {
    match args.channel.as_deref() {
        None => {}
        Some("power") => model.measurement.channel = Channel::Power,
        Some("force") => model.measurement.channel = Channel::Force,
        Some(other) => bail!("--channel `{other}`: allowed `power`, `force`"),
    }
    Ok(model)
}

fn options(args: &DiscrepancyArgs) -> anyhow::Result<workflow::Options> {
    if !(workflow::MIN_EFFECT_TO_NOISE..=10.0).contains(&args.min_enr) {
        bail!(
            "--min-enr {}: allowed {} ..= 10 (the default {} is the configuration docs/twin.md measures; the flags only narrow it)",
            args.min_enr,
            workflow::MIN_EFFECT_TO_NOISE,
            workflow::MIN_EFFECT_TO_NOISE
        );
    }
    let mut o = workflow::Options {
        folds: args.folds,
        sealed_fraction: args.sealed,
        max_effects: args.max_effects.min(EffectKind::ALL.len()),
        fit_speed_exponent: args.fit_speed_exponent,
        min_effect_to_noise: args.min_enr,
        calibrate_spindle: !args.no_spindle_calibration,
        ..workflow::Options::default()
    };
    if let Some(list) = args.effects.as_deref().filter(|l| l.trim() != "all") {
        o.candidates = list
            .split(',')
            .map(|s| {
                EffectKind::from_name(s.trim()).with_context(|| {
                    format!(
                        "--effects: unknown effect `{}`; allowed: all, or any of {}",
                        s.trim(),
                        EffectKind::LIBRARY.map(|k| k.name()).join(", ")
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?;
    }
    Ok(o)
}

/// Run `acc discrepancy`.
pub fn run(args: &DiscrepancyArgs) -> anyhow::Result<()> {
    // Flags first: a bad flag is reported before any file is read.
    let mut opts = options(args)?;
    let (model, log, program) = load_inputs(args)?;
    // A controller plans the program's motion: its acceleration limit is a candidate.
    if program.is_some() && args.effects.is_none() {
        opts.candidates.push(EffectKind::FeedAccelLimit);
    }
    // A plant replay (a log with the applied override) takes the engagement from the
    // workpiece inside each period, as the simulator does.
    if let Some(eng) = path_engagement(args, Some(&model))? {
        opts.workpiece = Some((eng.workpiece, eng.x0_mm));
        opts.anchor_to_log = true;
        opts.estimate_path_start = args.x0_mm.is_none();
    }
    let analysis = workflow::analyse(&model, &log, &opts)
        .with_context(|| format!("analysing {}", args.measured.display()))?;
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let write = |name: &str, text: &str| -> anyhow::Result<()> {
        let p = out.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))
    };
    write("report.json", &analysis.report.to_json()?)?;
    write("report.md", &analysis.report.to_markdown())?;
    let updated = analysis.updated.folded();
    write(
        "model.updated.toml",
        &format!(
            "# Written by `acc discrepancy`: the model with the effects that passed selection\n# (named, or withheld: report.md says why) and refitted nominal parameters. [machine] and [tool] are the simulator's machine and tool files\n# (also written alone as machine.updated.toml and tool.updated.toml).\n{}",
            updated.to_toml()?
        ),
    )?;
    write("machine.updated.toml", &updated.machine_toml()?)?;
    write("tool.updated.toml", &updated.tool_toml()?)?;
    plots(&analysis, out, &analysis.report.input.unit)?;
    if let Some((entries, log, blocks)) = &program {
        use crate::cmd_discrepancy_program::{places_markdown, where_they_disagree};
        let places = where_they_disagree(log, &analysis.series, entries, blocks);
        let table = places_markdown(&places, &analysis.report.input.unit);
        write("where.md", &table)?;
        write(
            "rows.csv",
            &crate::cmd_discrepancy_program::rows_csv(log, &analysis.series, blocks),
        )?;
        println!("where the model and the run disagree (where.md):\n{table}");
        crate::cmd_discrepancy_program::print_findings(&analysis.report);
    }
    println!("{}", analysis.report.conclusion);
    println!("wrote {}", out.display());
    Ok(())
}

fn plots(a: &workflow::Analysis, out: &Path, unit: &str) -> anyhow::Result<()> {
    let s = &a.series;
    let pts =
        |y: &[f64]| -> Vec<(f64, f64)> { s.t_s.iter().copied().zip(y.iter().copied()).collect() };
    let mut shades: Vec<Shade> = s
        .flagged
        .iter()
        .map(|&(a, b)| Shade::new("nominal biased (significant)", a, b))
        .collect();
    if let Some(&t_end) = s.t_s.last() {
        shades.push(Shade::new("sealed part", s.sealed_from_s, t_end));
    }
    let resid = |y: &[f64]| -> Vec<f64> { s.measured.iter().zip(y).map(|(m, p)| m - p).collect() };
    let fig = Figure {
        title: "Measured, nominal and updated model (open-loop replay)".into(),
        x_label: "time [s]".into(),
        panels: vec![
            Panel {
                y_label: format!("channel [{unit}]"),
                series: vec![
                    Series::line("measured", pts(&s.measured)),
                    Series::line("nominal", pts(&s.nominal)),
                    Series::line("updated", pts(&s.updated)),
                ],
                shades: shades.clone(),
                ..Panel::default()
            },
            Panel {
                y_label: format!("residual [{unit}]"),
                series: vec![
                    Series::line("measured − nominal", pts(&resid(&s.nominal))),
                    Series::line("measured − updated", pts(&resid(&s.updated))),
                ],
                shades,
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    time_series(&fig, out.join("overlay.svg"))?;
    let r = resid(&s.nominal);
    let chart = XyChart {
        title: format!("Nominal residual against `{}`", s.strongest_signal),
        x_label: s.strongest_signal.clone(),
        y_label: format!("measured − nominal [{unit}]"),
        series: vec![Series::markers(
            "rows",
            s.signal.iter().copied().zip(r.iter().copied()).collect(),
        )],
        width_px: 900,
        height_px: 600,
        ..XyChart::default()
    };
    xy_chart(&chart, out.join("residual_vs_signal.svg"))?;
    let bars = GroupedBars {
        title: "Sealed part: bias per segment, nominal vs updated".into(),
        y_label: format!("mean residual [{unit}]"),
        categories: s
            .sealed_bias
            .iter()
            .map(|b| format!("{:.0} s", b.0))
            .collect(),
        groups: vec![
            (
                "nominal".into(),
                s.sealed_bias.iter().map(|b| b.1).collect(),
            ),
            (
                "updated".into(),
                s.sealed_bias.iter().map(|b| b.2).collect(),
            ),
        ],
        ..GroupedBars::default()
    };
    grouped_bars(&bars, out.join("sealed_bias.svg"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(clap::Parser)]
    struct P {
        #[command(flatten)]
        a: DiscrepancyArgs,
    }

    fn args(extra: &[&str]) -> DiscrepancyArgs {
        let mut v = vec!["acc", "--measured", "m.csv", "--out", "o"];
        v.extend_from_slice(extra);
        <P as clap::Parser>::try_parse_from(v).expect("parse").a
    }

    #[test]
    fn flags_map_to_options_and_bad_ones_name_the_flag() {
        // The default is the evaluated configuration (docs/twin.md).
        let o = options(&args(&[])).expect("defaults");
        let d = workflow::Options::default();
        assert_eq!(o.candidates, EffectKind::ALL.to_vec());
        assert_eq!(o.candidates, d.candidates);
        assert_eq!(o.min_effect_to_noise, 1.0);
        assert_eq!(o.withhold_on_structure, Some(true));
        assert_eq!(o.withhold_on_structure, d.withhold_on_structure);
        // `all` is the default; a higher floor narrows.
        let o = options(&args(&["--effects", "all", "--min-enr", "2"])).expect("all");
        assert_eq!(o.candidates, EffectKind::ALL.to_vec());
        assert_eq!(o.min_effect_to_noise, 2.0);
        let o = options(&args(&["--effects", "ks_step, depth_exponent"])).expect("two");
        assert_eq!(
            o.candidates,
            [EffectKind::KsStep, EffectKind::DepthExponent]
        );
        for bad in ["20", "0.5"] {
            let e = options(&args(&["--min-enr", bad]))
                .expect_err("a bad flag")
                .to_string();
            assert!(
                e.contains(&format!("--min-enr {bad}: allowed 1 ..= 10")),
                "{e}"
            );
        }
        // The rules that were a flag are the default: the flag is gone.
        let p = <P as clap::Parser>::try_parse_from([
            "acc",
            "--measured",
            "m",
            "--out",
            "o",
            "--strict",
        ]);
        assert!(p.is_err());
        let e = format!(
            "{:#}",
            options(&args(&["--effects", "wear"])).expect_err("a bad flag")
        );
        assert!(
            e.contains("unknown effect `wear`") && e.contains("all, or any of"),
            "{e}"
        );
        assert!(e.contains("second_order_drive"), "{e}");
    }
}
