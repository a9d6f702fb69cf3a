//! Least-squares fitting of a model's free parameters on a subset of a log's rows:
//! a grid over delays and time constants first, then Levenberg–Marquardt (the
//! `levenberg-marquardt` crate, a port of MINPACK's `lmder`) on everything, with
//! confidence intervals from the Jacobian inflated for AR(1) residuals.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use serde::Serialize;

use crate::effects::EffectKind;
use crate::model::Model;
use crate::replay::{replay_shared, Inputs};
use crate::stats::{lag1, n_eff, t_critical};

/// A free parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Free {
    /// Multiplier on `process.ks` (nominal, confusable with every load effect).
    KsScale,
    /// Offset added to `spindle.noload_power_w`, W (nominal, power channel).
    Noload,
    /// Offset added to the speed exponent `process.gamma` (nominal, when the log's spindle
    /// speed varies); `Ks` stays anchored at the calibration point.
    SpeedExponent,
    /// Parameter `i` of an effect.
    Effect(EffectKind, usize),
    /// Offset added to `tool.wear.growth_per_min`, 1/min, 0 ..= 10: a `Ks` rising with
    /// cutting time (not a library effect: the alternative the workflow sets against
    /// tool wear).
    WearPerMinute,
}

impl Free {
    /// Name in reports: `process.ks_scale`, `spindle.noload_offset_w`, `<effect>.<key>`.
    pub fn name(self) -> String {
        match self {
            Free::KsScale => "process.ks_scale".into(),
            Free::Noload => "spindle.noload_offset_w".into(),
            Free::SpeedExponent => "process.gamma_offset".into(),
            Free::Effect(k, i) => format!("{}.{}", k.name(), k.params()[i].key),
            Free::WearPerMinute => "wear.growth_per_min_offset".into(),
        }
    }

    fn bounds(self) -> (f64, f64) {
        match self {
            Free::KsScale => (0.02, 50.0),
            Free::Noload => (-1e5, 1e5),
            Free::SpeedExponent => (-2.0, 2.0),
            Free::Effect(k, i) => (k.params()[i].lo, k.params()[i].hi),
            Free::WearPerMinute => (0.0, 10.0),
        }
    }

    fn scale(self) -> f64 {
        match self {
            Free::KsScale => 0.01,
            Free::Noload => 1.0,
            Free::SpeedExponent => 0.02,
            Free::Effect(k, i) => k.params()[i].scale,
            Free::WearPerMinute => 1e-3,
        }
    }

    /// Value that switches the parameter off (1 for the Ks multiplier, 0 otherwise).
    pub fn null(self) -> f64 {
        match self {
            Free::KsScale => 1.0,
            Free::Noload | Free::SpeedExponent | Free::WearPerMinute => 0.0,
            Free::Effect(k, i) => k.params()[i].null,
        }
    }
}

/// A weak Gaussian prior on the nominal parameters, centred on the model as given, so
/// that they stay put where a training subset cannot identify them (e.g. `Ks` and the
/// no-load power on a fold without air cutting). Standard deviations: 30 % of `Ks`,
/// 20 % of the no-load power (at least 50 W), 0.5 on γ. Pseudo-residuals are scaled by
/// `scale` (the channel's noise σ) so they weigh like data rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Channel noise σ, channel unit.
    pub scale: f64,
    /// Centre of `tool.process.calib_force_n`, N.
    pub calib_force_n: f64,
    /// Centre of `machine.spindle.no_load_power_w`, W.
    pub no_load_power_w: f64,
    /// Centre of `tool.process.gamma`.
    pub gamma: f64,
}

impl Prior {
    /// The prior centred on `model`, scaled by `sigma`.
    pub fn around(model: &Model, sigma: f64) -> Prior {
        Prior {
            scale: sigma,
            calib_force_n: model.tool.process.calib_force_n,
            no_load_power_w: model.machine.spindle.no_load_power_w,
            gamma: model.tool.process.gamma,
        }
    }

    fn residual(&self, f: Free, m: &Model) -> Option<f64> {
        let z = match f {
            Free::KsScale => (m.tool.process.calib_force_n / self.calib_force_n - 1.0) / 0.3,
            Free::Noload => {
                (m.machine.spindle.no_load_power_w - self.no_load_power_w)
                    / (0.2 * self.no_load_power_w).max(50.0)
            }
            Free::SpeedExponent => (m.tool.process.gamma - self.gamma) / 0.5,
            Free::Effect(..) | Free::WearPerMinute => return None,
        };
        Some(self.scale * z)
    }
}

/// `base` with the free parameters set to `theta`.
pub fn apply(base: &Model, free: &[Free], theta: &[f64]) -> Model {
    let mut m = base.clone();
    for (f, &v) in free.iter().zip(theta) {
        match *f {
            Free::KsScale => m.tool.process.calib_force_n = base.tool.process.calib_force_n * v,
            Free::Noload => {
                m.machine.spindle.no_load_power_w = base.machine.spindle.no_load_power_w + v
            }
            Free::SpeedExponent => m.tool.process.gamma = base.tool.process.gamma + v,
            Free::Effect(k, i) => m.effects.set(k, i, v),
            Free::WearPerMinute => m.tool.wear.growth_per_min = base.tool.wear.growth_per_min + v,
        }
    }
    m
}

/// Current values of the free parameters in `base` (KsScale 1, Noload 0).
pub fn current(base: &Model, free: &[Free]) -> Vec<f64> {
    free.iter()
        .map(|f| match *f {
            Free::KsScale => 1.0,
            Free::Noload | Free::SpeedExponent | Free::WearPerMinute => 0.0,
            Free::Effect(k, i) => base.effects.get(k, i),
        })
        .collect()
}

/// One fitted parameter.
#[derive(Debug, Clone, Serialize)]
pub struct FittedParam {
    /// Parameter name (see [`Free::name`]).
    pub name: String,
    /// Estimate.
    pub value: f64,
    /// Standard error (AR(1)-inflated).
    pub std_err: f64,
    /// 95 % interval, low end.
    pub ci_low: f64,
    /// 95 % interval, high end.
    pub ci_high: f64,
    /// Null value (the parameter switched off).
    pub null: f64,
    /// `true` when the estimate sits on a fitting bound (interval unreliable).
    pub at_bound: bool,
}

impl Fit {
    /// A derived quantity `h(θ)` with gradient `grad` (over `free`) as a [`FittedParam`]
    /// named `name` with null `null`: delta-method standard error `√(gᵀ·C·g)` and the fit's
    /// 95 % t-interval.
    pub fn derived(&self, name: String, value: f64, grad: &[f64], null: f64) -> FittedParam {
        let g = DVector::from_column_slice(grad);
        let var = (g.transpose() * &self.cov * &g)[(0, 0)];
        let se = if var.is_finite() {
            var.max(0.0).sqrt()
        } else {
            f64::INFINITY
        };
        FittedParam {
            name,
            value,
            std_err: se,
            ci_low: value - self.t_crit * se,
            ci_high: value + self.t_crit * se,
            null,
            at_bound: false,
        }
    }
}

impl Fit {
    /// 95 % profile-likelihood interval of effect parameter `k` (an index into `free`;
    /// Venzon and Moolgavkar 1988): the values `v` for which the data SSE, minimized over
    /// the other free parameters with `k` held at `v`, rises above the fit's minimum by at
    /// most `t²·s²·(1+ρ)/(1−ρ)`. Unlike the Jacobian interval it follows a curved ridge
    /// between parameters that trade off (a no-load drift's ΔP against its τ when the log
    /// is shorter than τ). Searched outward from the estimate in steps of the linearized
    /// standard error (doubling), then bisected; clipped at the fitting bounds. Replaces
    /// `params[k]`'s interval and standard error (half the width over `t`); returns
    /// `false` (nothing changed) when `k` is not an effect parameter.
    pub fn profile(&mut self, k: usize, inp: &Inputs, rows: &[usize]) -> bool {
        let Some(&Free::Effect(kind, i)) = self.free.get(k) else {
            return false;
        };
        let others: Vec<Free> = self
            .free
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .map(|(_, f)| *f)
            .collect();
        let (lo, hi) = self.free[k].bounds();
        let v0 = self.theta[k];
        let limit = self.sse + self.t_crit.powi(2) * self.s2_inflated;
        let at = |v: f64| -> f64 {
            let mut m = self.model.clone();
            m.effects.set(kind, i, v);
            let m = refine(&m, &others, inp, rows);
            sse(&m, inp, rows)
        };
        let se = self.params[k].std_err;
        let step0 = if se.is_finite() && se > 0.0 {
            se
        } else {
            self.free[k].scale()
        };
        let mut ends = [lo, hi];
        for (e, dir) in ends.iter_mut().zip([-1.0, 1.0]) {
            let bound = *e;
            // Bracket: `inside` within the limit, `outside` beyond it (or the bound).
            let (mut inside, mut outside) = (v0, None);
            let mut step = step0;
            for _ in 0..12 {
                let v = (v0 + dir * step).clamp(lo, hi);
                if at(v) > limit {
                    outside = Some(v);
                    break;
                }
                inside = v;
                if v == bound {
                    break;
                }
                step *= 2.0;
            }
            let Some(mut out) = outside else {
                *e = inside;
                continue;
            };
            for _ in 0..8 {
                let mid = 0.5 * (inside + out);
                if at(mid) > limit {
                    out = mid;
                } else {
                    inside = mid;
                }
            }
            *e = 0.5 * (inside + out);
        }
        let p = &mut self.params[k];
        p.ci_low = ends[0].min(v0);
        p.ci_high = ends[1].max(v0);
        p.std_err = (p.ci_high - p.ci_low) / (2.0 * self.t_crit);
        true
    }
}

/// A fit result.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The model with fitted parameters.
    pub model: Model,
    /// Free parameters.
    pub free: Vec<Free>,
    /// Estimates (same order as `free`).
    pub theta: Vec<f64>,
    /// Parameter table with intervals.
    pub params: Vec<FittedParam>,
    /// Covariance of the estimates (same order as `free`; AR(1)-inflated), NaN where the
    /// Jacobian is singular.
    pub cov: DMatrix<f64>,
    /// Student-t factor of the 95 % intervals (effective degrees of freedom).
    pub t_crit: f64,
    /// Residual variance per row inflated for AR(1) residuals, `s²·(1+ρ)/(1−ρ)`, channel
    /// unit².
    pub s2_inflated: f64,
    /// Sum of squared residuals over the fitted rows.
    pub sse: f64,
    /// Number of fitted rows.
    pub n: usize,
}

struct Problem<'a> {
    base: &'a Model,
    free: &'a [Free],
    inp: &'a Inputs,
    rows: &'a [usize],
    theta: DVector<f64>,
}

impl<'a> Problem<'a> {
    fn new(
        base: &'a Model,
        free: &'a [Free],
        inp: &'a Inputs,
        rows: &'a [usize],
        theta: Vec<f64>,
    ) -> Self {
        Problem {
            base,
            free,
            inp,
            rows,
            theta: DVector::from_vec(theta),
        }
    }

    /// Data residuals over `rows`, then one pseudo-residual per nominal parameter when
    /// the inputs carry a [`Prior`].
    fn resid(&self, theta: &[f64]) -> DVector<f64> {
        let m = apply(self.base, self.free, theta);
        let r = replay_shared(&m, self.inp);
        let data = self
            .rows
            .iter()
            .map(|&i| self.inp.measured[i] - r.predicted[i]);
        let prior: Vec<f64> = match &self.inp.prior {
            Some(p) => self
                .free
                .iter()
                .filter_map(|f| p.residual(*f, &m))
                .collect(),
            None => Vec::new(),
        };
        DVector::from_iterator(self.rows.len() + prior.len(), data.chain(prior))
    }

    fn clamp(&self, theta: &mut [f64]) {
        for (v, f) in theta.iter_mut().zip(self.free) {
            let (lo, hi) = f.bounds();
            *v = if v.is_finite() {
                v.clamp(lo, hi)
            } else {
                f.null()
            };
        }
    }

    /// Forward-difference Jacobian of the residuals (steps of 1 % of each parameter's
    /// scale, taken inward at an upper bound).
    fn jac(&self, theta: &[f64]) -> DMatrix<f64> {
        let p = theta.len();
        let r0 = self.resid(theta);
        let mut j = DMatrix::zeros(r0.len(), p);
        for k in 0..p {
            let (lo, hi) = self.free[k].bounds();
            let h = self.free[k].scale() * 1e-2;
            let mut tp = theta.to_vec();
            tp[k] = if theta[k] + h <= hi {
                theta[k] + h
            } else {
                theta[k] - h
            };
            tp[k] = tp[k].clamp(lo, hi);
            let step = tp[k] - theta[k];
            if step == 0.0 {
                continue;
            }
            let col = (self.resid(&tp) - &r0) / step;
            j.set_column(k, &col);
        }
        j
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        let mut t: Vec<f64> = x.iter().copied().collect();
        self.clamp(&mut t);
        self.theta = DVector::from_vec(t);
    }

    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.resid(self.theta.as_slice()))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        Some(self.jac(self.theta.as_slice()))
    }
}

/// Relative change of the sum of squares and of the parameters at which a fit stops
/// (Levenberg–Marquardt's `ftol` and `xtol`; MINPACK's default is 1.49e−8). The naming
/// compares sums of squares whose differences matter at about 1/n of them (2e−4 on a
/// 10-minute log), so the fit is converged well below that; the crate's own default
/// (30 ε) keeps a slow fit iterating to its patience.
const LM_TOLERANCE: f64 = 1e-8;

fn lm(base: &Model, free: &[Free], start: &[f64], inp: &Inputs, rows: &[usize]) -> Vec<f64> {
    if free.is_empty() {
        return Vec::new();
    }
    let mut theta = start.to_vec();
    let problem = Problem::new(base, free, inp, rows, start.to_vec());
    problem.clamp(&mut theta);
    let problem = Problem::new(base, free, inp, rows, theta);
    let (solved, _report) = LevenbergMarquardt::new()
        .with_ftol(LM_TOLERANCE)
        .with_xtol(LM_TOLERANCE)
        .with_patience(30)
        .minimize(problem);
    let theta: Vec<f64> = solved.theta.iter().copied().collect();
    // The clamp at a bound can stall the trust region; restart once from halfway back.
    let stuck = free.iter().zip(&theta).zip(start).any(|((f, v), s0)| {
        let (lo, hi) = f.bounds();
        (*v == lo || *v == hi) && (v - s0).abs() > 0.0
    });
    if !stuck {
        return theta;
    }
    let restart: Vec<f64> = theta
        .iter()
        .zip(start)
        .map(|(v, s0)| 0.5 * (v + s0))
        .collect();
    let problem = Problem::new(solved.base, free, inp, rows, restart);
    let (again, _) = LevenbergMarquardt::new()
        .with_ftol(LM_TOLERANCE)
        .with_xtol(LM_TOLERANCE)
        .with_patience(30)
        .minimize(problem);
    let theta2: Vec<f64> = again.theta.iter().copied().collect();
    let cost = |t: &[f64]| again.resid(t).norm_squared();
    if cost(&theta2) < cost(&theta) {
        theta2
    } else {
        theta
    }
}

/// Local refinement only (no grid, no intervals): LM from the values in `base`; returns
/// the fitted model. Used inside cross-validation.
pub fn refine(base: &Model, free: &[Free], inp: &Inputs, rows: &[usize]) -> Model {
    let th = lm(base, free, &current(base, free), inp, rows);
    apply(base, free, &th)
}

/// Sum of squared residuals of `model` over `rows`.
pub fn sse(model: &Model, inp: &Inputs, rows: &[usize]) -> f64 {
    let r = replay_shared(model, inp);
    rows.iter()
        .map(|&i| (inp.measured[i] - r.predicted[i]).powi(2))
        .sum()
}

/// Fit `free` (starting from their values in `base`) on `rows`: grid over the parameters
/// listed in `grid` (each tried with the other parameters refined by LM), then LM on all.
pub fn fit(base: &Model, free: &[Free], grid: &[Free], inp: &Inputs, rows: &[usize]) -> Fit {
    let start = current(base, free);
    let mut best = start.clone();
    let grid_params: Vec<(usize, &'static [f64])> = grid
        .iter()
        .filter_map(|g| {
            let k = free.iter().position(|f| f == g)?;
            match *g {
                Free::Effect(e, i) => e.params()[i].grid.map(|gr| (k, gr)),
                _ => None,
            }
        })
        .collect();
    if !grid_params.is_empty() {
        let mut best_sse = f64::INFINITY;
        let mut combos: Vec<Vec<f64>> = vec![Vec::new()];
        for (_, values) in &grid_params {
            combos = combos
                .into_iter()
                .flat_map(|c| {
                    values.iter().map(move |v| {
                        let mut c = c.clone();
                        c.push(*v);
                        c
                    })
                })
                .collect();
        }
        let inner: Vec<usize> = (0..free.len())
            .filter(|k| !grid_params.iter().any(|(g, _)| g == k))
            .collect();
        let inner_free: Vec<Free> = inner.iter().map(|&k| free[k]).collect();
        for combo in combos {
            let mut fixed = base.clone();
            let mut full = start.clone();
            for ((k, _), v) in grid_params.iter().zip(&combo) {
                full[*k] = *v;
            }
            fixed = apply(&fixed, free, &full);
            // Inner parameters are fitted relative to `fixed`; KsScale/Noload restart at null.
            let inner_start: Vec<f64> = inner.iter().map(|&k| full[k]).collect();
            let th = lm(&fixed, &inner_free, &inner_start, inp, rows);
            let m = apply(&fixed, &inner_free, &th);
            let s = sse(&m, inp, rows);
            if s < best_sse {
                best_sse = s;
                for (j, &k) in inner.iter().enumerate() {
                    best[k] = th[j];
                }
                for ((k, _), v) in grid_params.iter().zip(&combo) {
                    best[*k] = *v;
                }
            }
        }
    }
    let mut theta = lm(base, free, &best, inp, rows);
    for k in 0..free.len() {
        if free[k] == Free::Effect(EffectKind::OverrideDeadTime, 0) {
            theta = pattern_search(base, free, theta, k, inp, rows);
        }
    }
    finish(base, free, theta, inp, rows)
}

/// Steps of [`pattern_search`], s: down to the simulator's 1 ms plant step.
const DELAY_STEPS: [f64; 5] = [0.016, 0.008, 0.004, 0.002, 0.001];

/// Refine parameter `k` of `theta` by a pattern search (each trial value with the other
/// parameters refitted by LM) in [`DELAY_STEPS`]. The override dead time acts in whole
/// steps of the simulator's plant (1 ms at its mean-model rate), so the sum of squares is
/// piecewise constant in it: LM's numerical derivative sees a flat step (or a cliff) and
/// stops wherever the grid left it — a +0.12 s delay fitted from the 0.1 s grid point
/// landed 2–3 ms short and left a residual that a second effect then absorbed.
fn pattern_search(
    base: &Model,
    free: &[Free],
    theta: Vec<f64>,
    k: usize,
    inp: &Inputs,
    rows: &[usize],
) -> Vec<f64> {
    let others: Vec<usize> = (0..free.len()).filter(|&j| j != k).collect();
    let other_free: Vec<Free> = others.iter().map(|&j| free[j]).collect();
    let (lo, hi) = free[k].bounds();
    // The others are relative to `base` (the trial only changes the delay), so their
    // refitted values stay in `theta`'s coordinates.
    let trial = |v: f64, from: &[f64]| -> (f64, Vec<f64>) {
        let fixed = apply(base, &[free[k]], &[v]);
        let start: Vec<f64> = others.iter().map(|&j| from[j]).collect();
        let th = lm(&fixed, &other_free, &start, inp, rows);
        let mut full = from.to_vec();
        full[k] = v;
        for (j, &o) in others.iter().enumerate() {
            full[o] = th[j];
        }
        (sse(&apply(base, free, &full), inp, rows), full)
    };
    let mut best_sse = sse(&apply(base, free, &theta), inp, rows);
    let mut best = theta;
    for step in DELAY_STEPS {
        loop {
            let mut moved = false;
            for dir in [-1.0, 1.0] {
                let v = (best[k] + dir * step).clamp(lo, hi);
                if v == best[k] {
                    continue;
                }
                let (s, full) = trial(v, &best);
                if s < best_sse {
                    (best_sse, best) = (s, full);
                    moved = true;
                    break;
                }
            }
            if !moved {
                break;
            }
        }
    }
    best
}

/// `(JᵀJ)⁻¹` with the parameters the data do not determine marked, not guessed: on the
/// correlation-scaled matrix `D^-½·JᵀJ·D^-½`, eigen-directions with eigenvalue below
/// 1e-10 × the largest are unidentified (a ks_step boundary inside an air gap moves
/// nothing); a parameter with more than 1 % of its weight on them gets NaN (an infinite
/// standard error), the others the pseudo-inverse over the identified directions. A plain
/// inverse of a near-singular `JᵀJ` returned negative variances, clamped to zero: a
/// zero-width interval around a parameter the log cannot see.
fn covariance_of(jtj: &DMatrix<f64>) -> DMatrix<f64> {
    let p = jtj.nrows();
    let d: Vec<f64> = (0..p).map(|k| jtj[(k, k)]).collect();
    let scale: Vec<f64> = d
        .iter()
        .map(|&v| {
            if v > 0.0 && v.is_finite() {
                1.0 / v.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let scaled = DMatrix::from_fn(p, p, |a, b| jtj[(a, b)] * scale[a] * scale[b]);
    if scaled.iter().any(|v| !v.is_finite()) {
        return DMatrix::from_element(p, p, f64::NAN);
    }
    let eig = nalgebra::SymmetricEigen::new(scaled);
    let top = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let tol = 1e-10 * top.max(f64::MIN_POSITIVE);
    let mut cov = DMatrix::zeros(p, p);
    let mut lost = vec![0.0; p];
    for (i, &l) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(i);
        if l > tol {
            cov += (v * v.transpose()) / l;
        } else {
            for k in 0..p {
                lost[k] += v[k] * v[k];
            }
        }
    }
    let mut cov = DMatrix::from_fn(p, p, |a, b| cov[(a, b)] * scale[a] * scale[b]);
    for k in 0..p {
        if scale[k] == 0.0 || lost[k] > 0.01 {
            cov.row_mut(k).fill(f64::NAN);
            cov.column_mut(k).fill(f64::NAN);
        }
    }
    cov
}

fn finish(base: &Model, free: &[Free], theta: Vec<f64>, inp: &Inputs, rows: &[usize]) -> Fit {
    let model = apply(base, free, &theta);
    let problem = Problem::new(base, free, inp, rows, theta.clone());
    let n = rows.len();
    let r_all = problem.resid(&theta);
    let r = r_all.rows(0, n);
    let sse = r.norm_squared();
    let p = free.len();
    let rho = lag1(r.as_slice()).max(0.0);
    let ne = n_eff(n, rho);
    let s2 = sse / (n.saturating_sub(p)).max(1) as f64;
    let infl = (1.0 + rho) / (1.0 - rho);
    let j = problem.jac(&theta);
    let jtj = j.transpose() * &j;
    let cov = covariance_of(&jtj);
    let tc = t_critical(0.95, (ne - p as f64).max(1.0));
    let params = free
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let se = (cov[(k, k)] * s2 * infl).max(0.0).sqrt();
            let se = if se.is_finite() { se } else { f64::INFINITY };
            let (lo, hi) = f.bounds();
            let v = theta[k];
            FittedParam {
                name: f.name(),
                value: v,
                std_err: se,
                ci_low: v - tc * se,
                ci_high: v + tc * se,
                null: f.null(),
                at_bound: (v - lo).abs() < 1e-12 || (v - hi).abs() < 1e-12,
            }
        })
        .collect();
    Fit {
        model,
        free: free.to_vec(),
        theta,
        params,
        cov: cov * (s2 * infl),
        t_crit: tc,
        s2_inflated: s2 * infl,
        sse,
        n,
    }
}

#[cfg(test)]
mod covariance_tests {
    use super::covariance_of;
    use nalgebra::DMatrix;

    #[test]
    fn a_well_posed_matrix_inverts_exactly() {
        let a = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]);
        let c = covariance_of(&a);
        let i = a.clone().try_inverse().expect("invertible");
        assert!((c - i).abs().max() < 1e-12);
    }

    #[test]
    fn a_parameter_the_data_do_not_see_gets_no_variance_and_the_others_theirs() {
        // The second parameter has a zero column: unidentified; the first keeps 1/4.
        let a = DMatrix::from_row_slice(2, 2, &[4.0, 0.0, 0.0, 0.0]);
        let c = covariance_of(&a);
        assert!((c[(0, 0)] - 0.25).abs() < 1e-12);
        assert!(c[(1, 1)].is_nan());
        // Two exactly collinear parameters: neither is determined alone.
        let b = DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 2.0]);
        let c = covariance_of(&b);
        assert!(c[(0, 0)].is_nan() && c[(1, 1)].is_nan());
        assert!((c[(2, 2)] - 0.5).abs() < 1e-12);
    }
}
