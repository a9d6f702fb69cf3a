//! The workflow on a log written by the simulator itself, and the file formats: run-log
//! errors with line and column, model files the simulator loads.

use std::path::Path;

use acc_ident::model::Channel;
use acc_ident::runlog::{read_csv_from, RunLogError};
use acc_ident::{import, workflow, Model};
use acc_sim::scenario::{LawKind, Scenario};

/// A closed-loop `acc sim` run of `scenario` (under configs/) measured by a dynamometer
/// (5 N noise, 0.05 s window): the scenarios measure spindle power by default, these
/// tests replay a force channel.
fn dynamometer_run(scenario: &str) -> (Scenario, acc_sim::RunResult) {
    let mut sc =
        Scenario::load(acc_sim::run::configs_dir().join(scenario)).expect("scenario loads");
    sc.measurement = acc_sim::scenario::MeasurementSpec::Dynamometer {
        noise_n: 5.0,
        lowpass_hz: 0.0,
        window_s: 0.05,
    };
    let (res, _) = sc.run_law(LawKind::Ours).expect("simulates");
    (sc, res)
}

/// The simulator's tool-wear scenario (closed loop, dynamometer, `Ks` +1.5 %/cm³):
/// replayed with a wear-free nominal model, tool wear is named and its interval covers
/// the simulator's value; with the true model nothing is named.
#[test]
fn simulated_tool_wear_is_named_and_sized() {
    let (sc, res) = dynamometer_run("scenarios/tool_wear.toml");
    let log = import::from_sim_rows(&res.rows).expect("simulator log");
    let mut tool = sc.tool.clone();
    tool.wear = sc.wear;
    let mut truth = import::model_from_sim(&sc.machine, &tool, Channel::Force);
    truth.measurement.force_window_s = 0.05; // the scenario's dynamometer window
    let mut nominal = truth.clone();
    nominal.tool.wear.growth_per_cm3 = 0.0;
    let opts = workflow::Options::default();
    let a = workflow::analyse(&nominal, &log, &opts).expect("runs");
    assert_eq!(
        a.report.accepted,
        vec!["tool_wear".to_string()],
        "{}",
        a.report.conclusion
    );
    let param = |name: &str| {
        a.report
            .updated_params
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} reported"))
            .clone()
    };
    let (g, p, size) = (
        param("tool_wear.ks_growth_per_cm3"),
        param("tool_wear.volume_exponent"),
        param(workflow::WEAR_SIZE),
    );
    // The simulator's law is linear (p = 1): the fitted exponent must say so.
    assert!(
        (p.ci_low <= 1.0 && 1.0 <= p.ci_high) || (p.value - 1.0).abs() < 0.05,
        "exponent {} [{}, {}]",
        p.value,
        p.ci_low,
        p.ci_high
    );
    // The wear the data measure, the Ks growth by the end of the selection part, against
    // the simulator's: g·V_e with V_e the volume removed by then (from the log). The
    // interval reflects the measurement noise only; the simulator integrates the
    // engagement at 1 kHz while the log gives the depth at the end of each period, which
    // leaves a bias of about 1 %: accept the interval or 2 % of the true value.
    let n_sel = a.report.input.selection_rows;
    let ve_cm3: f64 = (1..n_sel)
        .map(|i| {
            log.radial_depth_mm[i] * log.axial_depth_mm[i] * log.feed_mm_min[i] / 60.0
                * (log.t_s[i] - log.t_s[i - 1])
        })
        .sum::<f64>()
        / 1000.0;
    let truth_g = sc.wear.growth_per_cm3;
    let truth_size = truth_g * ve_cm3;
    assert!(
        (size.ci_low <= truth_size && truth_size <= size.ci_high)
            || (size.value - truth_size).abs() < 0.02 * truth_size,
        "wear growth over the selection part {truth_size}: estimate {} [{}, {}] (g {} p {})",
        size.value,
        size.ci_low,
        size.ci_high,
        g.value,
        p.value
    );
    assert!(a.report.sealed.rms_reduction_pct > 80.0);
    let folded = a.updated.folded();
    let end = folded.tool.wear.factor(ve_cm3, 0.0) - 1.0;
    assert!(
        (end - truth_size).abs() < 0.03 * truth_size,
        "{end} vs {truth_size}"
    );
    let b = workflow::analyse(&truth, &log, &opts).expect("runs");
    assert!(b.report.accepted.is_empty(), "{}", b.report.conclusion);
}

/// `model.updated.toml` reads back unchanged, and its machine and tool sections load with
/// the simulator's own loaders.
#[test]
fn updated_model_round_trips_and_loads_in_the_simulator() {
    let case = acc_ident::synth::Case {
        duration_s: 120.0,
        ..Default::default()
    };
    let (model, log, _) = acc_ident::synth::generate(
        &case,
        &[acc_ident::synth::Hidden {
            kind: acc_ident::EffectKind::NoloadDrift,
            value: 150.0,
        }],
        4,
    );
    let a = workflow::analyse(&model, &log, &workflow::Options::default()).expect("runs");
    assert_eq!(a.report.accepted, vec!["noload_drift".to_string()]);
    let updated = a.updated.folded();
    let text = updated.to_toml().expect("serializes");
    let back = Model::parse(Path::new("model.updated.toml"), &text).expect("reads back");
    assert_eq!(back, updated);
    // The drift is a simulator machine key now, not an `[effects.*]` entry.
    assert!(back.machine.spindle.noload_drift.is_some());
    assert!(back.effects.noload_drift.is_none());
    assert!(text.contains("[machine.spindle.noload_drift]"), "{text}");
    let dir = tempfile::tempdir().expect("tempdir");
    let m = dir.path().join("machine.updated.toml");
    let t = dir.path().join("tool.updated.toml");
    std::fs::write(&m, updated.machine_toml().expect("machine")).expect("write");
    std::fs::write(&t, updated.tool_toml().expect("tool")).expect("write");
    let spec =
        acc_sim::config::MachineSpec::load(&m).expect("the simulator loads the machine file");
    assert_eq!(
        spec.spindle.noload_drift,
        updated.machine.spindle.noload_drift
    );
    acc_sim::config::ToolSpec::load(&t).expect("the simulator loads the tool file");
    updated
        .sim_specs(Path::new("model.updated.toml"))
        .expect("sections are sim-compatible");
}

#[test]
fn run_log_errors_name_line_and_column() {
    let p = Path::new("bad.csv");
    let good = "t_s,feed_mm_min,spindle_rpm,radial_depth_mm,axial_depth_mm,power_w\n";
    let mut text = good.to_string();
    for i in 0..12 {
        // Power varies (a constant measured channel is refused as dead); row 2 is 900.
        text.push_str(&format!(
            "{:.1},200,600,2,16,{}\n",
            i as f64 * 0.1 + 0.1,
            if i == 1 { 900 } else { 890 + i }
        ));
    }
    assert_eq!(read_csv_from(text.as_bytes(), p).expect("reads").len(), 12);
    let bad = text.replacen("0.2,200,600,2,16,900", "0.2,abc,600,2,16,900", 1);
    let e = read_csv_from(bad.as_bytes(), p).expect_err("bad cell");
    assert!(
        matches!(&e, RunLogError::BadValue { line: 3, col: 2, column, .. } if column == "feed_mm_min"),
        "{e}"
    );
    assert!(
        e.to_string().contains("line 3, column 2 (`feed_mm_min`)"),
        "{e}"
    );
    let neg = text.replacen("0.3,200,600,2,16,892", "0.3,200,600,-2,16,892", 1);
    let e = read_csv_from(neg.as_bytes(), p).expect_err("negative depth");
    assert!(e.to_string().contains("line 4, column 4"), "{e}");
    let missing = text.replace("spindle_rpm", "rpm");
    let e = read_csv_from(missing.as_bytes(), p).expect_err("missing column");
    assert!(
        e.to_string()
            .contains("missing required column `spindle_rpm`"),
        "{e}"
    );
    let no_channel = text.replace(",power_w", ",other");
    let e = read_csv_from(no_channel.as_bytes(), p).expect_err("no channel");
    assert!(e.to_string().contains("power_w"), "{e}");
}

#[test]
fn model_file_errors_name_file_key_and_range() {
    let case = acc_ident::synth::Case::default();
    let m = acc_ident::synth::nominal_model(&case);
    let text = m
        .to_toml()
        .expect("serializes")
        .replace("efficiency = 0.85", "efficiency = 1.5");
    let e = Model::parse(Path::new("m.toml"), &text).expect_err("out of range");
    assert_eq!(
        e.to_string(),
        "m.toml: key `machine.spindle.efficiency` = 1.5 is out of range: allowed 0.05 ..= 1"
    );
    let text = m
        .to_toml()
        .expect("serializes")
        .replace("[tool.wear]", "[tool.wear]\nbogus = 1");
    let e = Model::parse(Path::new("m.toml"), &text).expect_err("unknown key");
    assert!(e.to_string().contains("bogus"), "{e}");
}

/// `report.json` keeps its documented top-level and nested keys (schema version 1).
#[test]
fn report_json_has_the_stable_schema() {
    let case = acc_ident::synth::Case {
        duration_s: 120.0,
        ..Default::default()
    };
    let (model, log, _) = acc_ident::synth::generate(&case, &[], 5);
    let a = workflow::analyse(&model, &log, &workflow::Options::default()).expect("runs");
    let v: serde_json::Value =
        serde_json::from_str(&a.report.to_json().expect("serializes")).expect("parses");
    assert_eq!(v["schema_version"], 1);
    for key in [
        "input",
        "noise",
        "locate",
        "rounds",
        "accepted",
        "ambiguous",
        "updated_params",
        "sealed",
        "conclusion",
    ] {
        assert!(v.get(key).is_some(), "missing `{key}`");
    }
    for key in ["rms", "fit_pct", "bias", "segments"] {
        assert!(
            v["sealed"]["updated"].get(key).is_some(),
            "missing sealed.updated.{key}"
        );
    }
    let c = &v["rounds"][0]["candidates"][0];
    for key in [
        "effect",
        "applicable",
        "params",
        "heldout_gain_pct",
        "folds_improved",
        "heldout_chi2",
        "p_adjusted",
        "ci_excludes_null",
        "signature_gone",
        "passed",
    ] {
        assert!(c.get(key).is_some(), "missing candidate `{key}`");
    }
    assert!(a.report.to_markdown().contains("## Sealed final part"));
}

/// A slower feed drive and a longer override delay in the simulated machine than in the
/// model (closed loop, case III poles on the 2-3-4 mm workpiece): each is named first,
/// with the fitted extra time close to the difference. (A small second effect may follow:
/// the replay runs the chord between two rows' logged depths while the simulator
/// integrates the engagement at 1 kHz, and this dynamometer's noise is low enough to see
/// that.)
#[test]
fn simulated_feed_path_effects_are_named() {
    for (kind, extra) in [("feed_drive_lag", 0.3), ("override_dead_time", 0.3)] {
        let mut sc = Scenario::load(acc_sim::run::configs_dir().join("scenarios/paper_case3.toml"))
            .expect("scenario loads");
        let nominal_model = {
            let mut m = import::model_from_sim(&sc.machine, &sc.tool, Channel::Force);
            m.tool.wear = sc.wear;
            m.measurement.force_window_s = 0.05;
            m
        };
        // This test isolates the feed path: the production policy's overload protection
        // (feed hold at 2 Fr) would end the run when the slower path lets the force overshoot.
        sc.policy.overload_force_n = 1e5;
        if kind == "feed_drive_lag" {
            sc.machine.feed_drive.tau_s += extra;
        } else {
            sc.machine.override_path.delay_s += extra;
        }
        let (res, _) = sc.run_law(LawKind::Ours).expect("simulates");
        let log = import::from_sim_rows(&res.rows).expect("simulator log");
        // Under the default the whole library offers a second-order drive beside them: the
        // hidden effect is named first, or tied with it and reported "ambiguous" with the
        // experiment that separates them. The slower drive may be named as the
        // second-order drive itself: with the model's own lag of 8 ms, a second lag of
        // 0.3 s in series is the same drive (a first-order lag of 0.308 s to within the
        // 8 ms), so then its fitted second lag must be the hidden extra.
        let d =
            workflow::analyse(&nominal_model, &log, &workflow::Options::default()).expect("runs");
        let tied = d
            .report
            .ambiguous
            .iter()
            .any(|x| x.effects.iter().any(|e| e == kind));
        let same_drive = kind == "feed_drive_lag"
            && d.report.accepted.first().map(String::as_str) == Some("second_order_drive")
            && d.report.updated_params.iter().any(|p| {
                p.name == "second_order_drive.tau2_s" && (p.value - extra).abs() < 0.1 * extra
            });
        assert!(
            d.report.accepted.first() == Some(&kind.to_string()) || tied || same_drive,
            "{kind}: {}",
            d.report.conclusion
        );
        // Narrowed to the process, machine and spindle effects: named first, its value.
        let narrowed = workflow::Options {
            candidates: acc_ident::EffectKind::PROCESS_AND_MACHINE.to_vec(),
            ..workflow::Options::default()
        };
        let a = workflow::analyse(&nominal_model, &log, &narrowed).expect("runs");
        assert!(
            a.report.accepted.first() == Some(&kind.to_string()),
            "{kind}: {}",
            a.report.conclusion
        );
        let p = a
            .report
            .updated_params
            .iter()
            .find(|p| p.name.starts_with(kind))
            .expect("parameter reported");
        assert!(
            (p.value - extra).abs() < 0.1 * extra,
            "{kind}: fitted {} for {extra}",
            p.value
        );
    }
}

/// `--workpiece` on a simulator's log (`x_true_mm` in every row): the log places itself
/// on the workpiece — the replayed tool starts where the log's first period began (its
/// first true position less its true mean feed × the period, `RunLog::path_start_mm`),
/// which is where the simulator starts it (0), not a period of feed from there (the rule
/// for a production log's first read, applied to the simulator's first position, would put
/// it `x_true` of the first row ahead). With the true model (hidden-wear scenario,
/// dynamometer force) the residual is the sensor noise, as with the twin evaluation's start
/// at 0; a period off, entries and exits miss.
#[test]
fn a_simulator_log_on_the_workpiece_is_placed_by_its_true_position() {
    let (sc, res) = dynamometer_run("scenarios/hidden_wear.toml");
    let wp = acc_sim::run::configs_dir().join("workpieces/wear_cut_150.toml");
    let eng = acc_ident::engagement::PathEngagement::load(&wp, 16.0, 0.0).expect("workpiece");
    let log = acc_ident::runlog::from_records_with(&res.rows, Path::new("sim.csv"), Some(&eng))
        .expect("simulator log on the workpiece");
    let x_true0 = res.rows[0].x_true_mm.expect("plant truth");
    assert_eq!(log.x_mm.as_ref().map(|x| x[0]), Some(x_true0));
    let start = log.path_start_mm().expect("a start");
    assert!(start.abs() < 2e-3, "start {start} mm (the simulator's: 0)");
    let mut tool = sc.tool.clone();
    tool.wear = sc.wear;
    let mut truth = import::model_from_sim(&sc.machine, &tool, Channel::Force);
    truth.measurement.force_window_s = 0.05;
    let rms_from = |x0: f64, anchor: bool| {
        let opts = workflow::Options {
            workpiece: Some((eng.workpiece.clone(), x0)),
            anchor_to_log: anchor,
            ..workflow::Options::default()
        };
        let r = workflow::calibrated_residual(&truth, &log, &opts).expect("replay");
        (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
    };
    let (placed, at_zero, a_period_on) = (
        rms_from(0.0, true),
        rms_from(0.0, false),
        rms_from(x_true0, false),
    );
    println!(
        "true model: RMS {placed:.2} N placed by the log, {at_zero:.2} N from 0, {a_period_on:.2} N from {x_true0:.3} mm"
    );
    assert!(placed < 7.0, "placed: RMS {placed} N against 5 N noise");
    assert!(
        (placed - at_zero).abs() < 0.02 * at_zero,
        "{placed} vs {at_zero}"
    );
    assert!(
        a_period_on > 1.5 * placed,
        "a period on: RMS {a_period_on} N, placed {placed} N"
    );
}
