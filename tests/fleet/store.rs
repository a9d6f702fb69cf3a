//! The fleet store written by `acc sim --fleet` for two machines, read by four engines:
//! `acc history query` (embedded DataFusion), and three we did not write, DuckDB, pyarrow
//! and Spark in local mode (`tests/peers/fleet_engines.py`). Per machine, the period rows equal the run log's rows,
//! the cuts and their time saved equal the SQLite tool history's, and every engine gives
//! the same counts, sums and Kc trend.

use std::process::Command;

use crate::e2e_support::acc_bin;
use crate::fleet_support::{acc, assert_same, by_datafusion, by_python, by_run_logs};

/// Two machines, each one `acc sim` run of `two_tools` (tools 1 and 2) with its own seed.
const MACHINES: [(&str, &str); 2] = [("mill-a", "11"), ("mill-b", "12")];

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
    let logs = by_run_logs(tmp.path(), &MACHINES.map(|(m, _)| m));
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
    for engine in ["duckdb", "pyarrow", "spark"] {
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
