//! Entry and exit control of the shop layer (docs/shop.md "Entry control") through the
//! production loop on the simulated machine: learning across runs, the issue-14 figures
//! on the interrupted-cut and hard-inclusion scenarios, and why the interrupted cut's RMS
//! target cannot be met.

use acc_runtime::{RunRecord, ShopControl};
use acc_sim::summary::{attribute_rows, summarize};
use acc_sim::{LawKind, Scenario};

fn scenario(name: &str) -> Scenario {
    Scenario::load(acc_sim::run::configs_dir().join(format!("scenarios/{name}.toml")))
        .expect("scenario loads")
}

/// One pass of `sc` with `shop` through the production loop.
fn pass(sc: &Scenario, mut shop: ShopControl) -> (acc_sim::RunResult, ShopControl) {
    let mut law = sc.build_law(LawKind::Ours).expect("law");
    let mut channel = sc.build_channel().expect("channel");
    let setup = acc_sim::RunSetup {
        channel: Some(channel.as_mut()),
        shop: acc_sim::ShopLayer::Given(&mut shop),
        ..acc_sim::RunSetup::default()
    };
    let res = acc_sim::run(sc, law.as_mut(), setup).expect("runs");
    assert!(res.finished, "the pass reaches the end of the path");
    (res, shop)
}

/// Peak measured force over the first `n` periods from the entry into `block`, N.
fn entry_peak(rows: &[RunRecord], block: u16, n: usize) -> f64 {
    let i = rows
        .iter()
        .position(|r| r.block == Some(block) && r.flags.contains("entry"))
        .expect("an entry in the block");
    rows[i..i + n]
        .iter()
        .filter_map(|r| r.force_n)
        .fold(0.0, f64::max)
}

/// Two passes of the interrupted cut with `table`, the second starting from what the
/// first learned: (first pass, second pass, the first pass's shop layer, tool, block of
/// the first entry).
fn two_passes(
    sc: &Scenario,
    table: acc_config::ToolTable,
) -> (
    acc_sim::RunResult,
    acc_sim::RunResult,
    ShopControl,
    u16,
    u16,
) {
    let period_s = sc.controller.period_s;
    let (first, shop1) = pass(sc, ShopControl::new(table.clone(), period_s));
    let tool = first.rows.iter().find_map(|r| r.tool).expect("tool number");
    let block = first
        .rows
        .iter()
        .find(|r| r.flags.contains("entry"))
        .and_then(|r| r.block)
        .expect("block of the first entry");
    // The next run (the same program tomorrow) starts from what this one learned.
    let (second, _) = pass(
        sc,
        ShopControl::new(table, period_s).with_learned_from(&shop1),
    );
    (first, second, shop1, tool, block)
}

#[test]
fn the_second_entry_of_a_tool_and_block_peaks_lower_than_the_first() {
    // Entry control with learning only (the predictive limiter off): the first entry of
    // (tool, block) has nothing learned and runs in at the air override; the second starts
    // from the override that settled at the first.
    let sc = scenario("interrupted");
    let mut table = sc.tools.clone().expect("the scenario has a tool table");
    table.entry.limiter = false;
    let (first, second, shop1, tool, block) = two_passes(&sc, table);
    let ov = shop1
        .learned_entry(tool, block)
        .expect("learned entry override");
    assert!((55..=75).contains(&ov), "learned override {ov} %");
    let n = (1.5 / sc.controller.period_s).round() as usize;
    let p1 = entry_peak(&first.rows, block, n);
    let p2 = entry_peak(&second.rows, block, n);
    eprintln!("limiter off: learned {ov} %; entry peaks {p1:.1} -> {p2:.1} N");
    assert!(p1 > 880.0, "the unlearned entry overshoots: {p1:.1} N");
    assert!(
        p2 < p1 - 50.0,
        "second entry peak {p2:.1} N, first {p1:.1} N"
    );
    assert!(p2 <= 880.0, "second entry peak {p2:.1} N above 1.10 Fr");
}

#[test]
fn with_the_predictive_limiter_learning_keeps_the_entry_under_the_limit() {
    // The shipped table: the predictive limiter already holds the first entry under
    // Fr (1 + limit_pct/100); what the second pass learned (the full engagement bounds the
    // growth model, its under-prediction margin) must not raise the entry or the run's
    // figures.
    let sc = scenario("interrupted");
    let table = sc.tools.clone().expect("the scenario has a tool table");
    assert!(
        table.entry.enabled && table.entry.limiter,
        "configs/tooltable.toml"
    );
    let limit = 800.0 * (1.0 + table.entry.limit_pct / 100.0);
    let (first, second, shop1, tool, block) = two_passes(&sc, table);
    let ov = shop1
        .learned_entry(tool, block)
        .expect("learned entry override");
    assert!((55..=75).contains(&ov), "learned override {ov} %");
    let margin = shop1.learned_margin(tool, block).expect("learned margin");
    assert!((1.0..=1.5).contains(&margin), "margin {margin}");
    let n = (1.5 / sc.controller.period_s).round() as usize;
    let p1 = entry_peak(&first.rows, block, n);
    let p2 = entry_peak(&second.rows, block, n);
    let (s1, s2) = (summarize(&first, &sc), summarize(&second, &sc));
    eprintln!(
        "limiter on: learned {ov} %, margin {margin:.3}; entry peaks {p1:.1} -> {p2:.1} N; \
         RMS {:.1} -> {:.1} N, peak {:.1} -> {:.1} N",
        s1.rms_error_cut_n, s2.rms_error_cut_n, s1.peak_force_n, s2.peak_force_n
    );
    assert!(
        p1 <= limit && p2 <= p1,
        "{p1:.1} -> {p2:.1} N (limit {limit:.0} N)"
    );
    assert!(s2.peak_force_n <= 880.0, "{}", s2.peak_force_n);
    assert!(s2.rms_error_cut_n <= s1.rms_error_cut_n * 1.02);
}

/// (RMS error in cut, peak, cycle time) of ours, and the best baseline's RMS.
fn figures(sc: &Scenario) -> (f64, f64, f64, f64) {
    let (_, ours) = sc.run_law(LawKind::Ours).expect("ours runs");
    let best = [
        LawKind::ConstantFeed,
        LawKind::ConstantSafeFeed,
        LawKind::FixedGainPi,
        LawKind::RateLimited,
        LawKind::Proportional,
    ]
    .into_iter()
    .map(|k| sc.run_law(k).expect("baseline runs").1.rms_error_cut_n)
    .fold(f64::INFINITY, f64::min);
    (
        ours.rms_error_cut_n,
        ours.peak_force_n,
        ours.cycle_time_s.expect("finishes"),
        best,
    )
}

#[test]
fn golden_entry_figures_on_the_interrupted_cut() {
    // Measured (acc compare configs/scenarios/interrupted.toml): RMS 106.3 N, peak 856.8 N,
    // cycle 46.8 s; best baseline (proportional) 104.2 N. Today without entry control:
    // 108.8 N, 992.9 N, 46.4 s.
    let (rms, peak, cycle, best) = figures(&scenario("interrupted"));
    assert!((best - 104.2).abs() < 0.1, "best baseline {best}");
    assert!(peak <= 880.0, "peak {peak:.1} N above 1.10 Fr");
    assert!(rms <= 106.3 * 1.02, "RMS {rms:.1} N");
    assert!(
        cycle <= 46.4 * 1.02,
        "cycle {cycle:.1} s, more than 2 % over 46.4 s"
    );
}

#[test]
fn golden_entry_figures_on_the_hard_inclusion() {
    // Measured: RMS 68.8 N, peak 867.8 N, cycle 55.0 s; best baseline (rate-limited)
    // 118.4 N, 0.7x = 82.9 N. Without entry control: 70.3 N, 939.4 N, 54.8 s.
    let (rms, peak, cycle, best) = figures(&scenario("hard_inclusion"));
    assert!((best - 118.4).abs() < 0.1, "best baseline {best}");
    assert!(peak <= 880.0, "peak {peak:.1} N above 1.10 Fr");
    assert!(rms <= 0.7 * best, "RMS {rms:.1} N above 0.7 x {best:.1} N");
    assert!(rms <= 68.8 * 1.02, "RMS {rms:.1} N");
    assert!(
        cycle <= 54.8 * 1.02,
        "cycle {cycle:.1} s, more than 2 % over 54.8 s"
    );
}

/// The interrupted cut's RMS target (0.7 x the best baseline, 72.9 N) is out of reach of
/// any override law: the rows the metric attributes to the cut include the engagement ramp,
/// where even the maximum override (150 %) gives less than Fr, and on the 10 % board every
/// other row can only be at a grid position. Per row the smallest error any law could
/// have (the plant's force per percent of override at that row, force ∝ feed, no noise):
/// over all rows in cut it exceeds the target, and ours is within 10 % of it.
#[test]
fn the_interrupted_rms_target_is_below_the_engagement_ramp_floor() {
    let sc = scenario("interrupted");
    let (res, s) = sc.run_law(LawKind::Ours).expect("runs");
    let fr = s.force_ref_n;
    let seg = attribute_rows(&res.rows, &sc.workpiece, sc.tool.diameter_mm);
    let spec = sc.controller.override_spec;
    let max = f64::from(spec.max_pct);
    let step = usize::from(spec.step_pct);
    let mut n = 0usize;
    let (mut ramp2, mut grid2) = (0.0, 0.0);
    for (r, i) in res.rows.iter().zip(&seg) {
        if !sc.workpiece.segments[*i].is_cut() {
            continue;
        }
        n += 1;
        let applied = f64::from(r.override_applied_pct.expect("applied"));
        let f_true = r.force_true_n.expect("truth");
        let k = if applied > 0.0 { f_true / applied } else { 0.0 };
        ramp2 += (fr - k * max).max(0.0).powi(2);
        grid2 += (0..=usize::from(spec.max_pct))
            .step_by(step)
            .map(|q| (k * q as f64 - fr).powi(2))
            .fold(f64::INFINITY, f64::min);
    }
    let ramp = (ramp2 / n as f64).sqrt();
    let grid = (grid2 / n as f64).sqrt();
    let ours = s.rms_error_cut_n;
    eprintln!(
        "over {n} rows: ramp floor {ramp:.1} N, 10 % grid floor {grid:.1} N; ours {ours:.1} N"
    );
    let target = 0.7 * 104.2;
    assert!(
        ramp > target + 10.0,
        "ramp floor {ramp:.1} N vs target {target:.1} N"
    );
    assert!(
        grid > ramp && grid > target + 20.0,
        "grid floor {grid:.1} N"
    );
    assert!(
        ours > grid && ours < 1.1 * grid,
        "ours {ours:.1} N vs floor {grid:.1} N"
    );
}
