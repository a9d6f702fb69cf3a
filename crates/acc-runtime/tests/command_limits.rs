//! The tool's and the plan's limits on the law's command: judged by the policy before the
//! law steps and applied in the law's one quantization step. A limit below the law's
//! command is written on the board's grid and re-engages the law there; a cap above it
//! changes nothing. Checked with a scripted law against a scripted board, the policy driven
//! period by period.

use acc_core::{FeedOverride, ForceSample};
use acc_pmc::{Board, BoardStatus};
use acc_runtime::policy::{AccState, CommandLimits, CycleInput, FaultPolicy, PolicyConfig};
use acc_runtime::runner::execute_writes;
use acc_runtime::testing::{ScriptedBoard, ScriptedLaw};
use acc_runtime::WritePlan;

struct Rig {
    p: FaultPolicy,
    law: ScriptedLaw,
    b: ScriptedBoard,
    heartbeat: u16,
    k: u32,
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
        let input = CycleInput {
            t_s: f64::from(self.k) * 0.1,
            link: Ok(s),
            write_error: None,
            force: ForceSample {
                force_n: 600.0,
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
        let mut plan = WritePlan {
            control: Some(out.control),
            ..WritePlan::default()
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
