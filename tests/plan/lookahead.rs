//! The plan and its look-ahead (`acc plan`, `acc sim --plan`): on the pocket program the
//! look-ahead brings every entry and corner to Fr where feedback alone is far above, and
//! so does the plan's lead (`--plan-lead`) at a lower force RMS error, and on the contour
//! the lead is within 1.1 × the oracle held to its rule (per override); a wrong plan (a
//! stock higher than planned), with or without the lead, never raises the force above
//! feedback alone and the log flags the disagreement; with a plan that over-predicts (a
//! stock lower than planned) the lead's largest force is no higher than the cap's; a
//! missing or corrupt plan file is refused naming the file and line.

use crate::e2e_support::{pocket_program, root};
use acc_runtime::{LookAhead, LookAheadConfig, Plan};
use acc_sim::plan::PlanParams;
use acc_sim::program::{event_peaks, EventKind, ProgramPath};
use acc_sim::{LawKind, RunResult, Scenario};

const POCKET_BOX: &str = "-20,-20,-10,60,50,0";

fn scenario() -> Scenario {
    Scenario::load(root().join("configs/scenarios/paper_case3.toml")).expect("scenario")
}

/// Run `path` with the scenario's own law, with `plan`'s look-ahead if given.
fn run(base: &Scenario, path: &ProgramPath, plan: Option<Plan>) -> RunResult {
    let sc = path.scenario_for(base);
    let mut law = sc.build_law(LawKind::Ours).expect("law");
    crate::e2e_support::run_program(&sc, path, law.as_mut(), plan)
}

/// The highest peak (N) at the path's entries and at its corners the run reached.
fn peaks(path: &ProgramPath, run: &RunResult) -> (f64, f64) {
    let p = event_peaks(&run.rows, &path.events(), 1.0);
    let max = |k: EventKind| {
        p.iter()
            .filter(|(e, _)| e.kind == k)
            .filter_map(|(_, f)| *f)
            .fold(0.0, f64::max)
    };
    (max(EventKind::Entry), max(EventKind::Corner))
}

#[test]
fn the_plan_brings_every_entry_and_corner_of_the_pocket_to_fr() {
    let sc = scenario();
    let fr = sc.controller.force_ref_n;
    let path = pocket_program(&sc, POCKET_BOX);
    let plan = path.plan(&PlanParams::of(&sc));
    let alone = run(&sc, &path, None);
    let ahead = run(&sc, &path, Some(plan));
    assert!(alone.finished && ahead.finished);
    assert!(event_peaks(&ahead.rows, &path.events(), 1.0)
        .iter()
        .all(|(_, p)| p.is_some()));
    let (e0, c0) = peaks(&path, &alone);
    let (e1, c1) = peaks(&path, &ahead);
    // Feedback alone: the loop sees the entry and the corner a period after the tool
    // (4.61 and 1.26 Fr, docs/programs.md).
    assert!(
        e0 > 3.0 * fr && c0 > 1.2 * fr,
        "feedback alone {e0} / {c0} N"
    );
    assert!(e1 <= 1.05 * fr, "entries with the plan {:.3} Fr", e1 / fr);
    assert!(c1 <= 1.05 * fr, "corners with the plan {:.3} Fr", c1 / fr);
    // The plan agrees with the plant it was made for.
    assert!(!ahead.rows.iter().any(|r| r.flags.contains("plan_disagree")));
    assert!(ahead.rows.iter().any(|r| r.flags.contains("plan_cap:")));
}

#[test]
fn a_plan_made_for_a_higher_fr_caps_at_the_runs_own_fr() {
    // Planned for the scenario's Fr, run with a tool whose Fr is 5/8 of it (a tool table
    // given to the run but not to the plan): the caps follow the run's Fr.
    let sc = scenario();
    let path = pocket_program(&sc, POCKET_BOX);
    let plan = path.plan(&PlanParams::of(&sc));
    assert!(plan
        .rows
        .iter()
        .all(|r| r.force_ref_n == Some(sc.controller.force_ref_n)));
    let mut low = sc.clone();
    low.controller.force_ref_n *= 5.0 / 8.0;
    let fr = low.controller.force_ref_n;
    let ahead = run(&low, &path, Some(plan.clone()));
    assert!(ahead.finished);
    let (e, c) = peaks(&path, &ahead);
    println!(
        "planned for {:.0} N, run at Fr {fr:.0} N: entries {:.3} Fr, corners {:.3} Fr",
        sc.controller.force_ref_n,
        e / fr,
        c / fr
    );
    assert!(e <= 1.05 * fr, "entries {:.3} Fr", e / fr);
    assert!(c <= 1.05 * fr, "corners {:.3} Fr", c / fr);
    // The same plan without its recorded Fr caps for the Fr it was made for: higher.
    let mut unrecorded = plan;
    for r in &mut unrecorded.rows {
        r.force_ref_n = None;
    }
    let old = run(&low, &path, Some(unrecorded));
    let (e0, c0) = peaks(&path, &old);
    println!(
        "without the plan's Fr: entries {:.3} Fr, corners {:.3} Fr",
        e0 / fr,
        c0 / fr
    );
    assert!(e0.max(c0) > e.max(c), "{e0} {c0} against {e} {c}");
}

/// Run `path` with `plan`'s look-ahead and its lead (`--plan-lead`).
fn run_lead(base: &Scenario, path: &ProgramPath, plan: Plan) -> RunResult {
    let sc = path.scenario_for(base);
    let mut law = sc.build_law(LawKind::Ours).expect("law");
    let cfg = LookAheadConfig {
        lead: true,
        ..LookAheadConfig::new(
            sc.controller.period_s,
            sc.controller.force_ref_n,
            sc.policy.max_override_pct,
        )
    };
    let la = LookAhead::new(plan, cfg);
    acc_sim::oracle_program::run_program_ahead(&sc, path, law.as_mut(), Some(la)).expect("run")
}

#[test]
fn the_plans_lead_keeps_every_entry_and_corner_at_fr_and_lowers_the_rms() {
    let sc = scenario();
    let fr = sc.controller.force_ref_n;
    let path = pocket_program(&sc, POCKET_BOX);
    let plan = path.plan(&PlanParams::of(&sc));
    let capped = run(&sc, &path, Some(plan.clone()));
    let led = run_lead(&sc, &path, plan);
    assert!(capped.finished && led.finished);
    let (e, c) = peaks(&path, &led);
    assert!(e <= 1.05 * fr, "entries with the lead {:.3} Fr", e / fr);
    assert!(c <= 1.05 * fr, "corners with the lead {:.3} Fr", c / fr);
    let n_led = led
        .rows
        .iter()
        .filter(|r| r.flags.contains("plan_lead:"))
        .count();
    assert!(n_led > 100, "{n_led} periods led");
    assert!(!capped.rows.iter().any(|r| r.flags.contains("plan_lead:")));
    // The force RMS error while cutting, the program summary's (force above 5 % of Fr).
    let rms = |r: &RunResult| {
        let e: Vec<f64> = r
            .rows
            .iter()
            .filter_map(|x| x.force_n)
            .filter(|f| *f > 0.05 * fr)
            .map(|f| (f - fr).powi(2))
            .collect();
        (e.iter().sum::<f64>() / e.len() as f64).sqrt()
    };
    let (r0, r1) = (rms(&capped), rms(&led));
    println!("pocket RMS: cap {r0:.1} N, lead {r1:.1} N; {n_led} periods led");
    assert!(
        r1 < 0.95 * r0,
        "the lead lowers the RMS: {r1:.1} N against {r0:.1} N"
    );
}

#[test]
fn a_plan_for_a_lower_stock_never_raises_the_force_and_is_flagged() {
    let sc = scenario();
    // Planned on a stock 1 mm lower than the one on the table: where the plan says air at
    // the top there is metal, and every pass cuts deeper than planned.
    let planned = pocket_program(&sc, "-20,-20,-10,60,50,-1");
    let plan = planned.plan(&PlanParams::of(&sc));
    let path = pocket_program(&sc, POCKET_BOX);
    let alone = run(&sc, &path, None);
    for (name, wrong) in [
        ("cap", run(&sc, &path, Some(plan.clone()))),
        ("lead", run_lead(&sc, &path, plan)),
    ] {
        wrong_plan_checks(name, &path, &alone, &wrong);
    }
}

#[test]
fn a_plan_that_over_predicts_gains_nothing_unsafe_from_the_lead() {
    let sc = scenario();
    // Planned on the full stock, run on one 1 mm lower: the plan predicts metal that is not
    // there (its scale falls below 1), then the passes below meet the planned metal.
    let planned = pocket_program(&sc, POCKET_BOX);
    let plan = planned.plan(&PlanParams::of(&sc));
    let path = pocket_program(&sc, "-20,-20,-10,60,50,-1");
    let top = |r: &RunResult| {
        r.rows
            .iter()
            .filter_map(|x| x.force_true_n)
            .fold(0.0, f64::max)
    };
    let alone = top(&run(&sc, &path, None));
    let capped = top(&run(&sc, &path, Some(plan.clone())));
    let led = top(&run_lead(&sc, &path, plan));
    println!("over-predicting plan: largest true force alone {alone:.0} N, cap {capped:.0} N, lead {led:.0} N");
    assert!(
        led <= capped * 1.001,
        "lead {led:.0} N above the cap's {capped:.0} N"
    );
    assert!(
        led <= alone,
        "lead {led:.0} N above feedback alone {alone:.0} N"
    );
}

/// A run with a wrong plan (`name`) against feedback alone: never a higher force, flagged.
fn wrong_plan_checks(name: &str, path: &ProgramPath, alone: &RunResult, wrong: &RunResult) {
    let top = |r: &RunResult| {
        r.rows
            .iter()
            .filter_map(|x| x.force_true_n)
            .fold(0.0, f64::max)
    };
    assert!(
        top(wrong) <= top(alone) * 1.001,
        "{name}: wrong plan {:.0} N above feedback alone {:.0} N",
        top(wrong),
        top(alone)
    );
    // Where the run stops early, it stops in feed hold (the breakage watch sees the force
    // drop at an exit the plan did not know of), never at a higher feed.
    assert!(wrong.finished || wrong.ended_in_feed_hold, "{name}");
    let (e0, _) = peaks(path, alone);
    let (e1, _) = peaks(path, wrong);
    assert!(
        e1 <= e0 * 1.001,
        "{name}: entries: wrong plan {e1:.0} N, alone {e0:.0} N"
    );
    assert!(
        wrong
            .rows
            .iter()
            .any(|r| r.flags.contains("plan_disagree:above")),
        "{name}: the measured force above the plan is flagged"
    );
}

fn acc(args: &[&str]) -> (bool, String) {
    let (ok, _, err) = crate::e2e_support::acc_output(args);
    (ok, err)
}

#[test]
fn a_missing_or_corrupt_plan_is_refused_naming_the_file_and_line() {
    let dir = std::env::temp_dir().join(format!("acc-plan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let sim = |plan: &std::path::Path| {
        acc(&[
            "sim",
            "paper_case3",
            "--program",
            "tests/nc/pocket_rect.ngc",
            &format!("--stock-box={POCKET_BOX}"),
            "--no-plot",
            "--out",
            &dir.join("out").display().to_string(),
            "--plan",
            &plan.display().to_string(),
        ])
    };
    let missing = dir.join("missing.csv");
    let (ok, err) = sim(&missing);
    assert!(
        !ok && err.contains("missing.csv") && err.contains("cannot read the plan"),
        "{err}"
    );
    // A plan `acc plan` wrote, with one cell broken on its fourth line.
    let (ok, err) = acc(&[
        "plan",
        "tests/nc/pocket_rect.ngc",
        &format!("--stock-box={POCKET_BOX}"),
        "--no-plot",
        "--out",
        &dir.display().to_string(),
    ]);
    assert!(ok, "{err}");
    let good = std::fs::read_to_string(dir.join("plan.csv")).expect("plan.csv");
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    lines[3] = lines[3].replacen(",false,", ",maybe,", 1);
    let corrupt = dir.join("corrupt.csv");
    std::fs::write(&corrupt, lines.join("\n") + "\n").expect("write");
    let (ok, err) = sim(&corrupt);
    assert!(
        !ok && err.contains("corrupt.csv:4") && err.contains("rapid"),
        "{err}"
    );
    assert!(
        !dir.join("out").join("run.csv").exists(),
        "nothing ran on a bad plan"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The lead against the oracle held to its own rule: on the contour (an inside-corner
/// contour with a full-width slot) the plan's lead comes within 1.1 × the force RMS error
/// of the oracle within 1.05 Fr per override — no override whose force over a whole
/// period is above it, as the lead commands — while the oracle judged on period means alone (which may
/// alternate two positions, the upper one above 1.05 Fr once held) is lower, and every
/// entry and corner stays within 1.05 Fr (docs/programs.md, "How far the loop is from it").
#[test]
fn the_lead_on_the_contour_is_within_a_tenth_of_the_oracle_per_override() {
    use acc_sim::oracle_program::{program_rms_within, ProgramPlant};
    use acc_sim::program_summary::summarize_program;
    let sc = scenario();
    let path = crate::e2e_support::program_path(
        &sc,
        &root().join("tests/nc/contour_inside_corners.ngc"),
        "-10,-10,-10,70,65,0",
        0.25,
    );
    let run_sc = path.scenario_for(&sc);
    let fr = run_sc.controller.force_ref_n;
    let plant = ProgramPlant::new(&run_sc, &path);
    let within = program_rms_within(&plant, 1.05, false).expect("oracle within 1.05 Fr");
    let per_override =
        program_rms_within(&plant, 1.05, true).expect("oracle within 1.05 Fr per override");
    assert!(within.finished && per_override.finished);
    let led = run_lead(&sc, &path, path.plan(&PlanParams::of(&run_sc)));
    assert!(led.finished);
    let lead = summarize_program(&led.rows, fr, run_sc.controller.period_s).rms_error_n;
    let (w, h) = (within.summary.rms_error_n, per_override.summary.rms_error_n);
    println!(
        "contour RMS: lead {lead:.1} N; oracle within 1.05 Fr {w:.1} N ({:.2}), per override {h:.1} N ({:.2})",
        lead / w,
        lead / h
    );
    assert!(
        h > w * 1.05,
        "the rule per override costs the oracle: {h} against {w}"
    );
    assert!(
        lead <= 1.1 * h,
        "lead {lead:.1} N against the oracle's {h:.1} N per override"
    );
    let (e, c) = peaks(&path, &led);
    assert!(
        e.max(c) <= 1.05 * fr,
        "entries {:.3} Fr, corners {:.3} Fr",
        e / fr,
        c / fr
    );
}
