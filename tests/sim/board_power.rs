//! `acc sim` measures the way `acc run` does: on the spindle-power channel the simulated
//! board carries the measured power in its `POWER` registers, and the loop's force is the
//! production `SpindleSource` (board power) on the status read. Checked row by row: the
//! same source, fed only what the run log says the board reported (whole watts, whole
//! rpm), gives every logged force bit for bit.

use acc_core::PeriodInput;
use acc_sim::scenario::MeasurementSpec;
use acc_sim::{LawKind, Scenario};

fn scenario(name: &str) -> Scenario {
    let dir = acc_sim::run::configs_dir();
    Scenario::load(dir.join(format!("scenarios/{name}.toml"))).expect("scenario")
}

#[test]
fn the_logged_force_is_the_board_power_estimate_of_the_logged_register() {
    let sc = scenario("paper_case3");
    assert!(matches!(sc.measurement, MeasurementSpec::SpindlePower(s) if s.board_power));
    // The source as the run's loop gets it: the same start-up calibration (same seed).
    let mut source = sc
        .build_channel()
        .expect("channel")
        .take_board_source()
        .expect("the spindle-power channel hands its estimator to the loop");
    assert_eq!(source.name(), "board-power");
    let (run, _) = sc.run_law(LawKind::Ours).expect("run");
    let mut estimated = 0;
    for row in &run.rows {
        // A row without a force is one the loop did not estimate (the end of the run).
        let (Some(p), Some(rpm), Some(_)) = (row.power_w, row.spindle_rpm, row.force_n) else {
            continue;
        };
        assert_eq!(p, p.round(), "the board reports whole watts: {p}");
        let got = source.estimate(&PeriodInput {
            period_s: sc.controller.period_s,
            spindle_rpm: rpm,
            feed_mm_min: row.feed_mm_min.unwrap_or(0.0),
            power_w: Some(p),
            ..PeriodInput::default()
        });
        assert!(got.valid, "period {}", row.period);
        assert_eq!(row.force_n, Some(got.force_n), "period {}", row.period);
        estimated += 1;
    }
    assert!(
        estimated + 2 >= run.rows.len(),
        "{estimated} of {}",
        run.rows.len()
    );
    // The estimate is not the truth: the estimator's own error is there.
    let err: Vec<f64> = run
        .rows
        .iter()
        .filter_map(|r| Some(r.force_n? - r.force_true_n.filter(|f| *f > 400.0)?))
        .collect();
    let rms = (err.iter().map(|e| e * e).sum::<f64>() / err.len() as f64).sqrt();
    assert!(rms > 0.5 && rms < 10.0, "estimator error {rms:.2} N RMS");
}

#[test]
fn a_dynamometer_is_not_on_the_board() {
    let sc = scenario("paper_case3_dynamometer");
    assert!(sc
        .build_channel()
        .expect("channel")
        .take_board_source()
        .is_none());
    let (run, _) = sc.run_law(LawKind::Ours).expect("run");
    // The board's register still carries the spindle power, in whole watts.
    assert!(run
        .rows
        .iter()
        .filter_map(|r| r.power_w)
        .all(|p| p == p.round()));
}
