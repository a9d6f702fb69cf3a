//! Wear and breakage watch on the simulated machine, through the production loop
//! (`acc_sim::run` = `ControlLoop` + `FaultPolicy` against `SimBoard`): a broken tool is
//! answered with feed hold within 2 periods; a spike likewise; the shipped scenarios (entry
//! peaks, hard inclusion, depth steps, wear) raise no breakage alarm.

use acc_runtime::record::RunRecord;
use acc_sim::run::configs_dir;
use acc_sim::{LawKind, Scenario};

/// Bit 5 of the run log's `alarms`: breakage.
const BREAKAGE_BIT: u8 = 1 << 5;

fn run(sc: &Scenario) -> Vec<RunRecord> {
    sc.run_law(LawKind::Ours).expect("run").0.rows
}

/// Periods from the break to the first row with the feed-hold request, and that row.
fn hold_delay(rows: &[RunRecord], at_s: f64, period_s: f64) -> (f64, RunRecord) {
    let first = rows
        .iter()
        .find(|r| r.feed_hold)
        .cloned()
        .expect("a feed hold was requested");
    ((first.t_s - at_s) / period_s, first)
}

#[test]
fn a_broken_tool_is_answered_with_feed_hold_within_2_periods() {
    let sc = Scenario::load(configs_dir().join("scenarios/tool_breakage.toml")).expect("scenario");
    let b = sc.breakage.expect("[breakage]");
    let rows = run(&sc);
    // Cutting steadily until the break, no hold before it.
    assert!(rows.iter().filter(|r| r.t_s < b.at_s).all(|r| !r.feed_hold));
    let (delay, row) = hold_delay(&rows, b.at_s, sc.controller.period_s);
    assert!(
        delay > 0.0 && delay <= 2.0 + 1e-9,
        "feed hold {delay:.2} periods after the break"
    );
    assert_eq!(row.alarms & BREAKAGE_BIT, BREAKAGE_BIT, "{row:?}");
    assert_eq!(row.state, "breakage");
    assert!(row.has_flag("fault"));
    assert!(row.has_flag("breakage"), "{}", row.flags);
    assert!(row.flags.contains("breakage:drop"), "{}", row.flags);
    // The release never raised the override.
    let before = rows
        .iter()
        .rev()
        .find(|r| r.t_s < row.t_s && r.override_cmd_pct.is_some())
        .and_then(|r| r.override_cmd_pct)
        .expect("a command before");
    assert!(row.override_cmd_pct.is_none_or(|c| c <= before));
}

#[test]
fn a_force_spike_is_answered_with_feed_hold_within_2_periods() {
    let mut sc =
        Scenario::load(configs_dir().join("scenarios/tool_breakage.toml")).expect("scenario");
    let at_s = 25.0;
    sc.breakage = Some(acc_sim::scenario::BreakageSpec {
        at_s,
        force_factor: 4.0,
    });
    let rows = run(&sc);
    let (delay, row) = hold_delay(&rows, at_s, sc.controller.period_s);
    assert!(
        delay > 0.0 && delay <= 2.0 + 1e-9,
        "feed hold {delay:.2} periods after the spike"
    );
    assert_eq!(row.alarms & BREAKAGE_BIT, BREAKAGE_BIT, "{row:?}");
    assert!(row.flags.contains("breakage:spike"), "{}", row.flags);
}

#[test]
fn shipped_scenarios_raise_no_breakage_alarm() {
    for name in [
        "paper_case1",
        "paper_case3",
        "paper_case4",
        "paper_fixed_gain",
        "interrupted",
        "hard_inclusion",
        "tool_wear",
    ] {
        let sc =
            Scenario::load(configs_dir().join(format!("scenarios/{name}.toml"))).expect("scenario");
        let rows = run(&sc);
        let hit = rows.iter().find(|r| r.alarms & BREAKAGE_BIT != 0);
        assert!(
            hit.is_none(),
            "{name}: false breakage alarm at {:?}",
            hit.map(|r| r.t_s)
        );
    }
}

#[test]
fn bad_breakage_and_watch_keys_name_file_key_and_range() {
    let dir = tempfile::tempdir().expect("tmp");
    let base = std::fs::read_to_string(configs_dir().join("scenarios/tool_breakage.toml"))
        .expect("scenario");
    let abs = configs_dir().join("scenarios").canonicalize().expect("dir");
    let base = base.replace("\"../", &format!("\"{}/../", abs.display()));
    for (from, to, key) in [
        ("at_s = 30.0", "at_s = -1.0", "breakage.at_s"),
        (
            "force_factor = 0.05",
            "force_factor = 11.0",
            "breakage.force_factor",
        ),
        (
            "[summary]",
            "[watch]\nbreakage_spike_factor = 0.5\n[summary]",
            "watch.breakage_spike_factor",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let p = dir.path().join("s.toml");
        std::fs::write(&p, base.replacen(from, to, 1)).expect("write");
        let e = Scenario::load(&p).expect_err(key).to_string();
        assert!(
            e.contains(&p.display().to_string()) && e.contains(key),
            "{key}: {e}"
        );
    }
}
