//! `acc fault-matrix`: every fault of the reliability table, driven at the worst moment of
//! a real closed loop, on a v2 and on a v1 board, measured on the machine side.
//!
//! Each row is one production run: `acc board-sim` (the running `acc` binary) serves the
//! simulated machine of paper case III on a new pty, `acc run` drives it, and the fault hits at
//! `--at-s` of machine time, deep in the 4 mm step where the override and the force are at
//! their highest. Board faults are `acc board-sim --fault` schedules; process faults are real
//! signals sent to the `acc run` process when the board reports the moment. The row is then
//! judged from the two run logs:
//!
//! - **last cmd**: the override ACC last commanded before the fault (the board's
//!   `OVERRIDE_CMD` in the last period it was `ACC_ACTIVE`);
//! - **max applied after**: the largest override on the PMC inputs in the window after the
//!   fault while the feed was not held (in feed hold the axes stand still, whatever the
//!   override);
//! - **force before / after**: the largest true cutting force (the simulator's) in the
//!   `--before-s` before the fault and in the window after it;
//! - **log complete**: `acc run`'s log has one row for every period from the first to the last
//!   (`period` consecutive), skipped and faulty ones included;
//! - **exit**: `acc run`'s exit code (or the signal that ended it).
//!
//! Pass: max applied after ≤ last cmd, force after ≤ 1.05 × force before, log complete. A
//! row no controller can make safe (a v1 board has no fallback clamp) is marked with why;
//! the NC's own override lock is reported, not judged (the NC ignores the override inputs).
//!
//! **Hostile-line rows** (`garbage-*`, `delay-*`): a man in the middle
//! (`tests/peers/mitm_proxy.py`, an independent Python program) sits on the serial line
//! between `acc board-sim`'s pty and `acc run`, transparent until the fault moment, when
//! the harness switches its faults on (SIGUSR1) until the end of the window (SIGUSR2): a
//! share of the replies corrupted with a VALID CRC (a flipped register bit, another slave
//! address, an exception, a wrong byte count, a truncated frame, random contents), or every
//! status read answered with the board's reply of N reads earlier (a buffering gateway).
//! These rows also pass only if
//!
//! - the true force in every period after the fault in which the feed was not held is at
//!   most 1.05 × the force before (ACC keeps driving through a bad line: every period
//!   counts, not only the released ones);
//! - no period after the fault ends in the state `operator_handback` or `switch_off`: the
//!   proxy never touches the knob or the switch, so such a release is a bad frame taken for
//!   the operator;
//! - every status read (FC04) the proxy altered in a way the controller can tell from the
//!   frame ([`must_be_flagged`](crate::read_match::must_be_flagged)) has its period flagged in `acc run`'s log ([`suspicious`](crate::read_match::suspicious):
//!   `link:`, `implausible:`, `unconfirmed:`, `force_invalid`, `echo`, `delay`). The reads
//!   are matched to the log's rows in order ([`align_reads`](crate::read_match::align_reads), checked on the power the
//!   proxy handed over); if that match is not reliable, the row falls back to counting:
//!   flagged rows after the fault ≥ altered reads that must be flagged, and says so.
//!   Delayed replies are not required to be flagged (nothing in one frame shows them).
//!
//! **Wrong-plan rows** (`plan-low-stock`, `plan-lead-low-stock`, `plan-missing`): `acc run
//! --plan` against `acc board-sim --program` cutting the pocket program, with a plan made for
//! a lower stock (followed with the cap alone, or with the plan's lead) or a plan file that
//! does not exist; their criteria are in [`wrong_plan`].
//!
//! **The LinuxCNC section** (`--linuxcnc`, its own table `fault-matrix-linuxcnc.md` /
//! `.json`): the faults of a LinuxCNC machine under `acc run --hal`, each a run of `acc
//! linuxcnc --fault KIND@N`; their criteria are in [`linuxcnc`].
//!
//! The other faults are timing faults, so their rows run on the wall clock. A row that fails, or
//! never reaches the fault moment, while the host was too loaded for `acc run` to keep its
//! period (its run log's `late` and `skipped` periods, [`rerun::HostLoad`]) or to start (its
//! start-up transactions unanswered, exit 5, before a period), or whose fault met no cut
//! under ACC (ACC had released or held the feed before it: the row tested nothing), is run
//! once more; the table's verdict then names the first attempt beside the second one's verdict
//! (and the JSON has it as `first_attempt`), its logs kept in `<row>-first`.

mod faults;
pub mod linuxcnc;
mod report;
mod rerun;
mod row;
mod verdict;
mod wrong_plan;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{bail, Context};

use crate::child;

use faults::{Action, Fault, PlanFault, FAULTS};
use report::markdown;
use rerun::{first_attempt, HostLoad};
use row::run_row;
use verdict::Row;

/// Arguments of `acc fault-matrix`.
#[derive(Debug, clap::Args)]
pub struct FaultMatrixArgs {
    /// Output directory: `fault-matrix.md` (the table), `fault-matrix.json`, and one folder
    /// of logs per row.
    #[arg(long, default_value = "out/fault-matrix")]
    pub out: PathBuf,
    /// Board protocols to test: `2`, `1` or `both`.
    #[arg(long, default_value = "both")]
    pub protocol: String,
    /// Only these faults (repeatable; names as in the table's first column).
    #[arg(long = "only")]
    pub only: Vec<String>,
    /// Scenario served by `acc board-sim` (the default: paper case III on shortened steps,
    /// the 4 mm step from about 10 s to 34 s of machine time).
    #[arg(long, default_value = "configs/scenarios/fault_matrix.toml")]
    pub scenario: PathBuf,
    /// `acc run` configuration (its `runtime.time_scale` must equal `--time-scale`).
    #[arg(long, default_value = "configs/runtime/fault_matrix.toml")]
    pub config: PathBuf,
    /// `acc run` configuration of the wrong-plan rows (`plan-*`: `--pace controller`, a link
    /// tolerant of a loaded host).
    #[arg(long, default_value = "configs/runtime/fault_matrix_plan.toml")]
    pub plan_config: PathBuf,
    /// Machine seconds per wall second for both processes (1 ..= 20).
    #[arg(long, default_value_t = 5.0)]
    pub time_scale: f64,
    /// Machine time of the fault, s (the default scenario's 4 mm step runs from about 10 s
    /// to 34 s, settled by 12 s).
    #[arg(long, default_value_t = 16.0)]
    pub at_s: f64,
    /// Window before the fault for the reference force, s of machine time.
    #[arg(long, default_value_t = 2.0)]
    pub before_s: f64,
    /// Window after the fault, s of machine time.
    #[arg(long, default_value_t = 6.0)]
    pub after_s: f64,
    /// Window after the fault of the hostile-line rows (`garbage-*`, `delay-*`), s of machine
    /// time: long enough for 1 % of the replies to be a handful (the default scenario's 4 mm
    /// step ends at about 34 s).
    #[arg(long, default_value_t = 12.0)]
    pub line_after_s: f64,
    /// The man-in-the-middle proxy of the hostile-line rows (run with `python3`).
    #[arg(long, default_value = "tests/peers/mitm_proxy.py")]
    pub proxy: PathBuf,
    /// Seed of the proxy's corruption.
    #[arg(long, default_value_t = 1)]
    pub line_seed: u64,
    /// Rows run at once (1 ..= 8). Each row has its own `acc board-sim`, pty and `acc run`,
    /// so against the simulated board rows are independent; a row that fails while the host
    /// was too loaded to keep the period is run again as with one job. Against one real
    /// board, keep 1.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// The LinuxCNC section instead of the board rows ([`linuxcnc`]): each row one `acc
    /// linuxcnc --fault KIND@N` run on headless LinuxCNC, one after another (one LinuxCNC
    /// per host); the table in `--out` as `fault-matrix-linuxcnc.md` / `.json`.
    #[arg(long)]
    pub linuxcnc: bool,
    /// The LinuxCNC rows' program.
    #[arg(long, default_value = "tests/nc/linuxcnc_short.ngc")]
    pub linuxcnc_program: PathBuf,
    /// The LinuxCNC rows' stock box `X0,Y0,Z0,X1,Y1,Z1`, mm.
    #[arg(long, default_value = "0,-20,-10,40,20,0", allow_hyphen_values = true)]
    pub linuxcnc_stock_box: String,
}

/// One row; if it failed (or never reached the fault moment) while `acc run` could not keep
/// its period ([`HostLoad::overloaded`]), or its fault met no cut under ACC
/// ([`Row::untested`]: the row says nothing of its fault), once more, its first attempt's
/// logs kept in `<dir>-first` and its outcome in [`Row::first_attempt`].
fn run_row_rerun_if_overloaded(
    args: &FaultMatrixArgs,
    f: &Fault,
    protocol: u8,
    dir: &Path,
) -> anyhow::Result<Row> {
    let first = run_row(args, f, protocol, dir);
    let run_log = child::read(&dir.join("run.csv")).unwrap_or_default();
    let run_err = std::fs::read_to_string(dir.join("run.stderr")).unwrap_or_default();
    let (outcome, load) = match &first {
        Ok(row) if row.ok => return first,
        Ok(row) => (
            row.verdict.clone(),
            HostLoad::of(&run_log, f, row.t_fault_s),
        ),
        Err(e) => (
            format!("error: {e:#}"),
            HostLoad::of(&run_log, f, None).with_start(&run_err),
        ),
    };
    let untested = matches!(&first, Ok(row) if row.untested.is_some());
    if !load.overloaded() && !untested {
        return first;
    }
    let outcome = first_attempt(&outcome, &load);
    let kept = dir.with_file_name(format!(
        "{}-first",
        dir.file_name()
            .map_or_else(|| "row".into(), |n| n.to_string_lossy())
    ));
    let _ = std::fs::remove_dir_all(&kept);
    std::fs::rename(dir, &kept)
        .with_context(|| format!("keeping the first attempt in {}", kept.display()))?;
    std::fs::create_dir_all(dir)?;
    eprintln!(
        "v{protocol} {}: {outcome}; running the row once more",
        f.name
    );
    let mut row = run_row(args, f, protocol, dir)?;
    row.first_attempt = Some(outcome);
    Ok(row)
}

/// The order rows start in: the plan rows first (each cuts a whole pocket, several times
/// a row of the 1-D cut), so that `--jobs` workers end together; the others as given.
fn start_order(cells: &[(u8, &Fault)]) -> Vec<usize> {
    let long = |f: &Fault| matches!(f.action, Action::Plan(p) if p != PlanFault::Missing);
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by_key(|&i| !long(cells[i].1));
    order
}

/// Every row of `cells` (protocol, fault), `--jobs` at a time, the longest first; a
/// progress line per finished row; the rows returned in the order given. The first error
/// stops the matrix (rows under way finish).
fn run_rows(args: &FaultMatrixArgs, cells: &[(u8, &Fault)]) -> anyhow::Result<Vec<Row>> {
    let total = cells.len();
    let order = start_order(cells);
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<anyhow::Result<Row>>>> =
        Mutex::new((0..total).map(|_| None).collect());
    let started = Instant::now();
    let worker = || loop {
        let k = next.fetch_add(1, Ordering::SeqCst);
        if k >= total || failed.load(Ordering::SeqCst) {
            return;
        }
        let i = order[k];
        let (protocol, f) = cells[i];
        let dir = args.out.join(format!("v{protocol}-{}", f.name));
        let row = std::fs::create_dir_all(&dir)
            .map_err(anyhow::Error::from)
            .and_then(|()| run_row_rerun_if_overloaded(args, f, protocol, &dir))
            .with_context(|| format!("fault-matrix row v{protocol} {}", f.name));
        let n = done.fetch_add(1, Ordering::SeqCst) + 1;
        match &row {
            Ok(r) => eprintln!(
                "[{n:>2}/{total}] v{protocol} {:<16} {} ({:.0} s elapsed)",
                f.name,
                r.verdict,
                started.elapsed().as_secs_f64()
            ),
            Err(_) => failed.store(true, Ordering::SeqCst),
        }
        results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(row);
    };
    std::thread::scope(|s| {
        for _ in 0..args.jobs {
            s.spawn(worker);
        }
    });
    let mut rows = Vec::with_capacity(total);
    for r in results.into_inner().unwrap_or_else(|e| e.into_inner()) {
        match r {
            Some(row) => rows.push(row?),
            None => continue,
        }
    }
    Ok(rows)
}

/// `acc fault-matrix`: every row, the table written to `--out` (`fault-matrix.md`,
/// `fault-matrix.json`) and printed; an error naming the rows that failed.
pub fn run(args: &FaultMatrixArgs) -> anyhow::Result<()> {
    if args.linuxcnc {
        return linuxcnc::run(args);
    }
    if !(1..=8).contains(&args.jobs) {
        bail!("--jobs {}: allowed 1 ..= 8", args.jobs);
    }
    if !(args.time_scale.is_finite() && (1.0..=20.0).contains(&args.time_scale)) {
        bail!("--time-scale {}: allowed 1 ..= 20", args.time_scale);
    }
    let protocols: &[u8] = match args.protocol.as_str() {
        "both" => &[2, 1],
        "2" => &[2],
        "1" => &[1],
        p => bail!("--protocol {p}: allowed 2, 1 or both"),
    };
    for o in &args.only {
        if !FAULTS.iter().any(|f| f.name == o) {
            let names: Vec<_> = FAULTS.iter().map(|f| f.name).collect();
            bail!(
                "--only {o}: not a fault of the matrix; allowed: {}",
                names.join(", ")
            );
        }
    }
    for (flag, v) in [
        ("--at-s", args.at_s),
        ("--before-s", args.before_s),
        ("--after-s", args.after_s),
        ("--line-after-s", args.line_after_s),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 600.0) {
            bail!("{flag} {v}: allowed 0 < s <= 600");
        }
    }
    for (what, p) in [
        ("--scenario", &args.scenario),
        ("--config", &args.config),
        ("--plan-config", &args.plan_config),
    ] {
        if !p.is_file() {
            bail!("{what} {}: no such file", p.display());
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let faults: Vec<&Fault> = FAULTS
        .iter()
        .filter(|f| args.only.is_empty() || args.only.iter().any(|o| o == f.name))
        .collect();
    let cells: Vec<(u8, &Fault)> = protocols
        .iter()
        .flat_map(|&p| faults.iter().map(move |&f| (p, f)))
        .collect();
    let rows = run_rows(args, &cells)?;
    let table = markdown(&rows, args);
    report::write_section(&args.out, "fault-matrix", &table, &rows)?;
    let failed: Vec<_> = rows.iter().filter(|r| !r.ok).collect();
    if !failed.is_empty() {
        bail!(
            "{} of {} rows failed: {}",
            failed.len(),
            rows.len(),
            failed
                .iter()
                .map(|r| format!("v{} {}", r.protocol, r.fault))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
