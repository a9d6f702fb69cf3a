//! The separating test cut of an ambiguous pair, run by the simulator's plant.
//!
//! When two candidate effects explain the same residual (the log cannot tell them apart,
//! e.g. a closed-loop feed that follows the depth), the report names the cut that would
//! separate them ([`crate::EffectKind::separating_experiment`]) and runs it here: one
//! test cut at the log's spindle speed and programmed feed — an air stretch, a
//! constant-feed pass at two depths, override steps at the larger depth, an air pause and
//! a last pass — replayed by [`acc_sim::replay`] (the simulator's `Machine::advance`)
//! under each fitted explanation. If their predictions differ by more than 5σ over the cut
//! (summed squared difference > 25 σ²), the cut separates them.

use crate::effects::EffectKind;
use crate::model::{Channel, Model};
use crate::replay::{replay, Inputs};
use crate::report::TestCut;
use crate::runlog::RunLog;

/// One stretch of the test cut: duration s, radial depth mm, override %.
const PLAN: [(f64, f64, f64); 7] = [
    (2.0, 0.0, 100.0),
    (6.0, 0.5, 100.0),
    (6.0, 1.0, 100.0),
    (4.0, 1.0, 60.0),
    (4.0, 1.0, 140.0),
    (4.0, 0.0, 100.0),
    (4.0, 1.0, 100.0),
];

/// The test-cut log on the conditions of `inp` (speed, period, programmed feed, depths).
pub fn cut_log(inp: &Inputs) -> (RunLog, String) {
    let cut: Vec<usize> = (0..inp.len()).filter(|&i| inp.is_cut(i)).collect();
    let pick = |v: &[f64], dflt: f64| {
        let x: Vec<f64> = cut.iter().map(|&i| v[i]).collect();
        if x.is_empty() {
            dflt
        } else {
            let mut x = x;
            x.sort_by(f64::total_cmp);
            x[x.len() / 2]
        }
    };
    let rpm = pick(&inp.spindle_rpm, 1000.0);
    let axial = pick(&inp.axial_depth_mm, 1.0);
    let d_hi = cut
        .iter()
        .map(|&i| inp.radial_depth_mm[i])
        .fold(0.0, f64::max)
        .max(0.1);
    let prog = pick(&inp.plant.programmed_feed_mm_min, 100.0);
    let period = inp.period_s.max(1e-3);
    let mut log = RunLog {
        t_s: Vec::new(),
        x_mm: None,
        radial_depth_mm: Vec::new(),
        axial_depth_mm: Vec::new(),
        spindle_rpm: Vec::new(),
        programmed_feed_mm_min: Some(Vec::new()),
        override_cmd_pct: Some(Vec::new()),
        override_applied_pct: Some(Vec::new()),
        feed_mm_min: Vec::new(),
        force_n: Some(Vec::new()),
        power_w: Some(Vec::new()),
        wear_vb_um: None,
        phase: None,
        sample_advance: None,
        board_feed_mm_min: None,
        plant_truth: false,
        row_flags: None,
    };
    let mut t = 0.0;
    for (dur, depth, ov) in PLAN {
        let rows = (dur / period).round() as usize;
        for _ in 0..rows {
            t += period;
            log.t_s.push(t);
            let d = depth * d_hi;
            log.radial_depth_mm.push(d);
            log.axial_depth_mm.push(if d > 0.0 { axial } else { 0.0 });
            log.spindle_rpm.push(rpm);
            for (v, x) in [
                (&mut log.programmed_feed_mm_min, prog),
                (&mut log.override_cmd_pct, ov),
                (&mut log.override_applied_pct, ov),
                (&mut log.force_n, 0.0),
                (&mut log.power_w, 0.0),
            ] {
                if let Some(v) = v.as_mut() {
                    v.push(x);
                }
            }
            log.feed_mm_min.push(prog * ov / 100.0);
        }
    }
    let desc = format!(
        "at {rpm:.0} rpm and {prog:.0} mm/min programmed: 2 s air, a constant-feed pass at \
         two radial depths ({:.2} and {:.2} mm, axial {axial:.2} mm, 6 s each), override \
         steps 100 → 60 → 140 % at the larger depth (4 s each), a 4 s air pause, 4 s more \
         at the larger depth",
        0.5 * d_hi,
        d_hi
    );
    (log, desc)
}

/// Run the test cut under the two fitted explanations `a` and `b` of the pair `pair`;
/// `sigma` is the log's noise σ.
pub fn run(
    inp: &Inputs,
    a: &Model,
    b: &Model,
    pair: (EffectKind, EffectKind),
    sigma: f64,
) -> TestCut {
    run_named(inp, a, b, (pair.0.name(), pair.1.name()), sigma)
}

/// [`run`] for two explanations named in words (one of them may lie outside the
/// library, e.g. a `Ks` rising with cutting time against tool wear).
pub fn run_named(inp: &Inputs, a: &Model, b: &Model, names: (&str, &str), sigma: f64) -> TestCut {
    let (log, desc) = cut_log(inp);
    let description = format!("{}; to separate `{}` from `{}`", desc, names.0, names.1);
    let pred = |m: &Model| -> Option<Vec<f64>> {
        let mut m = m.clone();
        if m.measurement.channel == Channel::Force && m.measurement.force_estimator.is_some() {
            // The cut has no measured power to adapt the estimator's no-load on.
            if let Some(e) = m.measurement.force_estimator.as_mut() {
                e.adapt = None;
            }
        }
        let i = Inputs::from_log(&log, &m).ok()?;
        Some(replay(&m, &i).predicted)
    };
    let (pa, pb) = match (pred(a), pred(b)) {
        (Some(x), Some(y)) => (x, y),
        _ => {
            return TestCut {
                description,
                rows: log.len(),
                rms_difference: f64::NAN,
                max_difference: f64::NAN,
                noise_sigma: sigma,
                separates: false,
            }
        }
    };
    let d: Vec<f64> = pa.iter().zip(&pb).map(|(x, y)| x - y).collect();
    let ss: f64 = d.iter().map(|x| x * x).sum();
    let n = d.len().max(1) as f64;
    TestCut {
        description,
        rows: log.len(),
        rms_difference: (ss / n).sqrt(),
        max_difference: d.iter().fold(0.0, |m, x| m.max(x.abs())),
        noise_sigma: sigma,
        separates: sigma > 0.0 && ss / (sigma * sigma) > 25.0,
    }
}
