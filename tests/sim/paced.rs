//! `acc sim --step-stdin`: a run paced from outside (the end-to-end tests' way of pacing a
//! simulated run instead of racing a wall-clock one) stands where it is told to and ends
//! with the same run log, byte for byte, as the run at full speed.

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::e2e_support::{acc_bin, root};

fn sim(out: &std::path::Path, extra: &[&str]) -> std::process::Child {
    Command::new(acc_bin())
        .args(["sim", "paper_case1", "--no-plot", "--out"])
        .arg(out)
        .args(extra)
        .current_dir(root())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn acc sim")
}

#[test]
fn a_run_paced_from_stdin_stops_where_told_and_ends_the_same() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (fast, paced) = (dir.path().join("fast"), dir.path().join("paced"));
    let mut a = sim(&fast, &[]);
    drop(a.stdin.take());
    assert!(a.wait().expect("acc sim").success());

    let mut b = sim(&paced, &["--step-stdin"]);
    let mut steps = b.stdin.take().expect("stdin");
    writeln!(steps, "30").expect("step");
    // It stands at 30 periods: the log (flushed per row) has 30 rows and no more.
    let log = paced.join("run.csv");
    let rows = || {
        std::fs::read_to_string(&log)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0)
    };
    let mut waited = 0;
    while rows() < 30 && waited < 300 {
        std::thread::sleep(Duration::from_millis(50));
        waited += 1;
    }
    assert_eq!(rows(), 30, "the run went to the 30 periods allowed");
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(rows(), 30, "and stood there");
    assert!(b.try_wait().expect("status").is_none(), "still running");
    writeln!(steps, "all").expect("step");
    drop(steps);
    assert!(b.wait().expect("acc sim").success());

    let fast_log = std::fs::read(fast.join("run.csv")).expect("fast log");
    let paced_log = std::fs::read(paced.join("run.csv")).expect("paced log");
    assert!(fast_log.len() > 10_000);
    assert!(
        fast_log == paced_log,
        "the paced run differs from the fast one"
    );
}
