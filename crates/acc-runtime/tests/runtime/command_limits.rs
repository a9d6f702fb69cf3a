//! The tool's and the plan's limits on the law's command: judged by the policy before the
//! law steps and applied in the law's one quantization step. A limit below the law's
//! command is written on the board's grid and re-engages the law there; a cap above it
//! changes nothing. Checked with a scripted law against a scripted board, the policy driven
//! period by period.

use acc_core::{FeedOverride, ForceSample};
use acc_pmc::{Board, BoardStatus};
use acc_runtime::policy::{AccState, CommandLimits, FaultPolicy, PolicyConfig, PolicyInput};
use acc_runtime::runner::execute_writes;
use acc_runtime::testing::{ScriptedBoard, ScriptedLaw};
use acc_runtime::BoardWrites;

struct Rig {
    p: FaultPolicy,
    law: ScriptedLaw,
    b: ScriptedBoard,
    heartbeat: u16,
    k: u32,
    /// The force of the samples, N.
    force_n: f64,
    /// The next period's input carries this failed write (of the period before).
    write_error: Option<acc_pmc::BoardErrorKind>,
}

impl Rig {
    /// A policy armed on a v2 board, the law commanding 120 % every period.
    fn armed() -> Self {
        let cfg = PolicyConfig {
            debounce_reads: 1,
            ..PolicyConfig::default()
        };
        let mut rig = Self {
            p: FaultPolicy::new(cfg),
            law: ScriptedLaw::new([120]),
            b: ScriptedBoard::new(),
            heartbeat: 0,
            k: 0,
            force_n: 600.0,
            write_error: None,
        };
        for _ in 0..4 {
            rig.period(true);
        }
        assert_eq!(rig.p.state(), AccState::Active);
        rig.law.engaged.clear();
        rig
    }

    /// One period with a valid (or invalid) force sample; returns the command written.
    fn period(&mut self, valid: bool) -> Option<u16> {
        self.b.board.push_power_sample(1200);
        self.b.now_ms += 100;
        let s: BoardStatus = self.b.read_status().expect("clean link");
        let input = PolicyInput {
            t_s: f64::from(self.k) * 0.1,
            link: Ok(s),
            write_error: self.write_error.take(),
            force: ForceSample {
                force_n: self.force_n,
                power_w: Some(1200.0),
                valid,
            },
            programmed_feed_mm_min: 200.0,
            feed_mm_min: 2.0 * f64::from(s.override_applied_pct),
            held: false,
            delay: Default::default(),
            log_stalled: false,
        };
        self.k += 1;
        let out = self.p.step(&input, &mut self.law);
        let mut plan = BoardWrites {
            control: Some(out.control),
            ..BoardWrites::default()
        };
        if let Some(c) = out.write_override {
            self.heartbeat = self.heartbeat.wrapping_add(1);
            plan.override_and_heartbeat = Some((c.0, self.heartbeat));
        }
        let r = execute_writes(&mut self.b, &plan);
        assert_eq!(r.error(), None);
        out.write_override.map(FeedOverride::pct)
    }
}

#[test]
fn a_tool_limit_below_the_laws_command_is_written_on_the_grid_and_reengages_the_law() {
    let mut rig = Rig::armed();
    assert_eq!(rig.period(true), Some(120));
    assert!(
        rig.law.engaged.is_empty(),
        "no limit: the law is not re-engaged"
    );
    rig.p.set_command_limits(CommandLimits {
        cap_pct: Some(87),
        floor_pct: None,
    });
    assert_eq!(rig.period(true), Some(80));
    assert_eq!(
        rig.law.engaged,
        vec![80],
        "re-engaged on the written command"
    );
    // A cap above the law's command changes nothing.
    rig.law.script.push_back(70);
    assert_eq!(rig.period(true), Some(70));
    assert_eq!(rig.law.engaged, vec![80]);
}

#[test]
fn a_plan_cap_below_the_tools_floor_wins_and_the_floor_needs_a_valid_sample() {
    let mut rig = Rig::armed();
    rig.law.script.push_back(30);
    // The tool's entry floor at 71 % (ceiled to 80 %) and a plan cap at 54 % (floored to
    // 50 %): the cap is applied last.
    rig.p.set_command_limits(CommandLimits {
        cap_pct: Some(54),
        floor_pct: Some(71),
    });
    assert_eq!(rig.period(true), Some(50));
    assert_eq!(rig.law.engaged, vec![50]);
    rig.p.set_command_limits(CommandLimits {
        cap_pct: None,
        floor_pct: Some(71),
    });
    assert_eq!(
        rig.period(true),
        Some(80),
        "the floor raises a valid period"
    );
    assert_eq!(rig.law.engaged, vec![50, 80]);
    // On an invalid sample the command never rises above the last one, whatever the law.
    rig.law.script.push_back(90);
    assert_eq!(rig.period(false), Some(80));
    // Nor does the floor raise it: a law lowering to 40 % on an invalid sample is written.
    rig.law.script.push_back(40);
    assert_eq!(rig.period(false), Some(40));
    assert_eq!(
        rig.law.engaged,
        vec![50, 80],
        "the guards do not re-engage the law"
    );
}

#[test]
fn after_a_fault_the_law_settles_under_what_acc_allowed_before_it() {
    use acc_runtime::policy::SETTLE_PERIODS;
    let mut rig = Rig::armed();
    // The law regulates to Fr 800 N; the samples (600 N) show the tool cutting.
    rig.law.force_ref_n = Some(800.0);
    // A dither between 40 % and 50 % (a board on the 10 % grid holding Fr).
    rig.law.script.extend([40, 50, 40, 50, 40]);
    let before: Vec<_> = (0..5).map(|_| rig.period(true)).collect();
    assert_eq!(before, [40, 50, 40, 50, 40].map(Some));
    // A fault of the line: last period's write timed out (the ack lost), and this period's
    // force sample is unusable. The command is held.
    // The law asks for 60 % in every period it is stepped after the fault (a failing link
    // holds without stepping it).
    rig.law
        .script
        .extend(std::iter::repeat_n(60, SETTLE_PERIODS as usize + 1));
    rig.write_error = Some(acc_pmc::BoardErrorKind::Timeout);
    assert_eq!(rig.period(false), Some(40));
    // The law, answering the held period, asks for 60 %: for the settling periods it gets
    // at most 50 % (the highest of the dither), re-engaged there; then 60 % again.
    rig.law.engaged.clear();
    for k in 0..SETTLE_PERIODS {
        assert_eq!(rig.period(true), Some(50), "period {k} after the fault");
    }
    assert!(
        rig.law.engaged.iter().all(|&e| e == 50),
        "{:?}",
        rig.law.engaged
    );
    assert_eq!(rig.period(true), Some(60));
    // In air (a valid force below 0.2 Fr) a fault caps nothing: the law may rise.
    rig.force_n = 100.0;
    rig.law.script.push_back(80);
    rig.write_error = Some(acc_pmc::BoardErrorKind::Timeout);
    assert_eq!(rig.period(false), Some(60));
    assert_eq!(rig.period(true), Some(80));
    // An unusable sample alone (no fault of the line) holds that period only: once the
    // settling of the fault in air is over, back in the cut.
    for _ in 0..SETTLE_PERIODS {
        rig.period(true);
    }
    rig.force_n = 600.0;
    rig.law.script.extend([50, 50, 90]);
    assert_eq!(rig.period(true), Some(50));
    assert_eq!(rig.period(false), Some(50));
    assert_eq!(rig.period(true), Some(90));
}
