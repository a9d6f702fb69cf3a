//! `acc stability <preset> [--plot out.svg]`: closed-loop poles, damping, the Kc ratio
//! margin of the adaptive gains and the fixed-gain stable range of a controller preset
//! (seed 002: characteristic polynomial of eqs. 4 + 6, pole assignment eq. 14; physics.md §1).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use acc_config::{load_preset, Preset};
use acc_core::delay::{delay_margin_periods, delay_poles, DECAY_RADIUS};
use acc_core::poles::{assign, assign_integral, PiGains};
use acc_core::stability::spectral_radius;
use acc_core::stability::{
    bisect_boundary, describe_pole, fixed_gain_stable_range, integral_kc_ratio_margin,
    integral_pole, kc_ratio_margin, pi_poles, Pole, PoleInfo, StableRange,
};
use acc_core::{DesiredPoles, ModeConfig};
use acc_plot::{unit_circle, xy_chart, Series, Style, Written, XyChart};
use anyhow::Context as _;

/// Arguments of `acc stability`.
#[derive(Debug, clap::Args)]
pub struct StabilityArgs {
    /// Controller preset: a file, or a name in configs/presets (e.g. `case1`).
    pub preset: String,
    /// Draw the pole map to this SVG file (a PNG is written next to it).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<PathBuf>,
}

/// The paper's fixed gains (seed 002): Kp = 0.05 (mm/min)/N, Ki = 2.5 (mm/min)/(N·s).
const PAPER_FIXED: PiGains = PiGains { kp: 0.05, ki: 2.5 };

/// Points per swept pole path.
const SWEEP_POINTS: usize = 600;

/// Everything `acc stability` reports about one preset.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// The preset.
    pub preset: Preset,
    /// Gains at Kc_hat = Kc_nominal (the preset's own for fixed-gain).
    pub gains: PiGains,
    /// Closed-loop poles with Kc = Kc_hat = Kc_nominal.
    pub poles: Vec<PoleInfo>,
    /// Range of Kc / Kc_hat that keeps the adaptive loop stable (`None` for fixed gains).
    pub ratio_margin: Option<StableRange>,
    /// Stable range of Km·Kc with the gains frozen at Kc_hat = Kc_nominal.
    pub frozen_range: StableRange,
    /// Stable range of Km·Kc of the paper's fixed-gain controller.
    pub paper_fixed_range: StableRange,
    /// Poles at Kc = factor · Kc_nominal with the gains frozen: (Kc, poles).
    pub frozen_table: Vec<(f64, Vec<PoleInfo>)>,
    /// Extra periods of dead time the loop tolerates at Kc = Kc_hat = Kc_nominal (every pole
    /// inside [`DECAY_RADIUS`]; `None`: not even without extra delay).
    pub delay_margin: Option<u32>,
    /// Largest pole magnitude with 0 ..= 3 extra periods of dead time.
    pub delay_radii: Vec<(u32, f64)>,
}

/// Gains of the preset's mode at Kc_hat (eq. 14, conclusion 5, or the fixed ones).
fn gains_at(mode: ModeConfig, km: f64, kc_hat: f64, period_s: f64) -> anyhow::Result<PiGains> {
    Ok(match mode {
        ModeConfig::AdaptivePi { poles } => assign(poles, km, kc_hat, period_s)?,
        ModeConfig::FixedPi { kp, ki } => PiGains { kp, ki },
        ModeConfig::AdaptiveIntegral { pole } => PiGains {
            kp: 0.0,
            ki: assign_integral(pole, km, kc_hat, period_s)?,
        },
    })
}

/// Closed-loop poles for gains at plant gain `g = Km·Kc` (one pole for integral-only).
fn loop_poles(gains: PiGains, integral_only: bool, g: f64, period_s: f64) -> Vec<Pole> {
    if integral_only {
        vec![integral_pole(gains.ki, g, period_s)]
    } else {
        pi_poles(gains.kp, gains.ki, g, period_s).to_vec()
    }
}

/// Analyse a loaded preset.
pub fn analyse(preset: Preset) -> anyhow::Result<Analysis> {
    let c = &preset.controller;
    let t = c.period_s;
    let kc0 = preset.plant.kc_nominal;
    let integral_only = matches!(c.mode, ModeConfig::AdaptiveIntegral { .. });
    let gains = gains_at(c.mode, c.km, kc0, t)?;
    let describe = |ps: Vec<Pole>| ps.into_iter().map(|z| describe_pole(z, t)).collect();
    let poles = describe(loop_poles(gains, integral_only, c.km * kc0, t));
    let ratio_margin = match c.mode {
        ModeConfig::AdaptivePi { poles } => Some(kc_ratio_margin(poles)?),
        ModeConfig::AdaptiveIntegral { pole } => Some(integral_kc_ratio_margin(pole)?),
        ModeConfig::FixedPi { .. } => None,
    };
    let frozen_range = if integral_only {
        // Pole 1 − g·Ki·T: stable for 0 < g < 2/(Ki·T).
        let analytic_max = 2.0 / (gains.ki * t);
        let radius = |g: f64| integral_pole(gains.ki, g, t).norm();
        let numeric_max = bisect_boundary(radius, 1e-3 * analytic_max, 10.0 * analytic_max);
        StableRange {
            analytic_max,
            numeric_max,
        }
    } else {
        fixed_gain_stable_range(gains.kp, gains.ki, t)?
    };
    let paper_fixed_range = fixed_gain_stable_range(PAPER_FIXED.kp, PAPER_FIXED.ki, t)?;
    let frozen_table = [0.5, 1.0, 1.5, 2.0]
        .iter()
        .map(|f| {
            let kc = f * kc0;
            (kc, describe(loop_poles(gains, integral_only, c.km * kc, t)))
        })
        .collect();
    let g0 = c.km * kc0;
    let delay_margin = delay_margin_periods(gains.kp, gains.ki, g0, t);
    let delay_radii = (0..=3)
        .map(|d| {
            (
                d,
                spectral_radius(&delay_poles(gains.kp, gains.ki, g0, t, d)),
            )
        })
        .collect();
    Ok(Analysis {
        preset,
        gains,
        poles,
        ratio_margin,
        frozen_range,
        paper_fixed_range,
        frozen_table,
        delay_margin,
        delay_radii,
    })
}

fn fmt_pole(p: &PoleInfo) -> String {
    let z = if p.z.im.abs() < 1e-12 {
        format!("{:+.4}", p.z.re)
    } else {
        format!(
            "{:+.4} {} {:.4}j",
            p.z.re,
            if p.z.im < 0.0 { '-' } else { '+' },
            p.z.im.abs()
        )
    };
    let wn = if p.natural_freq_rad_s.is_finite() {
        format!("{:8.2} rad/s", p.natural_freq_rad_s)
    } else {
        "     inf rad/s".to_string()
    };
    format!(
        "{z:<22} |z| = {:.4}  damping = {:+.3}  wn = {wn}",
        p.magnitude, p.damping
    )
}

/// Six significant digits, in exponent form below 1e-3.
fn sig(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 {
        format!("{v:.5e}")
    } else {
        format!("{v:.6}")
    }
}

fn mode_text(mode: ModeConfig) -> String {
    match mode {
        ModeConfig::AdaptivePi {
            poles: DesiredPoles::Real(a, b),
        } => {
            format!("adaptive PI, desired poles {a}, {b} (eq. 14)")
        }
        ModeConfig::AdaptivePi {
            poles: DesiredPoles::Complex { re, im },
        } => {
            format!("adaptive PI, desired poles {re} ± {im}j (eq. 14)")
        }
        ModeConfig::FixedPi { kp, ki } => format!("fixed-gain PI, Kp = {kp}, Ki = {ki} (eq. 4)"),
        ModeConfig::AdaptiveIntegral { pole } => {
            format!("adaptive integral-only, desired pole {pole} (conclusion 5)")
        }
    }
}

/// The text report.
pub fn render(a: &Analysis) -> String {
    let p = &a.preset;
    let c = &p.controller;
    let kc0 = p.plant.kc_nominal;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "preset      {} — {} ({})",
        p.name,
        p.description,
        p.file.display()
    );
    let _ = writeln!(s, "mode        {}", mode_text(c.mode));
    let _ = writeln!(
        s,
        "loop        T = {} s, Fr = {} N, Km = {}, nominal Kc = {kc0} N/(mm/min) at {} mm/min",
        c.period_s, c.force_ref_n, c.km, p.plant.nominal_feed_mm_min
    );
    let _ = writeln!(
        s,
        "gains       Kp = {} (mm/min)/N, Ki = {} (mm/min)/(N·s) at Kc_hat = {kc0}",
        sig(a.gains.kp),
        sig(a.gains.ki)
    );
    let _ = writeln!(s, "\nclosed-loop poles at Kc = Kc_hat = {kc0}:");
    for pole in &a.poles {
        let _ = writeln!(s, "  {}", fmt_pole(pole));
    }
    match a.ratio_margin {
        Some(m) => {
            let _ = writeln!(
                s,
                "\nKc ratio margin: stable for 0 < Kc/Kc_hat < {:.6} (Jury; numeric {:.6}), i.e. \
                 the true Kc may exceed the estimate by {:.1} %",
                m.analytic_max,
                m.numeric_max,
                100.0 * (m.analytic_max - 1.0)
            );
        }
        None => {
            let _ = writeln!(s, "\nKc ratio margin: n/a (fixed gains do not use Kc_hat)");
        }
    }
    let radii: Vec<String> = a
        .delay_radii
        .iter()
        .map(|(d, r)| format!("+{d}: {r:.4}"))
        .collect();
    let margin = match a.delay_margin {
        Some(m) => format!(
            "{m} extra period(s) of dead time ({:.1} s)",
            f64::from(m) * c.period_s
        ),
        None => "none: the loop is not stable even without extra delay".into(),
    };
    let _ = writeln!(
        s,
        "delay margin: {margin} beyond the design's one period, every pole inside \
         {DECAY_RADIUS} (largest pole by extra delay: {}); acc run measures the line's delay \
         every period and holds the feed when it exceeds the margin of the gains in use",
        radii.join(", ")
    );
    let frozen = if a.ratio_margin.is_some() {
        "gains frozen at Kc_hat"
    } else {
        "fixed gains"
    };
    let _ = writeln!(
        s,
        "fixed-gain stable range ({frozen}): 0 < Km·Kc < {:.6} N/(mm/min) (Jury; numeric {:.6})",
        a.frozen_range.analytic_max, a.frozen_range.numeric_max
    );
    let _ = writeln!(
        s,
        "paper fixed gains Kp = 0.05, Ki = 2.5: 0 < Km·Kc < 2/(2Kp + Ki·T) = {:.6} (numeric {:.6})",
        a.paper_fixed_range.analytic_max, a.paper_fixed_range.numeric_max
    );
    let _ = writeln!(s, "\npoles with the {frozen} over the process gain:");
    for (kc, poles) in &a.frozen_table {
        let radius = poles.iter().map(|p| p.magnitude).fold(0.0, f64::max);
        let verdict = if radius < 1.0 { "stable" } else { "UNSTABLE" };
        let _ = writeln!(s, "  Kc = {kc:6.3}: {verdict}");
        for pole in poles {
            let _ = writeln!(s, "      {}", fmt_pole(pole));
        }
    }
    s
}

/// Sorted pole branches along a geometric Kc sweep: (Kc, [upper/right, lower/left]).
fn sweep(
    gains: PiGains,
    integral_only: bool,
    km: f64,
    t: f64,
    lo: f64,
    hi: f64,
) -> Vec<Vec<(f64, f64)>> {
    let mut branches = vec![Vec::with_capacity(SWEEP_POINTS); if integral_only { 1 } else { 2 }];
    let ratio = (hi / lo).powf(1.0 / (SWEEP_POINTS - 1) as f64);
    for k in 0..SWEEP_POINTS {
        let kc = lo * ratio.powi(i32::try_from(k).unwrap_or(i32::MAX));
        let mut ps = loop_poles(gains, integral_only, km * kc, t);
        // Upper half-plane first; real pairs: right one first.
        ps.sort_by(|a, b| b.im.total_cmp(&a.im).then(b.re.total_cmp(&a.re)));
        for (branch, z) in branches.iter_mut().zip(ps) {
            // Cut the path where it runs far off the map.
            let pt = if z.norm() <= 2.5 {
                (z.re, z.im)
            } else {
                (f64::NAN, f64::NAN)
            };
            branch.push(pt);
        }
    }
    branches
}

/// Where a swept path leaves the unit circle: the poles on the circle at the boundary
/// plant gain `g_max = Km·Kc`.
fn boundary_points(gains: PiGains, integral_only: bool, t: f64, g_max: f64) -> Vec<(f64, f64)> {
    loop_poles(gains, integral_only, g_max, t)
        .into_iter()
        .filter(|z| (z.norm() - 1.0).abs() < 1e-6)
        .map(|z| (z.re, z.im))
        .collect()
}

/// Draw the pole map: unit circle, desired poles, and the pole paths over the swept Kc of
/// the fixed-gain controllers (the preset's gains frozen at Kc_hat = Kc_nominal, and the
/// paper's Kp = 0.05, Ki = 2.5), with the points where they leave the circle.
pub fn plot(a: &Analysis, out: &Path) -> anyhow::Result<Written> {
    let p = &a.preset;
    let c = &p.controller;
    let (t, km) = (c.period_s, c.km);
    let [lo, hi] = p.plant.kc_sweep;
    let integral_only = matches!(c.mode, ModeConfig::AdaptiveIntegral { .. });
    let mut series = vec![unit_circle(240)];
    let kc0 = p.plant.kc_nominal;
    let ticks = [0.5, 1.0, 1.5, 2.0].map(|f| f * kc0);
    let mut add_paths = |name: String,
                         gains: PiGains,
                         integral_only: bool,
                         g_max: f64,
                         color,
                         label_style: Style| {
        for (k, branch) in sweep(gains, integral_only, km, t, lo, hi)
            .into_iter()
            .enumerate()
        {
            let label = if k == 0 { name.clone() } else { String::new() };
            series.push(Series::line(label, branch).with_color(color));
        }
        let at_ticks: Vec<(f64, f64)> = ticks
            .iter()
            .flat_map(|kc| loop_poles(gains, integral_only, km * kc, t))
            .filter(|z| z.norm() <= 2.5)
            .map(|z| (z.re, z.im))
            .collect();
        let tick_names: Vec<String> = ticks.iter().map(|k| format!("{k}")).collect();
        series.push(
            Series::markers(format!("  at Kc = {}", tick_names.join(", ")), at_ticks)
                .with_color(color),
        );
        // Which marker is which Kc: the value written next to each (both paths often lie on
        // the real axis, one over the other).
        for (kc, name) in ticks.iter().zip(&tick_names) {
            let at: Vec<(f64, f64)> = loop_poles(gains, integral_only, km * kc, t)
                .into_iter()
                .filter(|z| z.norm() <= 2.5)
                .map(|z| (z.re, z.im))
                .collect();
            series.push(
                Series::markers(name.clone(), at)
                    .with_color(color)
                    .with_style(label_style),
            );
        }
        let exits = boundary_points(gains, integral_only, t, g_max);
        if !exits.is_empty() {
            let label = format!("  leaves the circle at Kc = {:.3}", g_max / km);
            series.push(Series::markers(label, exits).with_color((0, 0, 0)));
        }
    };
    let paper_name = format!("paper fixed gains Kp = 0.05, Ki = 2.5, Kc {lo} … {hi}");
    match c.mode {
        ModeConfig::FixedPi { .. } => add_paths(
            format!(
                "fixed gains Kp = {}, Ki = {}, Kc {lo} … {hi}",
                a.gains.kp, a.gains.ki
            ),
            a.gains,
            false,
            a.frozen_range.numeric_max,
            (213, 94, 0),
            Style::Text,
        ),
        _ => {
            add_paths(
                paper_name,
                PAPER_FIXED,
                false,
                a.paper_fixed_range.numeric_max,
                (213, 94, 0),
                Style::Text,
            );
            add_paths(
                format!("gains frozen at Kc_hat = {kc0}, Kc {lo} … {hi}"),
                a.gains,
                integral_only,
                a.frozen_range.numeric_max,
                (0, 114, 178),
                Style::TextBelow,
            );
        }
    }
    let desired: Vec<(f64, f64)> = match c.mode {
        ModeConfig::AdaptivePi { poles } => poles.as_pairs().to_vec(),
        ModeConfig::AdaptiveIntegral { pole } => vec![(pole, 0.0)],
        ModeConfig::FixedPi { .. } => a.poles.iter().map(|p| (p.z.re, p.z.im)).collect(),
    };
    let desired_name = match c.mode {
        ModeConfig::FixedPi { .. } => format!("poles at nominal Kc = {kc0}"),
        _ => "desired poles (Kc_hat = Kc)".to_string(),
    };
    series.push(
        Series::markers(desired_name, desired)
            .with_color((0, 158, 115))
            .with_style(Style::Markers),
    );
    let chart = XyChart {
        title: format!("Pole map — {} ({})", p.name, mode_text(c.mode)),
        x_label: "Re z".into(),
        y_label: "Im z".into(),
        series,
        equal_aspect: true,
        width_px: 900,
        height_px: 800,
        ..XyChart::default()
    };
    Ok(xy_chart(&chart, out)?)
}

/// Run `acc stability`.
pub fn run(args: &StabilityArgs) -> anyhow::Result<()> {
    let path = crate::configs::find("presets", &args.preset);
    let preset = load_preset(&path)?;
    let analysis = analyse(preset).with_context(|| format!("analysing {}", path.display()))?;
    print!("{}", render(&analysis));
    if let Some(out) = &args.plot {
        let w = plot(&analysis, out)?;
        println!("\npole map: {} and {}", w.svg.display(), w.png.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn preset(name: &str) -> Preset {
        load_preset(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("../../configs/presets/{name}.toml")),
        )
        .unwrap()
    }

    #[test]
    fn fixed_gain_report_shows_the_paper_boundary_and_3mm_instability() {
        let a = analyse(preset("fixed_gain")).unwrap();
        assert!(a.ratio_margin.is_none());
        assert!((a.frozen_range.analytic_max - 2.0 / 0.35).abs() < 1e-12);
        assert!((a.frozen_range.numeric_max - 2.0 / 0.35).abs() < 1e-6);
        // Kc = 2, 4 stable (1 and 2 mm); 6, 8 unstable (3 and 4 mm).
        let stable: Vec<bool> = a
            .frozen_table
            .iter()
            .map(|(_, ps)| ps.iter().all(|p| p.magnitude < 1.0))
            .collect();
        assert_eq!(stable, [true, true, false, false]);
        let text = render(&a);
        assert!(text.contains("0 < Km·Kc < 5.714286"), "{text}");
        assert!(text.contains("UNSTABLE"));
    }

    #[test]
    fn adaptive_reports_desired_poles_and_ratio_margin() {
        for (name, poles, margin) in [
            ("case1", [0.2, -0.05], 2.0 / 0.86),
            ("case2", [0.1, -0.6], 2.0 / 1.56),
            ("case3", [0.001, -0.001], 2.0 / (1.0 + 1e-6)),
        ] {
            let a = analyse(preset(name)).unwrap();
            let mut got: Vec<f64> = a.poles.iter().map(|p| p.z.re).collect();
            got.sort_by(f64::total_cmp);
            assert!(
                (got[0] - poles[1]).abs() < 1e-9 && (got[1] - poles[0]).abs() < 1e-9,
                "{name}: {got:?}"
            );
            let m = a.ratio_margin.unwrap();
            assert!(
                (m.analytic_max - margin).abs() < 1e-9,
                "{name}: {}",
                m.analytic_max
            );
            assert!((m.numeric_max - margin).abs() < 1e-9);
            // Gains frozen at Kc_hat = 4: the Km·Kc range is the ratio margin times 4.
            assert!((a.frozen_range.analytic_max - 4.0 * margin).abs() < 1e-9);
            assert!(render(&a).contains("Kc ratio margin: stable for 0 < Kc/Kc_hat <"));
        }
    }

    #[test]
    fn the_delay_margin_of_each_paper_preset() {
        for (name, margin) in [("case1", Some(1)), ("case2", Some(0)), ("case3", Some(0))] {
            let a = analyse(preset(name)).expect("analysed");
            assert_eq!(a.delay_margin, margin, "{name}");
            assert!(render(&a).contains("delay margin: "));
        }
        // Case III with one extra period: a pole on the unit circle.
        let a = analyse(preset("case3")).expect("analysed");
        assert!(
            (a.delay_radii[1].1 - 1.0).abs() < 1e-3,
            "{:?}",
            a.delay_radii
        );
    }

    #[test]
    fn complex_pair_with_negative_kp_is_analysed() {
        let mut p = preset("case1");
        let poles = DesiredPoles::Complex { re: 0.5, im: 0.4 };
        p.controller.mode = ModeConfig::AdaptivePi { poles };
        let a = analyse(p).unwrap();
        assert!(a.gains.kp < 0.0, "eq. 14 gives Kp = -0.41/4");
        let m = a.ratio_margin.unwrap();
        // 1 − s − p = 1 − 1 − 0.41 < 0: only |a0| < 1 binds, r < 1/0.41.
        assert!((m.analytic_max - 1.0 / 0.41).abs() < 1e-9);
        assert!((a.frozen_range.analytic_max - 4.0 / 0.41).abs() < 1e-9);
        let text = render(&a);
        assert!(text.contains("+0.5000 + 0.4000j"), "{text}");
    }

    #[test]
    fn pole_map_writes_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("acc-stability-{}", std::process::id()));
        let a = analyse(preset("case2")).unwrap();
        let w = plot(&a, &dir.join("poles.svg")).unwrap();
        let svg = std::fs::read_to_string(&w.svg).unwrap();
        assert!(svg.contains("desired poles"));
        assert!(
            svg.contains("leaves the circle at Kc = 5.714"),
            "paper gains exit"
        );
        assert!(
            svg.contains("leaves the circle at Kc = 5.128"),
            "case II frozen gains exit"
        );
        assert!(svg.contains("at Kc = 2, 4, 6, 8"));
        // Each marker carries its Kc in the path's colour (paper gains orange, frozen blue).
        for color in ["#D55E00", "#0072B2"] {
            for kc in ["2", "4", "6", "8"] {
                let label = format!("fill=\"{color}\">\n{kc}\n</text>");
                assert!(svg.contains(&label), "no label {kc} in {color}");
            }
        }
        let png = std::fs::read(&w.png).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert!(png.len() > 20_000);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
