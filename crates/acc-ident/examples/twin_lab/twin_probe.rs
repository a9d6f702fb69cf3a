//! Probe: replay residual of null logs from `acc sim` (development aid).
use acc_ident::model::Channel;
use acc_ident::twin;
pub fn main() {
    let dir = acc_sim::run::configs_dir();
    let args: Vec<String> = crate::args().skip(1).collect();
    let names = if args.is_empty() {
        vec!["paper_case3.toml".to_string()]
    } else {
        args
    };
    for name in names {
        let sc = acc_sim::Scenario::load(dir.join("scenarios").join(&name)).expect("scenario");
        let t = std::time::Instant::now();
        let log = twin::simulate(&sc).expect("sim");
        let ts = t.elapsed().as_secs_f64();
        for ch in [Channel::Power, Channel::Force] {
            let m = twin::model_for_scenario(&sc, ch);
            for wp in [None, Some((&sc.workpiece, 0.0))] {
                let t = std::time::Instant::now();
                let r = twin::replay_residual(&m, &log, wp).expect("replay");
                let dt = t.elapsed().as_secs_f64();
                let rms = (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt();
                let d: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
                let sd = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64 / 2.0).sqrt();
                let mean = r.iter().sum::<f64>() / r.len() as f64;
                let worst = r
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .unwrap_or((0, &0.0));
                println!("{name} {ch:?} wp={} rows {} sim {ts:.2}s replay {dt:.3}s: rms {rms:.2} mean {mean:.2} diff-sigma {sd:.2} worst row {} {:.1}", wp.is_some(), r.len(), worst.0, worst.1);
            }
        }
    }
}
