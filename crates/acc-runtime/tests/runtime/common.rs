//! The scripted rig the fault-policy tests drive: a `ControlLoop` with the fault policy,
//! a scripted law and a linear power-to-force map on a `ScriptedBoard`, on board time
//! advanced 100 ms per period (`policy.rs`, `policy_operator.rs`).
#![allow(dead_code)] // each test file uses part of the rig

use acc_pmc::BoardStatus;
use acc_runtime::policy::{AccState, Event, FaultPolicy, PolicyConfig, Release};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedLaw};
use acc_runtime::{ControlLoop, PeriodRecord};
/// 0.5 N per W: 1600 W is the paper's Fr = 800 N.
pub const N_PER_W: f64 = 0.5;

pub struct Rig {
    pub lp: ControlLoop<ScriptedLaw, LinearPowerForce>,
    pub b: ScriptedBoard,
    pub t_s: f64,
    pub power_w: u32,
    pub freeze_seq: bool,
}

impl Rig {
    /// On a v2 board (the `ScriptedBoard` default).
    pub fn new(cfg: PolicyConfig, script: impl IntoIterator<Item = u16>) -> Self {
        Self::on(ScriptedBoard::new(), cfg, script)
    }

    /// On a v1 board (no fallback clamp, no `BOARD_RESTARTED`).
    pub fn v1(cfg: PolicyConfig, script: impl IntoIterator<Item = u16>) -> Self {
        Self::on(ScriptedBoard::v1(), cfg, script)
    }

    /// The rules are tested on the reads as the board gives them: `debounce_reads` = 1
    /// unless a test sets it (the line guard's confirmation has its own tests below and
    /// in `guard.rs`).
    pub fn on(b: ScriptedBoard, cfg: PolicyConfig, script: impl IntoIterator<Item = u16>) -> Self {
        let cfg = if cfg.debounce_reads == PolicyConfig::default().debounce_reads {
            PolicyConfig {
                debounce_reads: 1,
                ..cfg
            }
        } else {
            cfg
        };
        Self::exact(b, cfg, script)
    }

    /// With `cfg` as given (the line guard's debounce included).
    pub fn exact(
        b: ScriptedBoard,
        cfg: PolicyConfig,
        script: impl IntoIterator<Item = u16>,
    ) -> Self {
        Self::with_law(b, cfg, ScriptedLaw::new(script))
    }

    /// With `cfg` as given and the law `law` (e.g. one that reports an Fr, for the rules
    /// that judge the force against it), at 1200 W.
    pub fn with_law(b: ScriptedBoard, cfg: PolicyConfig, law: ScriptedLaw) -> Self {
        cfg.validate().expect("valid policy config");
        Self {
            lp: ControlLoop::new(
                FaultPolicy::new(cfg),
                law,
                LinearPowerForce { n_per_w: N_PER_W },
                cfg.period_s,
            ),
            b,
            t_s: 0.0,
            power_w: 1200,
            freeze_seq: false,
        }
    }

    pub fn step(&mut self) -> PeriodRecord {
        if self.freeze_seq {
            self.b.board.set_spindle_power_w(self.power_w);
        } else {
            self.b.board.push_power_sample(self.power_w);
        }
        self.b.now_ms += 100;
        let r = self.lp.cycle(&mut self.b, self.t_s);
        self.t_s += 0.1;
        r
    }

    pub fn run(&mut self, n: usize) -> Vec<PeriodRecord> {
        (0..n).map(|_| self.step()).collect()
    }

    pub fn status(&self) -> BoardStatus {
        self.b.board.status()
    }

    /// The board's status at board time now (its watchdog runs even when no request
    /// reaches it).
    pub fn status_now(&mut self) -> BoardStatus {
        self.b.board.tick(self.b.now_ms);
        self.b.board.status()
    }

    pub fn state(&self) -> AccState {
        self.lp.policy().state()
    }

    /// Operator cycles the ACC switch off then on (one period each).
    pub fn cycle_switch(&mut self) -> (PeriodRecord, PeriodRecord) {
        self.b.board.set_acc_switch(false);
        let off = self.step();
        self.b.board.set_acc_switch(true);
        let on = self.step();
        (off, on)
    }
}

pub fn released(r: &PeriodRecord, why: Release) -> bool {
    r.out.events.contains(&Event::Released(why))
}

pub fn armed(r: &PeriodRecord) -> bool {
    r.out
        .events
        .iter()
        .any(|e| matches!(e, Event::Armed { .. }))
}

/// Applied override and feed hold on the board, period by period.
pub fn applied(recs: &[PeriodRecord]) -> Vec<(u16, bool)> {
    recs.iter()
        .filter_map(|r| r.link.ok())
        .map(|s| (s.override_applied_pct, s.feed_hold_active))
        .collect()
}
