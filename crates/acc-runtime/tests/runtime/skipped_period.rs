//! A period the ticker skipped (`ControlLoop::skip`): nothing is read or written, the row
//! is flagged, and the command kept in force is booked for the echoes of the next periods,
//! so the loop delay reads the designed 1 period again after the skip and the line guard
//! keeps confirming the board's echo. Checked on a scripted board with a dithering law.

use acc_runtime::policy::{AccState, PolicyConfig};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedLaw};
use acc_runtime::{ControlLoop, FaultPolicy, PeriodRecord};

const DITHER: [u16; 7] = [50, 60, 60, 70, 50, 50, 60];

struct Rig {
    lp: ControlLoop<ScriptedLaw, LinearPowerForce>,
    b: ScriptedBoard,
    t_s: f64,
}

impl Rig {
    fn new() -> Self {
        let cfg = PolicyConfig::default();
        let script = (0..200).map(|k| DITHER[k % 7]);
        Self {
            lp: ControlLoop::new(
                FaultPolicy::new(cfg),
                ScriptedLaw::new(script),
                LinearPowerForce { n_per_w: 0.5 },
                cfg.period_s,
            ),
            b: ScriptedBoard::new(),
            t_s: 0.0,
        }
    }

    /// The board's tick of one period (its sample sequence advances).
    fn tick(&mut self) {
        self.b.board.push_power_sample(1200);
        self.b.now_ms += 100;
        self.t_s += 0.1;
    }

    fn step(&mut self) -> PeriodRecord {
        self.tick();
        self.lp.cycle(&mut self.b, self.t_s)
    }
}

#[test]
fn a_skipped_period_keeps_the_command_in_force_and_the_echo_at_one_period() {
    let mut rig = Rig::new();
    let before: Vec<_> = (0..40).map(|_| rig.step()).collect();
    assert_eq!(rig.lp.policy().state(), AccState::Active);
    assert_eq!(before.last().map(|r| r.delay.echo_periods), Some(Some(1)));
    let writes = rig.b.override_writes.len();

    rig.tick();
    let row = rig.lp.skip(rig.t_s);
    assert!(row.flags.contains("skipped"), "{}", row.flags);
    assert_eq!(rig.b.override_writes.len(), writes, "nothing written");

    let after: Vec<_> = (0..40).map(|_| rig.step()).collect();
    for r in &after {
        assert_eq!(r.out.state, AccState::Active, "period {}", r.index);
        assert_eq!(r.guard.unconfirmed, None, "period {}", r.index);
        assert!(
            r.delay.echo_periods.is_none_or(|e| e == 1),
            "period {}: {:?}",
            r.index,
            r.delay
        );
    }
    assert_eq!(after.last().map(|r| r.delay.echo_periods), Some(Some(1)));
    assert_eq!(after[0].index, before.len() as u64 + 1);
}
