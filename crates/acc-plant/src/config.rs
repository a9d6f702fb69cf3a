//! Machine and tool files (`configs/machines/*.toml`, `configs/machines/tools/*.toml`).

use std::path::Path;

use acc_config::RangeError;
use acc_config::{check_range, load_toml, ConfigError};
use acc_core::filter::FirstOrderLag;
use serde::{Deserialize, Serialize};

use crate::process::{ProcessSpec, ToothSpec, WearSpec};

/// `[spindle]` table of a machine file.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpindleSpec {
    /// Commanded spindle speed, rpm (paper: 600).
    pub rpm: f64,
    /// Spindle input power while turning in air, W (iron, friction and fan losses).
    pub no_load_power_w: f64,
    /// Efficiency from electrical input to cutting power, 0…1.
    pub efficiency: f64,
    /// `[spindle.noload_drift]`: thermal drift of the no-load power (default: off). Acts on
    /// the constant-speed spindle's power and on the induction-motor channel
    /// (`crate::motor::MotorEffects`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noload_drift: Option<NoloadDrift>,
    /// `[spindle.motor_efficiency]`: load-dependent copper losses (default: off). Acts on
    /// the constant-speed spindle's power and on the induction-motor channel
    /// (`crate::motor::MotorEffects`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor_efficiency: Option<MotorEfficiency>,
    /// `[spindle.sensor_lowpass]`: first-order low-pass of the reported spindle power
    /// (default: off). Acts on the constant-speed spindle's power and on the
    /// induction-motor channel (`crate::motor::SpindlePowerChannel::with_sensor_lowpass`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_lowpass: Option<SensorLowpass>,
}

impl SpindleSpec {
    /// A spindle without drift or load-dependent losses.
    pub fn new(rpm: f64, no_load_power_w: f64, efficiency: f64) -> Self {
        SpindleSpec {
            rpm,
            no_load_power_w,
            efficiency,
            noload_drift: None,
            motor_efficiency: None,
            sensor_lowpass: None,
        }
    }

    /// Electrical input power at speed `rpm` under the cutting torque `torque_nm`, `t_s`
    /// seconds after the spindle started, W:
    /// `P = P_air(t) + P_c/η + c·P_c²/1000` with `P_c = T·ω` the cutting power
    /// (physics.md §2: input power = no-load power + cutting power over the efficiency;
    /// copper loss ∝ I² ∝ torque², seed 000), `P_air(t)` from [`NoloadDrift::power_w`] and
    /// `c` from [`MotorEfficiency`]. 0 with the spindle stopped (`rpm ≤ 0`).
    pub fn input_power_w(&self, torque_nm: f64, rpm: f64, t_s: f64) -> f64 {
        if rpm <= 0.0 {
            return 0.0;
        }
        let cut_w = torque_nm * rpm * 2.0 * std::f64::consts::PI / 60.0;
        self.no_load_power_w
            + self.noload_drift.map_or(0.0, |d| d.power_w(t_s))
            + cut_w / self.efficiency
            + self.motor_efficiency.map_or(0.0, |m| m.loss_w(cut_w))
    }

    /// Validate the optional effect tables; `prefix` is the spindle table's key path in
    /// `f` (`spindle` in a machine file).
    pub fn validate_effects(&self, f: &Path, prefix: &str) -> Result<(), ConfigError> {
        if let Some(d) = self.noload_drift {
            d.validate(f, &format!("{prefix}.noload_drift"))?;
        }
        if let Some(m) = self.motor_efficiency {
            m.validate(f, &format!("{prefix}.motor_efficiency"))?;
        }
        if let Some(l) = self.sensor_lowpass {
            l.validate(f, &format!("{prefix}.sensor_lowpass"))?;
        }
        Ok(())
    }
}

/// Thermal drift of the no-load power after spindle start (bearings and motor warming up):
/// `P_air(t) = P_air + ΔP · (1 − e^(−t/τ))`. Null (off): `ΔP = 0`. The same parameters
/// and bounds as the discrepancy workflow's `noload_drift` effect (`acc-ident`).
///
/// The constant-speed spindle adds `ΔP·(1 − e^(−t/τ))` to its input power as is. The
/// induction-motor channel (`crate::motor::MotorEffects`) loads its shaft with the bearing
/// friction torque `ΔP·(1 − e^(−t/τ))/ω`, so its measured (two-wattmeter) input rises by
/// that times the motor's input per shaft watt: ≈ 1.03 in air, 1.08 at 5 N·m and 1.19 at
/// 15 N·m on `seed002-small-mill` at 600 rpm (`tests/sim/motor_effects.rs`). `t` is the
/// time since the machine (or the motor simulation) started.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoloadDrift {
    /// Final drift ΔP, W. Range [`NoloadDrift::DELTA_W_RANGE`].
    pub delta_w: f64,
    /// Thermal time constant τ, s. Range [`NoloadDrift::TAU_S_RANGE`].
    pub tau_s: f64,
}

impl NoloadDrift {
    /// Allowed ΔP, W.
    pub const DELTA_W_RANGE: (f64, f64) = (-2000.0, 2000.0);
    /// Allowed τ, s.
    pub const TAU_S_RANGE: (f64, f64) = (5.0, 1e4);

    /// Drift `ΔP · (1 − e^(−t/τ))` at `t_s` after spindle start, W (0 for `t ≤ 0`; a
    /// step for `τ ≤ 0`).
    pub fn power_w(&self, t_s: f64) -> f64 {
        self.delta_w * FirstOrderLag::new(self.tau_s).step_response(t_s)
    }

    /// Range checks; errors name `<prefix>.delta_w` / `<prefix>.tau_s`.
    pub fn validate(&self, f: &Path, prefix: &str) -> Result<(), ConfigError> {
        let (lo, hi) = Self::DELTA_W_RANGE;
        check_range(f, &format!("{prefix}.delta_w"), self.delta_w, lo, hi)?;
        let (lo, hi) = Self::TAU_S_RANGE;
        check_range(f, &format!("{prefix}.tau_s"), self.tau_s, lo, hi)?;
        Ok(())
    }
}

/// Load-dependent motor losses (copper loss ∝ I² ∝ torque², seed 000 and physics.md §2):
/// extra input power `c · P_c² / 1000` W for a cutting power `P_c` W, so the efficiency of
/// the cutting share falls with load. Null (off): `c = 0`. The same parameter and bounds as
/// the discrepancy workflow's `motor_efficiency` effect (`acc-ident`).
///
/// The induction-motor channel (`crate::motor::MotorEffects`) draws it as the copper loss
/// of an extra stator series resistance `R_x = c·P_c²/(1000·3|I_s|²)` at the same phase
/// currents: its measured (two-wattmeter) input rises by exactly `c·P_c²/1000` (within the
/// 0.1 s window's ±0.2 W in `tests/sim/motor_effects.rs`), its RMS current does not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorEfficiency {
    /// Loss coefficient `c`, 1/kW. Range [`MotorEfficiency::COPPER_LOSS_RANGE`].
    pub copper_loss_per_kw: f64,
}

impl MotorEfficiency {
    /// Allowed `c`, 1/kW.
    pub const COPPER_LOSS_RANGE: (f64, f64) = (-0.5, 5.0);

    /// Extra loss `c · P_c² / 1000` at the cutting power `cut_power_w`, W.
    pub fn loss_w(&self, cut_power_w: f64) -> f64 {
        self.copper_loss_per_kw * cut_power_w * cut_power_w / 1000.0
    }

    /// Range check; errors name `<prefix>.copper_loss_per_kw`.
    pub fn validate(&self, f: &Path, prefix: &str) -> Result<(), ConfigError> {
        let (lo, hi) = Self::COPPER_LOSS_RANGE;
        check_range(
            f,
            &format!("{prefix}.copper_loss_per_kw"),
            self.copper_loss_per_kw,
            lo,
            hi,
        )?;
        Ok(())
    }
}

/// `[feed_drive]` table.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FeedDriveSpec {
    /// Time constant τ of the feed drive's first-order lag, s (seed 002, eq. 5; the paper
    /// assumes T ≫ τ, eq. 6).
    pub tau_s: f64,
    /// Time constant of a second first-order lag in series, s (default 0: the first-order
    /// drive of seed 002; > 0: a second-order drive, e.g. a velocity loop behind the
    /// position loop). Range 0 ..= 1.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub tau2_s: f64,
    /// Acceleration limit of the feed along the path, mm/s² (default 0: none; > 0: the
    /// drive's input ramps at most this fast, as a trajectory planner's tangential limit,
    /// [`crate::accel::AccelLimit`]). Range 0 ..= 100 000.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub accel_mm_s2: f64,
    /// Rapid traverse rate of an NC program's G0 moves, mm/min (not overridden by the
    /// feed override). Default 10 000, range 100 ..= 100 000.
    #[serde(default = "default_rapid_mm_min")]
    pub rapid_mm_min: f64,
}

/// The default rapid traverse rate, mm/min.
fn default_rapid_mm_min() -> f64 {
    10_000.0
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// `[override_path]` table: from the board's register to the interpolator.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OverridePathSpec {
    /// Dead time from writing `OVERRIDE_CMD` to the feed starting to change, s (PMC ladder
    /// scan + board output + interpolator pick-up).
    pub delay_s: f64,
    /// Override resolution of the board, percent: 10 (4-bit board) or 1 (byte board).
    pub step_pct: u16,
    /// The NC's own ceiling on the feed override, percent (a machine parameter: the
    /// interpolator runs at most this override whatever the PMC's register holds). Default
    /// none; range 10 ..= 250.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nc_max_pct: Option<u16>,
}

/// `[sim]` table: internal integration rates.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SimRates {
    /// Internal rate of the mean-force model, Hz (default 1000).
    #[serde(default = "default_mean_rate")]
    pub mean_rate_hz: f64,
    /// Internal rate of the tooth-level model, Hz (default 10 000: 250 samples per tooth
    /// pass at 600 rpm with 4 flutes).
    #[serde(default = "default_tooth_rate")]
    pub tooth_rate_hz: f64,
}

impl Default for SimRates {
    fn default() -> Self {
        SimRates {
            mean_rate_hz: default_mean_rate(),
            tooth_rate_hz: default_tooth_rate(),
        }
    }
}

impl SimRates {
    /// Whether both rates are the defaults (the `[sim]` table can then be left out).
    pub fn is_default(&self) -> bool {
        *self == SimRates::default()
    }
}

fn default_mean_rate() -> f64 {
    1000.0
}

fn default_tooth_rate() -> f64 {
    10_000.0
}

/// A machine file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MachineSpec {
    /// Name.
    pub name: String,
    /// Spindle.
    pub spindle: SpindleSpec,
    /// Feed drive.
    pub feed_drive: FeedDriveSpec,
    /// Override path.
    pub override_path: OverridePathSpec,
    /// Internal rates (written only when they differ from the defaults).
    #[serde(default, skip_serializing_if = "SimRates::is_default")]
    pub sim: SimRates,
    /// Axis travel an NC program must stay within (optional; absent: not checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel: Option<Travel>,
}

/// `[travel]`: the axes' travel, mm, in the frame of an NC program's path (work
/// coordinates plus the work offset): `x_mm = [min, max]` and likewise `y_mm`, `z_mm`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Travel {
    /// X travel `[min, max]`, mm.
    pub x_mm: [f64; 2],
    /// Y travel `[min, max]`, mm.
    pub y_mm: [f64; 2],
    /// Z travel `[min, max]`, mm.
    pub z_mm: [f64; 2],
}

impl Travel {
    /// The first axis of `p` (mm) outside the travel: its name, value and range.
    pub fn outside(&self, p: &[f64; 3]) -> Option<(&'static str, f64, [f64; 2])> {
        [("X", self.x_mm), ("Y", self.y_mm), ("Z", self.z_mm)]
            .into_iter()
            .zip(p)
            .find(|((_, r), v)| **v < r[0] - 1e-9 || **v > r[1] + 1e-9)
            .map(|((a, r), v)| (a, *v, r))
    }
}

impl MachineSpec {
    /// Load and validate; errors name the file, the key and the allowed range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let spec: MachineSpec = load_toml(path)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Validate every value.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        check_range(f, "spindle.rpm", self.spindle.rpm, 1.0, 60_000.0)?;
        check_range(
            f,
            "spindle.no_load_power_w",
            self.spindle.no_load_power_w,
            0.0,
            1e6,
        )?;
        check_range(f, "spindle.efficiency", self.spindle.efficiency, 0.05, 1.0)?;
        self.spindle.validate_effects(f, "spindle")?;
        check_range(f, "feed_drive.tau_s", self.feed_drive.tau_s, 0.0, 1.0)?;
        check_range(f, "feed_drive.tau2_s", self.feed_drive.tau2_s, 0.0, 1.0)?;
        check_range(
            f,
            "feed_drive.accel_mm_s2",
            self.feed_drive.accel_mm_s2,
            0.0,
            100_000.0,
        )?;
        check_range(
            f,
            "feed_drive.rapid_mm_min",
            self.feed_drive.rapid_mm_min,
            100.0,
            100_000.0,
        )?;
        if let Some(t) = &self.travel {
            for (key, r) in [
                ("travel.x_mm", t.x_mm),
                ("travel.y_mm", t.y_mm),
                ("travel.z_mm", t.z_mm),
            ] {
                if !(r[0].is_finite() && r[1].is_finite() && r[0] < r[1]) {
                    return Err(ConfigError::OutOfRange(
                        RangeError::new(
                            key,
                            format!("[{}, {}]", r[0], r[1]),
                            "[min, max] with min < max, finite",
                        )
                        .in_file(f),
                    ));
                }
            }
        }
        check_range(
            f,
            "override_path.delay_s",
            self.override_path.delay_s,
            0.0,
            1.0,
        )?;
        if !matches!(self.override_path.step_pct, 1 | 10) {
            return Err(ConfigError::OutOfRange(
                RangeError::new(
                    "override_path.step_pct",
                    self.override_path.step_pct.to_string(),
                    "1 or 10",
                )
                .in_file(f),
            ));
        }
        if let Some(m) = self.override_path.nc_max_pct {
            check_range(f, "override_path.nc_max_pct", f64::from(m), 10.0, 250.0)?;
        }
        check_range(f, "sim.mean_rate_hz", self.sim.mean_rate_hz, 10.0, 1e5)?;
        check_range(f, "sim.tooth_rate_hz", self.sim.tooth_rate_hz, 100.0, 1e6)?;
        Ok(())
    }
}

/// A tool file: geometry, the calibrated force law, wear and tooth-level geometry.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    /// Name.
    pub name: String,
    /// Diameter D, mm (paper: 16).
    pub diameter_mm: f64,
    /// Number of flutes N (paper: 4).
    pub flutes: usize,
    /// Mean-force law (eq. 1).
    pub process: ProcessSpec,
    /// Wear law (default: no wear).
    #[serde(default)]
    pub wear: WearSpec,
    /// Tooth-level geometry (default: [`ToothSpec::default`], the paper tool's 30° helix).
    #[serde(default)]
    pub tooth: ToothSpec,
    /// `[runout]`: once-per-revolution force ripple (default: off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runout: Option<Runout>,
}

/// Runout of the tool in its holder: the force is multiplied by `1 + A · cos(θ + φ)`, θ the
/// spindle angle since the start of the run; over an interval the factor is its mean,
/// `1 + A · (sin(θ₁ + φ) − sin(θ₀ + φ)) / (θ₁ − θ₀)`. Null (off): `A = 0`. The same
/// parameters and bounds as the discrepancy workflow's `runout` effect (`acc-ident`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Runout {
    /// Relative amplitude A. Range [`Runout::AMPLITUDE_RANGE`].
    pub amplitude: f64,
    /// Phase φ at θ = 0, rad. Range [`Runout::PHASE_RAD_RANGE`].
    pub phase_rad: f64,
}

impl Runout {
    /// Allowed A.
    pub const AMPLITUDE_RANGE: (f64, f64) = (0.0, 0.5);
    /// Allowed φ, rad.
    pub const PHASE_RAD_RANGE: (f64, f64) = (-10.0, 10.0);

    /// Mean force factor while the spindle turns from `theta0_rad` to `theta1_rad`
    /// (the instantaneous factor when they coincide).
    pub fn mean_factor(&self, theta0_rad: f64, theta1_rad: f64) -> f64 {
        let d = theta1_rad - theta0_rad;
        let mean_cos = if d.abs() < 1e-9 {
            (theta1_rad + self.phase_rad).cos()
        } else {
            ((theta1_rad + self.phase_rad).sin() - (theta0_rad + self.phase_rad).sin()) / d
        };
        1.0 + self.amplitude * mean_cos
    }

    /// Range checks; errors name `<prefix>.amplitude` / `<prefix>.phase_rad`.
    pub fn validate(&self, f: &Path, prefix: &str) -> Result<(), ConfigError> {
        let (lo, hi) = Self::AMPLITUDE_RANGE;
        check_range(f, &format!("{prefix}.amplitude"), self.amplitude, lo, hi)?;
        let (lo, hi) = Self::PHASE_RAD_RANGE;
        check_range(f, &format!("{prefix}.phase_rad"), self.phase_rad, lo, hi)?;
        Ok(())
    }
}

impl ToolSpec {
    /// Load and validate; errors name the file, the key and the allowed range.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let spec: ToolSpec = load_toml(path)?;
        spec.validate(path)?;
        Ok(spec)
    }

    /// Validate every value.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        check_range(f, "diameter_mm", self.diameter_mm, 0.1, 500.0)?;
        check_range(f, "flutes", self.flutes as f64, 1.0, 32.0)?;
        self.process.validate(f)?;
        self.wear.validate(f, "wear")?;
        check_range(f, "tooth.helix_deg", self.tooth.helix_deg, 0.0, 60.0)?;
        check_range(
            f,
            "tooth.axial_slices",
            self.tooth.axial_slices as f64,
            1.0,
            256.0,
        )?;
        if let Some(r) = self.runout {
            r.validate(f, "runout")?;
        }
        Ok(())
    }

    /// Tool radius R, mm.
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }
}

/// First-order low-pass of a measured channel, applied to its period means:
/// `y_k = a·y_(k−1) + (1 − a)·x_k`, `a = e^(−T_k/τ)` (exact discretisation of
/// `y' = (x − y)/τ` for a piecewise-constant input), starting at `y_0 = x_0`. In a machine
/// file it filters the reported spindle power (`power_w` of the board and the run log, and
/// what a power-based force source sees). Null (off): `τ = 0`. The same parameter and bounds
/// as the discrepancy workflow's `sensor_lowpass` effect (`acc-ident`).
///
/// Both spindle models use this one discretisation ([`SensorLowpass::step`], once per
/// control period): the constant-speed spindle on its period-mean input power, the
/// induction-motor channel (`crate::motor::SpindlePowerChannel::with_sensor_lowpass`) on the
/// two-wattmeter power of each period's measurement window — the `power_w` it logs and
/// the power its force estimate is made from (the phase currents are not filtered). The
/// channel's start-up calibration cut reads through it too, settling each level for
/// `≥ τ·ln 1000`, so its constants are those of the unfiltered cut within the cut's own
/// noise (measured in `tests/sim/motor_effects.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorLowpass {
    /// Time constant τ, s. Range [`SensorLowpass::TAU_S_RANGE`].
    pub tau_s: f64,
}

impl SensorLowpass {
    /// Allowed τ, s.
    pub const TAU_S_RANGE: (f64, f64) = (0.0, 3.0);

    /// One period of length `dt_s` with mean input `x`; `state` holds the last output
    /// (`None` before the first period). Returns the filtered value.
    pub fn step(&self, state: &mut Option<f64>, x: f64, dt_s: f64) -> f64 {
        FirstOrderLag::new(self.tau_s).step_from(state, x, dt_s)
    }

    /// Filter a series of period means in place; `dt_s[k]` is the length of period `k`.
    pub fn filter(&self, values: &mut [f64], dt_s: &[f64]) {
        let mut state = None;
        for (v, dt) in values.iter_mut().zip(dt_s) {
            *v = self.step(&mut state, *v, *dt);
        }
    }

    /// Range check; errors name `<prefix>.tau_s`.
    pub fn validate(&self, f: &Path, prefix: &str) -> Result<(), ConfigError> {
        let (lo, hi) = Self::TAU_S_RANGE;
        check_range(f, &format!("{prefix}.tau_s"), self.tau_s, lo, hi)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cutting power of 1 N·m at 600 rpm, W (`T·ω`).
    const CUT_W: f64 = 1.0 * 600.0 * 2.0 * std::f64::consts::PI / 60.0;

    #[test]
    fn noload_drift_adds_the_thermal_rise_and_is_off_at_null() {
        let base = SpindleSpec::new(600.0, 700.0, 0.8);
        let nominal = 700.0 + CUT_W / 0.8;
        assert!((base.input_power_w(1.0, 600.0, 300.0) - nominal).abs() < 1e-9);
        let drift = NoloadDrift {
            delta_w: 120.0,
            tau_s: 300.0,
        };
        let spec = SpindleSpec {
            noload_drift: Some(drift),
            ..base
        };
        // One time constant after start: ΔP·(1 − 1/e).
        let want = nominal + 120.0 * (1.0 - (-1.0f64).exp());
        assert!((spec.input_power_w(1.0, 600.0, 300.0) - want).abs() < 1e-9);
        // Settled after many time constants, none at start.
        assert!((spec.input_power_w(1.0, 600.0, 1e5) - nominal - 120.0).abs() < 1e-6);
        assert!((spec.input_power_w(1.0, 600.0, 0.0) - nominal).abs() < 1e-9);
        let null = SpindleSpec {
            noload_drift: Some(NoloadDrift {
                delta_w: 0.0,
                ..drift
            }),
            ..base
        };
        assert_eq!(
            null.input_power_w(1.0, 600.0, 300.0),
            base.input_power_w(1.0, 600.0, 300.0)
        );
    }

    #[test]
    fn motor_efficiency_adds_copper_loss_and_is_off_at_null() {
        let base = SpindleSpec::new(600.0, 700.0, 0.8);
        let spec = SpindleSpec {
            motor_efficiency: Some(MotorEfficiency {
                copper_loss_per_kw: 0.5,
            }),
            ..base
        };
        // 30 N·m: P_c = 1885 W, loss 0.5·1.885 kW·1885 W = 1777 W.
        let pc = 30.0 * CUT_W;
        let want = 700.0 + pc / 0.8 + 0.5 * pc * pc / 1000.0;
        assert!((spec.input_power_w(30.0, 600.0, 0.0) - want).abs() < 1e-9);
        // The loss grows with load²: the effective efficiency of the cutting share falls.
        let eta = |t: f64| t * CUT_W / (spec.input_power_w(t, 600.0, 0.0) - 700.0);
        assert!(eta(30.0) < eta(3.0) && eta(3.0) < 0.8);
        // Air cut: no loss.
        assert_eq!(spec.input_power_w(0.0, 600.0, 0.0), 700.0);
        let null = SpindleSpec {
            motor_efficiency: Some(MotorEfficiency {
                copper_loss_per_kw: 0.0,
            }),
            ..base
        };
        assert_eq!(
            null.input_power_w(30.0, 600.0, 0.0),
            base.input_power_w(30.0, 600.0, 0.0)
        );
        assert_eq!(spec.input_power_w(30.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn sensor_lowpass_is_a_first_order_lag_and_off_at_null() {
        let l = SensorLowpass { tau_s: 0.3 };
        let mut v = vec![0.0, 1.0, 1.0, 1.0];
        l.filter(&mut v, &[0.1; 4]);
        // Step response of y' = (x − y)/τ sampled at the period ends: 1 − e^(−kT/τ).
        for (k, y) in v.iter().enumerate().skip(1) {
            let want = 1.0 - (-(k as f64) * 0.1 / 0.3).exp();
            assert!((y - want).abs() < 1e-12, "{k}: {y} vs {want}");
        }
        let mut w = vec![0.0, 1.0, 1.0];
        SensorLowpass { tau_s: 0.0 }.filter(&mut w, &[0.1; 3]);
        assert_eq!(w, vec![0.0, 1.0, 1.0]);
    }

    #[test]
    fn tool_file_runout_is_range_checked_by_key() {
        let dir = crate::configs_dir().join("machines/tools/hss_endmill_16_4f.toml");
        let text = std::fs::read_to_string(&dir).expect("tool file");
        let f = Path::new("t.toml");
        let parse = |extra: &str| -> Result<ToolSpec, ConfigError> {
            let spec: ToolSpec = acc_config::parse_toml(f, &format!("{text}\n{extra}"))?;
            spec.validate(f)?;
            Ok(spec)
        };
        assert_eq!(parse("").expect("nominal").runout, None);
        let ok = parse("[runout]\namplitude = 0.1\nphase_rad = 1.0\n").expect("in range");
        assert_eq!(ok.runout.map(|r| r.amplitude), Some(0.1));
        let e = parse("[runout]\namplitude = 0.9\nphase_rad = 1.0\n")
            .expect_err("A > 0.5")
            .to_string();
        assert!(
            e.contains("runout.amplitude") && e.contains("t.toml"),
            "{e}"
        );
    }

    /// Machine and tool files written by `toml` (as `acc discrepancy` writes them) read
    /// back equal; default `[sim]` rates and absent effects are left out; a tool file
    /// without `[tooth]` gets the paper tool's 30° helix.
    #[test]
    fn specs_round_trip_through_toml_and_tooth_defaults() {
        let dir = crate::configs_dir().join("machines");
        let f = Path::new("x.toml");
        let machine = MachineSpec::load(dir.join("paper_vmc.toml")).expect("machine file");
        let text = toml::to_string_pretty(&machine).expect("serializes");
        assert!(
            !text.contains("[sim]") && !text.contains("noload_drift"),
            "{text}"
        );
        let back: MachineSpec = acc_config::parse_toml(f, &text).expect("reads back");
        assert_eq!(back, machine);
        let fast = MachineSpec {
            sim: SimRates {
                mean_rate_hz: 500.0,
                ..SimRates::default()
            },
            ..machine
        };
        let text = toml::to_string_pretty(&fast).expect("serializes");
        let back: MachineSpec = acc_config::parse_toml(f, &text).expect("reads back");
        assert_eq!(back.sim.mean_rate_hz, 500.0);
        let tool = ToolSpec::load(dir.join("tools/hss_endmill_16_4f.toml")).expect("tool file");
        let text = toml::to_string_pretty(&tool).expect("serializes");
        let back: ToolSpec = acc_config::parse_toml(f, &text).expect("reads back");
        assert_eq!(back, tool);
        let cut = text.find("[tooth]").expect("tooth table written");
        let no_tooth: ToolSpec =
            acc_config::parse_toml(f, &text[..cut]).expect("[tooth] is optional");
        assert_eq!(no_tooth.tooth.helix_deg, 30.0);
        assert_eq!(no_tooth.tooth.axial_slices, 16);
    }

    fn machine_text(spindle_extra: &str) -> String {
        format!(
            "name = \"m\"\n[spindle]\nrpm = 600.0\nno_load_power_w = 700.0\nefficiency = 0.8\n\
             {spindle_extra}\n[feed_drive]\ntau_s = 0.008\n[override_path]\ndelay_s = 0.016\n\
             step_pct = 10\n"
        )
    }

    fn parse(text: &str) -> Result<MachineSpec, ConfigError> {
        let f = Path::new("m.toml");
        let spec: MachineSpec = acc_config::parse_toml(f, text)?;
        spec.validate(f)?;
        Ok(spec)
    }

    #[test]
    fn machine_file_effect_keys_default_off_and_are_range_checked() {
        let spec = parse(&machine_text("")).expect("nominal file");
        assert_eq!(spec.spindle.noload_drift, None);
        assert_eq!(spec.spindle.motor_efficiency, None);
        let spec = parse(&machine_text(
            "[spindle.noload_drift]\ndelta_w = 120.0\ntau_s = 300.0\n\
             [spindle.motor_efficiency]\ncopper_loss_per_kw = 0.2\n",
        ))
        .expect("effects in range");
        assert_eq!(
            spec.spindle.noload_drift,
            Some(NoloadDrift {
                delta_w: 120.0,
                tau_s: 300.0
            })
        );
        for (extra, key) in [
            (
                "[spindle.noload_drift]\ndelta_w = 120.0\ntau_s = 1.0\n",
                "spindle.noload_drift.tau_s",
            ),
            (
                "[spindle.noload_drift]\ndelta_w = 5000.0\ntau_s = 300.0\n",
                "spindle.noload_drift.delta_w",
            ),
            (
                "[spindle.motor_efficiency]\ncopper_loss_per_kw = 9.0\n",
                "spindle.motor_efficiency.copper_loss_per_kw",
            ),
            (
                "[spindle.sensor_lowpass]\ntau_s = 4.0\n",
                "spindle.sensor_lowpass.tau_s",
            ),
        ] {
            let e = parse(&machine_text(extra))
                .expect_err("out of range")
                .to_string();
            assert!(e.contains(key) && e.contains("m.toml"), "{e}");
        }
    }
}
