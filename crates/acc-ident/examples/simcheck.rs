//! Replay consistency against the simulator: run a scenario, replay the same machine and
//! tool open loop on its log, print the residual.
use acc_ident::{import, model::Channel, replay, workflow};
use acc_sim::scenario::{LawKind, Scenario};

fn main() {
    let name = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "tool_wear".into());
    let path = acc_sim::run::configs_dir().join(format!("scenarios/{name}.toml"));
    let sc = Scenario::load(&path).expect("scenario");
    let (res, _) = sc.run_law(LawKind::Ours).expect("run");
    let log = import::from_sim_rows(&res.rows);
    let mut tool = sc.tool.clone();
    tool.wear = sc.wear;
    for ch in [Channel::Force, Channel::Power] {
        let mut m = import::model_from_sim(&sc.machine, &tool, ch);
        m.measurement.force_window_s = 0.05;
        let inp = replay::Inputs::from_log(&log, &m).unwrap();
        let r = replay::replay(&m, &inp);
        let e: Vec<f64> = (0..inp.len())
            .map(|i| inp.measured[i] - r.predicted[i])
            .collect();
        let rms = acc_ident::stats::rms(&e);
        let worst = e
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        println!(
            "{ch:?}: rows {} rms {rms:.3} worst {:.2} at t {:.1}",
            inp.len(),
            worst.1,
            inp.t_s[worst.0]
        );
        let mut nominal = m.clone();
        nominal.tool.wear.growth_per_cm3 = 0.0;
        let a = workflow::analyse(&nominal, &log, &Default::default()).unwrap();
        println!("  no-wear nominal: {}", a.report.conclusion);
        let a = workflow::analyse(&m, &log, &Default::default()).unwrap();
        println!("  true nominal: {}", a.report.conclusion);
    }
}
