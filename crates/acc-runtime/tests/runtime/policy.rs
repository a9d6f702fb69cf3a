//! Fault policy, part one: arming on the switch, link loss, CRC errors, invalid or stale
//! power, the watchdog and board restarts — each case against a scripted board
//! (`ScriptedBoard`: the spec's `BoardLogic` behind a link with scripted faults) and a
//! scripted law, on board time advanced 100 ms per period (the rig is in `common`; part two
//! is `policy_operator.rs`).

use acc_core::ForceSample;
use acc_pmc::{BoardErrorKind, BoardStatus};
use acc_runtime::policy::{
    AccState, Event, FaultPolicy, PolicyConfig, PolicyInput, Rearm, Release,
};
use acc_runtime::testing::{LinkFault, ScriptedBoard, ScriptedLaw};

use crate::common::*;

#[test]
fn arms_bumpless_only_while_the_switch_is_on() {
    let mut rig = Rig::new(PolicyConfig::default(), [80, 90]);
    rig.b.board.set_acc_switch(false);
    rig.b.board.set_operator_override_pct(70);
    let idle = rig.run(3);
    assert!(idle.iter().all(|r| r.out.state == AccState::Idle));
    assert!(
        rig.b.override_writes.is_empty(),
        "nothing written while off"
    );
    assert!(!rig.status().acc_active);

    rig.b.board.set_acc_switch(true);
    let r = rig.step();
    assert!(r.out.events.contains(&Event::Armed {
        at_pct: 70,
        alarm_reset: false
    }));
    assert_eq!(
        rig.lp.law().engaged,
        vec![70],
        "bumpless: engaged at the override in force"
    );
    rig.run(2);
    assert!(rig.status().acc_active);
    assert_eq!(rig.status().override_applied_pct, 90);

    // switch off: released at once, not latched; the board follows the operator again
    rig.b.board.set_acc_switch(false);
    let r = rig.step();
    assert!(released(&r, Release::SwitchOff));
    assert_eq!(rig.state(), AccState::Idle);
    assert!(!rig.status().acc_active);
    assert_eq!(rig.status().override_applied_pct, 70);
    // on again: re-arms without further ceremony
    rig.b.board.set_acc_switch(true);
    assert!(armed(&rig.step()));
}

#[test]
fn link_timeout_holds_then_stops_commanding_and_rearms_when_the_link_returns_mid_cut() {
    let cfg = PolicyConfig {
        link_hold_periods: 5,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [110, 120]);
    rig.run(4);
    assert_eq!(rig.status().override_applied_pct, 120);
    // every transaction times out for a while (requests never reach the board)
    rig.b
        .inject(LinkFault::RequestLost(BoardErrorKind::Timeout), 200);
    let during: Vec<_> = rig.run(5);
    for r in &during {
        assert_eq!(r.out.state, AccState::Active);
        assert_eq!(r.out.write_override.map(|c| c.0), Some(120), "held");
        assert!(r.out.control.acc_request);
    }
    let r = rig.step();
    assert!(
        released(&r, Release::LinkLost),
        "released after 5 held periods"
    );
    assert!(r.out.alarms.link_lost);
    assert!(!r.out.control.acc_request);
    assert_eq!(r.out.write_override, None, "no more heartbeat");
    // a release mid-cut that is not the operator's is a feed hold, on a v2 board too (the
    // clamp holds the override, nobody holds the force)
    assert!(r.out.control.feed_hold_request);
    // nothing is commanded while the link is down: the board's watchdog trips, its clamp
    // (and, FALLBACK_MODE = 1, its feed hold) takes over
    let writes_before = rig.b.override_writes.len();
    let down = rig.run(10);
    assert!(down.iter().all(|r| r.out.write_override.is_none()));
    assert_eq!(rig.b.override_writes.len(), writes_before);
    let st = rig.status_now();
    assert!(st.watchdog_tripped && st.fallback_active && st.feed_hold_active);
    assert!(st.override_applied_pct <= 120);
    // link back, the cut still on: re-armed at the last command (no switch cycle), the
    // override written before ACC_REQUEST | ALARM_RESET
    rig.b.faults.clear();
    let controls_before = rig.b.control_writes.len();
    let back = rig.run(3);
    let re = back
        .iter()
        .find(|r| {
            r.out.events.contains(&Event::Rearmed {
                reason: Rearm::LinkRestored,
                at_pct: 120,
            })
        })
        .expect("re-armed at 120");
    assert_eq!(re.writes.override_and_heartbeat.map(|p| p.0), Some(120));
    let c = re.writes.control.expect("control written");
    assert!(c.acc_request && c.alarm_reset && !c.feed_hold_request);
    assert_eq!(rig.b.override_writes.last().map(|w| w.0), Some(120));
    assert!(rig.b.control_writes[controls_before..]
        .iter()
        .any(|c| c.acc_request && c.alarm_reset));
    assert!(re.record(None).flags.contains("rearm:link_restored"));
    for r in &back {
        let s = r.link.expect("link back");
        assert!(
            s.override_applied_pct <= 120,
            "never above the last command"
        );
    }
    let st = rig.status();
    assert!(!st.watchdog_tripped && !st.feed_hold_active && st.acc_active);
    assert_eq!(st.override_applied_pct, 120);
    assert_eq!(rig.state(), AccState::Active);
    assert!(!rig.lp.policy().alarms().any());
}

#[test]
fn link_back_after_the_cut_ended_stays_latched_until_the_switch_cycles() {
    let cfg = PolicyConfig {
        link_hold_periods: 3,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [110, 120]);
    rig.run(4);
    rig.b
        .inject(LinkFault::RequestLost(BoardErrorKind::Timeout), 200);
    rig.run(10);
    assert_eq!(rig.state(), AccState::Latched(Release::LinkLost));
    rig.b.board.set_cycle_active(false);
    rig.b.faults.clear();
    rig.run(3);
    assert_eq!(
        rig.state(),
        AccState::Latched(Release::LinkLost),
        "no re-arm by itself out of the cut"
    );
    assert!(rig.status().watchdog_tripped);
    // operator cycles the switch: re-armed with ALARM_RESET, alarm cleared
    let (_, on) = rig.cycle_switch();
    assert!(on.out.events.contains(&Event::Armed {
        at_pct: 100,
        alarm_reset: true
    }));
    rig.run(2);
    assert!(!rig.status().watchdog_tripped);
    assert!(rig.status().acc_active);
    assert!(!rig.lp.policy().alarms().any());
}

#[test]
fn v1_link_loss_rearms_at_most_at_the_knob_when_the_link_returns() {
    let cfg = PolicyConfig {
        link_hold_periods: 3,
        ..PolicyConfig::default()
    };
    // ACC at 60 %, the operator's knob at 100 %: a v1 board's watchdog hands the feed to
    // the knob (no clamp) — unavoidable while nothing gets through
    let mut rig = Rig::v1(cfg, [60]);
    rig.run(4);
    rig.b
        .inject(LinkFault::RequestLost(BoardErrorKind::Timeout), 200);
    let recs = rig.run(12);
    let rel = recs
        .iter()
        .find(|r| released(r, Release::LinkLost))
        .expect("released");
    assert!(
        rel.out.control.feed_hold_request,
        "v1: a raising release asks for feed hold"
    );
    let st = rig.status_now();
    assert!(st.watchdog_tripped && st.override_applied_pct == 100 && !st.feed_hold_active);
    rig.b.faults.clear();
    let recs = rig.run(4);
    let re = recs
        .iter()
        .find_map(|r| {
            r.out.events.iter().find_map(|e| match e {
                Event::Rearmed { reason, at_pct } => Some((*reason, *at_pct)),
                _ => None,
            })
        })
        .expect("re-armed");
    assert_eq!(re, (Rearm::LinkRestored, 60));
    let st = rig.status();
    assert!(st.acc_active && !st.feed_hold_active && !st.watchdog_tripped);
    assert_eq!(st.override_applied_pct, 60);
}

#[test]
fn crc_errors_hold_then_release() {
    let cfg = PolicyConfig {
        link_hold_periods: 3,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [90]);
    rig.run(3);
    // replies are corrupt, but the requests reach the board: the heartbeat keeps it alive
    rig.b.inject(LinkFault::ReplyLost(BoardErrorKind::Crc), 100);
    let recs = rig.run(4);
    assert!(recs[..3].iter().all(|r| r.out.state == AccState::Active));
    assert!(recs[..3]
        .iter()
        .all(|r| r.out.write_override.map(|c| c.0) == Some(90)));
    assert!(released(&recs[3], Release::LinkLost));
    assert!(
        !rig.status().watchdog_tripped,
        "heartbeat reached the board while held"
    );
    assert!(
        !rig.b.board.control().acc_request,
        "release reached the board"
    );
    // a single CRC error inside the budget does not release
    let mut rig = Rig::new(cfg, [90]);
    rig.run(3);
    rig.b.inject(LinkFault::ReplyLost(BoardErrorKind::Crc), 1);
    rig.run(5);
    assert_eq!(rig.state(), AccState::Active);
}

#[test]
fn invalid_power_never_raises_the_feed_and_releases_after_n() {
    let cfg = PolicyConfig {
        invalid_power_periods: 4,
        ..PolicyConfig::default()
    };
    // the law asks for more and more (v1 board: a release hands the feed to the knob)
    let mut rig = Rig::v1(cfg, [80, 90, 100, 110, 120, 130, 140, 150]);
    rig.run(3);
    let before = rig.status().override_applied_pct;
    assert_eq!(before, 90);
    rig.power_w = u32::MAX; // "negative" power on the wire (−1 as i32): implausible
    let seen_before = rig.lp.law().seen.len();
    let recs = rig.run(5);
    for r in &recs[..4] {
        assert!(!r.out.force_valid);
        assert!(r.out.write_override.is_some_and(|c| c.0 <= before));
        assert_eq!(r.out.state, AccState::Active);
    }
    assert!(released(&recs[4], Release::PowerInvalid));
    assert!(recs[4].out.alarms.power_invalid);
    // the operator's knob (100 %) is above ACC's last command (90 %): handing back would
    // raise the feed, so the release requests feed hold
    assert!(recs[4].out.events.contains(&Event::FeedHold(true)));
    rig.step();
    assert!(rig.status().feed_hold_active);
    // the implausible samples never reached the law (the line guard held them: the law
    // was not stepped), and nothing it saw was not finite
    assert_eq!(rig.lp.law().seen.len(), seen_before);
    assert!(recs[..4]
        .iter()
        .all(|r| r.record(None).flags.contains("implausible:power")));
    assert!(rig.lp.law().seen.iter().all(|m| m.force_n.is_finite()));
}

#[test]
fn a_fault_release_mid_cut_holds_the_feed_whatever_the_knob() {
    // ACC at 120 %, the knob at 100 %: the release lowers the override, but nobody would
    // be holding the force: feed hold.
    let cfg = PolicyConfig {
        link_hold_periods: 2,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [120]);
    rig.run(3);
    rig.b
        .inject(LinkFault::ReplyLost(BoardErrorKind::Timeout), 6);
    let recs = rig.run(3);
    assert!(released(&recs[2], Release::LinkLost));
    assert!(recs[2].out.control.feed_hold_request);
    // Out of the cut (CYCLE_ACTIVE off) a release below the knob does not hold, and with
    // `hold_on_raising_release` off a raising one does not either.
    for (script, hold_on_raising) in [(120, true), (60, false)] {
        let cfg = PolicyConfig {
            link_hold_periods: 2,
            hold_on_raising_release: hold_on_raising,
            ..PolicyConfig::default()
        };
        let mut rig = Rig::v1(cfg, [script]);
        rig.b.board.set_cycle_active(false);
        rig.run(3);
        rig.b
            .inject(LinkFault::ReplyLost(BoardErrorKind::Timeout), 6);
        let recs = rig.run(3);
        assert!(released(&recs[2], Release::LinkLost), "{script}");
        assert!(!recs[2].out.control.feed_hold_request, "{script}");
    }
}

#[test]
fn implausible_board_power_is_invalid_even_if_the_source_accepts_it() {
    let mut p = FaultPolicy::new(PolicyConfig::default());
    let mut law = ScriptedLaw::new([150]);
    let st = BoardStatus {
        acc_switch: true,
        override_applied_pct: 60,
        operator_override_pct: 100,
        override_step_pct: 10,
        spindle_power_w: u32::MAX,
        ..BoardStatus::default()
    };
    let o = p.step(
        &PolicyInput {
            t_s: 0.0,
            link: Ok(st),
            write_error: None,
            force: ForceSample {
                force_n: 500.0,
                power_w: None,
                valid: true,
            },
            programmed_feed_mm_min: 200.0,
            feed_mm_min: 120.0,
            held: false,
            delay: Default::default(),
            log_stalled: false,
        },
        &mut law,
    );
    assert!(!o.force_valid);
}

#[test]
fn nan_or_negative_force_is_invalid() {
    let mut p = FaultPolicy::new(PolicyConfig::default());
    let mut law = ScriptedLaw::new([150]);
    let mut st = BoardStatus {
        acc_switch: true,
        override_applied_pct: 60,
        operator_override_pct: 100,
        override_step_pct: 10,
        programmed_feed_mm_min: 200,
        ..BoardStatus::default()
    };
    let good = ForceSample {
        force_n: 500.0,
        power_w: Some(1000.0),
        valid: true,
    };
    let input = |t: f64, seq: u16, force: ForceSample, st: &BoardStatus| PolicyInput {
        t_s: t,
        link: Ok(BoardStatus {
            sample_seq: seq,
            ..*st
        }),
        write_error: None,
        force,
        programmed_feed_mm_min: 200.0,
        feed_mm_min: 2.0 * f64::from(st.override_applied_pct),
        held: false,
        delay: Default::default(),
        log_stalled: false,
    };
    let o = p.step(&input(0.0, 1, good, &st), &mut law);
    assert_eq!(o.write_override.map(|c| c.0), Some(60));
    st.acc_active = true;
    for (k, bad) in [
        ForceSample {
            force_n: f64::NAN,
            ..good
        },
        ForceSample {
            force_n: -20.0,
            ..good
        },
        ForceSample {
            power_w: Some(f64::NAN),
            ..good
        },
        ForceSample {
            power_w: Some(-5.0),
            ..good
        },
    ]
    .into_iter()
    .enumerate()
    {
        let o = p.step(
            &input(0.1 * (k + 1) as f64, 2 + k as u16, bad, &st),
            &mut law,
        );
        assert!(!o.force_valid, "case {k}");
        assert_eq!(
            o.write_override.map(|c| c.0),
            Some(60),
            "case {k}: not raised"
        );
    }
}

#[test]
fn frozen_sample_seq_is_stale_power() {
    let cfg = PolicyConfig {
        stale_seq_periods: 3,
        invalid_power_periods: 5,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [80, 90, 100, 110, 120, 130, 140, 150]);
    let first = rig.run(2);
    // Where the sample sits in the board's sequence (logged as seq_repeat / seq_skip:n).
    assert_eq!(first[0].out.sample_advance, None, "no read before");
    assert_eq!(first[1].out.sample_advance, Some(1));
    rig.freeze_seq = true;
    let recs = rig.run(10);
    assert!(recs.iter().all(|r| r.out.sample_advance == Some(0)));
    // seq unchanged for 1, 2 periods: still valid; from the 3rd on stale
    assert!(recs[0].out.force_valid && recs[1].out.force_valid);
    assert!(!recs[2].out.force_valid);
    assert!(recs[2].out.events.contains(&Event::PowerInvalid {
        stale: true,
        consecutive: 1
    }));
    let at_stale = recs[1].out.write_override.map(|c| c.0).unwrap_or(0);
    for r in &recs[2..7] {
        assert!(r.out.write_override.is_some_and(|c| c.0 <= at_stale));
    }
    assert!(released(&recs[7], Release::PowerInvalid));
    // a frozen SAMPLE_SEQ is not a link error: the policy alone judges it
    assert!(recs
        .iter()
        .flat_map(|r| r.out.events.iter())
        .all(|e| !matches!(e, Event::LinkError { .. })));
}

#[test]
fn watchdog_trip_is_detected_and_rearmed_only_by_the_switch() {
    let mut rig = Rig::new(PolicyConfig::default(), [120]);
    rig.b.board.set_operator_override_pct(80);
    rig.run(3);
    assert_eq!(rig.status().override_applied_pct, 120);
    // the board saw no heartbeat for 600 ms (e.g. the PC stalled): it trips
    rig.b.now_ms += 600;
    let r = rig.step();
    assert!(r.out.events.contains(&Event::WatchdogTripped));
    assert!(released(&r, Release::Watchdog));
    assert!(r.out.alarms.watchdog);
    assert_eq!(rig.status().override_applied_pct, 80, "operator's override");
    // switch still on: stays latched
    rig.run(5);
    assert_eq!(rig.state(), AccState::Latched(Release::Watchdog));
    assert!(rig.status().watchdog_tripped);
    let (_, on) = rig.cycle_switch();
    assert!(on.out.control.alarm_reset && on.out.control.acc_request);
    rig.run(2);
    assert!(!rig.status().watchdog_tripped);
    assert!(rig.status().acc_active);
    assert_eq!(rig.state(), AccState::Active);
}

#[test]
fn v2_board_restart_mid_cut_rearms_at_the_last_command_without_motion_above_it() {
    let mut rig = Rig::new(PolicyConfig::default(), [70]);
    rig.run(3);
    assert!(rig.status().acc_active);
    assert_eq!(rig.status().override_applied_pct, 70);
    rig.b.board.power_cycle();
    let r = rig.step();
    // the period that sees the restart: the board is at the knob (100 %) but its power-up
    // feed hold stops the axes
    let s = r.link.expect("status");
    assert!(s.board_restarted && s.feed_hold_active);
    assert!(r.out.events.contains(&Event::Rearmed {
        reason: Rearm::BoardRestart,
        at_pct: 70
    }));
    assert!(r.record(None).flags.contains("rearm:board_restart"));
    assert_eq!(r.writes.override_and_heartbeat.map(|p| p.0), Some(70));
    let c = r.writes.control.expect("control");
    assert!(c.acc_request && c.alarm_reset);
    // override first, then CONTROL
    assert_eq!(rig.b.override_writes.last().map(|w| w.0), Some(70));
    let after = rig.run(5);
    for (pct, hold) in applied(&after) {
        assert_eq!((pct, hold), (70, false), "continues at the last command");
    }
    assert!(!rig.status().board_restarted);
    assert_eq!(rig.state(), AccState::Active);
    assert!(after.iter().all(|r| r.out.events.is_empty()));
}

#[test]
fn v1_board_restart_mid_cut_rearms_at_once_never_above_the_knob_or_the_last_command() {
    // knob (100 %) above the last command (70 %): one period at the knob is unavoidable,
    // the re-arm brings it back to 70 at once
    let mut rig = Rig::v1(PolicyConfig::default(), [70]);
    rig.run(3);
    rig.b.board.power_cycle();
    let recs = rig.run(4);
    assert!(recs[0].out.events.contains(&Event::Rearmed {
        reason: Rearm::BoardRestart,
        at_pct: 70
    }));
    assert_eq!(
        applied(&recs),
        vec![(100, false), (70, false), (70, false), (70, false)]
    );
    // knob (50 %) below the last command: the re-arm stays at the knob
    let mut rig = Rig::v1(
        PolicyConfig {
            operator_handback_pct: 60,
            ..PolicyConfig::default()
        },
        [70],
    );
    rig.run(3);
    rig.b.board.set_operator_override_pct(50);
    rig.b.board.power_cycle();
    let recs = rig.run(4);
    assert!(recs[0].out.events.contains(&Event::Rearmed {
        reason: Rearm::BoardRestart,
        at_pct: 50
    }));
    assert!(applied(&recs).iter().all(|(p, _)| *p <= 50));
}

#[test]
fn board_reset_out_of_the_cut_is_released_and_latched() {
    let mut rig = Rig::new(PolicyConfig::default(), [70]);
    rig.run(3);
    assert!(rig.status().acc_active);
    rig.b.board.set_cycle_active(false);
    rig.b.board.power_cycle();
    let r = rig.step();
    assert!(released(&r, Release::BoardReset));
    assert!(r.out.alarms.board_reset);
    assert!(r.out.fault);
    rig.run(3);
    assert_eq!(rig.state(), AccState::Latched(Release::BoardReset));
    assert!(!rig.status().acc_active);
    rig.cycle_switch();
    rig.run(2);
    assert!(rig.status().acc_active);
}

#[test]
fn a_board_that_keeps_restarting_is_released() {
    let mut rig = Rig::new(PolicyConfig::default(), [70]);
    rig.run(3);
    let mut recs = Vec::new();
    for _ in 0..12 {
        rig.b.board.power_cycle();
        recs.push(rig.step());
    }
    assert!(recs
        .iter()
        .any(|r| released(r, Release::BoardReset) || released(r, Release::NoBoardAck)));
    assert!(applied(&recs).iter().all(|(p, hold)| *p <= 70 || *hold));
}

#[test]
fn a_stopped_spindle_is_no_power_fault_acc_holds_through_it_and_drives_on() {
    // An M5 (a tool change, a program's end, an abort): no speed, no power, and a sample the
    // estimator cannot make (here: stale). Found on LinuxCNC: counted as invalid power, it
    // released ACC latched, and the program after it ran uncontrolled (3.4 Fr).
    let cfg = PolicyConfig {
        stale_seq_periods: 1,
        invalid_power_periods: 3,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [60, 70, 80, 90, 100, 110, 120, 130, 140, 150]);
    rig.run(3);
    let last = rig.lp.policy().last_command().expect("a command");
    rig.b.board.set_spindle_rpm(0);
    rig.power_w = 0;
    rig.freeze_seq = true;
    let stopped = rig.run(10);
    for r in &stopped {
        assert!(!r.out.force_valid);
        assert_eq!(r.out.state, AccState::Active, "held through the stop");
        assert!(r.out.write_override.is_some_and(|c| c.0 <= last));
        assert!(!r
            .out
            .events
            .iter()
            .any(|e| matches!(e, Event::PowerInvalid { .. })));
    }
    assert!(!stopped.iter().any(|r| r.out.control.feed_hold_request));
    // M3: the spindle turns, the samples are valid, the law steps on from the held command.
    rig.b.board.set_spindle_rpm(600);
    rig.power_w = 1200;
    rig.freeze_seq = false;
    let on = rig.run(3);
    assert!(on.iter().all(|r| r.out.state == AccState::Active));
    assert!(on
        .last()
        .is_some_and(|r| r.out.force_valid && r.out.step.is_some()));

    // A stalled spindle (no speed, but power drawn) is invalid power as before: released.
    let mut rig = Rig::new(cfg, [60, 70, 80]);
    rig.run(3);
    rig.b.board.set_spindle_rpm(0);
    rig.freeze_seq = true;
    let stalled = rig.run(5);
    assert!(stalled
        .iter()
        .any(|r| released(r, Release::PowerInvalid) && r.out.control.feed_hold_request));
}

#[test]
fn a_fault_release_mid_cut_holds_the_feed_on_v1_and_v2() {
    let cfg = PolicyConfig {
        invalid_power_periods: 2,
        ..PolicyConfig::default()
    };
    for (v2, mut rig) in [(true, Rig::new(cfg, [60])), (false, Rig::v1(cfg, [60]))] {
        rig.run(3);
        assert_eq!(rig.status().override_applied_pct, 60);
        rig.power_w = u32::MAX;
        let recs = rig.run(3);
        let rel = recs
            .iter()
            .find(|r| released(r, Release::PowerInvalid))
            .expect("released");
        assert!(rel.out.control.feed_hold_request, "v2 = {v2}");
        rig.power_w = 1200;
        let after = rig.run(3);
        let st = rig.status();
        assert!(st.feed_hold_active, "v2 = {v2}");
        if v2 {
            // and the board's clamp: min(knob 100, last 60)
            assert!(st.fallback_active);
            assert!(applied(&after).iter().all(|(p, _)| *p <= 60));
        } else {
            assert_eq!(st.override_applied_pct, 100);
        }
    }
}

#[test]
fn a_board_that_never_confirms_acc_is_released() {
    let cfg = PolicyConfig {
        ack_periods: 3,
        ..PolicyConfig::default()
    };
    let mut rig = Rig::new(cfg, [70]);
    // control writes get lost on the way, silently (the board never sees ACC_REQUEST)…
    // modelled by a board that drops CONTROL right after each write: power-cycle every period
    let mut recs = Vec::new();
    for _ in 0..6 {
        rig.b.board.power_cycle();
        recs.push(rig.step());
    }
    assert!(recs.iter().any(|r| released(r, Release::NoBoardAck)));
}

#[test]
fn a_program_stopped_in_the_cut_runs_again_at_the_command_that_was_cutting() {
    // An abort in the cut (CYCLE_ACTIVE falls, the spindle stops), the program run again
    // from its start: its air moves ask 150 %, but until its first cut has been measured
    // the command stays at the 40 % that was cutting when the program stopped. Found on
    // LinuxCNC: the re-entry into the wall the abort left, at the air's 150 %, reached
    // 3.3 Fr.
    let cfg = PolicyConfig {
        debounce_reads: 1,
        ..PolicyConfig::default()
    };
    let law = ScriptedLaw {
        force_ref_n: Some(800.0),
        ..ScriptedLaw::new([40; 10].into_iter().chain([150; 60]))
    };
    let mut rig = Rig::with_law(ScriptedBoard::new(), cfg, law);
    rig.power_w = 1700;
    let cut = rig.run(8);
    assert!(cut.iter().any(|r| r.out.state == AccState::Active));
    assert_eq!(rig.lp.policy().last_command(), Some(40));
    // The abort.
    rig.b.board.set_cycle_active(false);
    rig.b.board.set_spindle_rpm(0);
    rig.power_w = 0;
    rig.run(5);
    // Run again: the spindle on, the air moves (20 W: 10 N, no cut).
    rig.b.board.set_cycle_active(true);
    rig.b.board.set_spindle_rpm(600);
    rig.power_w = 20;
    let air = rig.run(20);
    for r in air.iter().filter(|r| r.out.step.is_some()) {
        assert_eq!(r.out.restart_cap, Some(40), "{:?}", r.out);
        assert!(r.out.write_override.is_some_and(|c| c.0 <= 40));
    }
    assert!(air.iter().filter(|r| r.out.step.is_some()).count() >= 15);
    // The re-entry: capped for its first ENTRY_PERIODS cutting periods, then the law is
    // free (here its script's 150 %).
    rig.power_w = 1700;
    let entry = rig.run(6);
    let capped: Vec<bool> = entry.iter().map(|r| r.out.restart_cap.is_some()).collect();
    assert_eq!(capped, [true, true, true, false, false, false], "{entry:?}");
    assert!(entry[..3]
        .iter()
        .all(|r| r.out.write_override.is_some_and(|c| c.0 <= 40)));
    assert_eq!(entry[5].out.write_override.map(|c| c.0), Some(150));

    // A program that ends in air and starts again: no cap.
    let mut rig = Rig::new(cfg, [150; 40]);
    rig.power_w = 20;
    rig.run(10);
    rig.b.board.set_cycle_active(false);
    rig.run(3);
    rig.b.board.set_cycle_active(true);
    let again = rig.run(5);
    assert!(again.iter().all(|r| r.out.restart_cap.is_none()));
}
