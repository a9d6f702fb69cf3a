//! `acc discrepancy --program part.ngc --stock-box …`: a run log of `acc run` under a CNC
//! controller that ran an NC program (LinuxCNC: `acc linuxcnc`, docs/linuxcnc.md), compared
//! with the model replaying the same program through the same stock.
//!
//! Such a log has no depth of cut. Each row's path position is rebuilt from its block and
//! its logged feed ([`acc_sim::program_visits`]); the engagement of the row is then the
//! program's sweep through the stock there ([`acc_sim::program::ProgramPath`], as `acc sim
//! --program` builds it): the log gets the depth columns of a simulator's log and the model
//! replays on them (docs/twin.md, "Replay on the logged depths"). A rapid's rows, and a
//! block's rows once the position reaches the block's end, get programmed feed 0: in
//! exact-path mode (`G61`) the planner comes to rest at every block's end.
//!
//! [`where_they_disagree`] then places the residual on the program: per block, at the
//! entries, and at the override's speed changes.

use std::path::Path;

use acc_ident::RunLog;
use acc_runtime::record::RunRecord;
use acc_sim::engagement::{EngagementSource as _, ToolGeometry};
use acc_sim::program::ProgramPath;
use acc_sim::program_visits::{BlockVisits, PathPlace};
use anyhow::Context as _;

/// The program's path and its blocks.
pub struct ProgramLog {
    path: ProgramPath,
    tool: ToolGeometry,
    /// Every visit of each block, in path order: a block runs more than once when a
    /// subroutine (`o… call`), a loop or a repeat runs its lines again.
    visits: BlockVisits,
}

impl ProgramLog {
    /// Build the path of `opts` for the model's tool (diameter, flutes, flute length), its
    /// spindle speed and rapid rate; `None` without `--program`.
    pub fn load(
        opts: &crate::cmd_sim_program::ProgramArgs,
        model: &acc_ident::Model,
    ) -> anyhow::Result<Option<Self>> {
        let Some(program) = &opts.program else {
            opts.stock.check_without_program()?;
            return Ok(None);
        };
        let spec = opts.stock.spec(program)?;
        let tool = ToolGeometry::of(&model.tool);
        let path = ProgramPath::build(
            &spec,
            &tool,
            model.machine.spindle.rpm,
            model.machine.feed_drive.rapid_mm_min,
        )
        .with_context(|| format!("--program {}", program.display()))?;
        let visits = BlockVisits::of(&path);
        Ok(Some(ProgramLog { path, tool, visits }))
    }

    /// The records with the engagement of the program at each row's path position
    /// (depth columns and `x_true_mm`) and programmed feed 0 where the tool stands or
    /// rapids.
    pub fn with_engagement(&self, rows: &[RunRecord]) -> Vec<RunRecord> {
        let mut path = self.path.clone();
        rows.iter()
            .zip(self.visits.positions(rows))
            .map(|(r, PathPlace { at_mm: s, stands })| {
                let e = path.engagement_at(&self.tool, s);
                let mut r = r.clone();
                r.radial_depth_mm = Some(e.radial_mm);
                r.axial_depth_mm = Some(e.axial_mm);
                r.x_true_mm = Some(s);
                if stands {
                    r.programmed_feed_mm_min = Some(0.0);
                }
                r
            })
            .collect()
    }

    /// The entries of the path (positions, mm).
    pub fn entries_mm(&self) -> Vec<f64> {
        self.path
            .events()
            .iter()
            .filter(|e| e.kind == acc_sim::program::EventKind::Entry)
            .map(|e| e.at_mm)
            .collect()
    }
}

/// Read the run log `measured` (written by `acc`) with the program's engagement; with the
/// block of every row.
pub fn read_log(
    measured: &Path,
    program: &ProgramLog,
) -> anyhow::Result<(RunLog, Vec<Option<u16>>)> {
    let file = std::fs::File::open(measured)
        .with_context(|| format!("--measured {}: cannot open", measured.display()))?;
    let rows = acc_runtime::record::read_run_log(file)
        .with_context(|| format!("--measured {}", measured.display()))?;
    if rows.iter().all(|r| r.block.is_none()) {
        anyhow::bail!(
            "--measured {}: no row has a block number (`block`); --program needs a log of a controller that reports its block (acc run on LinuxCNC or a v2 board)",
            measured.display()
        );
    }
    let log = acc_ident::runlog::from_records(&program.with_engagement(&rows), measured)?;
    Ok((log, rows.iter().map(|r| r.block).collect()))
}

/// One place on the program and the residual there.
#[derive(Debug, Clone, PartialEq)]
pub struct Place {
    /// What the rows are: `block N`, `entries`, `speed changes`, `steady cut`.
    pub name: String,
    /// Rows compared there.
    pub rows: usize,
    /// RMS of measured − nominal there, in the channel's unit.
    pub nominal_rms: f64,
    /// Mean of measured − nominal there.
    pub nominal_mean: f64,
    /// RMS of measured − updated there.
    pub updated_rms: f64,
}

/// Seconds after an entry whose rows count as the entry's.
const ENTRY_S: f64 = 1.0;
/// Seconds after an override step whose rows count as the speed change's.
const SPEED_CHANGE_S: f64 = 0.5;
/// An applied override that moves by at least this much is a speed change, %.
const SPEED_STEP_PCT: f64 = 5.0;

/// The residual of the analysis placed on the program: per cutting block, over the second
/// after each entry, over the half second after each speed change (the applied override
/// moves by ≥ 5 %) and on the rest of the cut. `log` is the log as analysed (rows of
/// `series`, in order), `entries_mm` the path's entries.
pub fn where_they_disagree(
    log: &RunLog,
    series: &acc_ident::workflow::Series,
    entries_mm: &[f64],
    blocks: &[Option<u16>],
) -> Vec<Place> {
    let n = series.t_s.len().min(log.t_s.len()).min(blocks.len());
    let cut = |i: usize| log.radial_depth_mm[i] > 0.0 && log.axial_depth_mm[i] > 0.0;
    let x = log.x_mm.clone().unwrap_or_else(|| vec![0.0; n]);
    let mut entry = vec![false; n];
    for &at in entries_mm {
        if let Some(k) = (0..n).find(|&i| x[i] >= at) {
            for (i, e) in entry.iter_mut().enumerate().skip(k) {
                if log.t_s[i] > log.t_s[k] + ENTRY_S {
                    break;
                }
                *e = true;
            }
        }
    }
    let ov = log
        .override_applied_pct
        .clone()
        .unwrap_or_else(|| vec![100.0; n]);
    let mut speed = vec![false; n];
    for k in 1..n {
        if (ov[k] - ov[k - 1]).abs() >= SPEED_STEP_PCT {
            for (i, sp) in speed.iter_mut().enumerate().skip(k) {
                if log.t_s[i] > log.t_s[k] + SPEED_CHANGE_S {
                    break;
                }
                *sp = true;
            }
        }
    }
    let place = |name: String, pick: &dyn Fn(usize) -> bool| {
        let idx: Vec<usize> = (0..n).filter(|&i| cut(i) && pick(i)).collect();
        let stat = |y: &[f64]| {
            let r: Vec<f64> = idx.iter().map(|&i| series.measured[i] - y[i]).collect();
            let m = r.len().max(1) as f64;
            (
                (r.iter().map(|v| v * v).sum::<f64>() / m).sqrt(),
                r.iter().sum::<f64>() / m,
            )
        };
        let (nominal_rms, nominal_mean) = stat(&series.nominal);
        Place {
            name,
            rows: idx.len(),
            nominal_rms,
            nominal_mean,
            updated_rms: stat(&series.updated).0,
        }
    };
    let mut out: Vec<Place> = Vec::new();
    let mut seen: Vec<u16> = blocks[..n]
        .iter()
        .enumerate()
        .filter(|&(i, _)| cut(i))
        .filter_map(|(_, b)| *b)
        .collect();
    seen.dedup();
    seen.sort_unstable();
    seen.dedup();
    for b in seen {
        out.push(place(format!("block {b}"), &|i| blocks[i] == Some(b)));
    }
    out.push(place("entries (1 s after)".into(), &|i| entry[i]));
    out.push(place("speed changes (0.5 s after)".into(), &|i| speed[i]));
    out.push(place("steady cut".into(), &|i| !entry[i] && !speed[i]));
    out.into_iter().filter(|p| p.rows > 0).collect()
}

/// The places as a Markdown table, in `unit`.
pub fn places_markdown(places: &[Place], unit: &str) -> String {
    let mut s = format!(
        "| where | rows | nominal RMS, {unit} | nominal mean, {unit} | updated RMS, {unit} |\n| --- | ---: | ---: | ---: | ---: |\n"
    );
    for p in places {
        s.push_str(&format!(
            "| {} | {} | {:.1} | {:+.1} | {:.1} |\n",
            p.name, p.rows, p.nominal_rms, p.nominal_mean, p.updated_rms
        ));
    }
    s
}

/// Print the named effects' parameters with their 95 % intervals and the sealed part's RMS
/// (one line each, `param NAME = V [LO, HI]`, `sealed rms NOMINAL -> UPDATED UNIT`).
pub fn print_findings(report: &acc_ident::report::Report) {
    println!("named: {}", report.accepted.join(", "));
    for p in &report.updated_params {
        println!(
            "param {} = {} [{}, {}]",
            p.name, p.value, p.ci_low, p.ci_high
        );
    }
    println!(
        "sealed rms {} -> {} {}",
        report.sealed.nominal.rms, report.sealed.updated.rms, report.input.unit
    );
}

/// The analysed rows as CSV: time, block, path position, depths, measured, nominal and
/// updated prediction (`rows.csv` of `acc discrepancy --program`).
pub fn rows_csv(
    log: &RunLog,
    series: &acc_ident::workflow::Series,
    blocks: &[Option<u16>],
) -> String {
    let mut s = String::from("t_s,block,x_mm,radial_mm,axial_mm,measured,nominal,updated\n");
    let n = series.t_s.len().min(log.t_s.len()).min(blocks.len());
    let x = log.x_mm.clone().unwrap_or_else(|| vec![0.0; n]);
    for i in 0..n {
        s.push_str(&format!(
            "{:.3},{},{:.3},{:.3},{:.3},{:.2},{:.2},{:.2}\n",
            log.t_s[i],
            blocks[i].map_or(String::new(), |b| b.to_string()),
            x[i],
            log.radial_depth_mm[i],
            log.axial_depth_mm[i],
            series.measured[i],
            series.nominal[i],
            series.updated[i]
        ));
    }
    s
}
