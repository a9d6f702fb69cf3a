//! Fault policy, part two: overload, operator priority (locked override, knob hand-back,
//! the v1 knob cap), the command's bounds as properties, the NC context in the run log, the
//! tool table's limits and the breakage watch at a block's end — each against the scripted
//! board of `common` on board time advanced 100 ms per period.

use acc_core::ForceSample;
use acc_pmc::{BoardErrorKind, BoardStatus};
use acc_runtime::policy::{AccState, Event, FaultPolicy, PolicyConfig, PolicyInput, Release};
use acc_runtime::testing::{ScriptedBoard, ScriptedLaw};

use crate::common::*;

#[test]
fn overload_requests_feed_hold_and_alarm() {
    let cfg = PolicyConfig {
        overload_force_n: 1600.0,
        overload_time_s: 0.3,
        ..PolicyConfig::default()
    };
    assert_eq!(
        cfg.overload_periods(),
        4,
        "the first period above, then 0.3 s at T = 0.1 s"
    );
    let mut rig = Rig::new(cfg, [100]);
    rig.run(3);
    // a 0.2 s spike: no feed hold
    rig.power_w = 4000; // 2000 N
    rig.run(3);
    rig.power_w = 1200;
    rig.run(2);
    assert_eq!(rig.state(), AccState::Active);
    assert!(!rig.status().feed_hold_active);
    // sustained overload: 0.3 s above the limit
    rig.power_w = 4000;
    let recs = rig.run(5);
    let hold_at = recs
        .iter()
        .position(|r| r.out.events.contains(&Event::FeedHold(true)))
        .expect("feed hold requested");
    assert_eq!(
        hold_at, 3,
        "0.3 s after the first period above: the 4th period"
    );
    assert!(released(&recs[hold_at], Release::Overload));
    assert!(recs[hold_at].out.alarms.overload);
    assert!(rig.status().feed_hold_active);
    // the operator cycles the switch: feed hold cleared, re-armed
    rig.power_w = 0;
    let (off, on) = rig.cycle_switch();
    assert!(off.out.control.feed_hold_request, "held until re-armed");
    assert!(on.out.events.contains(&Event::FeedHold(false)));
    assert!(armed(&on));
    rig.step();
    assert!(!rig.status().feed_hold_active);
}

#[test]
fn stopping_the_program_keeps_a_feed_hold_the_policy_requested() {
    let mut rig = Rig::new(PolicyConfig::default(), [100]);
    rig.run(3);
    rig.power_w = 4000; // 2000 N, above 2 Fr for longer than 0.3 s
    rig.run(6);
    assert!(rig.status().feed_hold_active, "overload feed hold");
    rig.lp.shutdown(&mut rig.b, 3).expect("written");
    let last = rig
        .b
        .control_writes
        .last()
        .copied()
        .expect("control written");
    assert!(!last.acc_request, "ACC released");
    assert!(last.feed_hold_request, "the overload's feed hold is kept");
    assert!(rig.status().feed_hold_active, "the axes stay held");
}

/// Periods of sustained overload (from an armed, active policy) until the feed hold.
fn periods_to_overload_hold(cfg: PolicyConfig) -> usize {
    let mut rig = Rig::new(cfg, [100]);
    rig.run(3);
    assert_eq!(rig.state(), AccState::Active);
    rig.power_w = 4000; // 2000 N, above the 1600 N limit
    let recs = rig.run(20);
    recs.iter()
        .position(|r| r.out.events.contains(&Event::FeedHold(true)))
        .expect("feed hold requested")
        + 1
}

#[test]
fn overload_time_is_counted_in_periods_of_the_configured_t() {
    // The rig's clock advances 0.1 s per cycle whatever T says: only `period_s` can make
    // the two configurations trip after different numbers of periods.
    let base = PolicyConfig {
        overload_force_n: 1600.0,
        overload_time_s: 0.3,
        ..PolicyConfig::default()
    };
    let fast = PolicyConfig {
        period_s: 0.05,
        ..base
    };
    assert_eq!(periods_to_overload_hold(base), 4, "1 + 0.3 s / 0.1 s");
    assert_eq!(periods_to_overload_hold(fast), 7, "1 + 0.3 s / 0.05 s");
    // ceil: 0.25 s at T = 0.1 s needs 3 whole periods after the first; 0 s trips on the
    // first period above; 0.9 s / 0.3 s stays 1 + 3 despite floating-point rounding.
    let c = |overload_time_s, period_s| PolicyConfig {
        overload_time_s,
        period_s,
        ..base
    };
    assert_eq!(c(0.25, 0.1).overload_periods(), 4);
    assert_eq!(c(0.0, 0.1).overload_periods(), 1);
    assert_eq!(c(0.9, 0.3).overload_periods(), 4);
    assert_eq!(periods_to_overload_hold(c(0.0, 0.1)), 1);
}

#[test]
fn override_locked_freezes_the_law_and_does_not_fight_the_nc() {
    let mut rig = Rig::new(PolicyConfig::default(), [60]);
    rig.run(3);
    let steps_before = rig.lp.law().seen.len();
    rig.b.board.set_override_locked(true);
    let recs = rig.run(4);
    assert_eq!(rig.lp.law().frozen_calls, vec![true]);
    assert_eq!(
        rig.lp.law().seen.len(),
        steps_before,
        "not stepped while locked"
    );
    assert!(recs
        .iter()
        .all(|r| r.out.write_override.map(|c| c.0) == Some(60)));
    assert!(
        recs.iter().all(|r| r.out.state == AccState::Active),
        "no fault release"
    );
    assert_eq!(
        rig.status().override_applied_pct,
        100,
        "the NC forces 100 %"
    );
    rig.b.board.set_override_locked(false);
    rig.run(2);
    assert_eq!(rig.lp.law().frozen_calls, vec![true, false]);
    assert!(rig.lp.law().seen.len() > steps_before);
    assert_eq!(rig.status().override_applied_pct, 60);
}

#[test]
fn operator_knob_down_more_than_handback_hands_control_back() {
    let mut rig = Rig::new(PolicyConfig::default(), [130]);
    rig.run(2);
    rig.b.board.set_operator_override_pct(90); // down by exactly 10: keeps ACC
    rig.run(2);
    assert_eq!(rig.state(), AccState::Active);
    rig.b.board.set_operator_override_pct(120); // up: new reference
    rig.run(1);
    rig.b.board.set_operator_override_pct(100); // down 20 from 120
    let r = rig.step();
    assert!(released(&r, Release::OperatorHandback));
    assert!(!r.out.alarms.any(), "a hand-back is not an alarm");
    rig.run(1);
    assert_eq!(rig.status().override_applied_pct, 100);
    rig.run(3);
    assert_eq!(rig.state(), AccState::Latched(Release::OperatorHandback));
}

#[test]
fn on_a_v1_board_a_knob_above_the_command_caps_acc_instead_of_raising_the_feed() {
    // ACC drives 50 %; the operator turns the knob from 100 % to 70 %: handing back would
    // move a v1 board to 70 % (a raise). ACC keeps control with 70 % as its ceiling: when
    // its law asks for more (90 %) the command stops at the knob, and ACC stays in control
    // (at the knob's value a hand-back would hold a dither step for good).
    let mut rig = Rig::v1(PolicyConfig::default(), [50, 50, 50, 50, 90, 90, 90]);
    rig.run(3);
    assert_eq!(rig.status().override_applied_pct, 50);
    rig.b.board.set_operator_override_pct(70);
    for r in rig.run(6) {
        assert!(
            !released(&r, Release::OperatorHandback),
            "{:?}",
            r.out.events
        );
        assert_eq!(r.out.state, AccState::Active);
        let applied = rig.status().override_applied_pct;
        assert!(applied <= 70, "never above the knob: {applied}");
        assert!(!r.out.control.feed_hold_request);
    }
    assert_eq!(
        rig.status().override_applied_pct,
        70,
        "the law's 90 % capped at the knob"
    );
    // A knob turned below ACC's command hands back at once.
    let mut rig = Rig::v1(PolicyConfig::default(), [50]);
    rig.run(3);
    rig.b.board.set_operator_override_pct(40);
    assert!(released(&rig.step(), Release::OperatorHandback));
    rig.run(1);
    assert_eq!(
        rig.status().override_applied_pct,
        40,
        "handed back below ACC's command"
    );
    // A v2 board hands back at once: its clamp keeps ACC's 50 %.
    let mut rig = Rig::new(PolicyConfig::default(), [50]);
    rig.run(3);
    rig.b.board.set_operator_override_pct(70);
    let r = rig.step();
    assert!(released(&r, Release::OperatorHandback));
    rig.run(1);
    assert_eq!(rig.status().override_applied_pct, 50, "the v2 clamp");
}

#[test]
fn never_commands_above_the_configured_maximum() {
    let cfg = PolicyConfig {
        max_override_pct: 120,
        min_override_pct: 15,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [150, 137, 5, 0, 119]);
    let recs = rig.run(6);
    let cmds: Vec<u16> = recs
        .iter()
        .filter_map(|r| r.out.write_override.map(|c| c.0))
        .collect();
    // armed at 100 (in force); then 150→120, 137→130→120 (max), 5→20 (min 15 rounded up
    // to the 10 % step), 0→20, 119→110 (floored to the step)
    assert_eq!(cmds, vec![100, 120, 120, 20, 20, 110]);
    assert!(rig.b.override_writes.iter().all(|&(c, _)| c <= 120));
}

#[test]
fn invalid_policy_config_names_the_key() {
    let e = PolicyConfig {
        max_override_pct: 160,
        ..PolicyConfig::default()
    }
    .validate()
    .expect_err("out of range");
    assert_eq!(e.key, "max_override_pct");
    assert!(e.to_string().contains("1 ..= 150"));
    let e = PolicyConfig {
        overload_time_s: f64::NAN,
        ..PolicyConfig::default()
    }
    .validate()
    .expect_err("out of range");
    assert_eq!(e.key, "overload_time_s");
    // Counts of tolerated faults must be positive: 0 would release on one CRC error.
    for (cfg, key) in [
        (
            PolicyConfig {
                link_hold_periods: 0,
                ..PolicyConfig::default()
            },
            "link_hold_periods",
        ),
        (
            PolicyConfig {
                invalid_power_periods: 0,
                ..PolicyConfig::default()
            },
            "invalid_power_periods",
        ),
    ] {
        let e = cfg.validate().expect_err("zero refused");
        assert_eq!(e.key, key);
        assert!(
            e.to_string().contains("= 0") && e.to_string().contains("1 ..= 1000"),
            "{e}"
        );
    }
    assert!(PolicyConfig {
        link_hold_periods: 1,
        invalid_power_periods: 1,
        ..PolicyConfig::default()
    }
    .validate()
    .is_ok());
}

mod invariant {
    use super::*;
    use proptest::prelude::*;

    #[derive(Debug, Clone)]
    struct Period {
        link: Result<BoardStatus, BoardErrorKind>,
        write_error: Option<BoardErrorKind>,
        force: ForceSample,
        law_cmd: u16,
    }

    fn kind() -> impl Strategy<Value = BoardErrorKind> {
        prop_oneof![
            Just(BoardErrorKind::Timeout),
            Just(BoardErrorKind::Crc),
            Just(BoardErrorKind::Exception(3)),
            Just(BoardErrorKind::Disconnected),
            Just(BoardErrorKind::Protocol),
        ]
    }

    fn status() -> impl Strategy<Value = BoardStatus> {
        (
            proptest::bits::u8::masked(0x7f),
            0u16..=15,
            0u16..=15,
            prop_oneof![Just(10u16), Just(1u16)],
            0u16..4,
            any::<u32>(),
        )
            .prop_map(|(bits, applied, op, step, seq, power)| BoardStatus {
                acc_switch: bits & 1 != 0 || bits & 0x40 != 0,
                acc_active: bits & 2 != 0,
                cycle_active: bits & 4 != 0,
                feed_hold_active: bits & 8 != 0,
                watchdog_tripped: bits & 0x10 != 0 && bits & 0x20 != 0,
                override_locked: bits & 0x20 != 0 && bits & 1 != 0,
                cnc_alarm: false,
                override_applied_pct: applied * 10,
                operator_override_pct: op * 10,
                override_step_pct: step,
                spindle_power_w: power % 5000,
                spindle_rpm: 600,
                sample_seq: seq,
                programmed_feed_mm_min: 200,
                ..BoardStatus::default()
            })
    }

    fn force() -> impl Strategy<Value = ForceSample> {
        prop_oneof![
            4 => (0.0f64..2500.0).prop_map(|f| ForceSample { force_n: f, power_w: Some(2.0 * f), valid: true }),
            1 => Just(ForceSample::INVALID),
            1 => Just(ForceSample { force_n: f64::NAN, power_w: Some(1.0), valid: true }),
            1 => Just(ForceSample { force_n: -1.0, power_w: Some(-2.0), valid: true }),
            1 => Just(ForceSample { force_n: 700.0, power_w: Some(1e9), valid: true }),
        ]
    }

    fn period() -> impl Strategy<Value = Period> {
        (
            prop_oneof![4 => status().prop_map(Ok), 1 => kind().prop_map(Err)],
            prop_oneof![6 => Just(None), 1 => kind().prop_map(Some)],
            force(),
            0u16..=200,
        )
            .prop_map(|(link, write_error, force, law_cmd)| Period {
                link,
                write_error,
                force,
                law_cmd,
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1024))]
        /// No period with a fault input (link error, write error, invalid/NaN/negative/
        /// implausible force, stale sequence, watchdog tripped, override locked) ever writes an
        /// override above the last one written; no write ever exceeds the maximum or misses
        /// the board step.
        #[test]
        fn no_fault_input_ever_raises_the_commanded_override(
            periods in proptest::collection::vec(period(), 1..120),
            max in 60u16..=150,
        ) {
            let cfg = PolicyConfig { max_override_pct: max, stale_seq_periods: 2, ..PolicyConfig::default() };
            let mut p = FaultPolicy::new(cfg);
            let mut law = ScriptedLaw::new(periods.iter().map(|x| x.law_cmd));
            let mut last_written: Option<u16> = None;
            let mut last_seq: Option<u16> = None;
            let mut same_seq = 0u32;
            for (i, x) in periods.iter().enumerate() {
                let input = PolicyInput {
                    t_s: i as f64 * 0.1,
                    link: x.link,
                    write_error: x.write_error,
                    force: if x.link.is_ok() { x.force } else { ForceSample::INVALID },
                    programmed_feed_mm_min: 200.0,
                    feed_mm_min: x.link.map_or(0.0, |s| 2.0 * f64::from(s.override_applied_pct)),
                    held: false,
                    delay: Default::default(),
        log_stalled: false,
                };
                let stale = match x.link {
                    Ok(s) => {
                        same_seq = if last_seq == Some(s.sample_seq) { same_seq + 1 } else { 0 };
                        last_seq = Some(s.sample_seq);
                        same_seq >= 2
                    }
                    Err(_) => false,
                };
                let f = input.force;
                let tripped = x.link.is_ok_and(|s| s.watchdog_tripped);
                let fault = x.link.is_err()
                    || x.write_error.is_some()
                    || stale
                    || !f.valid
                    || !f.force_n.is_finite()
                    || f.force_n < 0.0
                    || f.power_w.is_some_and(|p| !(0.0..=cfg.max_power_w).contains(&p))
                    || x.link.is_ok_and(|s| s.watchdog_tripped || s.override_locked);
                let out = p.step(&input, &mut law);
                let is_arm = out.events.iter().any(|e| matches!(e, Event::Armed { .. }));
                if let Some(c) = out.write_override {
                    prop_assert!(c.0 <= max, "period {}: {} above max {}", i, c.0, max);
                    if let Ok(s) = x.link {
                        let step = if s.override_step_pct == 0 { 10 } else { s.override_step_pct };
                        prop_assert_eq!(c.0 % step, 0);
                    }
                    if fault && !is_arm {
                        if let Some(last) = last_written {
                            prop_assert!(c.0 <= last, "period {}: fault raised {} -> {}", i, last, c.0);
                        }
                    }
                    last_written = Some(c.0);
                }
                prop_assert!(!fault || out.fault, "period {}: fault input not flagged", i);
                if is_arm {
                    // The operator's switch re-arms a tripped board (with ALARM_RESET); any
                    // other fault input blocks arming.
                    let other = fault && !(tripped && !x.link.is_ok_and(|s| s.override_locked)
                        && x.write_error.is_none() && !stale && f.valid && f.force_n.is_finite()
                        && f.force_n >= 0.0
                        && f.power_w.is_none_or(|p| (0.0..=cfg.max_power_w).contains(&p)));
                    prop_assert!(!other, "period {}: armed on a faulty period", i);
                    prop_assert!(out.control.alarm_reset == tripped);
                }
            }
        }
    }
}

#[test]
fn the_run_log_carries_the_nc_context_of_a_v2_board_only() {
    let mut rig = Rig::new(PolicyConfig::default(), [80]);
    rig.b.board.set_tool_number(12);
    rig.b.board.set_program_number(4711);
    rig.b.board.set_block_number(230);
    let row = rig.step().record(None);
    assert_eq!(
        (row.tool, row.program, row.block),
        (Some(12), Some(4711), Some(230))
    );
    rig.b.board.set_block_number(0); // 0 = unknown on the board: an empty cell
    assert_eq!(rig.step().record(None).block, None);
    // A v1 board has no such registers: the cells stay empty whatever the board holds.
    let mut rig = Rig::v1(PolicyConfig::default(), [80]);
    rig.b.board.set_tool_number(12);
    let row = rig.step().record(None);
    assert_eq!((row.tool, row.program, row.block), (None, None, None));
}

/// The tool table's wear and breakage levels reach the fault policy's breakage watch for the
/// tool the board reports (and `[default]`'s for a tool it does not list).
#[test]
fn the_tools_breakage_limits_follow_the_tool_number() {
    use acc_pmc::BoardStatus;
    use acc_runtime::testing::{LinearPowerForce, ScriptedLaw};
    use acc_runtime::{ControlLoop, FaultPolicy, PolicyConfig, ShopControl};
    let text = "[default]\nfr_n = 800.0\nbreakage_spike_x = 3.0\nbreakage_drop_pct = 60.0\n\
                [tool.2]\nfr_n = 500.0\nbreakage_spike_x = 1.8\nbreakage_drop_pct = 45.0\n\
                wear_warn_pct = 10.0\nwear_limit_pct = 20.0\n";
    let table = acc_config::ToolTable::parse("t.toml", text).expect("table");
    let mut control = ControlLoop::new(
        FaultPolicy::new(PolicyConfig::default()),
        ScriptedLaw::new([100]),
        LinearPowerForce { n_per_w: 1.0 },
        0.1,
    )
    .with_shop(ShopControl::new(table, 0.1));
    let status = |tool: u16| BoardStatus {
        protocol_version: acc_pmc::regs::PROTOCOL_V2,
        tool_number: tool,
        spindle_rpm: 500,
        spindle_power_w: 100,
        programmed_feed_mm_min: 200,
        override_applied_pct: 100,
        operator_override_pct: 100,
        cycle_active: true,
        override_step_pct: 10,
        ..BoardStatus::default()
    };
    control.decide(0.0, Ok(status(2)));
    let l = *control.policy().watch_limits();
    assert_eq!(
        (
            l.breakage_spike_factor,
            l.breakage_drop_pct,
            l.wear_warn_pct,
            l.wear_limit_pct
        ),
        (1.8, 45.0, 10.0, 20.0)
    );
    // A tool change counts once the next read confirms it (the line guard's debounce).
    let first = control.decide(0.1, Ok(status(7)));
    assert!(first.record(None).flags.contains("unconfirmed:tool_number"));
    let l = *control.policy().watch_limits();
    assert_eq!((l.breakage_spike_factor, l.breakage_drop_pct), (1.8, 45.0));
    control.decide(0.2, Ok(status(7)));
    let l = *control.policy().watch_limits();
    assert_eq!((l.breakage_spike_factor, l.breakage_drop_pct), (3.0, 60.0));
}

/// The tool table's overload limit and reaction follow the tool: `warning` raises the alarm
/// and keeps regulating, `spindle_stop` requests feed hold and logs the spindle-stop request.
#[test]
fn the_tools_overload_limit_and_reaction_follow_the_tool_number() {
    use acc_pmc::BoardStatus;
    use acc_runtime::testing::{LinearPowerForce, ScriptedLaw};
    use acc_runtime::{ControlLoop, FaultPolicy, PolicyConfig, ShopControl};
    let text = "[default]\nfr_n = 800.0\n\
                [tool.2]\noverload_n = 900.0\noverload_time_s = 0.1\noverload_reaction = \"warning\"\n\
                [tool.3]\noverload_n = 900.0\noverload_time_s = 0.1\noverload_reaction = \"spindle_stop\"\n";
    let table = acc_config::ToolTable::parse("t.toml", text).expect("table");
    let run = |tool: u16| {
        let mut control = ControlLoop::new(
            FaultPolicy::new(PolicyConfig::default()),
            ScriptedLaw::new([100]),
            LinearPowerForce { n_per_w: 1.0 },
            0.1,
        )
        .with_shop(ShopControl::new(table.clone(), 0.1));
        let status = |seq: u16| BoardStatus {
            protocol_version: acc_pmc::regs::PROTOCOL_V2,
            tool_number: tool,
            sample_seq: seq,
            spindle_rpm: 500,
            spindle_power_w: 1000, // 1000 N: above the tool's 900 N, below the default 1600 N
            programmed_feed_mm_min: 200,
            override_applied_pct: 100,
            operator_override_pct: 100,
            cycle_active: true,
            override_step_pct: 10,
            ..BoardStatus::default()
        };
        let recs: Vec<_> = (0..5u16)
            .map(|i| {
                control
                    .decide(f64::from(i) * 0.1, Ok(status(i + 1)))
                    .record(None)
            })
            .collect();
        (control.policy().alarms().overload, recs)
    };
    let (alarm, recs) = run(2);
    assert!(alarm, "warning: the overload alarm is raised");
    assert!(recs.iter().all(|r| !r.feed_hold), "warning: no feed hold");
    let (alarm, recs) = run(3);
    assert!(alarm);
    assert!(recs.iter().any(|r| r.feed_hold), "spindle_stop: feed hold");
    assert!(
        recs.iter()
            .any(|r| r.flags.contains("overload:spindle_stop")),
        "spindle_stop: the request is logged"
    );
    let (alarm, recs) = run(7);
    assert!(
        !alarm && recs.iter().all(|r| !r.feed_hold),
        "default: 1600 N"
    );
}

/// The debounce's cost on a real operator act: the knob turned down from 100 % to 60 %
/// mid-cut is handed back one period (0.1 s) later with the default `debounce_reads` = 2
/// than without debounce, within the 0.2 s the issue allows; a one-frame flipped knob value
/// is never an operator act.
#[test]
fn debounce_costs_one_period_on_a_real_knob_move_and_ignores_a_flipped_frame() {
    let periods_to_handback = |debounce_reads: u32| {
        let cfg = PolicyConfig {
            debounce_reads,
            ..PolicyConfig::default()
        };
        let mut rig = Rig::exact(ScriptedBoard::new(), cfg, [70]);
        rig.run(5);
        assert_eq!(rig.state(), AccState::Active);
        rig.b.board.set_operator_override_pct(60);
        (1..=10)
            .find(|_| released(&rig.step(), Release::OperatorHandback))
            .expect("handed back")
    };
    let plain = periods_to_handback(1);
    let debounced = periods_to_handback(2);
    assert_eq!(plain, 1, "without debounce: the period that reads the knob");
    assert_eq!(debounced, 2, "one more read confirms it");
    let cost_s = f64::from(debounced - plain) * 0.1;
    assert!(cost_s <= 0.2 + 1e-9, "reaction cost {cost_s} s");

    // One corrupted frame: the knob reads 60 for one period only.
    let mut rig = Rig::exact(ScriptedBoard::new(), PolicyConfig::default(), [70]);
    rig.run(5);
    rig.b.board.set_operator_override_pct(60);
    let flipped = rig.step();
    assert!(flipped
        .record(None)
        .flags
        .contains("unconfirmed:operator_override"));
    rig.b.board.set_operator_override_pct(100);
    let after = rig.run(5);
    assert!(std::iter::once(&flipped)
        .chain(after.iter())
        .all(|r| !released(r, Release::OperatorHandback)));
    assert_eq!(rig.state(), AccState::Active);
}

/// A cut that ends with its block: the read that shows the force drop already shows the
/// next block's number, which the line guard holds until the next read confirms it. The
/// breakage watch judges that drop one period later: the next block confirmed, no
/// breakage; the block number back (a bad frame), a breakage; the same drop in a block that
/// goes on is one at once.
#[test]
fn a_drop_while_the_next_block_waits_for_confirmation_is_judged_a_period_later() {
    // The flags of the period of the drop (the board showing `first`) and the next
    // (showing `then`).
    let run = |first: u16, then: u16| {
        let cfg = PolicyConfig::default();
        let law = ScriptedLaw {
            force_ref_n: Some(800.0),
            ..ScriptedLaw::new([100])
        };
        let mut rig = Rig::with_law(ScriptedBoard::new(), cfg, law);
        rig.power_w = 1600; // 800 N
        rig.b.board.set_tool_number(1);
        rig.b.board.set_block_number(10);
        let steady = rig.run(30);
        assert_eq!(rig.state(), AccState::Active);
        assert!(steady
            .iter()
            .all(|r| !r.record(None).flags.contains("breakage")));
        rig.b.board.set_block_number(first);
        rig.power_w = 200; // 100 N
        let drop = rig.step().record(None).flags;
        rig.b.board.set_block_number(then);
        (drop, rig.step().record(None).flags)
    };
    let (drop, next) = run(11, 11);
    assert!(drop.contains("unconfirmed:block_number"), "{drop}");
    assert!(
        !drop.contains("breakage") && !next.contains("breakage"),
        "{drop} / {next}"
    );
    let (drop, next) = run(11, 10);
    assert!(!drop.contains("breakage"), "{drop}");
    assert!(next.contains("breakage:drop"), "{next}");
    let (drop, _) = run(10, 10);
    assert!(drop.contains("breakage:drop"), "{drop}");
}

/// The NC's feed hold mid-cut (the operator's button, a paused program): the axes stand and
/// the force falls to nothing, but the law is not stepped on it; the last command is written
/// every period (the heartbeat goes on) and the cut resumes at it. Without the rule, a law
/// stepped on the missing chip winds up to the maximum override for the resume (measured on
/// LinuxCNC: 3.4 Fr at the resume of a paused heavy cut).
#[test]
fn a_feed_hold_mid_cut_holds_the_command_and_the_law() {
    let mut rig = Rig::new(
        PolicyConfig::default(),
        [60, 70, 80, 90, 100, 110, 120, 130],
    );
    rig.power_w = 1600; // 800 N: cutting
    let before = rig.run(2);
    let last = before[1].out.write_override.expect("a command").0;
    assert_eq!(rig.state(), AccState::Active);
    rig.b.board.set_operator_feed_hold(true);
    rig.power_w = 0;
    let held = rig.run(6);
    // The first period reads the hold unconfirmed (the line guard); from the confirmation on
    // every period writes the last command and steps nothing.
    for r in held.iter().skip(2) {
        assert_eq!(r.out.write_override.map(|o| o.0), Some(last), "{r:?}");
        assert!(
            r.out.step.is_none(),
            "the law is not stepped in a feed hold"
        );
        assert_eq!(r.writes.override_and_heartbeat.map(|w| w.0), Some(last));
    }
    assert_eq!(rig.state(), AccState::Active, "ACC keeps the cut");
    rig.b.board.set_operator_feed_hold(false);
    rig.power_w = 1600;
    let resumed = rig.run(3);
    let first_step = resumed
        .iter()
        .find_map(|r| r.out.step.map(|s| s.command.0))
        .expect("the law steps again after the hold");
    assert!(
        first_step <= 90,
        "the law resumes where it was, not wound up: {first_step}"
    );
}
