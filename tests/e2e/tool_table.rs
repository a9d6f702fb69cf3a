//! `acc run` with a shop tool table (`[tools] file`) against `acc board-sim` over a real pty:
//! the emulated v2 board reports tool 1 (Fr 800 N in `configs/tooltable.toml`) and, from
//! x = 60 mm on, tool 2 (Fr 500 N) (`configs/scenarios/two_tools.toml`). The production loop
//! reads `TOOL_NUMBER` every period and regulates to that tool's Fr; the override does not
//! rise at the switch.

use std::time::Duration;

use crate::e2e_support::{cmd, read_log, root, spawn_board_sim_on, spawn_run_for};

/// The run config: `board_sim_fast.toml` with `[tools] file = configs/tooltable.toml`,
/// tolerant of late replies on a loaded host ([`crate::e2e_support::load_tolerant_config`]).
fn run_config_with_tools(dir: &std::path::Path) -> std::path::PathBuf {
    let table = root().join("configs/tooltable.toml");
    crate::e2e_support::load_tolerant_config(
        dir,
        &format!("[tools]\nfile = {:?}\n", table.to_string_lossy()),
    )
}

#[test]
fn acc_run_switches_the_force_limit_with_the_boards_tool_number() {
    let dir = tempfile::tempdir().expect("temp dir");
    let config = run_config_with_tools(dir.path());
    let run_log = dir.path().join("run.csv");
    let (board, pty) = spawn_board_sim_on(
        "configs/scenarios/two_tools.toml",
        &["--pace", "controller"],
    );
    // 15 mm of air at 150 %, then tool 1 to x = 60 mm (about 20 s), then tool 2.
    let run = spawn_run_for(&config.to_string_lossy(), &pty, &run_log, "50", &[]);
    let (code, out, err) = run.finish(Duration::from_secs(60));
    drop(board);
    assert_eq!(
        code,
        Some(0),
        "acc run exit; stdout:\n{out}\nstderr:\n{err:?}"
    );

    let rows = read_log(&run_log);
    assert!(rows.len() >= 490, "{} rows", rows.len());
    let switch = rows
        .iter()
        .position(|r| r.tool == Some(2))
        .expect("the board reported tool 2");
    assert!(
        rows[..switch].iter().filter(|r| r.tool == Some(1)).count() > 200,
        "tool 1 before the switch"
    );
    // Fr follows the tool.
    for r in &rows[switch.saturating_sub(50)..switch] {
        if let Some(fr) = r.force_ref_n {
            assert_eq!(fr, 800.0, "tool 1 row {}: Fr", r.period);
        }
    }
    for r in &rows[switch..] {
        if let Some(fr) = r.force_ref_n {
            assert_eq!(fr, 500.0, "tool 2 row {}: Fr", r.period);
        }
    }
    // No bump: in the 3 s after the switch the command never exceeds the last one before it.
    let before = cmd(&rows[switch - 1]);
    for r in &rows[switch..(switch + 30).min(rows.len())] {
        assert!(
            cmd(r) <= before,
            "override {} % at row {} above {before} % before the tool change",
            cmd(r),
            r.period
        );
    }
    // Regulated to each tool's Fr: the estimated force over the last 8 s of each tool.
    let mean = |rs: &[acc_runtime::record::RunRecord]| {
        let f: Vec<f64> = rs.iter().filter_map(|r| r.force_n).collect();
        f.iter().sum::<f64>() / f.len().max(1) as f64
    };
    let m1 = mean(&rows[switch - 80..switch]);
    let m2 = mean(&rows[rows.len() - 80..]);
    println!("tool 1: {m1:.1} N (Fr 800), tool 2: {m2:.1} N (Fr 500), switch at row {switch}");
    assert!(
        (m1 - 800.0).abs() < 0.08 * 800.0,
        "tool 1 mean force {m1:.1} N"
    );
    assert!(
        (m2 - 500.0).abs() < 0.08 * 500.0,
        "tool 2 mean force {m2:.1} N"
    );
}
