//! Support for the end-to-end tests: the `acc` binary, `acc board-sim` on a pty, `acc run`
//! against it, SIGINT, and reading the two run logs.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use acc_runtime::record::{read_run_log, RunRecord};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Newest modification time of the files under `dir`.
fn newest(dir: &Path) -> Option<std::time::SystemTime> {
    let mut best = None;
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let p = e.path();
        let t = if p.is_dir() {
            newest(&p)
        } else {
            e.metadata().and_then(|m| m.modified()).ok()
        };
        best = best.max(t);
    }
    best
}

/// The `acc` binary next to this test's `deps/` folder (`ACC_BIN` overrides). It is built
/// with the same cargo only when missing or older than a source file of the workspace
/// (building it from inside a test run costs a feature re-resolution, so not every time).
pub fn acc_bin() -> PathBuf {
    static BIN: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BIN.get_or_init(|| {
        if let Ok(p) = std::env::var("ACC_BIN") {
            return PathBuf::from(p);
        }
        let exe = std::env::current_exe().expect("test executable path");
        let dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("target/<profile>/deps/<test>");
        let bin = dir.join("acc");
        let built = std::fs::metadata(&bin).and_then(|m| m.modified()).ok();
        let src = ["crates", "sim/src"]
            .iter()
            .filter_map(|d| newest(&root().join(d)))
            .max();
        if built.is_none() || src > built {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            // The binary of this test's own profile (`cargo test --release` runs
            // target/release/acc, which a plain `cargo build` would leave stale).
            let profile = match dir.file_name().and_then(|n| n.to_str()) {
                Some("debug") | None => "dev",
                Some(p) => p,
            };
            // `full`: the fleet store and the OPC UA server, as `cargo test --workspace`
            // builds the binary (the crates' dev-dependencies ask for both).
            let args = [
                "build",
                "--quiet",
                "-p",
                "acc-cli",
                "--bin",
                "acc",
                "--features",
                "full",
                "--profile",
                profile,
            ];
            let status = Command::new(cargo)
                .args(args)
                .current_dir(root())
                .status()
                .expect("run cargo build -p acc-cli");
            assert!(status.success(), "building the acc binary failed");
        }
        assert!(bin.exists(), "no acc binary at {}", bin.display());
        bin
    })
    .clone()
}

/// A child process whose stderr lines are collected on a thread.
pub struct Proc {
    /// The process.
    pub child: Child,
    /// First stdout line (the pty path for board-sim).
    pub first_line: Option<String>,
    stderr: mpsc::Receiver<String>,
    /// stderr lines seen so far.
    pub err_lines: Vec<String>,
}

impl Proc {
    /// Spawn `acc <args>`; with `read_first_line`, wait for the first stdout line.
    pub fn spawn(args: &[&str], read_first_line: bool) -> Proc {
        Self::spawn_with_stdin(args, read_first_line, Stdio::inherit())
    }

    /// As [`Proc::spawn`], with `stdin` (e.g. piped, to pace `acc sim --step-stdin`).
    pub fn spawn_with_stdin(args: &[&str], read_first_line: bool, stdin: Stdio) -> Proc {
        let mut child = Command::new(acc_bin())
            .args(args)
            .current_dir(root())
            .stdin(stdin)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn acc");
        let (tx, rx) = mpsc::channel();
        let err = child.stderr.take().expect("stderr piped");
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let first_line = if read_first_line {
            let out = child.stdout.take().expect("stdout piped");
            let mut line = String::new();
            BufReader::new(out)
                .read_line(&mut line)
                .expect("first stdout line");
            Some(line.trim().to_string())
        } else {
            None
        };
        Proc {
            child,
            first_line,
            stderr: rx,
            err_lines: Vec::new(),
        }
    }

    /// Collect stderr lines received so far.
    pub fn drain(&mut self) {
        while let Ok(l) = self.stderr.try_recv() {
            self.err_lines.push(l);
        }
    }

    /// Wait (at most `timeout`) for a stderr line containing `needle`.
    pub fn wait_for(&mut self, needle: &str, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        loop {
            if self.err_lines.iter().any(|l| l.contains(needle)) {
                return true;
            }
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            match self
                .stderr
                .recv_timeout(left.min(Duration::from_millis(200)))
            {
                Ok(l) => self.err_lines.push(l),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return self.err_lines.iter().any(|l| l.contains(needle))
                }
            }
        }
    }

    /// Send SIGINT (as Ctrl-C would).
    pub fn sigint(&self) {
        let ok = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "kill -INT {}", self.child.id());
    }

    /// Wait for the exit (at most `timeout`, then kill); returns (exit code, stdout).
    pub fn finish(mut self, timeout: Duration) -> (Option<i32>, String, Vec<String>) {
        let end = Instant::now() + timeout;
        let code = loop {
            if let Ok(Some(st)) = self.child.try_wait() {
                break st.code();
            }
            if Instant::now() > end {
                let _ = self.child.kill();
                let _ = self.child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut out = String::new();
        if let Some(mut o) = self.child.stdout.take() {
            let _ = std::io::Read::read_to_string(&mut o, &mut out);
        }
        std::thread::sleep(Duration::from_millis(50));
        self.drain();
        (code, out, std::mem::take(&mut self.err_lines))
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// The simulator's summary of a machine-side run log (`acc board-sim --log`) of `scenario`,
/// judged like `acc sim` judges its own runs.
pub fn machine_summary(log: &Path, scenario: &acc_sim::Scenario, law: &str) -> acc_sim::Summary {
    let result = acc_sim::RunResult {
        law: law.into(),
        finished: true,
        volume_mm3: 0.0,
        rows: read_log(log),
        ended_in_feed_hold: false,
    };
    acc_sim::summarize(&result, scenario)
}

/// Read a run log.
pub fn read_log(path: &Path) -> Vec<RunRecord> {
    let f = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    read_run_log(f).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A value after `key` in a `key: value` line of `text`.
pub fn field<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines()
        .find_map(|l| l.strip_prefix(key))
        .map(|v| v.trim_start_matches(':').trim())
}

/// Rows where the policy drove the override (armed and writing).
pub fn is_active(r: &RunRecord) -> bool {
    r.state == "active"
}

/// The override commanded in a row's period: the one written, else the one in force.
pub fn cmd(r: &RunRecord) -> u16 {
    r.override_cmd_pct
        .or(r.override_applied_pct)
        .unwrap_or_default()
}

/// The fault invariant on an `acc run` log: in every row where the force sample was not
/// usable (link error, stale or implausible power) and ACC was driving, the override written
/// (if any) is not above the last one written. Returns the rows checked.
pub fn assert_faults_never_raise(rows: &[RunRecord]) -> usize {
    let mut prev: Option<u16> = None;
    let mut checked = 0;
    for (i, r) in rows.iter().enumerate() {
        if !is_active(r) {
            prev = None;
            continue;
        }
        let Some(c) = r.override_cmd_pct else {
            continue;
        };
        if !r.force_valid {
            if let Some(p) = prev {
                assert!(
                    c <= p,
                    "row {i} (t = {:.2} s, flags {}): fault period raised the command {p} -> {c}",
                    r.t_s,
                    r.flags,
                );
                checked += 1;
            }
        }
        prev = Some(c);
    }
    checked
}

/// Start `acc board-sim` on the paper's case III scenario (2-3-4 mm) at 4x time, 115 200
/// baud, machine time starting with the controller, plus `extra` arguments; returns the
/// process and the pty path it printed.
pub fn spawn_board_sim(extra: &[&str]) -> (Proc, String) {
    spawn_board_sim_on("configs/scenarios/paper_case3.toml", extra)
}

/// [`spawn_board_sim`] on another scenario (`scenario` relative to the repository root).
pub fn spawn_board_sim_on(scenario: &str, extra: &[&str]) -> (Proc, String) {
    let scenario = root().join(scenario);
    let scenario = scenario.to_string_lossy();
    let mut args = vec![
        "board-sim",
        "--scenario",
        &scenario,
        "--time-scale",
        "4",
        "--baud",
        "115200",
        "--wait-for-controller",
    ];
    args.extend_from_slice(extra);
    let board = Proc::spawn(&args, true);
    let pty = board
        .first_line
        .clone()
        .expect("board-sim prints the pty path");
    assert!(pty.starts_with("/dev/"), "pty path, got {pty:?}");
    (board, pty)
}

/// `configs/runtime/board_sim_fast.toml` written to `dir` with its relative paths made
/// absolute, `extra` TOML appended, and made tolerant of a loaded host: 2x time instead of
/// 4x (T = 50 ms of wall time) with a 40 ms reply timeout (45 ms budget), so that the board
/// answers the start-up writes in time, and the link and power hold long enough
/// (`link_hold_periods`, `invalid_power_periods` = 1000) that a late reply holds the
/// override instead of ending the run. For the tests whose subject is not the link's timing,
/// against `acc board-sim --pace controller` (whose machine moves with the controller's
/// writes, whatever its `--time-scale`).
pub fn load_tolerant_config(dir: &Path, extra: &str) -> PathBuf {
    let cfg_dir = root().join("configs/runtime");
    let text = std::fs::read_to_string(cfg_dir.join("board_sim_fast.toml")).expect("config");
    let abs = |rel: &str| format!("{:?}", cfg_dir.join(rel).to_string_lossy());
    let mut set = 0;
    let lines: Vec<String> = text
        .lines()
        .map(|l| match l.split_once(" = ").map(|(k, _)| k) {
            Some(k @ ("link_hold_periods" | "invalid_power_periods")) => {
                set += 1;
                format!("{k} = 1000")
            }
            Some(k @ ("time_scale" | "timeout_ms" | "budget_ms")) => {
                set += 1;
                let v = match k {
                    "time_scale" => "2.0",
                    "timeout_ms" => "40",
                    _ => "45",
                };
                format!("{k} = {v}")
            }
            Some("controller") => format!("controller = {}", abs("../presets/case3.toml")),
            Some("calibration") => format!("calibration = {}", abs("paper_vmc_power.toml")),
            _ => l.to_string(),
        })
        .collect();
    assert_eq!(set, 5, "board_sim_fast.toml: the hold, time and link keys");
    let path = dir.join("run_tolerant.toml");
    std::fs::write(&path, format!("{}\n{extra}", lines.join("\n"))).expect("write config");
    path
}

/// Start `acc run --config <config> --port <pty> --log <log>`.
pub fn spawn_run(config: &str, pty: &str, log: &Path) -> Proc {
    Proc::spawn(
        &[
            "run",
            "--config",
            config,
            "--port",
            pty,
            "--log",
            &log.to_string_lossy(),
        ],
        false,
    )
}

/// Start `acc run --config <config> --port <pty> --log <log> --duration-s <secs>` plus
/// `extra` arguments (it ends by itself after `secs` of machine time).
pub fn spawn_run_for(config: &str, pty: &str, log: &Path, secs: &str, extra: &[&str]) -> Proc {
    let log = log.to_string_lossy();
    let mut args = vec![
        "run",
        "--config",
        config,
        "--port",
        pty,
        "--log",
        &log,
        "--duration-s",
        secs,
    ];
    args.extend_from_slice(extra);
    Proc::spawn(&args, false)
}

/// Ctrl-C to `acc run`; it must exit 0. Returns its stdout and stderr lines.
pub fn interrupt_expect_clean_exit(run: Proc) -> (String, Vec<String>) {
    run.sigint();
    let (code, out, err) = run.finish(Duration::from_secs(10));
    assert_eq!(
        code,
        Some(0),
        "acc run exit code; stdout:\n{out}\nstderr:\n{err:?}"
    );
    (out, err)
}

/// `true` if the peer is usable; otherwise print the skip reason (or panic under `CI`).
pub fn peer_ready(what: &str, check: &mut Command) -> bool {
    let ok = check
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        if std::env::var_os("CI").is_some() {
            panic!("{what} is not installed but CI is set: run `bash .ci/deps`");
        }
        eprintln!("SKIP: {what} is not installed (run `bash .ci/deps`); interop test not run");
    }
    ok
}

/// The wall-paced closed loops of one test binary (the board on its own ticker, the link's
/// timing under test: the fault matrix, the fault schedule, the pymodbus stand-in, the
/// reconnects) take this lock and run one at a time: two such pairs faster than real time
/// on a 2-core machine would slip each other's timing. A pair whose board moves with the
/// controller's writes (`--pace controller`, the run config made tolerant of a loaded host:
/// [`load_tolerant_config`]) runs the same whatever runs beside it, and takes no lock.
pub fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());
    SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The pocket program `tests/nc/pocket_rect.ngc` on a box stock (`X0,Y0,Z0,X1,Y1,Z1`, mm,
/// 0.25 mm cells), with `sc`'s tool, spindle speed and rapid rate.
pub fn pocket_program(sc: &acc_sim::Scenario, stock_box: &str) -> acc_sim::program::ProgramPath {
    program_path(
        sc,
        &root().join("tests/nc/pocket_rect.ngc"),
        stock_box,
        0.25,
    )
}

/// `law` on the program `path` with `sc` (the program's scenario), as `acc sim --program`
/// runs it: the board's engagement source is the program; with `plan` that plan's
/// look-ahead, as `--plan`.
pub fn run_program(
    sc: &acc_sim::Scenario,
    path: &acc_sim::program::ProgramPath,
    law: &mut dyn acc_core::OverrideLaw,
    plan: Option<acc_runtime::Plan>,
) -> acc_sim::RunResult {
    acc_sim::oracle_program::run_program(sc, path, law, plan).expect("run")
}

/// The program `file` on a box stock (`X0,Y0,Z0,X1,Y1,Z1`, mm, cells of `cell_mm`), with
/// `sc`'s tool, spindle speed and rapid rate.
pub fn program_path(
    sc: &acc_sim::Scenario,
    file: &Path,
    stock_box: &str,
    cell_mm: f64,
) -> acc_sim::program::ProgramPath {
    use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
    let spec = ProgramSpec {
        program: file.to_path_buf(),
        stock: StockSource::Box(stock_box.parse().expect("box"), cell_mm),
        tools: None,
    };
    ProgramPath::for_scenario(&spec, sc).expect("program")
}

/// Run `acc <args>` from the repository root to its end: (exit 0, stdout, stderr). An
/// analysis traces its plant on one thread (`ACC_TRACE_THREADS=1`): in this binary it
/// runs beside the wall-paced closed loops, whose two processes need the other core.
pub fn acc_output(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(acc_bin())
        .env("ACC_TRACE_THREADS", "1")
        .args(args)
        .current_dir(root())
        .output()
        .expect("run acc");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
