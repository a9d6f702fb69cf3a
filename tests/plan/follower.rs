//! The plan follower (`acc_sim::plan_follower`, docs/plan.md "What the loop does not know"):
//! on the pocket program, a law that reads the plan with the tool's exact position and the
//! plan's scale known keeps 1.05 Fr at a force RMS error within 1.1 × the oracle's on the
//! same plant — the plant's force follows the engagement the plan predicts along the path,
//! the axial depth included.

use crate::e2e_support::{pocket_program, root};
use acc_sim::plan::PlanParams;
use acc_sim::plan_follower::{follow_plan, FollowerConfig};
use acc_sim::Scenario;

const POCKET_BOX: &str = "-20,-20,-10,60,50,0";

/// The oracle within 1.05 Fr on the pocket, N (`cargo run --release -p acc-sim --example
/// oracle_trace -- tests/nc/pocket_rect.ngc -20,-20,-10,60,50,0 DIR`, docs/plan.md).
const ORACLE_N: f64 = 91.8;

#[test]
fn the_plan_follower_keeps_the_peak_within_a_tenth_of_the_oracle() {
    let base = Scenario::load(root().join("configs/scenarios/paper_case3.toml")).expect("scenario");
    let path = pocket_program(&base, POCKET_BOX);
    let sc = path.scenario_for(&base);
    let fr = sc.controller.force_ref_n;
    let plan = path.plan(&PlanParams::of(&sc));
    let r = follow_plan(&base, &path, &plan, FollowerConfig::of(&base, 1.05));
    assert!(r.finished, "the follower finishes the program");
    eprintln!(
        "RMS {:.1} N, highest {:.3} Fr",
        r.summary.rms_error_n,
        r.peak_n() / fr
    );
    assert!(r.peak_n() <= 1.05 * fr, "{:.0} N", r.peak_n());
    assert!(
        r.summary.rms_error_n <= 1.1 * ORACLE_N,
        "{:.1} N against the oracle's {ORACLE_N} N",
        r.summary.rms_error_n
    );
}
