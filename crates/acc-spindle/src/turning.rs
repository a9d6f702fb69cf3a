//! Force-from-signal models on the real turning data set (Vicomtech / Mondragon
//! Unibertsitatea, CC BY-SA 4.0; Ferrando Chacón et al., Int. J. Adv. Manuf. Technol.
//! 125:4027–4045, 2023) and the two ways `acc estimate-eval` validates them:
//!
//! * [`leave_one_tool_out`] (the headline): for each tool, fit on the other tools pooled
//!   ([`split_by_tool`]) and measure the MAPE against the dynamometer `F_c` on the held-out
//!   tool — the error on a tool the estimator has not seen;
//! * [`cross_tool`]: fit on one tool, validate on each other tool.
//!
//! Every fitted constant comes from the training rows only; the held-out tool's rows are
//! used for prediction and scoring, never in a fit.

use std::collections::BTreeMap;

use acc_core::spindle_force::SpindleError;

use crate::calibrate::least_squares;
use crate::datasets::TurningRow;
use crate::eval::mape_pct;

/// Fitted constants of a [`TurningModel`], in the order of its equation (unused trailing
/// entries are 0).
pub type TurningParams = [f64; 4];

/// Force-from-signal models for the turning data. Turning has no tool radius: `ω·r` of
/// seed 000 eq. 14 becomes `k·n` (the workpiece radius is lumped into `k`); `n` is the
/// encoder speed × 10⁻⁷, `P` the spindle mechanical power (W), `I_z` the mean current of the
/// feed (Z) drive (A), `V_b` the flank wear (µm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TurningModel {
    /// `P = k·F·n` → `F = P/(k·n)` (eq. 14, no no-load term).
    Plain,
    /// `P = k·F·n + c·n²`: a speed-dependent no-load term.
    SpeedNoLoad,
    /// `P = k·F·n + q·(F·n)²`: load-dependent efficiency.
    Efficiency,
    /// `F = a·P/n + b·I_z`: spindle power plus the feed drive's current (the static form
    /// of seed 004's spindle + feed-drive combination: the feed current carries the feed
    /// force, which grows with flank wear).
    FeedCurrent,
    /// `F = a·P/n + b·(I_z − I_z0)`, fitted as `a·P/n + b·I_z + c`: the feed drive's
    /// no-load (friction) current `I_z0` subtracted, as seed 004's `Kt·I = C + Kf·F_x`
    /// and the band-pass of [`crate::fusion`] do.
    FeedCurrentOffset,
    /// The same equation as [`TurningModel::FeedCurrentOffset`], fitted robustly: least
    /// absolute relative error (the MAPE itself), by iteratively reweighted least squares.
    FeedCurrentRobust,
    /// `F = b·I_z + c`: the feed drive's current alone, with its no-load offset (no spindle
    /// signal).
    FeedOnly,
    /// `F = a·P/n + b·I_z + c + w·V_b`: with the measured flank wear. A diagnostic, not an
    /// online estimator: `V_b` is measured off the machine; it shows how much of the error
    /// is wear that the signals do not carry.
    WearDiagnostic,
    /// `F = a·P/n + b·I_z + c + s·t`, `t` the segment's index within its tool (a
    /// cutting-time proxy). A diagnostic: the data set's segments are samples of each tool's
    /// life, not all of it (tool 9's record starts at `V_b` = 132 µm), so `t` is not the
    /// tool's cutting time.
    TimeDiagnostic,
}

/// Iterations of the reweighted fit of [`TurningModel::FeedCurrentRobust`].
const IRLS_ITERATIONS: usize = 50;
/// Smallest relative residual the reweighting divides by (avoids infinite weights).
const IRLS_FLOOR: f64 = 1e-4;

impl TurningModel {
    /// All models, table order.
    pub const ALL: [TurningModel; 9] = [
        TurningModel::Plain,
        TurningModel::SpeedNoLoad,
        TurningModel::Efficiency,
        TurningModel::FeedCurrent,
        TurningModel::FeedCurrentOffset,
        TurningModel::FeedCurrentRobust,
        TurningModel::FeedOnly,
        TurningModel::WearDiagnostic,
        TurningModel::TimeDiagnostic,
    ];

    /// The model chosen by the leave-one-tool-out median (see `docs/spindle.md`).
    pub const CHOSEN: TurningModel = TurningModel::FeedCurrentOffset;

    /// `true` for the diagnostics, which need what an online estimator does not have.
    pub fn is_diagnostic(self) -> bool {
        matches!(
            self,
            TurningModel::WearDiagnostic | TurningModel::TimeDiagnostic
        )
    }

    /// Label for tables.
    pub fn label(self) -> &'static str {
        match self {
            TurningModel::Plain => "power P/(k·n)",
            TurningModel::SpeedNoLoad => "power − c·n² (no-load)",
            TurningModel::Efficiency => "power, efficiency q·(Fn)²",
            TurningModel::FeedCurrent => "power + feed-drive current",
            TurningModel::FeedCurrentOffset => "power + feed-drive current − no-load",
            TurningModel::FeedCurrentRobust => "same, least abs. relative error",
            TurningModel::FeedOnly => "feed-drive current − no-load only",
            TurningModel::WearDiagnostic => "diagnostic: + measured flank wear V_b",
            TurningModel::TimeDiagnostic => "diagnostic: + segment index in tool",
        }
    }

    /// The regressors of the linear force models (`F ≈ p·x`), `None` for the models fitted
    /// on power.
    fn regressors(self, r: &TurningRow) -> Option<[f64; 4]> {
        let pn = r.power_w / speed(r);
        let iz = r.feed_current_a;
        match self {
            TurningModel::Plain | TurningModel::SpeedNoLoad | TurningModel::Efficiency => None,
            TurningModel::FeedCurrent => Some([pn, iz, 0.0, 0.0]),
            TurningModel::FeedCurrentOffset | TurningModel::FeedCurrentRobust => {
                Some([pn, iz, 1.0, 0.0])
            }
            TurningModel::FeedOnly => Some([0.0, iz, 1.0, 0.0]),
            TurningModel::WearDiagnostic => Some([pn, iz, 1.0, r.vb_um]),
            TurningModel::TimeDiagnostic => Some([pn, iz, 1.0, f64::from(r.segment)]),
        }
    }

    /// Fit on `rows`; returns the parameters for [`TurningModel::predict`].
    pub fn fit(self, rows: &[TurningRow]) -> Result<TurningParams, SpindleError> {
        let pad2 = |[a, b]: [f64; 2]| [a, b, 0.0, 0.0];
        match self {
            TurningModel::Plain => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| ([r.force_n * speed(r)], r.power_w))
                    .collect();
                least_squares(&m, "turning plain").map(|[k]| [k, 0.0, 0.0, 0.0])
            }
            TurningModel::SpeedNoLoad => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| ([r.force_n * speed(r), speed(r) * speed(r)], r.power_w))
                    .collect();
                least_squares(&m, "turning no-load").map(pad2)
            }
            TurningModel::Efficiency => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| {
                        let fnn = r.force_n * speed(r);
                        ([fnn, fnn * fnn], r.power_w)
                    })
                    .collect();
                least_squares(&m, "turning efficiency").map(pad2)
            }
            TurningModel::FeedCurrent => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| ([r.power_w / speed(r), r.feed_current_a], r.force_n))
                    .collect();
                least_squares(&m, "turning feed current").map(pad2)
            }
            TurningModel::FeedCurrentOffset => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| ([r.power_w / speed(r), r.feed_current_a, 1.0], r.force_n))
                    .collect();
                least_squares(&m, "turning feed current offset").map(|[a, b, c]| [a, b, c, 0.0])
            }
            TurningModel::FeedCurrentRobust => fit_least_relative(rows),
            TurningModel::FeedOnly => {
                let m: Vec<_> = rows
                    .iter()
                    .map(|r| ([r.feed_current_a, 1.0], r.force_n))
                    .collect();
                least_squares(&m, "turning feed only").map(|[b, c]| [0.0, b, c, 0.0])
            }
            TurningModel::WearDiagnostic | TurningModel::TimeDiagnostic => {
                let m: Vec<_> = rows
                    .iter()
                    .filter_map(|r| self.regressors(r).map(|x| (x, r.force_n)))
                    .collect();
                least_squares(&m, "turning diagnostic")
            }
        }
    }

    /// Predict the cutting force of one row, N.
    pub fn predict(self, p: TurningParams, r: &TurningRow) -> f64 {
        let n = speed(r);
        match self {
            TurningModel::Plain => r.power_w / (p[0] * n),
            TurningModel::SpeedNoLoad => (r.power_w - p[1] * n * n) / (p[0] * n),
            TurningModel::Efficiency => {
                // Root of q·x² + k·x − P = 0 that is 0 at P = 0, x = F·n.
                let disc = (p[0] * p[0] + 4.0 * p[1] * r.power_w).max(0.0);
                2.0 * r.power_w / (p[0] + disc.sqrt()) / n
            }
            _ => self
                .regressors(r)
                .map_or(f64::NAN, |x| x.iter().zip(p).map(|(x, p)| x * p).sum()),
        }
    }
}

/// The speed `n` of the models: encoder units × 10⁻⁷ (keeps the fits well scaled).
fn speed(r: &TurningRow) -> f64 {
    r.speed * 1e-7
}

/// `F = a·P/n + b·I_z + c` minimising `Σ |F̂ − F|/F` (the MAPE): iteratively reweighted
/// least squares, row weight `1/(F·√max(|e|, 10⁻⁴))` with `e` the previous relative
/// residual; starts from least squares on the relative error.
fn fit_least_relative(rows: &[TurningRow]) -> Result<TurningParams, SpindleError> {
    const M: &str = "turning feed current robust";
    let x = |r: &TurningRow| [r.power_w / speed(r), r.feed_current_a, 1.0];
    let mut w: Vec<f64> = rows.iter().map(|r| 1.0 / r.force_n).collect();
    let mut p = [0.0; 3];
    for _ in 0..IRLS_ITERATIONS {
        let m: Vec<_> = rows
            .iter()
            .zip(&w)
            .map(|(r, &w)| (x(r).map(|v| v * w), r.force_n * w))
            .collect();
        p = least_squares(&m, M)?;
        for (wi, r) in w.iter_mut().zip(rows) {
            let fit: f64 = x(r).iter().zip(p).map(|(x, p)| x * p).sum();
            let e = ((fit - r.force_n) / r.force_n).abs();
            *wi = 1.0 / (r.force_n * e.max(IRLS_FLOOR).sqrt());
        }
    }
    Ok([p[0], p[1], p[2], 0.0])
}

/// The rows of every tool, by tool id, in file order.
fn by_tool(rows: &[TurningRow]) -> BTreeMap<u32, Vec<TurningRow>> {
    let mut out: BTreeMap<u32, Vec<TurningRow>> = BTreeMap::new();
    for r in rows {
        out.entry(r.tool).or_default().push(*r);
    }
    out
}

/// Split `rows` into (training: every other tool, held out: tool `held_out`), keeping the
/// file order in each.
pub fn split_by_tool(rows: &[TurningRow], held_out: u32) -> (Vec<TurningRow>, Vec<TurningRow>) {
    rows.iter().partition(|r| r.tool != held_out)
}

/// One fold of [`leave_one_tool_out`].
#[derive(Debug, Clone, PartialEq)]
pub struct LotoFold {
    /// The held-out tool.
    pub held_out_tool: u32,
    /// Rows the model was fitted on (all other tools).
    pub training_rows: usize,
    /// Rows of the held-out tool.
    pub held_out_rows: usize,
    /// The constants fitted on the other tools.
    pub params: TurningParams,
    /// MAPE on the held-out tool against the dynamometer `F_c`, %.
    pub mape_pct: f64,
    /// Mean signed relative error on the held-out tool, % (positive: overestimate).
    pub bias_pct: f64,
}

/// Leave-one-tool-out cross-validation: for each tool, fit `model` on the other tools
/// pooled and validate on it. One fold per tool, in tool order.
pub fn leave_one_tool_out(
    rows: &[TurningRow],
    model: TurningModel,
) -> Result<Vec<LotoFold>, SpindleError> {
    by_tool(rows)
        .keys()
        .map(|&tool| {
            let (train, test) = split_by_tool(rows, tool);
            let params = model.fit(&train)?;
            let est: Vec<f64> = test.iter().map(|r| model.predict(params, r)).collect();
            let truth: Vec<f64> = test.iter().map(|r| r.force_n).collect();
            let bias = est
                .iter()
                .zip(&truth)
                .map(|(e, t)| (e - t) / t)
                .sum::<f64>()
                / truth.len().max(1) as f64;
            Ok(LotoFold {
                held_out_tool: tool,
                training_rows: train.len(),
                held_out_rows: test.len(),
                params,
                mape_pct: mape_pct(&est, &truth),
                bias_pct: 100.0 * bias,
            })
        })
        .collect()
}

/// One calibration tool's result.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossToolResult {
    /// Tool used for calibration.
    pub calibration_tool: u32,
    /// MAPE on each other tool, %.
    pub per_tool_mape_pct: Vec<(u32, f64)>,
    /// Mean of `per_tool_mape_pct`, %.
    pub mean_mape_pct: f64,
}

/// Calibrate `model` on each tool in turn and validate on the others.
pub fn cross_tool(
    rows: &[TurningRow],
    model: TurningModel,
) -> Result<Vec<CrossToolResult>, SpindleError> {
    let by_tool = by_tool(rows);
    let mut out = Vec::new();
    for (&cal, cal_rows) in &by_tool {
        let p = model.fit(cal_rows)?;
        let mut per = Vec::new();
        for (&val, val_rows) in &by_tool {
            if val == cal {
                continue;
            }
            let est: Vec<f64> = val_rows.iter().map(|r| model.predict(p, r)).collect();
            let truth: Vec<f64> = val_rows.iter().map(|r| r.force_n).collect();
            per.push((val, mape_pct(&est, &truth)));
        }
        let mean = per.iter().map(|x| x.1).sum::<f64>() / per.len().max(1) as f64;
        out.push(CrossToolResult {
            calibration_tool: cal,
            per_tool_mape_pct: per,
            mean_mape_pct: mean,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of tools 1–4 following `F = 0.5·P/n + 30·I_z + 60` exactly, with loads and
    /// speeds that vary within each tool.
    fn rows() -> Vec<TurningRow> {
        let mut out = Vec::new();
        for tool in 1..=4u32 {
            for k in 0..20u32 {
                let kf = f64::from(k);
                let speed = 7.0e6 + 1.0e5 * f64::from(tool) + 2.0e4 * (kf % 5.0);
                let power_w = 2000.0 + 40.0 * kf + 100.0 * f64::from(tool);
                let feed_current_a = 3.0 + 0.1 * kf - 0.2 * f64::from(tool);
                let force_n = 0.5 * power_w / (speed * 1e-7) + 30.0 * feed_current_a + 60.0;
                out.push(TurningRow {
                    line: u64::from(tool * 100 + k),
                    tool,
                    force_n,
                    power_w,
                    power_elec: 12.0 * power_w,
                    speed,
                    feed: 2000.0,
                    feed_current_a,
                    vb_um: 5.0 * kf,
                    segment: k,
                });
            }
        }
        out
    }

    #[test]
    fn split_never_puts_the_held_out_tool_in_training() {
        let all = rows();
        for tool in 1..=4 {
            let (train, test) = split_by_tool(&all, tool);
            assert!(train.iter().all(|r| r.tool != tool));
            assert!(test.iter().all(|r| r.tool == tool));
            assert_eq!(test.len(), 20);
            assert_eq!(train.len() + test.len(), all.len());
        }
    }

    #[test]
    fn a_folds_constants_do_not_depend_on_its_held_out_tool() {
        let clean = rows();
        // Corrupt tool 3's signals: only the fold that holds tool 3 out must not notice.
        let mut dirty = clean.clone();
        for r in dirty.iter_mut().filter(|r| r.tool == 3) {
            r.feed_current_a *= 3.0;
        }
        for m in [TurningModel::FeedCurrentOffset, TurningModel::Plain] {
            let a = leave_one_tool_out(&clean, m).unwrap();
            let b = leave_one_tool_out(&dirty, m).unwrap();
            assert_eq!(a.len(), 4);
            for (fa, fb) in a.iter().zip(&b) {
                assert_eq!((fa.training_rows, fa.held_out_rows), (60, 20));
                if fa.held_out_tool == 3 {
                    assert_eq!(fa.params, fb.params, "{m:?}");
                } else if m == TurningModel::FeedCurrentOffset {
                    assert_ne!(fa.params, fb.params, "{m:?} fold {}", fa.held_out_tool);
                }
            }
        }
    }

    #[test]
    fn exact_models_are_recovered_on_unseen_tools() {
        let all = rows();
        for m in [
            TurningModel::FeedCurrentOffset,
            TurningModel::FeedCurrentRobust,
            TurningModel::WearDiagnostic,
        ] {
            for f in leave_one_tool_out(&all, m).unwrap() {
                assert!(
                    f.mape_pct < 1e-6,
                    "{m:?} tool {}: {}",
                    f.held_out_tool,
                    f.mape_pct
                );
                assert!((f.params[0] - 0.5).abs() < 1e-6, "{m:?} {:?}", f.params);
                assert!((f.params[1] - 30.0).abs() < 1e-4, "{m:?} {:?}", f.params);
            }
        }
        // Without the offset the same data cannot be fitted exactly.
        let worst = leave_one_tool_out(&all, TurningModel::FeedCurrent)
            .unwrap()
            .iter()
            .map(|f| f.mape_pct)
            .fold(0.0, f64::max);
        assert!(worst > 0.1, "{worst}");
    }
}
