//! `acc run --plan` end to end: `acc plan` writes the plan of the pocket program
//! (`tests/nc/pocket_rect.ngc`), `acc board-sim --program` serves the simulated machine
//! cutting that program over a real pty (`--pace controller`: the run is the same on a
//! loaded host), and `acc run --plan plan.csv` drives it for the first pass (the plunge, the
//! slotting entry and the zig-zag's corners). Judged from the machine-side run log (the
//! simulator's true force at the path's entries and corners) and `acc run`'s log (its
//! `plan_cap:` and `plan_lead:` flags): with the plan every entry and corner reached stays
//! ≤ 1.05 Fr, and with `--plan-lead` too while the lead sets the command in the cut (never
//! exceeded); without
//! it (the control) the entry peaks far above Fr.

use std::path::Path;
use std::time::Duration;

use crate::e2e_support::{pocket_program, read_log, root, spawn_board_sim_on, spawn_run_for};
use acc_runtime::record::RunRecord;
use acc_sim::program::{event_peaks, EventKind};

const SCENARIO: &str = "configs/scenarios/paper_case3.toml";
const POCKET_BOX: &str = "-20,-20,-10,60,50,0";
/// Machine time of each run, s: the approach, the plunge, the slotting entry and the first
/// corners of the first pass.
const RUN_S: &str = "20";

/// One closed loop over a pty, with the plan at `plan` if given and `acc run`'s `more`
/// arguments: (machine log, acc run log).
fn closed_loop(
    dir: &Path,
    tag: &str,
    plan: Option<&Path>,
    more: &[&str],
) -> (Vec<RunRecord>, Vec<RunRecord>) {
    let config = crate::e2e_support::load_tolerant_config(dir, "");
    let machine_log = dir.join(format!("machine-{tag}.csv"));
    let run_log = dir.join(format!("run-{tag}.csv"));
    let (board, pty) = spawn_board_sim_on(
        SCENARIO,
        &[
            "--pace",
            "controller",
            "--program",
            "tests/nc/pocket_rect.ngc",
            &format!("--stock-box={POCKET_BOX}"),
            "--log",
            &machine_log.to_string_lossy(),
        ],
    );
    let plan_arg = plan.map(|p| p.to_string_lossy().into_owned());
    let mut extra: Vec<&str> = match &plan_arg {
        Some(p) => vec!["--plan", p],
        None => vec![],
    };
    extra.extend_from_slice(more);
    let run = spawn_run_for(&config.to_string_lossy(), &pty, &run_log, RUN_S, &extra);
    let (code, out, err) = run.finish(Duration::from_secs(120));
    board.sigint();
    let (_, _, berr) = board.finish(Duration::from_secs(10));
    assert_eq!(
        code,
        Some(0),
        "acc run ({tag}) exit; stdout:\n{out}\nstderr:\n{err:?}\nboard-sim:\n{berr:?}"
    );
    (read_log(&machine_log), read_log(&run_log))
}

/// The highest true peak at the entries and at the corners the machine reached, as a
/// multiple of Fr, and how many of each it reached.
fn peaks(machine: &[RunRecord], fr: f64) -> ((f64, usize), (f64, usize)) {
    let sc = acc_sim::Scenario::load(root().join(SCENARIO)).expect("scenario");
    let events = pocket_program(&sc, POCKET_BOX).events();
    let p = event_peaks(machine, &events, 1.0);
    let of = |k: EventKind| {
        let v: Vec<f64> = p
            .iter()
            .filter(|(e, _)| e.kind == k)
            .filter_map(|(_, f)| *f)
            .collect();
        (v.iter().copied().fold(0.0, f64::max) / fr, v.len())
    };
    (of(EventKind::Entry), of(EventKind::Corner))
}

#[test]
fn acc_run_with_the_plan_holds_every_entry_and_corner_of_the_pocket_at_fr() {
    let dir = tempfile::tempdir().expect("temp dir");
    let plan_dir = dir.path().join("plan");
    let (ok, out, err) = crate::e2e_support::acc_output(&[
        "plan",
        "tests/nc/pocket_rect.ngc",
        &format!("--stock-box={POCKET_BOX}"),
        "--scenario",
        SCENARIO,
        "--no-plot",
        "--out",
        &plan_dir.to_string_lossy(),
    ]);
    assert!(ok, "acc plan: {out}\n{err}");
    let plan = plan_dir.join("plan.csv");
    let fr = 800.0;

    let (machine, run) = closed_loop(dir.path(), "plan", Some(&plan), &[]);
    // The board reported the program's blocks, tools and feeds.
    assert!(run.iter().any(|r| r.block.is_some_and(|b| b > 1)), "blocks");
    assert!(machine.iter().all(|r| r.tool == Some(1)), "tool T1");
    let capped = run.iter().filter(|r| r.flags.contains("plan_cap:")).count();
    assert!(capped > 10, "{capped} periods with the plan's cap");
    assert!(
        !run.iter().any(|r| r.flags.contains("plan_lead:")),
        "no lead by default"
    );
    let ((entry, n_entry), (corner, n_corner)) = peaks(&machine, fr);
    println!(
        "with the plan: {n_entry} entries, peak {entry:.3} Fr; {n_corner} corners, peak {corner:.3} Fr; {capped} capped periods"
    );
    assert!(
        n_entry >= 1 && n_corner >= 2,
        "{n_entry} entries, {n_corner} corners reached"
    );
    assert!(entry <= 1.05, "entries with the plan {entry:.3} Fr");
    assert!(corner <= 1.05, "corners with the plan {corner:.3} Fr");

    // `--plan-lead`: the plan's lead sets the command in the cut, nothing writes above it,
    // and the entries and corners stay at Fr.
    let (machine_l, run_l) = closed_loop(dir.path(), "lead", Some(&plan), &["--plan-lead"]);
    let lead = |r: &RunRecord| -> Option<u16> {
        let v = r
            .flags
            .split(';')
            .find_map(|f| f.strip_prefix("plan_lead:"))?;
        Some(v.parse().expect("plan_lead:<pct>"))
    };
    let led: Vec<_> = run_l.iter().filter_map(|r| Some((lead(r)?, r))).collect();
    assert!(led.len() > 10, "{} periods with the plan's lead", led.len());
    for (l, r) in &led {
        // A led period is one where the plan and the measurement agree on a sound line.
        for bad in ["plan_disagree", "force_invalid", "link:", "write:", "fault"] {
            assert!(
                !r.flags.contains(bad),
                "t = {} s: led with {bad}: {}",
                r.t_s,
                r.flags
            );
        }
        // The command written is the lead (no shop layer here to cap it lower).
        if let Some(cmd) = r.override_cmd_pct {
            assert_eq!(
                cmd, *l,
                "t = {} s: command {cmd} % against the lead {l} %",
                r.t_s
            );
        }
    }
    let ((entry_l, _), (corner_l, _)) = peaks(&machine_l, fr);
    println!(
        "with the plan's lead: entries peak {entry_l:.3} Fr; corners peak {corner_l:.3} Fr; {} led periods",
        led.len()
    );
    assert!(entry_l <= 1.05, "entries with the lead {entry_l:.3} Fr");
    assert!(corner_l <= 1.05, "corners with the lead {corner_l:.3} Fr");

    // The control: the same loop without the plan sees the entry a period after the tool.
    let (machine0, run0) = closed_loop(dir.path(), "alone", None, &[]);
    assert!(!run0.iter().any(|r| r.flags.contains("plan_")));
    let ((entry0, _), (corner0, _)) = peaks(&machine0, fr);
    println!("feedback alone: entries peak {entry0:.3} Fr; corners peak {corner0:.3} Fr");
    assert!(entry0 > 2.0, "feedback alone: entries {entry0:.3} Fr");
    assert!(
        entry0.max(corner0) > entry.max(corner) + 0.5,
        "the plan lowers the peaks: {entry0:.3} / {corner0:.3} Fr alone, {entry:.3} / {corner:.3} Fr with the plan"
    );
}
