//! `SimBoard`: the PMC interface board of the simulated machine.
//!
//! Register behaviour is the PMC crate's pure [`BoardLogic`] (the same code the Modbus
//! server runs), fed with Modbus requests exactly as a link would send them; the machine
//! side of the board (operator switch, NC state, spindle power, rpm, programmed feed) is
//! driven by the simulated [`Machine`]. The loop sees only the [`Board`] trait.

use acc_pmc::emu::{lock_board, BoardLogic, Exception, Reply, Request, SharedBoard};
use acc_pmc::regs::{holding, input, OverrideResolution};
use acc_pmc::{Board, BoardStatus, ControlBits};
use acc_runtime::RunRecord;

use crate::machine::{Machine, PeriodRecord};

/// A fault of the board's power transducer input (for fault scenarios and `acc board-sim`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerFault {
    /// The power register follows the machine but `SAMPLE_SEQ` stops (a stale sensor).
    FrozenSeq,
    /// The power register reads `0xFFFF_FFFF` (−1 W as a signed value: a broken input).
    Garbage,
}

/// The simulated board plus the machine behind it, on a manual clock.
///
/// The register logic is shared ([`SharedBoard`]): `acc sim` talks to it in process through
/// the [`Board`] trait, `acc board-sim` serves the same logic over Modbus RTU to `acc run`;
/// both step the machine with [`SimBoard::advance_period`].
#[derive(Debug)]
pub struct SimBoard {
    logic: SharedBoard,
    machine: Machine,
    now_ms: u64,
    power_fault: Option<PowerFault>,
    external_clock: bool,
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
            logic: logic.shared(),
            machine,
            now_ms: 0,
            power_fault: None,
            external_clock: false,
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

    /// The board logic (machine-side switches for fault scenarios), locked.
    pub fn logic_mut(&mut self) -> std::sync::MutexGuard<'_, BoardLogic> {
        lock_board(&self.logic)
    }

    /// The shared register logic, to serve it over a link (an RTU server on a pty). The
    /// server then runs the logic's clock (its watchdog on the server's time): this board
    /// stops ticking it with the simulator's stepped time.
    pub fn serve(&mut self) -> SharedBoard {
        self.external_clock = true;
        self.logic.clone()
    }

    /// Set or clear a fault of the power input (applies from the next period).
    pub fn set_power_fault(&mut self, fault: Option<PowerFault>) {
        self.power_fault = fault;
    }

    /// Advance the manual clock and the machine by one control period: the machine runs
    /// with the override now on the PMC inputs (`OVERRIDE_APPLIED`) and the feed hold, then
    /// the board publishes the new spindle power sample, speed and programmed feed.
    pub fn advance_period(&mut self, period_s: f64) -> PeriodRecord<'_> {
        let (applied, hold) = {
            let mut b = lock_board(&self.logic);
            if !self.external_clock {
                b.tick(self.now_ms);
            }
            (b.override_applied_pct(), b.feed_hold_active())
        };
        self.machine.set_override_input_pct(applied);
        self.machine.set_feed_hold(hold);
        self.now_ms += (period_s * 1000.0).round() as u64;
        let path_mm = self.machine.workpiece().length_mm();
        let rec = self.machine.advance(period_s);
        {
            let mut b = lock_board(&self.logic);
            let power = rec.power_mean_w.clamp(0.0, f64::from(u32::MAX)).round() as u32;
            match self.power_fault {
                None => b.push_power_sample(power),
                Some(PowerFault::FrozenSeq) => b.set_spindle_power_w(power),
                Some(PowerFault::Garbage) => b.push_power_sample(u32::MAX),
            }
            b.set_spindle_rpm(rec.spindle_rpm.clamp(0.0, f64::from(u16::MAX)).round() as u16);
            b.set_cycle_active(rec.x_mm < path_mm);
        }
        rec
    }

    fn publish_machine_inputs(&mut self) {
        let fp = self.machine.programmed_feed_mm_min();
        let rpm = self.machine.spindle_rpm();
        let power = self.machine.spindle_power_w();
        let finished = self.machine.finished();
        let mut b = lock_board(&self.logic);
        b.set_programmed_feed_mm_min(fp.clamp(0.0, f64::from(u16::MAX)).round() as u16);
        b.set_spindle_rpm(rpm.clamp(0.0, f64::from(u16::MAX)).round() as u16);
        b.push_power_sample(power.clamp(0.0, f64::from(u32::MAX)).round() as u32);
        b.set_cycle_active(!finished);
    }
}

/// Fill the simulator-only columns of a run-log record with the plant's truth for the period
/// `rec` (true position, depths, true mean force over `true_force_n`'s window, the drive's
/// actual feed).
pub fn add_truth(row: &mut RunRecord, rec: &PeriodRecord<'_>, true_force_n: f64) {
    row.x_true_mm = Some(rec.x_mm);
    row.radial_depth_mm = Some(rec.radial_depth_mm);
    row.axial_depth_mm = Some(rec.axial_depth_mm);
    row.force_true_n = Some(true_force_n);
    row.feed_true_mm_min = Some(rec.feed_mean_mm_min);
}

impl Board for SimBoard {
    type Error = Exception;

    fn read_status(&mut self) -> Result<BoardStatus, Exception> {
        let reply = lock_board(&self.logic).handle(
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
        lock_board(&self.logic).handle(
            Request::WriteMultiple {
                addr: holding::OVERRIDE_CMD,
                values: vec![override_pct, heartbeat],
            },
            self.now_ms,
        )?;
        Ok(())
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Exception> {
        lock_board(&self.logic).handle(
            Request::WriteSingle {
                addr: holding::CONTROL,
                value: control.to_register(),
            },
            self.now_ms,
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::configs_dir;
    use crate::scenario::Scenario;
    use acc_pmc::{BoardError, BoardErrorKind};

    fn board() -> SimBoard {
        let sc =
            Scenario::load(configs_dir().join("scenarios/paper_case1.toml")).expect("scenario");
        sc.build_board()
    }

    #[test]
    fn status_reports_the_machine_through_the_registers() {
        let mut b = board();
        let s = b.read_status().expect("status");
        assert!(s.acc_switch && s.cycle_active && !s.acc_active);
        assert_eq!(s.programmed_feed_mm_min, 200);
        assert_eq!(s.override_step_pct, 10);
        b.write_control(ControlBits {
            acc_request: true,
            ..ControlBits::default()
        })
        .expect("control");
        b.write_override(150, 1).expect("override");
        let s = b.read_status().expect("status");
        assert!(s.acc_active);
        assert_eq!(s.override_applied_pct, 150);
        let rec = b.advance_period(0.1);
        // The override path still carries the power-up 100 % for its 16 ms dead time (target
        // 200 mm/min), then 150 % (300 mm/min); the 8 ms lag from standstill loses about
        // τ·target: mean ≈ 300 − 0.16·100 − 0.08·250 = 264 mm/min.
        assert!(
            (rec.feed_mean_mm_min - 264.0).abs() < 5.0,
            "{}",
            rec.feed_mean_mm_min
        );
        let s = b.read_status().expect("status");
        assert_eq!(s.spindle_rpm, 600);
        // Air cut: the spindle draws its no-load power, 700 W.
        assert_eq!(s.spindle_power_w, 700);
        // One sample at power-up (the board has a reading before the first period), one per
        // period since.
        assert_eq!(s.sample_seq, 2);
    }

    #[test]
    fn the_board_refuses_an_override_off_its_step() {
        let mut b = board();
        let err = b.write_override(125, 1).expect_err("not a multiple of 10");
        assert_eq!(err.kind(), BoardErrorKind::Exception(3));
        assert_eq!(b.read_status().expect("status").override_applied_pct, 100);
    }

    #[test]
    fn a_silent_controller_trips_the_watchdog_and_the_operator_takes_over() {
        let mut b = board();
        b.logic_mut().set_operator_override_pct(70);
        b.write_control(ControlBits {
            acc_request: true,
            ..ControlBits::default()
        })
        .expect("control");
        b.write_override(150, 1).expect("override");
        // No heartbeat for 0.6 s > WATCHDOG_MS = 500 ms.
        for _ in 0..6 {
            b.advance_period(0.1);
        }
        let s = b.read_status().expect("status");
        assert!(s.watchdog_tripped && !s.acc_active);
        assert_eq!(s.override_applied_pct, 70);
        // The machine follows the operator's 70 % after the dead time and lag.
        let rec = b.advance_period(0.1);
        assert!(
            (rec.feed_mean_mm_min - 140.0).abs() < 1.0,
            "{}",
            rec.feed_mean_mm_min
        );
    }
}
