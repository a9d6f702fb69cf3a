//! The tool history (SQLite) survives a restart: the Kc trend of a worn tool written by one
//! run continues in the next from the same fresh reference; a file of a newer schema version
//! is refused with an error naming the file and both versions.

use acc_runtime::history::{History, Watch, SCHEMA_VERSION};
use acc_runtime::watch::{WatchLimits, WearLevel};
use acc_sim::run::configs_dir;
use acc_sim::{LawKind, Scenario};

#[test]
fn the_wear_trend_continues_across_a_restart() {
    let sc = Scenario::load(configs_dir().join("scenarios/tool_wear.toml")).expect("scenario");
    let rows = sc.run_law(LawKind::Ours).expect("run").0.rows;
    let half = rows.len() / 2;
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("acc-history.sqlite");
    let period = sc.controller.period_s;

    // Run 1: the first half of the worn tool's cut; then the process ends.
    let first_last = {
        let mut h = History::open(&path).expect("create");
        let run = h.begin_run("first").expect("run");
        let mut w = Watch::new(WatchLimits::default(), period);
        w.continue_from(&h).expect("refs");
        for it in w.run_all(&rows[..half]) {
            h.add(run, &it).expect("store");
        }
        let t = h.wear_trend(1).expect("trend");
        assert!(t.len() >= 5, "{} trend points", t.len());
        assert!(
            t[0].rise_pct.abs() < 1e-9,
            "the first point is the fresh reference"
        );
        t.last().expect("point").rise_pct
    };

    // Run 2, a new process: the same file; the second half continues the trend.
    let mut h = History::open(&path).expect("reopen");
    assert_eq!(h.run_count().expect("runs"), 1);
    let run = h.begin_run("second").expect("run");
    let mut w = Watch::new(WatchLimits::default(), period);
    w.continue_from(&h).expect("refs");
    let items = w.run_all(&rows[half..]);
    for it in &items {
        h.add(run, it).expect("store");
    }
    let trend = h.wear_trend(1).expect("trend");
    let second: Vec<_> = trend.iter().filter(|p| p.run == run).collect();
    assert!(!second.is_empty());
    // Measured against the stored reference, not a new one: the rise goes on from where the
    // first run stopped, and the worn tool reaches the warning level.
    assert!(
        second[0].rise_pct >= first_last - 1.0,
        "restart: {:.1} % after {:.1} %",
        second[0].rise_pct,
        first_last
    );
    let last = trend.last().expect("point");
    assert!(last.rise_pct > 30.0, "Kc rise {:.1} %", last.rise_pct);
    assert_eq!(last.level, WearLevel::Warn.as_str());
    assert!(h.count("cuts").expect("cuts") >= 2);
    assert!(
        h.count("alarms").expect("alarms") >= 1,
        "the wear warning is stored"
    );
    drop(h);

    // A newer schema version (a file written by a newer acc) is refused.
    rusqlite::Connection::open(&path)
        .and_then(|c| {
            c.execute(
                "UPDATE schema_version SET version = ?1",
                [SCHEMA_VERSION + 1],
            )
        })
        .expect("bump the schema version");
    let e = History::open(&path).expect_err("newer schema refused");
    let msg = e.to_string();
    assert!(
        msg.contains("acc-history.sqlite")
            && msg.contains(&(SCHEMA_VERSION + 1).to_string())
            && msg.contains(&SCHEMA_VERSION.to_string()),
        "{msg}"
    );
}
