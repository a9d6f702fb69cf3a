//! `[runtime] on_device_lost = "reconnect"` end to end: `acc run` against `acc board-sim`
//! over a pty reached through a symlink (the way a udev rule names a USB adapter). The
//! board-sim is killed (its pty vanishes: every read fails with EIO); with a new board-sim
//! behind the same name `acc run` reopens the port, logs every period in between (flagged
//! `link:disconnected`) and drives the new board; without one it gives up after
//! `reconnect_timeout_s` with exit code 4, a message naming the device and the time, and a
//! complete run log.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::e2e_support::{field, one_at_a_time, read_log, root, spawn_board_sim, spawn_run, Proc};

/// `board_sim_fast.toml` with absolute paths and `[runtime]` reconnecting for
/// `timeout_s` s of machine time.
fn config(dir: &Path, timeout_s: f64) -> PathBuf {
    let cfgs = root().join("configs");
    let text = std::fs::read_to_string(cfgs.join("runtime/board_sim_fast.toml"))
        .expect("board_sim_fast.toml")
        .replace("\"../presets/", &format!("\"{}/presets/", cfgs.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/runtime/paper_vmc_power.toml\"", cfgs.display()),
        )
        .replacen(
            "[runtime]",
            &format!(
                "[runtime]\non_device_lost = \"reconnect\"\nreconnect_timeout_s = {timeout_s}"
            ),
            1,
        );
    let p = dir.join("reconnect_run.toml");
    std::fs::write(&p, text).expect("write config");
    p
}

/// Point the symlink `link` at `target` (atomically: a new link renamed over the old).
fn point(link: &Path, target: &str) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).expect("symlink");
    std::fs::rename(&tmp, link).expect("rename symlink");
}

/// `acc run` (reconnect policy, `reconnect_timeout_s` = `timeout_s`) on a board-sim behind the
/// symlink `<dir>/board`; at t = 5 s of machine time the board-sim is killed. Returns the
/// run, the device link and the run log path.
fn run_until_the_board_dies(dir: &Path, timeout_s: f64) -> (Proc, PathBuf, PathBuf) {
    let cfg = config(dir, timeout_s);
    let run_log = dir.join("run.csv");
    let dev = dir.join("board");
    let (mut board, pty) = spawn_board_sim(&["--fault", "operator@5:100", "--pace", "controller"]);
    point(&dev, &pty);
    let run = spawn_run(&cfg.to_string_lossy(), &dev.to_string_lossy(), &run_log);
    assert!(
        board.wait_for("fault Operator(100)", Duration::from_secs(60)),
        "board-sim did not reach t = 5 s: {:?}",
        board.err_lines
    );
    board.child.kill().expect("kill board-sim");
    let _ = board.child.wait();
    (run, dev, run_log)
}

#[test]
fn acc_run_reopens_the_board_device_when_it_comes_back() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let (run, dev, run_log) = run_until_the_board_dies(dir.path(), 40.0);
    // A second of wall time (4 s of machine time) without the device, then a new board
    // behind the same name.
    std::thread::sleep(Duration::from_secs(1));
    let (mut board2, pty2) =
        spawn_board_sim(&["--fault", "operator@3:100", "--pace", "controller"]);
    point(&dev, &pty2);
    assert!(
        board2.wait_for("fault Operator(100)", Duration::from_secs(60)),
        "acc run never drove the new board: {:?}",
        board2.err_lines
    );
    run.sigint();
    let (code, out, err) = run.finish(Duration::from_secs(30));
    let text = format!("{out}\n{}", err.join("\n"));
    assert!(
        matches!(code, Some(0) | Some(3)),
        "an orderly stop after the reconnect:\n{text}"
    );
    assert!(text.contains("reconnects: 1;"), "{text}");
    let rows = read_log(&run_log);
    let periods: usize = field(&out, "periods")
        .and_then(|v| v.parse().ok())
        .expect("summary line `periods: N`");
    assert_eq!(rows.len(), periods, "a row every period, the gone ones too");
    let first_gone = rows
        .iter()
        .position(|r| r.has_flag("link:disconnected"))
        .expect("rows flagged link:disconnected");
    let gone = rows
        .iter()
        .filter(|r| r.has_flag("link:disconnected"))
        .count();
    assert!(
        gone >= 5,
        "about 4 s of machine time without it: {gone} rows"
    );
    assert!(
        rows[first_gone..]
            .iter()
            .skip_while(|r| r.override_applied_pct.is_none())
            .count()
            > 10,
        "statuses from the new board after the gap"
    );
    board2.sigint();
    let _ = board2.finish(Duration::from_secs(10));
}

#[test]
fn acc_run_gives_up_after_the_reconnect_timeout() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    // 4 s of machine time = 1 s of wall time at 4x
    let (run, dev, run_log) = run_until_the_board_dies(dir.path(), 4.0);
    let started = Instant::now();
    let (code, out, err) = run.finish(Duration::from_secs(30));
    let text = format!("{out}\n{}", err.join("\n"));
    assert_eq!(code, Some(4), "exit code of a lost device:\n{text}");
    assert!(
        text.contains(&format!("device {} is gone", dev.display()))
            && text.contains("reconnect_timeout_s = 4 s"),
        "the message names the device and the time:\n{text}"
    );
    assert!(
        started.elapsed() < Duration::from_secs(8),
        "ended within a bounded time: {:?}",
        started.elapsed()
    );
    let rows = read_log(&run_log);
    let periods: usize = field(&out, "periods")
        .and_then(|v| v.parse().ok())
        .expect("summary line `periods: N`");
    assert_eq!(rows.len(), periods, "run log complete to the last period");
    let gone = rows
        .iter()
        .rev()
        .take_while(|r| r.has_flag("link:disconnected") || r.has_flag("skipped"))
        .count();
    assert!(
        (35..=50).contains(&gone),
        "about 4 s of machine time at T = 0.1 s: {gone}"
    );
}
