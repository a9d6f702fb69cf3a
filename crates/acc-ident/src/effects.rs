//! Candidate effects: named, bounded, physically parameterized changes to the nominal
//! model. Each is `None` (switched off) in a nominal model; its null parameter values also
//! switch it off. They are kept apart from the nominal physics so that each can move into
//! the simulator (`sim/`) unchanged: an effect is a pure function of the replay state.

use std::path::Path;

use acc_config::RangeError;
use acc_config::{check_range, ConfigError};
use serde::{Deserialize, Serialize};

/// Load-dependent motor losses, no-load drift, the sensor low-pass and runout are the
/// simulator's own machine- and tool-file types (`spindle.motor_efficiency`,
/// `spindle.noload_drift`, `spindle.sensor_lowpass`, tool `runout`): one
/// parameterization, one set of bounds, one implementation
/// ([`acc_sim::config::SpindleSpec::input_power_w`], [`SensorLowpass::filter`],
/// [`Runout::mean_factor`]).
pub use acc_sim::config::{MotorEfficiency, NoloadDrift, Runout, SensorLowpass};

/// The effect library.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// Tool wear: `Ks` grows linearly with removed volume (physics.md §1, case I).
    ToolWear,
    /// Load-dependent motor efficiency: copper loss ∝ load² (physics.md §2, I² losses).
    MotorEfficiency,
    /// Feed-drive first-order lag τ (physics.md eq. (5)).
    FeedDriveLag,
    /// First-order low-pass in the measurement channel.
    SensorLowpass,
    /// Dead time in the override path (PMC scan + board).
    OverrideDeadTime,
    /// Feed exponent β ≠ nominal (physics.md eq. (1), (3)).
    FeedExponent,
    /// Once-per-revolution force ripple (runout), seen only when sampling resolves it.
    Runout,
    /// Thermal drift of the no-load power: first-order rise after start.
    NoloadDrift,
    /// Gain drift of the measured channel: the logged value is `(1 + g·t)` × the
    /// channel's (an amplifier or transducer warming up), `t` in minutes from the log's start.
    SensorGainDrift,
    /// Pure delay of the measured channel: the logged value is the channel's `d` seconds
    /// earlier (a buffer, a transport delay), linear between rows.
    MeasurementDelay,
    /// Depth exponent α ≠ nominal: the force law's radial-depth exponent becomes
    /// `α + Δα` with `Ks` re-solved at the calibration point (physics.md eq. (1), the
    /// simulator's `tool.process.alpha`).
    DepthExponent,
    /// A `Ks` step at a material boundary: `Ks × (1 + δ)` for the material after a
    /// boundary on the tool path (the simulator's segment `ks_factor`).
    KsStep,
    /// A second-order feed drive: a second first-order lag `τ₂` in series with the drive
    /// lag (the simulator's `feed_drive.tau2_s`).
    SecondOrderDrive,
    /// An acceleration-limited feed: the drive's input ramps at most `a` mm/s² along the
    /// path, a trajectory planner's tangential limit (the simulator's
    /// `feed_drive.accel_mm_s2`). In [`EffectKind::LIBRARY`], not in the default
    /// candidates [`EffectKind::ALL`]: a candidate where a controller plans the motion.
    FeedAccelLimit,
}

/// Description of one effect parameter.
#[derive(Debug, Clone, Copy)]
pub struct ParamInfo {
    /// Key in the `[effects.<name>]` section.
    pub key: &'static str,
    /// Unit (text).
    pub unit: &'static str,
    /// Lower bound used in fitting.
    pub lo: f64,
    /// Upper bound used in fitting.
    pub hi: f64,
    /// Value that switches the effect off.
    pub null: f64,
    /// Typical scale (finite-difference steps, starting points).
    pub scale: f64,
    /// Grid searched before local refinement (delays and time constants), if any.
    pub grid: Option<&'static [f64]>,
    /// `false` for a setting the fit does not change (e.g. a reference feed).
    pub fitted: bool,
}

mod params;
use params::*;

impl EffectKind {
    /// The process, machine and spindle effects: the first eight of [`EffectKind::ALL`],
    /// without the measurement chain (`sensor_gain_drift`, `measurement_delay`) and the
    /// three shapes `depth_exponent`, `ks_step`, `second_order_drive`. A narrowed
    /// candidate set (`acc discrepancy --effects`) for a log whose sensor is known sound;
    /// the synthetic sweep measures the selection rules on it.
    pub const PROCESS_AND_MACHINE: [EffectKind; 8] = {
        let mut d = [EffectKind::ToolWear; 8];
        let mut i = 0;
        while i < d.len() {
            d[i] = EffectKind::ALL[i];
            i += 1;
        }
        d
    };

    /// The whole library, in [`EFFECTS`] order: [`EffectKind::ALL`] and the acceleration
    /// limit, a candidate only where a log's motion is a controller's plan (`acc
    /// discrepancy --program`).
    pub const LIBRARY: [EffectKind; 14] = {
        let mut d = [EffectKind::FeedAccelLimit; 14];
        let mut i = 0;
        while i < EffectKind::ALL.len() {
            d[i] = EffectKind::ALL[i];
            i += 1;
        }
        d
    };

    /// The default candidates, in report order (`Options::candidates`): the library
    /// without [`EffectKind::FeedAccelLimit`].
    pub const ALL: [EffectKind; 13] = [
        EffectKind::ToolWear,
        EffectKind::MotorEfficiency,
        EffectKind::FeedDriveLag,
        EffectKind::SensorLowpass,
        EffectKind::OverrideDeadTime,
        EffectKind::FeedExponent,
        EffectKind::Runout,
        EffectKind::NoloadDrift,
        EffectKind::SensorGainDrift,
        EffectKind::MeasurementDelay,
        EffectKind::DepthExponent,
        EffectKind::KsStep,
        EffectKind::SecondOrderDrive,
    ];

    /// The effect's entry in [`EFFECTS`].
    pub fn desc(self) -> &'static EffectDesc {
        &EFFECTS[self as usize]
    }

    /// Name used in files and reports (the `[effects.<name>]` section).
    pub fn name(self) -> &'static str {
        self.desc().name
    }

    /// Look an effect up by [`EffectKind::name`].
    pub fn from_name(name: &str) -> Option<EffectKind> {
        EffectKind::LIBRARY.into_iter().find(|k| k.name() == name)
    }

    /// The effect's parameters; the first is the primary one (its interval must exclude
    /// the null for the effect to be accepted).
    pub fn params(self) -> &'static [ParamInfo] {
        self.desc().params
    }

    /// Which measured channels can see the effect.
    pub fn power_only(self) -> bool {
        matches!(self, EffectKind::MotorEfficiency | EffectKind::NoloadDrift)
    }

    /// The experiment that tells this effect from `other`, for "ambiguous" verdicts.
    pub fn separating_experiment(self, other: EffectKind) -> &'static str {
        use EffectKind::*;
        let pair = if self <= other {
            (self, other)
        } else {
            (other, self)
        };
        match pair {
            (ToolWear, SensorGainDrift) | (NoloadDrift, SensorGainDrift) => {
                "air-cut pauses early and late in the run: a gain drift scales the air power (or a zero force stays zero), wear only acts while cutting, a no-load drift adds a constant"
            }
            (FeedDriveLag, MeasurementDelay)
            | (SensorLowpass, MeasurementDelay)
            | (OverrideDeadTime, MeasurementDelay) => {
                "a depth step (tool entry) at constant feed: a measurement delay shifts it, a lag or low-pass rounds it, an override dead time leaves it in place"
            }
            (ToolWear, NoloadDrift) => {
                "an air-cut pause late in the run (spindle on, no engagement): no-load drift raises the air power, tool wear does not"
            }
            (FeedDriveLag, SensorLowpass) => {
                "a depth step (or tool entry) at constant feed: a sensor low-pass smears it, a feed-drive lag does not"
            }
            (FeedDriveLag, OverrideDeadTime) => {
                "a large override step (≥ 30 %) held for several seconds: dead time shifts the response without rounding it, a lag rounds it without shifting it"
            }
            (SensorLowpass, OverrideDeadTime) => {
                "a depth step at constant feed: a sensor low-pass smears it, an override dead time does not"
            }
            (MotorEfficiency, FeedExponent) => {
                "a depth sweep at constant feed: load-dependent losses follow the load, the feed exponent only the feed"
            }
            (ToolWear, FeedExponent) => {
                "a repeat of an early feed step late in the run: wear changes the force at equal feed, the feed exponent does not"
            }
            (ToolWear, MotorEfficiency) => {
                "a load sweep (several depths) on a fresh tool: losses grow with load², wear with removed volume"
            }
            (MotorEfficiency, NoloadDrift) => {
                "air-cut pauses at the start and end: drift moves the air power, load-dependent losses do not"
            }
            (MotorEfficiency, DepthExponent) => {
                "constant-feed passes at two radial depths and, at one depth, two feeds: the depth exponent changes the force ratio between depths only, load-dependent losses follow the load whichever input changes it"
            }
            (FeedExponent, DepthExponent) => {
                "a constant-feed pass at two radial depths (override fixed): only the depth exponent changes the force ratio; then a feed step at one depth: only the feed exponent responds"
            }
            (ToolWear, DepthExponent) => {
                "two radial depths cut alternately (shallow, deep, shallow, deep) on a fresh tool: the depth exponent repeats the same ratio every time, wear drifts both up with removed volume"
            }
            (ToolWear, KsStep) => {
                "a pass over the boundary and back (or the boundary cut first on a fresh tool): a material step sits at a place and jumps there, wear grows smoothly with removed volume"
            }
            (KsStep, SensorGainDrift) => {
                "air-cut pauses before and after the boundary, and the boundary region cut again later: a material step acts only while cutting and at its place, a gain drift scales with time everywhere"
            }
            (NoloadDrift, KsStep) => {
                "an air-cut pause just before and just after the boundary: a no-load drift moves the air power, a material step only the cutting power"
            }
            (FeedDriveLag, FeedAccelLimit)
            | (SecondOrderDrive, FeedAccelLimit)
            | (OverrideDeadTime, FeedAccelLimit) => {
                "two override steps held for several seconds, one small (10 %) and one large (≥ 50 %): an acceleration limit takes a time in proportion to the step, a lag or a dead time the same time whatever its size"
            }
            (FeedDriveLag, SecondOrderDrive)
            | (OverrideDeadTime, SecondOrderDrive)
            | (SensorLowpass, SecondOrderDrive)
            | (SecondOrderDrive, MeasurementDelay) => {
                "a large override step (≥ 30 %) held for several seconds, then a depth step at constant feed: a second-order drive starts the feed response with zero slope (an S-curve) and leaves the depth step sharp; a first-order lag starts it at full slope, a dead time shifts it unrounded, a sensor low-pass or a measurement delay also smears or shifts the depth step"
            }
            _ => {
                "a run with an air-cut pause, an override step and a depth step at constant feed: each excites a different pair of effects"
            }
        }
    }
}

/// Tool wear: extra growth `g` added to the simulator's `tool.wear.growth_per_cm3`, with
/// the wear curve's exponent `p` in place of `tool.wear.volume_exponent`, so the `Ks`
/// factor is `initial · (1 + (g_V + g)·V^p + g_t·t)` with `V` the removed volume in cm³
/// (Ks grows with wear, physics.md §1 case I; the simulator's [`WearSpec::factor`]).
/// `p < 1` is a break-in that slows down, `p > 1` wear that accelerates at the end of the
/// tool's life. Null: `g = 0` (and `p` = the tool's own exponent).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolWear {
    /// Relative growth of Ks per cm³ removed (at `p` = 1), 1/cm³. Range −0.5 ..= 10.
    pub ks_growth_per_cm3: f64,
    /// Exponent `p` of the removed volume, 1. Range 0.3 ..= 3 (default 1).
    #[serde(default = "one")]
    pub volume_exponent: f64,
}

fn one() -> f64 {
    1.0
}

/// Extra feed-drive lag added to `feed_drive.tau_s` (physics.md eq. (5)). Null: 0 s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedDriveLag {
    /// Extra time constant, s. Range 0 ..= 0.99 (the simulator allows τ ≤ 1 s).
    pub extra_tau_s: f64,
}

/// Extra dead time in the override path, added to `feed_drive.override_delay_s`. Null: 0 s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverrideDeadTime {
    /// Extra delay, s. Range 0 ..= 0.99 (the simulator allows ≤ 1 s).
    pub extra_delay_s: f64,
}

/// Feed exponent change: force multiplied by `(f / f_ref)^Δβ` (physics.md eq. (1)); the
/// model's exponent becomes `β + Δβ` with `Ks` rescaled at `f_ref`. Null: `Δβ = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedExponent {
    /// Exponent change Δβ. Range −0.85 ..= 0.9 (β + Δβ stays in the simulator's 0.1 ..= 2).
    pub delta_beta: f64,
    /// Reference feed at which `Ks` is unchanged, mm/min (> 0).
    pub feed_ref_mm_min: f64,
}

/// Depth exponent change (`[effects.depth_exponent]`): the force law's radial-depth
/// exponent becomes `α + Δα`, `Ks` re-solved at the calibration point (the simulator's
/// [`acc_sim::process::ForceLaw::new`]). Null: `Δα = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepthExponent {
    /// Exponent change Δα, 1. Range −0.5 ..= 0.5.
    pub delta_alpha: f64,
}

/// A `Ks` step at a material boundary (`[effects.ks_step]`): the force is `× (1 + δ)` once
/// the tool centre has passed the boundary. The boundary is placed as a fraction of the
/// log's cut path — from the tool-centre position where the first cutting row begins to
/// where the last one ends — so a fit can grid it without knowing the part; the replay
/// states it in mm ([`crate::replay::Replay::ks_step_boundary_mm`]). Null: `δ = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KsStep {
    /// Relative `Ks` change after the boundary, 1. Range −0.6 ..= 1.5.
    pub delta: f64,
    /// Boundary as a fraction of the cut path, 1. Range 0.01 ..= 0.99 (default 0.5).
    #[serde(default = "half")]
    pub boundary_frac: f64,
}

fn half() -> f64 {
    0.5
}

impl KsStep {
    /// Boundary position, mm, on a cut path from `x_first_mm` to `x_last_mm`.
    pub fn boundary_mm(&self, x_first_mm: f64, x_last_mm: f64) -> f64 {
        x_first_mm + self.boundary_frac * (x_last_mm - x_first_mm)
    }

    /// The `Ks` factor averaged over a stretch of path `[x0_mm, x1_mm]` (tool-centre
    /// positions, mm) for a boundary at `b_mm`: `1 + δ·(part of the stretch past b)`.
    pub fn mean_factor(&self, b_mm: f64, x0_mm: f64, x1_mm: f64) -> f64 {
        let (lo, hi) = if x0_mm <= x1_mm {
            (x0_mm, x1_mm)
        } else {
            (x1_mm, x0_mm)
        };
        let past = if hi - lo < 1e-12 {
            if lo >= b_mm {
                1.0
            } else {
                0.0
            }
        } else {
            ((hi - b_mm) / (hi - lo)).clamp(0.0, 1.0)
        };
        1.0 + self.delta * past
    }
}

/// A second lag in series with the feed drive (`[effects.second_order_drive]`), added to
/// the machine's `feed_drive.tau2_s`. Null: 0 s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SecondOrderDrive {
    /// Second time constant, s. Range 0 ..= 0.99 (the simulator allows τ₂ ≤ 1 s).
    pub tau2_s: f64,
}

/// An acceleration limit of the feed (`[effects.feed_accel_limit]`), parameterized by its
/// inverse `k = 1000/a` (s²/m, `a` in mm/s²) so that 0 is the null (no limit) and a
/// limit adds to the machine's own: `1000/a = k_machine + k`. A trajectory planner
/// accelerates the path at most at `a` (LinuxCNC: the tangential share of `[AXIS_*]
/// MAX_ACCELERATION`), so the feed ramps at `60·a` mm/min per s
/// ([`acc_sim::accel::AccelLimit`]). Null: 0 s²/m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedAccelLimit {
    /// Inverse acceleration `1000/a`, s²/m. Range 0 ..= 200 (a ≥ 5 mm/s²).
    pub inverse_accel_s2_per_m: f64,
}

impl FeedAccelLimit {
    /// The acceleration, mm/s² (`f64::INFINITY` at the null).
    pub fn accel_mm_s2(&self) -> f64 {
        1000.0 / self.inverse_accel_s2_per_m
    }
}

/// The `[effects]` section: each effect absent (off) or present with its parameters.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Tool wear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_wear: Option<ToolWear>,
    /// Load-dependent motor efficiency.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor_efficiency: Option<MotorEfficiency>,
    /// Feed-drive lag.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_drive_lag: Option<FeedDriveLag>,
    /// Sensor low-pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_lowpass: Option<SensorLowpass>,
    /// Override dead time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub override_dead_time: Option<OverrideDeadTime>,
    /// Feed exponent change.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_exponent: Option<FeedExponent>,
    /// Runout ripple.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runout: Option<Runout>,
    /// No-load thermal drift.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noload_drift: Option<NoloadDrift>,
    /// Gain drift of the measured channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_gain_drift: Option<SensorGainDrift>,
    /// Pure delay of the measured channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measurement_delay: Option<MeasurementDelay>,
    /// Depth exponent change.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_exponent: Option<DepthExponent>,
    /// `Ks` step at a material boundary.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ks_step: Option<KsStep>,
    /// Second-order feed drive.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub second_order_drive: Option<SecondOrderDrive>,
    /// Acceleration-limited feed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_accel_limit: Option<FeedAccelLimit>,
}

/// Gain drift of the measured channel (`[effects.sensor_gain_drift]`). Null: 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorGainDrift {
    /// Relative gain change per minute from the log's start, 1/min. Range −0.5 ..= 0.5.
    pub gain_per_min: f64,
}

/// Pure delay of the measured channel (`[effects.measurement_delay]`). Null: 0 s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurementDelay {
    /// Delay, s. Range 0 ..= 1.5.
    pub delay_s: f64,
}

impl SensorGainDrift {
    /// Apply to the channel `y` logged at `t_s` (s).
    pub fn apply(&self, y: &mut [f64], t_s: &[f64]) {
        let t0 = t_s.first().copied().unwrap_or(0.0);
        for (v, t) in y.iter_mut().zip(t_s) {
            *v *= 1.0 + self.gain_per_min * (t - t0) / 60.0;
        }
    }
}

impl MeasurementDelay {
    /// Apply to the channel `y` logged at `t_s` (s): each row takes the channel at
    /// `t − delay`, linear between rows, the first row's value before the log.
    pub fn apply(&self, y: &mut [f64], t_s: &[f64]) {
        if self.delay_s <= 0.0 || y.is_empty() {
            return;
        }
        let orig = y.to_vec();
        let mut k = 0usize;
        for (i, v) in y.iter_mut().enumerate() {
            let t = t_s[i] - self.delay_s;
            while k + 1 < orig.len() && t_s[k + 1] <= t {
                k += 1;
            }
            *v = if t <= t_s[0] {
                orig[0]
            } else if k + 1 < orig.len() {
                let w = (t - t_s[k]) / (t_s[k + 1] - t_s[k]).max(1e-12);
                orig[k] + w.clamp(0.0, 1.0) * (orig[k + 1] - orig[k])
            } else {
                orig[k]
            };
        }
    }
}

impl Effects {
    /// `true` when no effect is switched on.
    pub fn is_empty(&self) -> bool {
        self.active().is_empty()
    }

    /// Whether `kind` is switched on.
    pub fn is_on(&self, kind: EffectKind) -> bool {
        (kind.desc().get)(self).is_some()
    }

    /// The effects switched on.
    pub fn active(&self) -> Vec<EffectKind> {
        EffectKind::LIBRARY
            .into_iter()
            .filter(|k| self.is_on(*k))
            .collect()
    }

    /// Switch `kind` off.
    pub fn remove(&mut self, kind: EffectKind) {
        (kind.desc().clear)(self)
    }

    /// Parameter `i` of `kind` (its null value when the effect is off).
    pub fn get(&self, kind: EffectKind, i: usize) -> f64 {
        let d = kind.desc();
        let null = d.params.get(i).map_or(0.0, |p| p.null);
        (d.get)(self)
            .filter(|_| i < d.params.len())
            .map_or(null, |v| v[i])
    }

    /// Switch `kind` on (with its [`EffectDesc::off`] values if it was off) and set
    /// parameter `i`.
    pub fn set(&mut self, kind: EffectKind, i: usize, v: f64) {
        let d = kind.desc();
        let mut values = (d.get)(self).unwrap_or(d.off);
        if let Some(x) = values.get_mut(i) {
            *x = v;
        }
        (d.set)(self, values)
    }

    /// Range checks of every present effect; errors name `effects.<name>.<key>`.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        for kind in self.active() {
            for (i, p) in kind.params().iter().enumerate() {
                let key = format!("effects.{}.{}", kind.name(), p.key);
                check_range(f, &key, self.get(kind, i), p.lo, p.hi)?;
            }
        }
        if let Some(e) = self.feed_exponent {
            if e.feed_ref_mm_min <= 0.0 {
                return Err(ConfigError::OutOfRange(
                    RangeError::new(
                        "effects.feed_exponent.feed_ref_mm_min",
                        e.feed_ref_mm_min.to_string(),
                        "> 0",
                    )
                    .in_file(f),
                ));
            }
        }
        Ok(())
    }
}

/// One effect of the library: its kind, name, parameters and how it sits in [`Effects`].
/// Adding an effect is one [`EFFECTS`] entry (plus its [`EffectKind`] variant, its
/// parameter struct and its [`Effects`] field).
#[derive(Debug, Clone, Copy)]
pub struct EffectDesc {
    /// The effect.
    pub kind: EffectKind,
    /// Name in files and reports, the [`Effects`] field and `[effects.<name>]` section.
    pub name: &'static str,
    /// Parameters, primary first (at most [`MAX_PARAMS`]).
    pub params: &'static [ParamInfo],
    /// Parameter values an effect is switched on with before one is set (the nulls,
    /// except for settings such as a reference feed or a time constant).
    pub off: [f64; MAX_PARAMS],
    /// The parameter values when on (unused slots 0).
    pub get: fn(&Effects) -> Option<[f64; MAX_PARAMS]>,
    /// Switch on with these parameter values.
    pub set: fn(&mut Effects, [f64; MAX_PARAMS]),
    /// Switch off.
    pub clear: fn(&mut Effects),
}

/// Most parameters of one effect.
pub const MAX_PARAMS: usize = 2;

/// One [`EffectDesc`]: `entry!(Kind, field: Struct { key = off, … }, PARAMS)`, the keys in
/// the order of `PARAMS`.
macro_rules! entry {
    ($kind:ident, $field:ident: $ty:ident { $($key:ident = $off:expr),+ }, $params:expr) => {
        EffectDesc {
            kind: EffectKind::$kind,
            name: stringify!($field),
            params: &$params,
            off: pad(&[$($off),+]),
            get: |fx| fx.$field.map(|e| pad(&[$(e.$key),+])),
            set: |fx, v| {
                let mut it = v.into_iter();
                fx.$field = Some($ty { $($key: it.next().unwrap_or(0.0)),+ });
            },
            clear: |fx| fx.$field = None,
        }
    };
}

/// `v` in a [`MAX_PARAMS`] array, unused slots 0.
const fn pad(v: &[f64]) -> [f64; MAX_PARAMS] {
    let mut out = [0.0; MAX_PARAMS];
    let mut i = 0;
    while i < v.len() && i < MAX_PARAMS {
        out[i] = v[i];
        i += 1;
    }
    out
}

/// The effect library, in [`EffectKind`] order ([`EffectKind::LIBRARY`]).
pub static EFFECTS: [EffectDesc; 14] = [
    entry!(ToolWear, tool_wear: ToolWear { ks_growth_per_cm3 = 0.0, volume_exponent = 1.0 }, P_TOOL_WEAR),
    entry!(MotorEfficiency, motor_efficiency: MotorEfficiency { copper_loss_per_kw = 0.0 }, P_MOTOR),
    entry!(FeedDriveLag, feed_drive_lag: FeedDriveLag { extra_tau_s = 0.0 }, P_LAG),
    entry!(SensorLowpass, sensor_lowpass: SensorLowpass { tau_s = 0.0 }, P_LOWPASS),
    entry!(OverrideDeadTime, override_dead_time: OverrideDeadTime { extra_delay_s = 0.0 }, P_DEAD),
    entry!(FeedExponent, feed_exponent: FeedExponent { delta_beta = 0.0, feed_ref_mm_min = 200.0 }, P_BETA),
    entry!(Runout, runout: Runout { amplitude = 0.0, phase_rad = 0.0 }, P_RUNOUT),
    entry!(NoloadDrift, noload_drift: NoloadDrift { delta_w = 0.0, tau_s = 300.0 }, P_DRIFT),
    entry!(SensorGainDrift, sensor_gain_drift: SensorGainDrift { gain_per_min = 0.0 }, P_GAIN_DRIFT),
    entry!(MeasurementDelay, measurement_delay: MeasurementDelay { delay_s = 0.0 }, P_MEAS_DELAY),
    entry!(DepthExponent, depth_exponent: DepthExponent { delta_alpha = 0.0 }, P_DEPTH_EXP),
    entry!(KsStep, ks_step: KsStep { delta = 0.0, boundary_frac = 0.5 }, P_KS_STEP),
    entry!(SecondOrderDrive, second_order_drive: SecondOrderDrive { tau2_s = 0.0 }, P_TAU2),
    entry!(FeedAccelLimit, feed_accel_limit: FeedAccelLimit { inverse_accel_s2_per_m = 0.0 }, P_ACCEL),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_measurement_delay_shifts_the_channel_and_a_gain_drift_scales_it() {
        let t: Vec<f64> = (1..=10).map(|i| 0.1 * f64::from(i)).collect();
        let y0: Vec<f64> = (0..10).map(f64::from).collect();
        let mut y = y0.clone();
        MeasurementDelay { delay_s: 0.15 }.apply(&mut y, &t);
        // 1.5 rows late, linear between rows; the first rows hold the first value.
        assert_eq!(y[0], 0.0);
        assert_eq!(y[1], 0.0);
        assert!((y[5] - 3.5).abs() < 1e-9, "{y:?}");
        let mut y = y0.clone();
        MeasurementDelay { delay_s: 0.0 }.apply(&mut y, &t);
        assert_eq!(y, y0);
        let mut y = vec![100.0; 10];
        SensorGainDrift { gain_per_min: 0.6 }.apply(&mut y, &t);
        // 0.9 s after the first row: × (1 + 0.6 · 0.9/60).
        assert!((y[9] - 100.9).abs() < 1e-9 && y[0] == 100.0, "{y:?}");
    }

    #[test]
    fn the_table_is_in_kind_order_and_round_trips_every_parameter() {
        for (i, k) in EffectKind::LIBRARY.into_iter().enumerate() {
            let d = &EFFECTS[i];
            assert_eq!(d.kind, k);
            assert!(d.params.len() <= MAX_PARAMS, "{}", d.name);
            let mut e = Effects::default();
            assert!(!e.is_on(k) && e.get(k, 0) == d.params[0].null);
            for (j, p) in d.params.iter().enumerate() {
                e.set(k, j, p.hi);
                assert_eq!(e.get(k, j), p.hi, "{}.{}", d.name, p.key);
            }
            assert_eq!(e.active(), vec![k]);
            // Serialized under its name.
            let text = toml::to_string(&e).expect("toml");
            assert!(text.contains(&format!("[{}]", d.name)), "{text}");
            e.remove(k);
            assert!(e.is_empty());
        }
    }

    #[test]
    fn the_new_effects_are_in_the_library_with_their_names() {
        for (k, n) in [
            (EffectKind::SensorGainDrift, "sensor_gain_drift"),
            (EffectKind::MeasurementDelay, "measurement_delay"),
            (EffectKind::FeedAccelLimit, "feed_accel_limit"),
        ] {
            assert!(EffectKind::LIBRARY.contains(&k));
            assert_eq!(EffectKind::from_name(n), Some(k));
            let mut e = Effects::default();
            e.set(k, 0, 0.1);
            assert!(e.is_on(k) && e.get(k, 0) == 0.1);
            e.remove(k);
            assert!(!e.is_on(k));
        }
    }
}
