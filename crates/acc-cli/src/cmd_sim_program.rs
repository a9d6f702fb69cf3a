//! `acc sim <scenario> --program part.ngc --stock stock.toml | --stock-box …`: the
//! scenario's machine, tool, controller and channel on an NC program cut from a Z-map stock
//! (`acc_sim::program`); the report per block and per tool, and the stock after the run.
//! `acc board-sim --program …` takes the same options ([`ProgramArgs`], [`load`]): the
//! machine behind the served board then follows the program.

use std::path::{Path, PathBuf};

use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
use acc_sim::program_summary::summarize_program;
use acc_sim::{RunResult, Scenario};
use anyhow::Context as _;

/// The program options of `acc sim`, `acc board-sim`, `acc compare` and
/// `acc discrepancy`: a program and its stock.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ProgramArgs {
    /// An NC program (RS274/NGC) in place of the scenario's 1-D workpiece; the scenario
    /// gives the machine, tool, controller and measurement (`acc discrepancy`: the program
    /// the measured run ran).
    #[arg(long, value_name = "FILE.ngc")]
    pub program: Option<PathBuf>,
    /// The program's stock and tool table (only with `--program`).
    #[command(flatten)]
    pub stock: StockArgs,
}

/// A program's stock and tool table: the options every command that cuts an NC program
/// shares (`acc sim --program`, `acc plan`, `acc optimize`, `acc linuxcnc`,
/// `acc linuxcnc-process`).
#[derive(Debug, Clone, clap::Args)]
pub struct StockArgs {
    /// The program's stock: a `stock.toml` (a box or a height map, docs/stock.md).
    #[arg(
        id = "stock",
        long = "stock",
        value_name = "stock.toml",
        conflicts_with = "stock_box"
    )]
    pub file: Option<PathBuf>,
    /// The program's stock as a box `X0,Y0,Z0,X1,Y1,Z1`, mm (program coordinates).
    #[arg(
        id = "stock_box",
        long = "stock-box",
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        allow_hyphen_values = true
    )]
    pub box_spec: Option<String>,
    /// Cell size of `--stock-box`, mm (0.01 ..= 10).
    #[arg(long, value_name = "MM", default_value_t = 0.25)]
    pub cell: f64,
    /// LinuxCNC tool table (`.tbl`, mm) with the diameters of the program's T numbers
    /// (without it, or for T0, the scenario's tool).
    #[arg(long, value_name = "FILE.tbl")]
    pub tools: Option<PathBuf>,
}

impl Default for StockArgs {
    fn default() -> Self {
        Self {
            file: None,
            box_spec: None,
            cell: 0.25,
            tools: None,
        }
    }
}

impl StockArgs {
    /// The stock, checked: exactly one of `--stock` and `--stock-box` ([`stock_source`]).
    pub fn source(&self) -> anyhow::Result<StockSource> {
        stock_source(self.file.as_deref(), self.box_spec.as_deref(), self.cell)
    }

    /// `program` on this stock with this tool table.
    pub fn spec(&self, program: &Path) -> anyhow::Result<ProgramSpec> {
        Ok(ProgramSpec {
            program: program.to_path_buf(),
            stock: self.source()?,
            tools: self.tools.clone(),
        })
    }

    /// Refuses a stock or tool table given without the program it belongs to.
    pub fn check_without_program(&self) -> anyhow::Result<()> {
        let given = [
            ("--stock", self.file.is_some()),
            ("--stock-box", self.box_spec.is_some()),
            ("--tools", self.tools.is_some()),
        ];
        match given.iter().find(|(_, g)| *g) {
            Some((flag, _)) => anyhow::bail!("{flag} belongs to a program: give --program too"),
            None => Ok(()),
        }
    }
}

/// The look-ahead of `acc sim --plan` (`plan`) for scenario `sc`, if given, with the plan's
/// lead when `lead` (`--plan-lead`), else its cap only: the plan file read and checked (an error names the
/// file, the line and the column).
pub fn lookahead(
    plan: Option<&Path>,
    lead: bool,
    sc: &Scenario,
) -> anyhow::Result<Option<acc_runtime::LookAhead>> {
    let Some(p) = plan else {
        return Ok(None);
    };
    let plan = acc_runtime::Plan::load(p)?;
    let cfg = acc_runtime::LookAheadConfig {
        lead,
        ..acc_runtime::LookAheadConfig::new(
            sc.controller.period_s,
            sc.controller.force_ref_n,
            sc.policy.max_override_pct,
        )
    };
    Ok(Some(acc_runtime::LookAhead::new(plan, cfg)))
}

/// The stock of `--stock stock.toml` or `--stock-box X0,Y0,Z0,X1,Y1,Z1` on cells of `--cell`
/// mm (0.01 ..= 10), checked (the box parsed, the file named); exactly one of the two.
pub fn stock_source(
    stock: Option<&Path>,
    stock_box: Option<&str>,
    cell_mm: f64,
) -> anyhow::Result<StockSource> {
    match (stock, stock_box) {
        (Some(p), None) => Ok(StockSource::File(p.to_path_buf())),
        (None, Some(b)) => {
            if !(cell_mm.is_finite() && (0.01..=10.0).contains(&cell_mm)) {
                anyhow::bail!("--cell {cell_mm}: allowed 0.01 ..= 10 mm");
            }
            let spec = b
                .parse::<acc_stock::BoxSpec>()
                .map_err(|e| anyhow::anyhow!("--stock-box {b}: {e}"))?;
            Ok(StockSource::Box(spec, cell_mm))
        }
        _ => anyhow::bail!("give --stock stock.toml or --stock-box X0,Y0,Z0,X1,Y1,Z1"),
    }
}

/// The program's path through its stock, with the warnings printed; `None` without
/// `--program`.
pub fn load(args: &ProgramArgs, sc: &Scenario) -> anyhow::Result<Option<ProgramPath>> {
    let Some(program) = &args.program else {
        args.stock.check_without_program()?;
        return Ok(None);
    };
    if args.stock.file.is_none() && args.stock.box_spec.is_none() {
        anyhow::bail!(
            "--program needs its stock: --stock stock.toml or --stock-box X0,Y0,Z0,X1,Y1,Z1"
        );
    }
    let spec = args.stock.spec(program)?;
    let tool = acc_plant::engagement::ToolGeometry::of(&sc.tool);
    let path = ProgramPath::build_within(
        &spec,
        &tool,
        sc.machine.spindle.rpm,
        sc.machine.feed_drive.rapid_mm_min,
        sc.machine.travel.as_ref(),
    )?;
    if path.cuts_air_only() {
        eprintln!(
            "warning: {}: the program does not reach the stock; it cuts air",
            program.display()
        );
    }
    if path.rapid_collisions() > 0 {
        eprintln!(
            "warning: {}: rapid moves run through the stock ({} steps)",
            program.display(),
            path.rapid_collisions()
        );
    }
    if path.beyond_flutes() > 0 {
        eprintln!(
            "warning: {}: material above the flutes at {} steps",
            program.display(),
            path.beyond_flutes()
        );
    }
    Ok(Some(path))
}

/// The force ceiling of the second and third oracle figures of `--oracle`, × Fr: the peak
/// target at entries and corners of a law that knows the cut ahead (docs/programs.md).
const ORACLE_CEILING: f64 = 1.05;

/// Print the per-tool and per-block summary (with `--oracle` the oracle's figures and the
/// run's ratio to them), write `blocks.csv` and draw the stock after the run (`stock.svg`,
/// `stock.png`) into `out`.
pub fn report(
    oracle: bool,
    sc: &Scenario,
    path: &ProgramPath,
    result: &RunResult,
    out: &Path,
    plot: bool,
) -> anyhow::Result<()> {
    let s = summarize_program(
        &result.rows,
        sc.controller.force_ref_n,
        sc.controller.period_s,
    );
    println!(
        "program: {} pieces, {:.0} mm of path, {:.1} s at the programmed feeds; removes {:.1} cm³",
        path.segments().len(),
        acc_plant::engagement::EngagementSource::path_length_mm(path).unwrap_or(0.0),
        path.nominal_time_s(),
        path.removed_mm3() / 1000.0
    );
    if !result.finished {
        println!(
            "the run ended before the end of the program{}",
            if result.ended_in_feed_hold {
                " (feed hold)"
            } else {
                ""
            }
        );
    }
    print!("{s}");
    // The peaks at the entries and corners: what feedback alone leaves there.
    let fr = sc.controller.force_ref_n;
    let peaks = acc_sim::program::event_peaks(&result.rows, &path.events(), 1.0);
    for kind in [
        acc_sim::program::EventKind::Entry,
        acc_sim::program::EventKind::Corner,
    ] {
        let of: Vec<(u32, f64)> = peaks
            .iter()
            .filter(|(e, _)| e.kind == kind)
            .filter_map(|(e, p)| Some((e.block, (*p)?)))
            .collect();
        let name = match kind {
            acc_sim::program::EventKind::Entry => "entries",
            acc_sim::program::EventKind::Corner => "corners",
        };
        match of.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            Some((block, p)) => println!(
                "{name}: {}; highest true peak {:.2} Fr (block {block}); mean peak {:.2} Fr",
                of.len(),
                p / fr,
                of.iter().map(|x| x.1).sum::<f64>() / of.len() as f64 / fr
            ),
            None => println!("{name}: none reached"),
        }
    }
    if oracle {
        let plant = acc_sim::oracle_program::ProgramPlant::new(sc, path);
        let o = acc_sim::oracle_program::program_oracle(&plant)?;
        let within = acc_sim::oracle_program::program_rms_within(&plant, ORACLE_CEILING, false)?;
        let per_override =
            acc_sim::oracle_program::program_rms_within(&plant, ORACLE_CEILING, true)?;
        print!(
            "{}",
            acc_sim::oracle_program::report(
                &o,
                plant.safe_pct(),
                &s,
                result.finished,
                Some((ORACLE_CEILING, &within, &per_override))
            )
        );
    }
    let csv = out.join("blocks.csv");
    std::fs::write(&csv, s.blocks_csv())
        .with_context(|| format!("{}: cannot write", csv.display()))?;
    println!("blocks: {}", csv.display());
    if plot {
        let z = path.stock_after();
        let (nx, ny) = z.size();
        let c = z.corner_mm();
        let w = acc_plot::height_field(
            &acc_plot::HeightField {
                title: format!("stock after {}", sc.name),
                nx,
                ny,
                heights: z.heights(),
                corner_mm: (c[0], c[1]),
                cell_mm: z.cell_mm(),
            },
            &out.join("stock.svg"),
        )?;
        println!("stock: {} and {}", w.svg.display(), w.png.display());
    }
    Ok(())
}
