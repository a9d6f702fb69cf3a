//! The twin closes on production logs (issue "One loop, one log", item 3): `acc board-sim`
//! runs a machine whose tool wears fast (`configs/scenarios/hidden_wear.toml`: +6 % `Ks`
//! per cm³, an effect hidden in the machine and NOT in the model), `acc run` controls it
//! over a pty pair (`configs/runtime/board_sim_twin.toml`, 4x time), and `acc discrepancy
//! --workpiece` on `acc run`'s log — production columns only, no depth of cut — rebuilds the
//! engagement from the workpiece at the logged path position, names the wear and at least
//! halves the sealed-part RMS, once on the force channel (`force_n`, the loop's estimate
//! from spindle power) and once on the power channel (`power_w`, the board's register).
//!
//! One closed-loop run (about 23 s of wall time) is shared by the tests of this file.
//!
//! `--x0-mm -0.8`: the simulated machine starts its tool centre at the start of the
//! workpiece (workpiece coordinate 0) when `acc run` arms (`--wait-for-controller`), but a
//! row's `x_mm` already counts the feed of the period it opens, and the power sample the
//! row read was published by the board up to one period earlier: the logged position leads
//! the position of the measured period by about two periods of feed (0.5–1 mm at
//! 140–300 mm/min; measured on this scenario against board-sim's own log).

mod e2e_support;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use e2e_support::{
    acc_bin, interrupt_expect_clean_exit, read_log, root, spawn_board_sim_on, spawn_run,
};

const SCENARIO: &str = "configs/scenarios/hidden_wear.toml";
const WORKPIECE: &str = "configs/workpieces/wear_cut_150.toml";
const MODEL: &str = "configs/models/paper_vmc_production.toml";
const RUN_CONFIG: &str = "configs/runtime/board_sim_twin.toml";

/// `acc run`'s log of one closed-loop run on the hidden-wear machine (run once).
fn production_log() -> &'static Path {
    static LOG: OnceLock<PathBuf> = OnceLock::new();
    LOG.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("e2e_twin_production-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("log dir");
        let log = dir.join("run.csv");
        let start = Instant::now();
        let (mut board, pty) =
            spawn_board_sim_on(SCENARIO, &["--exit-when-done", "--linger-s", "0.5"]);
        let run = spawn_run(RUN_CONFIG, &pty, &log);
        assert!(
            board.wait_for("workpiece finished", Duration::from_secs(60)),
            "the workpiece was not finished within 60 s: {:?}",
            board.err_lines
        );
        interrupt_expect_clean_exit(run);
        let (bcode, _, berr) = board.finish(Duration::from_secs(10));
        assert_eq!(bcode, Some(0), "board-sim exit: {berr:?}");
        println!(
            "closed loop on the hidden-wear machine: {:.1} s wall",
            start.elapsed().as_secs_f64()
        );
        // A production log: path position and measurements, no engagement.
        let rows = read_log(&log);
        assert!(rows.len() > 700, "{} rows", rows.len());
        assert!(rows.iter().all(|r| r.radial_depth_mm.is_none()
            && r.axial_depth_mm.is_none()
            && r.x_true_mm.is_none()));
        assert!(rows.iter().all(|r| r.x_mm.is_some()));
        assert!(
            rows.last().and_then(|r| r.x_mm).is_some_and(|x| x > 180.0),
            "the path covers the 180 mm workpiece"
        );
        log
    })
}

/// Run `acc <args>` in the repository root: (exit code, stdout, stderr).
fn acc(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(acc_bin())
        .args(args)
        .current_dir(root())
        .output()
        .expect("run acc");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `acc discrepancy --workpiece` on the production log, channel `channel`: the report.
fn discrepancy(channel: &str) -> serde_json::Value {
    let log = production_log();
    let out = log.with_file_name(format!("disc-{channel}"));
    let start = Instant::now();
    let (m, o) = (log.display().to_string(), out.display().to_string());
    let (code, stdout, stderr) = acc(&[
        "discrepancy",
        "--measured",
        &m,
        "--model",
        MODEL,
        "--workpiece",
        WORKPIECE,
        "--x0-mm=-0.8",
        "--channel",
        channel,
        "--out",
        &o,
    ]);
    assert_eq!(code, Some(0), "stdout:\n{stdout}\nstderr:\n{stderr}");
    println!(
        "{channel}: {} ({:.1} s)",
        stdout.trim(),
        start.elapsed().as_secs_f64()
    );
    assert!(stderr.contains("engagement: from"), "{stderr}");
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    serde_json::from_str(&text).expect("report.json parses")
}

/// The report names tool wear and the updated model at least halves the sealed-part RMS.
fn assert_wear_found(report: &serde_json::Value, unit: &str) {
    let accepted = report["accepted"].as_array().expect("accepted list");
    assert!(
        accepted.iter().any(|e| e == "tool_wear"),
        "tool wear named: {accepted:?}; {}",
        report["conclusion"]
    );
    let sealed = &report["sealed"];
    let nominal = sealed["nominal"]["rms"].as_f64().expect("nominal rms");
    let updated = sealed["updated"]["rms"].as_f64().expect("updated rms");
    println!("sealed RMS {nominal:.1} -> {updated:.1} {unit}; accepted {accepted:?}");
    assert!(
        sealed["rows"].as_u64().is_some_and(|n| n > 100),
        "sealed part: {sealed}"
    );
    assert!(
        updated <= 0.5 * nominal,
        "sealed RMS {nominal} -> {updated} {unit}: not halved"
    );
}

#[test]
fn production_log_force_channel_names_the_hidden_wear() {
    let report = discrepancy("force");
    assert_eq!(report["input"]["channel"], "force");
    assert_wear_found(&report, "N");
}

#[test]
fn production_log_power_channel_names_the_hidden_wear() {
    let report = discrepancy("power");
    assert_eq!(report["input"]["channel"], "power");
    assert_wear_found(&report, "W");
}

#[test]
fn production_log_without_workpiece_says_what_is_missing() {
    let log = production_log();
    let rows = read_log(log).len();
    let out = log.with_file_name("disc-none");
    let (m, o) = (log.display().to_string(), out.display().to_string());
    let (code, stdout, stderr) = acc(&[
        "discrepancy",
        "--measured",
        &m,
        "--model",
        MODEL,
        "--out",
        &o,
    ]);
    assert_ne!(code, Some(0), "refused; stdout:\n{stdout}");
    assert!(!out.join("report.json").exists(), "no report written");
    for want in [
        m.as_str(),
        "line 2:",
        "columns 30 (`radial_depth_mm`) and 31 (`axial_depth_mm`) are empty",
        &format!("{rows} of {rows} data rows, lines 2..={}", rows + 1),
        "nothing can be compared",
        "--workpiece",
        "`x_mm`",
        "--x0-mm",
    ] {
        assert!(stderr.contains(want), "missing {want:?} in:\n{stderr}");
    }
    // --x0-mm alone is refused: it is an offset along the workpiece.
    let (code, _, stderr) = acc(&[
        "discrepancy",
        "--measured",
        &m,
        "--model",
        MODEL,
        "--out",
        &o,
        "--x0-mm",
        "5",
    ]);
    assert_ne!(code, Some(0));
    assert!(stderr.contains("--x0-mm 5 needs --workpiece"), "{stderr}");
}
