//! The model file (`--model`, `model.updated.toml`).
//!
//! It is the simulator's machine file under `[machine]` and its tool file under `[tool]`
//! (same keys: `machine.spindle.no_load_power_w`, `machine.feed_drive.tau_s`,
//! `machine.override_path.delay_s`, `tool.process.calib_force_n`, `tool.wear.growth_per_cm3`
//! `machine.spindle.noload_drift.*`, `machine.spindle.motor_efficiency.*` …), plus
//! `[measurement]` (which channel to compare) and `[effects.*]` for the candidate effects
//! while they are fitted and for those the simulator does not have yet. [`Model::machine_toml`] and
//! [`Model::tool_toml`] give the two sections as stand-alone simulator files.

use std::path::Path;

use acc_config::{check_range, ConfigError};
use acc_core::spindle_force;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectKind, Effects, MotorEfficiency};

/// Which measured channel the model predicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Channel {
    /// Spindle input power `power_w`, W.
    #[default]
    Power,
    /// Mean cutting force `force_n`, N.
    Force,
}

impl Channel {
    /// The channel's unit: `W` or `N`.
    pub fn unit(self) -> &'static str {
        match self {
            Channel::Power => "W",
            Channel::Force => "N",
        }
    }
}

/// Where the replayed feed comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum FeedInput {
    /// The command path (`programmed_feed_mm_min · override_cmd_pct / 100` through the
    /// override delay and the feed-drive lag) when the log has both columns, else the
    /// recorded feed.
    #[default]
    Auto,
    /// Always the command path (error if the columns are missing).
    Command,
    /// Always the recorded `feed_mm_min` (feed-drive lag and override dead time are then
    /// not identifiable and are skipped).
    Recorded,
    /// The simulator's plant ([`acc_sim::replay`]) driven by the logged
    /// `override_applied_pct` (the override on the PMC inputs during each period),
    /// `programmed_feed_mm_min` and feed hold. `auto` picks it when both columns exist.
    Plant,
}

/// `[machine.spindle]`: the simulator machine file's `[spindle]`.
pub type Spindle = acc_sim::config::SpindleSpec;
/// `[machine.feed_drive]`: the simulator machine file's `[feed_drive]`.
pub type FeedDrive = acc_sim::config::FeedDriveSpec;
/// `[machine.override_path]`: the simulator machine file's `[override_path]`.
pub type OverridePath = acc_sim::config::OverridePathSpec;
/// `[machine]`: the simulator's machine file.
pub type Machine = acc_sim::config::MachineSpec;
/// `[tool.process]`: the mean-force law of seed 002 eq. (1), `F = Ks·a_p·d^α·f^β·s^γ`,
/// with `Ks` fixed by one calibration point (the simulator tool file's `[process]`).
pub type Process = acc_sim::process::ProcessSpec;
/// `[tool.wear]`: `Ks` factor `initial · (1 + g_V·V + g_t·t)` (the simulator tool file's
/// `[wear]`; default a new tool that does not wear).
pub type Wear = acc_sim::process::WearSpec;
/// `[tool]`: the simulator's tool file.
pub type Tool = acc_sim::config::ToolSpec;
/// `[tool.tooth]`: helical end-mill geometry for the simulator's tooth-level force
/// (default 30° helix, 16 axial slices).
pub type Tooth = acc_sim::process::ToothSpec;

/// `[measurement]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Measurement {
    /// Channel compared with the model. Default `power`.
    #[serde(default)]
    pub channel: Channel,
    /// Source of the replayed feed. Default `auto`.
    #[serde(default)]
    pub feed_input: FeedInput,
    /// Averaging window of the force channel at the end of each period, s (default 0 =
    /// the whole period; the simulator's dynamometer averages the last 0.05 s).
    #[serde(default)]
    pub force_window_s: f64,
    /// Force model of the replayed plant (`mean`, or `tooth`: the simulator's tooth-level
    /// force, seed 004). Default `mean`. Used when the log carries the override the board
    /// applied and the programmed feed (a log written by `acc sim`, `acc run` or
    /// `acc board-sim`): the replay is then the simulator's plant ([`acc_sim::replay`]).
    #[serde(default)]
    pub force_model: PlantForceModel,
    /// The spindle motor whose two-wattmeter power the log's `power_w` holds (the
    /// simulator's `[measurement] kind = "spindle-power"` channel, e.g.
    /// `seed002-small-mill`); absent: the constant-efficiency spindle law of
    /// `[machine.spindle]` (the board's power register). With a motor,
    /// `machine.spindle.no_load_power_w` is the motor's air-cut input power at the
    /// logged speed and `efficiency` is not used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spindle_motor: Option<acc_sim::motor::BuiltinMotor>,
    /// Averaging window of the power channel at the end of each period, s (default 0 =
    /// the whole period; the simulator's spindle-power channel reads the last 0.05 s).
    #[serde(default)]
    pub power_window_s: f64,
    /// The spindle-power force estimator whose output the log's `force_n` holds (the
    /// simulator's `[measurement] kind = "spindle-power"` channel, `acc_core::spindle_force`'s
    /// `power` / `power-efficiency` method): absent, `force_n` is a force sensor. With it,
    /// the force channel is replayed as the estimator sees the spindle: the model's power
    /// (motor `spindle_motor`, window `power_window_s`, drift, losses, sensor low-pass)
    /// through the estimator's no-load subtraction (its adaptation replayed on the logged
    /// `power_w`), efficiency curve and dead band.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_estimator: Option<ForceEstimator>,
}

/// `[measurement.force_estimator]`: the installation's spindle-power force estimator
/// (its calibration file): `F = T(P − P_air)/r` with `T` the root of
/// `c·T² + a·ω·T = ΔP` (`acc_core::spindle_force::PowerEfficiency`), forces within
/// `noise_floor_sigma·σ_air/(a·ω·r)` reported as 0, a load below
/// `−max(negative_sigma·σ_air, 0.05·P_air)` invalid (logged as 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceEstimator {
    /// `a`: input power per unit of cutting power at light load, −.
    pub gain: f64,
    /// `c`: load losses per squared cutting torque, W/(N·m)².
    pub loss_w_per_nm2: f64,
    /// Tool radius the estimator divides the torque by, mm.
    pub tool_radius_mm: f64,
    /// The learned air-cut point (speed, `P_air`, its σ).
    pub no_load: spindle_force::NoLoadPoint,
    /// The no-load adaptation rule (`None`: fixed no-load).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adapt: Option<spindle_force::AdaptRule>,
    /// Dead band in σ of the air-cut power, −.
    pub noise_floor_sigma: f64,
    /// Negative-load limit in σ of the air-cut power, −.
    pub negative_sigma: f64,
}

impl ForceEstimator {
    /// The estimator of a calibrated `acc_core::spindle_force` estimator (`power` or
    /// `power-efficiency` method, one learned speed); `None` for the current methods.
    pub fn from_estimator(est: &spindle_force::SpindleEstimator) -> Option<ForceEstimator> {
        let cfg = est.config();
        let pe = match cfg.method {
            spindle_force::Method::Power => spindle_force::PowerEfficiency {
                gain: 1.0,
                loss_w_per_nm2: 0.0,
            },
            spindle_force::Method::PowerEfficiency => est.constants().power_efficiency?,
            _ => return None,
        };
        let no_load = est.no_load().points().next()?;
        let (adapt, floor) = match cfg.no_load {
            spindle_force::NoLoadMode::Off => return None,
            spindle_force::NoLoadMode::Fixed => (None, cfg.noise_floor_sigma),
            spindle_force::NoLoadMode::Adaptive => (
                est.no_load().rule().enabled.then(|| *est.no_load().rule()),
                cfg.noise_floor_sigma,
            ),
        };
        Some(ForceEstimator {
            gain: pe.gain,
            loss_w_per_nm2: pe.loss_w_per_nm2,
            tool_radius_mm: cfg.tool_radius_mm,
            no_load,
            adapt,
            noise_floor_sigma: floor,
            negative_sigma: cfg.negative_sigma,
        })
    }

    /// The no-load power and its σ in force at each logged row: the adaptation replayed on
    /// the logged power (`lookup` before `observe`, as the estimator does), W.
    pub fn no_load_track(&self, rpm: &[f64], power_w: &[f64]) -> Vec<(f64, f64)> {
        let rule = self.adapt.unwrap_or(spindle_force::AdaptRule {
            enabled: false,
            ..spindle_force::AdaptRule::default()
        });
        let Ok(mut m) = spindle_force::NoLoadModel::from_points(&[self.no_load], rule) else {
            return vec![(self.no_load.power_w, self.no_load.sigma_power_w); rpm.len()];
        };
        m.set_adapt(self.adapt.is_some());
        rpm.iter()
            .zip(power_w)
            .map(|(&s, &p)| {
                let nl = m
                    .lookup(s)
                    .map_or((self.no_load.power_w, self.no_load.sigma_power_w), |n| {
                        (n.power_w, n.sigma_power_w)
                    });
                if s > 0.0 && p.is_finite() {
                    m.observe(s, p, f64::NAN);
                }
                nl
            })
            .collect()
    }

    /// The force the estimator reports for the input power `p_w` (W) at `rpm` with the
    /// no-load `(P_air, σ)`, N (0 in the dead band, when invalid or the spindle stands).
    pub fn force_n(&self, p_w: f64, rpm: f64, no_load: (f64, f64)) -> f64 {
        if rpm <= 0.0 || !p_w.is_finite() {
            return 0.0;
        }
        let omega = 2.0 * std::f64::consts::PI * rpm / 60.0;
        let dp = p_w - no_load.0;
        let limit = (self.negative_sigma * no_load.1).max(0.05 * no_load.0);
        if dp < -limit {
            return 0.0;
        }
        let pe = spindle_force::PowerEfficiency {
            gain: self.gain,
            loss_w_per_nm2: self.loss_w_per_nm2,
        };
        let r_m = self.tool_radius_mm * 1e-3;
        let f = pe.torque_nm(dp, omega) / r_m;
        let floor = self.noise_floor_sigma * no_load.1 / (self.gain * omega) / r_m;
        if f > floor {
            f
        } else {
            0.0
        }
    }
}

/// Force model of the replayed plant (`measurement.force_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PlantForceModel {
    /// Mean force of seed 002 eq. (1).
    #[default]
    Mean,
    /// Mean force times the tooth-pass ripple of a helical end mill (seed 004).
    Tooth,
}

impl PlantForceModel {
    /// The simulator's force model.
    pub fn sim(self) -> acc_sim::ForceModel {
        match self {
            PlantForceModel::Mean => acc_sim::ForceModel::Mean,
            PlantForceModel::Tooth => acc_sim::ForceModel::Tooth,
        }
    }
}

/// `e` of a simulator file check with its key placed under the model file's `section`
/// (`spindle.rpm` of a machine file is `machine.spindle.rpm` here).
fn under(section: &str, e: ConfigError) -> ConfigError {
    match e {
        ConfigError::OutOfRange(mut r) => {
            r.key = format!("{section}.{}", r.key);
            ConfigError::OutOfRange(r)
        }
        ConfigError::Invalid { file, key, message } => ConfigError::Invalid {
            file,
            key: format!("{section}.{key}"),
            message,
        },
        other => other,
    }
}

/// A complete model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// Free-text name.
    #[serde(default)]
    pub name: String,
    /// Measured channel and feed source.
    #[serde(default)]
    pub measurement: Measurement,
    /// The simulator machine.
    pub machine: Machine,
    /// The simulator tool.
    pub tool: Tool,
    /// Candidate effects on top of machine and tool (all absent in a nominal model).
    #[serde(default, skip_serializing_if = "Effects::is_empty")]
    pub effects: Effects,
}

impl Model {
    /// Read and validate a model file.
    pub fn load(path: &Path) -> Result<Model, ConfigError> {
        let m: Model = acc_config::load_toml(path)?;
        m.validate(path)?;
        Ok(m)
    }

    /// Parse and validate model TOML text (`path` names the source in errors).
    pub fn parse(path: &Path, text: &str) -> Result<Model, ConfigError> {
        let m: Model = acc_config::parse_toml(path, text)?;
        m.validate(path)?;
        Ok(m)
    }

    /// Range checks: `[machine]` and `[tool]` by the simulator's own checks
    /// ([`acc_sim::config::MachineSpec::validate`], [`acc_sim::config::ToolSpec::validate`]),
    /// so each key has the one range `acc sim` allows; then `[measurement]` and
    /// `[effects]`. Errors name the file, the key as written here (`machine.…`, `tool.…`)
    /// and the allowed range.
    pub fn validate(&self, f: &Path) -> Result<(), ConfigError> {
        self.machine.validate(f).map_err(|e| under("machine", e))?;
        self.tool.validate(f).map_err(|e| under("tool", e))?;
        for (key, v) in [
            (
                "measurement.force_window_s",
                self.measurement.force_window_s,
            ),
            (
                "measurement.power_window_s",
                self.measurement.power_window_s,
            ),
        ] {
            check_range(f, key, v, 0.0, 10.0)?;
        }
        self.effects.validate(f)
    }

    /// The effects that the simulator already has a key for are folded into the
    /// machine and tool sections (extra lag into `feed_drive.tau_s`, an acceleration limit
    /// into `feed_drive.accel_mm_s2`, extra dead time into
    /// `override_path.delay_s`, wear into `wear.growth_per_cm3`, feed exponent into
    /// `process.beta` with `Ks` kept at the calibration point, losses added to
    /// `spindle.motor_efficiency.copper_loss_per_kw`, drift into `spindle.noload_drift`
    /// and a power-channel low-pass into `spindle.sensor_lowpass` when the machine has none
    /// yet); the others stay in `[effects]`.
    pub fn folded(&self) -> Model {
        let mut m = self.clone();
        let fx = &self.effects;
        if let Some(e) = fx.feed_drive_lag {
            m.machine.feed_drive.tau_s += e.extra_tau_s;
        }
        if let Some(e) = fx.override_dead_time {
            m.machine.override_path.delay_s += e.extra_delay_s;
        }
        if let Some(e) = fx.feed_accel_limit {
            // The inverse accelerations add (`1000/a = k_machine + k`).
            let k = crate::replay::machine_inv_accel(self) + e.inverse_accel_s2_per_m;
            if k > 0.0 {
                m.machine.feed_drive.accel_mm_s2 = 1000.0 / k;
            }
        }
        if let Some(e) = fx.tool_wear {
            // Clamp at the simulator's lower bound: a negative growth is not a wear law.
            // The candidate's exponent replaces the tool's (the replay's law exactly).
            m.tool.wear.growth_per_cm3 =
                (m.tool.wear.growth_per_cm3 + e.ks_growth_per_cm3).max(0.0);
            m.tool.wear.volume_exponent = e.volume_exponent;
        }
        if let Some(e) = fx.feed_exponent {
            // F = Ks f^β (f/f_ref)^Δβ with f_ref = calib feed ⇔ β' = β + Δβ at the same
            // calibration point (seed 002 eq. 1).
            if (e.feed_ref_mm_min - m.tool.process.calib_feed_mm_min).abs() < 1e-9 {
                m.tool.process.beta += e.delta_beta;
                m.effects.feed_exponent = None;
            }
        }
        if let Some(e) = fx.motor_efficiency {
            // The loss c·P_c²/1000 is linear in c: the two coefficients add.
            let c = m
                .machine
                .spindle
                .motor_efficiency
                .map_or(0.0, |m| m.copper_loss_per_kw);
            let (lo, hi) = MotorEfficiency::COPPER_LOSS_RANGE;
            let sum = c + e.copper_loss_per_kw;
            if (lo..=hi).contains(&sum) {
                m.machine.spindle.motor_efficiency = Some(MotorEfficiency {
                    copper_loss_per_kw: sum,
                });
                m.effects.motor_efficiency = None;
            }
        }
        if let Some(e) = fx.noload_drift {
            // Two drifts with different τ are not one: fold only into a machine without one.
            if m.machine.spindle.noload_drift.is_none() {
                m.machine.spindle.noload_drift = Some(e);
                m.effects.noload_drift = None;
            }
        }
        if let Some(e) = fx.sensor_lowpass {
            // The machine key filters the reported spindle power only; two low-passes in
            // series are not one.
            if self.measurement.channel == Channel::Power
                && m.machine.spindle.sensor_lowpass.is_none()
            {
                m.machine.spindle.sensor_lowpass = Some(e);
                m.effects.sensor_lowpass = None;
            }
        }
        if let Some(e) = fx.runout {
            // Two ripples multiply; fold only into a tool without one.
            if m.tool.runout.is_none() {
                m.tool.runout = Some(e);
                m.effects.runout = None;
            }
        }
        for k in [
            EffectKind::FeedDriveLag,
            EffectKind::FeedAccelLimit,
            EffectKind::OverrideDeadTime,
            EffectKind::ToolWear,
        ] {
            m.effects.remove(k);
        }
        m
    }

    /// Serialize to TOML text (the format [`Model::load`] reads).
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string_pretty(self)
    }

    /// The `[machine]` section as a stand-alone simulator machine file.
    pub fn machine_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string_pretty(&self.machine)
    }

    /// The `[tool]` section as a stand-alone simulator tool file.
    pub fn tool_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string_pretty(&self.tool)
    }

    /// The machine and tool sections checked against the simulator's own ranges (the
    /// sections are the simulator's types, so this is what `acc sim` reads). `path` names
    /// the model file in errors.
    pub fn sim_specs(
        &self,
        path: &Path,
    ) -> Result<(acc_sim::config::MachineSpec, acc_sim::config::ToolSpec), ConfigError> {
        self.machine.validate(path)?;
        self.tool.validate(path)?;
        Ok((self.machine.clone(), self.tool.clone()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::{MotorEfficiency, NoloadDrift, Runout, SensorLowpass};
    use crate::replay::{replay, Inputs};
    use crate::synth;

    /// Drift, losses, the power low-pass and runout fold into simulator machine and tool
    /// keys, and the folded model predicts exactly what the model with the effects
    /// predicted.
    #[test]
    fn spindle_effects_fold_into_machine_keys_without_changing_the_prediction() {
        // 500 rpm at 10 Hz: a period is 5/6 of a revolution, so runout shows in the means.
        let case = synth::Case {
            duration_s: 60.0,
            rpm: 500.0,
            ..Default::default()
        };
        let (nominal, log, _) = synth::generate(&case, &[], 1);
        let mut m = nominal.clone();
        m.effects.noload_drift = Some(NoloadDrift {
            delta_w: 150.0,
            tau_s: 40.0,
        });
        m.effects.motor_efficiency = Some(MotorEfficiency {
            copper_loss_per_kw: 0.3,
        });
        m.effects.sensor_lowpass = Some(SensorLowpass { tau_s: 0.4 });
        m.effects.runout = Some(Runout {
            amplitude: 0.2,
            phase_rad: 1.0,
        });
        let folded = m.folded();
        assert!(folded.effects.is_empty(), "{:?}", folded.effects);
        let s = &folded.machine.spindle;
        assert_eq!(s.noload_drift, m.effects.noload_drift);
        assert_eq!(s.motor_efficiency, m.effects.motor_efficiency);
        assert_eq!(s.sensor_lowpass, m.effects.sensor_lowpass);
        assert_eq!(folded.tool.runout, m.effects.runout);
        let inp = Inputs::from_log(&log, &m).expect("inputs");
        let (a, b) = (replay(&m, &inp), replay(&folded, &inp));
        let base = replay(&nominal, &inp);
        let moved = a
            .predicted
            .iter()
            .zip(&base.predicted)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(moved > 50.0, "the effects change the power: {moved} W");
        for (x, y) in a.predicted.iter().zip(&b.predicted) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
        // A machine that already has a drift keeps the candidate in [effects].
        let mut twice = m.clone();
        twice.machine.spindle.noload_drift = Some(NoloadDrift {
            delta_w: 10.0,
            tau_s: 500.0,
        });
        assert!(twice.folded().effects.noload_drift.is_some());
        // The keys round-trip through the file and are range-checked by name.
        let text = folded.to_toml().expect("toml");
        let back = Model::parse(Path::new("m.toml"), &text).expect("reads back");
        assert_eq!(back, folded);
        // One range per key: the simulator's (α ≥ 0.1 in a tool file, so here too).
        let e = Model::parse(
            Path::new("m.toml"),
            &text.replace("alpha = 0.8", "alpha = 0.05"),
        )
        .expect_err("α below the simulator's 0.1");
        let msg = e.to_string();
        assert!(
            msg.contains("m.toml") && msg.contains("tool.process.alpha") && msg.contains("0.1"),
            "{msg}"
        );
        let bad = text.replace("tau_s = 40.0", "tau_s = 1.0");
        let e = Model::parse(Path::new("m.toml"), &bad).expect_err("τ below 5 s");
        assert!(
            e.to_string().contains("machine.spindle.noload_drift.tau_s"),
            "{e}"
        );
    }
}
