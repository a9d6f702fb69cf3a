//! The plant's feed path under a model: the simulator's trace
//! ([`acc_sim::replay::trace`]: override path, feed drive, engagement and force law, at
//! unit force) kept per [`Inputs`], so that every model that drives the plant alike —
//! every load, loss, sensor and wear candidate — shares one trace.
//!
//! The candidates that move the path (override dead time, feed-drive lag, second lag,
//! depth exponent) are fitted by Levenberg–Marquardt: each iterate, Jacobian column and
//! cross-validation fold moves them by a little, and each would otherwise be a new trace
//! of the whole log (a 10-minute log: about 80 ms each, several hundred per analysis).
//! The nodes one model needs and the cache lacks are traced on the machine's threads at
//! once (a bilinear blend of the two lags needs four). Two rules keep the number of traces
//! to the points that differ:
//! - the dead time is taken in whole internal steps of the plant, as its delay line holds
//!   it (`Machine::new` rounds `delay_s·rate`): a delay of the same step count is the
//!   same trace;
//! - the lags and the depth exponent are traced on nodes counted from the model's own
//!   value (so the model without the candidate is traced exactly): the lags' nodes
//!   [`LAG_NODE_S`] apart at a lag of 0 and [`LAG_NODE_SHARE`] of the lag apart above it,
//!   the exponent's [`ALPHA_NODE`] apart. A value between nodes gets the linear
//!   interpolation of its neighbours' traces (multilinear when several are between
//!   nodes). The interpolation error is second order in the spacing: measured on paper
//!   case III (test `an_interpolated_path_is_the_traced_path`), 2.6e−5 of the largest
//!   force at an extra lag of 5.3 ms, 3.6e−6 at a second lag of 4.7 ms and 5.8e−6 at
//!   Δα = 0.104 — a two-hundredth or less of what the candidate itself moves, and far
//!   below a force noise of about 1e−2 of the level.

use std::rc::Rc;

use acc_sim::replay::PeriodTrace;

use super::{channel_window_s, FeedSource, Inputs, PlantInputs};
use crate::effects::EffectKind;
use crate::model::{Channel, Model};

/// Spacing of the traced nodes of the feed drive's lags (first and second) at a lag of
/// 0, s: half an internal step of the plant at 1 kHz.
const LAG_NODE_S: f64 = 5e-4;

/// Growth of the lags' node spacing with the lag, − (the spacing is 5 % of the lag plus
/// [`LAG_NODE_S`]).
const LAG_NODE_SHARE: f64 = 0.05;

/// Spacing of the traced nodes of the inverse acceleration `1000/a` at 0, s²/m.
const ACCEL_NODE: f64 = 0.25;

/// Spacing of the traced nodes of the depth exponent `α`, −.
const ALPHA_NODE: f64 = 0.01;

/// What does not change while only loads, losses and the sensor are fitted: the plant's
/// feed path and its force per unit calibration force (`Ks·a_p·d^α·f^β·s^γ /
/// calib_force_n`).
#[derive(Debug, Clone, PartialEq)]
struct PathKey {
    delay_s: f64,
    tau_s: f64,
    /// Second lag of the feed drive, s (0: first-order drive).
    tau2_s: f64,
    /// Inverse acceleration limit `1000/a` of the feed, s²/m (0: none).
    inv_accel_s2_per_m: f64,
    window_s: f64,
    process: [f64; 8],
}

/// The simulator's plant trace of one [`PathKey`].
#[derive(Debug)]
pub(super) struct PathCache {
    key: PathKey,
    plant: Rc<Vec<PeriodTrace>>,
}

/// What a plant trace reads of the [`Inputs`]: plain data, so that the traces of one
/// model's nodes can run on several threads (the `Inputs` keep their caches in cells).
#[derive(Debug, Clone, Copy)]
struct TraceFrom<'a> {
    plant: &'a PlantInputs,
    /// Period ending at each row, s.
    dt_s: &'a [f64],
    /// Median period, s.
    period_s: f64,
    /// [`Inputs::board_sample`], when it covers every row.
    board_sample: Option<&'a [usize]>,
    /// The channel reads the motor's power: the compared power, or the power a
    /// spindle-power force estimator reads.
    power_read: bool,
    /// The runout basis of the inputs' drive, shared by their traces.
    runout_basis: &'a acc_sim::replay::RunoutBasis,
}

impl<'a> TraceFrom<'a> {
    fn new(inp: &'a Inputs) -> Self {
        TraceFrom {
            plant: &inp.plant,
            dt_s: &inp.dt_s,
            period_s: inp.period_s,
            board_sample: inp.board_sample.as_deref().filter(|s| s.len() == inp.len()),
            power_read: inp.channel == Channel::Power || inp.estimator_no_load.is_some(),
            runout_basis: &inp.runout_basis,
        }
    }
}

/// Replay the simulator's plant for the path key (see [`acc_sim::replay::trace`]).
fn plant_trace(model: &Model, from: TraceFrom<'_>, key: &PathKey) -> Vec<PeriodTrace> {
    let plant = from.plant;
    let mut machine = model.machine.clone();
    // The recorded feed is the feed: no override path, no drive lag.
    let instant = plant.source == FeedSource::Recorded;
    machine.override_path.delay_s = if instant { 0.0 } else { key.delay_s };
    machine.feed_drive.tau_s = if instant { 0.0 } else { key.tau_s };
    machine.feed_drive.tau2_s = if instant { 0.0 } else { key.tau2_s };
    machine.feed_drive.accel_mm_s2 = if instant || key.inv_accel_s2_per_m <= 0.0 {
        0.0
    } else {
        1000.0 / key.inv_accel_s2_per_m
    };
    // The process constants of the key (the depth-exponent candidate changes α).
    let mut tool = model.tool.clone();
    tool.process.alpha = key.process[4];
    // The motor channel: the power, or the power a spindle-power force estimator reads.
    let motor = match (from.power_read, model.measurement.spindle_motor) {
        (true, Some(m)) => m.config().ok(),
        _ => None,
    };
    let channel = acc_sim::replay::ReplayChannel {
        window_s: key.window_s,
        torque_lag_s: motor.as_ref().map_or(0.0, |c| c.drive.torque_lag_s),
        daq_rate_hz: motor.as_ref().map_or(0.0, |c| c.sensors.sample_rate_hz),
    };
    let run = |engagement: &acc_sim::replay::ReplayEngagement,
               drive: &acc_sim::replay::ReplayDrive<'_>| {
        acc_sim::replay::trace(
            &machine,
            &tool,
            model.measurement.force_model.sim(),
            engagement,
            drive,
            &channel,
            from.runout_basis,
        )
    };
    let settled = plant.source == FeedSource::Command;
    let Some(sample) = from.board_sample else {
        return run(
            &plant.engagement,
            &acc_sim::replay::ReplayDrive {
                period_s: from.dt_s,
                override_applied_pct: &plant.override_applied_pct,
                programmed_feed_mm_min: &plant.programmed_feed_mm_min,
                feed_hold: None,
                spindle_rpm: plant.spindle_rpm.as_deref(),
                settled,
            },
        );
    };
    // On the board's periods (`raced::board_periods`): the override, programmed feed and
    // speed of the row that drove each (or the board's feed's placement of the override,
    // `PlantInputs::board_override_pct`), the engagement of the row that read it or the next.
    let periods = super::raced::board_periods(sample);
    let mut ov = Vec::with_capacity(periods.len());
    let mut prog = Vec::with_capacity(periods.len());
    let mut rpm = Vec::with_capacity(periods.len());
    // A logged engagement is per row: on the board's periods, a period no row read takes
    // the engagement of the row that read the next sample.
    let logged = match &plant.engagement {
        acc_sim::replay::ReplayEngagement::Logged(e) => Some(e),
        acc_sim::replay::ReplayEngagement::Workpiece { .. } => None,
    };
    let mut eng = Vec::with_capacity(if logged.is_some() { periods.len() } else { 0 });
    for (s, &(from, row)) in periods.iter().enumerate() {
        ov.push(
            plant
                .board_override_pct
                .as_ref()
                .map_or(plant.override_applied_pct[from], |o| o[s]),
        );
        prog.push(plant.programmed_feed_mm_min[from]);
        if let Some(r) = &plant.spindle_rpm {
            rpm.push(r[from]);
        }
        if let Some(e) = logged {
            eng.push(e[row]);
        }
    }
    let engagement = match logged {
        Some(_) => acc_sim::replay::ReplayEngagement::Logged(eng),
        None => plant.engagement.clone(),
    };
    let grid = run(
        &engagement,
        &acc_sim::replay::ReplayDrive {
            period_s: &vec![from.period_s; periods.len()],
            override_applied_pct: &ov,
            programmed_feed_mm_min: &prog,
            feed_hold: None,
            spindle_rpm: plant.spindle_rpm.as_ref().map(|_| rpm.as_slice()),
            settled,
        },
    );
    sample.iter().map(|&s| grid[s]).collect()
}

/// Paths kept per [`Inputs`], at least: a fit's grid over the delays and time constants
/// of the drive candidates alone tries more than twenty.
const PATH_CACHE: usize = 24;

/// Rows of plant trace kept per [`Inputs`] (about 110 bytes a row): more paths than
/// [`PATH_CACHE`] on a log shorter than this over [`PATH_CACHE`] rows. A 10-minute log
/// (6 000 rows) keeps 250 paths, 165 MB: its analysis traces about 110 nodes on one
/// channel of a simulator log, and about 390 on a LinuxCNC log whose drive candidates
/// wander to lags of tenths of a second; with 250 kept, the nodes traced again after
/// being dropped are 3 % of the traces there (with 166 kept, 36 %).
const PATH_CACHE_ROWS: usize = 1_500_000;

/// Keep `c`, dropping the path used longest ago when the cache is full.
fn remember(inp: &Inputs, c: Rc<PathCache>) {
    let keep = PATH_CACHE.max(PATH_CACHE_ROWS / inp.len().max(1));
    let mut v = inp.cache.borrow_mut();
    if v.len() >= keep {
        v.remove(0);
    }
    v.push(c);
}

/// The threads the traces of one model run on: `ACC_TRACE_THREADS` when it is a number
/// ≥ 1 (the test suite sets 1 where an analysis runs beside a wall-paced closed loop),
/// else as many as the machine has. The traces are the same on any number.
fn trace_threads() -> usize {
    std::env::var("ACC_TRACE_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n >= 1)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// The traces of `keys`, from the cache or traced now. Keys the cache lacks are traced
/// on [`trace_threads`] threads (each trace is the same pure function of its key
/// on any thread), then kept in the order of `keys`.
fn traced(model: &Model, inp: &Inputs, keys: &[PathKey]) -> Vec<Rc<Vec<PeriodTrace>>> {
    let cached = |key: &PathKey| {
        let mut v = inp.cache.borrow_mut();
        let k = v.iter().position(|c| c.key == *key)?;
        // Most recently used last.
        let c = v.remove(k);
        let plant = c.plant.clone();
        v.push(c);
        Some(plant)
    };
    let mut out: Vec<Option<Rc<Vec<PeriodTrace>>>> = keys.iter().map(cached).collect();
    let mut missing: Vec<&PathKey> = Vec::new();
    for (key, o) in keys.iter().zip(&out) {
        if o.is_none() && !missing.contains(&key) {
            missing.push(key);
        }
    }
    let from = TraceFrom::new(inp);
    let threads = trace_threads();
    let fresh: Vec<Vec<PeriodTrace>> = if missing.len() < 2 || threads < 2 {
        missing
            .iter()
            .map(|k| plant_trace(model, from, k))
            .collect()
    } else {
        let per = missing.len().div_ceil(threads);
        std::thread::scope(|scope| {
            let jobs: Vec<_> = missing
                .chunks(per)
                .map(|chunk| {
                    scope.spawn(move || {
                        chunk
                            .iter()
                            .map(|k| plant_trace(model, from, k))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            jobs.into_iter()
                .flat_map(|j| j.join().expect("a plant trace panicked"))
                .collect()
        })
    };
    for (key, plant) in missing.into_iter().zip(fresh) {
        let plant = Rc::new(plant);
        for (k, o) in keys.iter().zip(out.iter_mut()) {
            if k == key {
                *o = Some(plant.clone());
            }
        }
        remember(
            inp,
            Rc::new(PathCache {
                key: key.clone(),
                plant,
            }),
        );
    }
    out.into_iter()
        .map(|o| o.expect("every key cached or traced"))
        .collect()
}

/// The traced values around `base + offset` on the nodes `node(j)`, `j` ≠ 0 (`node(0)` is
/// `base` itself, the model's own value, traced exactly; `node` increasing), with their
/// linear interpolation weights: one node with weight 1 when the value lies on one (`base`
/// when `offset` is 0), else its two neighbours. `index` is the inverse of `node` (the
/// continuous node index of a value).
fn between(
    base: f64,
    offset: f64,
    node: impl Fn(f64) -> f64,
    index: impl Fn(f64) -> f64,
) -> Vec<(f64, f64)> {
    if offset == 0.0 {
        return vec![(base, 1.0)];
    }
    let value = base + offset;
    let at = |j: f64| if j == 0.0 { base } else { node(j) };
    let t = index(value);
    let j = t.round();
    if (t - j).abs() < 1e-9 {
        return vec![(at(j), 1.0)];
    }
    let j = t.floor();
    let (a, b) = (at(j), at(j + 1.0));
    let w = ((value - a) / (b - a)).clamp(0.0, 1.0);
    vec![(a, 1.0 - w), (b, w)]
}

/// The nodes of a feed-drive lag around `base + offset` (`offset` ≥ 0), s: spaced
/// [`LAG_NODE_S`] apart at a lag of 0 and widening in proportion to the lag
/// ([`LAG_NODE_SHARE`]): `τⱼ = (base + c)·(1 + r)ʲ − c` with `c = LAG_NODE_S / r`, so
/// that the spacing is `r·(τ + c)`. The interpolation error is second order in the
/// spacing relative to the lag, so it stays alike over the range.
fn lag_nodes(base: f64, offset: f64) -> Vec<(f64, f64)> {
    let r = LAG_NODE_SHARE;
    let c = LAG_NODE_S / r;
    let growth = (1.0 + r).ln();
    between(
        base,
        offset,
        |j| (base + c) * (j * growth).exp() - c,
        |v| ((v + c) / (base + c)).ln() / growth,
    )
}

/// The nodes of the inverse acceleration around `base + offset` (`offset` ≥ 0), s²/m: as
/// [`lag_nodes`], [`ACCEL_NODE`] apart at 0 and widening by [`LAG_NODE_SHARE`].
fn accel_nodes(base: f64, offset: f64) -> Vec<(f64, f64)> {
    let r = LAG_NODE_SHARE;
    let c = ACCEL_NODE / r;
    let growth = (1.0 + r).ln();
    between(
        base,
        offset,
        |j| (base + c) * (j * growth).exp() - c,
        |v| ((v + c) / (base + c)).ln() / growth,
    )
}

/// The machine's own inverse acceleration `1000/a`, s²/m (0 without a limit).
pub(crate) fn machine_inv_accel(model: &Model) -> f64 {
    let a = model.machine.feed_drive.accel_mm_s2;
    if a > 0.0 {
        1000.0 / a
    } else {
        0.0
    }
}

/// The nodes of the depth exponent around `base + offset`, [`ALPHA_NODE`] apart from
/// `base`.
fn exponent_nodes(base: f64, offset: f64) -> Vec<(f64, f64)> {
    between(
        base,
        offset,
        |j| base + j * ALPHA_NODE,
        |v| (v - base) / ALPHA_NODE,
    )
}

/// `Σ wₖ·traceₖ` row by row (weights summing to 1).
fn blend(parts: &[(Rc<Vec<PeriodTrace>>, f64)]) -> Vec<PeriodTrace> {
    let n = parts.first().map_or(0, |p| p.0.len());
    (0..n)
        .map(|i| {
            let mut o = PeriodTrace {
                feed_mean_mm_min: 0.0,
                feed_window_mm_min: 0.0,
                unit_force_mean: 0.0,
                unit_force_window: 0.0,
                runout_mean: [0.0; 2],
                runout_window: [0.0; 2],
                unit_torque_window: 0.0,
                unit_torque_sq_window: 0.0,
                volume_mm3: 0.0,
                radial_depth_mm: 0.0,
                x_mm: 0.0,
            };
            for (tr, w) in parts {
                let t = &tr[i];
                o.feed_mean_mm_min += w * t.feed_mean_mm_min;
                o.feed_window_mm_min += w * t.feed_window_mm_min;
                o.unit_force_mean += w * t.unit_force_mean;
                o.unit_force_window += w * t.unit_force_window;
                for k in 0..2 {
                    o.runout_mean[k] += w * t.runout_mean[k];
                    o.runout_window[k] += w * t.runout_window[k];
                }
                o.unit_torque_window += w * t.unit_torque_window;
                o.unit_torque_sq_window += w * t.unit_torque_sq_window;
                o.volume_mm3 += w * t.volume_mm3;
                o.radial_depth_mm += w * t.radial_depth_mm;
                o.x_mm += w * t.x_mm;
            }
            o
        })
        .collect()
}

/// The plant's trace under `model` on `inp` (see the module's documentation for the
/// nodes and the interpolation between them).
pub(super) fn path(model: &Model, inp: &Inputs) -> Rc<Vec<PeriodTrace>> {
    let fx = &model.effects;
    let p = &model.tool.process;
    let machine = &model.machine;
    let rate_hz = acc_sim::Machine::rate_hz(machine, model.measurement.force_model.sim());
    // The delay line holds whole internal steps.
    let base_delay = machine.override_path.delay_s;
    let steps = ((base_delay + fx.get(EffectKind::OverrideDeadTime, 0).max(0.0)) * rate_hz).round();
    let delay_s = if steps == (base_delay * rate_hz).round() {
        base_delay
    } else {
        steps / rate_hz
    };
    let window_s = channel_window_s(model, inp);
    let key = |tau_s: f64, tau2_s: f64, alpha: f64, inv_accel_s2_per_m: f64| PathKey {
        delay_s,
        tau_s,
        tau2_s,
        inv_accel_s2_per_m,
        window_s,
        process: [
            p.calib_radial_mm,
            p.calib_feed_mm_min,
            p.calib_rpm,
            p.calib_axial_mm,
            alpha,
            p.beta,
            p.gamma,
            p.radial_ratio,
        ],
    };
    let lag = lag_nodes(
        machine.feed_drive.tau_s,
        fx.get(EffectKind::FeedDriveLag, 0).max(0.0),
    );
    let lag2 = lag_nodes(
        machine.feed_drive.tau2_s,
        fx.get(EffectKind::SecondOrderDrive, 0).max(0.0),
    );
    let alpha = exponent_nodes(p.alpha, fx.get(EffectKind::DepthExponent, 0));
    let accel = accel_nodes(
        machine_inv_accel(model),
        fx.get(EffectKind::FeedAccelLimit, 0).max(0.0),
    );
    let mut keys = Vec::with_capacity(16);
    let mut weights = Vec::with_capacity(16);
    for &(a, wa) in &lag {
        for &(b, wb) in &lag2 {
            for &(c, wc) in &alpha {
                for &(d, wd) in &accel {
                    keys.push(key(a, b, c, d));
                    weights.push(wa * wb * wc * wd);
                }
            }
        }
    }
    let parts: Vec<_> = traced(model, inp, &keys).into_iter().zip(weights).collect();
    match parts.as_slice() {
        [(one, _)] => one.clone(),
        _ => Rc::new(blend(&parts)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Paper case III with the dynamometer, its model and the log's inputs.
    fn case3() -> (Model, Inputs) {
        let cfg = acc_sim::run::configs_dir();
        let sc = acc_sim::Scenario::load(cfg.join("scenarios/paper_case3_dynamometer.toml"))
            .expect("scenario");
        let mut law = sc.build_law(acc_sim::LawKind::Ours).expect("law");
        let res = acc_sim::run(&sc, law.as_mut(), acc_sim::RunSetup::default()).expect("run");
        let log =
            crate::runlog::from_records(&res.rows, std::path::Path::new("p.csv")).expect("log");
        let model = Model::load(&cfg.join("models/paper_vmc.toml")).expect("model");
        let inp = Inputs::from_log(&log, &model).expect("inputs");
        (model, inp)
    }

    /// The exact trace of `model` (no nodes, no cache).
    fn exact(model: &Model, inp: &Inputs) -> Vec<PeriodTrace> {
        let fx = &model.effects;
        let p = &model.tool.process;
        let key = PathKey {
            delay_s: model.machine.override_path.delay_s + fx.get(EffectKind::OverrideDeadTime, 0),
            tau_s: model.machine.feed_drive.tau_s + fx.get(EffectKind::FeedDriveLag, 0),
            tau2_s: model.machine.feed_drive.tau2_s + fx.get(EffectKind::SecondOrderDrive, 0),
            inv_accel_s2_per_m: machine_inv_accel(model) + fx.get(EffectKind::FeedAccelLimit, 0),
            window_s: channel_window_s(model, inp),
            process: [
                p.calib_radial_mm,
                p.calib_feed_mm_min,
                p.calib_rpm,
                p.calib_axial_mm,
                p.alpha + fx.get(EffectKind::DepthExponent, 0),
                p.beta,
                p.gamma,
                p.radial_ratio,
            ],
        };
        plant_trace(model, TraceFrom::new(inp), &key)
    }

    /// Largest difference of the window's unit force, over the largest unit force.
    fn worst(a: &[PeriodTrace], b: &[PeriodTrace]) -> f64 {
        let top = b.iter().map(|t| t.unit_force_window).fold(0.0, f64::max);
        let d = a
            .iter()
            .zip(b)
            .map(|(a, b)| (a.unit_force_window - b.unit_force_window).abs())
            .fold(0.0, f64::max);
        d / top
    }

    /// Between nodes the interpolated path is the traced one to within 1e−4 of the force
    /// level and a fiftieth of what the candidate moves; on a node and without the candidates it is the trace itself; a dead time
    /// of the same whole step count is the same trace.
    #[test]
    fn an_interpolated_path_is_the_traced_path() {
        let (model, inp) = case3();
        assert_eq!(*path(&model, &inp), exact(&model, &inp), "nominal: exact");
        for (kind, value) in [
            (EffectKind::FeedDriveLag, 0.0053),
            (EffectKind::SecondOrderDrive, 0.0047),
            (EffectKind::DepthExponent, 0.1037),
            (EffectKind::FeedAccelLimit, 3.37),
        ] {
            let mut m = model.clone();
            m.effects.set(kind, 0, value);
            let between = path(&m, &inp);
            let e = worst(&between, &exact(&m, &inp));
            assert!(e < 1e-4, "{kind:?} {value}: {e:.2e} of the force level");
            // The candidate moves the path far more than the interpolation's error.
            let moved = worst(&exact(&model, &inp), &exact(&m, &inp));
            assert!(
                moved > 50.0 * e,
                "{kind:?}: moved {moved:.2e}, error {e:.2e}"
            );
        }
        // Two candidates between nodes at once: the corners' multilinear blend.
        let mut both = model.clone();
        both.effects.set(EffectKind::FeedDriveLag, 0, 0.0121);
        both.effects.set(EffectKind::DepthExponent, 0, -0.0456);
        assert!(worst(&path(&both, &inp), &exact(&both, &inp)) < 1e-4);
        // A dead time of 0.4 ms rounds to no step on a 1 kHz plant: the nominal trace.
        let mut dead = model.clone();
        dead.effects.set(EffectKind::OverrideDeadTime, 0, 0.0004);
        assert_eq!(*path(&dead, &inp), exact(&model, &inp));
    }

    /// The nodes: one on a node, the two neighbours between them with weights that
    /// reproduce the value; a lag's spacing widens with the lag.
    #[test]
    fn the_nodes_bracket_the_value() {
        assert_eq!(lag_nodes(0.008, 0.0), vec![(0.008, 1.0)]);
        for (base, offset) in [(0.008, 0.0031), (0.0, 0.0007), (0.0, 0.2), (0.05, 0.7)] {
            let n = lag_nodes(base, offset);
            assert_eq!(n.len(), 2, "{base} {offset}");
            let v: f64 = n.iter().map(|(x, w)| x * w).sum();
            assert!((v - (base + offset)).abs() < 1e-12, "{n:?}");
            assert!(n[0].0 <= base + offset && base + offset <= n[1].0);
            let spacing = n[1].0 - n[0].0;
            let expected = LAG_NODE_SHARE * (base + offset) + LAG_NODE_S;
            assert!(
                (spacing / expected - 1.0).abs() < 0.1,
                "{spacing} vs {expected}"
            );
        }
        let n = exponent_nodes(1.0, -0.0456);
        let v: f64 = n.iter().map(|(x, w)| x * w).sum();
        assert!((v - 0.9544).abs() < 1e-12 && n.len() == 2);
        assert!((n[1].0 - n[0].0 - ALPHA_NODE).abs() < 1e-12);
    }
}
