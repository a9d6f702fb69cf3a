//! Residual of the nominal replay of one null log, row by row (development aid); with
//! `LOGGED=1` replayed on its logged depths instead of the workpiece.
//!
//! cargo run --release -p acc-ident --example twin_lab -- twin_resid interrupted.toml force 1007
use acc_ident::model::Channel;
use acc_ident::twin;

pub fn main() {
    let a: Vec<String> = crate::args().skip(1).collect();
    let (wp, ch, seed) = crate::case_args(&a, 1);
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("sc");
    sc.workpiece = acc_sim::Workpiece::load(dir.join("workpieces").join(&wp)).expect("wp");
    sc.max_time_s = 60.0;
    sc.seed = seed;
    let log = twin::simulate(&sc).expect("log");
    let m = twin::model_for_scenario(&sc, ch);
    let on = (std::env::var_os("LOGGED").is_none()).then_some((&sc.workpiece, 0.0));
    let r = twin::replay_residual(&m, &log, on).expect("replay");
    let meas = match ch {
        Channel::Force => log.force_n.clone().unwrap_or_default(),
        Channel::Power => log.power_w.clone().unwrap_or_default(),
    };
    for (i, x) in r.iter().enumerate() {
        println!(
            "{i} t {:.2} ov {:.0} meas {:.1} resid {:.2} P {:.1} depth {:.2}",
            log.t_s[i],
            log.override_applied_pct.as_ref().map_or(0.0, |o| o[i]),
            meas[i],
            x,
            log.power_w.as_ref().map_or(0.0, |p| p[i]),
            log.radial_depth_mm[i]
        );
    }
}
