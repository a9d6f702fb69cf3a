//! `acc sim <scenario>`: run a scenario on the simulated machine; write the run log (CSV,
//! one row per period), print the per-segment summary, and draw the paper-style figure
//! (force with Fr, override, feed, Kc_hat, Kp, Ki over time; seed 002 figs. 8–12).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use acc_plot::{time_series, Figure, HLine, Panel, Series, Shade, Style, Written};
use acc_runtime::record::{RunLogWriter, RunRecord};
use acc_sim::summary::attribute_rows;
use acc_sim::{summarize, LawKind, RunResult, Scenario};
use anyhow::Context as _;

/// Arguments of `acc sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// Scenario: a file, or a name in configs/scenarios (e.g. `paper_case3`).
    pub scenario: String,
    /// Output directory for the run log and plots (default `out/<scenario name>`).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Override the scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Model file (e.g. `acc discrepancy`'s `model.updated.toml`) whose `[machine]` and
    /// `[tool]` replace the scenario's machine and tool; the model's tool wear also replaces
    /// the scenario's `[wear]`.
    #[arg(long, value_name = "MODEL.toml")]
    pub model: Option<PathBuf>,
    /// Which law to run: ours (the scenario's preset), constant, constant-safe, fixed-pi,
    /// rate-limited, proportional.
    #[arg(long, default_value = "ours", value_parser = parse_law)]
    pub law: LawKind,
    /// Do not draw plots.
    #[arg(long)]
    pub no_plot: bool,
    /// Tool-history database (SQLite) the run's cuts, Kc trend and alarms are added to
    /// (default `acc-history.sqlite` in the output directory).
    #[arg(long, value_name = "FILE")]
    pub history: Option<PathBuf>,
    /// Pace the run to wall time: machine seconds per wall second (default: as fast as
    /// possible, or real time (`1`) with `--live`); e.g. `1` for real time while `--shdr` /
    /// `--mqtt` clients watch.
    #[arg(long, value_name = "X", conflicts_with = "step_stdin")]
    pub time_scale: Option<f64>,
    /// Pace the run from standard input (for tests and demonstrations): the run stands at
    /// t = 0 and goes on only as far as allowed; each line `N` allows N more control periods,
    /// `all` (or the end of the input) lets it run to the end. Deterministic: the same run
    /// as without pacing.
    #[arg(long)]
    pub step_stdin: bool,
    /// With `--live`: keep serving the page this long after the run ends, s (0 ..= 86400).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    pub live_keep: f64,
    /// Telemetry (`--shdr`, `--mqtt`, `--live`).
    #[command(flatten)]
    pub telemetry: crate::telemetry::TelemetryArgs,
    /// An NC program on a stock (`--program`, `--stock`, `--stock-box`, `--tools`).
    #[command(flatten)]
    pub program: crate::cmd_sim_program::ProgramArgs,
    /// Follow the plan `acc plan` wrote (`plan.csv`): the loop lowers the override ahead
    /// of every engagement change the plan names (look-ahead, docs/plan.md).
    #[arg(long, value_name = "plan.csv", requires = "program")]
    pub plan: Option<PathBuf>,
    /// With `--plan`: while the tool cuts and the measurement confirms the plan, the plan's
    /// lead sets the command from the force ahead (docs/plan.md, "The plan's lead").
    #[arg(long, requires = "plan")]
    pub plan_lead: bool,
    /// Also compute the oracle of the program (a law on the board's grid that knows the
    /// engagement ahead, on the noise-free plant: the lowest force RMS error, peak and
    /// cycle, docs/programs.md) and print the run's ratio to each.
    #[arg(long, requires = "program")]
    pub oracle: bool,
    /// The fleet store (`--fleet`, `--machine`).
    #[command(flatten)]
    pub fleet: crate::fleet_cli::FleetArgs,
}

/// Parse a law name of `--law`.
pub fn parse_law(s: &str) -> Result<LawKind, String> {
    Ok(match s {
        "ours" => LawKind::Ours,
        "constant" => LawKind::ConstantFeed,
        "constant-safe" => LawKind::ConstantSafeFeed,
        "fixed-pi" => LawKind::FixedGainPi,
        "rate-limited" => LawKind::RateLimited,
        "proportional" => LawKind::Proportional,
        _ => {
            return Err(format!(
                "unknown law `{s}`: allowed ours, constant, constant-safe, fixed-pi, rate-limited, proportional"
            ))
        }
    })
}

/// A scenario argument: an existing file, else a shipped scenario by name
/// (see [`crate::configs::find`]).
pub fn resolve_scenario(arg: &str) -> PathBuf {
    crate::configs::find("scenarios", arg)
}

/// Load the scenario named by `arg`, with an optional seed override.
pub fn load_scenario(arg: &str, seed: Option<u64>) -> anyhow::Result<Scenario> {
    let path = resolve_scenario(arg);
    let mut sc = Scenario::load(&path)?;
    if let Some(s) = seed {
        sc.seed = s;
    }
    Ok(sc)
}

/// Default output directory: `out/<scenario file stem>`.
pub fn default_out(sc: &Scenario) -> PathBuf {
    let stem = sc
        .path
        .file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned());
    Path::new("out").join(stem)
}

/// Run `acc sim`.
pub fn run_cmd(args: &SimArgs) -> anyhow::Result<()> {
    let mut sc = load_scenario(&args.scenario, args.seed)?;
    if let Some(model) = &args.model {
        sc.use_model(model)?;
    }
    let program = crate::cmd_sim_program::load(&args.program, &sc)?;
    let lookahead = crate::cmd_sim_program::lookahead(args.plan.as_deref(), args.plan_lead, &sc)?;
    if let Some(p) = &program {
        sc = p.scenario_for(&sc);
    }
    let fleet = args.fleet.open(crate::fleet_cli::now_us())?;
    let out = args.out.clone().unwrap_or_else(|| default_out(&sc));
    std::fs::create_dir_all(&out).with_context(|| format!("{}: cannot create", out.display()))?;
    let log_path = out.join("run.csv");
    let file = File::create(&log_path)
        .with_context(|| format!("{}: cannot create", log_path.display()))?;
    let mut writer = RunLogWriter::new(BufWriter::new(file))?;
    // A program's constant safe feed is its own: from the plan of its engagement.
    let mut law = match &program {
        Some(p) => p.build_law(&sc, args.law)?,
        None => sc.build_law(args.law)?,
    };
    if let (Some(p), LawKind::ConstantSafeFeed) = (&program, args.law) {
        let pct = p.safe_override_pct(&sc);
        println!("constant safe feed of the program: {pct} %");
    }
    if let Some(x) = args.time_scale {
        if !(x.is_finite() && (0.01..=1000.0).contains(&x)) {
            anyhow::bail!("--time-scale {x}: allowed 0.01 ..= 1000 (machine s per wall s)");
        }
    }
    if !(args.live_keep.is_finite() && (0.0..=86_400.0).contains(&args.live_keep)) {
        anyhow::bail!("--live-keep {}: allowed 0 ..= 86400 s", args.live_keep);
    }
    let tel = crate::telemetry::Telemetry::start(
        &crate::telemetry::with_default_pki(
            args.telemetry.over(&Default::default()),
            &out.join("pki"),
        ),
        false,
        sc.controller.period_s,
    )?;
    tel.set_live_info(acc_telemetry::LiveInfo {
        title: format!("acc sim: {}", sc.name),
        overload_n: Some(sc.policy.overload_force_n),
    });
    // The operator watches the live view at real time unless --time-scale says otherwise.
    let time_scale = args
        .time_scale
        .or((tel.has_live() && !args.step_stdin).then_some(1.0));
    let mut observe = |r: &RunRecord| tel.tap.publish(r);
    let setup = acc_sim::RunSetup {
        log: Some(&mut writer),
        prepare: Some(&mut |board| {
            if let Some(p) = &program {
                board.set_engagement_source(Some(Box::new(p.clone())));
            }
        }),
        observe: Some(&mut observe),
        pace: if args.step_stdin {
            acc_sim::run::Pace::Gated(paced_from_stdin(sc.controller.period_s))
        } else {
            time_scale.map_or(acc_sim::run::Pace::Stepped, acc_sim::run::Pace::Wall)
        },
        lookahead,
        ..acc_sim::RunSetup::default()
    };
    let result = acc_sim::run(&sc, law.as_mut(), setup)?;
    tel.finish_lingering(args.live_keep);
    println!("scenario: {} ({})", sc.name, sc.path.display());
    if let Some(model) = &args.model {
        println!("model: {} (machine, tool and wear)", model.display());
    }
    println!(
        "seed {}; {} periods of {} s",
        sc.seed,
        result.rows.len(),
        sc.controller.period_s
    );
    match &program {
        Some(p) => {
            crate::cmd_sim_program::report(args.oracle, &sc, p, &result, &out, !args.no_plot)?
        }
        None => print!("{}", summarize(&result, &sc)),
    }
    println!("run log: {}", log_path.display());
    let history = crate::watch_cli::history_path(args.history.as_deref(), &log_path);
    let items = crate::watch_cli::store_run(
        &history,
        &format!("acc sim {}", sc.path.display()),
        sc.watch,
        sc.tools.as_ref(),
        sc.controller.period_s,
        &result.rows,
    )?;
    crate::watch_cli::print_summary(&acc_runtime::history::WatchSummary::of(&items), &history);
    if let Some(f) = fleet {
        f.write_run(&result.rows, &items)?;
    }
    if !args.no_plot {
        let w = plot_run(&sc, &result, &out.join("run.svg"), program.is_none())?;
        println!("plot: {} and {}", w.svg.display(), w.png.display());
    }
    Ok(())
}

/// x-intervals (time) of air cuts, for shading.
pub fn air_shades(sc: &Scenario, rows: &[RunRecord]) -> Vec<Shade> {
    let seg = attribute_rows(rows, &sc.workpiece, sc.tool.diameter_mm);
    let mut shades = Vec::new();
    let mut start: Option<f64> = None;
    let dt = sc.controller.period_s;
    for (row, s) in rows.iter().zip(&seg) {
        let air = !sc.workpiece.segments[*s].is_cut();
        match (air, start) {
            (true, None) => start = Some(row.t_s - dt),
            (false, Some(t0)) => {
                shades.push(Shade::new("air cut", t0, row.t_s - dt));
                start = None;
            }
            _ => {}
        }
    }
    if let (Some(t0), Some(last)) = (start, rows.last()) {
        shades.push(Shade::new("air cut", t0, last.t_s));
    }
    shades
}

/// `(t, value)` points of the records that have the value (an empty cell is a gap).
pub fn pts(rows: &[RunRecord], f: impl Fn(&RunRecord) -> Option<f64>) -> Vec<(f64, f64)> {
    rows.iter()
        .filter_map(|r| f(r).map(|v| (r.t_s, v)))
        .collect()
}

/// The paper-style figure of one run (seed 002 figs. 8–12): force with Fr, override,
/// feed, Kc_hat, Kp and Ki over time, air cuts shaded.
pub fn plot_run(
    sc: &Scenario,
    result: &RunResult,
    out: &Path,
    shade_air: bool,
) -> anyhow::Result<Written> {
    let rows = &result.rows;
    // The air cuts of a 1-D workpiece (a program's path is not along x).
    let shades = if shade_air {
        air_shades(sc, rows)
    } else {
        Vec::new()
    };
    let fr = sc.controller.force_ref_n;
    let panel = |y_label: &str, series: Vec<Series>, hlines: Vec<HLine>| Panel {
        y_label: y_label.into(),
        series,
        hlines,
        shades: shades.clone(),
        y_range: None,
    };
    let fig = Figure {
        title: format!("{} — {}", sc.name, result.law),
        x_label: "time [s]".into(),
        panels: vec![
            panel(
                "force [N]",
                vec![
                    Series::line("measured Fc", pts(rows, |r| r.force_n)),
                    Series::line("true", pts(rows, |r| r.force_true_n)).with_style(Style::Dashed),
                ],
                vec![HLine::new("Fr", fr), HLine::new("1.1·Fr", 1.1 * fr)],
            ),
            panel(
                "override [%]",
                vec![
                    Series::line(
                        "commanded",
                        pts(rows, |r| r.override_cmd_pct.map(f64::from)),
                    ),
                    Series::line(
                        "applied",
                        pts(rows, |r| r.override_applied_pct.map(f64::from)),
                    )
                    .with_style(Style::Dashed),
                ],
                vec![],
            ),
            panel(
                "feed [mm/min]",
                vec![Series::line(
                    "feed",
                    pts(rows, |r| r.feed_true_mm_min.or(r.feed_mm_min)),
                )],
                vec![HLine::new("programmed", sc.programmed_feed_mm_min)],
            ),
            panel(
                "Kc_hat [N/(mm/min)]",
                vec![Series::line("Kc_hat", pts(rows, |r| r.kc_hat))],
                vec![],
            ),
            panel(
                "Kp [(mm/min)/N]",
                vec![Series::line("Kp", pts(rows, |r| r.kp))],
                vec![],
            ),
            panel(
                "Ki [(mm/min)/(N·s)]",
                vec![Series::line("Ki", pts(rows, |r| r.ki))],
                vec![],
            ),
        ],
        panel_height_px: 200,
        ..Figure::default()
    };
    Ok(time_series(&fig, out)?)
}

/// A stepped clock that stands at t = 0 and goes on as far as standard input allows: a line
/// `N` adds N periods of `period_s`, `all` or the end of the input lifts the gate; any other
/// line is reported on stderr and ignored.
fn paced_from_stdin(period_s: f64) -> acc_core::clock::GatedClock {
    use std::io::BufRead;
    let clock = acc_core::clock::GatedClock::new();
    let gate = clock.clone();
    let period = std::time::Duration::from_secs_f64(period_s);
    std::thread::spawn(move || {
        let mut periods: u32 = 0;
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            let line = line.trim();
            if line == "all" {
                break;
            }
            match line.parse::<u32>() {
                Ok(n) => {
                    periods = periods.saturating_add(n);
                    gate.allow(period * periods);
                }
                Err(_) => eprintln!(
                    "acc sim --step-stdin: `{line}`: expected a number of periods (0 ..= {}) or `all`",
                    u32::MAX
                ),
            }
        }
        gate.allow(std::time::Duration::MAX);
    });
    clock
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acc_sim_writes_log_and_plots_and_resolves_names() {
        let dir = std::env::temp_dir().join(format!("acc-sim-cmd-{}", std::process::id()));
        let args = SimArgs {
            scenario: "paper_case1".into(),
            out: Some(dir.clone()),
            seed: Some(11),
            model: None,
            law: LawKind::Ours,
            no_plot: false,
            history: None,
            time_scale: None,
            step_stdin: false,
            live_keep: 0.0,
            telemetry: Default::default(),
            program: Default::default(),
            plan: None,
            plan_lead: false,
            oracle: false,
            fleet: Default::default(),
        };
        run_cmd(&args).expect("acc sim");
        let log = std::fs::read_to_string(dir.join("run.csv")).expect("run log");
        // Header + one row per period; the 2-3-4 mm part takes about 60 s.
        let rows = log.lines().count() - 1;
        assert!((550..=650).contains(&rows), "{rows} rows");
        assert!(dir.join("run.svg").is_file() && dir.join("run.png").is_file());
        std::fs::remove_dir_all(&dir).ok();
        assert!(load_scenario("no_such_scenario", None).is_err());
        assert_eq!(parse_law("rate-limited"), Ok(LawKind::RateLimited));
        assert!(parse_law("pid").is_err());
    }
}
