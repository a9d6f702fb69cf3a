//! `acc optimize part.ngc --stock stock.toml | --stock-box … [--tools T.tbl] [--scenario S]
//! [--min-segment MM] --out part.opt.ngc`: the program with its F words rewritten per block
//! from the plan (`acc_sim::optimize`), and its predicted cycle time and peak force before
//! and after (stdout and `part.opt.summary.md`).

use std::path::PathBuf;

use acc_sim::optimize::{OptimizeParams, DEFAULT_MIN_SEGMENT_MM};
use acc_sim::plan::PlanFigures;
use acc_sim::program::ProgramPath;
use anyhow::Context as _;

use crate::cmd_plan::PlanInput;

/// Arguments of `acc optimize`.
#[derive(Debug, Clone, clap::Args)]
pub struct OptimizeArgs {
    /// Program, stock and machine (as `acc plan`).
    #[command(flatten)]
    pub input: PlanInput,
    /// Shortest piece a block is split into where its engagement changes, mm (0.01 ..= 1000).
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_MIN_SEGMENT_MM)]
    pub min_segment: f64,
    /// The optimized program to write.
    #[arg(long, value_name = "FILE.ngc")]
    pub out: PathBuf,
}

/// Predicted machine time of a path: feed moves at their feed (at most the rapid rate) and
/// rapids at the rapid rate, s.
fn times(path: &ProgramPath, rapid_mm_min: f64) -> (f64, f64) {
    path.segments().iter().fold((0.0, 0.0), |(f, r), s| {
        if s.rapid {
            (f, r + 60.0 * s.length_mm() / rapid_mm_min)
        } else {
            let v = s.feed_mm_min.min(rapid_mm_min).max(1e-9);
            (f + 60.0 * s.length_mm() / v, r)
        }
    })
}

/// Run `acc optimize`.
pub fn run_cmd(args: &OptimizeArgs) -> anyhow::Result<()> {
    let input = &args.input;
    let setup = input.setup()?;
    let (sc, path, plan) = (&setup.scenario, &setup.path, setup.params);
    let text = std::fs::read_to_string(&input.program)
        .with_context(|| format!("{}: cannot read", input.program.display()))?;
    let rapid = sc.machine.feed_drive.rapid_mm_min;
    let params = OptimizeParams {
        plan,
        min_segment_mm: args.min_segment,
        max_feed_mm_min: rapid,
    };
    let table = sc.tools.clone();
    let air = move |tool: u32| {
        table
            .as_ref()
            .map_or(acc_config::DEFAULT_AIR_FEED_MM_MIN, |t| {
                t.get(u16::try_from(tool).unwrap_or(0)).air_feed_mm_min
            })
    };
    let name = input.program.display().to_string();
    let opt = acc_sim::optimize::optimize(&name, &text, path, &params, &air)?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    std::fs::write(&args.out, &opt.text)
        .with_context(|| format!("{}: cannot write", args.out.display()))?;
    // The optimized program through the same stock: its time and its plan's peak.
    let after = input.load(sc, &args.out)?;
    let fr = plan.force_ref_n;
    let max = plan.grid.max_pct;
    let f0 = PlanFigures::of(&path.plan(&plan), max);
    let f1 = PlanFigures::of(&after.plan(&plan), max);
    let (feed0, rapid0) = times(path, rapid);
    let (feed1, rapid1) = times(&after, rapid);
    let mut md = String::new();
    md += &format!(
        "optimized {} on {} (Fr {fr} N, rapid {rapid} mm/min, shortest piece {} mm)\n{}\n\n",
        input.program.display(),
        sc.name,
        args.min_segment,
        setup.predicted_by()
    );
    md += "| program | cycle, s | feed moves, s | rapids, s | predicted peak at 100 %, Fr |\n";
    md += "| --- | --- | --- | --- | --- |\n";
    for (label, f, r, peak) in [
        ("original", feed0, rapid0, f0.peak_100_n),
        ("optimized", feed1, rapid1, f1.peak_100_n),
    ] {
        md += &format!(
            "| {label} | {:.1} | {f:.1} | {r:.1} | {:.3} |\n",
            f + r,
            peak / fr
        );
    }
    md += &format!(
        "\nratio optimized / original: {:.3}\n\
         lines rewritten: {}, split: {} (+{} lines), kept whole at their lowest feed: {}\n\
         written: {}\n",
        (feed1 + rapid1) / (feed0 + rapid0).max(1e-9),
        opt.lines_rewritten,
        opt.lines_split,
        opt.lines_added,
        opt.kept_whole,
        args.out.display()
    );
    if let Some((a, b)) = opt.added_numbers {
        md +=
            &format!("added lines numbered N{a}..N{b} (above every block number of the program)\n");
    }
    print!("{md}");
    let summary = args.out.with_extension("summary.md");
    std::fs::write(&summary, &md)
        .with_context(|| format!("{}: cannot write", summary.display()))?;
    println!("summary: {}", summary.display());
    Ok(())
}
