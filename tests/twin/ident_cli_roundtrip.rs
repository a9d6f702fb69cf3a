//! The issue-6 loop through the `acc` binary: a simulated tool-wear log → `acc discrepancy`
//! names tool wear and writes `model.updated.toml` → `acc sim --model` runs that model as
//! is, with the identified wear (and the wear-free nominal model runs without wear).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::process::Command;

use crate::e2e_support::{acc_bin, root};
use acc_runtime::record::{read_run_log, RunLogWriter, RunRecord};
use acc_sim::scenario::{LawKind, MeasurementSpec, Scenario};

/// Run `acc <args>` in the repository root; panic with its output unless it exits 0.
fn acc_ok(args: &[&str]) -> String {
    let out = Command::new(acc_bin())
        .args(args)
        .current_dir(root())
        .output()
        .expect("run acc");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "acc {args:?} exited {:?}\nstdout:\n{stdout}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Median Kc_hat of the valid cutting rows in the last fifth of the cut over that in the
/// first fifth (after the first fifth, to skip the estimator's start-up).
fn kc_growth(rows: &[RunRecord]) -> f64 {
    let cut: Vec<f64> = rows
        .iter()
        .filter(|r| r.force_valid && r.radial_depth_mm.is_some_and(|d| d > 0.0))
        .filter_map(|r| r.kc_hat)
        .collect();
    assert!(cut.len() > 100, "{} valid cutting rows", cut.len());
    let n = cut.len() / 5;
    let median = |s: &[f64]| {
        let mut v = s.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    median(&cut[cut.len() - n..]) / median(&cut[n..2 * n])
}

fn read_log(path: &Path) -> Vec<RunRecord> {
    read_run_log(File::open(path).expect("run log exists")).expect("run log parses")
}

#[test]
fn discrepancy_model_runs_in_acc_sim_with_its_wear() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = root().join("configs/scenarios/tool_wear.toml");
    let mut sc = Scenario::load(&scenario).expect("scenario loads");
    sc.measurement = MeasurementSpec::Dynamometer {
        noise_n: 5.0,
        lowpass_hz: 0.0,
        window_s: 0.05,
    };
    let measured = dir.path().join("measured.csv");
    let mut writer = RunLogWriter::new(BufWriter::new(File::create(&measured).expect("create")))
        .expect("log header");
    let mut law = sc.build_law(LawKind::Ours).expect("law");
    let truth = acc_sim::run(
        &sc,
        law.as_mut(),
        acc_sim::RunSetup {
            log: Some(&mut writer),
            ..acc_sim::RunSetup::default()
        },
    )
    .expect("simulates");
    drop(writer);
    let truth_growth = kc_growth(&truth.rows);
    assert!(
        truth_growth > 1.15,
        "the scenario wears: Kc_hat x{truth_growth}"
    );

    let disc = dir.path().join("disc");
    let (m, d) = (measured.display().to_string(), disc.display().to_string());
    acc_ok(&[
        "discrepancy",
        "--model",
        "configs/models/paper_vmc.toml",
        "--measured",
        &m,
        "--out",
        &d,
    ]);
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(disc.join("report.json")).expect("report.json"),
    )
    .expect("report.json parses");
    let accepted = report["accepted"].as_array().expect("accepted list");
    assert!(
        accepted.iter().any(|e| e == "tool_wear"),
        "report names tool wear: {accepted:?}"
    );

    // The updated model, as written, in `acc sim --model`: its wear replaces the scenario's.
    let updated = disc.join("model.updated.toml");
    let (u, s) = (
        updated.display().to_string(),
        scenario.display().to_string(),
    );
    let run_updated = dir.path().join("updated");
    let out = acc_ok(&[
        "sim",
        &s,
        "--model",
        &u,
        "--out",
        &run_updated.display().to_string(),
        "--no-plot",
    ]);
    assert!(out.contains("model.updated.toml"), "{out}");
    let growth = kc_growth(&read_log(&run_updated.join("run.csv")));

    // The wear-free nominal model: its wear (off) also replaces the scenario's [wear].
    let run_nominal = dir.path().join("nominal");
    acc_ok(&[
        "sim",
        &s,
        "--model",
        "configs/models/paper_vmc.toml",
        "--out",
        &run_nominal.display().to_string(),
        "--no-plot",
    ]);
    let nominal = kc_growth(&read_log(&run_nominal.join("run.csv")));
    println!("Kc_hat growth: true wear x{truth_growth:.3}, updated model x{growth:.3}, wear-free model x{nominal:.3}");
    assert!(
        (growth / truth_growth - 1.0).abs() < 0.1,
        "updated model Kc_hat x{growth}, true wear x{truth_growth}"
    );
    assert!(
        (nominal - 1.0).abs() < 0.05,
        "wear-free model Kc_hat x{nominal}"
    );
}
