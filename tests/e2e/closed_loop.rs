//! End to end over a real pty pair: `acc run` (production code: config, serial port, RTU
//! client, threaded runtime, fault policy, controller, spindle-power force source) against
//! `acc board-sim` (RtuServer + BoardLogic + the simulated machine) on the paper's 2-3-4 mm
//! workpiece, case III, in closed loop. The machine moves with the controller's writes
//! (`--pace controller`); `acc run` runs `board_sim_fast.toml` made tolerant of a loaded host
//! (2x time, T = 0.1 s of machine time every 50 ms, late replies held:
//! `crate::e2e_support::load_tolerant_config`), about 31 s of wall time for the 62 s cut on an idle
//! host. The simulator's settled-force criterion is judged on the board-sim's machine-side
//! log with the simulator's own summary.

use std::time::Duration;

use crate::e2e_support::{
    assert_faults_never_raise, field, interrupt_expect_clean_exit, read_log, root, spawn_board_sim,
    spawn_run,
};
use acc_sim::{summarize, RunResult, Scenario};

#[test]
fn closed_loop_over_a_pty_meets_the_settled_force_criterion() {
    let dir = tempfile::tempdir().expect("temp dir");
    let sim_log = dir.path().join("sim.csv");
    let run_log = dir.path().join("run.csv");
    let scenario = root().join("configs/scenarios/paper_case3.toml");
    let sim_log_s = sim_log.to_string_lossy().to_string();
    let (mut board, pty) = spawn_board_sim(&["--log", &sim_log_s, "--pace", "controller"]);
    let config = crate::e2e_support::load_tolerant_config(dir.path(), "");
    let run = spawn_run(&config.to_string_lossy(), &pty, &run_log);
    // The machine advances with the controller's writes (slower on a loaded host):
    // the deadline only guards a hang.
    assert!(
        board.wait_for("workpiece finished", Duration::from_secs(300)),
        "the workpiece was not finished within 300 s: {:?}",
        board.err_lines
    );
    let (out, _) = interrupt_expect_clean_exit(run);
    board.sigint();
    let (bcode, _, berr) = board.finish(Duration::from_secs(10));
    assert_eq!(bcode, Some(0), "board-sim exit: {berr:?}");

    // The controller's log: complete to the last period, ACC released at the end.
    let rows = read_log(&run_log);
    let periods: usize = field(&out, "periods")
        .and_then(|v| v.parse().ok())
        .expect("summary line `periods: N`");
    assert_eq!(rows.len(), periods, "one run-log row per period");
    assert!(
        out.contains("ACC_REQUEST cleared, the operator has the override"),
        "{out}"
    );
    assert!(
        berr.iter()
            .any(|l| l.contains("final ACC_REQUEST=0 ACC_ACTIVE=0")),
        "the board saw ACC_REQUEST cleared: {berr:?}"
    );
    // The adaptive PI drove: of the periods the law was stepped (a late reply holds the
    // override without a step), nine in ten in `adaptive_pi`, and most periods stepped.
    let stepped = rows.iter().filter(|r| !r.mode.is_empty()).count();
    let adaptive = rows.iter().filter(|r| r.mode == "adaptive_pi").count();
    assert!(
        adaptive > stepped * 9 / 10 && stepped > rows.len() / 2,
        "{adaptive} adaptive_pi of {stepped} stepped periods, {} rows",
        rows.len()
    );
    assert_faults_never_raise(&rows);

    // The machine's log, judged like `acc sim`.
    let sc = Scenario::load(&scenario).expect("scenario");
    let summary = crate::e2e_support::machine_summary(&sim_log, &sc, "acc run over a pty");
    let fr = sc.controller.force_ref_n;
    let mut judged = 0;
    for seg in summary.segments.iter().filter(|s| s.reaches_ref) {
        println!(
            "{}: mean {:.1} N over {} settled periods, osc {:.1} N, override {:.0} %",
            seg.label,
            seg.mean_force_n,
            seg.settled_periods,
            seg.osc_amplitude_n,
            seg.mean_override_pct
        );
        assert!(
            (seg.mean_force_n - fr).abs() <= 0.05 * fr,
            "{}: settled mean force {:.1} N not within ±5 % of {fr} N",
            seg.label,
            seg.mean_force_n
        );
        assert!(
            seg.settled_periods >= 20,
            "{}: too short to judge",
            seg.label
        );
        judged += 1;
    }
    assert_eq!(
        judged, 3,
        "the 2, 3 and 4 mm segments reach Fr: {summary:?}"
    );
    // air cuts run at the maximum override
    let air = summary
        .segments
        .iter()
        .find(|s| !s.is_cut)
        .expect("air segment");
    assert!(air.frac_at_max > 0.5, "air cut at 150 %: {air:?}");

    // One loop, one log: `acc sim` on the same scenario writes a log with the same header as
    // `acc run` and `acc board-sim`, and its settled forces agree with the serial run's within
    // 2 % per segment.
    let header = |p: &std::path::Path| {
        std::fs::read_to_string(p)
            .expect("log")
            .lines()
            .next()
            .expect("header")
            .to_string()
    };
    let sim_out = dir.path().join("sim_out");
    let (code, sout, serr) = crate::e2e_support::Proc::spawn(
        &[
            "sim",
            &scenario.to_string_lossy(),
            "--out",
            &sim_out.to_string_lossy(),
            "--no-plot",
        ],
        false,
    )
    .finish(Duration::from_secs(60));
    assert_eq!(code, Some(0), "acc sim: {sout}\n{serr:?}");
    let sim_csv = sim_out.join("run.csv");
    assert_eq!(header(&sim_csv), header(&run_log), "acc sim vs acc run");
    assert_eq!(
        header(&sim_csv),
        header(&sim_log),
        "acc sim vs acc board-sim"
    );
    let in_process = summarize(
        &RunResult {
            law: "acc sim".into(),
            finished: true,
            volume_mm3: 0.0,
            rows: read_log(&sim_csv),
            ended_in_feed_hold: false,
        },
        &sc,
    );
    for (a, b) in summary
        .segments
        .iter()
        .zip(&in_process.segments)
        .filter(|(a, _)| a.reaches_ref)
    {
        let d = (a.mean_force_n - b.mean_force_n).abs() / b.mean_force_n;
        println!(
            "{}: acc run over the pty {:.1} N, acc sim {:.1} N ({:.2} %)",
            a.label,
            a.mean_force_n,
            b.mean_force_n,
            100.0 * d
        );
        assert!(
            d <= 0.02,
            "{}: settled forces differ by {:.2} %",
            a.label,
            100.0 * d
        );
    }
}
