//! A tool change is an event the loop applies to the law: the shop layer returns it (the new
//! tool's Fr and the Kc_hat to restart from) and `ControlLoop::decide` applies it through
//! `OverrideLaw`, before the policy steps the law. Checked on a scripted board (the spec's
//! `BoardLogic`) with a law that records what is done to it.

use acc_core::{FeedOverride, Measurement, Mode, OverrideLaw, StepOutput};
use acc_runtime::testing::{empty_trace, LinearPowerForce, ScriptedBoard};
use acc_runtime::{AccState, ControlLoop, FaultPolicy, PeriodRecord, PolicyConfig, ShopControl};

/// A law that always asks 150 %, keeps a force reference and a Kc_hat as a real law does
/// (its Kc_hat grows by 0.5 N/(mm/min) per step, as an estimate that moves), and records
/// every change made to them from outside.
#[derive(Debug, Clone)]
struct RecordingLaw {
    force_ref_n: f64,
    kc_hat: f64,
    /// `set_force_ref_n` calls, N.
    fr_calls: Vec<f64>,
    /// `reset_kc_estimate` calls, N/(mm/min).
    kc_resets: Vec<f64>,
}

impl OverrideLaw for RecordingLaw {
    fn name(&self) -> &str {
        "recording"
    }
    fn engage(&mut self, _current: FeedOverride) {}
    fn step(&mut self, _m: &Measurement) -> StepOutput {
        self.kc_hat += 0.5;
        let mut trace = empty_trace(Mode::Baseline);
        trace.force_ref_n = self.force_ref_n;
        trace.kc_hat = self.kc_hat;
        StepOutput {
            command: FeedOverride(150),
            trace,
        }
    }
    fn set_frozen(&mut self, _frozen: bool) {}
    fn set_force_ref_n(&mut self, force_ref_n: f64) {
        self.force_ref_n = force_ref_n;
        self.fr_calls.push(force_ref_n);
    }
    fn kc_estimate(&self) -> Option<f64> {
        Some(self.kc_hat)
    }
    fn reset_kc_estimate(&mut self, kc_hat: f64) {
        self.kc_hat = kc_hat;
        self.kc_resets.push(kc_hat);
    }
}

/// Tool 1 is limited to 60 %; tool 2 may run at 150 % and has a `kc_init`.
const TABLE: &str = "[default]\nfr_n = 800.0\n\
                     [tool.1]\nfr_n = 800.0\nmax_override_pct = 60\n\
                     [tool.2]\nfr_n = 1200.0\nkc_init = 3.0\n";

struct Rig {
    lp: ControlLoop<RecordingLaw, LinearPowerForce>,
    b: ScriptedBoard,
    t_s: f64,
}

impl Rig {
    /// Tool 1 in the spindle, 400 N of force (800 W at 0.5 N/W).
    fn new() -> Self {
        let table = acc_config::ToolTable::parse("tools.toml", TABLE).expect("table");
        let law = RecordingLaw {
            force_ref_n: 800.0,
            kc_hat: 5.0,
            fr_calls: Vec::new(),
            kc_resets: Vec::new(),
        };
        let lp = ControlLoop::new(
            FaultPolicy::new(PolicyConfig::default()),
            law,
            LinearPowerForce { n_per_w: 0.5 },
            0.1,
        )
        .with_shop(ShopControl::new(table, 0.1));
        let mut b = ScriptedBoard::new();
        b.board.set_tool_number(1);
        b.board.set_block_number(10);
        Self { lp, b, t_s: 0.0 }
    }

    fn step(&mut self) -> PeriodRecord {
        self.b.board.push_power_sample(800);
        self.b.now_ms += 100;
        let r = self.lp.cycle(&mut self.b, self.t_s);
        self.t_s += 0.1;
        r
    }

    /// Step until the period that applies a tool change (at most 5 periods: the line
    /// guard confirms a new `TOOL_NUMBER` on the next read); that period's record and the
    /// law's Kc_hat just before it.
    fn step_to_change(&mut self) -> (PeriodRecord, f64) {
        for _ in 0..5 {
            let kc_before = self.lp.law().kc_hat;
            let r = self.step();
            if r.record(None).flags.contains("tool_change") {
                return (r, kc_before);
            }
        }
        panic!("the tool change was never applied");
    }
}

fn cmd(r: &PeriodRecord) -> Option<u16> {
    r.out.write_override.map(|o| o.0)
}

#[test]
fn a_tool_change_sets_the_laws_fr_and_kc_and_never_raises_the_command_at_once() {
    let mut rig = Rig::new();
    // The first tool of the run is an event too: Fr of tool 1, no Kc restart (no
    // `kc_init`, no history). The command settles at tool 1's 60 %.
    let run_in: Vec<_> = (0..10).map(|_| rig.step()).collect();
    assert_eq!(rig.lp.policy().state(), AccState::Active);
    assert_eq!(rig.lp.law().fr_calls, vec![800.0]);
    assert!(rig.lp.law().kc_resets.is_empty());
    assert!(run_in
        .iter()
        .all(|r| !r.record(None).flags.contains("tool_change")));
    let last_before = run_in.iter().rev().find_map(cmd).expect("a command");
    assert_eq!(last_before, 60, "tool 1's maximum");

    // Tool 2: the law gets its Fr and restarts Kc_hat at its `kc_init`.
    rig.b.board.set_tool_number(2);
    let (change, kc_tool1) = rig.step_to_change();
    let law = rig.lp.law();
    assert_eq!(law.fr_calls, vec![800.0, 1200.0], "Fr of tool 2");
    assert_eq!(
        law.kc_resets,
        vec![3.0],
        "Kc_hat restarts at tool 2's kc_init"
    );
    assert_eq!(law.force_ref_n, 1200.0);
    assert_eq!(
        change.out.step.map(|s| s.trace.force_ref_n),
        Some(1200.0),
        "the law stepped on the new Fr in the change period"
    );
    // The command of the change period is not above the last one on tool 1, although the
    // law asks 150 % and tool 2 allows it …
    let at_change = cmd(&change).expect("a command at the change");
    assert!(at_change <= last_before, "{at_change} > {last_before}");
    // … and rises after it by the ramp only (50 %/s = 5 % per period, floored onto the
    // 10 % grid): never a jump, up to tool 2's 150 %.
    let mut prev = at_change;
    for _ in 0..30 {
        if let Some(c) = cmd(&rig.step()) {
            assert!(c <= prev + 10, "{prev} -> {c}");
            prev = c;
        }
    }
    assert_eq!(prev, 150, "the ramp ends at tool 2's maximum");

    // Back to tool 1: Fr 800 N and the Kc_hat it had when it was last used.
    rig.b.board.set_tool_number(1);
    rig.step_to_change();
    let law = rig.lp.law();
    assert_eq!(law.fr_calls, vec![800.0, 1200.0, 800.0]);
    assert_eq!(
        law.kc_resets,
        vec![3.0, kc_tool1],
        "tool 1's own last Kc_hat"
    );
}

#[test]
fn a_period_without_a_law_step_logs_the_fr_of_the_tool_in_use() {
    let mut rig = Rig::new();
    for _ in 0..10 {
        rig.step();
    }
    rig.b.board.set_tool_number(2);
    rig.step_to_change();
    // The status read times out: the law is not stepped this period; the row still carries
    // tool 2's Fr, not the run's fallback (tool 1's, here passed as the preset's 800 N).
    rig.b.inject(
        acc_runtime::testing::LinkFault::RequestLost(acc_pmc::BoardErrorKind::Timeout),
        1,
    );
    let lost = rig.step();
    assert!(lost.link.is_err(), "the read failed");
    assert!(lost.out.step.is_none(), "the law was not stepped");
    assert_eq!(lost.record(Some(800.0)).force_ref_n, Some(1200.0));
    // Without a tool table the fallback stays the run's Fr.
    assert_eq!(
        PeriodRecord {
            tool_force_ref_n: None,
            ..lost
        }
        .record(Some(800.0))
        .force_ref_n,
        Some(800.0)
    );
}
