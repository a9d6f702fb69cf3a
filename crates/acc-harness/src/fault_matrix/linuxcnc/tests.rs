//! The rows judged on hand-made logs: each criterion passes and fails.

use acc_linuxcnc::machine_log::MachineRow;
use acc_runtime::record::RunRecord;

use super::*;

const FR: f64 = 800.0;

/// A machine log every 10 ms to `end_s`: heartbeat toggling every 0.1 s until
/// `silent_from` (then still), the fault at `t_fault`, feed/force/adaptive by time.
fn machine(
    end_s: f64,
    t_fault: f64,
    silent_from: f64,
    at: impl Fn(f64) -> (f64, f64, f64, f64),
) -> Vec<MachineRow> {
    (0..=(end_s * 100.0) as u32)
        .map(|k| {
            let t = f64::from(k) * 0.01;
            let (feed, force, af, fo) = at(t);
            let beat_t = t.min(silent_from);
            MachineRow {
                t_s: t,
                feed_mm_min: feed,
                force_n: force,
                adaptive_feed: af,
                heartbeat: ((beat_t * 10.0).floor() as u64) % 2 == 1,
                feed_override: fo,
                fault: t >= t_fault,
                ..MachineRow::default()
            }
        })
        .collect()
}

/// A run log every 0.1 s to `end_s` (its clock 0.1 s behind the machine log's first
/// toggle), with state and command by time.
fn run_log(end_s: f64, at: impl Fn(f64) -> (&'static str, u16, u16)) -> Vec<RunRecord> {
    (0..=(end_s * 10.0) as u64)
        .map(|k| {
            let t = k as f64 * 0.1;
            let (state, cmd, applied) = at(t + 0.1);
            RunRecord {
                t_s: t,
                period: k,
                state: state.into(),
                override_cmd_pct: Some(cmd),
                override_applied_pct: Some(applied),
                programmed_feed_mm_min: Some(300.0),
                feed_mm_min: Some(300.0),
                force_ref_n: Some(FR),
                ..RunRecord::default()
            }
        })
        .collect()
}

fn fault(name: &str) -> &'static LcncFault {
    LCNC_FAULTS.iter().find(|f| f.name == name).expect("row")
}

#[test]
fn a_frozen_acc_whose_watchdog_stops_the_motion_and_whose_clamp_holds_passes() {
    // Cutting at 0.6 × 150 % = 90 %; acc frozen at 5 s: the feed 0 from 5.22 s to 7.5 s,
    // then the clamp at 90 % again.
    let mut m = machine(12.0, 5.0, 5.0, |t| {
        let feed = if (5.22..7.5).contains(&t) { 0.0 } else { 270.0 };
        (feed, 700.0, 0.6, 1.5)
    });
    // The heartbeat comes back after SIGCONT at 7 s.
    for r in m.iter_mut().filter(|r| r.t_s >= 7.0) {
        r.heartbeat = ((r.t_s * 10.0).floor() as u64) % 2 == 1;
    }
    let run = run_log(11.0, |t| {
        if t < 5.0 {
            ("active", 90, 90)
        } else {
            ("watchdog", 90, 90)
        }
    });
    let r = judge(fault("stop-acc"), FR, &m, &run, "1.0 cycle_s 11.5\n");
    assert!(r.ok, "{r:#?}");
    assert_eq!(r.allowed_pct.map(f64::round), Some(90.0));
    assert!(
        (r.stop_s.expect("stop") - 0.22).abs() < 0.011,
        "{:?}",
        r.stop_s
    );
    assert_eq!(r.states_after, vec!["watchdog".to_string()]);
    assert_eq!(r.program, "completed (11.5 s)");
}

#[test]
fn a_feed_above_what_acc_allowed_while_it_is_silent_fails() {
    // acc frozen; the adaptive feed jumps to 1.0 (150 %) while it is silent.
    let m = machine(8.0, 5.0, 5.0, |t| {
        let af = if t > 5.5 { 1.0 } else { 0.6 };
        let feed = if (5.2..5.5).contains(&t) { 0.0 } else { 300.0 };
        (feed, 700.0, af, 1.5)
    });
    let run = run_log(5.0, |_| ("active", 90, 90));
    let r = judge(fault("stop-acc"), FR, &m, &run, "");
    assert!(!r.ok);
    assert!(r.verdict.contains("applied 150 %"), "{}", r.verdict);
    assert_eq!(r.program, "did not complete");
}

#[test]
fn acc_allowed_its_last_write_even_when_the_mark_came_before_it() {
    // acc's last period stepped 40 -> 50 %; its write landed between ui.py's mark (5.0 s)
    // and the freeze: the machine log shows 40 % before the mark and 50 % after it.
    let m = machine(8.0, 5.0, 5.0, |t| {
        let af = if t >= 5.02 {
            50.0 / 150.0
        } else {
            40.0 / 150.0
        };
        (300.0, 700.0, af, 1.5)
    });
    let run = run_log(5.0, |t| {
        if t < 4.9 {
            ("active", 40, 40)
        } else {
            ("active", 50, 40)
        }
    });
    let r = judge(fault("stop-acc"), FR, &m, &run, "");
    assert_eq!(r.allowed_pct.map(f64::round), Some(50.0), "{r:#?}");
    assert!(!r.verdict.contains("with acc not driving"), "{}", r.verdict);
    // A feed above that last write still fails.
    let m = machine(8.0, 5.0, 5.0, |t| {
        let af = if t >= 5.5 { 1.0 } else { 40.0 / 150.0 };
        let feed = if (5.2..5.5).contains(&t) { 0.0 } else { 300.0 };
        (feed, 700.0, af, 1.5)
    });
    let r = judge(fault("stop-acc"), FR, &m, &run, "");
    assert!(
        r.verdict.contains("applied 150 %") && r.verdict.contains("above the 50 %"),
        "{}",
        r.verdict
    );
}

#[test]
fn acc_raising_its_command_on_a_frozen_power_fails() {
    // The process killed at 5 s: its log ends; acc keeps driving and raises 90 → 120.
    let m = machine(5.05, 5.0, 99.0, |_| (270.0, 700.0, 0.6, 1.5));
    let run = run_log(10.0, |t| {
        let cmd = if t < 5.5 { 90 } else { 120 };
        ("active", cmd, cmd)
    });
    let r = judge(fault("kill-process"), FR, &m, &run, "1 cycle_s 12\n");
    assert!(!r.ok);
    assert!(
        r.verdict.contains("raised its command to 120 %"),
        "{}",
        r.verdict
    );
    assert_eq!(r.force_after_n, None);
    // Released on the stale sample and clamped instead: a pass.
    let run = run_log(10.0, |t| {
        if t < 5.3 {
            ("active", 90, 90)
        } else {
            ("power_invalid", 90, 90)
        }
    });
    let r = judge(fault("kill-process"), FR, &m, &run, "1 cycle_s 12\n");
    assert!(r.ok, "{r:#?}");
    assert_eq!(r.max_applied_not_driving_pct, Some(90.0));
}

#[test]
fn the_operators_knob_lowers_the_feed_and_a_missing_period_fails() {
    let m = machine(10.0, 5.0, 99.0, |t| {
        if t < 5.0 {
            (270.0, 700.0, 0.6, 1.5)
        } else {
            (90.0, 300.0, 1.0, 0.3)
        }
    });
    let mut run = run_log(9.0, |t| {
        if t < 5.1 {
            ("active", 90, 90)
        } else {
            ("operator_handback", 150, 30)
        }
    });
    let r = judge(fault("feed-override"), FR, &m, &run, "1 cycle_s 12\n");
    assert!(r.ok, "{r:#?}");
    assert_eq!(r.max_applied_not_driving_pct, Some(30.0));
    assert!(r.knob_s.expect("knob") < 0.02);
    run.remove(40);
    let r = judge(fault("feed-override"), FR, &m, &run, "1 cycle_s 12\n");
    assert!(r.verdict.contains("not consecutive"), "{}", r.verdict);
}

/// A run log every 0.1 s to `end_s` on the machine log's clock (see [`run_log`]), the
/// law stepped (mode set) where `at` says a state of `active` and `stepped`.
fn run_log_stepped(end_s: f64, at: impl Fn(f64) -> (&'static str, u16, bool)) -> Vec<RunRecord> {
    run_log(end_s, |t| {
        let (state, cmd, _) = at(t);
        (state, cmd, cmd)
    })
    .into_iter()
    .map(|mut r| {
        let (_, _, stepped) = at(r.t_s + 0.1);
        if stepped {
            r.mode = "adaptive_pi".into();
        }
        r
    })
    .collect()
}

/// The marker where `marked` says, instead of from the fault on.
fn marked(mut m: Vec<MachineRow>, marked: impl Fn(f64) -> bool) -> Vec<MachineRow> {
    for r in &mut m {
        r.fault = marked(r.t_s);
    }
    m
}

const COMPLETED: &str = "1 run x\n2 cycle_s 12.0\n";

#[test]
fn m52_off_passes_when_the_pin_holds_and_fails_when_it_says_150_percent() {
    // Cutting at 50 % (0.333 × 150 %), 900 N; M52 P0 from 5 to 9 s at F60 × 150 %.
    let cut = |pin_in_section: f64| {
        marked(
            machine(14.0, 5.0, 99.0, move |t| {
                if (5.0..9.0).contains(&t) {
                    (90.0, 540.0, pin_in_section, 1.5)
                } else if (9.0..9.05).contains(&t) && pin_in_section > 0.5 {
                    (450.0, 2250.0, pin_in_section, 1.5)
                } else {
                    (150.0, 900.0, 0.333, 1.5)
                }
            }),
            |t| (5.0..9.0).contains(&t),
        )
    };
    let run = run_log_stepped(13.0, |t| ("active", 50, !(5.0..9.1).contains(&t)));
    let r = judge(fault("m52-off"), FR, &cut(0.333), &run, COMPLETED);
    assert!(r.ok, "{r:#?}");
    let e = r.event.as_ref().expect("figures");
    assert_eq!(e.t_end_s, Some(9.0));
    assert_eq!(e.knob_during_pct, Some(150.0));
    assert!(e.pin_during_pct.is_some_and(|p| (p - 50.0).abs() < 0.1));
    assert!(r.outcome.contains("M52 P0 for 4.0 s"), "{}", r.outcome);
    // 1.0 on the pin under M52 P0: M52 P1 runs at 150 % until acc's next write.
    let r = judge(fault("m52-off"), FR, &cut(1.0), &run, COMPLETED);
    assert!(!r.ok);
    assert!(
        r.verdict.contains("the pin said 150 % under M52 P0"),
        "{}",
        r.verdict
    );
    assert!(
        r.verdict.contains("applied 150 % after M52 P1"),
        "{}",
        r.verdict
    );
    // A force above the one before that acc does not bring back.
    let high = marked(
        machine(14.0, 5.0, 99.0, |t| {
            if (5.0..9.0).contains(&t) {
                (90.0, 540.0, 0.333, 1.5)
            } else if (9.0..10.0).contains(&t) {
                (150.0, 1200.0, 0.333, 1.5)
            } else {
                (150.0, 900.0, 0.333, 1.5)
            }
        }),
        |t| (5.0..9.0).contains(&t),
    );
    let r = judge(fault("m52-off"), FR, &high, &run, COMPLETED);
    assert!(
        r.verdict
            .contains("stayed above 1.05 × 900 N for 1.00 s after M52 P1"),
        "{}",
        r.verdict
    );
    // M52 P1 never came back.
    let m = marked(cut(0.333), |t| t >= 5.0);
    let r = judge(fault("m52-off"), FR, &m, &run, COMPLETED);
    assert!(
        r.verdict.contains("M52 P1 never came back"),
        "{}",
        r.verdict
    );
}

#[test]
fn abort_restart_passes_when_acc_drives_on_and_fails_latched_or_wound_up() {
    // The first run cuts at 900 N to 5 s; aborted 5–6.3 s; the restart re-enters the
    // wall at 8 s (`entry_n` for 0.1 s), then 900 N.
    let restarted = |entry_n: f64| {
        marked(
            machine(14.0, 5.0, 99.0, move |t| {
                if (5.0..6.3).contains(&t) {
                    (0.0, 0.0, 0.333, 1.5)
                } else if (6.3..8.0).contains(&t) {
                    (450.0, 0.0, 1.0, 1.5)
                } else if (8.0..8.1).contains(&t) {
                    (450.0, entry_n, 1.0, 1.5)
                } else {
                    (150.0, 900.0, 0.333, 1.5)
                }
            }),
            |t| (5.0..6.3).contains(&t),
        )
    };
    let m = restarted(930.0);
    let ok = run_log_stepped(13.0, |_| ("active", 50, true));
    let r = judge(fault("abort-restart"), FR, &m, &ok, COMPLETED);
    assert!(r.ok, "{r:#?}");
    let e = r.event.as_ref().expect("figures");
    assert_eq!(
        (e.cmd_before_pct, e.cmd_after_end_pct),
        (Some(50), Some(50))
    );
    assert_eq!(e.peak_after_n, Some(930.0));
    // The re-entry at the air cut's command: 2 600 N for 0.1 s is above what ACC allowed.
    let r = judge(
        fault("abort-restart"),
        FR,
        &restarted(2600.0),
        &ok,
        COMPLETED,
    );
    assert!(
        r.verdict
            .contains("peak 2600 N after the restart > 1.05 × 900 N"),
        "{}",
        r.verdict
    );
    let e = r.event.as_ref().expect("figures");
    assert!(e
        .longest_excursion_s
        .is_some_and(|s| (s - 0.1).abs() < 0.011));
    // Latched on the abort's stopped spindle: the restart runs uncontrolled.
    let latched = run_log_stepped(13.0, |t| {
        if t < 5.2 {
            ("active", 50, true)
        } else {
            ("power_invalid", 50, false)
        }
    });
    let r = judge(fault("abort-restart"), FR, &m, &latched, COMPLETED);
    assert!(r.verdict.contains("acc did not drive in"), "{}", r.verdict);
    // Wound up over the abort.
    let wound = run_log_stepped(13.0, |t| ("active", if t < 6.0 { 50 } else { 150 }, true));
    let r = judge(fault("abort-restart"), FR, &m, &wound, COMPLETED);
    assert!(r.verdict.contains("restarted at 150 %"), "{}", r.verdict);
    // The force not brought back.
    let slow = marked(
        machine(14.0, 5.0, 99.0, |t| {
            if (5.0..6.3).contains(&t) {
                (0.0, 0.0, 0.333, 1.5)
            } else if t >= 8.0 {
                (450.0, 2600.0, 1.0, 1.5)
            } else {
                (150.0, 900.0, 0.333, 1.5)
            }
        }),
        |t| (5.0..6.3).contains(&t),
    );
    let r = judge(fault("abort-restart"), FR, &slow, &ok, COMPLETED);
    assert!(r.verdict.contains("peak 2600 N after"), "{}", r.verdict);
    // It never ran again.
    let r = judge(
        fault("abort-restart"),
        FR,
        &marked(m, |t| t >= 5.0),
        &ok,
        "",
    );
    assert!(r.verdict.contains("never ran again"), "{}", r.verdict);
}

#[test]
fn a_tool_change_passes_when_acc_drives_the_second_cut_and_fails_when_it_lets_go() {
    // The first tool: entry peak 1 390 N, 900 N; the change at 5 s; the second tool's
    // entry 1 180 N at 6 s, then 800 N.
    let m = marked(
        machine(12.0, 5.0, 99.0, |t| match t {
            t if t < 0.5 => (450.0, 1390.0, 1.0, 1.5),
            t if t < 4.0 => (150.0, 900.0, 0.333, 1.5),
            t if t < 6.0 => (0.0, 0.0, 1.0, 1.5),
            t if t < 6.3 => (450.0, 1180.0, 1.0, 1.5),
            _ => (210.0, 800.0, 0.467, 1.5),
        }),
        |t| t >= 5.0,
    );
    let ok = run_log_stepped(11.0, |_| ("active", 50, true));
    let r = judge(fault("tool-change"), FR, &m, &ok, COMPLETED);
    assert!(r.ok, "{r:#?}");
    let e = r.event.as_ref().expect("figures");
    assert_eq!((e.peak_before_n, e.peak_after_n), (1390.0, Some(1180.0)));
    assert_eq!(e.settled_mean_n, Some(800.0));
    // Released on the M5 with a feed hold: the second cut never under acc.
    let held = run_log_stepped(11.0, |t| {
        if t < 5.0 {
            ("active", 50, true)
        } else {
            ("power_invalid", 50, false)
        }
    });
    let r = judge(
        fault("tool-change"),
        FR,
        &m,
        &held,
        "1 feed inhibited for 5 s\n2 aborted\n",
    );
    assert!(r.verdict.contains("acc did not drive in"), "{}", r.verdict);
    assert!(r.verdict.contains("the program aborted"), "{}", r.verdict);
}

#[test]
fn a_fault_that_never_came_fails() {
    let m = machine(3.0, 99.0, 99.0, |_| (270.0, 300.0, 0.6, 1.5));
    let r = judge(fault("pause"), FR, &m, &[], "");
    assert!(
        r.verdict.starts_with("FAIL: the fault never came"),
        "{}",
        r.verdict
    );
}
