//! The twin closes on production logs (issue "One loop, one log", item 3): `acc board-sim`
//! runs a machine whose tool wears fast (`configs/scenarios/hidden_wear.toml`: +6 % `Ks`
//! per cm³, an effect hidden in the machine and NOT in the model), `acc run` controls it
//! over a pty pair (`configs/runtime/board_sim_fast.toml`: case III, 4x time), and `acc discrepancy
//! --workpiece` on `acc run`'s log — production columns only, no depth of cut — rebuilds the
//! engagement from the workpiece at the logged path position, names the wear and at least
//! halves the sealed-part RMS, once on the force channel (`force_n`, the loop's estimate
//! from spindle power) and once on the power channel (`power_w`, the board's register).
//!
//! One closed-loop run (about 23 s of wall time) is shared by the tests of this file.
//!
//! No `--x0-mm`: board-sim holds its machine with the tool centre at the workpiece's start
//! until `acc run` arms, so `acc run`'s first read sees it there (`--x0-mm` 0, the default),
//! and the replay's tool starts a period of the first row's feed before it
//! (`RunLog::path_start_mm`), so that its first period — standing for the held sample 0 —
//! ends there. From then on every row holds the board's sample it read (`seq_repeat` /
//! `seq_skip:<n>` place it), with the override that drove it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use crate::e2e_support::{
    acc_bin, interrupt_expect_clean_exit, load_tolerant_config, read_log, root, spawn_board_sim_on,
    spawn_run,
};

const SCENARIO: &str = "configs/scenarios/hidden_wear.toml";
const WORKPIECE: &str = "configs/workpieces/wear_cut_150.toml";
const MODEL: &str = "configs/models/paper_vmc_production.toml";
const RUN_CONFIG: &str = "configs/runtime/board_sim_fast.toml";

/// `acc run`'s log of one closed-loop run on the hidden-wear machine (run once).
fn production_log() -> &'static Path {
    static LOG: OnceLock<PathBuf> = OnceLock::new();
    LOG.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("e2e_twin_production-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("log dir");
        let log = dir.join("run.csv");
        let start = Instant::now();
        closed_loop(SCENARIO, RUN_CONFIG, &log);
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

/// `acc board-sim` on `scenario` until its workpiece is finished, `acc run` (the
/// twin's runtime config) controlling it over a pty and logging to `log`.
///
/// One closed loop at a time, and nothing CPU-heavy of this file beside it ([`machine`]).
fn closed_loop(scenario: &str, run_config: &str, log: &Path) {
    let _turn = machine();
    let (mut board, pty) = spawn_board_sim_on(
        scenario,
        &[
            "--exit-when-done",
            "--linger-s",
            "0.5",
            "--pace",
            "controller",
        ],
    );
    let run = spawn_run(run_config, &pty, log);
    assert!(
        board.wait_for("workpiece finished", Duration::from_secs(300)),
        "the workpiece was not finished within 300 s: {:?}",
        board.err_lines
    );
    interrupt_expect_clean_exit(run);
    let (bcode, _, berr) = board.finish(Duration::from_secs(10));
    assert_eq!(bcode, Some(0), "board-sim exit: {berr:?}");
}

/// The test machine for this file's heavy steps: a closed loop is two processes on their
/// own clocks at 4x, and with both cores busy (an `acc discrepancy` of another test beside
/// it) ticks come late — and a write delayed past the board's tick leaves no mark in the
/// log. Closed loops and analyses take turns.
fn machine() -> std::sync::MutexGuard<'static, ()> {
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Root mean square of a residual.
fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
}

/// The `q` quantile of |r| (1 = the largest).
fn quantile_abs(r: &[f64], q: f64) -> f64 {
    let mut a: Vec<f64> = r.iter().map(|x| x.abs()).collect();
    a.sort_by(f64::total_cmp);
    a[((a.len() - 1) as f64 * q).round() as usize]
}

/// Each channel with the σ of its register rounding and its unit: whole watts, and the
/// force those watts make (the estimate's step, read off the log: the smallest nonzero
/// change of `force_n`).
fn rounding(runlog: &acc_ident::RunLog) -> [(acc_ident::model::Channel, f64, &'static str); 2] {
    use acc_ident::model::Channel;
    let force = runlog.force_n.clone().expect("force column");
    let step = force
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-6)
        .fold(f64::INFINITY, f64::min);
    [
        (Channel::Power, 1.0 / 12f64.sqrt(), "W"),
        (Channel::Force, step / 12f64.sqrt(), "N"),
    ]
}

/// Run `acc <args>` in the repository root: (exit code, stdout, stderr).
fn acc(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(acc_bin())
        // One tracing thread beside the binary's wall-paced loops (`e2e_support::acc_output`).
        .env("ACC_TRACE_THREADS", "1")
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
    discrepancy_with(channel, &[])
}

/// [`discrepancy`] with `extra` flags.
fn discrepancy_with(channel: &str, extra: &[&str]) -> serde_json::Value {
    let log = production_log();
    let out = log.with_file_name(format!("disc-{channel}{}", extra.join("")));
    let _turn = machine();
    let start = Instant::now();
    let (m, o) = (log.display().to_string(), out.display().to_string());
    let mut args = vec![
        "discrepancy",
        "--measured",
        &m,
        "--model",
        MODEL,
        "--workpiece",
        WORKPIECE,
        "--channel",
        channel,
        "--out",
        &o,
    ];
    args.extend_from_slice(extra);
    let (code, stdout, stderr) = acc(&args);
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
/// Without `--x0-mm` the start was searched and kept: board-sim's first read sees the
/// held machine at the workpiece's start, exactly where `--x0-mm` 0 puts it.
fn assert_wear_found(report: &serde_json::Value, unit: &str) {
    let start = &report["path_shift"];
    println!("path start: {start}");
    assert_eq!(start["adopted"], false, "{start}");
    assert!(
        start["shift_mm"].as_f64().is_some_and(|s| s.abs() < 0.05),
        "{start}"
    );
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

/// The dynamometer's model file (`paper_vmc.toml`, force averaged over the last 0.05 s) on
/// the production log: `acc discrepancy` compares `acc run`'s force over the power's
/// window, says so, and finds what the production model finds.
#[test]
fn a_dynamometer_model_is_compared_over_the_power_window_on_a_production_log() {
    let log = production_log();
    let out = log.with_file_name("disc-dynamometer-model");
    let (m, o) = (log.display().to_string(), out.display().to_string());
    let (code, stdout, stderr) = {
        let _turn = machine();
        acc(&[
            "discrepancy",
            "--measured",
            &m,
            "--model",
            "configs/models/paper_vmc.toml",
            "--workpiece",
            WORKPIECE,
            "--channel",
            "force",
            "--out",
            &o,
        ])
    };
    assert_eq!(code, Some(0), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(
        stderr.contains("compared over the power's window, 0 s")
            && stderr.contains("force_window_s = 0.05 s"),
        "{stderr}"
    );
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    let dynamometer: serde_json::Value = serde_json::from_str(&text).expect("report.json");
    let production = discrepancy("force");
    assert_eq!(dynamometer["accepted"], production["accepted"]);
    assert_eq!(dynamometer["sealed"], production["sealed"]);
    assert_wear_found(&dynamometer, "N");
}

#[test]
fn production_log_power_channel_names_the_hidden_wear() {
    let report = discrepancy("power");
    assert_eq!(report["input"]["channel"], "power");
    assert_wear_found(&report, "W");
}

/// The default naming rules (the whole library, the effect-to-noise floor, and on this
/// exact replay the strict rules: withheld when structure remains, when the sealed part
/// is not predicted, or when wear cannot be told from a drift in cutting time) hold on a
/// production log: it replays to the register rounding, so the wear is named on the
/// power channel with nothing withheld, and the explanation says why it is not a drift in
/// time. A flag that would loosen them is refused.
#[test]
fn production_log_under_the_default_rules_names_the_hidden_wear_not_a_drift() {
    let report = discrepancy("power");
    assert_wear_found(&report, "W");
    assert!(
        report["withheld"].as_array().is_some_and(|w| w.is_empty()),
        "{}",
        report["withheld"]
    );
    let explanation = report["explanation"].as_array().expect("explanation");
    assert!(
        explanation.iter().any(|e| e
            .as_str()
            .is_some_and(|e| e.contains("so the growth is not a drift linear in cutting time"))),
        "{explanation:?}"
    );
    let (code, _, stderr) = acc(&[
        "discrepancy",
        "--measured",
        "x.csv",
        "--out",
        "o",
        "--min-enr",
        "0",
    ]);
    assert_ne!(code, Some(0));
    assert!(stderr.contains("--min-enr 0: allowed 1 ..= 10"), "{stderr}");
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
        "columns 35 (`radial_depth_mm`) and 36 (`axial_depth_mm`) are empty",
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

/// Issue 13, item 1 on the production path: with the machine's true model (the nominal
/// model plus the scenario's wear), `acc run`'s log — two processes on their own clocks
/// over a pty — replays to the rounding of the board's registers on both channels: whole
/// watts (σ 0.29 W), and the loop's force estimate from them (σ ≈ 0.5 N). Before board-sim
/// ticked half a period after the controller, a write now and then raced the board's tick:
/// the override read back was not the one that drove the sample, the replayed position
/// went 0.033 mm off for the rest of the log, and a null log replayed with 3.6 W RMS. A
/// late tick or a late read still happens on a loaded machine: `acc run` flags where its
/// read sits in the board's `SAMPLE_SEQ` (`seq_repeat`, `seq_skip:<n>`) and the replay runs
/// on the board's samples.
#[test]
fn production_log_replays_to_the_register_rounding_with_the_true_model() {
    let log = production_log();
    let _turn = machine();
    let sc = acc_sim::Scenario::load(root().join(SCENARIO)).expect("scenario");
    let nominal = acc_ident::Model::load(&root().join(MODEL)).expect("model");
    let mut truth = nominal.clone();
    truth.tool.wear = sc.wear;
    let eng = acc_ident::engagement::PathEngagement::load(
        &root().join(WORKPIECE),
        nominal.tool.diameter_mm,
        0.0,
    )
    .expect("workpiece");
    let runlog = acc_ident::runlog::read_csv_with(log, Some(&eng)).expect("run log");
    for (channel, sigma, unit) in rounding(&runlog) {
        let mut m = truth.clone();
        m.measurement.channel = channel;
        let r =
            acc_ident::twin::replay_residual_on_path(&m, &runlog, &eng.workpiece).expect("replay");
        let mut n = nominal.clone();
        n.measurement.channel = channel;
        let r0 =
            acc_ident::twin::replay_residual_on_path(&n, &runlog, &eng.workpiece).expect("replay");
        let p90 = quantile_abs(&r, 0.9);
        println!(
            "{channel:?}: true model RMS {:.3} {unit}, 90 % of rows within {p90:.3} {unit}, max {:.2} {unit}; rounding σ {sigma:.3} {unit}; nominal model RMS {:.1} {unit}",
            rms(&r),
            quantile_abs(&r, 1.0),
            rms(&r0)
        );
        // Rounding alone puts 90 % of the rows within 0.45 step = 1.56σ. The 90 % bound,
        // not the RMS, so that a write delayed past the board's tick by a stall of the
        // test machine (the override then lands a period late, unseen by `SAMPLE_SEQ`,
        // and the cut's later entries and exits are a few rows off) does not fail it.
        assert!(
            p90 < 2.0 * sigma,
            "{channel:?}: 90 % of rows within {p90} {unit} against σ {sigma} (RMS {}, max {})",
            rms(&r),
            quantile_abs(&r, 1.0)
        );
        assert!(
            rms(&r0) > 20.0 * sigma,
            "the wear is visible: nominal RMS {}",
            rms(&r0)
        );
    }
}

/// The same on a null log of another scenario and force model: `paper_case3_tooth.toml`
/// (tooth-level force, the 2-3-4 mm steps, no wear) under board-sim, `acc run` in the
/// loop; the model is the scenario's own (`twin::model_for_scenario`), so the power
/// register must replay to its rounding. (The force channel here is `acc run`'s estimate,
/// which the scenario's dynamometer model does not describe; the hidden-wear test above
/// covers it.) Runs after the shared closed loop, not beside it.
#[test]
fn a_tooth_model_null_log_replays_to_the_register_rounding() {
    use acc_ident::model::Channel;
    let _ = production_log();
    let scenario = "configs/scenarios/paper_case3_tooth.toml";
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("e2e_twin_tooth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("log dir");
    let log = dir.join("run.csv");
    closed_loop(scenario, RUN_CONFIG, &log);
    let _turn = machine();
    let sc = acc_sim::Scenario::load(root().join(scenario)).expect("scenario");
    let model = acc_ident::twin::model_for_scenario(&sc, Channel::Power);
    let eng = acc_ident::engagement::PathEngagement::load(
        &root().join(scenario),
        model.tool.diameter_mm,
        0.0,
    )
    .expect("workpiece");
    let runlog = acc_ident::runlog::read_csv_with(&log, Some(&eng)).expect("run log");
    let r =
        acc_ident::twin::replay_residual_on_path(&model, &runlog, &eng.workpiece).expect("replay");
    let (p90, rms) = (quantile_abs(&r, 0.9), rms(&r));
    let sigma = 1.0 / 12f64.sqrt();
    println!(
        "tooth model, null: power RMS {rms:.3} W, 90 % within {p90:.3} W, max {:.2} W; σ {sigma:.3} W ({} rows)",
        quantile_abs(&r, 1.0),
        r.len()
    );
    assert!(
        p90 < 2.0 * sigma,
        "90 % within {p90} W against σ {sigma} (RMS {rms})"
    );
}

/// The random cases' runtime config: [`load_tolerant_config`] (2x time, a 40 ms reply
/// timeout, the link and power held) with the breakage watch off. A late reply on a loaded
/// host at 4x (15 ms timeout) lets the controller's next write land before the machine
/// took the period of the last one, so that period runs on the next override — nothing in
/// the log says so, and the replay is then off by tens of watts at every edge (CI once:
/// 11 W RMS on a 662-row case that replays to 0.29 W here); the tolerant timing leaves
/// the machine 40 ms to take each command. The breakage watch: a random part can end in a
/// fast exit (a ramp running out at 1.29 mm left at 150 %: 781 → 689 → 540 → 387 → 274
/// N); when a late board tick makes one read find a sample again and the next skip one,
/// the watch sees the fall one sample shorter than it was and holds the feed as for a
/// broken tool (`breakage:drop`), so the part is never finished — the watch's trade-off
/// between a missed sample and a tool broken mid-window, not the replay this test is about.
fn random_case_run_config(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join(RUN_CONFIG)).expect("run config");
    assert!(
        !text.contains("[watch]"),
        "{RUN_CONFIG} has no [watch] table"
    );
    load_tolerant_config(dir, "[watch]\nbreakage = false\n")
}

/// One random production-path case: seed, force model, wear, programmed feed and workpiece
/// (an air lead-in, then cuts, ramps and air gaps).
#[derive(Debug, Clone)]
struct RandomCase {
    seed: u64,
    tooth: bool,
    wear_per_cm3: f64,
    /// Whole mm/min: the board's `PROGRAMMED_FEED` register (u16) carries no fraction, so
    /// a fractional F-word replays up to 0.5 mm/min off (measured: F175.4 → 2.3 W RMS).
    programmed_feed_mm_min: f64,
    lead_in_mm: f64,
    /// (length mm, depth at the start mm, depth at the end mm, air gap after it mm).
    cuts: Vec<(f64, f64, f64, f64)>,
}

impl RandomCase {
    /// The workpiece file's text.
    fn workpiece_toml(&self) -> String {
        let mut s = format!(
            "name = \"random production-path workpiece\"\naxial_depth_mm = 16.0\n\n[[segment]]\nkind = \"air\"\nlength_mm = {:.3}\n",
            self.lead_in_mm
        );
        for &(len, d0, d1, gap) in &self.cuts {
            if (d0 - d1).abs() < 1e-9 {
                s += &format!(
                    "\n[[segment]]\nkind = \"cut\"\nlength_mm = {len:.3}\ndepth_mm = {d0:.3}\n"
                );
            } else {
                s += &format!(
                    "\n[[segment]]\nkind = \"ramp\"\nlength_mm = {len:.3}\nfrom_mm = {d0:.3}\nto_mm = {d1:.3}\n"
                );
            }
            s += &format!(
                "\n[[segment]]\nkind = \"air\"\nlength_mm = {:.3}\n",
                gap.max(5.0)
            );
        }
        s
    }

    /// The scenario file's text (hidden_wear.toml's machine, tool and preset, absolute
    /// paths; `workpiece.toml` beside it).
    fn scenario_toml(&self) -> String {
        let c = root().join("configs");
        format!(
            "name = \"random production-path case\"\nmachine = \"{}\"\ntool = \"{}\"\nworkpiece = \"workpiece.toml\"\ncontroller = \"{}\"\nseed = {}\nprogrammed_feed_mm_min = {:.1}\nmax_time_s = 300.0\nforce_model = \"{}\"\n\n[wear]\ninitial_factor = 1.0\ngrowth_per_cm3 = {}\nvolume_exponent = 1.0\ngrowth_per_min = 0.0\n\n[measurement]\nkind = \"dynamometer\"\nnoise_n = 5.0\nwindow_s = 0.05\n",
            c.join("machines/paper_vmc.toml").display(),
            c.join("machines/tools/hss_endmill_16_4f.toml").display(),
            c.join("presets/case3.toml").display(),
            self.seed,
            self.programmed_feed_mm_min,
            if self.tooth { "tooth" } else { "mean" },
            self.wear_per_cm3,
        )
    }
}

fn random_case() -> impl proptest::strategy::Strategy<Value = RandomCase> {
    use proptest::prelude::*;
    let cut = (
        20.0..50.0f64,
        1.0..4.0f64,
        1.0..4.0f64,
        any::<bool>(),
        5.0..12.0f64,
    )
        .prop_map(|(len, d0, d1, ramp, gap)| (len, d0, if ramp { d1 } else { d0 }, gap));
    (
        any::<u64>(),
        any::<bool>(),
        prop_oneof![Just(0.0), 0.01..0.06f64],
        (150u32..250).prop_map(f64::from),
        10.0..20.0f64,
        proptest::collection::vec(cut, 1..=3),
    )
        .prop_map(|(seed, tooth, wear, feed, lead_in_mm, cuts)| RandomCase {
            seed: seed % 1_000_000,
            tooth,
            wear_per_cm3: wear,
            programmed_feed_mm_min: feed,
            lead_in_mm,
            cuts,
        })
}

/// Item 1 on the production path as a property: random workpieces (cuts, ramps, air gaps),
/// seeds, programmed feeds, tool wear and both force models (mean and tooth-level), each
/// run by `acc board-sim` with `acc run` in the loop over a pty at 4x time; with the
/// machine's true model (the production model plus the case's wear and force model) `acc
/// run`'s log replays to the rounding of the board's registers on both channels (90 % of
/// the rows within 2σ of whole watts, and of the force those watts make). Three cases per
/// run (each about 10-20 s of wall time), one after the other so the two processes of one
/// case have the machine to themselves; no shrinking (a failing case is printed whole).
#[test]
fn random_production_logs_replay_to_the_register_rounding() {
    use proptest::test_runner::{Config, TestRunner};
    let _ = production_log();
    let nominal = acc_ident::Model::load(&root().join(MODEL)).expect("model");
    let base = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("e2e_twin_random-{}", std::process::id()));
    let mut runner = TestRunner::new(Config {
        cases: 3,
        max_shrink_iters: 0,
        failure_persistence: None,
        ..Config::default()
    });
    let counter = std::sync::atomic::AtomicUsize::new(0);
    let result = runner.run(&random_case(), |case| {
        let k = 1 + counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        check_case(&base.join(format!("case{k}")), &nominal, &case)
    });
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// One random case: run it in the closed loop in `dir` and replay its log under the true
/// model on both channels.
fn check_case(
    dir: &Path,
    nominal: &acc_ident::Model,
    case: &RandomCase,
) -> Result<(), proptest::test_runner::TestCaseError> {
    use acc_ident::model::PlantForceModel;
    use proptest::test_runner::TestCaseError;
    std::fs::create_dir_all(dir).expect("case dir");
    std::fs::write(dir.join("workpiece.toml"), case.workpiece_toml()).expect("workpiece");
    let scenario = dir.join("scenario.toml");
    std::fs::write(&scenario, case.scenario_toml()).expect("scenario");
    let log = dir.join("run.csv");
    let start = Instant::now();
    let run_config = random_case_run_config(dir);
    closed_loop(
        &scenario.to_string_lossy(),
        &run_config.to_string_lossy(),
        &log,
    );
    let _turn = machine();
    let mut truth = nominal.clone();
    truth.tool.wear = acc_sim::Scenario::load(&scenario).expect("scenario").wear;
    if case.tooth {
        truth.measurement.force_model = PlantForceModel::Tooth;
    }
    let eng = acc_ident::engagement::PathEngagement::load(
        &dir.join("workpiece.toml"),
        truth.tool.diameter_mm,
        0.0,
    )
    .expect("workpiece");
    let runlog = acc_ident::runlog::read_csv_with(&log, Some(&eng)).expect("run log");
    for (channel, sigma, unit) in rounding(&runlog) {
        let mut m = truth.clone();
        m.measurement.channel = channel;
        let r = acc_ident::twin::replay_residual_on_path(&m, &runlog, &eng.workpiece)
            .map_err(|e| TestCaseError::fail(format!("replay: {e}")))?;
        let p90 = quantile_abs(&r, 0.9);
        println!(
            "{} ({:.0} s wall, {} rows, {} model, wear {:.3}/cm³, {:.0} mm/min, {} cuts) {channel:?}: RMS {:.3} {unit}, 90 % within {p90:.3} {unit}, max {:.2} {unit}; σ {sigma:.3} {unit}",
            dir.display(),
                start.elapsed().as_secs_f64(),
            r.len(),
            if case.tooth { "tooth" } else { "mean" },
            case.wear_per_cm3,
            case.programmed_feed_mm_min,
            case.cuts.len(),
            rms(&r),
            quantile_abs(&r, 1.0),
        );
        proptest::prop_assert!(
            p90 < 2.0 * sigma,
            "{channel:?}: 90 % of rows within {p90} {unit} against σ {sigma} (RMS {}); case {case:?}, log {}; the log's flags: {}",
            rms(&r),
            log.display(),
            flag_counts(&log)
        );
    }
    Ok(())
}

/// The run log's `flags` column counted (`late` ×3, `link:timeout;fault` ×1, …): what a
/// failing case's run went through.
fn flag_counts(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let mut lines = text.lines();
    let col = lines
        .next()
        .and_then(|h| h.split(',').position(|c| c == "flags"));
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    for l in lines {
        if let Some(f) = col
            .and_then(|c| l.split(',').nth(c))
            .filter(|f| !f.is_empty())
        {
            *counts.entry(f.to_string()).or_default() += 1;
        }
    }
    let list: Vec<String> = counts.iter().map(|(f, n)| format!("{f} ×{n}")).collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join(", ")
    }
}

/// A case the property test drew in CI (power 11 W RMS off on `acc run`'s log), kept as a
/// fixed regression case.
#[test]
fn a_drawn_case_with_three_cuts_replays_to_the_register_rounding() {
    let nominal = acc_ident::Model::load(&root().join(MODEL)).expect("model");
    let case = RandomCase {
        seed: 920844,
        tooth: false,
        wear_per_cm3: 0.039488568115826815,
        programmed_feed_mm_min: 167.0,
        lead_in_mm: 13.905962445642759,
        cuts: vec![
            (
                43.61230016926614,
                3.8476068097715594,
                2.596692718664336,
                8.123971244491074,
            ),
            (
                33.304415177023216,
                3.4107851318062874,
                2.4038467789745757,
                10.951860353755285,
            ),
            (
                34.02189043881391,
                3.1672376041173735,
                3.1672376041173735,
                8.939736993160347,
            ),
        ],
    };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("e2e_twin_drawn-{}", std::process::id()));
    if let Err(e) = check_case(&dir, &nominal, &case) {
        panic!("{e}");
    }
}
