//! The closed loop on the simulated machine.
//!
//! Per control period `T` (manual clock, no sleeping):
//! 1. the machine runs `T` with the override now applied by the board;
//! 2. the measurement channel turns the period into a force sample (`ForceSource`);
//! 3. the loop reads the board status through the [`Board`] trait (applied override,
//!    programmed feed, spindle speed and power) — the feed that produced the force is
//!    `programmed × applied`, as on a real machine;
//! 4. the law steps and its command is written with a new heartbeat through [`Board`];
//! 5. one run-log row is written (and flushed).
//!
//! The run ends when the tool centre has passed the end of the workpiece or at
//! `max_time_s`.

use std::io::Write;

use acc_core::{FeedOverride, Measurement, Mode, OverrideLaw, Saturation};
use acc_pmc::{Board, ControlBits};

use crate::channel::MeasurementChannel;
use crate::runlog::{RunLogRow, RunLogWriter};
use crate::scenario::{LawKind, Scenario};
use crate::summary::{summarize, Summary};
use crate::SimError;

/// What a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Law name.
    pub law: String,
    /// One row per period (the run log).
    pub rows: Vec<RunLogRow>,
    /// Whether the tool reached the end of the path before the time limit.
    pub finished: bool,
    /// Metal removed, mm³.
    pub volume_mm3: f64,
}

/// Run-log name of a mode.
pub fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::AdaptivePi => "adaptive_pi",
        Mode::FixedPi => "fixed_pi",
        Mode::AdaptiveIntegral => "adaptive_integral",
        Mode::Baseline => "baseline",
    }
}

fn saturation_name(s: Saturation) -> &'static str {
    match s {
        Saturation::None => "none",
        Saturation::Low => "low",
        Saturation::High => "high",
    }
}

/// Run `law` on a fresh machine built from `scenario`, measuring with the scenario's
/// channel; write every row to `log` if given.
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
    mut log: Option<&mut RunLogWriter<W>>,
) -> Result<RunResult, SimError> {
    let period_s = scenario.controller.period_s;
    let mut board = scenario.build_board();
    board.write_control(ControlBits {
        acc_request: true,
        ..ControlBits::default()
    })?;
    let status = board.read_status()?;
    law.engage(FeedOverride(status.override_applied_pct));
    let mut heartbeat: u16 = 0;
    let max_periods = (scenario.max_time_s / period_s).ceil() as usize;
    let mut rows = Vec::with_capacity(max_periods.min(1 << 20));
    let mut finished = false;
    for _ in 0..max_periods {
        let (rec_fields, reading) = {
            let rec = board.advance_period(period_s);
            let reading = channel.measure(&rec);
            (
                (
                    rec.t_end_s,
                    rec.x_mm,
                    rec.radial_depth_mm,
                    rec.axial_depth_mm,
                    rec.feed_mean_mm_min,
                ),
                reading,
            )
        };
        let (t_s, x_mm, depth, axial, feed_mean) = rec_fields;
        let status = board.read_status()?;
        law.set_frozen(status.override_locked);
        let programmed = f64::from(status.programmed_feed_mm_min);
        let m = Measurement {
            force_n: reading.sample.force_n,
            feed_mm_min: programmed * f64::from(status.override_applied_pct) / 100.0,
            programmed_feed_mm_min: programmed,
            valid: reading.sample.valid,
        };
        let out = law.step(&m);
        heartbeat = heartbeat.wrapping_add(1);
        board.write_override(out.command.pct(), heartbeat)?;
        let row = RunLogRow {
            t_s,
            x_mm: Some(x_mm),
            radial_depth_mm: Some(depth),
            axial_depth_mm: Some(axial),
            spindle_rpm: f64::from(status.spindle_rpm),
            programmed_feed_mm_min: programmed,
            override_cmd_pct: out.command.pct(),
            override_applied_pct: status.override_applied_pct,
            feed_mm_min: feed_mean,
            force_n: reading.sample.force_n,
            force_true_n: Some(reading.true_force_n),
            force_ref_n: out.trace.force_ref_n,
            power_w: reading
                .sample
                .power_w
                .or(Some(f64::from(status.spindle_power_w))),
            kc_hat: out.trace.kc_hat,
            kp: out.trace.kp,
            ki: out.trace.ki,
            mode: mode_name(out.trace.mode).to_string(),
            error_n: out.trace.error_n,
            valid: reading.sample.valid,
            saturation: saturation_name(out.trace.saturation).to_string(),
        };
        if let Some(w) = log.as_deref_mut() {
            w.write(&row)?;
        }
        rows.push(row);
        if board.machine().finished() {
            finished = true;
            break;
        }
    }
    Ok(RunResult {
        law: law.name().to_string(),
        rows,
        finished,
        volume_mm3: board.machine().volume_mm3(),
    })
}

impl Scenario {
    /// Build law `kind`, run it without a log file, and summarise the run.
    pub fn run_law(&self, kind: LawKind) -> Result<(RunResult, Summary), SimError> {
        let mut law = self.build_law(kind)?;
        let result = run::<std::io::Sink>(self, law.as_mut(), None)?;
        let summary = summarize(&result, self);
        Ok((result, summary))
    }
}

/// The repository's `configs/` directory (for tests, benches and the CLI's fallbacks).
pub fn configs_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs")
}
