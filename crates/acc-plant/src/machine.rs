//! The simulated machine: override path delay, feed drive lag, spindle, cutting process,
//! all advanced on the machine's own manual clock (`t_s`), never the wall clock.

use std::collections::VecDeque;
use std::f64::consts::PI;

use acc_core::filter::FirstOrderLag;

use crate::accel::AccelLimit;
use crate::config::{MachineSpec, Runout, SensorLowpass, SpindleSpec, ToolSpec};
use crate::engagement::{EngagementSource, ToolGeometry, WorkpieceSource};
use crate::process::{ForceLaw, ForceMemo, ToothModel, Wear, WearSpec};
use crate::workpiece::Workpiece;

/// Which force model the machine integrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ForceModel {
    /// Mean force of eq. (1) at the engaged depth (internal rate `sim.mean_rate_hz`).
    #[default]
    Mean,
    /// Mean force times the tooth-pass ripple of a helical end mill (seed 004; internal
    /// rate `sim.tooth_rate_hz`).
    Tooth,
}

/// A spindle drive: turns the load torque into a speed and an electrical input power.
/// The default is [`ConstantSpeedSpindle`]; an induction-motor model implements the same
/// trait.
pub trait SpindleModel: Send {
    /// Advance `dt_s` under the cutting torque `load_torque_nm`; returns the speed, rpm.
    fn step(&mut self, load_torque_nm: f64, dt_s: f64) -> f64;
    /// Electrical input power at the last step, W.
    fn input_power_w(&self) -> f64;
    /// Current speed, rpm.
    fn speed_rpm(&self) -> f64;
    /// A copy of this spindle in its current state, if it can be copied (the oracle of
    /// `acc compare` runs copies of the plant ahead of the run; default: `None`).
    fn boxed_clone(&self) -> Option<Box<dyn SpindleModel>> {
        None
    }
}

/// A stiff speed-controlled spindle: constant speed, input power
/// `P = P_air(t) + T_c·ω/η + c·(T_c·ω)²/1000` ([`SpindleSpec::input_power_w`]; the drift
/// and load-dependent losses only when the machine file sets them).
#[derive(Debug, Clone)]
pub struct ConstantSpeedSpindle {
    spec: SpindleSpec,
    power_w: f64,
    /// Time since spindle start, s.
    t_s: f64,
}

impl ConstantSpeedSpindle {
    /// At its commanded speed, idling.
    pub fn new(spec: SpindleSpec) -> Self {
        ConstantSpeedSpindle {
            spec,
            power_w: spec.input_power_w(0.0, spec.rpm, 0.0),
            t_s: 0.0,
        }
    }
}

impl SpindleModel for ConstantSpeedSpindle {
    fn step(&mut self, load_torque_nm: f64, dt_s: f64) -> f64 {
        self.t_s += dt_s;
        self.power_w = self
            .spec
            .input_power_w(load_torque_nm, self.spec.rpm, self.t_s);
        self.spec.rpm
    }

    fn input_power_w(&self) -> f64 {
        self.power_w
    }

    fn speed_rpm(&self) -> f64 {
        self.spec.rpm
    }

    fn boxed_clone(&self) -> Option<Box<dyn SpindleModel>> {
        Some(Box::new(self.clone()))
    }
}

/// One internal sample of the machine (rate `sim.mean_rate_hz` or `sim.tooth_rate_hz`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sample {
    /// Time at the end of the sample, s.
    pub t_s: f64,
    /// Tool centre position along the path, mm.
    pub x_mm: f64,
    /// Actual feed, mm/min.
    pub feed_mm_min: f64,
    /// Resultant cutting force, N (instantaneous for the tooth model).
    pub force_n: f64,
    /// Cutting torque, N·m.
    pub torque_nm: f64,
    /// Spindle speed, rpm.
    pub spindle_rpm: f64,
    /// Spindle electrical input power, W.
    pub power_w: f64,
}

/// What happened during one control period; samples are borrowed from the machine.
#[derive(Debug, Clone, Copy)]
pub struct PeriodRecord<'a> {
    /// Time at the end of the period, s.
    pub t_end_s: f64,
    /// Period length T, s.
    pub period_s: f64,
    /// Tool centre position at the end, mm.
    pub x_mm: f64,
    /// Engaged radial depth at the end, mm.
    pub radial_depth_mm: f64,
    /// Engaged axial depth at the end, mm.
    pub axial_depth_mm: f64,
    /// Mean spindle speed over the period, rpm.
    pub spindle_rpm: f64,
    /// Mean actual feed over the period, mm/min.
    pub feed_mean_mm_min: f64,
    /// Mean true cutting force over the whole period, N.
    pub force_mean_n: f64,
    /// Mean cutting torque over the period, N·m.
    pub torque_mean_nm: f64,
    /// Mean spindle input power over the period as the power sensor reports it, W (through
    /// the machine file's `spindle.sensor_lowpass` when set, else the true mean).
    pub power_mean_w: f64,
    /// `Ks` factor of the tool (wear) at the end of the period.
    pub wear_factor: f64,
    /// Internal samples of the period, oldest first.
    pub samples: &'a [Sample],
    /// Internal sample step, s.
    pub sample_dt_s: f64,
    /// What the program says at the end position (block, tool, feed); `None` on a 1-D
    /// workpiece.
    pub path_point: Option<crate::engagement::PathPoint>,
}

impl PeriodRecord<'_> {
    /// Mean force over the last `window_s` of the period (the whole period if `window_s`
    /// is 0 or longer than it), N.
    pub fn force_window_mean_n(&self, window_s: f64) -> f64 {
        let n = self.samples.len();
        if n == 0 {
            return 0.0;
        }
        let k = if window_s <= 0.0 {
            n
        } else {
            ((window_s / self.sample_dt_s).round() as usize).clamp(1, n)
        };
        self.samples[n - k..].iter().map(|s| s.force_n).sum::<f64>() / k as f64
    }
}

/// The simulated machine.
pub struct Machine {
    law: ForceLaw,
    wear: Wear,
    tooth: Option<ToothModel>,
    runout: Option<Runout>,
    /// Spindle angle since the start of the run, modulo 2π, rad (for the runout).
    spindle_angle_rad: f64,
    workpiece: Workpiece,
    radius_mm: f64,
    tau_s: f64,
    /// Second lag of a second-order feed drive (0: first order), s, and its state, mm/min.
    tau2_s: f64,
    feed_inner_mm_min: f64,
    /// The acceleration limit on the drive's input and its state.
    accel: AccelLimit,
    programmed_feed_mm_min: f64,
    rate_hz: f64,
    spindle: Box<dyn SpindleModel>,
    /// Low-pass of the reported spindle power and its state (last output, W).
    power_lowpass: Option<SensorLowpass>,
    power_reported_w: Option<f64>,
    /// Override values in flight on the override path, one per internal step.
    delay_line: VecDeque<u16>,
    delay_steps: usize,
    /// The NC's ceiling on the override, percent (`override_path.nc_max_pct`).
    nc_max_pct: Option<u16>,
    override_input_pct: u16,
    feed_hold: bool,
    /// Multiplier on the material's `Ks` (a hard spot injected by a fault schedule), 1 =
    /// the workpiece as specified.
    hardness_factor: f64,
    /// Tool breakage: from this time on (s) the cutting force is multiplied by the factor
    /// (a broken tool that no longer cuts: < 1; a chipped edge that rubs: > 1).
    breakage: Option<(f64, f64)>,
    /// Where the engagement comes from (default: the workpiece).
    engagement: Box<dyn EngagementSource>,
    /// The tool as the engagement source sees it.
    tool: ToolGeometry,
    t_s: f64,
    x_mm: f64,
    feed_mm_min: f64,
    theta_rad: f64,
    volume_mm3: f64,
    depth_mm: f64,
    samples: Vec<Sample>,
    /// The force law's last powers (a pure cache: results bit-identical without it).
    force_memo: ForceMemo,
}

impl std::fmt::Debug for Machine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Machine")
            .field("t_s", &self.t_s)
            .field("x_mm", &self.x_mm)
            .field("feed_mm_min", &self.feed_mm_min)
            .finish_non_exhaustive()
    }
}

impl Machine {
    /// Build a machine at rest at the start of the path, override input 100 %.
    pub fn new(
        machine: &MachineSpec,
        tool: &ToolSpec,
        wear: WearSpec,
        workpiece: Workpiece,
        model: ForceModel,
        programmed_feed_mm_min: f64,
    ) -> Self {
        let rate_hz = Self::rate_hz(machine, model);
        let tooth = (model == ForceModel::Tooth).then(|| {
            ToothModel::new(
                &tool.tooth,
                tool.flutes,
                tool.radius_mm(),
                workpiece.axial_depth_mm,
            )
        });
        let delay_steps = (machine.override_path.delay_s * rate_hz).round() as usize;
        let engagement: Box<dyn EngagementSource> =
            Box::new(WorkpieceSource::new(workpiece.clone()));
        Machine {
            law: ForceLaw::new(tool.process),
            wear: Wear::new(wear),
            tooth,
            runout: tool.runout,
            spindle_angle_rad: 0.0,
            radius_mm: tool.radius_mm(),
            workpiece,
            tau_s: machine.feed_drive.tau_s,
            tau2_s: machine.feed_drive.tau2_s,
            feed_inner_mm_min: 0.0,
            accel: AccelLimit::new(machine.feed_drive.accel_mm_s2),
            programmed_feed_mm_min,
            rate_hz,
            spindle: Box::new(ConstantSpeedSpindle::new(machine.spindle)),
            power_lowpass: machine.spindle.sensor_lowpass,
            power_reported_w: None,
            delay_line: VecDeque::from(vec![100; delay_steps]),
            delay_steps,
            nc_max_pct: machine.override_path.nc_max_pct,
            override_input_pct: 100,
            feed_hold: false,
            hardness_factor: 1.0,
            breakage: None,
            engagement,
            tool: ToolGeometry::of(tool),
            t_s: 0.0,
            x_mm: 0.0,
            feed_mm_min: 0.0,
            theta_rad: 0.0,
            volume_mm3: 0.0,
            depth_mm: 0.0,
            samples: Vec::new(),
            force_memo: ForceMemo::default(),
        }
    }

    /// A copy of the machine in its current state (clock, position, feed drive, override
    /// delay line, wear, spindle, engagement source), to run ahead of the real one: the
    /// oracle of `acc compare` tries every grid override on copies. `None` if the spindle
    /// model or the engagement source cannot be copied (their `boxed_clone` is `None`).
    pub fn try_clone(&self) -> Option<Machine> {
        Some(Machine {
            law: self.law,
            wear: self.wear,
            tooth: self.tooth.clone(),
            runout: self.runout,
            spindle_angle_rad: self.spindle_angle_rad,
            workpiece: self.workpiece.clone(),
            radius_mm: self.radius_mm,
            tau_s: self.tau_s,
            tau2_s: self.tau2_s,
            feed_inner_mm_min: self.feed_inner_mm_min,
            accel: self.accel,
            programmed_feed_mm_min: self.programmed_feed_mm_min,
            rate_hz: self.rate_hz,
            spindle: self.spindle.boxed_clone()?,
            power_lowpass: self.power_lowpass,
            power_reported_w: self.power_reported_w,
            delay_line: self.delay_line.clone(),
            delay_steps: self.delay_steps,
            nc_max_pct: self.nc_max_pct,
            override_input_pct: self.override_input_pct,
            feed_hold: self.feed_hold,
            hardness_factor: self.hardness_factor,
            breakage: self.breakage,
            engagement: self.engagement.boxed_clone()?,
            tool: self.tool,
            t_s: self.t_s,
            x_mm: self.x_mm,
            feed_mm_min: self.feed_mm_min,
            theta_rad: self.theta_rad,
            volume_mm3: self.volume_mm3,
            depth_mm: self.depth_mm,
            samples: Vec::with_capacity(self.samples.capacity()),
            force_memo: self.force_memo,
        })
    }

    /// Replace the spindle model (e.g. an induction motor).
    pub fn set_spindle(&mut self, spindle: Box<dyn SpindleModel>) {
        self.spindle = spindle;
    }

    /// Set the override on the PMC inputs, percent (the board's `OVERRIDE_APPLIED`). It
    /// reaches the feed after the override-path delay.
    pub fn set_override_input_pct(&mut self, pct: u16) {
        self.override_input_pct = pct;
    }

    /// Assert or release the NC's feed hold (feed target 0 while held).
    pub fn set_feed_hold(&mut self, hold: bool) {
        self.feed_hold = hold;
    }

    /// Multiply the material's specific cutting force `Ks` by `factor` from now on (a hard
    /// spot or inclusion the workpiece file does not describe; `acc board-sim --fault
    /// hard@T:S:F`). Non-finite or non-positive factors are ignored; 1 restores the
    /// workpiece as specified.
    pub fn set_hardness_factor(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.hardness_factor = factor;
        }
    }

    /// Break the tool at machine time `at_s` (s): from then on the cutting force is
    /// multiplied by `force_factor` (e.g. 0.05: the tool is gone; 3: a spike). Non-finite
    /// or negative values are ignored.
    pub fn set_breakage(&mut self, at_s: f64, force_factor: f64) {
        if at_s.is_finite() && at_s >= 0.0 && force_factor.is_finite() && force_factor >= 0.0 {
            self.breakage = Some((at_s, force_factor));
        }
    }

    /// Change the programmed feed of the NC block, mm/min (the replay of a log whose
    /// programmed feed changes; non-finite or negative values are ignored).
    pub fn set_programmed_feed_mm_min(&mut self, feed_mm_min: f64) {
        if feed_mm_min.is_finite() && feed_mm_min >= 0.0 {
            self.programmed_feed_mm_min = feed_mm_min;
        }
    }

    /// Take the engagement from `source` (asked at the tool's position every internal
    /// step, from the next period on) instead of the workpiece's; `None` returns to the
    /// workpiece. A logged profile for the what-if ([`crate::whatif`]), a log row's held
    /// depths for the replay ([`crate::replay`]).
    pub fn set_engagement_source(&mut self, source: Option<Box<dyn EngagementSource>>) {
        self.engagement =
            source.unwrap_or_else(|| Box::new(WorkpieceSource::new(self.workpiece.clone())));
    }

    /// Move the tool centre to path position `x_mm` (a replay starting part-way along the
    /// workpiece).
    pub fn set_position_mm(&mut self, x_mm: f64) {
        if x_mm.is_finite() {
            self.x_mm = x_mm;
        }
    }

    /// Programmed feed of the NC block, mm/min.
    pub fn programmed_feed_mm_min(&self) -> f64 {
        self.path_point()
            .map_or(self.programmed_feed_mm_min, |p| p.feed_mm_min)
    }

    /// What the program says at the tool's position (feed, rapid, block, tool); `None` on
    /// a 1-D workpiece.
    pub fn path_point(&self) -> Option<crate::engagement::PathPoint> {
        self.engagement.path_at(self.x_mm)
    }

    /// Length of the path the tool follows, mm: the program's, else the workpiece's.
    pub fn path_length_mm(&self) -> f64 {
        self.engagement
            .path_length_mm()
            .unwrap_or_else(|| self.workpiece.length_mm())
    }

    /// Machine time, s.
    pub fn t_s(&self) -> f64 {
        self.t_s
    }

    /// Tool centre position, mm.
    pub fn x_mm(&self) -> f64 {
        self.x_mm
    }

    /// Whether the tool centre has passed the end of the workpiece path.
    pub fn finished(&self) -> bool {
        self.x_mm >= self.path_length_mm()
    }

    /// Removed metal so far, mm³.
    pub fn volume_mm3(&self) -> f64 {
        self.volume_mm3
    }

    /// The workpiece.
    pub fn workpiece(&self) -> &Workpiece {
        &self.workpiece
    }

    /// The force law.
    pub fn force_law(&self) -> &ForceLaw {
        &self.law
    }

    /// Current spindle speed, rpm.
    pub fn spindle_rpm(&self) -> f64 {
        self.spindle.speed_rpm()
    }

    /// Current spindle input power, W.
    pub fn spindle_power_w(&self) -> f64 {
        self.spindle.input_power_w()
    }

    /// Internal sample step, s.
    pub fn sample_dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// The internal rate of `machine` under force model `model`, Hz (`sim.mean_rate_hz` or
    /// `sim.tooth_rate_hz`): [`Machine::advance`] takes `round(period · rate)` samples, at
    /// least one.
    pub fn rate_hz(machine: &MachineSpec, model: ForceModel) -> f64 {
        match model {
            ForceModel::Mean => machine.sim.mean_rate_hz,
            ForceModel::Tooth => machine.sim.tooth_rate_hz,
        }
    }

    /// Advance one control period `period_s` and return what happened.
    ///
    /// Per internal step `dt`: the override input enters the delay line; the feed target
    /// `f_prog · ov/100`, rate-limited by `feed_drive.accel_mm_s2` when set
    /// ([`AccelLimit`]), drives the feed drive's first-order lag (exact discretisation,
    /// `f += (target − f)(1 − e^(−dt/τ))`, seed 002 eq. 5); the tool moves `f·dt`; the
    /// engaged radial and axial depth and `Ks` factor come from the engagement source at
    /// the step's position (the workpiece unless [`Machine::set_engagement_source`] set
    /// another: along an NC program's path the axial depth changes inside a period where
    /// the tool enters, leaves or meets another depth level); the mean force follows eq. (1)
    /// with the tool's wear factor, times the tool's runout factor (its mean over the step);
    /// the tooth model multiplies in the ripple.
    pub fn advance(&mut self, period_s: f64) -> PeriodRecord<'_> {
        let n = ((period_s * self.rate_hz).round() as usize).max(1);
        let dt = period_s / n as f64;
        let alpha = FirstOrderLag::new(self.tau_s).alpha(dt);
        let alpha2 = FirstOrderLag::new(self.tau2_s).alpha(dt);
        // The axial depth at the period's end, for the record (the radial one likewise).
        let mut ap = 0.0;
        let t0 = self.t_s;
        self.samples.clear();
        let mut sums = [0.0f64; 5];
        for k in 0..n {
            let ov = if self.delay_steps == 0 {
                self.override_input_pct
            } else {
                self.delay_line.push_back(self.override_input_pct);
                self.delay_line
                    .pop_front()
                    .unwrap_or(self.override_input_pct)
            };
            let ov = self.nc_max_pct.map_or(ov, |m| ov.min(m));
            let target = match (self.feed_hold, self.engagement.path_at(self.x_mm)) {
                (true, _) => 0.0,
                // A rapid runs at the rapid rate whatever the feed override.
                (false, Some(p)) if p.rapid => p.feed_mm_min,
                (false, Some(p)) => p.feed_mm_min * f64::from(ov) / 100.0,
                (false, None) => self.programmed_feed_mm_min * f64::from(ov) / 100.0,
            };
            let target = self.accel.step(target, dt);
            let f_old = self.feed_mm_min;
            self.feed_mm_min = if self.tau2_s > 0.0 {
                self.feed_inner_mm_min =
                    FirstOrderLag::advance(self.feed_inner_mm_min, target, alpha);
                FirstOrderLag::advance(self.feed_mm_min, self.feed_inner_mm_min, alpha2)
            } else {
                FirstOrderLag::advance(self.feed_mm_min, target, alpha)
            };
            let dx = 0.5 * (f_old + self.feed_mm_min) * dt / 60.0;
            self.x_mm += dx;
            let rpm = self.spindle.speed_rpm();
            let eng = self.engagement.engagement_at(&self.tool, self.x_mm);
            self.depth_mm = eng.radial_mm;
            ap = eng.axial_mm;
            let mean = self.law.mean_force_n_memo(
                &mut self.force_memo,
                eng.radial_mm,
                ap,
                self.feed_mm_min,
                rpm,
                eng.ks_factor * self.wear.factor() * self.hardness_factor,
            );
            let t_step = t0 + (k + 1) as f64 * dt;
            let mean = match self.breakage {
                Some((at_s, factor)) if t_step >= at_s => mean * factor,
                _ => mean,
            };
            let th0 = self.spindle_angle_rad;
            let th1 = th0 + rpm / 60.0 * 2.0 * PI * dt;
            self.spindle_angle_rad = crate::exact::rem_tau(th1);
            let mean = match self.runout {
                Some(r) => mean * r.mean_factor(th0, th1),
                None => mean,
            };
            let force = match &self.tooth {
                Some(tooth) => {
                    self.theta_rad =
                        crate::exact::rem_tau(self.theta_rad + rpm / 60.0 * 2.0 * PI * dt);
                    mean * tooth.ratio(self.theta_rad, self.x_mm, &self.workpiece, eng.radial_mm)
                }
                None => mean,
            };
            let torque = self.law.torque_nm(force, self.radius_mm);
            let rpm_new = self.spindle.step(torque, dt);
            let power = self.spindle.input_power_w();
            let vol = eng.radial_mm * ap * dx;
            self.volume_mm3 += vol;
            self.wear.add(vol, dt);
            let t = t0 + (k + 1) as f64 * dt;
            self.samples.push(Sample {
                t_s: t,
                x_mm: self.x_mm,
                feed_mm_min: self.feed_mm_min,
                force_n: force,
                torque_nm: torque,
                spindle_rpm: rpm_new,
                power_w: power,
            });
            for (s, v) in sums
                .iter_mut()
                .zip([self.feed_mm_min, force, torque, rpm_new, power])
            {
                *s += v;
            }
        }
        self.t_s = t0 + period_s;
        let nf = n as f64;
        let power_mean_w = match self.power_lowpass {
            Some(l) => l.step(&mut self.power_reported_w, sums[4] / nf, period_s),
            None => sums[4] / nf,
        };
        PeriodRecord {
            t_end_s: self.t_s,
            period_s,
            x_mm: self.x_mm,
            radial_depth_mm: self.depth_mm,
            axial_depth_mm: ap,
            feed_mean_mm_min: sums[0] / nf,
            force_mean_n: sums[1] / nf,
            torque_mean_nm: sums[2] / nf,
            spindle_rpm: sums[3] / nf,
            power_mean_w,
            wear_factor: self.wear.factor(),
            path_point: self.engagement.path_at(self.x_mm),
            samples: &self.samples,
            sample_dt_s: dt,
        }
    }
}

#[cfg(test)]
#[path = "machine_tests.rs"]
mod tests;
