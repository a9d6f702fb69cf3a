//! `acc run` finds the board's protocol at start: against `acc board-sim --protocol 1` (a v1
//! board) it says so exactly once, on stderr, with what that board cannot do, and records it
//! in the summary; against the default v2 board-sim it writes `FALLBACK_MODE` and warns of
//! nothing.

use std::time::Duration;

use crate::e2e_support::{load_tolerant_config, spawn_board_sim, spawn_run_for};

/// `acc run --duration-s 2` against a board-sim started with `board_args` and paced by the
/// controller's writes; returns its stdout and stderr lines. The subject is the protocol, not
/// the link's timing: the run config holds the override through late replies on a loaded
/// host ([`load_tolerant_config`]).
fn short_run(board_args: &[&str]) -> (String, Vec<String>) {
    let dir = tempfile::tempdir().expect("temp dir");
    let log = dir.path().join("run.csv");
    let config = load_tolerant_config(dir.path(), "");
    let mut args = board_args.to_vec();
    args.extend(["--pace", "controller"]);
    let (board, pty) = spawn_board_sim(&args);
    let run = spawn_run_for(&config.to_string_lossy(), &pty, &log, "2", &[]);
    let (code, out, err) = run.finish(Duration::from_secs(30));
    assert_eq!(code, Some(0), "stdout:\n{out}\nstderr:\n{err:#?}");
    board.sigint();
    let _ = board.finish(Duration::from_secs(10));
    (out, err)
}

fn v1_warnings(err: &[String]) -> usize {
    err.iter()
        .filter(|l| l.starts_with("warning: ") && l.contains("speaks protocol v1"))
        .count()
}

#[test]
fn a_v1_board_is_announced_exactly_once() {
    for registers in ["exception", "zeros"] {
        let (out, err) = short_run(&["--protocol", "1", "--v1-registers", registers]);
        assert_eq!(v1_warnings(&err), 1, "{registers}: stderr {err:#?}");
        let line = err
            .iter()
            .find(|l| l.starts_with("warning: "))
            .expect("warning");
        assert!(
            line.contains(acc_pmc::BoardProtocol::V1.limitations()),
            "{line}"
        );
        assert!(out.contains("board protocol: v1;"), "{registers}: {out}");
        assert!(!out.contains("FALLBACK_MODE"), "{registers}: {out}");
    }
}

#[test]
fn a_v2_board_gets_its_fallback_mode_and_no_warning() {
    let (out, err) = short_run(&[]);
    assert_eq!(v1_warnings(&err), 0, "{err:#?}");
    assert!(
        out.contains("protocol v2; FALLBACK_MODE = clamp_and_feed_hold"),
        "{out}"
    );
    assert!(out.contains("board protocol: v2;"), "{out}");
}
