//! `SimBoard`: the PMC interface board of the simulated machine.
//!
//! Register behaviour is the PMC crate's pure [`BoardLogic`] (the same code the Modbus
//! server runs; protocol v2 unless built with [`SimBoard::with_protocol`]), fed with Modbus
//! requests exactly as a link would send them; the machine side of the board (operator
//! switch, NC state, spindle power, rpm, programmed feed, and the v2 NC context: tool,
//! program, block, actual feed) is driven by the simulated [`Machine`] every period. The
//! simulated NC obeys the board: the override it applies (`OVERRIDE_APPLIED`, with the
//! fallback clamp) and its feed hold (the controller's request, the watchdog's and the
//! power-up one after a restart in a cycle). The loop sees only the [`Board`] trait.

use acc_pmc::emu::{
    lock_board, BoardLogic, EmulatedProtocol, Exception, Reply, Request, SharedBoard,
};
use acc_pmc::regs::{holding, input, OverrideResolution};
use acc_pmc::{Board, BoardStatus, ControlBits};

use crate::machine::{Machine, PeriodRecord};

/// A fault of the board's power transducer input (for fault scenarios and `acc board-sim`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerFault {
    /// The power register follows the machine but `SAMPLE_SEQ` stops (a stale sensor).
    FrozenSeq,
    /// The power register reads `0xFFFF_FFFF` (−1 W as a signed value: a broken input).
    Garbage,
}

/// The NC context the simulated board reports (v2 registers 10…12), from the scenario's
/// `[nc]` table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NcContext {
    /// `TOOL_NUMBER` (T word).
    pub tool_number: u16,
    /// `PROGRAM_NUMBER` (O number).
    pub program_number: u16,
    /// Segment `i` (0-based) of the workpiece runs as block `block_step × (i + 1)` (low 16
    /// bits, as `BLOCK_NUMBER` carries them).
    pub block_step: u16,
    /// Tool changes along the path (`[[nc.tool_change]]`), in order of position: from
    /// `x_um` (tool centre, µm) on the board reports `tool`.
    pub tool_changes: [Option<ToolChange>; NcContext::MAX_TOOL_CHANGES],
}

/// One tool change of the simulated program: from tool-centre position `x_um` (µm) on,
/// `TOOL_NUMBER` = `tool`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ToolChange {
    /// Tool-centre position of the change, µm.
    pub x_um: i64,
    /// Tool number from there on.
    pub tool: u16,
}

impl Default for NcContext {
    /// Tool 1, program 1000, blocks N10, N20, …, no tool change.
    fn default() -> Self {
        NcContext {
            tool_number: 1,
            program_number: 1000,
            block_step: 10,
            tool_changes: [None; NcContext::MAX_TOOL_CHANGES],
        }
    }
}

impl NcContext {
    /// Most tool changes a scenario may list.
    pub const MAX_TOOL_CHANGES: usize = 16;

    /// `TOOL_NUMBER` with the tool centre at `x_mm`.
    pub fn tool_at(&self, x_mm: f64) -> u16 {
        let x_um = (x_mm * 1000.0).round() as i64;
        self.tool_changes
            .iter()
            .flatten()
            .rfind(|c| c.x_um <= x_um)
            .map_or(self.tool_number, |c| c.tool)
    }

    /// `BLOCK_NUMBER` while the tool is in segment `index` (0-based).
    pub fn block_number(&self, index: usize) -> u16 {
        let n = u64::from(self.block_step) * (index as u64 + 1);
        (n & 0xFFFF) as u16
    }
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
    nc: NcContext,
    /// End of each workpiece segment along the path, mm (for `BLOCK_NUMBER`).
    segment_ends_mm: Vec<f64>,
}

/// `TOOL_NUMBER` and `BLOCK_NUMBER` at path position `x_mm`: the program's (the N word,
/// else the line number, 16 bits) when the machine follows one, else the NC context's
/// numbering of the workpiece's segments (`ends_mm`).
fn nc_numbers(
    nc: &NcContext,
    ends_mm: &[f64],
    x_mm: f64,
    program: Option<crate::engagement::PathPoint>,
) -> (u16, u16) {
    match program {
        Some(p) => ((p.tool & 0xFFFF) as u16, (p.block & 0xFFFF) as u16),
        None => (nc.tool_at(x_mm), nc.block_number(segment_at(ends_mm, x_mm))),
    }
}

/// Index of the segment containing path position `x_mm` (the last one past the end).
fn segment_at(ends_mm: &[f64], x_mm: f64) -> usize {
    ends_mm
        .partition_point(|e| *e <= x_mm)
        .min(ends_mm.len().saturating_sub(1))
}

impl SimBoard {
    /// A v2 board with `step_pct` resolution (10 or 1; anything else is treated as 10), the
    /// operator's ACC switch on, operator override 100 %, NC cycle running, the default
    /// [`NcContext`].
    pub fn new(machine: Machine, step_pct: u16) -> Self {
        Self::with_protocol(machine, step_pct, EmulatedProtocol::V2)
    }

    /// As [`SimBoard::new`], speaking `protocol`.
    pub fn with_protocol(machine: Machine, step_pct: u16, protocol: EmulatedProtocol) -> Self {
        let res = OverrideResolution::from_step_pct(step_pct).unwrap_or_default();
        let mut logic = BoardLogic::with_protocol(res, protocol);
        logic.set_acc_switch(true);
        logic.set_operator_override_pct(100);
        logic.set_cycle_active(true);
        let mut board = SimBoard {
            logic: logic.shared(),
            machine,
            now_ms: 0,
            power_fault: None,
            external_clock: false,
            nc: NcContext::default(),
            segment_ends_mm: Vec::new(),
        };
        board.segment_ends_mm = board
            .machine
            .workpiece()
            .segments
            .iter()
            .map(|s| s.end_mm)
            .collect();
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

    /// Take the machine's engagement (and, for a program, its feeds, blocks and tools) from
    /// `source` ([`Machine::set_engagement_source`]) and publish the inputs it implies at
    /// the tool's position (programmed feed, `TOOL_NUMBER`, `BLOCK_NUMBER`).
    pub fn set_engagement_source(
        &mut self,
        source: Option<Box<dyn crate::engagement::EngagementSource>>,
    ) {
        self.machine.set_engagement_source(source);
        let fp = self.machine.programmed_feed_mm_min();
        lock_board(&self.logic)
            .set_programmed_feed_mm_min(fp.clamp(0.0, f64::from(u16::MAX)).round() as u16);
        self.publish_machine_inputs_no_sample();
    }

    /// The NC context reported from now on (tool, program, block numbering).
    pub fn set_nc_context(&mut self, nc: NcContext) {
        self.nc = nc;
        self.publish_machine_inputs_no_sample();
    }

    /// The NC context in use.
    pub fn nc_context(&self) -> NcContext {
        self.nc
    }

    /// Set or clear a fault of the power input (applies from the next period).
    pub fn set_power_fault(&mut self, fault: Option<PowerFault>) {
        self.power_fault = fault;
    }

    /// Advance the manual clock and the machine by one control period: the machine runs
    /// with the override now on the PMC inputs (`OVERRIDE_APPLIED`) and the feed hold, then
    /// the board publishes the new spindle power sample, speed and programmed feed, and the
    /// NC context: `ACTUAL_FEED` (the period's mean path feed after override, 0 while the
    /// feed is held), `TOOL_NUMBER`, `PROGRAM_NUMBER`, `BLOCK_NUMBER` (of the segment the
    /// tool is in).
    pub fn advance_period(&mut self, period_s: f64) -> PeriodRecord<'_> {
        self.advance_period_with(period_s, |_| ((), None)).0
    }

    /// [`SimBoard::advance_period`] with a sensor on the machine: `measure` reads the
    /// period first and returns what it wants to keep and the spindle power the board's
    /// transducer reports, W (whole watts; `None`: the machine's spindle model), which the
    /// board then publishes in its `POWER` registers (subject to a [`PowerFault`]).
    pub fn advance_period_with<T>(
        &mut self,
        period_s: f64,
        measure: impl FnOnce(&PeriodRecord<'_>) -> (T, Option<f64>),
    ) -> (PeriodRecord<'_>, T) {
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
        let path_mm = self.machine.path_length_mm();
        let rec = self.machine.advance(period_s);
        let (kept, sensor_power_w) = measure(&rec);
        {
            let mut b = lock_board(&self.logic);
            let power = sensor_power_w
                .unwrap_or(rec.power_mean_w)
                .clamp(0.0, f64::from(u32::MAX))
                .round() as u32;
            match self.power_fault {
                None => b.push_power_sample(power),
                Some(PowerFault::FrozenSeq) => b.set_spindle_power_w(power),
                Some(PowerFault::Garbage) => b.push_power_sample(u32::MAX),
            }
            b.set_spindle_rpm(rec.spindle_rpm.clamp(0.0, f64::from(u16::MAX)).round() as u16);
            b.set_cycle_active(rec.x_mm < path_mm);
            let feed = if b.feed_hold_active() {
                0
            } else {
                rec.feed_mean_mm_min.clamp(0.0, f64::from(u16::MAX)).round() as u16
            };
            b.set_actual_feed_mm_min(feed);
            if let Some(p) = rec.path_point {
                // A program's feed changes block by block (a rapid's is the rapid rate).
                b.set_programmed_feed_mm_min(
                    p.feed_mm_min.clamp(0.0, f64::from(u16::MAX)).round() as u16
                );
            }
            let (tool, block) =
                nc_numbers(&self.nc, &self.segment_ends_mm, rec.x_mm, rec.path_point);
            b.set_tool_number(tool);
            b.set_program_number(self.nc.program_number);
            b.set_block_number(block);
        }
        (rec, kept)
    }

    fn publish_machine_inputs_no_sample(&mut self) {
        let (tool, block) = nc_numbers(
            &self.nc,
            &self.segment_ends_mm,
            self.machine.x_mm(),
            self.machine.path_point(),
        );
        let mut b = lock_board(&self.logic);
        b.set_tool_number(tool);
        b.set_program_number(self.nc.program_number);
        b.set_block_number(block);
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
        drop(b);
        self.publish_machine_inputs_no_sample();
    }
}

/// The plant's truth of one period: what only the simulator knows and the run log's
/// simulator-only columns carry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantTruth {
    /// Tool-centre position at the end of the period, mm.
    pub x_mm: f64,
    /// Engaged radial depth, mm.
    pub radial_depth_mm: f64,
    /// Engaged axial depth, mm.
    pub axial_depth_mm: f64,
    /// True mean force over the measurement's window, N.
    pub force_n: f64,
    /// The feed drive's actual mean feed, mm/min.
    pub feed_mm_min: f64,
}

impl PlantTruth {
    /// The truth of period `rec`, with `true_force_n` the true mean force over the
    /// measurement's window.
    pub fn of(rec: &PeriodRecord<'_>, true_force_n: f64) -> Self {
        Self {
            x_mm: rec.x_mm,
            radial_depth_mm: rec.radial_depth_mm,
            axial_depth_mm: rec.axial_depth_mm,
            force_n: true_force_n,
            feed_mm_min: rec.feed_mean_mm_min,
        }
    }
}

/// Decode registers 0…8 of a v1 board's read reply.
fn v1_status(reply: Reply) -> Result<BoardStatus, Exception> {
    match reply {
        Reply::Registers(regs) if regs.len() >= usize::from(input::V1_COUNT) => {
            let mut block = [0u16; input::V1_COUNT as usize];
            block.copy_from_slice(&regs[..usize::from(input::V1_COUNT)]);
            Ok(BoardStatus::from_v1_input_registers(&block))
        }
        _ => Err(Exception::IllegalFunction),
    }
}

impl Board for SimBoard {
    type Error = Exception;

    /// The protocol the simulated board speaks (known without a read: it is our board).
    fn protocol(&self) -> Option<acc_pmc::BoardProtocol> {
        Some(if lock_board(&self.logic).protocol().is_v2() {
            acc_pmc::BoardProtocol::V2
        } else {
            acc_pmc::BoardProtocol::V1
        })
    }

    /// Input registers 0…14 as a client reads them; a v1 board (exception 02 for 9…14, or
    /// `PROTOCOL_VERSION` 0) is read as registers 0…8, like the RTU client does.
    fn read_status(&mut self) -> Result<BoardStatus, Exception> {
        let mut b = lock_board(&self.logic);
        let full = b.handle(
            Request::ReadInput {
                addr: 0,
                count: input::COUNT,
            },
            self.now_ms,
        );
        let regs = match full {
            Err(Exception::IllegalDataAddress) => {
                let reply = b.handle(
                    Request::ReadInput {
                        addr: 0,
                        count: input::V1_COUNT,
                    },
                    self.now_ms,
                )?;
                return v1_status(reply);
            }
            Ok(Reply::Registers(regs)) => regs,
            Err(e) => return Err(e),
            // The board answers a read with registers; anything else would be a bug in the
            // logic, reported like a device refusing the request.
            Ok(_) => return Err(Exception::IllegalFunction),
        };
        if regs.get(usize::from(input::PROTOCOL_VERSION)) == Some(&0) {
            return v1_status(Reply::Registers(regs));
        }
        let mut block = [0u16; input::COUNT as usize];
        for (b, r) in block.iter_mut().zip(regs) {
            *b = r;
        }
        Ok(BoardStatus::from_input_registers(&block))
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
