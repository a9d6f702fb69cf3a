//! What-if on a recorded cut (`acc_sim::whatif`, `acc what-if`): the production loop with
//! a preset, closed loop on the twin whose engagement comes from a run log.
//!
//! Figures (interrupted-cut scenario, case III, recorded by `acc sim interrupted`): the
//! same preset replayed gives peak 985.4 vs 992.9 N, mean in cut 732.8 vs 739.4 N, cycle
//! time 46.3 vs 46.4 s; the period-by-period measured-force difference is 69 N RMS (the
//! ±1-step dither of a 10 % board runs at another phase; one step is ~100 N). Fr 640 N:
//! peak 884 N, mean 601 N, cycle 55.0 s.

use std::process::Command;
use std::sync::Arc;

use acc_runtime::record::{read_run_log, RunLogWriter, RunRecord};
use acc_sim::process::ForceLaw;
use acc_sim::run::configs_dir;
use acc_sim::whatif::{cut_metrics, force_difference_rms_n, run_what_if, CutGeometry, WhatIfError};
use acc_sim::{LawKind, Scenario};

fn interrupted() -> Scenario {
    Scenario::load(configs_dir().join("scenarios/interrupted.toml")).expect("scenario")
}

/// The recorded run, through the CSV run log and back (as `acc what-if` reads it).
fn recorded(sc: &Scenario) -> Vec<RunRecord> {
    let (r, _) = sc.run_law(LawKind::Ours).expect("run");
    let mut buf = Vec::new();
    {
        let mut w = RunLogWriter::new(&mut buf).expect("writer");
        for row in &r.rows {
            w.write(row).expect("row");
        }
    }
    read_run_log(buf.as_slice()).expect("read back")
}

fn profile(sc: &Scenario, rows: &[RunRecord]) -> CutGeometry {
    let law = ForceLaw::new(sc.tool.process);
    let p = acc_sim::whatif::profile_from_rows(std::path::Path::new("run.csv"), rows, &law)
        .expect("profile");
    CutGeometry::Logged(Arc::new(p))
}

#[test]
fn same_preset_reproduces_the_recorded_cut() {
    let sc = interrupted();
    let rows = recorded(&sc);
    let wi = run_what_if(&sc, &profile(&sc, &rows), sc.controller).expect("what-if");
    assert!(wi.finished);
    let (a, b) = (cut_metrics(&rows, true), cut_metrics(&wi.rows, true));
    let rel = |x: f64, y: f64| (y - x).abs() / x;
    assert!(
        rel(a.peak_force_n, b.peak_force_n) < 0.03,
        "peak {a:?} vs {b:?}"
    );
    assert!(
        rel(a.mean_force_cut_n, b.mean_force_cut_n) < 0.02,
        "mean {a:?} vs {b:?}"
    );
    assert!(
        (a.cycle_time_s - b.cycle_time_s).abs() <= 0.3,
        "cycle {a:?} vs {b:?}"
    );
    assert!(
        rel(a.rms_error_n, b.rms_error_n) < 0.15,
        "rms {a:?} vs {b:?}"
    );
    let d = force_difference_rms_n(&rows, &wi.rows);
    assert!(d < 100.0, "period-by-period force difference {d:.1} N");
    // The profile reproduces the plant: every engaged period of the recorded run has its
    // depth at its recorded position.
    let CutGeometry::Logged(p) = profile(&sc, &rows) else {
        unreachable!()
    };
    for r in rows.iter().filter(|r| r.radial_depth_mm.is_some()) {
        let at = p.at(r.x_true_mm.expect("x"));
        assert!((at.radial_mm - r.radial_depth_mm.expect("d")).abs() < 1e-9);
    }
}

#[test]
fn gentler_preset_lowers_the_force_and_takes_longer() {
    let sc = interrupted();
    let rows = recorded(&sc);
    let mut gentle = sc.controller;
    gentle.force_ref_n = 640.0;
    // The tool table sets each tool's Fr (800 N): the what-if lowers it there too (the same
    // entry control, a gentler limit).
    let mut alone = sc.clone();
    if let Some(t) = alone.tools.as_mut() {
        t.default.fr_n = 640.0;
        t.tools.values_mut().for_each(|l| l.fr_n = 640.0);
    }
    let wi = run_what_if(&alone, &profile(&sc, &rows), gentle).expect("what-if");
    assert!(wi.finished);
    let (a, b) = (cut_metrics(&rows, true), cut_metrics(&wi.rows, true));
    assert_eq!(b.force_ref_n, 640.0);
    assert!(
        b.peak_force_n < a.peak_force_n - 50.0,
        "peak {a:?} vs {b:?}"
    );
    assert!(
        b.mean_force_cut_n < a.mean_force_cut_n - 100.0,
        "mean {a:?} vs {b:?}"
    );
    assert!(
        b.cycle_time_s > a.cycle_time_s + 3.0,
        "cycle {a:?} vs {b:?}"
    );
    // Closed loop: the gentler run reaches the same places later, so it has more rows.
    assert!(wi.rows.len() > rows.len());
}

#[test]
fn a_log_without_plant_truth_names_the_column_and_row() {
    let sc = interrupted();
    let mut rows = recorded(&sc);
    rows[4].force_true_n = None;
    let law = ForceLaw::new(sc.tool.process);
    let e = acc_sim::whatif::profile_from_rows(std::path::Path::new("prod.csv"), &rows, &law)
        .expect_err("missing truth");
    assert!(
        matches!(
            e,
            WhatIfError::Missing {
                row: 5,
                column: "force_true_n",
                ..
            }
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("prod.csv") && msg.contains("CSV line 6") && msg.contains("--workpiece"),
        "{msg}"
    );
    rows[4].force_true_n = Some(1.0);
    rows[7].x_true_mm = Some(-5.0);
    let msg = acc_sim::whatif::profile_from_rows(std::path::Path::new("prod.csv"), &rows, &law)
        .expect_err("x backwards")
        .to_string();
    assert!(msg.contains("x_true_mm") && msg.contains("row 8"), "{msg}");
}

/// `acc what-if` end to end: a log written by `acc sim`, a gentler preset file; the table,
/// the what-if log and the overlay plot; a bad preset named with its key; and the
/// deprecated name `acc replay` doing the same as `acc what-if`.
#[test]
fn acc_what_if_cli() {
    let dir = tempfile::tempdir().expect("tmp");
    let root = crate::e2e_support::root();
    let acc = crate::e2e_support::acc_bin();
    let run = |args: &[&str]| {
        let o = Command::new(&acc)
            .args(args)
            .current_dir(&root)
            .output()
            .expect("acc");
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    // `acc <name> --log LOG --scenario interrupted --preset PRESET <extra>`.
    let what_if = |name: &str, log: &std::path::Path, preset: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            name,
            "--log",
            log.to_str().expect("utf8"),
            "--scenario",
            "interrupted",
            "--preset",
            preset.to_str().expect("utf8"),
        ];
        args.extend_from_slice(extra);
        run(&args)
    };
    let rec = dir.path().join("rec");
    let (ok, _, err) = run(&["sim", "interrupted", "--out", rec.to_str().expect("utf8")]);
    assert!(ok, "{err}");
    let log = rec.join("run.csv");
    let preset = std::fs::read_to_string(configs_dir().join("presets/case3.toml"))
        .expect("preset")
        .replace("force_ref_n = 800.0", "force_ref_n = 640.0");
    let gentle = dir.path().join("gentle.toml");
    std::fs::write(&gentle, preset).expect("write");
    let out = dir.path().join("wi");
    let (ok, stdout, err) = what_if(
        "what-if",
        &log,
        &gentle,
        &["--tools", "none", "--out", out.to_str().expect("utf8")],
    );
    assert!(ok, "{err}");
    assert!(
        stdout.contains("| peak force [N] |") && stdout.contains("| 800.0 | 640.0 |"),
        "{stdout}"
    );
    for f in ["whatif.csv", "whatif.md", "whatif.svg", "whatif.png"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let wi = read_run_log(std::fs::File::open(out.join("whatif.csv")).expect("csv")).expect("log");
    assert!(wi.iter().all(|r| r.force_ref_n == Some(640.0)));
    // A bad preset: the file and the key.
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&gentle)
            .expect("read")
            .replace("force_ref_n = 640.0", "force_ref_n = -1.0"),
    )
    .expect("write");
    let (ok, _, err) = what_if("what-if", &log, &bad, &[]);
    assert!(!ok);
    assert!(
        err.contains("bad.toml") && err.contains("force_ref_n"),
        "{err}"
    );
    // A production log (no plant truth) without --workpiece: the column and the way out.
    let text = std::fs::read_to_string(&log).expect("log");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let blank: Vec<usize> = (0..header.len())
        .filter(|&i| {
            [
                "x_true_mm",
                "radial_depth_mm",
                "axial_depth_mm",
                "force_true_n",
                "feed_true_mm_min",
            ]
            .contains(&header[i])
        })
        .collect();
    let mut prod = header.join(",") + "\n";
    for l in lines {
        let cells: Vec<&str> = l
            .split(',')
            .enumerate()
            .map(|(i, c)| if blank.contains(&i) { "" } else { c })
            .collect();
        prod.push_str(&cells.join(","));
        prod.push('\n');
    }
    let prod_log = dir.path().join("prod.csv");
    std::fs::write(&prod_log, prod).expect("write");
    let (ok, _, err) = what_if("what-if", &prod_log, &gentle, &[]);
    assert!(!ok);
    assert!(
        err.contains("prod.csv")
            && err.contains("x_true_mm")
            && err.contains("row 1")
            && err.contains("--workpiece"),
        "{err}"
    );
    // With the workpiece it runs, under the new name and the deprecated one alike.
    let with_workpiece = |name: &str| {
        let (ok, stdout, err) = what_if(
            name,
            &prod_log,
            &gentle,
            &["--workpiece", "configs/workpieces/interrupted.toml"],
        );
        assert!(ok, "{name}: {err}");
        assert!(stdout.contains("workpiece"), "{name}: {stdout}");
        stdout
    };
    assert_eq!(with_workpiece("what-if"), with_workpiece("replay"));
    // The help names the old name as deprecated, under either name.
    for name in ["what-if", "replay"] {
        let (ok, stdout, err) = run(&[name, "--help"]);
        assert!(ok, "{name}: {err}");
        assert!(
            stdout.contains("`acc replay`") && stdout.contains("deprecated"),
            "{name}: {stdout}"
        );
    }
}
