//! Controller presets (`configs/presets/*.toml`): the TOML form of
//! [`acc_core::ControllerConfig`] plus the nominal plant used by `acc stability`.
//!
//! Every value is range-checked once at load; an error names the file, the dotted key and
//! the allowed range. The file layout (all keys required):
//!
//! ```toml
//! name = "paper case I"
//! description = "adaptive PI, poles 0.2 / -0.05"
//! [controller]
//! period_s = 0.1
//! force_ref_n = 800.0
//! km = 1.0
//! anti_windup = true
//! [mode]
//! kind = "adaptive-pi"     # or "fixed-pi" (kp, ki) or "adaptive-i" (pole)
//! poles = [0.2, -0.05]     # or { re = 0.3, im = 0.2 }
//! [override]
//! step_pct = 10
//! min_pct = 0
//! max_pct = 150
//! hysteresis_pct = 0.0     # optional (default 0 = round-to-nearest; 0 ..= step_pct/2)
//! quantizer = "round"      # optional: "round" (default) or "sigma_delta" (needs hysteresis 0)
//! [estimator]
//! kc_initial = 4.0
//! kc_min = 0.05
//! kc_max = 100.0
//! gain = "normalized"      # or "fixed" with g_c
//! mu = 0.5
//! min_force_n = 100.0
//! min_feed_mm_min = 5.0
//! confirm_periods = 10     # optional (default 10; 0 = no air-cut restore)
//! confirm_tol = 0.03       # optional (default 0.03)
//! [plant]
//! kc_nominal = 4.0
//! nominal_feed_mm_min = 200.0
//! kc_sweep = [0.5, 10.0]
//! ```
//!
//! ```
//! use acc_config::load_preset;
//! use acc_core::{ControllerConfig, PaperCase};
//! let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/presets");
//! let p = load_preset(format!("{dir}/case1.toml")).unwrap();
//! assert_eq!(p.controller, ControllerConfig::paper_case(PaperCase::I));
//! assert_eq!(p.plant.kc_sweep, [0.5, 10.0]);
//! ```

use std::path::{Path, PathBuf};

use acc_core::{
    ControllerConfig, DesiredPoles, EstimatorConfig, EstimatorGain, ModeConfig, OverrideSpec,
};
use serde::Deserialize;

use crate::RangeError;
use crate::{
    check_open_range, check_range, load_toml_with, parse_toml_with, ConfigError, KeyRange,
};

/// A preset file as written (before validation).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresetFile {
    /// Short name for tables and plots.
    pub name: String,
    /// One line on what the preset is for.
    pub description: String,
    /// Loop timing, reference and plant gain.
    pub controller: ControllerSection,
    /// Controller mode and its parameters.
    pub mode: ModeSection,
    /// Override resolution and range of the board.
    #[serde(rename = "override")]
    pub override_: OverrideSection,
    /// Kc estimator.
    pub estimator: EstimatorSection,
    /// Nominal plant for the stability analysis.
    pub plant: PlantSection,
}

/// `[controller]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSection {
    /// Sampling period T, s (0.001 ..= 10).
    pub period_s: f64,
    /// Force reference Fr, N (1 ..= 100 000).
    pub force_ref_n: f64,
    /// Km, feed-drive gain × force-measurement gain (0 < Km < 1e6).
    pub km: f64,
    /// Anti-windup on.
    pub anti_windup: bool,
}

/// Desired poles as written: `[z1, z2]` (real pair) or `{ re, im }` (conjugate pair).
/// Anything else is an error that names `mode.poles` and both accepted forms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PolesToml {
    /// Two real poles.
    Real([f64; 2]),
    /// A complex-conjugate pair re ± j·im.
    Complex {
        /// Real part.
        re: f64,
        /// Imaginary part.
        im: f64,
    },
}

impl<'de> Deserialize<'de> for PolesToml {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        use toml::Value;
        let v = Value::deserialize(d)?;
        let num = |v: &Value| match v {
            Value::Float(f) => Some(*f),
            Value::Integer(i) => Some(*i as f64),
            _ => None,
        };
        let parsed = match &v {
            Value::Array(a) if a.len() == 2 => num(&a[0])
                .zip(num(&a[1]))
                .map(|(z1, z2)| PolesToml::Real([z1, z2])),
            Value::Table(t) if t.len() == 2 => t
                .get("re")
                .and_then(num)
                .zip(t.get("im").and_then(num))
                .map(|(re, im)| PolesToml::Complex { re, im }),
            _ => None,
        };
        parsed.ok_or_else(|| {
            D::Error::custom(format!(
                "key `mode.poles` = {v}: expected a real pair [z1, z2] or a conjugate pair \
                 {{ re = .., im = .. }} (numbers, each pole strictly inside the unit circle)"
            ))
        })
    }
}

/// `[mode]`, tagged by `kind`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ModeSection {
    /// Adaptive PI with pole assignment (eq. 14).
    AdaptivePi {
        /// Desired closed-loop poles, strictly inside the unit circle.
        poles: PolesToml,
    },
    /// Fixed-gain PI (eq. 4).
    FixedPi {
        /// Kp, (mm/min)/N, 0 ..= 100.
        kp: f64,
        /// Ki, (mm/min)/(N·s), 0 < Ki <= 1000.
        ki: f64,
    },
    /// Integral-only adaptive, one pole (paper conclusion 5).
    AdaptiveI {
        /// Desired pole, −1 < p < 1.
        pole: f64,
    },
}

/// `[override]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverrideSection {
    /// Board step, percent (1 ..= 50).
    pub step_pct: u16,
    /// Minimum override, percent (multiple of the step, <= max_pct).
    pub min_pct: u16,
    /// Maximum override, percent (multiple of the step, <= 150).
    pub max_pct: u16,
    /// Quantizer hysteresis, percent of the override (0 ..= step_pct/2; default 0 = plain
    /// round-to-nearest), see [`OverrideSpec::quantize_hysteresis`].
    #[serde(default)]
    pub hysteresis_pct: f64,
    /// `"round"` (default: nearest position, with the hysteresis) or `"sigma_delta"`
    /// (error feedback: the time-average override follows the continuous command; needs
    /// `hysteresis_pct = 0`), see [`acc_core::SigmaDelta`].
    #[serde(default)]
    pub quantizer: QuantizerName,
}

/// `[override] quantizer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QuantizerName {
    /// Round to the nearest board position.
    #[default]
    Round,
    /// First-order σ-Δ error feedback.
    SigmaDelta,
}

impl From<QuantizerName> for acc_core::Quantizer {
    fn from(q: QuantizerName) -> Self {
        match q {
            QuantizerName::Round => acc_core::Quantizer::Round,
            QuantizerName::SigmaDelta => acc_core::Quantizer::SigmaDelta,
        }
    }
}

/// Estimator gain kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GainKind {
    /// g_c = μ/(Km·U), needs `mu`.
    Normalized,
    /// Fixed g_c, needs `g_c`.
    Fixed,
}

/// `[estimator]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorSection {
    /// Initial Kc_hat, N/(mm/min) (kc_min ..= kc_max).
    pub kc_initial: f64,
    /// Lower bound of Kc_hat, N/(mm/min) (0 < x < 1e4).
    pub kc_min: f64,
    /// Upper bound of Kc_hat, N/(mm/min) (kc_min < x <= 1e4).
    pub kc_max: f64,
    /// `"normalized"` or `"fixed"`.
    pub gain: GainKind,
    /// μ of the normalized gain, 0 < μ < 2.
    pub mu: Option<f64>,
    /// Fixed g_c, 1/(mm/min), 0 < g_c <= 10.
    pub g_c: Option<f64>,
    /// Runs only above this force, N (0 ..= 100 000).
    pub min_force_n: f64,
    /// Runs only above this applied feed, mm/min (0 ..= 100 000).
    pub min_feed_mm_min: f64,
    /// Cutting periods within `confirm_tol` before the estimate is confirmed (the value
    /// restored when an air cut starts), 0 ..= 10 000, 0 = off (default 10).
    #[serde(default = "default_confirm_periods")]
    pub confirm_periods: u16,
    /// Relative spread of such a run, 0 < x < 1 (default 0.03).
    #[serde(default = "default_confirm_tol")]
    pub confirm_tol: f64,
}

fn default_confirm_periods() -> u16 {
    EstimatorConfig::DEFAULT_CONFIRM_PERIODS
}

fn default_confirm_tol() -> f64 {
    EstimatorConfig::DEFAULT_CONFIRM_TOL
}

/// `[plant]`: the nominal operating point for the stability analysis.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantSection {
    /// Nominal process gain Kc, N/(mm/min) (0 < x < 1e4).
    pub kc_nominal: f64,
    /// Nominal (programmed) feed, mm/min (0 < x <= 100 000).
    pub nominal_feed_mm_min: f64,
    /// Kc range swept on the pole map, N/(mm/min), `[lo, hi]` with 0 < lo < hi <= 1e4.
    pub kc_sweep: [f64; 2],
}

/// A validated preset.
#[derive(Debug, Clone, PartialEq)]
pub struct Preset {
    /// File it was read from.
    pub file: PathBuf,
    /// Short name.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// The controller configuration.
    pub controller: ControllerConfig,
    /// The nominal plant.
    pub plant: PlantSection,
}

const POLES_ALLOWED: &str = "|z| < 1 (strictly inside the unit circle)";

impl ControllerSection {
    fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        check_range(file, "controller.period_s", self.period_s, 1e-3, 10.0)?;
        check_range(file, "controller.force_ref_n", self.force_ref_n, 1.0, 1e5)?;
        check_open_range(file, "controller.km", self.km, 0.0, 1e6)?;
        Ok(())
    }
}

impl ModeSection {
    /// Validate and convert; errors name `mode.<key>`.
    pub fn to_mode(&self, file: &Path) -> Result<ModeConfig, ConfigError> {
        match *self {
            ModeSection::AdaptivePi { poles } => {
                let (poles, written) = match poles {
                    PolesToml::Real([a, b]) => (DesiredPoles::Real(a, b), format!("[{a}, {b}]")),
                    PolesToml::Complex { re, im } => (
                        DesiredPoles::Complex { re, im },
                        format!("{{ re = {re}, im = {im} }}"),
                    ),
                };
                poles.validate().map_err(|e| {
                    ConfigError::OutOfRange(
                        RangeError::new("mode.poles", format!("{written} ({e})"), POLES_ALLOWED)
                            .in_file(file),
                    )
                })?;
                Ok(ModeConfig::AdaptivePi { poles })
            }
            ModeSection::FixedPi { kp, ki } => {
                check_range(file, "mode.kp", kp, 0.0, 100.0)?;
                check_range(file, "mode.ki", ki, f64::MIN_POSITIVE, 1000.0)?;
                Ok(ModeConfig::FixedPi { kp, ki })
            }
            ModeSection::AdaptiveI { pole } => {
                check_open_range(file, "mode.pole", pole, -1.0, 1.0)?;
                Ok(ModeConfig::AdaptiveIntegral { pole })
            }
        }
    }
}

impl OverrideSection {
    /// Validate and convert; errors name `override.<key>`.
    pub fn to_spec(&self, file: &Path) -> Result<OverrideSpec, ConfigError> {
        let bad = |key: &str, value: u16, allowed: String| {
            ConfigError::OutOfRange(RangeError::new(key, value.to_string(), allowed).in_file(file))
        };
        let step = self.step_pct;
        if !(1..=50).contains(&step) {
            return Err(bad("override.step_pct", step, "1 ..= 50".into()));
        }
        if self.max_pct > 150 || !self.max_pct.is_multiple_of(step) {
            return Err(bad(
                "override.max_pct",
                self.max_pct,
                format!("a multiple of step_pct = {step}, <= 150"),
            ));
        }
        if self.min_pct > self.max_pct || !self.min_pct.is_multiple_of(step) {
            return Err(bad(
                "override.min_pct",
                self.min_pct,
                format!(
                    "a multiple of step_pct = {step}, <= max_pct = {}",
                    self.max_pct
                ),
            ));
        }
        check_range(
            file,
            "override.hysteresis_pct",
            self.hysteresis_pct,
            0.0,
            f64::from(step) / 2.0,
        )?;
        if self.quantizer == QuantizerName::SigmaDelta && self.hysteresis_pct != 0.0 {
            return Err(ConfigError::OutOfRange(
                RangeError::new(
                    "override.hysteresis_pct",
                    self.hysteresis_pct.to_string(),
                    "0 with quantizer = \"sigma_delta\" (the dither replaces the deadband)",
                )
                .in_file(file),
            ));
        }
        Ok(OverrideSpec {
            step_pct: step,
            min_pct: self.min_pct,
            max_pct: self.max_pct,
            hysteresis_pct: self.hysteresis_pct,
            quantizer: self.quantizer.into(),
        })
    }
}

impl EstimatorSection {
    /// Validate and convert; errors name `estimator.<key>`.
    pub fn to_config(&self, file: &Path) -> Result<EstimatorConfig, ConfigError> {
        check_open_range(file, "estimator.kc_min", self.kc_min, 0.0, 1e4)?;
        if !(self.kc_max.is_finite() && self.kc_max > self.kc_min && self.kc_max <= 1e4) {
            return Err(ConfigError::OutOfRange(
                RangeError::new(
                    "estimator.kc_max",
                    self.kc_max.to_string(),
                    format!("kc_min = {} < x <= 10000", self.kc_min),
                )
                .in_file(file),
            ));
        }
        check_range(
            file,
            "estimator.kc_initial",
            self.kc_initial,
            self.kc_min,
            self.kc_max,
        )?;
        let missing = |key: &str, kind: &str| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: format!("estimator.{key}"),
            message: format!("required when gain = \"{kind}\""),
        };
        let gain = match self.gain {
            GainKind::Normalized => {
                let mu = self.mu.ok_or_else(|| missing("mu", "normalized"))?;
                check_open_range(file, "estimator.mu", mu, 0.0, 2.0)?;
                EstimatorGain::Normalized { mu }
            }
            GainKind::Fixed => {
                let g_c = self.g_c.ok_or_else(|| missing("g_c", "fixed"))?;
                check_range(file, "estimator.g_c", g_c, f64::MIN_POSITIVE, 10.0)?;
                EstimatorGain::Fixed { g_c }
            }
        };
        check_range(file, "estimator.min_force_n", self.min_force_n, 0.0, 1e5)?;
        check_range(
            file,
            "estimator.min_feed_mm_min",
            self.min_feed_mm_min,
            0.0,
            1e5,
        )?;
        check_range(
            file,
            "estimator.confirm_periods",
            f64::from(self.confirm_periods),
            0.0,
            10_000.0,
        )?;
        check_open_range(file, "estimator.confirm_tol", self.confirm_tol, 0.0, 1.0)?;
        Ok(EstimatorConfig {
            kc_initial: self.kc_initial,
            kc_min: self.kc_min,
            kc_max: self.kc_max,
            gain,
            min_force_n: self.min_force_n,
            min_feed_mm_min: self.min_feed_mm_min,
            confirm_periods: self.confirm_periods,
            confirm_tol: self.confirm_tol,
        })
    }
}

impl PlantSection {
    fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        check_open_range(file, "plant.kc_nominal", self.kc_nominal, 0.0, 1e4)?;
        check_range(
            file,
            "plant.nominal_feed_mm_min",
            self.nominal_feed_mm_min,
            1e-3,
            1e5,
        )?;
        let [lo, hi] = self.kc_sweep;
        check_open_range(file, "plant.kc_sweep[0]", lo, 0.0, 1e4)?;
        if !(hi.is_finite() && hi > lo && hi <= 1e4) {
            return Err(ConfigError::OutOfRange(
                RangeError::new(
                    "plant.kc_sweep[1]",
                    hi.to_string(),
                    format!("kc_sweep[0] = {lo} < x <= 10000"),
                )
                .in_file(file),
            ));
        }
        Ok(())
    }
}

impl PresetFile {
    /// Validate every value (errors name `file`, the key and the allowed range) and build
    /// the preset.
    pub fn validate(self, file: &Path) -> Result<Preset, ConfigError> {
        self.controller.validate(file)?;
        let mode = self.mode.to_mode(file)?;
        let override_spec = self.override_.to_spec(file)?;
        let estimator = self.estimator.to_config(file)?;
        self.plant.validate(file)?;
        let controller = ControllerConfig {
            period_s: self.controller.period_s,
            force_ref_n: self.controller.force_ref_n,
            km: self.controller.km,
            mode,
            override_spec,
            estimator,
            anti_windup: self.controller.anti_windup,
        };
        // Everything was checked above; this is the core's own consistency check.
        controller.validate().map_err(|e| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: "controller".into(),
            message: e.to_string(),
        })?;
        Ok(Preset {
            file: file.to_path_buf(),
            name: self.name,
            description: self.description,
            controller,
            plant: self.plant,
        })
    }
}

/// The allowed range of every numeric key of a preset, as the validation checks it: shown
/// also when a value does not deserialize at all (`step_pct = -10`, `mu = "half"`).
pub const PRESET_KEY_RANGES: &[KeyRange] = &[
    KeyRange::new("controller.period_s", "0.001 ..= 10"),
    KeyRange::new("controller.force_ref_n", "1 ..= 100000"),
    KeyRange::new("controller.km", "0 < x < 1000000"),
    KeyRange::new("mode.kp", "0 ..= 100"),
    KeyRange::new("mode.ki", "0 < x <= 1000"),
    KeyRange::new("mode.pole", "-1 < x < 1"),
    KeyRange::new("override.step_pct", "1 ..= 50"),
    KeyRange::new("override.min_pct", "a multiple of step_pct, <= max_pct"),
    KeyRange::new("override.max_pct", "a multiple of step_pct, <= 150"),
    KeyRange::new("override.hysteresis_pct", "0 ..= step_pct / 2"),
    KeyRange::new("override.quantizer", "\"round\" or \"sigma_delta\""),
    KeyRange::new("estimator.kc_initial", "kc_min ..= kc_max"),
    KeyRange::new("estimator.kc_min", "0 < x < 10000"),
    KeyRange::new("estimator.kc_max", "kc_min < x <= 10000"),
    KeyRange::new("estimator.mu", "0 < x < 2"),
    KeyRange::new("estimator.g_c", "0 < x <= 10"),
    KeyRange::new("estimator.min_force_n", "0 ..= 100000"),
    KeyRange::new("estimator.min_feed_mm_min", "0 ..= 100000"),
    KeyRange::new("estimator.confirm_periods", "0 ..= 10000 (0 = off)"),
    KeyRange::new("estimator.confirm_tol", "0 < x < 1"),
    KeyRange::new("plant.kc_nominal", "0 < x < 10000"),
    KeyRange::new("plant.nominal_feed_mm_min", "0.001 ..= 100000"),
];

/// Read and validate a preset file.
pub fn load_preset(path: impl AsRef<Path>) -> Result<Preset, ConfigError> {
    let path = path.as_ref();
    let file: PresetFile = load_toml_with(path, PRESET_KEY_RANGES)?;
    file.validate(path)
}

/// Validate preset text that came from `path` (used for errors only).
pub fn parse_preset(path: impl AsRef<Path>, text: &str) -> Result<Preset, ConfigError> {
    let path = path.as_ref();
    let file: PresetFile = parse_toml_with(path, text, PRESET_KEY_RANGES)?;
    file.validate(path)
}

/// Read a preset and return only its controller configuration (what a scenario needs).
pub fn load_controller(path: impl AsRef<Path>) -> Result<ControllerConfig, ConfigError> {
    load_preset(path).map(|p| p.controller)
}

/// Resolve a preset argument: an existing path is used as is; a bare name such as `case1`
/// is looked up as `<presets_dir>/<name>.toml`.
pub fn resolve_preset(arg: &str, presets_dir: impl AsRef<Path>) -> PathBuf {
    let p = Path::new(arg);
    if p.exists() || p.extension().is_some() || p.components().count() > 1 {
        p.to_path_buf()
    } else {
        presets_dir.as_ref().join(format!("{arg}.toml"))
    }
}
