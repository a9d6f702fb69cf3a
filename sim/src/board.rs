//! `SimBoard`: the PMC interface board of the simulated machine.
//!
//! Register behaviour is the PMC crate's pure [`BoardLogic`] (the same code the Modbus
//! server runs), fed with Modbus requests exactly as a link would send them; the machine
//! side of the board (operator switch, NC state, spindle power, rpm, programmed feed) is
//! driven by the simulated [`Machine`]. The loop sees only the [`Pmc`] trait.

use acc_pmc::board::{holding, input, BoardLogic, Exception, OverrideResolution, Reply, Request};
use acc_pmc::{BoardStatus, ControlBits, Pmc, PmcErrorKind};

use crate::machine::{Machine, PeriodRecord};

/// The simulated board plus the machine behind it, on a manual clock.
#[derive(Debug)]
pub struct SimBoard {
    logic: BoardLogic,
    machine: Machine,
    now_ms: u64,
}

impl SimBoard {
    /// A board with `step_pct` resolution (10 or 1; anything else is treated as 10), the
    /// operator's ACC switch on, operator override 100 %, NC cycle running.
    pub fn new(machine: Machine, step_pct: u16) -> Self {
        let res = OverrideResolution::from_step_pct(step_pct).unwrap_or_default();
        let mut logic = BoardLogic::new(res);
        logic.set_acc_switch(true);
        logic.set_operator_override_pct(100);
        logic.set_cycle_active(true);
        let mut board = SimBoard {
            logic,
            machine,
            now_ms: 0,
        };
        board.publish_machine_inputs();
        board
    }

    /// The machine behind the board.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The machine, mutable (to replace its spindle model, for instance).
    pub fn machine_mut(&mut self) -> &mut Machine {
        &mut self.machine
    }

    /// The board logic (machine-side switches for fault scenarios).
    pub fn logic_mut(&mut self) -> &mut BoardLogic {
        &mut self.logic
    }

    /// Advance the manual clock and the machine by one control period: the machine runs
    /// with the override now on the PMC inputs (`OVERRIDE_APPLIED`) and the feed hold, then
    /// the board publishes the new spindle power sample, speed and programmed feed.
    pub fn advance_period(&mut self, period_s: f64) -> PeriodRecord<'_> {
        self.logic.tick(self.now_ms);
        self.machine
            .set_override_input_pct(self.logic.override_applied_pct());
        self.machine.set_feed_hold(self.logic.feed_hold_active());
        self.now_ms += (period_s * 1000.0).round() as u64;
        // Disjoint borrows: the record borrows the machine, the board is updated alongside.
        let path_mm = self.machine.workpiece().length_mm();
        let rec = self.machine.advance(period_s);
        self.logic
            .push_power_sample(rec.power_mean_w.clamp(0.0, f64::from(u32::MAX)).round() as u32);
        self.logic
            .set_spindle_rpm(rec.spindle_rpm.clamp(0.0, f64::from(u16::MAX)).round() as u16);
        self.logic.set_cycle_active(rec.x_mm < path_mm);
        rec
    }

    fn publish_machine_inputs(&mut self) {
        let fp = self.machine.programmed_feed_mm_min();
        self.logic
            .set_programmed_feed_mm_min(fp.clamp(0.0, f64::from(u16::MAX)).round() as u16);
        self.logic.set_cycle_active(!self.machine.finished());
    }
}

impl Pmc for SimBoard {
    type Error = Exception;

    fn kind(err: &Exception) -> PmcErrorKind {
        PmcErrorKind::Exception(err.code())
    }

    fn read_status(&mut self) -> Result<BoardStatus, Exception> {
        let reply = self.logic.handle(
            Request::ReadInput {
                addr: 0,
                count: input::COUNT,
            },
            self.now_ms,
        )?;
        match reply {
            Reply::Registers(regs) => {
                let mut block = [0u16; input::COUNT as usize];
                for (b, r) in block.iter_mut().zip(regs) {
                    *b = r;
                }
                Ok(BoardStatus::from_input_registers(&block))
            }
            // The board answers a read with registers; anything else would be a bug in the
            // logic, reported like a device refusing the request.
            _ => Err(Exception::IllegalFunction),
        }
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Exception> {
        self.logic.handle(
            Request::WriteMultiple {
                addr: holding::OVERRIDE_CMD,
                values: vec![override_pct, heartbeat],
            },
            self.now_ms,
        )?;
        Ok(())
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Exception> {
        self.logic.handle(
            Request::WriteSingle {
                addr: holding::CONTROL,
                value: control.to_register(),
            },
            self.now_ms,
        )?;
        Ok(())
    }
}
