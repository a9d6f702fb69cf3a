//! Bad run configs and arguments fail before anything is sent to the board: `acc run` against
//! an emulated board on a pty whose server counts every request it sees. Each case asserts
//! the exit code (2: usage or config error), that the error names the file, the full dotted
//! key, the value and the allowed range, that the last line says how the run ended, and that
//! the board saw zero requests. Plus: a board that does not answer at start ends with exit
//! code 5.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::e2e_support::{root, Proc};
use acc_pmc::emu::{BoardLogic, PtyBoard};

/// The fast board-sim run config with its relative paths made absolute (the edited copies
/// live in a temp folder).
fn base_text() -> String {
    let cfg = root().join("configs");
    let text = std::fs::read_to_string(cfg.join("runtime/board_sim_fast.toml")).expect("base");
    text.replace(
        "\"../presets/",
        &format!("\"{}/presets/", cfg.to_string_lossy()),
    )
    .replace(
        "\"paper_vmc_power.toml\"",
        &format!("\"{}/runtime/paper_vmc_power.toml\"", cfg.to_string_lossy()),
    )
}

/// `text` with `key = value` set in `[table]` ("" = the top level): replaced if present,
/// otherwise added (the table too, if missing).
fn set(text: &str, table: &str, key: &str, value: &str) -> String {
    let mut out = Vec::new();
    let mut current = String::new();
    let mut done = false;
    let header = format!("[{table}]");
    for line in text.lines() {
        if line.starts_with('[') {
            if !done && current == table {
                out.push(format!("{key} = {value}"));
                done = true;
            }
            current = line
                .trim()
                .trim_matches(|c| c == '[' || c == ']')
                .to_string();
        }
        if !done && current == table && line.starts_with(&format!("{key} =")) {
            out.push(format!("{key} = {value}"));
            done = true;
            continue;
        }
        out.push(line.to_string());
    }
    if !done {
        if current != table {
            out.push(header);
        }
        out.push(format!("{key} = {value}"));
    }
    out.join("\n") + "\n"
}

/// A file in `dir` holding `text`.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write config");
    p
}

/// `acc run --config <config> --port <port> --log <log> <extra…>`: (exit code, all output).
fn run_acc(config: &str, port: &str, log: &str, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec!["run", "--config", config, "--port", port, "--log", log];
    args.extend_from_slice(extra);
    let (code, out, err) = Proc::spawn(&args, false).finish(Duration::from_secs(20));
    (code, format!("{out}\n{}", err.join("\n")))
}

/// One bad input: how to make it and what the error must name.
struct Case {
    /// What is wrong.
    what: &'static str,
    /// The run config to use (a path).
    config: PathBuf,
    /// `--port`: `None` = the emulated board's pty.
    port: Option<&'static str>,
    /// `--log`.
    log: &'static str,
    /// More arguments.
    extra: &'static [&'static str],
    /// Every one of these must be in the output (file, key, value, range).
    names: Vec<String>,
}

#[test]
fn bad_configs_and_arguments_fail_with_exit_2_before_anything_is_sent() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let base = base_text();
    let mut cases: Vec<Case> = Vec::new();
    // A run config with one key set: the error names this file, the key, value and range.
    let mut key = |what: &'static str, table: &str, k: &str, v: &str, names: &[&str]| {
        let name = format!("bad_{}_{}.toml", table.replace('.', "_"), cases.len());
        let cfg = write(d, &name, &set(&base, table, k, v));
        let mut n: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        n.push(cfg.to_string_lossy().to_string());
        cases.push(Case {
            what,
            config: cfg,
            port: None,
            log: "/dev/null",
            extra: &[],
            names: n,
        });
    };
    // [board]
    key(
        "baud not a standard rate",
        "board",
        "baud",
        "12345",
        &["key `board.baud` = 12345", "one of [1200"],
    );
    key(
        "slave 0",
        "board",
        "slave",
        "0",
        &["key `board.slave` = 0", "allowed 1 ..= 247"],
    );
    key(
        "slave a string",
        "board",
        "slave",
        "\"one\"",
        &[
            "key `board.slave`: \"one\" is a string",
            "allowed 1 ..= 247",
        ],
    );
    key(
        "watchdog too short",
        "board",
        "watchdog_ms",
        "50",
        &["key `board.watchdog_ms` = 50", "allowed 100 ..= 5000"],
    );
    key(
        "budget below timeout",
        "board",
        "budget_ms",
        "10",
        &["key `board.budget_ms` = 10"],
    );
    key(
        "unknown board key",
        "board",
        "slav",
        "1",
        &[
            "key `board.slav`: unknown key",
            "did you mean `board.slave`?",
        ],
    );
    key(
        "a parity the pty refuses",
        "board",
        "parity",
        "\"even\"",
        &["key `board.parity`", "refused parity = even"],
    );
    // [policy]: counts that must be positive reject 0, negatives show the range.
    for k in [
        "link_hold_periods",
        "invalid_power_periods",
        "stale_seq_periods",
        "ack_periods",
    ] {
        let named = format!("key `policy.{k}` = 0");
        key(
            "a zero count",
            "policy",
            k,
            "0",
            &[named.as_str(), "allowed 1 ..= 1000"],
        );
    }
    key(
        "negative unsigned count",
        "policy",
        "link_hold_periods",
        "-1",
        &["key `policy.link_hold_periods` = -1", "allowed 1 ..= 1000"],
    );
    key(
        "huge unsigned count",
        "policy",
        "ack_periods",
        "99999999999",
        &[
            "key `policy.ack_periods` = 99999999999",
            "allowed 1 ..= 1000",
        ],
    );
    key(
        "count as a string",
        "policy",
        "link_hold_periods",
        "\"five\"",
        &[
            "key `policy.link_hold_periods`: \"five\" is a string",
            "(line ",
            "allowed 1 ..= 1000",
        ],
    );
    key(
        "max override above 150",
        "policy",
        "max_override_pct",
        "200",
        &["key `policy.max_override_pct` = 200", "allowed 1 ..= 150"],
    );
    key(
        "negative handback",
        "policy",
        "operator_handback_pct",
        "-5",
        &[
            "key `policy.operator_handback_pct` = -5",
            "allowed 0 ..= 150",
        ],
    );
    key(
        "negative overload force",
        "policy",
        "overload_force_n",
        "-1.0",
        &["key `policy.overload_force_n` = -1", "allowed > 0"],
    );
    key(
        "unknown policy key",
        "policy",
        "link_hold_period",
        "5",
        &[
            "key `policy.link_hold_period`: unknown key",
            "did you mean `policy.link_hold_periods`?",
        ],
    );
    // [shutdown], [runtime]
    key(
        "zero air periods",
        "shutdown",
        "air_periods",
        "0",
        &["key `shutdown.air_periods` = 0", "allowed 1 ..= 1000"],
    );
    key(
        "drain too long",
        "shutdown",
        "drain_s",
        "601.0",
        &["key `shutdown.drain_s` = 601", "allowed 0 ..= 600"],
    );
    key(
        "air force above Fr",
        "shutdown",
        "air_force_n",
        "900.0",
        &["key `shutdown.air_force_n` = 900", "allowed 0 ..= 800"],
    );
    key(
        "zero time scale",
        "runtime",
        "time_scale",
        "0.0",
        &["key `runtime.time_scale` = 0", "allowed 0.1 ..= 100"],
    );
    key(
        "zero log queue",
        "runtime",
        "log_buffer",
        "0",
        &["key `runtime.log_buffer` = 0", "allowed 1 ..= 1000000"],
    );
    key(
        "negative log queue",
        "runtime",
        "log_buffer",
        "-1",
        &["key `runtime.log_buffer` = -1", "allowed 1 ..= 1000000"],
    );
    key(
        "unknown runtime key",
        "runtime",
        "time_scal",
        "4.0",
        &[
            "key `runtime.time_scal`: unknown key",
            "did you mean `runtime.time_scale`?",
        ],
    );
    // [force]
    key(
        "estimator radius out of range",
        "force.estimator",
        "tool_radius_mm",
        "0.0",
        &[
            "key `force.estimator.tool_radius_mm` = 0",
            "allowed 0.1 ..= 1000",
        ],
    );
    key(
        "unknown estimator variant",
        "force.estimator",
        "no_load",
        "\"fix\"",
        &["key `force.estimator.no_load`: \"fix\"", "`fixed`"],
    );
    // Referenced files that are missing name the key that referenced them.
    key(
        "missing controller preset",
        "",
        "controller",
        "\"no_such_preset.toml\"",
        &[
            "key `controller`: \"no_such_preset.toml\" cannot be read",
            "No such file",
        ],
    );
    key(
        "missing calibration",
        "force",
        "calibration",
        "\"no_such_cal.toml\"",
        &[
            "key `force.calibration`: \"no_such_cal.toml\" cannot be read",
            "No such file",
        ],
    );
    key(
        "unknown top-level key",
        "",
        "nmae",
        "\"x\"",
        &["key `nmae`: unknown key", "did you mean `name`?"],
    );

    // Errors inside a referenced file name that file and its key.
    let preset_text =
        std::fs::read_to_string(root().join("configs/presets/case3.toml")).expect("preset");
    let preset = write(
        d,
        "bad_preset.toml",
        &set(&preset_text, "override", "step_pct", "-10"),
    );
    let cfg = write(
        d,
        "run_bad_preset.toml",
        &set(
            &base,
            "",
            "controller",
            &format!("{:?}", preset.to_string_lossy()),
        ),
    );
    cases.push(Case {
        what: "negative step in the preset",
        config: cfg,
        port: None,
        log: "/dev/null",
        extra: &[],
        names: vec![
            preset.to_string_lossy().to_string(),
            "key `override.step_pct` = -10".into(),
            "allowed 1 ..= 50".into(),
        ],
    });
    let cal_text =
        std::fs::read_to_string(root().join("configs/runtime/paper_vmc_power.toml")).expect("cal");
    let cal = write(
        d,
        "bad_cal.toml",
        &set(&cal_text, "constants.power_efficiency", "gain", "\"high\""),
    );
    let cfg = write(
        d,
        "run_bad_cal.toml",
        &set(
            &base,
            "force",
            "calibration",
            &format!("{:?}", cal.to_string_lossy()),
        ),
    );
    cases.push(Case {
        what: "a string for a number in the calibration",
        config: cfg,
        port: None,
        log: "/dev/null",
        extra: &[],
        names: vec![
            cal.to_string_lossy().to_string(),
            "key `constants.power_efficiency.gain`: \"high\" is a string".into(),
        ],
    });

    // Arguments.
    let good = root().join("configs/runtime/board_sim_fast.toml");
    let arg = |what: &'static str,
               port: Option<&'static str>,
               log: &'static str,
               extra: &'static [&'static str],
               names: &[&str]| Case {
        what,
        config: good.clone(),
        port,
        log,
        extra,
        names: names.iter().map(|s| s.to_string()).collect(),
    };
    cases.push(arg(
        "a port that does not exist",
        Some("/dev/does-not-exist-acc"),
        "/dev/null",
        &[],
        &[
            "key `board.port`",
            "/dev/does-not-exist-acc",
            good.to_string_lossy().as_ref(),
        ],
    ));
    cases.push(arg(
        "an unwritable run log",
        None,
        "/proc/acc-no-such-dir/run.csv",
        &[],
        &["--log /proc/acc-no-such-dir/run.csv"],
    ));
    cases.push(arg(
        "a negative duration",
        None,
        "/dev/null",
        &["--duration-s", "-1"],
        &["--duration-s -1", "allowed > 0"],
    ));
    cases.push(arg(
        "a zero duration",
        None,
        "/dev/null",
        &["--duration-s", "0"],
        &["--duration-s 0", "allowed > 0"],
    ));
    cases.push(arg(
        "a duration that is not a number",
        None,
        "/dev/null",
        &["--duration-s", "abc"],
        &["--duration-s", "abc"],
    ));
    cases.push(Case {
        what: "a run config that does not exist",
        config: d.join("no_such_run.toml"),
        port: None,
        log: "/dev/null",
        extra: &[],
        names: vec![
            d.join("no_such_run.toml").to_string_lossy().to_string(),
            "cannot read".into(),
        ],
    });

    cases.push(arg(
        "a plan file that does not exist (--plan)",
        None,
        "/dev/null",
        &["--plan", "/proc/acc-no-such-dir/plan.csv"],
        &["/proc/acc-no-such-dir/plan.csv", "cannot read the plan"],
    ));
    assert!(cases.len() >= 39, "{} cases", cases.len());
    for c in &cases {
        // A fresh board per case: its request count belongs to this case alone.
        let board = PtyBoard::spawn(BoardLogic::default(), 1, 115_200).expect("pty board");
        let pty = board.path().to_string();
        let (code, text) = run_acc(
            &c.config.to_string_lossy(),
            c.port.unwrap_or(&pty),
            c.log,
            c.extra,
        );
        let stats = board.stop().expect("server stats");
        assert_eq!(
            code,
            Some(2),
            "{}: exit code 2 (usage or config error):\n{text}",
            c.what
        );
        for n in &c.names {
            assert!(
                text.contains(n.as_str()),
                "{}: the error names `{n}`:\n{text}",
                c.what
            );
        }
        assert!(!text.contains("panicked"), "{}: {text}", c.what);
        // clap's own usage errors end before `acc run` starts; every other error ends with
        // the run's last line.
        if !c.extra.contains(&"abc") {
            assert!(
                text.trim_end().ends_with("acc run: ended: usage or config error: nothing was sent to the board (exit code 2)"),
                "{}: last line says how the run ended:\n{text}",
                c.what
            );
        }
        assert_eq!(
            (stats.requests, stats.other_slave, stats.bytes_discarded),
            (0, 0, 0),
            "{}: nothing was sent to the board",
            c.what
        );
    }
}

#[test]
fn a_board_that_does_not_answer_at_start_ends_with_exit_5() {
    // The emulated board listens as slave 2; the config addresses slave 1: every request
    // reaches it and none is answered.
    let board = PtyBoard::spawn(BoardLogic::default(), 2, 115_200).expect("pty board");
    let pty = board.path().to_string();
    let cfg = root().join("configs/runtime/board_sim_fast.toml");
    let (code, text) = run_acc(&cfg.to_string_lossy(), &pty, "/dev/null", &[]);
    let stats = board.stop().expect("server stats");
    assert_eq!(code, Some(5), "board not answering: exit code 5:\n{text}");
    assert!(
        text.contains("writing WATCHDOG_MS = 500 ms to slave 1"),
        "the failed first transaction is named:\n{text}"
    );
    assert!(
        text.trim_end().ends_with("(exit code 5)")
            && text.contains("the board did not answer at start"),
        "{text}"
    );
    assert!(
        stats.other_slave >= 1,
        "the request reached the board: {stats:?}"
    );
    assert_eq!(stats.requests, 0, "and none was served: {stats:?}");
}
