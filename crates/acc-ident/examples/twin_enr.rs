//! Effect-to-noise ratio of the in-library cases of `twin_eval` (same cases, seeds and
//! workpieces), to read recovery at effect/noise ≥ 4 (issue 13): for each case the nominal
//! replay's residual on the log with the hidden effect (`rms_h`) against the residual on
//! the null log of the same workpiece and seed (`rms_0`, its difference-based σ `σ_0`):
//! `ENR = √max(0, rms_h² − rms_0²) / σ_0`. Joins `out/twin/cases.csv` and prints recovery
//! and coverage per channel over the cases with ENR ≥ 4.
//!
//! cargo run --release -p acc-ident --example twin_enr -- --cases out/twin/cases.csv
use std::collections::HashMap;

use acc_ident::model::Channel;
use acc_ident::twin::{self, Hidden};

const WORKPIECES: [&str; 5] = [
    "steps_1_2_3.toml",
    "steps_2_3_4.toml",
    "ramp_2_4.toml",
    "interrupted.toml",
    "hard_inclusion.toml",
];

fn library() -> Vec<Hidden> {
    vec![
        Hidden::ToolWear(0.03),
        Hidden::ToolWear(0.08),
        Hidden::FeedDriveLag(0.03),
        Hidden::FeedDriveLag(0.08),
        Hidden::OverrideDeadTime(0.05),
        Hidden::OverrideDeadTime(0.12),
        Hidden::CopperLoss(0.1),
        Hidden::CopperLoss(0.3),
        Hidden::NoloadDrift(40.0),
        Hidden::NoloadDrift(120.0),
        Hidden::SensorLowpass(0.1),
        Hidden::SensorLowpass(0.3),
        Hidden::Runout(0.05),
        Hidden::Runout(0.15),
        Hidden::LogGainDrift(0.02),
        Hidden::LogGainDrift(0.06),
        Hidden::LogDelay(1),
        Hidden::LogDelay(3),
    ]
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

fn sigma(r: &[f64]) -> f64 {
    let live: Vec<f64> = r.iter().copied().filter(|x| *x != 0.0).collect();
    let mut d: Vec<f64> = live.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0) / 0.6745 / 2f64.sqrt()
}

fn residual(base: &acc_sim::Scenario, h: Hidden, ch: Channel, seed: u64) -> Vec<f64> {
    let (mut sc, mut model, wp) = twin::hidden_case(base, h, ch);
    sc.seed = seed;
    if model.measurement.force_estimator.is_some() {
        model.measurement.force_estimator = twin::estimator_of(&sc);
    }
    let mut log = twin::simulate(&sc).expect("log");
    twin::apply_logging_path(h, ch, &mut log);
    twin::replay_residual(&model, &log, Some((&wp, 0.0))).expect("replay")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cases = args
        .iter()
        .position(|a| a == "--cases")
        .and_then(|i| args.get(i + 1))
        .cloned()
        .unwrap_or_else(|| "out/twin/cases.csv".into());
    let dir = acc_sim::run::configs_dir();
    let mut base =
        acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    base.max_time_s = 60.0;
    let text = std::fs::read_to_string(&cases).unwrap_or_default();
    // (channel, hidden label, workpiece) → (outcome, covered)
    let mut verdicts: HashMap<(String, String, String), (String, String)> = HashMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() >= 9 {
            verdicts.insert(
                (f[0].into(), f[1].into(), f[2].into()),
                (f[4].into(), f[8].into()),
            );
        }
    }
    println!("channel,hidden,workpiece,seed,enr,outcome,covered");
    for ch in [Channel::Power, Channel::Force] {
        let (mut n, mut ok, mut cov_n, mut cov_ok) = (0, 0, 0, 0);
        for h in library() {
            for (wi, w) in WORKPIECES.iter().enumerate() {
                let seed = 1000 + 7 * wi as u64;
                let mut sc = base.clone();
                sc.workpiece =
                    acc_sim::Workpiece::load(dir.join("workpieces").join(w)).expect("wp");
                let r0 = residual(&sc, Hidden::Null, ch, seed);
                let rh = residual(&sc, h, ch, seed);
                let (a, b, s) = (rms(&rh), rms(&r0), sigma(&r0).max(1e-9));
                let enr = (a * a - b * b).max(0.0).sqrt() / s;
                let key = (format!("{ch:?}"), h.label(), (*w).to_string());
                let (o, c) = verdicts.get(&key).cloned().unwrap_or_default();
                println!("{ch:?},{},{w},{seed},{enr:.2},{o},{c}", h.label());
                if enr >= 4.0 {
                    n += 1;
                    let want = h
                        .library()
                        .map(|k| k.name().to_string())
                        .unwrap_or_default();
                    ok += usize::from(o == want);
                    if c.starts_with("Some") {
                        cov_n += 1;
                        cov_ok += usize::from(c == "Some(true)");
                    }
                }
            }
        }
        eprintln!(
            "{ch:?}: at ENR ≥ 4, recovery {ok} of {n} ({:.1} %), coverage {cov_ok} of {cov_n} ({:.1} %)",
            100.0 * ok as f64 / n.max(1) as f64,
            100.0 * cov_ok as f64 / cov_n.max(1) as f64
        );
    }
}
