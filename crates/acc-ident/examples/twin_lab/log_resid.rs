//! Residual of the nominal replay of a run log file (`acc run`, `acc board-sim`, `acc sim`)
//! on a workpiece, placed as `acc discrepancy --workpiece` places it, row by row (`NO_ANCHOR=1`:
//! the tool starting at X0 instead); with `POS=1` the replayed tool position per row instead
//! (development aid: compare it with `acc board-sim --log`'s `x_true_mm`).
//!
//! `SCENARIO=FILE` replays the scenario's own model (`twin::model_for_scenario`, its wear
//! included) instead of MODEL.toml's machine and tool: the machine's true model.
//!
//! cargo run --release -p acc-ident --example twin_lab -- log_resid RUN.csv MODEL.toml WORKPIECE.toml X0 power
use acc_ident::model::Channel;
use acc_ident::twin;
use std::path::Path;

pub fn main() {
    let a: Vec<String> = crate::args().skip(1).collect();
    let mut m = acc_ident::Model::load(Path::new(&a[1])).expect("model");
    let x0: f64 = a[3].parse().expect("x0");
    let eng = acc_ident::engagement::PathEngagement::load(Path::new(&a[2]), m.tool.diameter_mm, x0)
        .expect("wp");
    let log = acc_ident::runlog::read_csv_with(Path::new(&a[0]), Some(&eng)).expect("log");
    let wp = eng.workpiece.clone();
    m.measurement.channel = if a.get(4).map(String::as_str) == Some("force") {
        Channel::Force
    } else {
        Channel::Power
    };
    if let Some(sc) = std::env::var_os("SCENARIO") {
        let sc = acc_sim::Scenario::load(Path::new(&sc)).expect("scenario");
        m = twin::model_for_scenario(&sc, m.measurement.channel);
    }
    if std::env::var("POS").is_ok() {
        positions(&m, &log, &wp);
        return;
    }
    let r = if std::env::var_os("NO_ANCHOR").is_some() {
        twin::replay_residual(&m, &log, Some((&wp, x0))).expect("replay")
    } else {
        twin::replay_residual_on_path(&m, &log, &wp).expect("replay")
    };
    for (i, x) in r.iter().enumerate() {
        println!(
            "{i} t {:.3} ov {:.0} x {:.2} P {:.1} resid {:.2}",
            log.t_s[i],
            log.override_applied_pct.as_ref().map_or(0.0, |o| o[i]),
            log.x_mm.as_ref().map_or(0.0, |o| o[i]),
            log.power_w.as_ref().map_or(0.0, |p| p[i]),
            x
        );
    }
}

/// Replayed tool position (mm), applied override (%) and period (s) per row, on the
/// rows' periods (a log with `seq_repeat` / `seq_skip` flags is replayed on the board's
/// samples instead: compare row by row only where there are none).
fn positions(m: &acc_ident::Model, log: &acc_ident::RunLog, wp: &acc_sim::Workpiece) {
    let inp = acc_ident::replay::Inputs::from_log(log, m).expect("inputs");
    let p = &inp.plant;
    let drive = acc_sim::replay::ReplayDrive {
        period_s: &inp.dt_s,
        override_applied_pct: &p.override_applied_pct,
        programmed_feed_mm_min: &p.programmed_feed_mm_min,
        feed_hold: None,
        spindle_rpm: None,
        settled: false,
    };
    let eng = acc_sim::replay::ReplayEngagement::Workpiece {
        workpiece: wp.clone(),
        x0_mm: log.path_start_mm().unwrap_or(0.0),
    };
    let tr = acc_sim::replay::trace(
        &m.machine,
        &m.tool,
        acc_sim::ForceModel::Mean,
        &eng,
        &drive,
        &acc_sim::replay::ReplayChannel::default(),
        &acc_sim::replay::RunoutBasis::default(),
    );
    for (i, t) in tr.iter().enumerate() {
        println!(
            "X {i} {:.4} {:.3} {:.4}",
            t.x_mm, p.override_applied_pct[i], inp.dt_s[i]
        );
    }
}
