//! Issue 13: the honest twin on logs from the production path (CI-sized; the full figures
//! come from `cargo run --release -p acc-ident --example twin_eval`, docs/twin.md), and the
//! bad-input checks (dead channel, non-finite values, units, gaps).

use acc_ident::model::Channel;
use acc_ident::twin::{self, run_case, Hidden};
use acc_ident::workflow;

fn scenario(workpiece: &str) -> acc_sim::Scenario {
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    sc.workpiece = acc_sim::Workpiece::load(dir.join("workpieces").join(workpiece)).expect("wp");
    sc.max_time_s = 60.0;
    sc
}

#[test]
fn null_logs_from_acc_sim_name_nothing_on_the_power_channel() {
    // The interrupted cut named `feed_exponent` on every seed before the replay was the
    // simulator's plant. (The force channel of a spindle-power log is the power
    // estimator's output, whose own dynamics still read as a feed-drive lag: docs/twin.md.)
    let ch = Channel::Power;
    let v = run_case(&scenario("interrupted.toml"), Hidden::Null, ch, 1007).expect("case");
    assert!(v.named.is_empty(), "{ch:?}: named {:?}", v.named);
}

#[test]
fn hidden_tool_wear_is_named_on_the_power_channel() {
    let ch = Channel::Power;
    let v = run_case(
        &scenario("steps_2_3_4.toml"),
        Hidden::ToolWear(0.08),
        ch,
        1000,
    )
    .expect("case");
    assert_eq!(
        v.named,
        vec![acc_ident::EffectKind::ToolWear],
        "{ch:?}: {v:?}"
    );
}

fn null_log() -> (acc_ident::Model, acc_ident::RunLog) {
    let sc = scenario("steps_2_3_4.toml");
    let log = twin::simulate(&sc).expect("log");
    (twin::model_for_scenario(&sc, Channel::Force), log)
}

#[test]
fn a_dead_force_channel_is_refused_with_its_column_and_value() {
    let (model, mut log) = null_log();
    log.force_n = Some(vec![0.0; log.len()]);
    let e = workflow::analyse(&model, &log, &workflow::Options::default())
        .expect_err("a dead channel is refused")
        .to_string();
    assert!(e.contains("`force_n` is constant (0 on all"), "{e}");
}

#[test]
fn a_nan_is_refused_with_its_line() {
    let (model, mut log) = null_log();
    log.force_n.as_mut().expect("force")[40] = f64::NAN;
    let e = workflow::analyse(&model, &log, &workflow::Options::default())
        .expect_err("NaN refused")
        .to_string();
    assert!(e.contains("line 42: column `force_n` is NaN"), "{e}");
}

#[test]
fn time_going_backwards_is_refused_and_gaps_split_the_run() {
    let (model, log) = null_log();
    let mut back = log.clone();
    back.t_s[30] = back.t_s[28];
    let e = workflow::analyse(&model, &back, &workflow::Options::default())
        .expect_err("time backwards")
        .to_string();
    assert!(e.contains("`t_s`"), "{e}");
    // A 5 s gap after row 150: never joined, the longest piece is analysed, the report says so.
    let mut gap = log.clone();
    for t in gap.t_s.iter_mut().skip(150) {
        *t += 5.0;
    }
    let a = workflow::analyse(&model, &gap, &workflow::Options::default()).expect("analysed");
    let w = a.report.warnings.join(" ");
    assert!(
        w.contains("line 152") && w.contains("gap of 5.100 s"),
        "{w}"
    );
    assert_eq!(a.report.input.rows, log.len() - 150, "{w}");
}

#[test]
fn power_in_kilowatts_is_flagged() {
    let (mut model, mut log) = null_log();
    model.measurement.channel = Channel::Power;
    for p in log.power_w.as_mut().expect("power") {
        *p /= 1000.0;
    }
    let w = log.unit_warnings().join(" ");
    assert!(w.contains("`power_w`") && w.contains("10³"), "{w}");
}
