//! The fleet-store figures per machine as each engine gives them: `acc history query`
//! (embedded DataFusion), DuckDB and pyarrow (`tests/peers/fleet_engines.py`), and the
//! machines' own run logs and tool histories; shared by the fleet tests.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use super::e2e_support::{acc_bin, peer_ready, read_log, root};

/// Run `acc` with `args`; panics with its output unless it succeeds. Returns stdout.
pub fn acc(args: &[&str]) -> String {
    let out = Command::new(acc_bin())
        .args(args)
        .current_dir(root())
        .output()
        .expect("acc runs");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "acc {args:?} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// What one engine says about each machine.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Machine {
    pub periods: u64,
    pub cuts: u64,
    pub time_saved_s: f64,
    pub kc_sum: f64,
    /// (UTC hour, mean Kc_hat of tool 1).
    pub kc_trend: Vec<(String, f64)>,
}

pub fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * (1.0 + a.abs().max(b.abs()))
}

pub fn assert_same(what: &str, a: &BTreeMap<String, Machine>, b: &BTreeMap<String, Machine>) {
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "{what}: machines"
    );
    for (m, x) in a {
        let y = &b[m];
        assert_eq!((x.periods, x.cuts), (y.periods, y.cuts), "{what}: {m} rows");
        assert!(
            close(x.time_saved_s, y.time_saved_s),
            "{what}: {m} time saved {x:?} vs {y:?}"
        );
        assert!(
            close(x.kc_sum, y.kc_sum),
            "{what}: {m} kc sum {x:?} vs {y:?}"
        );
        assert_eq!(
            x.kc_trend.len(),
            y.kc_trend.len(),
            "{what}: {m} trend {x:?} vs {y:?}"
        );
        for ((h1, k1), (h2, k2)) in x.kc_trend.iter().zip(&y.kc_trend) {
            assert!(
                h1 == h2 && close(*k1, *k2),
                "{what}: {m} trend {x:?} vs {y:?}"
            );
        }
    }
}

/// CSV of `acc history query --csv` as rows of cells (header dropped).
pub fn query_csv(store: &Path, sql: &str) -> Vec<Vec<String>> {
    let text = acc(&["history", "query", &store.to_string_lossy(), sql, "--csv"]);
    let mut r = csv::Reader::from_reader(text.as_bytes());
    r.records()
        .map(|x| x.expect("csv row").iter().map(str::to_string).collect())
        .collect()
}

/// The figures by `acc history query` (DataFusion).
pub fn by_datafusion(store: &Path) -> BTreeMap<String, Machine> {
    let mut out: BTreeMap<String, Machine> = BTreeMap::new();
    let num = |s: &str| s.parse::<f64>().unwrap_or_else(|e| panic!("`{s}`: {e}"));
    for r in query_csv(
        store,
        "SELECT machine, count(*), sum(kc_hat) FROM period GROUP BY machine",
    ) {
        let m = out.entry(r[0].clone()).or_default();
        m.periods = r[1].parse().expect("count");
        m.kc_sum = num(&r[2]);
    }
    for r in query_csv(
        store,
        "SELECT machine, count(*), sum(time_saved_s) FROM cut GROUP BY machine",
    ) {
        let m = out.entry(r[0].clone()).or_default();
        m.cuts = r[1].parse().expect("count");
        m.time_saved_s = num(&r[2]);
    }
    for r in query_csv(
        store,
        "SELECT machine, to_char(date_trunc('hour', ts), '%Y-%m-%dT%H') AS hour, avg(kc_hat) \
         FROM period WHERE tool = 1 AND kc_hat IS NOT NULL GROUP BY 1, 2 ORDER BY 1, 2",
    ) {
        out.entry(r[0].clone())
            .or_default()
            .kc_trend
            .push((r[1].clone(), num(&r[2])));
    }
    out
}

/// The figures by an engine of `tests/peers/fleet_engines.py` (`None`: skipped).
pub fn by_python(engine: &str, store: &Path) -> Option<BTreeMap<String, Machine>> {
    let script = root().join("tests/peers/fleet_engines.py");
    let module = match engine {
        "duckdb" => "duckdb",
        "spark" => "pyspark",
        _ => "pyarrow.dataset",
    };
    if engine == "spark"
        && !peer_ready(
            "java (Spark runs on it; apt default-jre-headless)",
            Command::new("java").arg("-version"),
        )
    {
        return None;
    }
    if !peer_ready(
        &format!("python3 {engine}"),
        Command::new("python3").args(["-c", &format!("import {module}")]),
    ) {
        return None;
    }
    let out = Command::new("python3")
        .arg(&script)
        .args([engine, &store.to_string_lossy(), "1"])
        .output()
        .expect("python3");
    assert!(
        out.status.success(),
        "{engine}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let mut res = BTreeMap::new();
    for (m, x) in v.as_object().expect("object") {
        let f = |k: &str| x[k].as_f64().unwrap_or(0.0);
        res.insert(
            m.clone(),
            Machine {
                periods: x["periods"].as_u64().expect("periods"),
                cuts: x["cuts"].as_u64().unwrap_or(0),
                time_saved_s: f("time_saved_s"),
                kc_sum: f("kc_sum"),
                kc_trend: x["kc_trend"]
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .map(|p| {
                                (
                                    p[0].as_str().expect("hour").to_string(),
                                    p[1].as_f64().expect("kc"),
                                )
                            })
                            .collect()
                    })
                    .unwrap_or_default(),
            },
        );
    }
    Some(res)
}

/// The figures from each machine's own files: the run-log CSV (periods, Kc) and the SQLite
/// tool history (cuts, time saved).
pub fn by_run_logs(dir: &Path, machines: &[&str]) -> BTreeMap<String, Machine> {
    let mut out = BTreeMap::new();
    for m in machines {
        let rows = read_log(&dir.join(m).join("run.csv"));
        let db = rusqlite::Connection::open(dir.join(m).join("history.sqlite")).expect("history");
        let (cuts, saved): (u64, f64) = db
            .query_row("SELECT count(*), total(time_saved_s) FROM cuts", [], |r| {
                Ok((r.get(0)?, r.get(1)?))
            })
            .expect("cuts");
        out.insert(
            m.to_string(),
            Machine {
                periods: rows.len() as u64,
                cuts,
                time_saved_s: saved,
                kc_sum: rows
                    .iter()
                    .filter_map(|r| r.kc_hat)
                    .filter(|k| k.is_finite())
                    .sum(),
                kc_trend: Vec::new(),
            },
        );
    }
    out
}
