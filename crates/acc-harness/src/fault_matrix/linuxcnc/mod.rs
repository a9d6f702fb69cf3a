//! The LinuxCNC section of `acc fault-matrix` (`--linuxcnc`): each row is one `acc linuxcnc
//! PROGRAM --fault KIND@N` run (headless LinuxCNC 2.9, `acc run --hal`, the simulated process
//! `acc linuxcnc-process`, the realtime watchdog of `configs/linuxcnc/acc.hal`); `ui.py`
//! carries the fault out the first time the true force reaches N and marks the moment in the
//! machine log (`fault` column). One LinuxCNC runs per host: the rows run one after another.
//!
//! A row is judged from the machine log (true force, feed, the adaptive feed acc wrote, the
//! operator's feed override, acc's heartbeat) and acc's run log:
//!
//! - **allowed**: what acc last allowed, `100 × feed override × adaptive feed` in the
//!   machine log's last row before the fault (percent of the programmed feed);
//! - **max applied, ACC not driving**: the largest applied override after the fault while
//!   the tool is in the stock (true force above 2 % of Fr; where the machine log has ended,
//!   the cut's programmed feed) and the feed moves, in the periods acc does not drive (its
//!   run log's state is not `active`) and while acc is silent (no heartbeat for 0.15 s: dead
//!   or frozen, the machine log's adaptive feed); rapids are not counted (acc never slows
//!   them, by design);
//! - **max cmd after** (the rows where acc must not raise: frozen acc, frozen power): the
//!   largest override acc commanded from 0.25 s after the fault (its last real sample is in
//!   by then) against its last command up to then;
//! - **force before / after**: the largest true force in the 1 s before the fault and in the
//!   5 s after it (none when the process is the fault: it is dead);
//! - **log complete**: the run log's periods consecutive.
//!
//! Pass: max applied ≤ allowed (+ 1 %, the pins' rounding), force after ≤ 1.05 × before, log
//! complete, no raise where acc must not raise, and for a dead or frozen acc the motion
//! stopped within 0.3 s of the fault. The run log's and the machine log's clocks start with
//! their processes: the run log is placed on the machine log's time by acc's first heartbeat
//! toggle (its first status read), to within one period.

//!
//! The files, in the order a row runs through them:
//!
//! | file | what it decides |
//! | --- | --- |
//! | `rows.rs` | the rows: each fault, the force and delay it comes at, what acc must not do |
//! | `mod.rs` | runs each row's `acc linuxcnc --fault`, reads its logs, writes the table |
//! | `judge.rs` | a row's figures from its logs, and the verdict of a fault from outside |
//! | `program_event.rs` | the verdict of a program's own event (`M52 P0`, restart, `M6`) |
//! | `row.rs` | what a row measured, and the windows its figures are taken over |
//! | `outcome.rs` | the row's outcome in words, and how its program ended |
//! | `table.rs` | the section's markdown table |

mod judge;
mod outcome;
mod program_event;
mod row;
mod rows;
mod table;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::time::Duration;

use acc_linuxcnc::machine_log::{self, MachineLogError};
use anyhow::{bail, Context};

use super::FaultMatrixArgs;
use crate::child::{describe, read, Proc};

pub use judge::judge;
pub use program_event::{judge_program_event, EventFigures};
pub use row::LcncRow;
pub use rows::{LcncFault, LCNC_FAULTS};
pub use table::markdown;

/// The LinuxCNC section: every row (or `--only`'s), one after another; the table in
/// `--out` (`fault-matrix-linuxcnc.md`, `.json`) and printed; an error naming failed rows.
pub fn run(args: &FaultMatrixArgs) -> anyhow::Result<()> {
    for o in &args.only {
        if !LCNC_FAULTS.iter().any(|f| f.name == o) {
            let names: Vec<_> = LCNC_FAULTS.iter().map(|f| f.name).collect();
            bail!(
                "--only {o}: not a LinuxCNC row; allowed: {}",
                names.join(", ")
            );
        }
    }
    if !args.linuxcnc_program.is_file() {
        bail!(
            "--linuxcnc-program {}: no such file",
            args.linuxcnc_program.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let faults: Vec<&LcncFault> = LCNC_FAULTS
        .iter()
        .filter(|f| args.only.is_empty() || args.only.iter().any(|o| o == f.name))
        .collect();
    let mut rows = Vec::new();
    for (k, f) in faults.iter().enumerate() {
        let dir = args.out.join(format!("linuxcnc-{}", f.name));
        let row = run_row(args, f, &dir).with_context(|| format!("LinuxCNC row {}", f.name))?;
        eprintln!(
            "[{}/{}] linuxcnc {:<14} {}",
            k + 1,
            faults.len(),
            f.name,
            row.verdict
        );
        rows.push(row);
    }
    let table = markdown(&rows, args);
    super::report::write_section(&args.out, "fault-matrix-linuxcnc", &table, &rows)?;
    let failed: Vec<_> = rows
        .iter()
        .filter(|r| !r.ok)
        .map(|r| r.fault.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} of {} LinuxCNC rows failed: {}",
            failed.len(),
            rows.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// The NC program of row `f`: its own beside `--linuxcnc-program`, or that one.
fn row_program(args: &FaultMatrixArgs, f: &LcncFault) -> PathBuf {
    match f.program {
        Some(name) => args.linuxcnc_program.with_file_name(name),
        None => args.linuxcnc_program.clone(),
    }
}

/// One row: `acc linuxcnc … --fault KIND@N --out dir`, then its logs judged.
fn run_row(args: &FaultMatrixArgs, f: &LcncFault, dir: &Path) -> anyhow::Result<LcncRow> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let out: PathBuf = dir.join("lcnc");
    let program = row_program(args, f);
    if !program.is_file() {
        bail!(
            "{}: no such file (row {}'s program, beside --linuxcnc-program)",
            program.display(),
            f.name
        );
    }
    let largs = vec![
        "linuxcnc".to_string(),
        program.to_string_lossy().into_owned(),
        format!("--stock-box={}", args.linuxcnc_stock_box),
        "--out".into(),
        out.to_string_lossy().into_owned(),
        "--fault".into(),
        format!("{}@{}+{}", f.name, f.at_force_n, f.delay_s),
        "--timeout-s".into(),
        "120".into(),
    ];
    let (mut p, _) = Proc::spawn(&largs, dir, "linuxcnc")?;
    let exit = match p.wait(Duration::from_secs(200)) {
        Some(st) => describe(st),
        None => "did not end in 200 s (killed)".into(),
    };
    p.drain(Duration::from_millis(200));
    let machine = match machine_log::read(&out.join("machine.csv")) {
        Ok(rows) => rows,
        Err(e @ MachineLogError::Io { .. }) => bail!(
            "{e} ({exit}; see {})",
            dir.join("linuxcnc.stderr").display()
        ),
        Err(e) => return Err(e.into()),
    };
    let run = read(&out.join("run.csv")).unwrap_or_default();
    let ui_log = std::fs::read_to_string(out.join("ui.log")).unwrap_or_default();
    let fr = run.iter().find_map(|r| r.force_ref_n).unwrap_or(800.0);
    let mut row = judge(f, fr, &machine, &run, &ui_log);
    row.exit = exit;
    Ok(row)
}
