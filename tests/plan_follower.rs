//! The plan follower (`acc_sim::plan_follower`, docs/plan.md "What the plan cannot see"):
//! on the pocket program, a law that reads the plan with the tool's exact position and the
//! plan's scale known exceeds 1.05 Fr only where the plant holds a corner's doubled axial
//! depth over a whole period (the plan predicts the depth along the path), and with the
//! plant reading the axial depth at every step it keeps 1.05 Fr at a force RMS error
//! within 1.1 × the oracle's on that plant.

mod e2e_support;

use acc_sim::plan::PlanParams;
use acc_sim::plan_follower::{follow_plan, FollowerConfig};
use acc_sim::Scenario;
use e2e_support::{pocket_program, root};

const POCKET_BOX: &str = "-20,-20,-10,60,50,0";

/// The oracle within 1.05 Fr on the pocket with the axial depth read per step, N
/// (`cargo run --release -p acc-sim --example oracle_trace -- tests/nc/pocket_rect.ngc
/// -20,-20,-10,60,50,0 DIR --axial-per-step`, docs/plan.md).
const ORACLE_PER_STEP_N: f64 = 91.8;

#[test]
fn the_plan_follower_exceeds_the_peak_only_where_the_plant_holds_the_axial_depth() {
    let base = Scenario::load(root().join("configs/scenarios/paper_case3.toml")).expect("scenario");
    let path = pocket_program(&base, POCKET_BOX);
    let sc = path.scenario_for(&base);
    let fr = sc.controller.force_ref_n;
    let plan = path.plan(&PlanParams::of(&sc));
    let run = |scale: f64, axial_per_step: bool| {
        let cfg = FollowerConfig {
            axial_per_step,
            ..FollowerConfig::of(&base, scale)
        };
        let r = follow_plan(&base, &path, &plan, cfg);
        assert!(r.finished, "the follower finishes the program");
        eprintln!(
            "scale {scale}, axial per step {axial_per_step}: RMS {:.1} N, highest {:.3} Fr",
            r.summary.rms_error_n,
            r.peak_n() / fr
        );
        r
    };
    // Held per period: the periods above 1.05 Fr are the corners of the second depth
    // level, each starting inside the doubled axial depth and keeping it to its end.
    let held = run(1.05, false);
    let over: Vec<_> = held
        .rows
        .iter()
        .filter(|r| r.force_true_n.unwrap_or(0.0) > 1.05 * fr)
        .collect();
    assert!(held.peak_n() > 1.2 * fr, "the hold's overshoot is there");
    assert!(
        over.iter().all(|r| r.axial_depth_mm.unwrap_or(0.0) > 3.0),
        "every period above 1.05 Fr holds a doubled depth: {over:?}"
    );
    // Read per step, the same follower keeps the peak and comes within 1.1 × the oracle.
    let step = run(1.05, true);
    assert!(step.peak_n() <= 1.05 * fr, "{:.0} N", step.peak_n());
    assert!(
        step.summary.rms_error_n <= 1.1 * ORACLE_PER_STEP_N,
        "{:.1} N",
        step.summary.rms_error_n
    );
}
