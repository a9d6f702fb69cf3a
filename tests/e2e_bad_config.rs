//! Bad run configs give clear errors (file, key, allowed range) before anything is sent to
//! the board: `acc run` against an emulated board on a pty whose server counts requests.

mod e2e_support;

use std::time::Duration;

use acc_pmc::emu::{BoardLogic, PtyBoard};
use e2e_support::{root, Proc};

/// The fast board-sim config with `board.<key> = <value>` replaced (or added).
fn config_with(dir: &std::path::Path, key: &str, value: &str) -> std::path::PathBuf {
    let base = root().join("configs/runtime/board_sim_fast.toml");
    let text = std::fs::read_to_string(&base).expect("base config");
    let mut out = String::new();
    let mut in_board = false;
    let mut done = false;
    for line in text.lines() {
        if line.starts_with('[') {
            if in_board && !done {
                out.push_str(&format!("{key} = {value}\n"));
                done = true;
            }
            in_board = line.trim() == "[board]";
        }
        if in_board && line.starts_with(&format!("{key} =")) {
            out.push_str(&format!("{key} = {value}\n"));
            done = true;
            continue;
        }
        // relative paths must keep pointing at configs/
        let line = line.replace("\"../presets/", "\"{CFG}/presets/");
        let line = line.replace(
            "\"paper_vmc_power.toml\"",
            "\"{CFG}/runtime/paper_vmc_power.toml\"",
        );
        out.push_str(&line);
        out.push('\n');
    }
    let out = out.replace("{CFG}", &root().join("configs").to_string_lossy());
    let path = dir.join(format!("bad_{key}.toml"));
    std::fs::write(&path, out).expect("write config");
    path
}

fn run_acc(config: &std::path::Path, port: &str) -> (Option<i32>, String) {
    run_acc_with(config, port, "/dev/null", &[])
}

/// `acc run --config <config> --port <port> --log <log> <extra…>`: (exit code, all output).
fn run_acc_with(
    config: &std::path::Path,
    port: &str,
    log: &str,
    extra: &[&str],
) -> (Option<i32>, String) {
    let config = config.to_string_lossy();
    let mut args = vec!["run", "--config", &config, "--port", port, "--log", log];
    args.extend_from_slice(extra);
    let (code, out, err) = Proc::spawn(&args, false).finish(Duration::from_secs(20));
    (code, format!("{out}\n{}", err.join("\n")))
}

#[test]
fn bad_configs_fail_clearly_before_anything_is_sent() {
    let dir = tempfile::tempdir().expect("temp dir");
    let board = PtyBoard::spawn(BoardLogic::default(), 1, 115_200).expect("pty board");
    let pty = board.path().to_string();
    let cases: [(&str, &str, &str, &str); 4] = [
        ("baud", "12345", "board.baud", "one of"),
        ("slave", "0", "board.slave", "1"),
        ("watchdog_ms", "50", "board.watchdog_ms", "100"),
        ("parity", "\"even\"", "board.parity", "even"),
    ];
    for (key, value, named, allowed) in cases {
        let cfg = config_with(dir.path(), key, value);
        let (code, text) = run_acc(&cfg, &pty);
        // 2: the exit code of every failed `acc` command (docs/runtime.md)
        assert_eq!(code, Some(2), "{key} = {value} must fail with exit code 2");
        assert!(
            text.contains(named) && text.contains(allowed),
            "{key} = {value}: error names `{named}` and `{allowed}`:\n{text}"
        );
        assert!(
            text.contains(&cfg.to_string_lossy().to_string()) || key == "parity",
            "{key}: error names the file:\n{text}"
        );
        assert!(!text.contains("panicked"), "{text}");
    }
    // unknown port
    let cfg = root().join("configs/runtime/board_sim_fast.toml");
    let (code, text) = run_acc(&cfg, "/dev/does-not-exist-acc");
    assert_eq!(code, Some(2), "unknown port: exit code 2");
    assert!(
        text.contains("/dev/does-not-exist-acc") && text.contains("board.port"),
        "unknown port named with its key:\n{text}"
    );
    // A run log that cannot be written, and a negative duration: refused before the port.
    let (code, text) = run_acc_with(&cfg, &pty, "/proc/acc-no-such-dir/run.csv", &[]);
    assert_eq!(code, Some(2), "unwritable log: exit code 2\n{text}");
    assert!(
        text.contains("--log /proc/acc-no-such-dir/run.csv"),
        "the log path is named:\n{text}"
    );
    let (code, text) = run_acc_with(&cfg, &pty, "/dev/null", &["--duration-s", "-1"]);
    assert_eq!(code, Some(2), "negative duration: exit code 2\n{text}");
    assert!(
        text.contains("--duration-s -1: must be a positive number of seconds"),
        "{text}"
    );
    let stats = board.stop().expect("server stats");
    assert_eq!(stats.requests, 0, "nothing was sent to the board");
}
