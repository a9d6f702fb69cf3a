//! [`HalBoard`]: acc's [`Board`] on LinuxCNC. It reads the machine from HAL pins, writes the
//! adaptive feed with the 150 % mapping ([`crate::mapping`]) and behaves as a v2 board
//! (`../shared/docs/pmc-board.md`, "Board behaviour"), fallback clamp included.

use std::sync::Arc;
use std::time::Duration;

use acc_pmc::clock::Clock;
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};

use crate::cycle::ProgramCycle;
use crate::mapping::{adaptive_feed, applied_pct, ratio_pct, LAW_MAX_PCT, MOTION_TYPE_TRAVERSE};
use crate::pins::{AccOutputs, MachineInputs, PinBackend};

/// `OVERRIDE_CMD` after power-up, percent (as a board).
const POWER_UP_OVERRIDE_PCT: u16 = 100;
/// `FALLBACK_OVERRIDE` while no clamp is engaged, percent.
const NO_CLAMP_PCT: u16 = 150;

/// An error of [`HalBoard`]: HAL pins cannot fail to read or write, only a command can be
/// refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HalBoardError {
    /// An override above the law's 150 %: refused as a board refuses it (exception 03).
    #[error("override {pct} % is above 150 %")]
    OverrideOutOfRange {
        /// The refused override, percent.
        pct: u16,
    },
}

impl BoardError for HalBoardError {
    fn kind(&self) -> BoardErrorKind {
        match self {
            HalBoardError::OverrideOutOfRange { .. } => BoardErrorKind::Exception(3),
        }
    }
}

/// The fallback clamp while it is engaged: the override applied when acc stopped driving.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FallbackClamp {
    /// `FALLBACK_OVERRIDE`, percent of the programmed feed.
    pct: u16,
    /// The operator's override when it engaged (a turn of the knob ends the clamp); ratio.
    feed_override: f64,
}

/// acc's board link on LinuxCNC, over any [`PinBackend`] ([`crate::HalPins`] on a machine).
///
/// Status, per `BoardStatus` field: the switch is `acc.enable`, `OVERRIDE_LOCKED` is "no
/// `M52 P1`", `WATCHDOG_TRIPPED` is "`acc.watchdog-ok` false after it was true",
/// `CYCLE_ACTIVE` the program
/// running (low through the MDI command that follows the program's run in AUTO at once:
/// [`crate::cycle`]), `FEED_HOLD_ACTIVE` paused or acc's hold, `CNC_ALARM` estop or machine off, the
/// block number `motion.program-line`, feeds in mm/min from the velocity pins (mm/s × 60),
/// the override step 1 %. `SAMPLE_SEQ` counts reads; with `acc.sample-seq-used` set, only the
/// reads that found the power source's counter `acc.sample-seq` moved since the last read
/// (a new sample: one step, as a board's sensor advances once a period), so that a frozen
/// power pin is a sequence standing still, which the policy judges stale. HAL has no sample
/// counter of its own.
#[derive(Debug)]
pub struct HalBoard<B> {
    /// The pins.
    pins: B,
    /// The last read's inputs.
    inputs: MachineInputs,
    /// The outputs as last written.
    outputs: AccOutputs,
    /// `OVERRIDE_CMD`: the law's last override, percent.
    law_pct: u16,
    /// `ACC_REQUEST` and `FEED_HOLD_REQUEST` as last written.
    control: ControlBits,
    /// `ACC_ACTIVE` at the last update.
    active: bool,
    /// acc has been active since the cycle started.
    was_active_this_cycle: bool,
    /// `CYCLE_ACTIVE` from `acc.program-running` and `acc.mode-auto` ([`crate::cycle`]).
    cycle: ProgramCycle,
    /// The engaged fallback clamp.
    clamp: Option<FallbackClamp>,
    /// `SAMPLE_SEQ`: reads so far, or with the source's counter, reads that found it moved.
    reads: u16,
    /// The source's counter `acc.sample-seq` at the last read (with `acc.sample-seq-used`).
    source_seq: Option<i32>,
    /// `acc.watchdog-ok` has been true at a read: the watchdog runs. Before that (HAL still
    /// loading, its threads not started) a false pin is no trip.
    watchdog_seen_ok: bool,
    /// The clock that spaces the heartbeat's toggles ([`HalBoard::with_clock`]), and the time
    /// of the last toggle on it.
    beat_clock: Option<(Arc<dyn Clock>, Option<Duration>)>,
}

/// Shortest time between two toggles of `acc.heartbeat-bit`, s. LinuxCNC's watchdog samples
/// the bit once a servo period (1 ms) and sees a change only between two samples: two toggles
/// within one sample (a late period followed at once by the next, its deadline a few ms
/// later) cancel, and the watchdog counts from the toggle before. On a loaded host the servo
/// thread itself runs late by several ms. A read sooner than this after the last toggle
/// leaves the bit as it is; the next period toggles it. Toggles are never added, so a dead
/// or frozen loop trips the watchdog as before.
pub const MIN_BEAT_SPACING: Duration = Duration::from_millis(20);

impl<B: PinBackend> HalBoard<B> {
    /// A link over `pins`, as a board after power-up: override command 100 %, no request.
    pub fn new(pins: B) -> Self {
        Self {
            pins,
            inputs: MachineInputs::default(),
            outputs: AccOutputs {
                adaptive_feed: 1.0,
                ..AccOutputs::default()
            },
            law_pct: POWER_UP_OVERRIDE_PCT,
            control: ControlBits::default(),
            active: false,
            was_active_this_cycle: false,
            cycle: ProgramCycle::default(),
            clamp: None,
            reads: 0,
            source_seq: None,
            watchdog_seen_ok: false,
            beat_clock: None,
        }
    }

    /// The same link, its heartbeat's toggles at least [`MIN_BEAT_SPACING`] apart on `clock`
    /// (without a clock every status read toggles the bit).
    pub fn with_clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.beat_clock = Some((clock, None));
        self
    }

    /// Whether this status read toggles the heartbeat (and, with a clock, when it did).
    fn beat_due(&mut self) -> bool {
        let Some((clock, last)) = self.beat_clock.as_mut() else {
            return true;
        };
        let now = clock.now();
        if last.is_some_and(|t| now.saturating_sub(t) < MIN_BEAT_SPACING) {
            return false;
        }
        *last = Some(now);
        true
    }

    /// The pin backend (a test reads its fake's outputs here).
    pub fn pins(&self) -> &B {
        &self.pins
    }

    /// The pin backend, to change (a test sets its fake's inputs here).
    pub fn pins_mut(&mut self) -> &mut B {
        &mut self.pins
    }

    /// Re-evaluates `ACC_ACTIVE`, the fallback clamp and the outputs from the last inputs
    /// and commands, and writes the pins.
    fn update(&mut self) {
        let i = self.inputs;
        let active =
            self.control.acc_request && i.acc_switch && i.watchdog_ok && i.adaptive_enabled;
        self.update_clamp(active);
        self.active = active;
        self.was_active_this_cycle = self.cycle_active() && (self.was_active_this_cycle || active);
        self.outputs = AccOutputs {
            adaptive_feed: self.adaptive_feed_now(),
            heartbeat: self.outputs.heartbeat,
            heartbeat_bit: self.outputs.heartbeat_bit,
            feed_hold: self.control.feed_hold_request,
            active,
            handed_back: self.was_active_this_cycle && !active,
            alarm: i.estop || !i.machine_on || self.watchdog_tripped(),
        };
        self.pins.write(&self.outputs);
    }

    /// Engages the clamp when acc stops driving for a reason other than the operator's
    /// switch or `M52 P0`; ends it when the knob turns, the cycle ends or acc drives again.
    fn update_clamp(&mut self, active: bool) {
        let i = self.inputs;
        let operator_released = !i.acc_switch || !i.adaptive_enabled;
        if self.active && !active && !operator_released {
            self.clamp = Some(FallbackClamp {
                pct: self.applied_now(),
                feed_override: i.feed_override,
            });
        }
        if let Some(clamp) = self.clamp {
            if active || !self.cycle_active() || clamp.feed_override != i.feed_override {
                self.clamp = None;
            }
        }
    }

    /// `CYCLE_ACTIVE` of the last read ([`crate::cycle`]).
    fn cycle_active(&self) -> bool {
        self.cycle.active()
    }

    /// acc requests the override and nothing but `M52 P0` keeps it from driving: the NC
    /// ignores the pin (`OVERRIDE_LOCKED`), the policy holds its command.
    fn locked_out(&self) -> bool {
        let i = &self.inputs;
        self.control.acc_request && i.acc_switch && i.watchdog_ok && !i.adaptive_enabled
    }

    /// The adaptive feed to write: the law's override mapped while active, and while only
    /// `M52 P0` keeps acc from driving (LinuxCNC ignores the pin then; it holds the held
    /// command for the moment `M52 P1` takes effect, which LinuxCNC applies a servo period
    /// later, before acc's next read); the clamp's `min(operator, FALLBACK_OVERRIDE)` while
    /// engaged; 1.0 (the operator's override alone) otherwise; 1.0 on a traverse.
    fn adaptive_feed_now(&self) -> f64 {
        let motion_type = self.inputs.motion_type;
        if self.active || self.locked_out() {
            return adaptive_feed(self.law_pct, motion_type);
        }
        match self.clamp {
            Some(clamp)
                if motion_type != MOTION_TYPE_TRAVERSE && self.inputs.feed_override > 0.0 =>
            {
                (f64::from(clamp.pct) / (100.0 * self.inputs.feed_override)).clamp(0.0, 1.0)
            }
            _ => 1.0,
        }
    }

    /// `OVERRIDE_APPLIED`: the override a feed move gets now, percent of its programmed
    /// feed, `100 × feed override × adaptive feed`. On a traverse, where the pin is 1.0
    /// (rapids are never slowed), the adaptive feed the feed move after it gets: acc's
    /// command while it drives (so that the command echoes as on a board, and a release
    /// during a rapid clamps at that command, not at 150 %). Under `M52 P0` the motion
    /// ignores the pin: the knob alone.
    fn applied_now(&self) -> u16 {
        let i = &self.inputs;
        if !i.adaptive_enabled {
            return ratio_pct(i.feed_override);
        }
        let driving = self.active || self.locked_out();
        let adaptive = if i.motion_type == MOTION_TYPE_TRAVERSE && driving {
            adaptive_feed(self.law_pct, 0)
        } else {
            self.outputs.adaptive_feed
        };
        applied_pct(i.feed_override, adaptive)
    }

    /// `WATCHDOG_TRIPPED`: `acc.watchdog-ok` false after it has been true. acc is loaded
    /// (`loadusr -W`) before the rest of its HAL file and LinuxCNC starts HAL's threads
    /// after all of them: until the watchdog has run, its `ok-out` is false without a trip,
    /// and a trip read then latched ACC for the whole run (seen once under load). ACC does
    /// not drive before the pin is true either way (`ACC_ACTIVE` needs it).
    fn watchdog_tripped(&self) -> bool {
        self.watchdog_seen_ok && !self.inputs.watchdog_ok
    }

    /// The status block of the last read.
    fn status(&self) -> BoardStatus {
        let i = &self.inputs;
        BoardStatus {
            acc_switch: i.acc_switch,
            acc_active: self.active,
            cycle_active: self.cycle_active(),
            feed_hold_active: i.program_paused || self.control.feed_hold_request,
            watchdog_tripped: self.watchdog_tripped(),
            override_locked: !i.adaptive_enabled,
            cnc_alarm: i.estop || !i.machine_on,
            override_applied_pct: self.applied_now(),
            operator_override_pct: ratio_pct(i.feed_override),
            override_step_pct: 1,
            spindle_power_w: i.spindle_power_w.round().clamp(0.0, f64::from(u32::MAX)) as u32,
            spindle_rpm: to_u16(i.spindle_speed_rpm.abs()),
            sample_seq: self.reads,
            programmed_feed_mm_min: to_u16(60.0 * i.requested_vel_mm_s),
            fallback_active: self.clamp.is_some(),
            board_restarted: false,
            protocol_version: 2,
            tool_number: to_u16(f64::from(i.tool_number)),
            program_number: 0,
            block_number: if i.program_line > 0 {
                i.program_line as u16
            } else {
                0
            },
            actual_feed_mm_min: to_u16(60.0 * i.current_vel_mm_s),
            fallback_override_pct: self.clamp.map_or(NO_CLAMP_PCT, |clamp| clamp.pct),
        }
    }
}

/// `value` rounded into `0..=u16::MAX`.
fn to_u16(value: f64) -> u16 {
    value.round().clamp(0.0, f64::from(u16::MAX)) as u16
}

impl<B: PinBackend> Board for HalBoard<B> {
    type Error = HalBoardError;

    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        self.inputs = self.pins.read();
        self.watchdog_seen_ok |= self.inputs.watchdog_ok;
        self.cycle
            .read(self.inputs.program_running, self.inputs.mode_auto);
        let source = self
            .inputs
            .sample_seq_used
            .then_some(self.inputs.sample_seq);
        if source.is_none() || source != self.source_seq {
            self.reads = self.reads.wrapping_add(1);
        }
        self.source_seq = source;
        // The loop reads the status every period, driving or not (it writes the override
        // only while it drives): the watchdog's bit toggles here, so that it stops only
        // when acc's loop stops; never twice within MIN_BEAT_SPACING.
        if self.beat_due() {
            self.outputs.heartbeat_bit = !self.outputs.heartbeat_bit;
        }
        self.update();
        Ok(self.status())
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error> {
        if f64::from(override_pct) > LAW_MAX_PCT {
            return Err(HalBoardError::OverrideOutOfRange { pct: override_pct });
        }
        self.law_pct = override_pct;
        self.outputs.heartbeat = i32::from(heartbeat);
        self.update();
        Ok(())
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error> {
        // ALARM_RESET has no pin: the realtime watchdog re-arms in HAL (its enable-in).
        self.control = ControlBits {
            alarm_reset: false,
            ..control
        };
        self.update();
        Ok(())
    }

    fn protocol(&self) -> Option<BoardProtocol> {
        Some(BoardProtocol::V2)
    }
}
