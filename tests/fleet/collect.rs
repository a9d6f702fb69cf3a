//! `acc collect` against a real `mosquitto` broker: three machines (`acc sim --mqtt
//! mqtt://…/fleet/<machine>`) publish, the collector writes the store, and DuckDB — an
//! engine we did not write — reads the collected files: per machine its period count and
//! Kc sum equal the run log's, its cuts and time saved equal the machine's tool history.
//! A second test restarts the broker in the middle of the runs: no cut is lost.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use crate::e2e_support::{acc_bin, read_log, root, Proc};
use crate::fleet_support::{assert_same, by_datafusion, by_python, by_run_logs};
use crate::mqtt_support::{free_port, mosquitto_ready, write_conf, write_persistent_conf, Broker};

/// Three machines, each one `acc sim` run of `two_tools` (two cuts) with its own seed.
const MACHINES: [(&str, &str); 3] = [("mill-a", "11"), ("mill-b", "12"), ("mill-c", "13")];

/// `acc collect` into `out` from `port`, committing every 0.5 s; waits until it connects.
fn start_collector(port: u16, out: &Path) -> Proc {
    let mut collect = Proc::spawn(
        &[
            "collect",
            "--mqtt",
            &format!("mqtt://127.0.0.1:{port}/fleet"),
            "--out",
            &out.to_string_lossy(),
            "--commit-s",
            "0.5",
        ],
        false,
    );
    assert!(
        collect.wait_for("collector connected", Duration::from_secs(30)),
        "the collector did not connect: {:?}",
        collect.err_lines
    );
    collect
}

/// Start one `acc sim` per machine publishing to `port` at `time_scale`.
fn start_machines(dir: &Path, port: u16, time_scale: &str) -> Vec<Child> {
    MACHINES
        .iter()
        .map(|(m, seed)| {
            let out = dir.join(m);
            Command::new(acc_bin())
                .args(["sim", "two_tools", "--no-plot", "--seed", seed])
                .args(["--time-scale", time_scale])
                .args(["--mqtt", &format!("mqtt://127.0.0.1:{port}/fleet/{m}")])
                .arg("--out")
                .arg(&out)
                .arg("--history")
                .arg(out.join("history.sqlite"))
                .current_dir(root())
                .stdout(std::fs::File::create(dir.join(format!("{m}.out"))).expect("stdout"))
                .stderr(std::fs::File::create(dir.join(format!("{m}.err"))).expect("stderr"))
                .spawn()
                .expect("acc sim")
        })
        .collect()
}

/// Wait until the store's cut count reaches `cuts` (the collector commits every 0.5 s),
/// then stop the collector; returns its summary line.
fn stop_collector_when(collect: Proc, store: &Path, cuts: u64) -> String {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(60) {
        let have: u64 = if store.join("cut").is_dir() {
            by_datafusion(store).values().map(|m| m.cuts).sum()
        } else {
            0
        };
        if have >= cuts {
            break;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    collect.sigint();
    let (code, out, err) = collect.finish(Duration::from_secs(30));
    assert_eq!(code, Some(0), "{out}\n{err:?}");
    out.lines()
        .find(|l| l.starts_with("collected:"))
        .unwrap_or_else(|| panic!("no summary: {out}"))
        .to_string()
}

fn machine_names() -> Vec<&'static str> {
    MACHINES.iter().map(|(m, _)| *m).collect()
}

#[test]
fn three_machines_publish_and_duckdb_sums_of_the_collected_store_equal_the_run_logs() {
    if !mosquitto_ready() {
        return;
    }
    let _ = acc_bin();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let _broker = Broker::start(&write_conf(dir.path(), port), port);
    let store = dir.path().join("collected");
    let collect = start_collector(port, &store);
    for mut s in start_machines(dir.path(), port, "5") {
        assert!(s.wait().expect("acc sim").success());
    }
    let logs = by_run_logs(dir.path(), &machine_names());
    let cuts: u64 = logs.values().map(|m| m.cuts).sum();
    let summary = stop_collector_when(collect, &store, cuts);
    let mut df = by_datafusion(&store);
    df.values_mut().for_each(|m| m.kc_trend.clear());
    assert_same("collected store (DataFusion) vs run logs", &df, &logs);
    for m in logs.values() {
        assert!(m.periods > 300 && m.cuts >= 2, "{m:?}");
    }
    if let Some(mut duck) = by_python("duckdb", &store) {
        duck.values_mut().for_each(|m| m.kc_trend.clear());
        assert_same("collected store (DuckDB) vs run logs", &duck, &logs);
    }
    println!("{summary}");
}

/// The periods each machine's run log holds, by machine.
fn log_periods(dir: &Path) -> Vec<(String, usize)> {
    machine_names()
        .into_iter()
        .map(|m| (m.to_string(), read_log(&dir.join(m).join("run.csv")).len()))
        .collect()
}

#[test]
fn a_broker_restart_in_the_middle_of_the_runs_loses_no_cut() {
    if !mosquitto_ready() {
        return;
    }
    let _ = acc_bin();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let conf: PathBuf = write_persistent_conf(dir.path(), port);
    let mut broker = Broker::start(&conf, port);
    let store = dir.path().join("collected");
    let collect = start_collector(port, &store);
    // 60 s of machine time at 4x: 15 s. Each machine's first cut ends at about 24.5 s of
    // machine time (6 s of wall time), while the broker is down (3 s to 9 s).
    let sims = start_machines(dir.path(), port, "4");
    let outage = Duration::from_secs(6);
    std::thread::sleep(Duration::from_secs(3));
    broker.terminate();
    std::thread::sleep(outage);
    let _broker = Broker::start(&conf, port);
    for mut s in sims {
        assert!(s.wait().expect("acc sim").success());
    }
    let logs = by_run_logs(dir.path(), &machine_names());
    let cuts: u64 = logs.values().map(|m| m.cuts).sum();
    let summary = stop_collector_when(collect, &store, cuts);
    let got = by_datafusion(&store);
    for (m, want) in &logs {
        let have = got.get(m).unwrap_or_else(|| panic!("{m} missing: {got:?}"));
        assert_eq!(
            have.cuts,
            want.cuts,
            "{m}: every cut reaches the store; collector: {summary}; machine: {}",
            std::fs::read_to_string(dir.path().join(format!("{m}.out"))).unwrap_or_default()
        );
        assert!(
            crate::fleet_support::close(have.time_saved_s, want.time_saved_s),
            "{m}: time saved {} vs {}",
            have.time_saved_s,
            want.time_saved_s
        );
        // Periods (QoS 0) sent while the broker was down are lost to the store, not to the
        // run log: at most the outage's periods (4x time, 10 periods/s) and a margin.
        let lost = want.periods.saturating_sub(have.periods);
        let outage_periods = (outage.as_secs_f64() * 4.0 * 10.0) as u64;
        assert!(
            have.periods <= want.periods && lost <= outage_periods + 40,
            "{m}: {} of {} periods stored (lost {lost}, outage {outage_periods})",
            have.periods,
            want.periods
        );
    }
    println!("{summary}; run logs {:?}", log_periods(dir.path()));
}
