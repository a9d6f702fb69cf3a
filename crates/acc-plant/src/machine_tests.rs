//! Tests of [`crate::machine`].
use super::*;
use crate::config::NoloadDrift;
use crate::configs_dir;
use crate::engagement::Engagement;

/// Reported period-mean power of the paper machine over `periods` 0.1 s periods of
/// `workpieces/steps_1_2_3.toml` (air, then cutting), with the given spindle low-pass.
fn reported_power(lowpass: Option<SensorLowpass>, periods: usize) -> Vec<f64> {
    let dir = configs_dir();
    let mut spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    spec.spindle.sensor_lowpass = lowpass;
    let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
    let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece");
    let mut m = Machine::new(&spec, &tool, tool.wear, wp, ForceModel::Mean, 200.0);
    (0..periods).map(|_| m.advance(0.1).power_mean_w).collect()
}

/// Internal samples (t, force) of the paper machine cutting `steps_1_2_3.toml` for 10 s.
fn force_samples(runout: Option<Runout>) -> Vec<(f64, f64)> {
    let dir = configs_dir();
    let spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    let mut tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
    tool.runout = runout;
    let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece");
    let mut m = Machine::new(&spec, &tool, tool.wear, wp, ForceModel::Mean, 200.0);
    let mut out = Vec::new();
    for _ in 0..100 {
        let rec = m.advance(0.1);
        out.extend(rec.samples.iter().map(|s| (s.t_s, s.force_n)));
    }
    out
}

/// Feed (period means) after an override step 0 → 100 % at t = 0 in air, with the
/// drive's second lag `tau2_s`.
fn feed_step(tau2_s: f64) -> Vec<f64> {
    let dir = configs_dir();
    let mut spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    spec.feed_drive.tau2_s = tau2_s;
    let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
    let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece");
    let mut m = Machine::new(&spec, &tool, tool.wear, wp, ForceModel::Mean, 200.0);
    m.set_override_input_pct(100);
    (0..20).map(|_| m.advance(0.05).feed_mean_mm_min).collect()
}

/// The NC's own ceiling: an override above it runs at the ceiling, one below it as
/// written; an out-of-range ceiling in a machine file names the key and the range.
#[test]
fn the_nc_caps_the_override_at_its_own_ceiling() {
    let dir = configs_dir();
    let run = |cap: Option<u16>, pct: u16| {
        let mut spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
        spec.override_path.nc_max_pct = cap;
        let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
        let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("wp");
        let mut m = Machine::new(&spec, &tool, tool.wear, wp, ForceModel::Mean, 200.0);
        m.set_override_input_pct(pct);
        (0..20)
            .map(|_| m.advance(0.1).feed_mean_mm_min)
            .last()
            .expect("rows")
    };
    assert!((run(None, 150) - 300.0).abs() < 1.0);
    assert!((run(Some(120), 150) - 240.0).abs() < 1.0);
    assert!((run(Some(120), 80) - 160.0).abs() < 1.0);
    let mut spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    spec.override_path.nc_max_pct = Some(5);
    let e = spec
        .validate(std::path::Path::new("m.toml"))
        .expect_err("5 %")
        .to_string();
    assert!(
        e.contains("override_path.nc_max_pct") && e.contains("m.toml"),
        "{e}"
    );
}

#[test]
fn a_second_order_drive_is_slower_and_off_at_zero() {
    let first = feed_step(0.0);
    let second = feed_step(0.1);
    // Off at 0: the first-order drive, bit for bit (the default of machine files).
    let spec = MachineSpec::load(configs_dir().join("machines/paper_vmc.toml")).expect("m");
    assert_eq!(spec.feed_drive.tau2_s, 0.0);
    // The second lag delays the rise, and both settle at the programmed feed.
    assert!(second[1] < first[1] - 5.0, "{second:?} vs {first:?}");
    assert!((second[19] - 200.0).abs() < 2.0 && (first[19] - 200.0).abs() < 1.0);
}

#[test]
fn runout_multiplies_the_force_by_its_step_mean_and_is_off_at_null() {
    let truth = force_samples(None);
    let r = Runout {
        amplitude: 0.2,
        phase_rad: 0.5,
    };
    let rip = force_samples(Some(r));
    // 600 rpm: θ(t) = 20π·t; each 1 ms step sees the mean of 1 + A·cos(θ + φ).
    let w = 600.0 / 60.0 * 2.0 * PI;
    let dt = 1e-3;
    let mut cut = 0;
    let mut spread = (f64::MAX, f64::MIN);
    for ((t, f0), (_, f1)) in truth.iter().zip(&rip) {
        if *f0 > 1.0 {
            let (a, b) = (w * (t - dt) + 0.5, w * t + 0.5);
            let want = 1.0 + 0.2 * (b.sin() - a.sin()) / (b - a);
            let ratio = f1 / f0;
            assert!((ratio - want).abs() < 1e-6, "t {t}: {ratio} vs {want}");
            spread = (spread.0.min(ratio), spread.1.max(ratio));
            cut += 1;
        }
    }
    assert!(
        cut > 1000 && spread.0 < 0.81 && spread.1 > 1.19,
        "{cut} {spread:?}"
    );
    let null = force_samples(Some(Runout {
        amplitude: 0.0,
        ..r
    }));
    assert_eq!(null, truth);
}

#[test]
fn a_hard_spot_scales_the_force_by_its_factor_until_restored() {
    let dir = configs_dir();
    let spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
    let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece");
    let mut plain = Machine::new(
        &spec,
        &tool,
        WearSpec::default(),
        wp.clone(),
        ForceModel::Mean,
        200.0,
    );
    let mut hard = Machine::new(
        &spec,
        &tool,
        WearSpec::default(),
        wp,
        ForceModel::Mean,
        200.0,
    );
    for _ in 0..150 {
        plain.advance(0.1);
        hard.advance(0.1);
    }
    hard.set_hardness_factor(2.5);
    hard.set_hardness_factor(f64::NAN); // ignored
    hard.set_hardness_factor(-1.0); // ignored
    let (p, h) = (
        plain.advance(0.1).force_mean_n,
        hard.advance(0.1).force_mean_n,
    );
    assert!(p > 100.0, "cutting: {p}");
    assert!((h / p - 2.5).abs() < 1e-9, "{h} / {p}");
    hard.set_hardness_factor(1.0);
    let (p, h) = (
        plain.advance(0.1).force_mean_n,
        hard.advance(0.1).force_mean_n,
    );
    assert!((h - p).abs() < 1e-9 * p, "{h} vs {p}");
}

#[test]
fn power_sensor_lowpass_filters_the_reported_period_means() {
    let n = 400;
    let truth = reported_power(None, n);
    let tau = 1.0;
    let lp = reported_power(Some(SensorLowpass { tau_s: tau }), n);
    // The reported series is the truth through y_k = a·y_(k−1) + (1 − a)·x_k.
    let a = (-0.1f64 / tau).exp();
    let mut y = truth[0];
    for (x, got) in truth.iter().zip(&lp) {
        y = a * y + (1.0 - a) * x;
        assert!((got - y).abs() < 1e-9, "{got} vs {y}");
    }
    // The path reaches the cut within the run: the filter had something to smooth.
    let jump = truth
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    let jump_lp = lp
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(jump > 50.0 && jump_lp < 0.5 * jump, "{jump} {jump_lp}");
    // Null τ = 0: the true means.
    assert_eq!(reported_power(Some(SensorLowpass { tau_s: 0.0 }), n), truth);
}

#[test]
fn constant_speed_spindle_drifts_with_its_own_running_time() {
    let spec = SpindleSpec {
        noload_drift: Some(NoloadDrift {
            delta_w: 200.0,
            tau_s: 50.0,
        }),
        ..SpindleSpec::new(600.0, 700.0, 0.8)
    };
    let mut s = ConstantSpeedSpindle::new(spec);
    assert_eq!(s.input_power_w(), 700.0);
    for _ in 0..100 {
        s.step(0.0, 0.5);
    }
    // 50 s = one time constant.
    let want = 700.0 + 200.0 * (1.0 - (-1.0f64).exp());
    assert!(
        (s.input_power_w() - want).abs() < 1e-9,
        "{}",
        s.input_power_w()
    );
}

/// Radial depth 4 mm throughout; the axial depth 2 mm before `at_mm`, 4 mm from it.
#[derive(Debug, Clone)]
struct AxialStep {
    at_mm: f64,
}

impl EngagementSource for AxialStep {
    fn engagement_at(&mut self, _tool: &ToolGeometry, x_mm: f64) -> Engagement {
        Engagement {
            radial_mm: 4.0,
            axial_mm: if x_mm < self.at_mm { 2.0 } else { 4.0 },
            ks_factor: 1.0,
        }
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(self.clone()))
    }
}

/// The period-mean forces of the paper machine at 100 % over 200 mm/min (1/3 mm per
/// 0.1 s period) through [`AxialStep`] at 1.0 mm, and each period's recorded axial depth.
fn axial_step_forces() -> Vec<(f64, f64)> {
    let dir = configs_dir();
    let spec = MachineSpec::load(dir.join("machines/paper_vmc.toml")).expect("machine");
    let tool = ToolSpec::load(dir.join("machines/tools/hss_endmill_16_4f.toml")).expect("tool");
    let wp = Workpiece::load(dir.join("workpieces/steps_1_2_3.toml")).expect("workpiece");
    let mut m = Machine::new(&spec, &tool, tool.wear, wp, ForceModel::Mean, 200.0);
    m.set_engagement_source(Some(Box::new(AxialStep { at_mm: 1.0 })));
    (0..8)
        .map(|_| {
            let r = m.advance(0.1);
            (r.force_mean_n, r.axial_depth_mm)
        })
        .collect()
}

#[test]
fn the_axial_depth_is_read_at_every_step() {
    let f = axial_step_forces();
    let (lo, hi) = (f[1].0, f[7].0);
    // The doubled depth doubles the force (eq. 1, α = 1).
    assert!((hi / lo - 2.0).abs() < 0.01, "{lo} → {hi}");
    // The period the step falls in cuts part of its path at each depth: its force is
    // between the two, and it records the depth at its end.
    let k = (0..8)
        .find(|&k| f[k].0 > lo * 1.01)
        .filter(|&k| k > 0)
        .expect("a period after the first crosses the step");
    assert!(f[k].0 < hi * 0.99, "{f:?}");
    assert!(f[k - 1].1 < f[k].1 && f[k].1 == f[7].1, "{f:?}");
}
