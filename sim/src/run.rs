//! The closed loop on the simulated machine: the production loop on a stepped clock.
//!
//! There is one control loop in `acc`: [`acc_runtime::ControlLoop`] with its
//! [`FaultPolicy`], the loop `acc run` drives on a wall clock against a serial or CAN board.
//! Here it runs against the simulated board ([`crate::SimBoard`], the emulator's
//! register logic behind the `Board` trait) on a clock the simulator steps. Per control period
//! `T`:
//! 1. the plant runs `T` with the override the board now applies (feed drive, process, wear,
//!    spindle); the board publishes the period's power sample, speed and cycle state;
//! 2. the scenario's measurement channel (dynamometer or induction-motor spindle power)
//!    measures the period; the loop's force source ([`PlantSensor`]) hands that sample on;
//! 3. [`ControlLoop::cycle`] reads the status through the `Board` trait, computes the actual
//!    feed (programmed × applied), lets the fault policy step the law, and writes the
//!    override with a new heartbeat and the `CONTROL` bits — exactly as under `acc run`;
//! 4. the period's [`RunRecord`] (the production record plus the plant's truth: position,
//!    depths, true force and feed) is written and flushed.
//!
//! The baselines of `acc compare` are other [`OverrideLaw`]s inside the same loop. The run
//! ends when the tool centre has passed the end of the workpiece or at `max_time_s`.

use std::cell::Cell;
use std::io::Write;
use std::rc::Rc;

use acc_core::{ForceSample, ForceSource, OverrideLaw, PeriodInput};
use acc_runtime::record::{RunLogWriter, RunRecord};
use acc_runtime::{ControlLoop, FaultPolicy};

use crate::board::add_truth;
use crate::channel::{MeasurementChannel, Reading};
use crate::scenario::{LawKind, Scenario};
use crate::summary::{summarize, Summary};
use crate::SimError;

/// What a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Law name.
    pub law: String,
    /// One record per period (the run log).
    pub rows: Vec<RunRecord>,
    /// Whether the tool reached the end of the path before the time limit.
    pub finished: bool,
    /// Metal removed, mm³.
    pub volume_mm3: f64,
    /// The fault policy released ACC with a feed hold (overload: tool-breakage protection)
    /// and the machine stood still for [`FEED_HOLD_END_S`]: the run ended there, as the
    /// operator would have to intervene on a real machine.
    pub ended_in_feed_hold: bool,
}

/// A run ends after this long in a feed hold requested by a fault release, s.
pub const FEED_HOLD_END_S: f64 = 2.0;

/// The simulated machine's force sensor as the production loop's [`ForceSource`]: the
/// simulator puts each period's reading of the measurement channel here before the loop's
/// cycle, and the loop's `estimate` hands it on (a real installation with a dynamometer
/// amplifier or a current-signal estimator wires its sensor the same way).
#[derive(Debug, Clone, Default)]
pub struct PlantSensor(Rc<Cell<Option<Reading>>>);

impl PlantSensor {
    /// Set the reading of the period that just ended.
    pub fn set(&self, reading: Reading) {
        self.0.set(Some(reading));
    }
}

impl ForceSource for PlantSensor {
    fn name(&self) -> &str {
        "plant-sensor"
    }

    fn estimate(&mut self, _input: &PeriodInput<'_>) -> ForceSample {
        self.0.get().map_or(ForceSample::INVALID, |r| r.sample)
    }
}

/// Run `law` on a fresh machine built from `scenario`, measuring with the scenario's
/// channel; write every record to `log` if given.
pub fn run<W: Write>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    log: Option<&mut RunLogWriter<W>>,
) -> Result<RunResult, SimError> {
    let mut channel = scenario.build_channel()?;
    run_with_channel(scenario, law, channel.as_mut(), log)
}

/// [`run`] with a caller-supplied measurement channel (e.g. one configured in code).
pub fn run_with_channel<W: Write>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    channel: &mut dyn MeasurementChannel,
    log: Option<&mut RunLogWriter<W>>,
) -> Result<RunResult, SimError> {
    run_with_shop(scenario, law, channel, log, scenario.tools.is_some())
}

/// [`run_with_channel`], with the scenario's tool table (`[tools]`, the shop layer of the
/// production loop: per-tool limits and entry control) only if `shop` (and the scenario
/// has one).
pub fn run_with_shop<W: Write>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    channel: &mut dyn MeasurementChannel,
    log: Option<&mut RunLogWriter<W>>,
    shop: bool,
) -> Result<RunResult, SimError> {
    run_prepared(scenario, law, channel, log, shop, &mut |_| {})
}

/// [`run_with_shop`] with `prepare` applied to the fresh simulated board before the
/// first period (the what-if replay sets the recorded engagement or the start position).
pub fn run_prepared<W: Write>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    channel: &mut dyn MeasurementChannel,
    log: Option<&mut RunLogWriter<W>>,
    shop: bool,
    prepare: &mut dyn FnMut(&mut crate::SimBoard),
) -> Result<RunResult, SimError> {
    run_observed(scenario, law, channel, log, shop, prepare, &mut |_| {})
}

/// [`run_prepared`] with `observe` called with every period's record right after it was
/// logged (`acc sim --shdr/--mqtt` publishes it on the telemetry tap there and paces the
/// run to wall time with `--time-scale`).
pub fn run_observed<W: Write>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    channel: &mut dyn MeasurementChannel,
    mut log: Option<&mut RunLogWriter<W>>,
    shop: bool,
    prepare: &mut dyn FnMut(&mut crate::SimBoard),
    observe: &mut dyn FnMut(&RunRecord),
) -> Result<RunResult, SimError> {
    let period_s = scenario.controller.period_s;
    let name = law.name().to_string();
    let sensor = PlantSensor::default();
    let mut control = ControlLoop::new(
        FaultPolicy::new(scenario.policy),
        law,
        sensor.clone(),
        period_s,
    );
    if let Some(table) = scenario.tools.clone().filter(|_| shop) {
        control = control.with_shop(acc_runtime::ShopControl::new(table, period_s));
    }
    let mut board = scenario.build_board();
    prepare(&mut board);
    let max_periods = (scenario.max_time_s / period_s).ceil() as usize;
    let mut rows = Vec::with_capacity(max_periods.min(1 << 20));
    let mut finished = false;
    let mut held_s = 0.0;
    let mut ended_in_feed_hold = false;
    for _ in 0..max_periods {
        let (t_s, truth, sensor_power) = {
            let rec = board.advance_period(period_s);
            let reading = channel.measure(&rec);
            sensor.set(reading);
            let mut truth = RunRecord::default();
            add_truth(&mut truth, &rec, reading.true_force_n);
            (rec.t_end_s, truth, reading.sample.power_w)
        };
        let cycle = control.cycle(&mut board, t_s);
        let mut row = cycle
            .record(Some(scenario.controller.force_ref_n))
            .with_truth_of(&truth);
        // A channel that measures power itself (the induction-motor channel's
        // two-wattmeter reading) logs what it measured; otherwise the board's register.
        if sensor_power.is_some() {
            row.power_w = sensor_power;
        }
        if let Some(w) = log.as_deref_mut() {
            w.write(&row)?;
        }
        observe(&row);
        let held = row.feed_hold && row.state != "active";
        rows.push(row);
        if board.machine().finished() {
            finished = true;
            break;
        }
        held_s = if held { held_s + period_s } else { 0.0 };
        if held_s >= FEED_HOLD_END_S - 1e-9 {
            ended_in_feed_hold = true;
            break;
        }
    }
    Ok(RunResult {
        law: name,
        rows,
        finished,
        volume_mm3: board.machine().volume_mm3(),
        ended_in_feed_hold,
    })
}

impl Scenario {
    /// Build law `kind`, run it without a log file, and summarise the run.
    pub fn run_law(&self, kind: LawKind) -> Result<(RunResult, Summary), SimError> {
        let mut law = self.build_law(kind)?;
        let mut channel = self.build_channel()?;
        let shop = self.tools.is_some() && (kind == LawKind::Ours || self.tools_for_baselines);
        let result =
            run_with_shop::<std::io::Sink>(self, law.as_mut(), channel.as_mut(), None, shop)?;
        let summary = summarize(&result, self);
        Ok((result, summary))
    }
}

/// The repository's `configs/` directory (for tests, benches and the CLI's fallbacks).
pub fn configs_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs")
}
