//! Calibration of the spindle's power law from the log itself, before effects are judged.
//!
//! A model's constant-efficiency spindle (`[machine.spindle]`, physics.md §2:
//! `P_in = P_air + P_c/η + c·P_c²/1000`) rarely matches the machine's motor: an induction
//! motor's input power is curved in the torque and its air-cut power is its own. Judged
//! against the wrong curve, the mismatch is "noise" many times the sensor's and hides the
//! effects the log holds. So on the power channel of a model without a motor curve
//! (`measurement.spindle_motor` absent) the workflow first sets, from the selection part
//! only (the sealed part is not looked at):
//!
//! - `no_load_power_w`: the median logged power over the air cuts (spindle turning, no
//!   cutting power replayed in the row and the row before);
//! - `efficiency` `η` and `motor_efficiency.copper_loss_per_kw` `c`: linear least squares
//!   of `P − P_air = P_c/η + c·P_c²/1000` over the cutting rows, with `P_c` the cutting
//!   power the model replays at its own `Ks` (held: a wear or a material change moves the
//!   logged power away from the model's `P_c`, which the curve in `P_c` cannot follow along
//!   the cut, so the effect stays for the search to name). With too narrow a spread of
//!   load levels (coefficient of variation of `P_c` under [`MIN_LOAD_SPREAD`]) only `η`
//!   is fitted;
//! - `measurement.power_window_s`: the averaging window of the power channel at the end of
//!   each period, the one of [`WINDOW_FRACTIONS`] (of the period; 0 = the whole period)
//!   and the model's own whose calibrated curve leaves the least residual — a channel that
//!   reads the last part of each period sees the feed's transients later than the period
//!   mean.
//!
//! The calibrated spindle replaces the model's only when the model's clearly does not
//! match: its residual over the cutting rows is above [`MISMATCH_RATIO`] times the
//! calibrated curve's ([`calibrate`]), and it inflates the noise σ above [`NOISE_RATIO`]
//! times the calibrated one's ([`inflates_noise`], judged by the workflow on both nominal
//! residuals). A mismatch the noise does not see stays for the nominal refit (a level, a
//! scale) and the effect search (a copper loss is `motor_efficiency`), and effects in a
//! matching spindle (a wear, a no-load drift) are not taken into the curve.

use crate::effects::MotorEfficiency;
use crate::model::{Channel, Model};
use crate::replay::{replay, Inputs, Replay};
use crate::report::SpindleCalibration;

/// Air-cut rows needed to set the no-load power.
pub const MIN_AIR_ROWS: usize = 5;
/// Cutting rows needed to fit the efficiency.
pub const MIN_CUT_ROWS: usize = 20;
/// Smallest coefficient of variation of the replayed cutting power over the cutting rows
/// for which the copper-loss curvature is fitted, −.
pub const MIN_LOAD_SPREAD: f64 = 0.02;
/// The model's spindle is recalibrated only when its residual over the cutting rows
/// exceeds the calibrated curve's by this factor, −.
pub const MISMATCH_RATIO: f64 = 10.0;
/// The calibrated spindle is adopted only when the model's inflates the noise: the noise σ
/// of the nominal residual with the model's spindle exceeds this factor times the σ with
/// the calibrated one, −. A mismatch that the noise does not see (a copper loss, a level,
/// a scale) is left to the effect search and the nominal refit. Measured (dev build):
/// the simulator's induction motor against a constant-efficiency model
/// (`examples/twin_lab/motor_mismatch.rs`, seed 1000) 4.59 → 0.96 W on the null log, 8.97 →
/// 1.15 W with wear 0.01/cm³; a hidden copper loss at ENR 4 (`examples/twin_lab/one.rs`
/// `motor_efficiency 4 0 11` and `4 0.6 12`) 9.94 → 8.05 and 12.02 → 8.45 W; a matching
/// spindle with a wear and a no-load drift at ENR 6 each
/// (`tests/twin/ident_null_and_pairs.rs`, seed 21) 9.48 → 11.30 W.
pub const NOISE_RATIO: f64 = 2.0;
/// Averaging windows of the power channel tried, fractions of the control period (0: the
/// whole period), −.
pub const WINDOW_FRACTIONS: [f64; 10] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9];

/// A spindle curve fitted on one replay: `P = P_air + b·P_c + c·P_c²/1000`.
struct Curve {
    p_air: f64,
    air_rows: usize,
    b: f64,
    c: Option<f64>,
    c_used: f64,
    cut_rows: usize,
    rms_before: f64,
    /// With the calibrated curve alone, W.
    rms_after: f64,
    /// With the curve and the wear signature (what the window is chosen by), W.
    rms_fit: f64,
}

/// The curve of `model`'s replay `nominal` over the selection rows `sel`; `None` with fewer
/// than [`MIN_CUT_ROWS`] cutting rows.
fn fit_curve(model: &Model, inp: &Inputs, nominal: &Replay, sel: &[usize]) -> Option<Curve> {
    let sp = &model.machine.spindle;
    let pc = &nominal.cut_power_w;
    let on = |i: usize| inp.spindle_rpm[i] > 0.0 && inp.measured[i].is_finite();
    let mut air: Vec<f64> = sel
        .iter()
        .filter(|&&i| on(i) && pc[i] == 0.0 && (i == 0 || pc[i - 1] == 0.0))
        .map(|&i| inp.measured[i])
        .collect();
    let air_rows = if air.len() >= MIN_AIR_ROWS {
        air.len()
    } else {
        0
    };
    let p_air = if air_rows > 0 {
        air.sort_by(f64::total_cmp);
        air[air.len() / 2]
    } else {
        sp.no_load_power_w
    };
    let cut: Vec<usize> = sel
        .iter()
        .copied()
        .filter(|&i| on(i) && pc[i] > 0.0)
        .collect();
    if cut.len() < MIN_CUT_ROWS {
        return None;
    }
    // Regressors: P_c, P_c²/1000 and the wear signature P_c·V (V the removed volume, cm³):
    // the last is fitted and then dropped, so that a Ks growing with the removed volume
    // is not taken into the curve but left for the search to name.
    let x: Vec<[f64; 3]> = cut
        .iter()
        .map(|&i| {
            [
                pc[i],
                pc[i] * pc[i] / 1000.0,
                pc[i] * nominal.volume_mm3[i] / 1000.0,
            ]
        })
        .collect();
    let y: Vec<f64> = cut.iter().map(|&i| inp.measured[i] - p_air).collect();
    let n = x.len() as f64;
    let mean = x.iter().map(|r| r[0]).sum::<f64>() / n;
    let sd = (x.iter().map(|r| (r[0] - mean).powi(2)).sum::<f64>() / n).sqrt();
    let c0 = sp.motor_efficiency.map_or(0.0, |e| e.copper_loss_per_kw);
    let curved = sd > MIN_LOAD_SPREAD * mean;
    // Without the curvature, the model's copper loss is kept and the two others fitted.
    let fixed_c = if curved { None } else { Some(c0) };
    let mut k = least_squares(&x, &y, [None, fixed_c, None])?;
    if k[0] < 1.0 {
        // η above 1: the bound η = 1 is the constrained optimum (a convex problem).
        k = least_squares(&x, &y, [Some(1.0), fixed_c, None])?;
    }
    let (b, c, g) = (k[0], curved.then_some(k[1]), k[2]);
    let c_used = c.unwrap_or(c0);
    let curve = |i: usize| p_air + b * pc[i] + c_used * pc[i] * pc[i] / 1000.0;
    let rms = |f: &dyn Fn(usize) -> f64| {
        (cut.iter()
            .map(|&i| (inp.measured[i] - f(i)).powi(2))
            .sum::<f64>()
            / cut.len() as f64)
            .sqrt()
    };
    Some(Curve {
        p_air,
        air_rows,
        b,
        c,
        c_used,
        cut_rows: cut.len(),
        rms_before: rms(&|i| nominal.predicted[i]),
        rms_after: rms(&curve),
        rms_fit: rms(&|i| curve(i) + g * pc[i] * nominal.volume_mm3[i] / 1000.0),
    })
}

/// Least squares of `y` on the columns of `x`, the coefficients given in `fixed` held
/// (their columns' share taken from `y` first); `None` when the system is singular.
fn least_squares(x: &[[f64; 3]], y: &[f64], fixed: [Option<f64>; 3]) -> Option<[f64; 3]> {
    let free: Vec<usize> = (0..3).filter(|&j| fixed[j].is_none()).collect();
    let yk: Vec<f64> = x
        .iter()
        .zip(y)
        .map(|(r, y)| y - (0..3).map(|j| fixed[j].unwrap_or(0.0) * r[j]).sum::<f64>())
        .collect();
    // The free columns' normal equations in the 3×3 solver (identity rows for the rest).
    let mut a = [[0.0; 3]; 3];
    let mut t = [0.0; 3];
    for (j, &cj) in free.iter().enumerate() {
        for (k, &ck) in free.iter().enumerate() {
            a[j][k] = x.iter().map(|r| r[cj] * r[ck]).sum();
        }
        t[j] = x.iter().zip(&yk).map(|(r, y)| r[cj] * y).sum();
    }
    for (j, row) in a.iter_mut().enumerate().skip(free.len()) {
        row[j] = 1.0;
    }
    let sol = crate::stats::solve3(a, t)?;
    let mut out = fixed.map(|f| f.unwrap_or(0.0));
    for (j, &cj) in free.iter().enumerate() {
        out[cj] = sol[j];
    }
    Some(out)
}

/// The model with its spindle calibrated on the selection rows `sel` of `inp`, given the
/// model's replay `nominal`; `None` when the calibration does not apply (force channel, a
/// motor curve in the model), the log has too few cutting rows, or the fit falls outside
/// the machine file's ranges (`spindle.efficiency` 0.05 ..= 1,
/// `spindle.motor_efficiency.copper_loss_per_kw` [`MotorEfficiency::COPPER_LOSS_RANGE`]).
pub(super) fn calibrate(
    model: &Model,
    inp: &Inputs,
    nominal: &Replay,
    sel: &[usize],
) -> Option<(Model, SpindleCalibration)> {
    if inp.channel != Channel::Power || model.measurement.spindle_motor.is_some() {
        return None;
    }
    let w0 = model.measurement.power_window_s;
    let mut best: Option<(f64, Curve)> = fit_curve(model, inp, nominal, sel).map(|c| (w0, c));
    for f in WINDOW_FRACTIONS {
        // Rounded to the µs: the window is written to the updated model.
        let w = (f * inp.period_s * 1e6).round() / 1e6;
        if (w - w0).abs() < 1e-9 {
            continue;
        }
        let mut m = model.clone();
        m.measurement.power_window_s = w;
        let Some(c) = fit_curve(&m, inp, &replay(&m, inp), sel) else {
            continue;
        };
        if best.as_ref().is_none_or(|(_, b)| c.rms_fit < b.rms_fit) {
            best = Some((w, c));
        }
    }
    let (window, curve) = best?;
    let eta = 1.0 / curve.b;
    let (lo, hi) = MotorEfficiency::COPPER_LOSS_RANGE;
    if !(0.05..=1.0).contains(&eta) || curve.c.is_some_and(|c| !(lo..=hi).contains(&c)) {
        return None;
    }
    let sp = &model.machine.spindle;
    let mut m = model.clone();
    m.measurement.power_window_s = window;
    let s = &mut m.machine.spindle;
    s.no_load_power_w = curve.p_air;
    s.efficiency = eta;
    if curve.c.is_some() {
        s.motor_efficiency = Some(MotorEfficiency {
            copper_loss_per_kw: curve.c_used,
        });
    }
    let before = fit_curve(model, inp, nominal, sel).map_or(curve.rms_before, |c| c.rms_before);
    // Only a spindle that clearly does not match is recalibrated: one whose curve misses
    // the cutting rows by more than [`MISMATCH_RATIO`] times what the calibrated curve
    // leaves; a model that matches within its effects is judged as given (a copper loss
    // or a drift in it stays an effect to name).
    if before < MISMATCH_RATIO * curve.rms_fit {
        return None;
    }
    Some((
        m,
        SpindleCalibration {
            no_load_power_w: (sp.no_load_power_w, curve.p_air),
            efficiency: (sp.efficiency, eta),
            copper_loss_per_kw: (
                sp.motor_efficiency.map_or(0.0, |e| e.copper_loss_per_kw),
                curve.c,
            ),
            power_window_s: (w0, window),
            air_rows: curve.air_rows,
            cut_rows: curve.cut_rows,
            residual_rms_w: (before, curve.rms_after),
            residual_rms_with_wear_w: curve.rms_fit,
            // Measured by the workflow on both nominal residuals ([`inflates_noise`]).
            noise_sigma: (f64::NAN, f64::NAN),
        },
    ))
}

/// Whether the model's spindle inflates the noise beyond [`NOISE_RATIO`] times the
/// calibrated one's (`c.noise_sigma`, as the workflow measured them): the condition for
/// adopting the calibration.
pub(super) fn inflates_noise(c: &SpindleCalibration) -> bool {
    c.noise_sigma.0 > NOISE_RATIO * c.noise_sigma.1
}
