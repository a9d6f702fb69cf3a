//! The closed loop on the simulated machine: the production loop, driven by the runtime's
//! one period driver ([`acc_runtime::drive`]) on the stepped clock.
//!
//! There is one control loop in `acc` ([`acc_runtime::ControlLoop`] with its
//! [`FaultPolicy`]) and one driver for it: `acc run` drives it on the wall clock against a
//! serial or CAN board; here the same driver runs it against the simulated board
//! ([`crate::SimBoard`], the emulator's register logic behind the `Board` trait) on a
//! [`ManualClock`] (or, paced, on a [`ScaledClock`] over the system clock). Per control
//! period `T`:
//! 1. the driver's ticker reaches the period's deadline; the status read asks the simulated
//!    board's ticker ([`SteppedPlant`]) to run the plant up to that time: `T` with the
//!    override the board now applies (feed drive, process, wear, spindle); the board
//!    publishes the period's power sample, speed and cycle state;
//! 2. the scenario's measurement channel measures the period. On the spindle-power channel
//!    the board publishes the measured power in its `POWER` registers and the loop's
//!    spindle source estimates the force from the status read — the estimator calibrated
//!    by the scenario's start-up cut, on the code path of `acc run`. A dynamometer is not
//!    on the board: its sample reaches the loop through [`PlantSensor`];
//! 3. the control thread decides ([`ControlLoop::decide`]: guard, force, shop layer, policy,
//!    law) and the driver writes the override with a new heartbeat and the `CONTROL` bits —
//!    exactly as under `acc run`;
//! 4. the period's [`RunRecord`] gets the plant's truth (position, depths, true force and
//!    feed: [`PlantTruth`]) from the observer ([`SimObserver`]) and goes to the run log.
//!
//! The baselines of `acc compare` are other [`OverrideLaw`]s inside the same loop. The run
//! ends when the tool centre has passed the end of the workpiece, after
//! [`FEED_HOLD_END_S`] in a fault's feed hold, or at `max_time_s`.

use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use acc_core::clock::{Clock, GatedClock, ManualClock, ScaledClock, SystemClock};
use acc_core::{ForceSample, ForceSource, OverrideLaw, PeriodInput};
use acc_pmc::{Board, BoardStatus, ControlBits};
use acc_runtime::record::{RunLogError, RunLogWriter, RunRecord};
use acc_runtime::{
    drive, ControlLoop, FaultPolicy, Hooks, LogSink, PeriodObserver, RunOptions, Verdict,
};

use crate::board::PlantTruth;
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

/// What the plant's last period left for the loop's sensor and the run log.
#[derive(Debug, Clone, Copy, Default)]
struct PlantPeriod {
    /// The measurement channel's reading of the period.
    reading: Option<Reading>,
    /// The plant's truth of the period.
    truth: Option<PlantTruth>,
    /// The tool centre has passed the end of the workpiece.
    finished: bool,
}

type SharedPeriod = Arc<Mutex<PlantPeriod>>;

fn lock(p: &SharedPeriod) -> std::sync::MutexGuard<'_, PlantPeriod> {
    p.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The simulated machine's force sensor as the production loop's [`ForceSource`] when the
/// sensor is not on the board (a dynamometer, a current method on the three-phase block):
/// the simulated board's ticker puts each period's reading of the measurement channel here
/// before the status read returns, and the loop's `estimate` hands it on (a real
/// installation with a dynamometer amplifier wires its sensor the same way).
#[derive(Debug, Clone, Default)]
pub struct PlantSensor(SharedPeriod);

/// The production loop's force source in a simulated run.
enum LoopSource {
    /// The spindle estimator on the board's power register, as under `acc run`
    /// ([`MeasurementChannel::take_board_source`]).
    Board(Box<dyn ForceSource>),
    /// The measurement channel's own reading.
    Plant(PlantSensor),
}

impl ForceSource for LoopSource {
    fn name(&self) -> &str {
        match self {
            LoopSource::Board(s) => s.name(),
            LoopSource::Plant(s) => s.name(),
        }
    }

    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample {
        match self {
            LoopSource::Board(s) => s.estimate(input),
            LoopSource::Plant(s) => s.estimate(input),
        }
    }
}

impl ForceSource for PlantSensor {
    fn name(&self) -> &str {
        "plant-sensor"
    }

    fn estimate(&mut self, _input: &PeriodInput<'_>) -> ForceSample {
        lock(&self.0)
            .reading
            .map_or(ForceSample::INVALID, |r| r.sample)
    }
}

/// The simulated board's ticker on the driver's clock: every status read first runs the
/// plant over the whole control periods that have ended on the clock (one per period on the
/// stepped clock), measures each with the scenario's channel and publishes it.
pub struct SteppedPlant<'a, C> {
    board: &'a mut crate::SimBoard,
    channel: &'a mut dyn MeasurementChannel,
    clock: C,
    period: Duration,
    /// Periods the plant has run.
    done: u64,
    shared: SharedPeriod,
}

impl<C: Clock> SteppedPlant<'_, C> {
    fn catch_up(&mut self) {
        let due = self.clock.now().as_nanos() / self.period.as_nanos().max(1);
        let period_s = self.period.as_secs_f64();
        while u128::from(self.done) < due {
            let channel = &mut *self.channel;
            let (_, (reading, truth)) = self.board.advance_period_with(period_s, |rec| {
                let reading = channel.measure(rec);
                let truth = PlantTruth::of(rec, reading.true_force_n);
                ((reading, truth), reading.board_power_w)
            });
            *lock(&self.shared) = PlantPeriod {
                reading: Some(reading),
                truth: Some(truth),
                finished: self.board.machine().finished(),
            };
            self.done += 1;
        }
    }
}

impl<C: Clock> Board for SteppedPlant<'_, C> {
    type Error = acc_pmc::emu::Exception;

    fn protocol(&self) -> Option<acc_pmc::BoardProtocol> {
        self.board.protocol()
    }

    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        self.catch_up();
        self.board.read_status()
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error> {
        self.board.write_override(override_pct, heartbeat)
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error> {
        self.board.write_control(control)
    }
}

/// The simulator's side of every period, on the driver's control thread: the plant's truth
/// into the record and the end conditions (path finished, a fault's
/// feed hold for [`FEED_HOLD_END_S`]).
struct SimObserver {
    shared: SharedPeriod,
    period_s: f64,
    held_s: f64,
    ended_in_feed_hold: bool,
}

impl PeriodObserver for SimObserver {
    fn period(&mut self, row: &mut RunRecord) -> Verdict {
        let plant = *lock(&self.shared);
        if let Some(t) = plant.truth {
            crate::truth::apply(&t, row);
        }
        if plant.finished {
            return Verdict::Finish;
        }
        let held = row.feed_hold && row.state != "active";
        self.held_s = if held {
            self.held_s + self.period_s
        } else {
            0.0
        };
        if self.held_s >= FEED_HOLD_END_S - 1e-9 {
            self.ended_in_feed_hold = true;
            return Verdict::Finish;
        }
        Verdict::Continue
    }
}

/// The run's records: kept in memory for the summary, handed to the caller's `observe` (the
/// telemetry tap), and, with a writer, in the run log. Every row the driver writes passes
/// here, a skipped period's too, so the telemetry sees the rows the run log holds.
struct SimSink<'a> {
    rows: Vec<RunRecord>,
    log: Option<&'a mut dyn RunLog>,
    observe: Option<&'a mut (dyn FnMut(&RunRecord) + Send)>,
}

impl LogSink for SimSink<'_> {
    type Error = RunLogError;

    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        if let Some(observe) = self.observe.as_deref_mut() {
            observe(rec);
        }
        if let Some(w) = self.log.as_deref_mut() {
            w.write_record(rec)?;
        }
        self.rows.push(rec.clone());
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// How a simulated run keeps time.
#[derive(Debug, Clone, Default)]
pub enum Pace {
    /// The stepped clock: as fast as the CPU allows, deterministic.
    #[default]
    Stepped,
    /// The wall clock at this many machine seconds per wall second (`acc sim --time-scale`,
    /// the live view).
    Wall(f64),
    /// The stepped clock, never past what its owner allows (`acc sim --step-stdin`: an
    /// end-to-end test paces the run); deterministic like [`Pace::Stepped`].
    Gated(GatedClock),
}

/// Where a run's shop layer (tool table, entry control) comes from.
#[derive(Default)]
pub enum ShopLayer<'a> {
    /// The scenario's tool table (`[tools]`), if it has one.
    #[default]
    FromScenario,
    /// No shop layer.
    Off,
    /// This shop layer (e.g. one that starts from what an earlier run learned,
    /// [`acc_runtime::ShopControl::with_learned_from`]); after the run it holds the shop
    /// layer as the run left it (what the run learned).
    Given(&'a mut acc_runtime::ShopControl),
}

/// The run log a simulated run writes: a [`RunLogWriter`] over any writer (a file, a
/// buffer).
pub trait RunLog: Send {
    /// Write one record (and flush it).
    fn write_record(&mut self, rec: &RunRecord) -> Result<(), RunLogError>;
}

impl<W: Write + Send> RunLog for RunLogWriter<W> {
    fn write_record(&mut self, rec: &RunRecord) -> Result<(), RunLogError> {
        self.write(rec)
    }
}

/// Everything but the scenario and the law of a simulated run. The default: the scenario's
/// measurement channel and shop layer, no run log, the stepped clock, no look-ahead.
#[derive(Default)]
pub struct RunSetup<'a> {
    /// The measurement channel (e.g. one configured in code); `None`: the scenario's own
    /// ([`Scenario::build_channel`]).
    pub channel: Option<&'a mut dyn MeasurementChannel>,
    /// The run log to write, if any.
    pub log: Option<&'a mut dyn RunLog>,
    /// The shop layer.
    pub shop: ShopLayer<'a>,
    /// Applied to the fresh simulated board before the first period (the what-if sets the
    /// recorded engagement or the start position), if given.
    pub prepare: Option<&'a mut dyn FnMut(&mut crate::SimBoard)>,
    /// Called with every record the run log gets, a skipped period's too, on the driver's
    /// logger thread (`acc sim` publishes it on the telemetry tap), if given.
    pub observe: Option<&'a mut (dyn FnMut(&RunRecord) + Send)>,
    /// How the run keeps time.
    pub pace: Pace,
    /// The plan's look-ahead, if the run follows one ([`acc_runtime::lookahead`]).
    pub lookahead: Option<acc_runtime::LookAhead>,
}

/// The simulated run: `law` in the production loop on the one period driver against a
/// fresh simulated board built from `scenario` (see the module docs), set up by `setup`.
pub fn run(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    setup: RunSetup<'_>,
) -> Result<RunResult, SimError> {
    match setup.pace.clone() {
        Pace::Stepped => run_on(scenario, law, setup, ManualClock::new()),
        Pace::Gated(clock) => run_on(scenario, law, setup, clock),
        Pace::Wall(scale) => {
            let clock =
                ScaledClock::new(SystemClock::new(), scale).ok_or(SimError::TimeScale(scale))?;
            run_on(scenario, law, setup, clock)
        }
    }
}

fn run_on<C: Clock + Clone>(
    scenario: &Scenario,
    law: &mut dyn OverrideLaw,
    setup: RunSetup<'_>,
    clock: C,
) -> Result<RunResult, SimError> {
    let RunSetup {
        channel,
        log,
        shop,
        prepare,
        observe,
        lookahead,
        ..
    } = setup;
    let mut own_channel = None;
    let channel: &mut dyn MeasurementChannel = match channel {
        Some(c) => c,
        None => own_channel.insert(scenario.build_channel()?).as_mut(),
    };
    let (shop, learned) = match shop {
        ShopLayer::FromScenario => (scenario.shop_control(true), None),
        ShopLayer::Off => (None, None),
        ShopLayer::Given(given) => (Some(given.clone()), Some(given)),
    };
    let period_s = scenario.controller.period_s;
    let name = law.name().to_string();
    let shared = SharedPeriod::default();
    let mut control = ControlLoop::new(
        FaultPolicy::new(scenario.policy).with_watch_limits(scenario.watch),
        law,
        channel.take_board_source().map_or_else(
            || LoopSource::Plant(PlantSensor(Arc::clone(&shared))),
            LoopSource::Board,
        ),
        period_s,
    );
    if let Some(sh) = shop {
        control = control.with_shop(sh);
    }
    if let Some(la) = lookahead {
        control = control.with_lookahead(la);
    }
    let mut board = scenario.build_board();
    if let Some(prepare) = prepare {
        prepare(&mut board);
    }
    let period = Duration::from_secs_f64(period_s);
    let max_periods = (scenario.max_time_s / period_s).ceil() as u64;
    let mut plant = SteppedPlant {
        board: &mut board,
        channel,
        clock: clock.clone(),
        period,
        done: 0,
        shared: Arc::clone(&shared),
    };
    let mut observer = SimObserver {
        shared,
        period_s,
        held_s: 0.0,
        ended_in_feed_hold: false,
    };
    let mut sink = SimSink {
        rows: Vec::with_capacity((max_periods as usize).min(1 << 20)),
        log,
        observe,
    };
    let opts = RunOptions {
        max_periods: Some(max_periods),
        // The stepped clock runs flat out: every period may wait for the writer.
        log_buffer: (max_periods as usize).saturating_add(1),
        force_ref_n: Some(scenario.controller.force_ref_n),
        device_lost_periods: None,
        ..RunOptions::new(period)
    };
    let hooks = Hooks {
        reopen: None,
        observer: Some(&mut observer),
    };
    let summary = drive(
        &mut plant,
        &mut control,
        clock,
        &mut sink,
        &AtomicBool::new(false),
        opts,
        hooks,
    )
    .map_err(SimError::Driver)?;
    if let Some(e) = summary.log_error {
        return Err(SimError::LogWrite(e));
    }
    if let (Some(given), Some(left)) = (learned, control.shop()) {
        *given = left.clone();
    }
    Ok(RunResult {
        law: name,
        rows: sink.rows,
        finished: board.machine().finished(),
        volume_mm3: board.machine().volume_mm3(),
        ended_in_feed_hold: observer.ended_in_feed_hold,
    })
}

impl Scenario {
    /// The shop layer of this scenario's tool table (`[tools]`), if `on` and it has one.
    pub fn shop_control(&self, on: bool) -> Option<acc_runtime::ShopControl> {
        self.tools
            .clone()
            .filter(|_| on)
            .map(|table| acc_runtime::ShopControl::new(table, self.controller.period_s))
    }

    /// Build law `kind`, run it without a log file, and summarise the run.
    pub fn run_law(&self, kind: LawKind) -> Result<(RunResult, Summary), SimError> {
        let mut law = self.build_law(kind)?;
        let shop = if kind == LawKind::Ours || self.tools_for_baselines {
            ShopLayer::FromScenario
        } else {
            ShopLayer::Off
        };
        let setup = RunSetup {
            shop,
            ..RunSetup::default()
        };
        let result = run(self, law.as_mut(), setup)?;
        let summary = summarize(&result, self);
        Ok((result, summary))
    }
}

/// The repository's `configs/` directory (for tests, benches and the CLI's fallbacks).
pub fn configs_dir() -> std::path::PathBuf {
    acc_plant::configs_dir()
}
