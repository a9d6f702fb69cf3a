//! Tests of [`crate::lookahead`].
use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use super::plan::{Plan, PlanRow};
use super::{Disagreement, LookAhead, LookAheadConfig, LookAheadInput};

fn row(block: u32, a: f64, b: f64, f100: f64, ov: u16) -> PlanRow {
    crate::plan::test_row(block, a, b, 600.0, f100, ov)
}

fn status(block: u16, feed: u16) -> BoardStatus {
    BoardStatus {
        protocol_version: 2,
        block_number: block,
        actual_feed_mm_min: feed,
        ..BoardStatus::default()
    }
}

fn force(f: f64) -> ForceSample {
    ForceSample {
        force_n: f,
        power_w: None,
        valid: true,
    }
}

/// The input of a period that read `st` (`None`: the read failed) with a valid force `f`
/// (N), T = 0.1 s: no line guard, a nominal line, the Fr in force.
fn read(st: Option<&BoardStatus>, f: f64) -> LookAheadInput {
    LookAheadInput::new(st.copied(), force(f), 0.1)
}

/// Air in block 10 for 20 mm, then a cut planned at 30 % in block 20.
fn lookahead() -> LookAhead {
    let plan = Plan {
        rows: vec![
            row(10, 0.0, 20.0, 0.0, 150),
            row(20, 20.0, 60.0, 2400.0, 30),
        ],
    };
    LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150))
}

#[test]
fn caps_before_the_entry_not_long_before() {
    let mut la = lookahead();
    // 900 mm/min = 1.5 mm per period; at 150 % of 600 the horizon (0.2 s) is 3 mm.
    let mut caps = Vec::new();
    for _ in 0..13 {
        caps.push(la.step(&read(Some(&status(10, 900)), 0.0)));
    }
    let first = caps
        .iter()
        .position(|s| s.cap_pct == Some(30))
        .expect("capped");
    let x = caps[first].position_mm.expect("located");
    assert!((15.0..20.0).contains(&x), "capped at {x} mm");
    assert!(caps[..first].iter().all(|s| s.cap_pct.is_none()));
    // In the cut, the block change locates the tool past the block's start: without a
    // line guard the block began within the last period, 0.3 mm at the feed read; the
    // middle of that, ± half.
    let s = la.step(&read(Some(&status(20, 180)), 720.0));
    assert_eq!(s.cap_pct, Some(30));
    assert!((s.position_mm.expect("x") - 20.15).abs() < 1e-9);
    assert!((la.unc_mm - 0.15).abs() < 1e-9);
    assert_eq!(s.disagreement, None);
}

#[test]
fn a_tool_fr_below_the_plans_lowers_the_cap_a_higher_one_never_raises_it() {
    // The cut (2400 N at 100 %, β = 1) is planned at 30 % for Fr 800 N.
    let in_cut = |plan_fr: Option<f64>, loop_fr: f64| {
        let mut la = lookahead();
        for r in &mut la.plan.rows {
            r.force_ref_n = plan_fr;
        }
        let input = LookAheadInput {
            force_ref_n: Some(loop_fr),
            ..read(Some(&status(20, 180)), 0.5 * loop_fr)
        };
        la.step(&input).cap_pct
    };
    // A tool whose Fr is 500 N: 100 · 500 / 2400 = 20.8 → 20 %.
    assert_eq!(in_cut(Some(800.0), 500.0), Some(20));
    // A higher Fr keeps the plan's 30 %, and so does a plan that did not record its Fr.
    assert_eq!(in_cut(Some(800.0), 1000.0), Some(30));
    assert_eq!(in_cut(None, 500.0), Some(30));
    assert_eq!(in_cut(Some(800.0), 800.0), Some(30));
}

/// A cut planned at 40 % for 10 mm, then a corner planned at 20 % from 10 mm.
fn cut_then_corner() -> LookAhead {
    let plan = Plan {
        rows: vec![
            row(30, 0.0, 10.0, 2000.0, 40),
            row(31, 10.0, 20.0, 4000.0, 20),
        ],
    };
    LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150))
}

fn in_force(block: u16, feed: u16, pct: u16) -> BoardStatus {
    BoardStatus {
        override_applied_pct: pct,
        ..status(block, feed)
    }
}

#[test]
fn the_walk_ahead_goes_as_far_as_the_override_in_force_lets_the_tool() {
    // Held at 40 % of 600 mm/min (4 mm/s), 0.2 s ahead is 0.8 mm, and on the first
    // period the change of its path from standstill (0.4 mm) behind and ahead of the
    // position: at 8.6 mm the corner at 10 mm is out of reach, at 9.4 mm it is in reach.
    let mut la = cut_then_corner();
    let mut at = |x_mm: f64, pct: u16| {
        la.x_mm = x_mm - 0.4;
        la.step(&read(Some(&in_force(30, 240, pct)), 790.0))
    };
    assert_eq!(at(8.6, 40).cap_pct, Some(40));
    assert_eq!(at(9.4, 40).cap_pct, Some(20));
    // At 150 % in force (9 mm/s until the new command acts) 0.2 s reaches 1.8 mm: the
    // corner is capped from 8.6 mm on, as from air.
    assert_eq!(at(8.6, 150).cap_pct, Some(20));
    // Likewise with 40 % applied and 150 % written but not yet applied.
    la.note_written(150);
    la.x_mm = 8.2;
    let s = la.step(&read(Some(&in_force(30, 240, 40)), 790.0));
    assert_eq!(s.cap_pct, Some(20));
}

#[test]
fn inside_a_rising_row_the_cap_follows_the_force_the_tool_can_reach() {
    // A corner: the force at 100 % rises from 1000 N to 4000 N over 2 mm (planned 20 %
    // for its end); Fr 800 N, held at 20 % of 600 mm/min = 2 mm/s: 0.4 mm in 0.2 s.
    let mut corner = row(31, 10.0, 12.0, 4000.0, 20);
    corner.force_min_100_n = 1000.0;
    corner.profile = crate::plan::ForceProfile::Rising;
    let plan = Plan {
        rows: vec![row(30, 0.0, 10.0, 1000.0, 80), corner.clone()],
    };
    let mut la = LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150));
    // 200 N measured at 20 %: what the plan predicts at the corner's start.
    let mut at = |x_mm: f64, pct: u16, f: f64| {
        la.x_mm = x_mm - 0.2;
        la.step(&read(Some(&in_force(31, 120, pct)), f))
            .cap_pct
            .expect("capped")
    };
    // At the corner's start, with the first period's path (0.2 mm) behind and ahead: reaching
    // 10.6 mm at 20 %, 1900 N at 100 %; at 42 % (the first cap) 11.04 mm, 2560 N: 31 %.
    let start = at(10.0, 20, 200.0);
    assert_eq!(start, 31);
    // Deeper in, lower; at the end, the plan's own override.
    let mid = at(11.0, 20, 500.0);
    assert!(mid < start && mid > 20, "{mid}");
    assert_eq!(at(12.0, 20, 800.0), 20);
    // A measured force above the plan's band: its shape is not trusted, the row is read
    // at its largest force.
    assert_eq!(at(10.0, 20, 1500.0), 20);
    // The same row flat (shape unknown): the plan's override throughout.
    corner.profile = crate::plan::ForceProfile::Flat;
    let plan = Plan {
        rows: vec![row(30, 0.0, 10.0, 1000.0, 80), corner],
    };
    let mut la = LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150));
    la.x_mm = 9.8;
    let s = la.step(&read(Some(&in_force(31, 120, 20)), 200.0));
    assert_eq!(s.cap_pct, Some(20));
}

#[test]
fn disagreement_needs_persistence_and_below_lifts_the_cap() {
    let mut la = lookahead();
    // Entering from air: a drop here would be the plan's (the band reaches air).
    assert!(la.step(&read(Some(&status(20, 180)), 720.0)).exit_planned);
    // In the cut at the planned force: the plan explains the force.
    assert!(la.step(&read(Some(&status(20, 180)), 720.0)).exit_planned);
    // A collapse to nothing where the plan says metal is not explained (a broken tool).
    assert!(!la.step(&read(Some(&status(20, 180)), 0.0)).exit_planned);
    la.step(&read(Some(&status(20, 180)), 720.0));
    // The plan predicts 720 N at 180 mm/min; 1500 N is above for three periods.
    let d: Vec<_> = (0..3)
        .map(|_| la.step(&read(Some(&status(20, 180)), 1500.0)))
        .collect();
    assert_eq!(d[1].disagreement, None);
    assert_eq!(d[2].disagreement, Some(Disagreement::Above));
    assert!(d.iter().all(|s| !s.exit_planned));
    assert_eq!(d[2].cap_pct, Some(30));
    // Air where the plan says metal: below, and the cap is lifted.
    let d: Vec<_> = (0..3)
        .map(|_| la.step(&read(Some(&status(20, 180)), 0.0)))
        .collect();
    assert_eq!(d[2].disagreement, Some(Disagreement::Below));
    assert_eq!(d[2].cap_pct, None);
}

/// A look-ahead with the plan's lead on one cut: 2000 N at 100 % of 600 mm/min, β = 1
/// (600 N at 30 %, 800 N = Fr at 40 %).
fn leading() -> LookAhead {
    let plan = Plan {
        rows: vec![row(30, 0.0, 100.0, 2000.0, 30)],
    };
    let cfg = LookAheadConfig {
        lead: true,
        ..LookAheadConfig::new(0.1, 800.0, 150)
    };
    LookAhead::new(plan, cfg)
}

/// In that cut at 30 % of 600 mm/min on a 10 % board, with tool `tool`.
fn cutting(tool: u16) -> BoardStatus {
    BoardStatus {
        override_step_pct: 10,
        tool_number: tool,
        ..in_force(30, 180, 30)
    }
}

#[test]
fn the_lead_acts_only_while_the_tool_cuts_and_the_plan_agrees() {
    let mut la = leading();
    let mut at = |f: f64| la.step(&read(Some(&cutting(1)), f));
    // Three periods where the measurement agrees with the plan (k = 1) before it leads:
    // then 40 %, the position whose predicted force is Fr.
    assert_eq!(at(600.0).lead_pct, None);
    assert_eq!(at(600.0).lead_pct, None);
    assert_eq!(at(600.0).lead_pct, Some(40));
    // The measurement jumps 25 % off the scale: no lead that period, the cap and the
    // law act; once the scale has followed (k = 1.25), the lead predicts 40 % at 1000 N
    // (above 1.05 Fr) and holds 30 % (750 N).
    let leads: Vec<_> = (0..6).map(|_| at(750.0).lead_pct).collect();
    assert_eq!(leads[0], None);
    assert_eq!(leads[5], Some(30));
    // A force above the plan's band: no lead, and the scale starts again.
    assert_eq!(at(1500.0).lead_pct, None);
    assert_eq!(at(750.0).lead_pct, None);
    // In air (no force): no lead; entries keep the cap.
    assert_eq!(at(0.0).lead_pct, None);
    // Back in a cut: the cut's own scale starts again. Its first period has no sample of
    // this cut; from the second, the entry is led at the tool's scale from the last cut
    // (1.25, confirmed at 750 N: 40 % would predict 1000 N, so 30 %).
    let back: Vec<_> = (0..3).map(|_| at(750.0).lead_pct).collect();
    assert_eq!(back, [None, Some(30), Some(30)]);
    // ...and a new tool starts it again (three agreeing periods before it leads).
    let st = cutting(2);
    let leads: Vec<_> = (0..3)
        .map(|_| la.step(&read(Some(&st), 600.0)).lead_pct)
        .collect();
    assert_eq!(leads, [None, None, Some(40)]);
}

#[test]
fn no_lead_after_a_failed_read_a_skipped_period_or_on_a_slow_line() {
    let mut la = leading();
    let st = cutting(1);
    let led = |la: &mut LookAhead, line_nominal: bool| {
        let input = LookAheadInput {
            line_nominal,
            ..read(Some(&st), 600.0)
        };
        (0..3).map(|_| la.step(&input).lead_pct).collect::<Vec<_>>()
    };
    assert_eq!(led(&mut la, true), [None, None, Some(40)]);
    // A failed read: no lead reported, the position moves on by the last path (0.3 mm)
    // and is that much less certain, and the cut's scale starts again: its first period
    // after the read has no sample of it, the next leads as an entry at the tool's scale.
    let x = la.last().position_mm.expect("x");
    assert_eq!(la.step(&read(None, 600.0)).lead_pct, None);
    assert!((la.x_mm - x - 0.3).abs() < 1e-9 && la.unc_mm >= 0.3 - 1e-9);
    assert_eq!(led(&mut la, true), [None, Some(40), Some(40)]);
    // A period the driver skipped: the same.
    la.missed();
    assert_eq!(led(&mut la, true), [None, Some(40), Some(40)]);
    // A slow line (a longer echo delay measured): no lead while it lasts.
    assert_eq!(led(&mut la, false), [None, None, None]);
    assert_eq!(led(&mut la, true)[2], Some(40));
}

#[test]
fn unknown_block_or_v1_board_is_lost() {
    let mut la = lookahead();
    let s = la.step(&read(Some(&status(99, 100)), 0.0));
    assert!(s.lost && s.cap_pct.is_none());
    let s = la.step(&read(Some(&BoardStatus::default()), 0.0));
    assert!(s.lost);
    // A block met again later in the program is found forward from the last one.
    let plan = Plan {
        rows: vec![
            row(5, 0.0, 10.0, 0.0, 150),
            row(6, 10.0, 20.0, 1000.0, 80),
            row(5, 20.0, 30.0, 0.0, 150),
        ],
    };
    let mut la = LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150));
    la.step(&read(Some(&status(5, 60)), 0.0));
    la.step(&read(Some(&status(6, 60)), 0.0));
    let s = la.step(&read(Some(&status(5, 60)), 0.0));
    let x = s.position_mm.expect("x");
    assert!((x - 20.05).abs() < 1e-9, "{x}");
}

#[test]
fn a_steady_periods_path_is_the_rows_feed_and_the_drift_grows_only_without_it() {
    // A programmed feed the register cannot show (283.4 mm/min, reported 283).
    let plan = Plan {
        rows: vec![crate::plan::test_row(30, 0.0, 100.0, 283.4, 2000.0, 30)],
    };
    let mut la = LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150));
    let unit = la.cfg.feed_rounding_mm_min * 0.1 / 60.0;
    // The first period has no override of the read before: the register's path.
    la.step(&read(Some(&in_force(30, 283, 100)), 0.0));
    assert!((la.x_mm - 283.0 * 0.1 / 60.0).abs() < 1e-12);
    assert!((la.drift_mm - unit).abs() < 1e-12);
    // Ten steady periods at 100 %: the row's feed, no drift added.
    for _ in 0..10 {
        la.step(&read(Some(&in_force(30, 283, 100)), 0.0));
    }
    let x = (283.0 + 10.0 * 283.4) * 0.1 / 60.0;
    assert!((la.x_mm - x).abs() < 1e-12, "{} vs {x}", la.x_mm);
    assert!((la.drift_mm - unit).abs() < 1e-12);
    // The override changed: the register's value (the period's mean), half a unit more.
    la.step(&read(Some(&in_force(30, 200, 50)), 0.0));
    assert!((la.x_mm - (x + 200.0 * 0.1 / 60.0)).abs() < 1e-12);
    assert!((la.drift_mm - 2.0 * unit).abs() < 1e-12);
    // Steady, but the register disagrees with the row's feed by more than its rounding (an
    // NC that slows the path on its own): the register's value again.
    la.step(&read(Some(&in_force(30, 120, 50)), 0.0));
    assert!((la.x_mm - (x + 320.0 * 0.1 / 60.0)).abs() < 1e-12);
    assert!((la.drift_mm - 3.0 * unit).abs() < 1e-12);
}

/// A cut planned at 30 % in block 30 (2000 N at 100 % over 10 mm), air in block 40, then
/// block 50: 0.05 mm at 4000 N (planned 20 %) and the same cut again.
fn cut_air_short_peak(lead: bool) -> LookAhead {
    let plan = Plan {
        rows: vec![
            row(30, 0.0, 10.0, 2000.0, 30),
            row(40, 10.0, 20.0, 0.0, 150),
            row(50, 20.0, 20.05, 4000.0, 20),
            row(50, 20.05, 60.0, 2000.0, 30),
        ],
    };
    let cfg = LookAheadConfig {
        lead,
        ..LookAheadConfig::new(0.1, 800.0, 150)
    };
    LookAhead::new(plan, cfg)
}

/// The caps of the periods approaching block 50 through the air of block 40 at 150 %,
/// after six periods of the cut of block 30 at 30 % whose force agrees with the plan (the
/// tool `air_tool` in the air, tool 1 in the cut).
fn caps_towards_the_entry(lead: bool, air_tool: u16) -> Vec<Option<u16>> {
    let mut la = cut_air_short_peak(lead);
    let step = |b: u16, v: u16, pct: u16, tool: u16| BoardStatus {
        override_step_pct: 10,
        tool_number: tool,
        ..in_force(b, v, pct)
    };
    for _ in 0..6 {
        la.step(&read(Some(&step(30, 180, 30, 1)), 600.0));
    }
    (0..6)
        .map(|_| {
            la.step(&read(Some(&step(40, 900, 150, air_tool)), 0.0))
                .cap_pct
        })
        .collect()
}

#[test]
fn an_entry_is_capped_at_the_period_means_once_the_tool_has_a_scale() {
    let cap_only = caps_towards_the_entry(false, 1);
    let led = caps_towards_the_entry(true, 1);
    let new_tool = caps_towards_the_entry(true, 2);
    // The row cap reads the 0.05 mm stretch at its largest force: 20 %. A period at 30 %
    // (0.3 mm) averages it with the cut after it, 700 N; one at 40 % 900 N, above the
    // ceiling: with the tool's scale from the cut before (1.0), the entry is capped at
    // 30 %.
    assert!(cap_only.contains(&Some(20)), "{cap_only:?}");
    assert!(
        led.contains(&Some(30)) && !led.contains(&Some(20)),
        "{led:?}"
    );
    // A new tool has no scale yet: the row cap.
    assert_eq!(new_tool, cap_only);
}

#[test]
fn the_entry_cap_is_not_lifted_in_a_cut_whose_scale_failed() {
    // The cut of `leading` (2000 N at 100 %, planned 30 %): a scale of 1 confirmed, then the
    // ratio jumps to 1.25 (750 N at 30 %, inside the band, not yet a disagreement) or a read
    // fails. The cut's scale is no longer confirmed; the tool's earlier one (1) would lift
    // the cap to 40 % (800 N predicted, 1000 N at the measured 1.25): it is not used.
    let mut la = leading();
    for _ in 0..4 {
        la.step(&read(Some(&cutting(1)), 600.0));
    }
    assert!(la.scale.confirmed() && la.tool_scale.is_some());
    for _ in 0..2 {
        let st = la.step(&read(Some(&cutting(1)), 750.0));
        assert_eq!((st.lead_pct, st.cap_pct), (None, Some(30)));
    }
    // After a failed read the cut starts its scale again: the first period after it has
    // no sample of this cut and keeps the row cap; with a sample of this cut agreeing with
    // the tool's scale (600 N at 30 %, 1.0) the entry is led at it (800 N at 40 %).
    let mut la = leading();
    for _ in 0..4 {
        la.step(&read(Some(&cutting(1)), 600.0));
    }
    la.step(&read(None, 600.0));
    let st = la.step(&read(Some(&cutting(1)), 600.0));
    assert_eq!((st.lead_pct, st.cap_pct), (None, Some(30)));
    let st = la.step(&read(Some(&cutting(1)), 600.0));
    assert_eq!((st.lead_pct, st.cap_pct), (Some(40), Some(40)));
}

#[test]
fn a_feed_hold_a_late_period_and_an_instantaneous_register_widen_the_drift() {
    let plan = Plan {
        rows: vec![crate::plan::test_row(30, 0.0, 100.0, 600.0, 2000.0, 30)],
    };
    let mut la = LookAhead::new(plan, LookAheadConfig::new(0.1, 800.0, 150));
    let unit = la.cfg.feed_rounding_mm_min * 0.1 / 60.0;
    for _ in 0..3 {
        la.step(&read(Some(&in_force(30, 180, 30)), 0.0));
    }
    assert!(
        (la.drift_mm - unit).abs() < 1e-12,
        "only the first period adds"
    );
    // A feed hold: the register's path, and the first period after it is not steady.
    let hold = BoardStatus {
        feed_hold_active: true,
        ..in_force(30, 0, 30)
    };
    la.step(&read(Some(&hold), 0.0));
    la.step(&read(Some(&in_force(30, 180, 30)), 0.0));
    assert!((la.drift_mm - 3.0 * unit).abs() < 1e-12);
    la.step(&read(Some(&in_force(30, 180, 30)), 0.0));
    assert!((la.drift_mm - 3.0 * unit).abs() < 1e-12);
    // A period of a line not as designed (late, lagging): a whole period's path.
    la.step(&LookAheadInput {
        line_nominal: false,
        ..read(Some(&in_force(30, 180, 30)), 0.0)
    });
    assert!((la.drift_mm - (3.0 * unit + 0.3)).abs() < 1e-9);
    // The window reaches the drift behind the position and ahead of the reach.
    let (x, dx) = (la.x_mm, 0.3);
    let (y0, y1, here) = la.window(x, dx, 0.0, 30);
    let reach = la.plan().advance(x, 30, la.cfg.command_delay_s);
    assert!((here - (x - la.drift_mm)).abs() < 1e-12 && (y0 - here).abs() < 1e-12);
    assert!((y1 - (reach + la.drift_mm)).abs() < 1e-12);
    // An override change whose period already shows the new feed (a mean would lie
    // between 180 and 240): the register is instantaneous, the window at least a period's
    // path from then on.
    let mut la = LookAhead::new(la.plan().clone(), LookAheadConfig::new(0.1, 800.0, 150));
    la.step(&read(Some(&in_force(30, 180, 30)), 0.0));
    la.step(&read(Some(&in_force(30, 210, 40)), 0.0));
    assert!(!la.instantaneous_feed, "a period's mean");
    la.step(&read(Some(&in_force(30, 240, 40)), 0.0));
    la.step(&read(Some(&in_force(30, 180, 30)), 0.0));
    assert!(la.instantaneous_feed);
    let (y0, _, _) = la.window(la.x_mm, 0.3, 0.0, 30);
    assert!((la.x_mm - y0 - 0.3).abs() < 1e-12);
}

#[test]
fn an_entry_is_led_only_on_a_ratio_of_this_cut_that_agrees_with_the_tools_scale() {
    // The tool's scale (1.0) confirmed in a first cut, then air.
    let confirmed = |st: &BoardStatus| {
        let mut la = leading();
        for _ in 0..4 {
            la.step(&read(Some(st), 600.0));
        }
        la.step(&read(Some(st), 0.0));
        la
    };
    let st = cutting(1);
    // Back in at 600 N (ratio 1.0): the first period has no ratio of this cut, the next
    // leads at the tool's scale.
    let mut la = confirmed(&st);
    let led: Vec<_> = (0..2)
        .map(|_| la.step(&read(Some(&st), 600.0)).lead_pct)
        .collect();
    assert_eq!(led, [None, Some(40)]);
    // In the material below 0.2 Fr (5 % on a 1 % board: 100 N, as the plan predicts): the
    // entry's cap may rise, but there is no ratio of this cut to judge by, so no lead.
    let mut la = confirmed(&st);
    let slow = BoardStatus {
        override_step_pct: 1,
        ..in_force(30, 30, 5)
    };
    let slow = BoardStatus {
        tool_number: 1,
        ..slow
    };
    for _ in 0..3 {
        let s = la.step(&read(Some(&slow), 100.0));
        assert_eq!(s.disagreement, None);
        assert!(s.cap_pct.is_some_and(|c| c > 5), "{s:?}");
        assert_eq!(s.lead_pct, None);
    }
    // This cut's ratio 25 % off the tool's scale (750 N at 30 %): the cap may rise to the
    // highest ratio's position, the command stays the law's.
    let mut la = confirmed(&st);
    for _ in 0..2 {
        let s = la.step(&read(Some(&st), 750.0));
        assert_eq!((s.lead_pct, s.cap_pct), (None, Some(30)));
    }
    // A board that names no tool (`TOOL_NUMBER` 0): no scale is kept from cut to cut;
    // three agreeing periods of this cut before the lead.
    let st0 = cutting(0);
    let mut la = confirmed(&st0);
    let led: Vec<_> = (0..3)
        .map(|_| la.step(&read(Some(&st0), 600.0)).lead_pct)
        .collect();
    assert_eq!(led, [None, None, Some(40)]);
    // Another program with the same tool number: the same.
    let mut la = confirmed(&st);
    let other = BoardStatus {
        program_number: 77,
        ..st
    };
    let led: Vec<_> = (0..3)
        .map(|_| la.step(&read(Some(&other), 600.0)).lead_pct)
        .collect();
    assert_eq!(led, [None, None, Some(40)]);
}

#[test]
fn a_block_change_bounds_the_position_by_the_periods_it_may_have_begun_in() {
    let plan = Plan {
        rows: vec![
            crate::plan::test_row(30, 0.0, 12.0, 600.0, 2000.0, 30),
            crate::plan::test_row(31, 12.0, 100.0, 600.0, 2000.0, 30),
        ],
    };
    // An instantaneous register (as above), then an override that moves between 30 and
    // 40 % every period: each period adds the change of its path (0.1 mm) to the drift.
    // Once the integrated position passes `until` (mm), `pending` runs the periods whose
    // raw block number is already 31 while the guard still reports 30; then 31 is reported.
    let change = |until: f64, pending: &dyn Fn(&mut LookAhead)| {
        let mut la = LookAhead::new(plan.clone(), LookAheadConfig::new(0.1, 800.0, 150));
        for (feed, pct) in [(180, 30), (210, 40), (240, 40), (180, 30)] {
            la.step(&read(Some(&in_force(30, feed, pct)), 0.0));
        }
        assert!(la.instantaneous_feed);
        let mut k = 0;
        while la.x_mm < until {
            let (feed, pct) = if k % 2 == 0 { (240, 40) } else { (180, 30) };
            la.step(&read(Some(&in_force(30, feed, pct)), 0.0));
            k += 1;
        }
        pending(&mut la);
        let drift_before = la.drift_mm;
        la.step(&read(Some(&in_force(31, 240, 40)), 0.0));
        (la, drift_before)
    };
    // A period whose raw read shows `block` while the guard reports 30 (`held`: the guard
    // held the read).
    let raw = |la: &mut LookAhead, block: u16, read_held: bool| {
        la.step(&LookAheadInput {
            raw_block: Some(block),
            read_held,
            ..read(Some(&in_force(30, 240, 40)), 0.0)
        });
    };
    let raw_31 = |la: &mut LookAhead| raw(la, 31, false);
    // Where the position is inside the reach, the drift allowance is bounded by it,
    // `max(x − start, start + reach − x)`, then grows by the change of the period's path
    // (0.1 mm at most).
    let bounded = |(la, before): (LookAhead, f64), reach: f64| {
        let x = la.x_mm;
        assert!(
            (12.0..=12.0 + reach).contains(&x),
            "x {x} mm, reach {reach} mm"
        );
        let want = before.min((x - 12.0).max(12.0 + reach - x));
        let d = la.drift_mm;
        assert!(
            (want - 1e-9..=want + 0.1 + 1e-9).contains(&d),
            "{d} mm, want {want}"
        );
        assert!(before > 2.0, "the dither's drift {before} mm");
    };
    // 40 % of 600 mm/min at most: 0.4 mm per period. With the guard's confirmation on the
    // next read, the block began within two periods.
    bounded(change(11.2, &raw_31), 0.8);
    // Without a raw number (no guard), within the last period.
    bounded(change(11.6, &|_| {}), 0.4);
    // A bad frame (another number) restarts the confirmation: four periods.
    bounded(
        change(10.4, &|la| {
            raw_31(la);
            raw(la, 77, false);
            raw_31(la);
        }),
        1.6,
    );
    // A read the guard held: its status is the last accepted one, so neither its override
    // nor the next period's start is known (the grid's maximum, 1.5 mm each).
    bounded(
        change(10.8, &|la| {
            raw(la, 31, true);
            raw_31(la);
        }),
        0.4 + 1.5 + 1.5,
    );
    // A held read that shows the old block (a stale frame) does not restart the count.
    bounded(
        change(10.4, &|la| {
            raw_31(la);
            raw(la, 30, true);
            raw_31(la);
        }),
        0.4 + 1.5 + 1.5 + 0.4,
    );
    // A failed read: its period and the next, whose override at the start is not known.
    bounded(
        change(11.2, &|la| {
            raw_31(la);
            la.step(&read(None, 0.0));
        }),
        1.5 + 1.5 + 0.4,
    );
    // An integrated position past the reach is wrong: the middle of the reach, ± half.
    let (la, _) = change(14.0, &raw_31);
    assert!((la.x_mm - 12.4).abs() < 1e-9 && (la.unc_mm - 0.4).abs() < 1e-9);
    assert!(la.drift_mm <= 0.1 + 1e-12);
}

#[test]
fn a_slow_period_in_the_material_keeps_the_cuts_scale_air_clears_it() {
    let plan = Plan {
        rows: vec![
            row(30, 0.0, 50.0, 2000.0, 30),
            row(31, 50.0, 100.0, 0.0, 150),
        ],
    };
    let cfg = LookAheadConfig {
        lead: true,
        ..LookAheadConfig::new(0.1, 800.0, 150)
    };
    let mut la = LookAhead::new(plan, cfg);
    // 5 % through the cut: 100 N, below the cutting share (160 N) and inside the band.
    let slow = BoardStatus {
        override_step_pct: 10,
        tool_number: 1,
        ..in_force(30, 30, 5)
    };
    for _ in 0..3 {
        la.step(&read(Some(&cutting(1)), 600.0));
    }
    assert!(la.scale.confirmed());
    la.step(&read(Some(&slow), 100.0));
    assert!(la.scale.scale().is_some(), "the same cut");
    // Back at 30 %: led at once, not after three new samples.
    assert_eq!(la.step(&read(Some(&cutting(1)), 600.0)).lead_pct, Some(40));
    // Unjudged periods keep the confirmation for at most `scale_confirm_periods`.
    for _ in 0..la.cfg.scale_confirm_periods {
        la.step(&read(Some(&slow), 100.0));
    }
    assert!(la.scale.confirmed());
    la.step(&read(Some(&slow), 100.0));
    assert!(!la.scale.confirmed());
    assert!(la.scale.scale().is_some());
    // A force below the band's lowest less its tolerance (a tool gone, air the plan does
    // not know) is not the same cut.
    la.step(&read(Some(&cutting(1)), 600.0));
    assert!(la.scale.confirmed());
    la.step(&read(Some(&slow), 20.0));
    assert!(la.scale.scale().is_none());
    for _ in 0..3 {
        la.step(&read(Some(&cutting(1)), 600.0));
    }
    assert!(la.scale.confirmed());
    // The same low force where the plan has air within the position's error (the block
    // of the air row): out of the cut, the scale starts again.
    la.step(&read(Some(&in_force(31, 180, 30)), 0.0));
    assert!(la.scale.scale().is_none());
}
