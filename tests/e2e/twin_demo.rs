//! The production-log demonstration of docs/twin-evaluation.md ("A production log at 10×")
//! in CI: `acc board-sim` runs the fast-wearing tool of `configs/scenarios/tool_wear.toml`
//! (+1.5 % `Ks` per cm³, hidden from the model), `acc run` controls it over a pty at 10×
//! time with the link timing of the demonstration (6 ms reply timeout, 7 ms budget), and
//! `acc discrepancy --model configs/models/paper_vmc_production.toml --workpiece …` (the
//! force channel: `acc run`'s estimate from the board's power register, a whole-period
//! mean) names the wear and at least halves the sealed RMS. The same machine without wear
//! is the production null: nothing is named.
//!
//! The part is `configs/workpieces/wear_cut_150.toml` (2 × 75 mm of 3 mm cut, about 7 cm³:
//! +11 % `Ks`), so each closed loop takes about 10 s of wall time. The board moves with the
//! controller's writes (`--pace controller`), so a loaded host slows the pair without
//! changing its log, and the test takes no lock. On a wall-paced board a write can race a
//! late board tick; the replay re-times those periods by the log's `board_feed_mm_min`
//! (docs/twin.md, "Logs from `acc board-sim` and `acc run`"), measured by hand at 10× in
//! docs/twin-production.md.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use crate::e2e_support::{acc_bin, interrupt_expect_clean_exit, load_tolerant_config, root, Proc};

const WORKPIECE: &str = "configs/workpieces/wear_cut_150.toml";
const MODEL: &str = "configs/models/paper_vmc_production.toml";

/// `tool_wear.toml` on the short part with wear growth `growth_per_cm3`, absolute paths.
fn scenario(dir: &Path, growth_per_cm3: f64) -> PathBuf {
    let c = root().join("configs");
    let text = std::fs::read_to_string(c.join("scenarios/tool_wear.toml")).expect("scenario");
    let text: Vec<String> = text
        .lines()
        .map(|l| match l.split_once(" = ") {
            Some((k @ ("machine" | "tool" | "controller"), v)) => {
                let rel = v.trim_matches('"').trim_start_matches("../");
                format!("{k} = {:?}", c.join(rel).to_string_lossy())
            }
            Some(("workpiece", _)) => {
                format!("workpiece = {:?}", root().join(WORKPIECE).to_string_lossy())
            }
            Some(("growth_per_cm3", _)) => format!("growth_per_cm3 = {growth_per_cm3}"),
            _ => l.to_string(),
        })
        .collect();
    let path = dir.join("scenario.toml");
    std::fs::write(&path, text.join("\n")).expect("write scenario");
    path
}

/// [`load_tolerant_config`] (absolute paths, the link and power held through a loaded
/// host's late replies) at 10× with the demonstration's link timing: `timeout_ms` 6,
/// `budget_ms` 7.
fn run_config(dir: &Path) -> PathBuf {
    let path = load_tolerant_config(dir, "");
    let text = std::fs::read_to_string(&path).expect("config");
    let text = text
        .replace("time_scale = 2.0", "time_scale = 10.0")
        .replace("timeout_ms = 40", "timeout_ms = 6")
        .replace("budget_ms = 45", "budget_ms = 7");
    assert!(text.contains("time_scale = 10.0") && text.contains("budget_ms = 7"));
    std::fs::write(&path, text).expect("write config");
    path
}

/// One closed loop at 10× on `scenario` in `dir`: `acc run`'s log.
fn closed_loop(dir: &Path, scenario: &Path) -> PathBuf {
    let sc = scenario.to_string_lossy();
    let mut board = Proc::spawn(
        &[
            "board-sim",
            "--scenario",
            &sc,
            "--time-scale",
            "10",
            "--baud",
            "115200",
            "--wait-for-controller",
            "--exit-when-done",
            "--linger-s",
            "0.5",
            "--pace",
            "controller",
        ],
        true,
    );
    let pty = board.first_line.clone().expect("board-sim prints the pty");
    let log = dir.join("run.csv");
    let config = run_config(dir);
    let run = crate::e2e_support::spawn_run(&config.to_string_lossy(), &pty, &log);
    assert!(
        board.wait_for("workpiece finished", Duration::from_secs(300)),
        "the workpiece was not finished within 300 s: {:?}",
        board.err_lines
    );
    interrupt_expect_clean_exit(run);
    let (code, _, err) = board.finish(Duration::from_secs(10));
    assert_eq!(code, Some(0), "board-sim exit: {err:?}");
    log
}

/// `acc discrepancy` on `log` against the production model, on its channel (`force_n`):
/// the report.
fn discrepancy(log: &Path) -> serde_json::Value {
    let out = log.with_file_name("disc");
    let (m, o) = (log.display().to_string(), out.display().to_string());
    let args = [
        "discrepancy",
        "--measured",
        &m,
        "--model",
        MODEL,
        "--workpiece",
        WORKPIECE,
        "--out",
        &o,
    ];
    let run = Command::new(acc_bin())
        // One tracing thread beside the binary's wall-paced loops (`e2e_support::acc_output`).
        .env("ACC_TRACE_THREADS", "1")
        .args(args)
        .current_dir(root())
        .output()
        .expect("run acc discrepancy");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    println!("{}: {}", log.display(), stdout.trim());
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    serde_json::from_str(&text).expect("report.json parses")
}

/// The named effects and the sealed RMS, nominal and updated.
fn verdict(report: &serde_json::Value) -> (Vec<String>, f64, f64) {
    let named = report["accepted"]
        .as_array()
        .expect("accepted")
        .iter()
        .filter_map(|e| e.as_str().map(String::from))
        .collect();
    let sealed = &report["sealed"];
    let rms = |k: &str| sealed[k]["rms"].as_f64().expect("sealed rms");
    (named, rms("nominal"), rms("updated"))
}

fn case_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("e2e_twin_demo-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("case dir");
    dir
}

#[test]
fn the_production_demonstration_names_the_hidden_wear_at_10x() {
    let dir = case_dir("wear");
    let log = closed_loop(&dir, &scenario(&dir, 0.015));
    let (named, nominal, updated) = verdict(&discrepancy(&log));
    println!("named {named:?}; sealed RMS {nominal:.2} -> {updated:.2} N");
    assert_eq!(named, ["tool_wear"], "log {}", log.display());
    assert!(
        updated <= 0.5 * nominal,
        "sealed RMS {nominal} -> {updated} N: not halved"
    );
}

#[test]
fn the_production_null_at_10x_names_nothing() {
    let dir = case_dir("null");
    let log = closed_loop(&dir, &scenario(&dir, 0.0));
    let (named, nominal, updated) = verdict(&discrepancy(&log));
    println!("named {named:?}; sealed RMS {nominal:.2} -> {updated:.2} N");
    assert!(
        named.is_empty(),
        "named {named:?} on a null; log {}",
        log.display()
    );
}
