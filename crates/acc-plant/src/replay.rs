//! The simulated plant replayed on the inputs a run log recorded (for the discrepancy
//! workflow, `acc-ident`): the same [`Machine`] the simulator steps — override path delay
//! line, first-order feed drive, engagement from the workpiece (or as logged), the force
//! law with the tooth model when selected — driven period by period with the override the
//! board applied (`override_applied_pct`), the programmed feed and the feed hold of each
//! logged row. Nothing is fed back: the replay is open loop on the logged commands.
//!
//! The trace is taken at **unit force scale** (`calib_force_n = 1`, no wear, no runout), so
//! a caller fitting `Ks`, wear and runout rescales it without re-running the plant: per
//! period it holds the means over the period and over the measurement window of the unit
//! force, the runout basis (`1 + A·cos(θ + φ)` is linear in `A·cos φ`, `A·sin φ`), and the
//! unit torque after the spindle drive's torque lag as the induction-motor channel
//! (`crate::motor::MotorSim::run_period_tail`) sees it, with its mean square (the motor's
//! input power is nonlinear in torque).

use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use acc_core::filter::FirstOrderLag;

use crate::config::{MachineSpec, ToolSpec};
use crate::engagement::{Engagement, EngagementSource, Held, Ramp};
use crate::machine::{ForceModel, Machine, SpindleModel};
use crate::process::WearSpec;
use crate::workpiece::{Segment, SegmentKind, Workpiece};

/// Where the replayed engagement comes from.
#[derive(Debug, Clone)]
pub enum ReplayEngagement {
    /// The workpiece the log was cut on; the tool centre starts at `x0_mm` and moves with
    /// the replayed feed (exactly as in the simulator).
    Workpiece {
        /// The workpiece.
        workpiece: Workpiece,
        /// Tool-centre position when the log began, mm.
        x0_mm: f64,
    },
    /// The engagement logged per row, sampled at the end of the row's period: over the
    /// period the chord from the row before's sample to this row's
    /// ([`crate::engagement::Ramp`]), held where the two agree. The tooth model needs the
    /// workpiece geometry, so this mode integrates the mean force model.
    Logged(Vec<Engagement>),
}

/// The logged commands that drive the replay, one entry per row.
///
/// A log that records only the feed the machine made (no override, no programmed feed) is
/// replayed with that feed as the programmed feed at 100 %, on a machine whose override
/// path and feed drive are instantaneous (`delay_s = tau_s = tau2_s = 0`): the feed is then
/// the logged one, held over each row's period.
#[derive(Debug, Clone, Copy)]
pub struct ReplayDrive<'a> {
    /// Length of the period ending at each row, s.
    pub period_s: &'a [f64],
    /// Override on the PMC inputs during the row's period, percent.
    pub override_applied_pct: &'a [f64],
    /// Programmed feed, mm/min.
    pub programmed_feed_mm_min: &'a [f64],
    /// Feed hold in force during the row's period (`None`: never).
    pub feed_hold: Option<&'a [bool]>,
    /// Spindle speed during the row's period, rpm (`None`: the machine's spindle,
    /// `spindle.rpm`). The force law's speed term and the spindle angle follow it.
    pub spindle_rpm: Option<&'a [f64]>,
    /// `true`: before the first row the override path and the feed drive have settled on
    /// the first row's inputs (a log cut from the middle of a run); `false`: the machine
    /// starts at rest, as the simulator does.
    pub settled: bool,
}

/// The logged spindle speed, rpm, shared between the replay and its spindle model (the
/// machine owns the model; the replay sets the speed row by row).
#[derive(Debug, Clone)]
struct SharedRpm(Arc<AtomicU64>);

impl SharedRpm {
    fn new(rpm: f64) -> Self {
        Self(Arc::new(AtomicU64::new(rpm.to_bits())))
    }
    fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }
    fn set(&self, rpm: f64) {
        self.0.store(rpm.to_bits(), Ordering::Relaxed);
    }
}

/// The replay's spindle: it turns at the speed the log recorded (set per row by
/// [`trace`]) or at the machine's, and has no input power — the trace reads the force
/// and the torque of each sample (the motor channel is the caller's, from the unit
/// torque), so the spindle law's power is not computed at every internal step.
struct ReplaySpindle {
    rpm: SharedRpm,
}

impl SpindleModel for ReplaySpindle {
    fn step(&mut self, _load_torque_nm: f64, _dt_s: f64) -> f64 {
        self.rpm.get()
    }

    fn input_power_w(&self) -> f64 {
        0.0
    }

    fn speed_rpm(&self) -> f64 {
        self.rpm.get()
    }
}

/// The time the override path and the feed drive of `machine` need to settle on a constant
/// input of `feed_mm_min` (mm/min) to within e⁻³⁰ (≈ 1e−13) of it, s: the delay, the
/// acceleration limit's ramp and 30 time constants.
fn settling_time_s(machine: &MachineSpec, feed_mm_min: f64) -> f64 {
    machine.override_path.delay_s
        + crate::accel::AccelLimit::new(machine.feed_drive.accel_mm_s2).ramp_time_s(feed_mm_min)
        + 30.0 * (machine.feed_drive.tau_s + machine.feed_drive.tau2_s)
}

/// How the measurement channel looks at each period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReplayChannel {
    /// Averaging window at the end of each period, s (0 = the whole period).
    pub window_s: f64,
    /// Torque lag of the spindle drive before the motor's power, s (0 = none: a
    /// constant-speed spindle or a force channel).
    pub torque_lag_s: f64,
    /// DAQ sample rate of the motor channel, Hz (0 = the machine's internal rate).
    pub daq_rate_hz: f64,
}

/// One replayed period at unit force scale.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PeriodTrace {
    /// Mean feed over the period, mm/min.
    pub feed_mean_mm_min: f64,
    /// Mean feed over the window, mm/min.
    pub feed_window_mm_min: f64,
    /// Mean unit force over the period (force per newton of `calib_force_n`), −.
    pub unit_force_mean: f64,
    /// Mean unit force over the window, −.
    pub unit_force_window: f64,
    /// Runout basis over the period: means of unit force × `(sin θ₁ − sin θ₀)/Δθ` and ×
    /// `(cos θ₁ − cos θ₀)/Δθ` per internal step (the runout factor's step mean is
    /// `1 + A·(cos φ·c + sin φ·s)`).
    pub runout_mean: [f64; 2],
    /// The runout basis over the window.
    pub runout_window: [f64; 2],
    /// Mean over the window of the unit torque after the drive's torque lag, N·m per N.
    pub unit_torque_window: f64,
    /// Mean square of the same, (N·m per N)².
    pub unit_torque_sq_window: f64,
    /// Removed volume since the replay began (unit independent), mm³.
    pub volume_mm3: f64,
    /// Radial depth at the end of the period, mm.
    pub radial_depth_mm: f64,
    /// Tool-centre position at the end of the period, mm.
    pub x_mm: f64,
}

/// The runout basis of every internal sample of a replay (see [`PeriodTrace::runout_mean`]),
/// shared by the traces of one drive: it depends only on the periods and the spindle's
/// speeds (the spindle angle turns at the logged or the machine's speed, whatever the
/// override path, the feed drive or the engagement), so the first trace on a drive
/// computes it and the next ones read it instead of a sine and a cosine per sample.
/// Use one per [`ReplayDrive`] (and machine rate): [`trace`] recomputes it where its
/// sample count differs.
#[derive(Debug, Clone, Default)]
pub struct RunoutBasis(std::sync::OnceLock<Vec<[f64; 2]>>);

/// The engagement of logged row `i` over its period, the tool at `x_start_mm`: the chord
/// from the row before's sample to this row's ([`Ramp`]) over `path_mm` (the last
/// period's path: the feed seldom changes much in one period), or this row's held where
/// the two agree, at the first row and when the tool did not move.
fn logged_source(
    rows: &[Engagement],
    i: usize,
    x_start_mm: f64,
    path_mm: f64,
) -> Box<dyn EngagementSource> {
    let clean = |e: Engagement| Engagement {
        radial_mm: e.radial_mm.max(0.0),
        axial_mm: e.axial_mm.max(0.0),
        ks_factor: e.ks_factor,
    };
    let to = clean(rows[i]);
    match i.checked_sub(1).map(|k| clean(rows[k])) {
        Some(from) if from != to && path_mm > 1e-9 => Box::new(Ramp {
            from,
            to,
            x_start_mm,
            length_mm: path_mm,
        }),
        _ => Box::new(Held(to)),
    }
}

/// Replay the plant of `machine` + `tool` (force model `force_model`) on `drive` with the
/// engagement `engagement`, seen through `channel`. One [`PeriodTrace`] per row. The
/// runout basis is read from `basis` when an earlier trace on the same drive left it
/// there, else computed and left there.
///
/// The simulator's own [`Machine::advance`] runs every period (same internal rate, delay
/// line, drive lag, engagement and force law); only the unit scale (no `Ks`, wear or
/// runout) and the logged engagement of [`ReplayEngagement::Logged`] differ.
pub fn trace(
    machine: &MachineSpec,
    tool: &ToolSpec,
    force_model: ForceModel,
    engagement: &ReplayEngagement,
    drive: &ReplayDrive<'_>,
    channel: &ReplayChannel,
    basis: &RunoutBasis,
) -> Vec<PeriodTrace> {
    let n = drive.period_s.len();
    let rate_hz = Machine::rate_hz(machine, force_model);
    // The samples `Machine::advance` takes over the drive's periods.
    let samples: usize = drive
        .period_s
        .iter()
        .map(|p| ((p * rate_hz).round() as usize).max(1))
        .sum();
    let known = basis.0.get().filter(|b| b.len() == samples);
    let mut fresh: Vec<[f64; 2]> = Vec::with_capacity(if known.is_some() { 0 } else { samples });
    let mut at_sample = 0usize;
    let mut unit = tool.clone();
    unit.process.calib_force_n = 1.0;
    unit.runout = None;
    let no_wear = WearSpec {
        initial_factor: 1.0,
        growth_per_cm3: 0.0,
        growth_per_min: 0.0,
        ..WearSpec::default()
    };
    let (wp, model, x0, logged) = match engagement {
        ReplayEngagement::Workpiece { workpiece, x0_mm } => {
            (workpiece.clone(), force_model, *x0_mm, None)
        }
        ReplayEngagement::Logged(rows) => {
            let a = rows.iter().map(|e| e.axial_mm).fold(0.0, f64::max).max(1.0);
            let wp = Workpiece {
                name: "logged engagement".into(),
                axial_depth_mm: a,
                segments: vec![Segment {
                    kind: SegmentKind::Cut,
                    start_mm: -1e12,
                    end_mm: 1e12,
                    depth_start_mm: 1.0,
                    depth_end_mm: 1.0,
                    ks_factor: 1.0,
                }],
            };
            (wp, ForceModel::Mean, 0.0, Some(rows))
        }
    };
    let fp0 = drive.programmed_feed_mm_min.first().copied().unwrap_or(0.0);
    let mut m = Machine::new(machine, &unit, no_wear, wp, model, fp0);
    let rpm_in = SharedRpm::new(machine.spindle.rpm);
    if let Some(r) = drive.spindle_rpm {
        rpm_in.set(r.first().copied().unwrap_or(machine.spindle.rpm));
    }
    m.set_spindle(Box::new(ReplaySpindle {
        rpm: rpm_in.clone(),
    }));
    let set_inputs = |m: &mut Machine, i: usize| {
        let ov = drive.override_applied_pct[i];
        m.set_override_input_pct(if ov.is_finite() {
            ov.round().clamp(0.0, f64::from(u16::MAX)) as u16
        } else {
            0
        });
        m.set_programmed_feed_mm_min(drive.programmed_feed_mm_min[i]);
        m.set_feed_hold(drive.feed_hold.is_some_and(|h| h[i]));
        if let Some(r) = drive.spindle_rpm {
            rpm_in.set(r[i].max(0.0));
        }
    };
    if drive.settled && n > 0 {
        // Out of the material, on the first row's inputs, until the delay line and the
        // drive hold them.
        set_inputs(&mut m, 0);
        m.set_engagement_source(Some(Box::new(Held(Engagement::air(0.0)))));
        let p = drive.period_s[0].max(1e-3);
        let feed = drive.programmed_feed_mm_min[0] * drive.override_applied_pct[0] / 100.0;
        for _ in 0..(settling_time_s(machine, feed) / p).ceil() as usize {
            m.advance(p);
        }
        m.set_engagement_source(None);
    }
    m.set_position_mm(x0);
    let lag = FirstOrderLag::new(channel.torque_lag_s);
    let mut lagged = 0.0;
    let mut theta = 0.0f64;
    // The last sample's end angle with its sine and cosine.
    let mut end_sc: Option<(f64, f64, f64)> = None;
    let mut out = Vec::with_capacity(n);
    // The path of the last replayed period, mm: the length of the next one's ramp.
    let mut last_path_mm = 0.0;
    for i in 0..n {
        let dt_row = drive.period_s[i];
        set_inputs(&mut m, i);
        let x_start_mm = m.x_mm();
        if let Some(rows) = logged {
            m.set_engagement_source(Some(logged_source(rows, i, x_start_mm, last_path_mm)));
        }
        let rpm = m.spindle_rpm();
        let rec = m.advance(dt_row);
        last_path_mm = rec.x_mm - x_start_mm;
        let ns = rec.samples.len();
        let dt = rec.sample_dt_s;
        // The force channel's window: the last k internal samples.
        let k = if channel.window_s <= 0.0 {
            ns
        } else {
            ((channel.window_s / dt).round() as usize).clamp(1, ns.max(1))
        };
        let mut tr = PeriodTrace {
            feed_mean_mm_min: rec.feed_mean_mm_min,
            unit_force_mean: rec.force_mean_n,
            radial_depth_mm: rec.radial_depth_mm,
            x_mm: rec.x_mm,
            ..PeriodTrace::default()
        };
        let dth = rpm / 60.0 * 2.0 * PI * dt;
        let (mut fw, mut ffw, mut rm, mut rw) = (0.0, 0.0, [0.0; 2], [0.0; 2]);
        for (j, s) in rec.samples.iter().enumerate() {
            let basis = match known {
                Some(b) => b[at_sample],
                None => {
                    let th0 = theta;
                    let th1 = th0 + dth;
                    theta = crate::exact::rem_tau(th1);
                    // sin and cos of the sample's start: the last sample's end where the
                    // angle was not wrapped (the same number, so the same values).
                    let (s0, c0) = match end_sc {
                        Some((a, s, c)) if a == th0 => (s, c),
                        _ => th0.sin_cos(),
                    };
                    let b = if dth.abs() < 1e-12 {
                        end_sc = None;
                        [c0, -s0]
                    } else {
                        let (s1, c1) = th1.sin_cos();
                        end_sc = Some((th1, s1, c1));
                        [(s1 - s0) / dth, (c1 - c0) / dth]
                    };
                    fresh.push(b);
                    b
                }
            };
            at_sample += 1;
            rm[0] += s.force_n * basis[0];
            rm[1] += s.force_n * basis[1];
            if j >= ns - k {
                fw += s.force_n;
                ffw += s.feed_mm_min;
                rw[0] += s.force_n * basis[0];
                rw[1] += s.force_n * basis[1];
            }
        }
        let (nsf, kf) = (ns.max(1) as f64, k.max(1) as f64);
        tr.unit_force_window = fw / kf;
        tr.feed_window_mm_min = ffw / kf;
        tr.runout_mean = [rm[0] / nsf, rm[1] / nsf];
        tr.runout_window = [rw[0] / kf, rw[1] / kf];
        // The motor channel: the torque samples in equal slices over the DAQ block, the
        // drive's lag stepped per slice, the window = the last DAQ samples
        // (`MotorSim::run_period_tail`).
        let fs = if channel.daq_rate_hz > 0.0 {
            channel.daq_rate_hz
        } else {
            1.0 / dt
        };
        let nd = ((dt_row * fs).round().max(0.0) as usize).max(1);
        let w = if channel.window_s > 0.0 && channel.window_s < dt_row {
            ((channel.window_s * fs).round() as usize).clamp(1, nd)
        } else {
            nd
        };
        let skip = nd - w;
        let slices = ns.clamp(1, nd);
        let (mut tw, mut tsq, mut cnt) = (0.0, 0.0, 0.0);
        for j in 0..slices {
            let start = j * nd / slices;
            let end = (j + 1) * nd / slices;
            let t_cut = rec.samples.get(j).map_or(0.0, |s| s.torque_nm);
            lagged = lag.step(lagged, t_cut, (end - start) as f64 / fs);
            let kept = end.saturating_sub(start.max(skip)) as f64;
            tw += kept * lagged;
            tsq += kept * lagged * lagged;
            cnt += kept;
        }
        let cnt = cnt.max(1.0);
        tr.unit_torque_window = tw / cnt;
        tr.unit_torque_sq_window = tsq / cnt;
        tr.volume_mm3 = m.volume_mm3();
        out.push(tr);
    }
    if known.is_none() && fresh.len() == samples {
        // Another thread's trace on the same drive may have left it first: the same values.
        let _ = basis.0.set(fresh);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::configs_dir;

    /// The paper's machine and Ø16 mm end mill on the shipped workpiece `file`.
    fn paper_machine_on(file: &str) -> (MachineSpec, ToolSpec, Workpiece) {
        let dir = configs_dir();
        let spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
        let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
        let wp = Workpiece::load(dir.join("workpieces").join(file)).expect("workpiece");
        (spec, tool, wp)
    }

    #[test]
    fn a_shared_runout_basis_gives_the_traces_a_fresh_one_gives() {
        // A drive with uneven periods and a changing spindle speed (the angle wraps at
        // every speed), traced at two feed-drive lags: the second trace on the shared
        // basis reads it, and every field of every period is the same bits as on a basis
        // of its own.
        let (mut spec, tool, wp) = paper_machine_on("steps_1_2_3.toml");
        let n = 200;
        let period: Vec<f64> = (0..n).map(|i| [0.1, 0.1, 0.103, 0.098][i % 4]).collect();
        let ov: Vec<f64> = (0..n).map(|i| [100.0, 70.0, 130.0][(i / 30) % 3]).collect();
        let fp = vec![200.0; n];
        let rpm: Vec<f64> = (0..n).map(|i| 600.0 + 3.7 * i as f64).collect();
        let drive = ReplayDrive {
            period_s: &period,
            override_applied_pct: &ov,
            programmed_feed_mm_min: &fp,
            feed_hold: None,
            spindle_rpm: Some(&rpm),
            settled: false,
        };
        let eng = ReplayEngagement::Workpiece {
            workpiece: wp,
            x0_mm: 0.0,
        };
        let shared = RunoutBasis::default();
        let bits = |t: &PeriodTrace| {
            [
                t.feed_mean_mm_min,
                t.unit_force_mean,
                t.unit_force_window,
                t.runout_mean[0],
                t.runout_mean[1],
                t.runout_window[0],
                t.runout_window[1],
                t.unit_torque_window,
            ]
            .map(f64::to_bits)
        };
        let channel = ReplayChannel {
            window_s: 0.05,
            ..ReplayChannel::default()
        };
        let run = |spec: &MachineSpec, drive: &ReplayDrive<'_>, basis: &RunoutBasis| {
            trace(spec, &tool, ForceModel::Mean, &eng, drive, &channel, basis)
        };
        let first = run(&spec, &drive, &shared);
        assert!(shared.0.get().is_some(), "the first trace leaves the basis");
        let nominal_tau_s = spec.feed_drive.tau_s;
        for tau_s in [nominal_tau_s, 0.03] {
            spec.feed_drive.tau_s = tau_s;
            let own = run(&spec, &drive, &RunoutBasis::default());
            let read = run(&spec, &drive, &shared);
            assert_eq!(own.len(), n);
            for (a, b) in own.iter().zip(&read) {
                assert_eq!(bits(a), bits(b));
            }
            assert!(own.iter().any(|t| t.runout_mean != [0.0; 2]));
            if tau_s == nominal_tau_s {
                assert!(first.iter().zip(&own).all(|(a, b)| bits(a) == bits(b)));
            }
        }
        // Another drive (other periods) with the same basis: recomputed, not misread.
        let short = &period[..n - 1];
        let other = ReplayDrive {
            period_s: short,
            override_applied_pct: &ov[..n - 1],
            programmed_feed_mm_min: &fp[..n - 1],
            spindle_rpm: Some(&rpm[..n - 1]),
            ..drive
        };
        let own = run(&spec, &other, &RunoutBasis::default());
        let read = run(&spec, &other, &shared);
        for (a, b) in own.iter().zip(&read) {
            assert_eq!(bits(a), bits(b));
        }
    }

    #[test]
    fn a_replay_of_the_simulators_own_commands_is_its_force_at_unit_scale() {
        let (spec, tool, wp) = paper_machine_on("steps_1_2_3.toml");
        let ov: Vec<f64> = (0..300)
            .map(|i| [100.0, 80.0, 120.0][(i / 40) % 3])
            .collect();
        let mut m = Machine::new(
            &spec,
            &tool,
            WearSpec::default(),
            wp.clone(),
            ForceModel::Mean,
            200.0,
        );
        let mut truth = Vec::new();
        for &o in &ov {
            m.set_override_input_pct(o as u16);
            truth.push(m.advance(0.1).force_mean_n);
        }
        let period = vec![0.1; ov.len()];
        let fp = vec![200.0; ov.len()];
        let tr = trace(
            &spec,
            &tool,
            ForceModel::Mean,
            &ReplayEngagement::Workpiece {
                workpiece: wp,
                x0_mm: 0.0,
            },
            &ReplayDrive {
                period_s: &period,
                override_applied_pct: &ov,
                programmed_feed_mm_min: &fp,
                feed_hold: None,
                spindle_rpm: None,
                settled: false,
            },
            &ReplayChannel::default(),
            &RunoutBasis::default(),
        );
        let calib = tool.process.calib_force_n;
        let mut cut = 0;
        for (t, f) in tr.iter().zip(&truth) {
            assert!(
                (t.unit_force_mean * calib - f).abs() < 1e-9 * f.max(1.0),
                "{t:?} {f}"
            );
            if *f > 10.0 {
                cut += 1;
            }
        }
        assert!(cut > 100, "{cut}");
    }

    /// A log's depths are sampled at the end of each period: replayed on them (no
    /// workpiece), the entries and exits of an interrupted cut come out close to the
    /// workpiece's own replay, because each period runs the chord from the row before's
    /// depth to its own; holding the row's depth over the period would put each change a
    /// period early.
    #[test]
    fn a_replay_on_logged_depths_follows_the_entries_of_the_workpiece() {
        let (spec, tool, wp) = paper_machine_on("interrupted.toml");
        let n = 120;
        let (period, ov, fp) = (vec![0.1; n], vec![100.0; n], vec![700.0; n]);
        let drive = ReplayDrive {
            period_s: &period,
            override_applied_pct: &ov,
            programmed_feed_mm_min: &fp,
            feed_hold: None,
            spindle_rpm: None,
            settled: false,
        };
        let on_wp = trace(
            &spec,
            &tool,
            ForceModel::Mean,
            &ReplayEngagement::Workpiece {
                workpiece: wp.clone(),
                x0_mm: 0.0,
            },
            &drive,
            &ReplayChannel::default(),
            &RunoutBasis::default(),
        );
        let rows: Vec<Engagement> = on_wp
            .iter()
            .map(|t| Engagement {
                radial_mm: t.radial_depth_mm,
                axial_mm: wp.axial_depth_mm,
                ks_factor: 1.0,
            })
            .collect();
        let logged = trace(
            &spec,
            &tool,
            ForceModel::Mean,
            &ReplayEngagement::Logged(rows.clone()),
            &drive,
            &ReplayChannel::default(),
            &RunoutBasis::default(),
        );
        let full = on_wp.iter().map(|t| t.unit_force_mean).fold(0.0, f64::max);
        let worst = |tr: &[PeriodTrace]| {
            tr.iter()
                .zip(&on_wp)
                .map(|(a, b)| (a.unit_force_mean - b.unit_force_mean).abs() / full)
                .fold(0.0, f64::max)
        };
        // The same rows held over each period, for scale.
        let held: Vec<PeriodTrace> = (0..n)
            .map(|i| {
                let drive = ReplayDrive {
                    period_s: &period[..=i],
                    override_applied_pct: &ov[..=i],
                    programmed_feed_mm_min: &fp[..=i],
                    ..drive
                };
                let mut same = rows[..=i].to_vec();
                if i > 0 {
                    same[i - 1] = rows[i];
                }
                *trace(
                    &spec,
                    &tool,
                    ForceModel::Mean,
                    &ReplayEngagement::Logged(same),
                    &drive,
                    &ReplayChannel::default(),
                    &RunoutBasis::default(),
                )
                .last()
                .expect("row")
            })
            .collect();
        let entries = rows
            .windows(2)
            .filter(|w| w[0].radial_mm == 0.0 && w[1].radial_mm > 0.0)
            .count();
        assert!(entries >= 3, "{entries} entries");
        let (chord, hold) = (worst(&logged), worst(&held));
        eprintln!("worst row off by {chord:.4} (chord) / {hold:.4} (held) of the full force");
        // The chord's worst row is the first contact, where the engagement bends (0.053 of
        // the full force at 700 mm/min); held, the whole change lands a period early
        // (0.19).
        assert!(chord < 0.07, "{chord}");
        assert!(hold > 3.0 * chord, "{hold} vs {chord}");
    }
}
