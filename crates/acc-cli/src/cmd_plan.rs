//! `acc plan part.ngc --stock stock.toml | --stock-box … [--tools T.tbl] [--scenario S]
//! [--model M.toml] [--measured run.csv] --out DIR`: the cutting plan of an NC program
//! (`acc_sim::plan`): `plan.csv`, the predicted force along the program (`plan.svg`,
//! `plan.png`) and a summary on stdout; with `--measured`, the plan's force error against
//! a run log (`acc_runtime::plan_error`).

use std::path::{Path, PathBuf};

use acc_ident::cutting::CuttingModel;
use acc_plot::{Figure, HLine, Panel, Series, Style};
use acc_runtime::plan::Plan;
use acc_runtime::record::RunRecord;
use acc_sim::plan::{PlanFigures, PlanParams};
use acc_sim::program::ProgramPath;
use acc_sim::Scenario;
use anyhow::Context as _;

/// The program, its stock and the machine of `acc plan` and `acc optimize`.
#[derive(Debug, Clone, clap::Args)]
pub struct PlanInput {
    /// The NC program (RS274/NGC).
    #[arg(value_name = "FILE.ngc")]
    pub program: PathBuf,
    /// The scenario whose machine, tool, force law, Fr and override grid the plan uses
    /// (a name under configs/scenarios or a path).
    #[arg(long, default_value = "paper_case3")]
    pub scenario: String,
    /// The program's stock and tool table.
    #[command(flatten)]
    pub stock: crate::cmd_sim_program::StockArgs,
    /// Model file (e.g. `acc discrepancy`'s `model.updated.toml`) whose machine, tool and
    /// cutting-force effects predict the force instead of the scenario's; its tool's wear
    /// law (a learned `tool_wear`) raises the force along the path with the volume removed.
    /// Fr, the override grid and the limits stay the scenario's.
    #[arg(long, value_name = "MODEL.toml")]
    pub model: Option<PathBuf>,
}

/// What `acc plan` and `acc optimize` plan with.
#[derive(Debug, Clone)]
pub struct PlanSetup {
    /// The scenario (its machine and tool those of `--model` if given).
    pub scenario: Scenario,
    /// The program's path through the stock.
    pub path: ProgramPath,
    /// The planner's constants.
    pub params: PlanParams,
    /// `--model` and its cutting-force law.
    pub model: Option<(PathBuf, CuttingModel)>,
}

impl PlanSetup {
    /// Which model predicted the force, for the summary and the plan file.
    pub fn predicted_by(&self) -> String {
        let Some((path, m)) = &self.model else {
            return format!("force predicted by scenario {}", self.scenario.name);
        };
        let w = &m.tool.wear;
        let names = |v: &[acc_ident::EffectKind]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")
            }
        };
        format!(
            "force predicted by model {} (its machine and tool; Fr and grid of scenario {})\n\
             tool wear: Ks factor {} · (1 + {:.5}·V^{:.3} + {:.5}·t) along the path (V removed cm³, t cutting min)\n\
             effects carried into the tool: {}; not used (no change to the mean cutting force): {}",
            path.display(),
            self.scenario.name,
            w.initial_factor,
            w.growth_per_cm3,
            w.volume_exponent,
            w.growth_per_min,
            names(&m.used),
            names(&m.not_used)
        )
    }
}

impl PlanInput {
    /// The scenario (with `--model`'s machine and tool), the planner's constants and the
    /// path of the program.
    pub fn setup(&self) -> anyhow::Result<PlanSetup> {
        let mut sc = crate::cmd_sim::load_scenario(&self.scenario, None)?;
        let model = match &self.model {
            None => None,
            Some(file) => {
                let m = acc_ident::Model::load(file)?.cutting(file)?;
                sc.use_machine_and_tool(file, m.machine.clone(), m.tool.clone())?;
                Some((file.clone(), m))
            }
        };
        let params = match &model {
            None => PlanParams::of(&sc),
            Some(_) => PlanParams::of(&sc).wearing(sc.wear),
        };
        let path = self.load(&sc, &self.program)?;
        Ok(PlanSetup {
            scenario: sc,
            path,
            params,
            model,
        })
    }

    /// `program`'s path through the stock on `sc`'s machine and tool (warnings printed).
    pub fn load(&self, sc: &Scenario, program: &Path) -> anyhow::Result<ProgramPath> {
        let program_args = crate::cmd_sim_program::ProgramArgs {
            program: Some(program.to_path_buf()),
            stock: self.stock.clone(),
        };
        crate::cmd_sim_program::load(&program_args, sc)?
            .ok_or_else(|| anyhow::anyhow!("no program"))
    }
}

/// Arguments of `acc plan`.
#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    /// Program, stock and machine.
    #[command(flatten)]
    pub input: PlanInput,
    /// Output directory (default `out/plan-<program>`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Do not draw the plot.
    #[arg(long)]
    pub no_plot: bool,
    /// A run log of the program (`acc sim --program … run.csv`, or `acc run`'s): print the
    /// plan's force error against its measured force (RMS over the cutting periods of the
    /// distance to the plan's force band at the logged feed, docs/plan.md).
    #[arg(long, value_name = "run.csv")]
    pub measured: Option<PathBuf>,
}

/// Run `acc plan`.
pub fn run_cmd(args: &PlanArgs) -> anyhow::Result<()> {
    // The log first: a bad log is refused before anything is planned.
    let measured = match &args.measured {
        None => None,
        Some(f) => Some(crate::cmd_what_if::read_log_of("--measured", f)?),
    };
    let setup = args.input.setup()?;
    let (sc, path, params) = (&setup.scenario, &setup.path, setup.params);
    let plan = path.plan(&params);
    let out = args.out.clone().unwrap_or_else(|| {
        let stem = args
            .input
            .program
            .file_stem()
            .map_or_else(|| "program".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from("out").join(format!("plan-{stem}"))
    });
    std::fs::create_dir_all(&out).with_context(|| format!("{}: cannot create", out.display()))?;
    let csv = out.join("plan.csv");
    let notes = match setup.model {
        Some(_) => vec![setup.predicted_by()],
        None => Vec::new(),
    };
    std::fs::write(&csv, plan.to_csv_noted(&notes)?)
        .with_context(|| format!("{}: cannot write", csv.display()))?;
    let fr = params.force_ref_n;
    let f = PlanFigures::of(&plan, params.grid.max_pct);
    println!(
        "plan of {} on {} ({} N Fr, grid {} %, {} ..= {} %)",
        args.input.program.display(),
        sc.name,
        fr,
        params.grid.step_pct,
        params.grid.min_pct,
        params.grid.max_pct
    );
    println!("{}", setup.predicted_by());
    println!(
        "{} rows ({} cutting) over {:.1} mm of path; {} engagement changes",
        f.rows,
        f.cutting_rows,
        plan.length_mm(),
        plan.rows.len().saturating_sub(1)
    );
    println!(
        "predicted peak of the feed moves at 100 %: {:.0} N = {:.2} Fr; at the planned overrides: {:.0} N = {:.2} Fr",
        f.peak_100_n,
        f.peak_100_n / fr,
        f.peak_planned_n,
        f.peak_planned_n / fr
    );
    if f.rapid_cut_rows > 0 {
        println!(
            "warning: {} rows of rapid moves run through the stock (not overridden)",
            f.rapid_cut_rows
        );
    }
    let shared = acc_nc::shared_block_numbers(path.calls());
    if let Some((n, lines)) = shared.first() {
        println!(
            "warning: {} block numbers name motions of more than one line (first: block number {n} at lines {}): \
             the look-ahead tells their visits apart by the path position only; give every \
             line its own N word (docs/plan.md)",
            shared.len(),
            lines
                .iter()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    println!(
        "constant safe feed of the program: {} % (every cutting row's force ≤ Fr)",
        f.safe_override_pct
    );
    println!(
        "machine time (no acceleration): {:.1} s at 100 %, {:.1} s at the planned overrides, \
         {:.1} s at the constant safe feed",
        f.nominal_time_s, f.planned_time_s, f.safe_time_s
    );
    let events = path.events();
    println!(
        "entries: {}, corners: {} (path positions, mm: {})",
        events
            .iter()
            .filter(|e| e.kind == acc_sim::program::EventKind::Entry)
            .count(),
        events
            .iter()
            .filter(|e| e.kind == acc_sim::program::EventKind::Corner)
            .count(),
        events
            .iter()
            .take(12)
            .map(|e| format!("{:.1}", e.at_mm))
            .collect::<Vec<_>>()
            .join(", ")
            + if events.len() > 12 { ", …" } else { "" }
    );
    if let (Some(rows), Some(file)) = (&measured, &args.measured) {
        let (rows, placed) = on_the_path(path, rows);
        if placed {
            println!(
                "{}: a controller's log (blocks, no simulator's position): rows placed on the program's path by their block visits",
                file.display()
            );
        }
        let e = acc_runtime::plan_error::plan_force_error(&plan, &rows);
        if e.periods == 0 {
            anyhow::bail!(
                "{}: no cutting period of the log lies on the plan's cutting rows (is it a run of this program?)",
                file.display()
            );
        }
        println!(
            "plan's force error against {}: RMS {:.1} N = {:.3} Fr, mean {:+.1} N over {} cutting periods ({} above the plan's band, {} below)",
            file.display(),
            e.rms_n,
            e.rms_n / fr,
            e.mean_n,
            e.periods,
            e.above,
            e.below
        );
    }
    println!("plan: {}", csv.display());
    if !args.no_plot {
        let w = plot(&plan, fr, &sc.name, &out.join("plan.svg"))?;
        println!("plot: {} and {}", w.svg.display(), w.png.display());
    }
    Ok(())
}

/// The run log's rows with their place on the program's path, and whether they were placed:
/// a simulator's log (`acc sim --program`) has its true path position (`x_true_mm`); a
/// controller's (`acc linuxcnc`, `acc run` on a v2 board) has blocks and a position that
/// integrates the feed through homing and tool changes, so its rows are placed by their
/// block visits ([`acc_sim::program_visits`]).
fn on_the_path(path: &ProgramPath, rows: &[RunRecord]) -> (Vec<RunRecord>, bool) {
    if rows.iter().any(|r| r.x_true_mm.is_some()) || rows.iter().all(|r| r.block.is_none()) {
        return (rows.to_vec(), false);
    }
    let places = acc_sim::program_visits::BlockVisits::of(path).positions(rows);
    let placed = rows
        .iter()
        .zip(places)
        .map(|(r, p)| RunRecord {
            x_true_mm: Some(p.at_mm),
            ..r.clone()
        })
        .collect();
    (placed, true)
}

/// The predicted force (at 100 % and at the planned overrides) and the planned override
/// along the program's path.
fn plot(
    plan: &Plan,
    fr: f64,
    name: &str,
    out: &std::path::Path,
) -> anyhow::Result<acc_plot::Written> {
    let steps = |f: &dyn Fn(&acc_runtime::plan::PlanRow) -> f64| {
        plan.rows
            .iter()
            .flat_map(|r| [(r.start_mm, f(r)), (r.end_mm, f(r))])
            .collect::<Vec<_>>()
    };
    let fig = Figure {
        title: format!("plan on {name}"),
        x_label: "path position [mm]".into(),
        panels: vec![
            Panel {
                y_label: "predicted force [N]".into(),
                series: vec![
                    Series::line("at 100 %", steps(&|r| r.force_100_n)).with_style(Style::Dashed),
                    Series::line("at the planned override", steps(&|r| r.force_planned_n)),
                ],
                hlines: vec![HLine::new("Fr", fr)],
                ..Panel::default()
            },
            Panel {
                y_label: "planned override [%]".into(),
                series: vec![Series::line(
                    "override",
                    steps(&|r| f64::from(r.override_pct)),
                )],
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    Ok(acc_plot::time_series(&fig, out)?)
}
