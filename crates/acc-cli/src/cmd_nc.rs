//! `acc nc PROGRAM [--tools FILE.tbl]`: interpret an NC program (crate `acc-nc`) and print
//! one row per motion (line, N, kind, end point, feed, length, tool) and a summary (blocks,
//! feed length, rapid length, time at programmed feed). Errors name file:line:column, the
//! word and what is allowed; nothing else is written.

use std::fmt::Write as _;
use std::path::PathBuf;

use acc_nc::{interpret_file, parse_work_offsets_var, Canon, Program, Setup, ToolTable, Units};
use anyhow::Context as _;

/// Units of the numbers in the LinuxCNC files (tool table, parameter file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TableUnits {
    /// Millimetres.
    Mm,
    /// Inches (LinuxCNC machines set up in inches; the stand-alone rs274).
    In,
}

/// Arguments of `acc nc`.
#[derive(Debug, clap::Args)]
pub struct NcArgs {
    /// The NC program (RS274/NGC, common Fanuc milling words; docs/nc.md).
    pub program: PathBuf,
    /// Tool table in LinuxCNC .tbl format (`T1 P1 Z50 D10 ;comment`): tool numbers for T and
    /// M6, lengths for G43. Without it only T0 is known.
    #[arg(long, value_name = "FILE.tbl")]
    pub tools: Option<PathBuf>,
    /// Work offsets of G54–G59 from a LinuxCNC parameter file (`.var`: #5221–#5323).
    /// Default: all zero.
    #[arg(long, value_name = "FILE.var")]
    pub offsets: Option<PathBuf>,
    /// Units of the numbers in `--tools` and `--offsets` (the machine's units in LinuxCNC).
    #[arg(long, value_enum, default_value = "mm")]
    pub table_units: TableUnits,
    /// Print the summary only, not the per-block table.
    #[arg(long)]
    pub summary_only: bool,
}

/// Run `acc nc`.
pub fn run(args: &NcArgs) -> anyhow::Result<()> {
    let mut setup = Setup::default();
    let units = match args.table_units {
        TableUnits::Mm => Units::Mm,
        TableUnits::In => Units::Inch,
    };
    if let Some(path) = &args.tools {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("--tools {}: cannot read", path.display()))?;
        setup.tools = ToolTable::parse_tbl(&path.display().to_string(), &text, units)?;
    }
    if let Some(path) = &args.offsets {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("--offsets {}: cannot read", path.display()))?;
        setup.work_offsets_mm = parse_work_offsets_var(&path.display().to_string(), &text, units)?;
    }
    let program = interpret_file(&args.program, &setup)?;
    print!("{}", report(&program, !args.summary_only));
    Ok(())
}

/// The per-block table (when `table`) and the summary, as printed.
pub fn report(p: &Program, table: bool) -> String {
    let mut out = String::new();
    if table {
        let _ = writeln!(
            out,
            "{:>6} {:>6} {:<9} {:>10} {:>10} {:>10} {:>9} {:>9} {:>4}",
            "line", "N", "motion", "X mm", "Y mm", "Z mm", "F mm/min", "len mm", "tool"
        );
        let mut tool = 0;
        for c in &p.calls {
            if let Canon::ToolChange { tool: t } = c.call {
                tool = t;
            }
            let Some(to) = c.call.end() else { continue };
            let feed = match c.call {
                Canon::Feed { feed_mm_min, .. } | Canon::Arc { feed_mm_min, .. } => {
                    format!("{feed_mm_min:.1}")
                }
                _ => "rapid".to_string(),
            };
            let n = c.block.map_or("-".to_string(), |n| n.to_string());
            let _ = writeln!(
                out,
                "{:>6} {:>6} {:<9} {:>10.4} {:>10.4} {:>10.4} {:>9} {:>9.3} {:>4}",
                c.line,
                n,
                c.call.kind(),
                to[0],
                to[1],
                to[2],
                feed,
                c.call.length_mm(),
                tool
            );
        }
    }
    let s = p.summary();
    let _ = writeln!(out, "program        {}", p.file);
    let _ = writeln!(out, "motion blocks  {}", s.motion_blocks);
    let _ = writeln!(out, "motions        {}", s.motions);
    let _ = writeln!(out, "tool changes   {}", s.tool_changes);
    let _ = writeln!(out, "feed length    {:.3} mm", s.feed_length_mm);
    let _ = writeln!(out, "rapid length   {:.3} mm", s.rapid_length_mm);
    let _ = writeln!(
        out,
        "time at feed   {:.1} s (programmed feed, 100 % override; rapids and acceleration not included) + dwell {:.1} s",
        s.feed_time_s, s.dwell_s
    );
    out
}
