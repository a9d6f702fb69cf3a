//! Bench binary: `acc discrepancy --program` on the first 10 minutes of a LinuxCNC run log
//! (issue target: within 10 s on 2 cores, release). The log is one `acc linuxcnc` wrote
//! (docs/twin-linuxcnc.md, "Speed", has the command); its path is
//! `ACC_BENCH_LINUXCNC_LOG`, with `ACC_BENCH_LINUXCNC_PROGRAM` and
//! `ACC_BENCH_LINUXCNC_STOCK` (the `--stock-box`) for another program than the inside
//! corners. Without the log the bench says why and measures nothing.
//!
//! `ACC_BENCH_LINUXCNC_LOG=/tmp/ic/lcnc/run.csv cargo bench -p acc-cli --bench discrepancy_linuxcnc`

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Rows of a 10-minute log at T = 0.1 s.
const TEN_MINUTES_ROWS: usize = 6000;
/// Timed runs; the median is reported.
const RUNS: usize = 3;
/// The target, s.
const TARGET_S: f64 = 10.0;

fn main() {
    let Some(log) = std::env::var_os("ACC_BENCH_LINUXCNC_LOG").map(PathBuf::from) else {
        println!(
            "discrepancy_linuxcnc: skipped, ACC_BENCH_LINUXCNC_LOG is not set (a run log \
             of `acc linuxcnc`; docs/twin-linuxcnc.md, \"Speed\")"
        );
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let program = std::env::var_os("ACC_BENCH_LINUXCNC_PROGRAM")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("../shared/data/nc/linuxcnc_inside_corners.ngc"));
    let stock = std::env::var("ACC_BENCH_LINUXCNC_STOCK")
        .unwrap_or_else(|_| "-13,-13,-5,102,107,0".to_string());
    let text = std::fs::read_to_string(&log)
        .unwrap_or_else(|e| panic!("ACC_BENCH_LINUXCNC_LOG {}: {e}", log.display()));
    let rows = text.lines().count().saturating_sub(1);
    let kept: Vec<&str> = text.lines().take(TEN_MINUTES_ROWS + 1).collect();
    let dir = tempfile::tempdir().expect("temporary directory");
    let ten = dir.path().join("run10.csv");
    std::fs::write(&ten, kept.join("\n") + "\n").expect("write the 10-minute log");
    let mut times = Vec::new();
    for k in 0..RUNS {
        let out = dir.path().join(format!("out{k}"));
        let t0 = Instant::now();
        let status = Command::new(env!("CARGO_BIN_EXE_acc"))
            .arg("discrepancy")
            .arg("--model")
            .arg(root.join("configs/models/linuxcnc_paper_vmc.toml"))
            .arg("--measured")
            .arg(&ten)
            .arg("--program")
            .arg(&program)
            .arg(format!("--stock-box={stock}"))
            .arg("--out")
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .status()
            .expect("run acc discrepancy");
        let s = t0.elapsed().as_secs_f64();
        assert!(status.success(), "acc discrepancy failed: {status}");
        println!("run {}: {s:.2} s", k + 1);
        times.push(s);
    }
    times.sort_by(f64::total_cmp);
    let median = times[RUNS / 2];
    println!(
        "acc discrepancy --program on {} of {rows} rows of {}: median {median:.2} s over {RUNS} runs \
         (target {TARGET_S} s: {})",
        kept.len() - 1,
        log.display(),
        if median <= TARGET_S { "met" } else { "not met" }
    );
}
