//! Names on a log whose replay is not exact are judged against the model error
//! (`acc_ident::workflow`'s `model_error`): on an `acc sim` log analysed on its own logged
//! depths (no workpiece, as a real machine's log is), a name whose updated model makes a
//! sealed block worse beyond the spread of the selection part's block biases is withheld,
//! and without the rule the same log names it.

use acc_ident::model::Channel;
use acc_ident::twin::{run_case_with, CaseAnalysis, Hidden};

fn scenario(workpiece: &str) -> acc_sim::Scenario {
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    sc.workpiece = acc_sim::Workpiece::load(dir.join("workpieces").join(workpiece)).expect("wp");
    sc.max_time_s = 60.0;
    sc
}

#[test]
fn a_wrong_name_on_logged_depths_is_withheld_against_the_model_error() {
    // A 0.05 s override dead time on the power channel (seed 1000): on the logged depths
    // the entry rows carry the replay's own error, and `measurement_delay` passes
    // selection; its updated model overshoots sealed blocks beyond the model error.
    let sc = scenario("steps_1_2_3.toml");
    let h = Hidden::OverrideDeadTime(0.05);
    let logged = |withhold_on_structure| CaseAnalysis {
        on_workpiece: false,
        withhold_on_structure,
    };
    let judged = run_case_with(&sc, h, Channel::Power, 1000, logged(Some(true))).expect("case");
    assert!(judged.named.is_empty(), "named {:?}", judged.named);
    assert_eq!(judged.withheld, vec!["measurement_delay".to_string()]);
    assert!(
        judged.conclusion.contains("beyond the model error"),
        "{}",
        judged.conclusion
    );
    let unjudged = run_case_with(&sc, h, Channel::Power, 1000, logged(None)).expect("case");
    assert_eq!(
        unjudged.named,
        vec![acc_ident::EffectKind::MeasurementDelay],
        "{}",
        unjudged.conclusion
    );
    // On the workpiece (an exact replay) the same log names the dead time.
    let exact = run_case_with(&sc, h, Channel::Power, 1000, CaseAnalysis::default()).expect("case");
    assert_eq!(
        exact.named,
        vec![acc_ident::EffectKind::OverrideDeadTime],
        "{}",
        exact.conclusion
    );
}
