//! Power logs from the simulator's induction motor compared with a constant-efficiency
//! spindle model (`configs/models/paper_vmc.toml`) and with the matching model: names,
//! wear's effect-to-noise ratio and the noise σ, per seed.
//!
//! cargo run -p acc-ident --example twin_lab -- motor_mismatch tool_wear=0.005 1000 1001 …
//! (case III on `steps_2_3_4` with the tool's own wear, 0.005/cm³; `null`: the tool does
//! not wear). `WINDOW=s` sets the shipped model's power window; `DUMP=prefix` writes the
//! series as `prefix.<model>.<seed>.csv`.
use acc_ident::model::{Channel, Model};
use acc_ident::twin::{case_log, Hidden};

pub fn main() {
    let a: Vec<String> = crate::args().skip(1).collect();
    let hidden = Hidden::parse(a.first().map_or("tool_wear=0.005", String::as_str))
        .expect("hidden effect label");
    let seeds: Vec<u64> = a.iter().skip(1).filter_map(|s| s.parse().ok()).collect();
    let dir = acc_sim::run::configs_dir();
    let mut base =
        acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    // The tool's own wear (0.005/cm³ in its file) is the hidden effect: the log without it
    // is the null, `tool_wear=0.005` case III as shipped.
    base.wear.growth_per_cm3 = 0.0;
    let mut shipped = Model::load(&dir.join("models/paper_vmc.toml")).expect("model");
    shipped.measurement.channel = Channel::Power;
    if let Some(w) = std::env::var("WINDOW").ok().and_then(|w| w.parse().ok()) {
        shipped.measurement.power_window_s = w;
    }
    for seed in seeds {
        let (log, matching, wp) = case_log(&base, hidden, Channel::Power, seed).expect("log");
        for (label, model, calibrate) in [
            ("matching", &matching, true),
            ("constant-efficiency, as given", &shipped, false),
            ("constant-efficiency, calibrated", &shipped, true),
        ] {
            let opts = acc_ident::workflow::Options {
                workpiece: Some((wp.clone(), 0.0)),
                calibrate_spindle: calibrate,
                ..Default::default()
            };
            let an = acc_ident::workflow::analyse(model, &log, &opts).expect("analyse");
            let r = &an.report;
            if let Ok(path) = std::env::var("DUMP") {
                let sr = &an.series;
                let mut out = String::from("t,measured,nominal,updated\n");
                for i in 0..sr.t_s.len() {
                    out += &format!(
                        "{},{},{},{}\n",
                        sr.t_s[i], sr.measured[i], sr.nominal[i], sr.updated[i]
                    );
                }
                std::fs::write(format!("{path}.{label}.{seed}.csv"), out).expect("dump");
            }
            let enr = r
                .rounds
                .first()
                .and_then(|rd| rd.candidates.iter().find(|c| c.effect == "tool_wear"))
                .map_or(f64::NAN, |c| c.effect_to_noise);
            let cal = r.spindle_calibration.as_ref().map_or(String::new(), |c| {
                format!(
                    " | window {:.3} P_air {:.1} W eta {:.3} c {:?} fit RMS {:.2} -> {:.2} W noise sigma {:.2} -> {:.2} W",
                    c.power_window_s.1,
                    c.no_load_power_w.1,
                    c.efficiency.1,
                    c.copper_loss_per_kw.1,
                    c.residual_rms_w.0,
                    c.residual_rms_w.1,
                    c.noise_sigma.0,
                    c.noise_sigma.1
                )
            });
            println!(
                "{} seed {seed} {label:>31}: named {:?} withheld {:?} unexplained {} wear ENR {enr:.1} sigma {:.2} W{cal}",
                hidden.label(),
                r.accepted,
                r.withheld.iter().map(|w| &w.effect).collect::<Vec<_>>(),
                r.unexplained.is_some(),
                r.noise.sigma
            );
        }
    }
}
