//! Rows without a valid measurement in a production log: the board gone before the log
//! ends. `acc run` keeps writing a row every period, with `link:<kind>` in `flags` and
//! empty status cells, which the reader fills with the last known value. Those rows are
//! replayed but never compared: the sealed part moves onto the valid rows, the report
//! counts what was left out, and a log with too few valid rows is refused.

use std::path::Path;

use acc_ident::engagement::PathEngagement;
use acc_ident::model::Channel;
use acc_ident::{runlog, twin, workflow};
use acc_runtime::RunRecord;

/// A production-style log of `acc sim`'s closed loop (paper case III on `steps_1_2_3`, to
/// the end of the workpiece): the production columns only, no plant truth, and `dead_tail`
/// more periods after the run in which the board is gone — each row as `acc run` writes it
/// when the status read fails.
fn production_rows(dead_tail: usize) -> (acc_sim::Scenario, Vec<RunRecord>) {
    let dir = acc_sim::run::configs_dir();
    production_rows_on(
        acc_sim::Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece"),
        dead_tail,
    )
}

/// [`production_rows`] on another workpiece.
fn production_rows_on(
    workpiece: acc_sim::Workpiece,
    dead_tail: usize,
) -> (acc_sim::Scenario, Vec<RunRecord>) {
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    sc.workpiece = workpiece;
    sc.max_time_s = 120.0;
    let mut law = sc.build_law(acc_sim::LawKind::Ours).expect("law");
    let res = acc_sim::run(&sc, law.as_mut(), acc_sim::RunSetup::default()).expect("run");
    let mut rows: Vec<RunRecord> = res
        .rows
        .into_iter()
        .map(acc_sim::truth::without_truth)
        .collect();
    let tail = board_gone(&rows, dead_tail, "disconnected");
    rows.extend(tail);
    (sc, rows)
}

/// `periods` rows after `rows` in which the board is gone, as `PeriodRecord::record` writes
/// them with the link in error (`link:<kind>`): no status, so no speed, power, force or
/// override; the loop carries its feed and path.
fn board_gone(rows: &[RunRecord], periods: usize, kind: &str) -> Vec<RunRecord> {
    let last = rows.last().expect("rows");
    let dt = rows[1].t_s - rows[0].t_s;
    (1..=periods)
        .map(|k| {
            let mut r = RunRecord {
                t_s: last.t_s + k as f64 * dt,
                period: last.period + k as u64,
                x_mm: last.x_mm,
                programmed_feed_mm_min: last.programmed_feed_mm_min,
                feed_mm_min: last.feed_mm_min,
                force_ref_n: last.force_ref_n,
                state: "link_lost".into(),
                alarms: 1,
                ..RunRecord::default()
            };
            r.flag(&format!("link:{kind}"));
            r
        })
        .collect()
}

/// The rows as `acc discrepancy --workpiece` reads them, with its options.
fn read(
    sc: &acc_sim::Scenario,
    rows: &[RunRecord],
    channel: Channel,
) -> (acc_ident::Model, acc_ident::RunLog, workflow::Options) {
    read_at(sc, rows, channel, 0.0)
}

/// [`read`] with the first row's position given (`--x0-mm`): `acc sim`'s first row
/// is a period of travel from the workpiece's start, so at its own position the replay is
/// exact.
fn read_at(
    sc: &acc_sim::Scenario,
    rows: &[RunRecord],
    channel: Channel,
    x0_mm: f64,
) -> (acc_ident::Model, acc_ident::RunLog, workflow::Options) {
    let model = twin::model_for_scenario(sc, channel);
    let eng = PathEngagement {
        workpiece: sc.workpiece.clone(),
        source: "steps_1_2_3.toml".into(),
        tool_diameter_mm: model.tool.diameter_mm,
        x0_mm,
    };
    let log = runlog::from_records_with(rows, Path::new("run.csv"), Some(&eng)).expect("log");
    let opts = workflow::Options {
        workpiece: Some((sc.workpiece.clone(), 0.0)),
        anchor_to_log: true,
        ..workflow::Options::default()
    };
    (model, log, opts)
}

#[test]
fn a_dead_tail_is_left_out_and_the_sealed_part_moves_onto_valid_rows() {
    let (sc, live) = production_rows(0);
    let n_live = live.len();
    // More dead rows than the sealed fraction: before, the sealed part was the dead tail
    // alone ("Sealed part: RMS 0.000 → 0.000 N, fit 0.0 %").
    let dead = n_live / 3;
    let (_, rows) = production_rows(dead);
    let t_dead = rows[n_live].t_s;
    for ch in [Channel::Force, Channel::Power] {
        let (model, log, opts) = read(&sc, &rows, ch);
        let a = workflow::analyse(&model, &log, &opts).expect("analysed");
        let r = &a.report;
        let lost = r
            .input
            .excluded_rows
            .iter()
            .find(|e| e.reason == "link_lost")
            .unwrap_or_else(|| panic!("{ch:?}: {:?}", r.input.excluded_rows));
        assert_eq!(lost.rows, dead, "{ch:?}");
        assert_eq!(lost.first_line, n_live + 2, "{ch:?}");
        assert!(
            r.sealed.to_s < t_dead,
            "{ch:?}: sealed to {} s",
            r.sealed.to_s
        );
        let valid = rows.len() - r.input.excluded_rows.iter().map(|e| e.rows).sum::<usize>();
        let expect = (0.2 * valid as f64).round() as usize;
        assert!(
            r.sealed.rows.abs_diff(expect) <= 1,
            "{ch:?}: {} rows sealed",
            r.sealed.rows
        );
        assert!(
            r.sealed.nominal.rms > 0.0 && r.sealed.nominal.fit_pct != 0.0,
            "{ch:?}: {:?}",
            r.sealed.nominal
        );
        assert!(
            r.conclusion.contains("have no valid measurement")
                && r.conclusion
                    .contains(&format!("{dead} link lost or board gone")),
            "{ch:?}: {}",
            r.conclusion
        );
        assert!(r.warnings.iter().any(|w| w.contains("link lost")), "{ch:?}");
    }
}

#[test]
fn a_log_with_too_few_valid_rows_is_refused_with_the_count() {
    // 60 live rows (fewer than the 80 five folds and a sealed part need), then the board
    // is gone for 500 more periods.
    let (sc, live) = production_rows(0);
    let mut rows: Vec<RunRecord> = live[..60].to_vec();
    let tail = board_gone(&rows, 500, "timeout");
    rows.extend(tail);
    let (model, log, opts) = read(&sc, &rows, Channel::Power);
    let e = workflow::analyse(&model, &log, &opts)
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("60 rows with a valid measurement of 560")
            && e.contains("at least 80")
            && e.contains("500 link lost or board gone")
            && e.contains("lines 62..=561"),
        "{e}"
    );
}

/// `periods` rows after `rows` in which the machine runs on in air, as a run logged on after
/// its part was finished: the readings of the run's first `lead` rows (air before the
/// first entry, noise included) over again, the path going on at the last row's feed.
fn air_after(rows: &[RunRecord], periods: usize, lead: usize) -> Vec<RunRecord> {
    let last = rows.last().expect("rows");
    let dt = rows[1].t_s - rows[0].t_s;
    let travel = last.feed_mm_min.unwrap_or(0.0) / 60.0 * dt;
    (1..=periods)
        .map(|k| RunRecord {
            t_s: last.t_s + k as f64 * dt,
            period: last.period + k as u64,
            x_mm: last.x_mm.map(|x| x + k as f64 * travel),
            feed_mm_min: last.feed_mm_min,
            programmed_feed_mm_min: last.programmed_feed_mm_min,
            override_cmd_pct: last.override_cmd_pct,
            override_applied_pct: last.override_applied_pct,
            ..rows[k % lead].clone()
        })
        .collect()
}

#[test]
fn a_long_air_tail_moves_the_sealed_part_onto_the_cutting_rows() {
    // A run logged on in air for half as long again after its part (board-sim with
    // `acc run --duration-s` past the part's end): the last 20 % of the rows hold no cut,
    // and a sealed part there judged nothing (a force channel reads zero: "Sealed part:
    // RMS 0.000 → 0.000 N").
    let (sc, mut rows) = production_rows(0);
    let n_live = rows.len();
    let lead = rows
        .iter()
        .position(|r| r.force_n.is_some_and(|f| f > 1.0))
        .expect("an entry")
        .saturating_sub(3);
    assert!(lead >= 10, "{lead} rows of air before the first entry");
    let tail = air_after(&rows, n_live / 2, lead);
    rows.extend(tail);
    let t_tail = rows[n_live].t_s;
    for ch in [Channel::Power, Channel::Force] {
        let x0 = rows[0].x_mm.expect("positions");
        let (model, log, opts) = read_at(&sc, &rows, ch, x0);
        let a = workflow::analyse(&model, &log, &opts).expect("analysed");
        let r = &a.report;
        assert!(
            r.sealed.from_s < t_tail - 5.0,
            "{ch:?}: sealed from {} s, air from {t_tail} s",
            r.sealed.from_s
        );
        assert!(
            r.sealed.nominal.rms > 0.0 && r.sealed.nominal.fit_pct > 90.0,
            "{ch:?}: {:?}",
            r.sealed.nominal
        );
        assert!(
            r.warnings.iter().any(|w| w.contains("hold no cutting row")),
            "{ch:?}: {:?}",
            r.warnings
        );
        assert!(r.accepted.is_empty(), "{ch:?}: named {:?}", r.accepted);
        assert!(r.unexplained.is_none(), "{ch:?}: {}", r.conclusion);
    }
}
