//! The fleet store written by `acc sim --fleet` for two machines, read by three engines:
//! `acc history query` (embedded DataFusion), and two we did not write, DuckDB and pyarrow
//! (`tests/peers/fleet_engines.py`). Per machine, the period rows equal the run log's rows,
//! the cuts and their time saved equal the SQLite tool history's, and every engine gives
//! the same counts, sums and Kc trend.

mod e2e_support;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use e2e_support::{acc_bin, peer_ready, read_log, root};

/// Two machines, each one `acc sim` run of `two_tools` (tools 1 and 2) with its own seed.
const MACHINES: [(&str, &str); 2] = [("mill-a", "11"), ("mill-b", "12")];

/// Run `acc` with `args`; panics with its output unless it succeeds. Returns stdout.
fn acc(args: &[&str]) -> String {
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
struct Machine {
    periods: u64,
    cuts: u64,
    time_saved_s: f64,
    kc_sum: f64,
    /// (UTC hour, mean Kc_hat of tool 1).
    kc_trend: Vec<(String, f64)>,
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * (1.0 + a.abs().max(b.abs()))
}

fn assert_same(what: &str, a: &BTreeMap<String, Machine>, b: &BTreeMap<String, Machine>) {
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
fn query_csv(store: &Path, sql: &str) -> Vec<Vec<String>> {
    let text = acc(&["history", "query", &store.to_string_lossy(), sql, "--csv"]);
    let mut r = csv::Reader::from_reader(text.as_bytes());
    r.records()
        .map(|x| x.expect("csv row").iter().map(str::to_string).collect())
        .collect()
}

/// The figures by `acc history query` (DataFusion).
fn by_datafusion(store: &Path) -> BTreeMap<String, Machine> {
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
fn by_python(engine: &str, store: &Path) -> Option<BTreeMap<String, Machine>> {
    let script = root().join("tests/peers/fleet_engines.py");
    let module = if engine == "duckdb" {
        "duckdb"
    } else {
        "pyarrow.dataset"
    };
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
fn by_run_logs(dir: &Path) -> BTreeMap<String, Machine> {
    let mut out = BTreeMap::new();
    for (m, _) in MACHINES {
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

#[test]
fn engines_we_did_not_write_read_the_store_of_acc_sim_runs() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let store = tmp.path().join("store");
    for (m, seed) in MACHINES {
        let out = tmp.path().join(m);
        let text = acc(&[
            "sim",
            "two_tools",
            "--seed",
            seed,
            "--no-plot",
            "--out",
            &out.to_string_lossy(),
            "--history",
            &out.join("history.sqlite").to_string_lossy(),
            "--fleet",
            &store.to_string_lossy(),
            "--machine",
            m,
        ]);
        assert!(text.contains(&format!("of machine {m}")), "{text}");
    }
    let logs = by_run_logs(tmp.path());
    let df = by_datafusion(&store);
    // The trend is the store's own (the run log has no wall-clock time): compare the rest.
    let mut df_no_trend = df.clone();
    df_no_trend.values_mut().for_each(|m| m.kc_trend.clear());
    assert_same(
        "DataFusion vs run logs and tool history",
        &df_no_trend,
        &logs,
    );
    for m in logs.values() {
        assert!(m.periods > 300 && m.cuts >= 2, "{m:?}");
    }
    for m in df.values() {
        assert!(!m.kc_trend.is_empty(), "tool 1 has a Kc trend: {m:?}");
    }
    for engine in ["duckdb", "pyarrow"] {
        if let Some(other) = by_python(engine, &store) {
            assert_same(&format!("{engine} vs DataFusion"), &other, &df);
        }
    }
}

#[test]
fn a_corrupt_file_a_newer_schema_and_bad_sql_each_get_one_line() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let store = tmp.path().join("store");
    let s = store.to_string_lossy().into_owned();
    acc(&[
        "sim",
        "two_tools",
        "--no-plot",
        "--out",
        &tmp.path().join("m").to_string_lossy(),
        "--history",
        &tmp.path().join("h.sqlite").to_string_lossy(),
        "--fleet",
        &s,
        "--machine",
        "m1",
    ]);
    let fail = |sql: &str| {
        let out = Command::new(acc_bin())
            .args(["history", "query", &s, sql])
            .output()
            .expect("acc");
        assert_eq!(out.status.code(), Some(2));
        String::from_utf8_lossy(&out.stderr).trim().to_string()
    };
    let e = fail("SELEC count(*) FROM period");
    assert!(
        e.starts_with("error: SQL:") && e.lines().count() == 1,
        "{e}"
    );
    let bad = store.join("cut/machine=m1/date=2026-01-01/broken.parquet");
    std::fs::create_dir_all(bad.parent().expect("parent")).expect("mkdir");
    std::fs::write(&bad, b"not parquet at all").expect("write");
    let e = fail("SELECT count(*) FROM period");
    assert!(
        e.contains("broken.parquet") && e.contains("not a readable Parquet file"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}
