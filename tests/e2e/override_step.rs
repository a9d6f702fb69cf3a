//! `acc run` on a 1 % board over a real pty: `acc board-sim` with the machine's
//! `override_path.step_pct = 1` reports `OVERRIDE_STEP = 1`; `acc run` with a 1 % σ-Δ preset
//! writes 1 % positions (the board answers exception 03 to anything off its grid), and the
//! machine-side log holds the settled mean force within 1 % of Fr in every section
//! (measured: 800.1 / 800.0 / 800.1 N on the 2 / 3 / 4 mm sections).

use std::time::Duration;

use crate::e2e_support::{
    assert_faults_never_raise, interrupt_expect_clean_exit, read_log, root, spawn_board_sim_on,
    spawn_run,
};
use acc_sim::Scenario;

#[test]
fn acc_run_drives_a_one_percent_board_with_sigma_delta() {
    let dir = tempfile::tempdir().expect("temp dir");
    let configs = root().join("configs");
    let abs = |text: String| text.replace("\"../", &format!("\"{}/", configs.display()));
    let put = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).expect("write");
        p
    };
    let read = |rel: &str| std::fs::read_to_string(configs.join(rel)).expect(rel);
    let machine = put(
        "vmc1.toml",
        read("machines/paper_vmc.toml").replace("\nstep_pct = 10", "\nstep_pct = 1"),
    );
    let preset = put(
        "case3_sd1.toml",
        read("presets/case3.toml")
            .replace("\nstep_pct = 10", "\nstep_pct = 1")
            .replace("quantizer = \"round\"", "quantizer = \"sigma_delta\""),
    );
    let scenario = put(
        "case3_1pct.toml",
        abs(read("scenarios/paper_case3.toml"))
            .replace(
                &format!("{}/machines/paper_vmc.toml", configs.display()),
                &machine.to_string_lossy(),
            )
            .replace(
                &format!("{}/presets/case3.toml", configs.display()),
                &preset.to_string_lossy(),
            ),
    );
    let runtime = put(
        "run.toml",
        abs(read("runtime/board_sim_fast.toml"))
            .replace(
                &format!("{}/presets/case3.toml", configs.display()),
                &preset.to_string_lossy(),
            )
            .replace(
                "calibration = \"paper_vmc_power.toml\"",
                &format!(
                    "calibration = \"{}\"",
                    configs.join("runtime/paper_vmc_power.toml").display()
                ),
            ),
    );
    let sc = Scenario::load(&scenario).expect("scenario");
    assert_eq!(sc.machine.override_path.step_pct, 1);
    let sim_log = dir.path().join("sim.csv");
    let run_log = dir.path().join("run.csv");
    let (mut board, pty) = spawn_board_sim_on(
        &scenario.to_string_lossy(),
        &["--log", &sim_log.to_string_lossy(), "--pace", "controller"],
    );
    let run = spawn_run(&runtime.to_string_lossy(), &pty, &run_log);
    assert!(
        board.wait_for("workpiece finished", Duration::from_secs(300)),
        "the workpiece was not finished: {:?}",
        board.err_lines
    );
    let (out, _) = interrupt_expect_clean_exit(run);
    board.sigint();
    let (bcode, _, berr) = board.finish(Duration::from_secs(10));
    assert_eq!(bcode, Some(0), "board-sim exit: {berr:?}");
    assert!(out.contains("OVERRIDE_STEP = 1 %"), "{out}");

    let rows = read_log(&run_log);
    assert_faults_never_raise(&rows);
    let cmds: Vec<u16> = rows.iter().filter_map(|r| r.override_cmd_pct).collect();
    assert!(cmds.iter().all(|&c| c <= 150));
    assert!(
        cmds.iter().filter(|&&c| c % 10 != 0).count() > cmds.len() / 4,
        "the 1 % grid is used"
    );
    assert!(
        !rows.iter().any(|r| r.flags.contains("exception")),
        "no command off the board's grid"
    );

    let summary = crate::e2e_support::machine_summary(&sim_log, &sc, "acc run, 1 % board, σ-Δ");
    let fr = sc.controller.force_ref_n;
    let mut judged = 0;
    for seg in summary.segments.iter().filter(|s| s.reaches_ref) {
        println!(
            "{}: mean {:.1} N over {} settled periods",
            seg.label, seg.mean_force_n, seg.settled_periods
        );
        assert!(
            (seg.mean_force_n - fr).abs() <= 0.01 * fr,
            "{}: {:.1} N",
            seg.label,
            seg.mean_force_n
        );
        judged += 1;
    }
    assert_eq!(judged, 3, "{summary:?}");
}
