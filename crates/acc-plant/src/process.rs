//! The cutting process: mean force (seed 002, eq. 1), tool wear, and the tooth-level force
//! of a helical end mill (seed 004).

use std::f64::consts::PI;
use std::path::Path;

use acc_config::{check_range, ConfigError};
use serde::{Deserialize, Serialize};

use crate::exact::PowMemo;
use crate::workpiece::Workpiece;

/// `[process]` table of a tool file: the mean-force law (seed 002, eq. 1)
/// `F = Ks · a_p · d^α · f^β · s^γ`, with `Ks` fixed by one calibration point so that the
/// file says what force the tool makes where.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProcessSpec {
    /// Mean resultant cutting force at the calibration point, N (paper: 800 N at 2 mm,
    /// 200 mm/min, 600 rpm, 16 mm axial depth).
    pub calib_force_n: f64,
    /// Radial depth of the calibration point, mm.
    pub calib_radial_mm: f64,
    /// Feed of the calibration point, mm/min.
    pub calib_feed_mm_min: f64,
    /// Spindle speed of the calibration point, rpm.
    pub calib_rpm: f64,
    /// Axial depth of the calibration point, mm.
    pub calib_axial_mm: f64,
    /// Radial-depth exponent α (eq. 1).
    pub alpha: f64,
    /// Feed exponent β (eq. 1); `Kc = F/f ∝ f^(β−1)` (eq. 3).
    pub beta: f64,
    /// Spindle-speed exponent γ (eq. 1).
    pub gamma: f64,
    /// Ratio of radial to tangential force `r1` (seed 004, `f_r = r1·f_t`); the resultant
    /// is `√(1 + r1²)·F_t`, so the cutting torque is `R·F/√(1 + r1²)`.
    pub radial_ratio: f64,
}

/// `[wear]` table: `Ks` grows with the removed volume and with cutting time,
/// `Ks factor = initial · (1 + g_V·(V/1 cm³)^p + g_t·t)`. The exponent `p` shapes the wear
/// curve: 1 is linear in removed volume, `p < 1` a fast break-in that slows down,
/// `p > 1` wear that accelerates towards the end of the tool's life (the power-law
/// flank-wear curve `VB ∝ t^p`, with `Ks` about linear in `VB`). The default (also for a
/// tool file without `[wear]`) is a new tool that does not wear.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WearSpec {
    /// `Ks` factor of the tool at the start of the run (1 = new tool; default 1).
    #[serde(default = "one")]
    pub initial_factor: f64,
    /// Relative `Ks` growth per cm³ of removed metal, 1/cm³ at `volume_exponent` = 1
    /// (in general `Ks` grows by `growth_per_cm3 · (V/1 cm³)^volume_exponent`; default 0).
    #[serde(default)]
    pub growth_per_cm3: f64,
    /// Exponent `p` of the removed volume in the wear law, 1 (default 1: linear; range
    /// [`WearSpec::VOLUME_EXPONENT_RANGE`]).
    #[serde(default = "one")]
    pub volume_exponent: f64,
    /// Relative `Ks` growth per minute of cutting, 1/min (default 0).
    #[serde(default)]
    pub growth_per_min: f64,
}

fn one() -> f64 {
    1.0
}

impl Default for WearSpec {
    fn default() -> Self {
        WearSpec {
            initial_factor: one(),
            growth_per_cm3: 0.0,
            volume_exponent: one(),
            growth_per_min: 0.0,
        }
    }
}

impl WearSpec {
    /// Allowed range of [`WearSpec::volume_exponent`].
    pub const VOLUME_EXPONENT_RANGE: (f64, f64) = (0.3, 3.0);

    /// `Ks` factor after `volume_cm3` of removed metal and `cut_time_min` of cutting:
    /// `initial · (1 + g_V·V^p + g_t·t)`.
    pub fn factor(&self, volume_cm3: f64, cut_time_min: f64) -> f64 {
        let v = volume_cm3.max(0.0);
        let vp = if self.volume_exponent == 1.0 {
            v
        } else {
            v.powf(self.volume_exponent)
        };
        self.initial_factor * (1.0 + self.growth_per_cm3 * vp + self.growth_per_min * cut_time_min)
    }

    /// Validate; errors name `file` and `prefix.key`.
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), ConfigError> {
        check_range(
            file,
            &format!("{prefix}.initial_factor"),
            self.initial_factor,
            0.1,
            10.0,
        )?;
        check_range(
            file,
            &format!("{prefix}.growth_per_cm3"),
            self.growth_per_cm3,
            0.0,
            10.0,
        )?;
        let (lo, hi) = Self::VOLUME_EXPONENT_RANGE;
        check_range(
            file,
            &format!("{prefix}.volume_exponent"),
            self.volume_exponent,
            lo,
            hi,
        )?;
        check_range(
            file,
            &format!("{prefix}.growth_per_min"),
            self.growth_per_min,
            0.0,
            10.0,
        )?;
        Ok(())
    }
}

impl ProcessSpec {
    /// The seed 002 calibration (as in `configs/machines/tools/hss_endmill_16_4f.toml`):
    /// 800 N at 2 mm radial depth, 200 mm/min, 600 rpm, 16 mm axial depth; α = β = 1,
    /// γ = −1, r1 = 0.4. For examples and tests.
    pub fn paper() -> Self {
        ProcessSpec {
            calib_force_n: 800.0,
            calib_radial_mm: 2.0,
            calib_feed_mm_min: 200.0,
            calib_rpm: 600.0,
            calib_axial_mm: 16.0,
            alpha: 1.0,
            beta: 1.0,
            gamma: -1.0,
            radial_ratio: 0.4,
        }
    }

    /// Validate every value; errors name `file` and `process.<key>`.
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        check_range(file, "process.calib_force_n", self.calib_force_n, 1e-3, 1e6)?;
        check_range(
            file,
            "process.calib_radial_mm",
            self.calib_radial_mm,
            1e-3,
            100.0,
        )?;
        check_range(
            file,
            "process.calib_feed_mm_min",
            self.calib_feed_mm_min,
            1e-3,
            1e5,
        )?;
        check_range(file, "process.calib_rpm", self.calib_rpm, 1.0, 1e5)?;
        check_range(
            file,
            "process.calib_axial_mm",
            self.calib_axial_mm,
            1e-3,
            200.0,
        )?;
        check_range(file, "process.alpha", self.alpha, 0.1, 3.0)?;
        check_range(file, "process.beta", self.beta, 0.1, 2.0)?;
        check_range(file, "process.gamma", self.gamma, -3.0, 3.0)?;
        check_range(file, "process.radial_ratio", self.radial_ratio, 0.0, 5.0)?;
        Ok(())
    }
}

/// The last powers [`ForceLaw::mean_force_n_memo`] computed (one memo per machine).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ForceMemo {
    radial: PowMemo,
    feed: PowMemo,
    rpm: PowMemo,
}

/// The mean-force law with its `Ks` solved from the calibration point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLaw {
    /// Specific cutting resistance of the new tool in the reference material, in
    /// N / (mm · mm^α · (mm/min)^β · rpm^γ).
    pub ks: f64,
    /// The law's parameters.
    pub spec: ProcessSpec,
}

impl ForceLaw {
    /// Solve `Ks` from the calibration point (eq. 1).
    pub fn new(spec: ProcessSpec) -> Self {
        let base = spec.calib_axial_mm
            * spec.calib_radial_mm.powf(spec.alpha)
            * spec.calib_feed_mm_min.powf(spec.beta)
            * spec.calib_rpm.powf(spec.gamma);
        ForceLaw {
            ks: spec.calib_force_n / base,
            spec,
        }
    }

    /// Mean resultant cutting force, N (seed 002, eq. 1, times the axial depth):
    /// `F = Ks·ks_factor·a_p·d^α·f^β·s^γ`; 0 without engagement, feed or speed.
    pub fn mean_force_n(
        &self,
        radial_mm: f64,
        axial_mm: f64,
        feed_mm_min: f64,
        rpm: f64,
        ks_factor: f64,
    ) -> f64 {
        self.mean_force_n_memo(
            &mut ForceMemo::default(),
            radial_mm,
            axial_mm,
            feed_mm_min,
            rpm,
            ks_factor,
        )
    }

    /// [`ForceLaw::mean_force_n`] bit for bit, remembering each power for its last
    /// argument in `memo` (the simulator's per-step call: speed and engaged depth rarely
    /// change from one internal step to the next, the feed not at all once settled).
    pub(crate) fn mean_force_n_memo(
        &self,
        memo: &mut ForceMemo,
        radial_mm: f64,
        axial_mm: f64,
        feed_mm_min: f64,
        rpm: f64,
        ks_factor: f64,
    ) -> f64 {
        if radial_mm <= 0.0 || feed_mm_min <= 0.0 || rpm <= 0.0 {
            return 0.0;
        }
        let s = &self.spec;
        self.ks
            * ks_factor
            * axial_mm
            * memo.radial.powf(radial_mm, s.alpha)
            * memo.feed.powf(feed_mm_min, s.beta)
            * memo.rpm.powf(rpm, s.gamma)
    }

    /// Process gain `Kc = F/f` at a feed, N/(mm/min) (seed 002, eq. 3).
    pub fn kc(&self, radial_mm: f64, axial_mm: f64, feed_mm_min: f64, rpm: f64) -> f64 {
        self.mean_force_n(radial_mm, axial_mm, feed_mm_min, rpm, 1.0) / feed_mm_min
    }

    /// Cutting torque for a resultant force, N·m: `T_c = R·F_t`, `F = √(1 + r1²)·F_t`
    /// (seed 004).
    pub fn torque_nm(&self, force_n: f64, radius_mm: f64) -> f64 {
        radius_mm * 1e-3 * force_n / (1.0 + self.spec.radial_ratio.powi(2)).sqrt()
    }
}

/// Tool wear state: `Ks` factor `= initial · (1 + g_V·V^p + g_t·t)` ([`WearSpec::factor`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wear {
    /// Parameters.
    pub spec: WearSpec,
    /// Removed volume so far, cm³.
    pub volume_cm3: f64,
    /// Cutting time so far (time with engagement), min.
    pub cut_time_min: f64,
}

impl Wear {
    /// A tool at its initial state.
    pub fn new(spec: WearSpec) -> Self {
        Wear {
            spec,
            volume_cm3: 0.0,
            cut_time_min: 0.0,
        }
    }

    /// Current `Ks` factor of the tool.
    pub fn factor(&self) -> f64 {
        self.spec.factor(self.volume_cm3, self.cut_time_min)
    }

    /// Account for `dt_s` of cutting that removed `volume_mm3`.
    pub fn add(&mut self, volume_mm3: f64, dt_s: f64) {
        if volume_mm3 > 0.0 {
            self.volume_cm3 += volume_mm3 * 1e-3;
            self.cut_time_min += dt_s / 60.0;
        }
    }
}

/// `[tooth]` table of a tool file: geometry for the tooth-level force.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToothSpec {
    /// Helix angle, degrees (paper tool: HSS end mill, 30°).
    pub helix_deg: f64,
    /// Number of axial slices the flute is integrated over (default 16).
    #[serde(default = "default_slices")]
    pub axial_slices: usize,
}

fn default_slices() -> usize {
    16
}

impl Default for ToothSpec {
    /// The paper tool: 30° helix, 16 axial slices.
    fn default() -> Self {
        ToothSpec {
            helix_deg: 30.0,
            axial_slices: default_slices(),
        }
    }
}

/// Tooth-level force shape of a helical end mill in down milling (seed 004).
///
/// Each flute `j` and axial slice `k` (height `z_k`) sits at immersion angle
/// `ψ = θ + 2πj/N − z_k·tan(β_helix)/R` (θ the cutter angle at the tool end, ψ measured
/// from the finished wall), cuts a chip `h = f_z·sin ψ` when it is in material, and adds
/// `f_t ∝ h·Δz`. The sum `S(θ)` over flutes and slices has the revolution mean
/// `N·a_p·d_eff/(2πR)` (with `d_eff` the engaged depth of
/// [`Workpiece::engagement`]), so `F(θ) = F_mean · S(θ)·2πR/(N·a_p·d_eff)` has the mean
/// force of eq. (1) and the ripple of the tooth passes.
#[derive(Debug, Clone)]
pub struct ToothModel {
    flutes: usize,
    radius_mm: f64,
    /// `(sin o, cos o)` of every flute/slice angle offset `o = 2πj/N − z_k·tan β/R`, so
    /// that `ψ = θ + o` needs no trigonometry per point.
    offsets: Vec<(f64, f64)>,
    dz_mm: f64,
    axial_mm: f64,
}

impl ToothModel {
    /// Build for a tool and an axial depth.
    pub fn new(spec: &ToothSpec, flutes: usize, radius_mm: f64, axial_mm: f64) -> Self {
        let n = spec.axial_slices.max(1);
        let flutes = flutes.max(1);
        let dz = axial_mm / n as f64;
        let tan_h = spec.helix_deg.to_radians().tan();
        let pitch = 2.0 * PI / flutes as f64;
        let offsets = (0..flutes)
            .flat_map(|j| {
                (0..n).map(move |k| {
                    let lag = (k as f64 + 0.5) * dz * tan_h / radius_mm;
                    (j as f64 * pitch - lag).sin_cos()
                })
            })
            .collect();
        ToothModel {
            flutes,
            radius_mm,
            offsets,
            dz_mm: dz,
            axial_mm,
        }
    }

    /// Instantaneous-to-mean force ratio at cutter angle `theta` (rad) with the centre at
    /// path position `x` (mm). Returns 1 when nothing is engaged (the mean is then 0 anyway).
    pub fn ratio(&self, theta: f64, x: f64, workpiece: &Workpiece, depth_eff_mm: f64) -> f64 {
        if depth_eff_mm <= 0.0 {
            return 1.0;
        }
        let r = self.radius_mm;
        let uniform = workpiece.uniform_over(x, r);
        let (st, ct) = theta.sin_cos();
        let mut s = 0.0;
        for &(so, co) in &self.offsets {
            // ψ = θ + o; the cutting half is 0 ≤ ψ ≤ π, i.e. sin ψ ≥ 0.
            let sin = st * co + ct * so;
            if sin < 0.0 {
                continue;
            }
            let cos = ct * co - st * so;
            let y = r * (1.0 - cos);
            let depth = match uniform {
                Some((d, _)) => d,
                None => workpiece.depth_at(x + r * sin),
            };
            if y < depth {
                s += sin * self.dz_mm;
            }
        }
        s * 2.0 * PI * r / (self.flutes as f64 * self.axial_mm * depth_eff_mm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workpiece::{SegmentSpec, WorkpieceFile};

    #[test]
    fn default_wear_is_a_new_tool_that_does_not_wear() {
        // A tool file without `[wear]` must cut with the calibrated Ks, not with Ks × 0.
        let d = WearSpec::default();
        assert_eq!(d.initial_factor, 1.0);
        assert_eq!((d.growth_per_cm3, d.growth_per_min), (0.0, 0.0));
        let empty: WearSpec = toml::from_str("").expect("empty [wear] table");
        assert_eq!(empty, d);
    }

    pub(crate) fn paper_spec() -> ProcessSpec {
        ProcessSpec::paper()
    }

    #[test]
    fn calibration_point_reproduces() {
        let law = ForceLaw::new(paper_spec());
        let f = law.mean_force_n(2.0, 16.0, 200.0, 600.0, 1.0);
        assert!((f - 800.0).abs() < 1e-9);
        assert!((law.kc(3.0, 16.0, 200.0, 600.0) - 6.0).abs() < 1e-9);
        assert_eq!(law.mean_force_n(0.0, 16.0, 200.0, 600.0, 1.0), 0.0);
    }

    #[test]
    fn wear_grows_ks() {
        let mut w = Wear::new(WearSpec {
            initial_factor: 1.0,
            growth_per_cm3: 0.01,
            volume_exponent: 1.0,
            growth_per_min: 0.0,
        });
        w.add(10_000.0, 1.0); // 10 cm³
        assert!((w.factor() - 1.1).abs() < 1e-12);
        w.add(0.0, 60.0); // air: no wear
        assert!((w.cut_time_min - 1.0 / 60.0).abs() < 1e-12);
    }

    #[test]
    fn wear_exponent_bends_the_curve() {
        let spec = |p: f64| WearSpec {
            growth_per_cm3: 0.01,
            volume_exponent: p,
            ..WearSpec::default()
        };
        // At 1 cm³ every exponent gives the same growth; at 4 cm³ a break-in law (p = ½)
        // has grown 2×, the linear law 4×, an accelerating law (p = 2) 16×.
        for p in [0.5, 1.0, 2.0] {
            assert!((spec(p).factor(1.0, 0.0) - 1.01).abs() < 1e-12);
        }
        assert!((spec(0.5).factor(4.0, 0.0) - 1.02).abs() < 1e-12);
        assert!((spec(1.0).factor(4.0, 0.0) - 1.04).abs() < 1e-12);
        assert!((spec(2.0).factor(4.0, 0.0) - 1.16).abs() < 1e-12);
        let f = std::path::Path::new("tool.toml");
        let err = spec(5.0)
            .validate(f, "wear")
            .expect_err("out of range")
            .to_string();
        assert!(
            err.contains("wear.volume_exponent") && err.contains("tool.toml"),
            "{err}"
        );
    }

    #[test]
    fn tooth_ratio_has_unit_mean_and_ripple() {
        let file = WorkpieceFile {
            name: "t".into(),
            axial_depth_mm: 16.0,
            segments: vec![SegmentSpec::Cut {
                length_mm: 100.0,
                depth_mm: 2.0,
                ks_factor: None,
            }],
        };
        let w = Workpiece::from_file(Path::new("t"), &file).expect("valid");
        let spec = ToothSpec {
            helix_deg: 30.0,
            axial_slices: 64,
        };
        let m = ToothModel::new(&spec, 4, 8.0, 16.0);
        let n = 4000;
        let vals: Vec<f64> = (0..n)
            .map(|k| m.ratio(2.0 * PI * k as f64 / n as f64, 10.0, &w, 2.0))
            .collect();
        let mean = vals.iter().sum::<f64>() / n as f64;
        let max = vals.iter().cloned().fold(f64::MIN, f64::max);
        let min = vals.iter().cloned().fold(f64::MAX, f64::min);
        assert!((mean - 1.0).abs() < 0.01, "mean {mean}");
        // 2 mm of a 16 mm cutter: a 41.4° engaged arc; the 30° helix spreads each flute over
        // another 66° along the 16 mm axial depth, so a flute is in the cut for 107° > the
        // 90° pitch: the force never drops to zero, but it ripples strongly.
        assert!(max > 1.2 && min > 0.05 && min < 0.5, "min {min} max {max}");
    }
}
