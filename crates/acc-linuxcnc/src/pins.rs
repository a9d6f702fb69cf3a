//! The pins acc owns on LinuxCNC, as two plain structs (one period's reads, one period's
//! writes) and the [`PinBackend`] that moves them: HAL ([`HalPins`]) or a test's fake.

use acc_hal::{BitIn, BitOut, FloatIn, FloatOut, HalComponent, HalError, S32In, S32Out};

/// What acc reads from LinuxCNC each period. Each field names the pin of component `acc`
/// and the LinuxCNC pin (2.9) an integrator nets it to (docs/linuxcnc.md).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MachineInputs {
    /// `acc.spindle-power` ← a power meter, a VFD's load, or the simulated process; W.
    pub spindle_power_w: f64,
    /// `acc.spindle-speed` ← `spindle.0.speed-out`; rpm.
    pub spindle_speed_rpm: f64,
    /// `acc.program-line` ← `motion.program-line` (0 = none).
    pub program_line: i32,
    /// `acc.motion-type` ← `motion.motion-type` (1 = traverse).
    pub motion_type: i32,
    /// `acc.tool-number` ← `iocontrol.0.tool-number` (0 = none).
    pub tool_number: i32,
    /// `acc.requested-vel` ← `motion.requested-vel`; mm/s.
    pub requested_vel_mm_s: f64,
    /// `acc.current-vel` ← `motion.current-vel`; mm/s.
    pub current_vel_mm_s: f64,
    /// `acc.feed-override` ← `halui.feed-override.value`; ratio (1.5 = 150 %).
    pub feed_override: f64,
    /// `acc.machine-on` ← `halui.machine.is-on`.
    pub machine_on: bool,
    /// `acc.estop` ← `halui.estop.is-activated`.
    pub estop: bool,
    /// `acc.program-running` ← `halui.program.is-running`.
    pub program_running: bool,
    /// `acc.program-paused` ← `halui.program.is-paused`.
    pub program_paused: bool,
    /// `acc.mode-auto` ← `halui.mode.is-auto`: the run is the program's (an MDI command
    /// also sets `halui.program.is-running`). Unconnected (false), `CYCLE_ACTIVE` is the
    /// program running alone.
    pub mode_auto: bool,
    /// `acc.adaptive-enabled` ← true while `M52 P1` is in force (the integrator's signal).
    pub adaptive_enabled: bool,
    /// `acc.enable` ← the operator's ACC ON switch.
    pub acc_switch: bool,
    /// `acc.watchdog-ok` ← `watchdog.ok-out`: the realtime watchdog on acc's heartbeat.
    pub watchdog_ok: bool,
    /// `acc.sample-seq` ← a counter the power source advances with every new power sample
    /// (the simulated process's `acc-process.sample-seq`); `SAMPLE_SEQ` when
    /// [`Self::sample_seq_used`].
    pub sample_seq: i32,
    /// `acc.sample-seq-used` (`setp` in the HAL file): `acc.sample-seq` is netted to a power
    /// source's counter. Without it `SAMPLE_SEQ` counts reads and a frozen power pin goes
    /// unnoticed.
    pub sample_seq_used: bool,
}

/// What acc writes to LinuxCNC each period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AccOutputs {
    /// `acc.adaptive-feed` → `motion.adaptive-feed`; in [0, 1].
    pub adaptive_feed: f64,
    /// `acc.heartbeat` (s32): the value of the last override write.
    pub heartbeat: i32,
    /// `acc.heartbeat-bit` → a `watchdog` input: toggles at every status read, i.e. once a
    /// period whether acc drives or not; it stops when acc's loop stops.
    pub heartbeat_bit: bool,
    /// `acc.feed-hold` → `motion.feed-inhibit` (or the integrator's pause).
    pub feed_hold: bool,
    /// `acc.active`: acc drives the adaptive feed.
    pub active: bool,
    /// `acc.handed-back`: acc was active and has handed the feed back.
    pub handed_back: bool,
    /// `acc.alarm`: estop, machine off or a tripped watchdog.
    pub alarm: bool,
}

/// Moves one period's pins; [`HalPins`] on LinuxCNC, a fake in tests.
pub trait PinBackend {
    /// Reads every input pin.
    fn read(&mut self) -> MachineInputs;
    /// Writes every output pin.
    fn write(&mut self, outputs: &AccOutputs);
}

/// The input pins of component `acc` on HAL.
#[derive(Debug)]
struct InputPins {
    spindle_power: FloatIn,
    spindle_speed: FloatIn,
    program_line: S32In,
    motion_type: S32In,
    tool_number: S32In,
    requested_vel: FloatIn,
    current_vel: FloatIn,
    feed_override: FloatIn,
    machine_on: BitIn,
    estop: BitIn,
    program_running: BitIn,
    program_paused: BitIn,
    mode_auto: BitIn,
    adaptive_enabled: BitIn,
    acc_switch: BitIn,
    watchdog_ok: BitIn,
    sample_seq: S32In,
    sample_seq_used: BitIn,
}

/// The output pins of component `acc` on HAL.
#[derive(Debug)]
struct OutputPins {
    adaptive_feed: FloatOut,
    heartbeat: S32Out,
    heartbeat_bit: BitOut,
    feed_hold: BitOut,
    active: BitOut,
    handed_back: BitOut,
    alarm: BitOut,
}

/// The pins of [`MachineInputs`] and [`AccOutputs`] on a HAL component, made ready.
#[derive(Debug)]
pub struct HalPins {
    inputs: InputPins,
    outputs: OutputPins,
    /// Dropped last: the component leaves HAL with its pins.
    _component: HalComponent,
}

impl HalPins {
    /// Creates every pin on `component` (named `<component>.<suffix>` as in the field docs)
    /// and makes it ready.
    pub fn new(component: HalComponent) -> Result<Self, HalError> {
        let c = &component;
        let inputs = InputPins {
            spindle_power: c.float_in("spindle-power")?,
            spindle_speed: c.float_in("spindle-speed")?,
            program_line: c.s32_in("program-line")?,
            motion_type: c.s32_in("motion-type")?,
            tool_number: c.s32_in("tool-number")?,
            requested_vel: c.float_in("requested-vel")?,
            current_vel: c.float_in("current-vel")?,
            feed_override: c.float_in("feed-override")?,
            machine_on: c.bit_in("machine-on")?,
            estop: c.bit_in("estop")?,
            program_running: c.bit_in("program-running")?,
            program_paused: c.bit_in("program-paused")?,
            mode_auto: c.bit_in("mode-auto")?,
            adaptive_enabled: c.bit_in("adaptive-enabled")?,
            acc_switch: c.bit_in("enable")?,
            watchdog_ok: c.bit_in("watchdog-ok")?,
            sample_seq: c.s32_in("sample-seq")?,
            sample_seq_used: c.bit_in("sample-seq-used")?,
        };
        let outputs = OutputPins {
            adaptive_feed: c.float_out("adaptive-feed")?,
            heartbeat: c.s32_out("heartbeat")?,
            heartbeat_bit: c.bit_out("heartbeat-bit")?,
            feed_hold: c.bit_out("feed-hold")?,
            active: c.bit_out("active")?,
            handed_back: c.bit_out("handed-back")?,
            alarm: c.bit_out("alarm")?,
        };
        component.ready()?;
        Ok(Self {
            inputs,
            outputs,
            _component: component,
        })
    }
}

impl PinBackend for HalPins {
    fn read(&mut self) -> MachineInputs {
        let i = &self.inputs;
        MachineInputs {
            spindle_power_w: i.spindle_power.get(),
            spindle_speed_rpm: i.spindle_speed.get(),
            program_line: i.program_line.get(),
            motion_type: i.motion_type.get(),
            tool_number: i.tool_number.get(),
            requested_vel_mm_s: i.requested_vel.get(),
            current_vel_mm_s: i.current_vel.get(),
            feed_override: i.feed_override.get(),
            machine_on: i.machine_on.get(),
            estop: i.estop.get(),
            program_running: i.program_running.get(),
            program_paused: i.program_paused.get(),
            mode_auto: i.mode_auto.get(),
            adaptive_enabled: i.adaptive_enabled.get(),
            acc_switch: i.acc_switch.get(),
            watchdog_ok: i.watchdog_ok.get(),
            sample_seq: i.sample_seq.get(),
            sample_seq_used: i.sample_seq_used.get(),
        }
    }

    fn write(&mut self, outputs: &AccOutputs) {
        let o = &mut self.outputs;
        o.adaptive_feed.set(outputs.adaptive_feed);
        o.heartbeat.set(outputs.heartbeat);
        o.heartbeat_bit.set(outputs.heartbeat_bit);
        o.feed_hold.set(outputs.feed_hold);
        o.active.set(outputs.active);
        o.handed_back.set(outputs.handed_back);
        o.alarm.set(outputs.alarm);
    }
}
