//! Where the tool stood when a production log began, estimated from the log (`acc
//! discrepancy --workpiece` without `--x0-mm`; `acc_ident::workflow::path_shift`).
//!
//! The log: `acc sim`'s closed loop on the hidden-wear machine
//! (`configs/scenarios/hidden_wear.toml`: +6 % `Ks` per cm³ on two 75 mm cuts), production
//! columns only, against the nominal production model (no wear). The simulator starts its
//! tool at rest at the workpiece's start and reads the machine first after one period, so
//! the replay's true start is 0 mm. `--x0-mm 0` describes `acc board-sim
//! --wait-for-controller` instead, whose first read sees the held machine: read that way,
//! this log's replay starts a period of the first row's feed too early (about 0.33 mm).

use std::path::Path;

use acc_ident::engagement::PathEngagement;
use acc_ident::model::Channel;
use acc_ident::report::Report;
use acc_ident::{runlog, workflow, Model};
use acc_runtime::RunRecord;

/// The closed loop's rows without the plant's truth, and the scenario.
fn production_rows() -> (acc_sim::Scenario, Vec<RunRecord>) {
    let dir = acc_sim::run::configs_dir();
    let sc = acc_sim::Scenario::load(dir.join("scenarios/hidden_wear.toml")).expect("scenario");
    let mut law = sc.build_law(acc_sim::LawKind::Ours).expect("law");
    let res = acc_sim::run(&sc, law.as_mut(), acc_sim::RunSetup::default()).expect("run");
    let first = &res.rows[0];
    assert!(
        first.x_true_mm.is_some_and(|x| x > 0.2),
        "the first read comes after the first period's travel: {:?}",
        first.x_true_mm
    );
    let rows = res
        .rows
        .into_iter()
        .map(acc_sim::truth::without_truth)
        .collect();
    (sc, rows)
}

/// The nominal production model on `channel`; the force channel averages the last 0.05 s
/// of the period, as the scenario's dynamometer does.
fn model(channel: Channel) -> Model {
    let dir = acc_sim::run::configs_dir();
    let mut m = Model::load(&dir.join("models/paper_vmc_production.toml")).expect("model");
    m.measurement.channel = channel;
    if channel == Channel::Force {
        m.measurement.force_window_s = 0.05;
    }
    m
}

/// The rows read as `acc discrepancy --workpiece --x0-mm X0` reads them, and its options
/// (`estimate`: without `--x0-mm`, the start searched from X0).
fn read(
    sc: &acc_sim::Scenario,
    rows: &[RunRecord],
    model: &Model,
    x0_mm: f64,
    estimate: bool,
) -> (acc_ident::RunLog, workflow::Options) {
    let eng = PathEngagement {
        workpiece: sc.workpiece.clone(),
        source: "wear_cut_150.toml".into(),
        tool_diameter_mm: model.tool.diameter_mm,
        x0_mm,
    };
    let log = runlog::from_records_with(rows, Path::new("run.csv"), Some(&eng)).expect("log");
    // The strict rules off (`None`): the subject is the start search. Under the default
    // the wear of this log is withheld on the power channel — the estimated start is
    // 0.013 mm off, which leaves 2–3 W at one depth change and one entry against a noise
    // of 0.3 W (docs/twin.md, "Limits").
    let opts = workflow::Options {
        workpiece: Some((sc.workpiece.clone(), x0_mm)),
        anchor_to_log: true,
        estimate_path_start: estimate,
        withhold_on_structure: None,
        ..workflow::Options::default()
    };
    (log, opts)
}

fn analyse(
    sc: &acc_sim::Scenario,
    rows: &[RunRecord],
    channel: Channel,
    x0_mm: f64,
    estimate: bool,
) -> Report {
    let m = model(channel);
    let (log, opts) = read(sc, rows, &m, x0_mm, estimate);
    workflow::analyse(&m, &log, &opts).expect("analysed").report
}

#[test]
fn the_start_is_found_where_the_tool_was_and_the_wear_then_explains_the_log() {
    let (sc, rows) = production_rows();
    for ch in [Channel::Power, Channel::Force] {
        let est = analyse(&sc, &rows, ch, 0.0, true);
        let s = est.path_shift.clone().expect("a start estimate");
        println!("{ch:?}: {}", s.text());
        // Given: a period of the first row's feed before 0 (`RunLog::path_start_mm`).
        assert!(s.given_start_mm < -0.2, "{ch:?}: {s:?}");
        assert!(s.adopted, "{ch:?}: {s:?}");
        let start = s.given_start_mm + s.shift_mm;
        assert!(
            start.abs() < 0.03,
            "{ch:?}: estimated start {start} mm, true 0"
        );
        let fixed = analyse(&sc, &rows, ch, 0.0, false);
        assert!(fixed.path_shift.is_none());
        let (a, b) = (fixed.sealed.updated.rms, est.sealed.updated.rms);
        println!(
            "{ch:?}: sealed RMS {a:.2} at the given start, {b:.2} at the estimate; named {:?} / {:?}",
            fixed.accepted, est.accepted
        );
        assert!(b < a, "{ch:?}: sealed RMS {a} → {b}");
        assert!(
            est.accepted.iter().any(|e| e == "tool_wear"),
            "{ch:?}: {:?}: {}",
            est.accepted,
            est.conclusion
        );
    }
}

#[test]
fn a_start_that_was_right_is_kept_and_one_beyond_the_search_is_reported() {
    let (sc, rows) = production_rows();
    let m = model(Channel::Power);
    // The first row's travel: `--x0-mm` there puts the replay's start at the true 0.
    let dt = rows[1].t_s - rows[0].t_s;
    let travel = rows[0].feed_mm_min.expect("feed") * dt / 60.0;
    let (log, opts) = read(&sc, &rows, &m, travel, true);
    let s = workflow::estimate_path_shift(&m, &log, &opts)
        .expect("estimated")
        .expect("a workpiece");
    assert!(s.given_start_mm.abs() < 1e-9, "{s:?}");
    assert!(!s.adopted, "{s:?}");
    assert!(s.shift_mm.abs() < 0.03, "{s:?}");
    // 10 mm off: outside the ±3 mm search.
    let (log, opts) = read(&sc, &rows, &m, travel - 10.0, true);
    let s = workflow::estimate_path_shift(&m, &log, &opts)
        .expect("estimated")
        .expect("a workpiece");
    assert!(s.at_bound && !s.adopted, "{s:?}");
    assert!(s.text().contains("check it"), "{}", s.text());
}
