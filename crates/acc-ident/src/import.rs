//! Importers for the real data in `../shared/data/`, mapped onto the run-log schema. The
//! files are read by `acc_spindle::datasets` (the one reader of these data sets, shared with
//! `acc estimate-eval`); this module maps its rows onto run logs.
//!
//! **Vicomtech turning** (`vicomtech-turning/tool_wear_tools_3-10.csv`, CC BY-SA 4.0,
//! Ferrando Chacón et al., Int. J. Adv. Manuf. Technol. 125 (2023) 4027–4045; raw data
//! Mondragon Unibertsitatea): one 1 s segment per row, in time order within a tool.
//!
//! | run-log column | source | unit |
//! | --- | --- | --- |
//! | `t_s` | row index within the tool × 1 s | s (segment time; gaps between passes are not recorded) |
//! | `force_n` | `F_c_MEAN` (dynamometer cutting force) | N |
//! | `power_w` | `TV50.S_MEAN` (spindle mechanical power) | W |
//! | `spindle_rpm` | `CON.SV2.S / 1000` (encoder speed; the data's internal scale, proportional to rpm, factor undocumented) | "rpm" (scaled) |
//! | `feed_mm_min` | `CON.G.FREAL` (programmed feed; proportional to speed, i.e. constant feed per revolution) | data's unit (mm/min assumed) |
//! | `radial_depth_mm`, `axial_depth_mm` | not recorded: 1 (placeholder: every row is cutting) | mm |
//! | `wear_vb_um` | `Vb` (flank wear, interpolated) — never read by the workflow | µm |
//!
//! Rows with zero programmed feed are skipped (one row of tool 3), and so are rows whose
//! feed per spindle unit is more than 20 % off the tool's median (1 s segments straddling
//! a pass change, e.g. tool 10 row 26 with a feed of 29 290).
//!
//! **UMich CNC mill** (`umich-cnc-mill/experiment_NN.csv`, CC0, University of Michigan
//! SMART lab 2018): wax, one row every 100 ms.
//!
//! | run-log column | source | unit |
//! | --- | --- | --- |
//! | `t_s` | row index × 0.1 s | s |
//! | `power_w` | `S1_OutputPower × 1000` | W (source in kW) |
//! | `spindle_rpm` | `S1_ActualVelocity × 60` | rpm, assuming the undocumented unit is rev/s (≈ 53.3 → 3 200 rpm) |
//! | `feed_mm_min` | `60·√(X1_ActualVelocity² + Y1_ActualVelocity²)` | mm/min (source mm/s) |
//! | `programmed_feed_mm_min` | `M1_CURRENT_FEEDRATE × 60` | mm/min (source mm/s, matches the path speed) |
//! | `radial_depth_mm`, `axial_depth_mm` | 1 while `Machining_Process` is a `Layer …` phase, else 0 (placeholder depth; wax cut depth not recorded) | mm |
//! | `phase` | `Machining_Process` | text |

use std::collections::BTreeMap;
use std::path::Path;

use acc_spindle::datasets::{read_mill, read_turning, DatasetError};

use crate::model::{
    Channel, FeedDrive, FeedInput, Machine, Measurement, Model, OverridePath, Process, Spindle,
    Tool, Wear,
};
use crate::runlog::{RunLog, RunLogError};

/// The data sets are read by `acc_spindle::datasets` (one reader for `acc estimate-eval`
/// and the import); its errors keep their file, line and column here.
impl From<DatasetError> for RunLogError {
    fn from(e: DatasetError) -> Self {
        match e {
            DatasetError::Open { file, reason } => RunLogError::Io { file, reason },
            DatasetError::MissingColumn { file, column } => RunLogError::MissingColumn {
                file,
                column,
                required: "see acc_ident::import docs".into(),
            },
            DatasetError::BadValue {
                file,
                line,
                col,
                column,
                message,
            } => RunLogError::BadValue {
                file,
                line,
                col,
                column,
                message,
            },
            DatasetError::Csv {
                file,
                line,
                message,
            } => RunLogError::Csv {
                file,
                line,
                message,
            },
        }
    }
}

/// Import the Vicomtech turning file: one run log per tool id, in file order.
pub fn vicomtech_turning(path: &Path) -> Result<BTreeMap<u32, RunLog>, RunLogError> {
    let (rows, _skipped) = read_turning(path)?;
    let mut out: BTreeMap<u32, RunLog> = BTreeMap::new();
    for r in rows {
        let log = out.entry(r.tool).or_insert_with(|| RunLog {
            force_n: Some(Vec::new()),
            power_w: Some(Vec::new()),
            wear_vb_um: Some(Vec::new()),
            ..RunLog::default()
        });
        let t = log.t_s.len() as f64 + 1.0;
        log.t_s.push(t);
        log.radial_depth_mm.push(1.0);
        log.axial_depth_mm.push(1.0);
        log.spindle_rpm.push(r.speed / 1000.0);
        log.feed_mm_min.push(r.feed);
        let push = |v: &mut Option<Vec<f64>>, x: f64| {
            if let Some(v) = v.as_mut() {
                v.push(x);
            }
        };
        push(&mut log.force_n, r.force_n);
        push(&mut log.power_w, r.power_w);
        push(&mut log.wear_vb_um, r.vb_um);
    }
    for log in out.values_mut() {
        let ratio: Vec<f64> = (0..log.len())
            .map(|i| log.feed_mm_min[i] / log.spindle_rpm[i].max(1e-9))
            .collect();
        let mut sorted = ratio.clone();
        sorted.sort_by(f64::total_cmp);
        let med = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let keep: Vec<usize> = (0..log.len())
            .filter(|&i| (ratio[i] - med).abs() <= 0.2 * med)
            .collect();
        *log = log.rows(&keep);
        log.validate(path)?;
    }
    Ok(out)
}

/// Import one UMich CNC-mill experiment file.
///
/// Only rows with the spindle at its running speed (within 2 % of the median of the
/// turning rows, and the rows before and after too) are kept: spindle run-up and
/// run-down power (inertia) is outside the model, and rows with the spindle stopped carry
/// no information. Time keeps the original 0.1 s grid (with gaps).
pub fn umich_mill(path: &Path) -> Result<RunLog, RunLogError> {
    let rows = read_mill(path)?;
    let mut log = RunLog::default();
    let mut power = Vec::new();
    let mut prog = Vec::new();
    let mut phases = Vec::new();
    for r in rows {
        let cutting = r.is_cutting();
        let t = (log.t_s.len() + 1) as f64 * 0.1;
        log.t_s.push(t);
        let d = if cutting { 1.0 } else { 0.0 };
        log.radial_depth_mm.push(d);
        log.axial_depth_mm.push(d);
        log.spindle_rpm.push((r.spindle_velocity * 60.0).max(0.0));
        let (vx, vy) = (r.x_velocity_mm_s, r.y_velocity_mm_s);
        log.feed_mm_min.push(60.0 * (vx * vx + vy * vy).sqrt());
        prog.push(r.programmed_feed_mm_s * 60.0);
        power.push(r.spindle_power_w);
        phases.push(r.process);
    }
    log.power_w = Some(power);
    log.programmed_feed_mm_min = Some(prog);
    log.phase = Some(phases);
    let mut turning: Vec<f64> = log
        .spindle_rpm
        .iter()
        .copied()
        .filter(|&s| s > 60.0)
        .collect();
    turning.sort_by(f64::total_cmp);
    let run = turning.get(turning.len() / 2).copied().unwrap_or(0.0);
    let steady = |i: usize| (log.spindle_rpm[i] - run).abs() <= 0.02 * run;
    let n = log.len();
    let keep: Vec<usize> = (1..n.saturating_sub(1))
        .filter(|&i| steady(i - 1) && steady(i) && steady(i + 1))
        .collect();
    let mut log = log.rows(&keep);
    // Cutting needs the tool moving as well as a cutting phase.
    for i in 0..log.len() {
        if log.feed_mm_min[i] <= 0.0 {
            log.radial_depth_mm[i] = 0.0;
            log.axial_depth_mm[i] = 0.0;
        }
    }
    log.validate(path)?;
    Ok(log)
}

/// A constant-`Ks` turning model for one tool's log, calibrated on its first
/// `early_fraction` of rows: force channel, `F = Ks·f/n` (α = 1 on the placeholder depth,
/// β = 1, γ = −1: force proportional to the feed per revolution, as in turning), no wear.
pub fn turning_model(log: &RunLog, early_fraction: f64) -> Model {
    let n_early = ((log.len() as f64 * early_fraction).round() as usize).clamp(1, log.len());
    let med = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let feed_ref = med(&log.feed_mm_min);
    let rpm_ref = med(&log.spindle_rpm);
    let force = log.force_n.as_deref().unwrap_or(&[]);
    let calib = (0..n_early.min(force.len()))
        .map(|i| force[i] * (feed_ref / log.feed_mm_min[i]) * (log.spindle_rpm[i] / rpm_ref))
        .sum::<f64>()
        / n_early.min(force.len()).max(1) as f64;
    let mut m = recorded_feed_model(
        "turning, constant Ks (calibrated on the early part)",
        "Vicomtech/Mondragon lathe",
        Channel::Force,
        Spindle::new(rpm_ref.max(1.0), 0.0, 1.0),
    );
    m.tool.name = "turning insert".into();
    m.tool.diameter_mm = 1.0;
    m.tool.flutes = 1;
    m.tool.process = Process {
        calib_force_n: calib.max(1e-3),
        calib_radial_mm: 1.0,
        calib_feed_mm_min: feed_ref,
        calib_rpm: rpm_ref,
        calib_axial_mm: 1.0,
        alpha: 1.0,
        beta: 1.0,
        gamma: -1.0,
        radial_ratio: 0.0,
    };
    m
}

/// A model for a real log with the feed as recorded (no override path), unit placeholder
/// depths and no wear; the caller sets the tool.
fn recorded_feed_model(name: &str, machine: &str, channel: Channel, spindle: Spindle) -> Model {
    Model {
        name: name.into(),
        measurement: Measurement {
            channel,
            feed_input: FeedInput::Recorded,
            force_window_s: 0.0,
            ..Default::default()
        },
        machine: Machine {
            name: machine.into(),
            spindle,
            feed_drive: FeedDrive {
                tau_s: 0.0,
                tau2_s: 0.0,
                accel_mm_s2: 0.0,
                rapid_mm_min: 10_000.0,
            },
            override_path: OverridePath {
                delay_s: 0.0,
                step_pct: 1,
                nc_max_pct: None,
            },
            sim: Default::default(),
            travel: None,
        },
        tool: Tool {
            name: String::new(),
            diameter_mm: 1.0,
            flutes: 1,
            process: Process {
                calib_force_n: 1.0,
                calib_radial_mm: 1.0,
                calib_feed_mm_min: 1.0,
                calib_rpm: 1.0,
                calib_axial_mm: 1.0,
                alpha: 1.0,
                beta: 1.0,
                gamma: 0.0,
                radial_ratio: 0.0,
            },
            wear: Wear::default(),
            tooth: Default::default(),
            runout: None,
        },
        effects: Default::default(),
    }
}

/// A nominal model for the UMich wax logs: power channel, no-load power from the median
/// of the air rows, a nominal (small) wax cutting force on the placeholder depth, feed as
/// recorded.
pub fn umich_model(log: &RunLog) -> Model {
    let power = log.power_w.as_deref().unwrap_or(&[]);
    let mut air: Vec<f64> = (0..log.len())
        .filter(|&i| log.radial_depth_mm[i] <= 0.0 && log.spindle_rpm[i] > 100.0)
        .filter_map(|i| power.get(i).copied())
        .collect();
    air.sort_by(f64::total_cmp);
    let p_air = air.get(air.len() / 2).copied().unwrap_or(0.0);
    let mut m = recorded_feed_model(
        "UMich wax mill, nominal",
        "UMich SMART lab mill",
        Channel::Power,
        Spindle::new(3200.0, p_air.max(0.0), 1.0),
    );
    m.tool.name = "end mill (wax)".into();
    m.tool.diameter_mm = 6.35;
    m.tool.flutes = 2;
    m.tool.process.calib_force_n = 5.0;
    m.tool.process.calib_feed_mm_min = 360.0;
    m.tool.process.calib_rpm = 3200.0;
    m
}

/// Run-log records (as `acc sim` writes them) as a [`RunLog`], in memory (see
/// [`crate::runlog::from_records`]; the records must carry the simulator's engagement).
pub fn from_sim_rows(
    rows: &[acc_runtime::RunRecord],
) -> Result<RunLog, crate::runlog::RunLogError> {
    crate::runlog::from_records(rows, std::path::Path::new("(simulator run)"))
}

/// A model built from the simulator's machine and tool files (`channel` compared).
pub fn model_from_sim(
    machine: &acc_sim::config::MachineSpec,
    tool: &acc_sim::config::ToolSpec,
    channel: Channel,
) -> Model {
    Model {
        name: format!("{} + {}", machine.name, tool.name),
        measurement: Measurement {
            channel,
            feed_input: FeedInput::Auto,
            force_window_s: 0.0,
            ..Default::default()
        },
        machine: machine.clone(),
        tool: tool.clone(),
        effects: Default::default(),
    }
}
