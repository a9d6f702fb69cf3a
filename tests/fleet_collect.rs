//! `acc collect` against a real `mosquitto` broker: two machines (`acc sim --mqtt
//! mqtt://…/fleet/<machine>`) publish, the collector writes the store, and per machine its
//! period rows equal the run log's rows and its cuts equal the store each machine wrote
//! beside its run (`--fleet`); DuckDB reads the collected store and agrees.

mod e2e_support;
mod mqtt_support;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use e2e_support::{acc_bin, read_log, root, Proc};
use mqtt_support::{free_port, mosquitto_ready, write_conf, Broker};

/// `acc history query --csv` as rows (header dropped); `None` while the store is missing.
fn query(store: &Path, sql: &str) -> Option<Vec<Vec<String>>> {
    let out = Command::new(acc_bin())
        .args(["history", "query", &store.to_string_lossy(), sql, "--csv"])
        .output()
        .expect("acc");
    if !out.status.success() {
        return None;
    }
    let mut r = csv::Reader::from_reader(out.stdout.as_slice());
    Some(
        r.records()
            .map(|x| x.expect("row").iter().map(str::to_string).collect())
            .collect(),
    )
}

const COUNTS: &str =
    "SELECT machine, (SELECT count(*) FROM period p WHERE p.machine = m.machine), \
    (SELECT count(*) FROM cut c WHERE c.machine = m.machine), \
    (SELECT sum(time_saved_s) FROM cut c WHERE c.machine = m.machine) \
    FROM (SELECT DISTINCT machine FROM period) m ORDER BY machine";

#[test]
fn two_machines_publish_and_acc_collect_writes_the_same_store() {
    if !mosquitto_ready() {
        return;
    }
    let _ = acc_bin();
    let dir = tempfile::tempdir().expect("tempdir");
    let port = free_port();
    let _broker = Broker::start(&write_conf(dir.path(), port), port);
    let collected = dir.path().join("collected");
    let direct = dir.path().join("direct");
    let mut collect = Proc::spawn(
        &[
            "collect",
            "--mqtt",
            &format!("mqtt://127.0.0.1:{port}/fleet"),
            "--out",
            &collected.to_string_lossy(),
            "--commit-s",
            "0.5",
        ],
        false,
    );
    assert!(
        collect.wait_for("collector connected", Duration::from_secs(20)),
        "the collector did not connect: {:?}",
        collect.err_lines
    );
    let machines = [("mill-a", "11"), ("mill-b", "12")];
    let sims: Vec<_> = machines
        .iter()
        .map(|(m, seed)| {
            Command::new(acc_bin())
                .args([
                    "sim",
                    "two_tools",
                    "--no-plot",
                    "--time-scale",
                    "20",
                    "--seed",
                    seed,
                ])
                .args(["--mqtt", &format!("mqtt://127.0.0.1:{port}/fleet/{m}")])
                .arg("--out")
                .arg(dir.path().join(m))
                .arg("--history")
                .arg(dir.path().join(m).join("h.sqlite"))
                .args(["--fleet", &direct.to_string_lossy(), "--machine", m])
                .current_dir(root())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("acc sim")
        })
        .collect();
    for mut s in sims {
        assert!(s.wait().expect("acc sim").success());
    }
    let want = query(&direct, COUNTS).expect("direct store");
    for ((m, _), row) in machines.iter().zip(&want) {
        let log = read_log(&dir.path().join(m).join("run.csv"));
        assert_eq!(row[0], *m);
        assert_eq!(
            row[1],
            log.len().to_string(),
            "{m}: --fleet rows = run log rows"
        );
    }
    // Every period and cut reaches the collector's store (commits every 0.5 s).
    let t0 = Instant::now();
    let got = loop {
        let got = query(&collected, COUNTS);
        if got.as_ref() == Some(&want) || t0.elapsed() > Duration::from_secs(30) {
            break got;
        }
        std::thread::sleep(Duration::from_millis(300));
    };
    collect.sigint();
    let (code, out, err) = collect.finish(Duration::from_secs(20));
    assert_eq!(code, Some(0), "{out}\n{err:?}");
    let got = got.expect("collected store");
    assert_eq!(got.len(), 2, "{got:?}");
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(
            g[..3],
            w[..3],
            "machine, periods, cuts: collected vs run log"
        );
        let (a, b): (f64, f64) = (g[3].parse().expect("f64"), w[3].parse().expect("f64"));
        assert!(
            (a - b).abs() < 1e-6,
            "time saved: collected {a} vs direct {b}"
        );
    }
    assert!(out.contains("collected:"), "{out}");
}
