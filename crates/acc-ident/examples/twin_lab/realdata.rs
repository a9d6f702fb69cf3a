//! Run the workflow on the real data in `../shared/data` and print the verdicts:
//! `cargo run --release -p acc-ident --example twin_lab -- realdata`.
use std::path::Path;

use acc_ident::{import, workflow};

pub fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let turning = root.join("vicomtech-turning/tool_wear_tools_3-10.csv");
    match import::vicomtech_turning(&turning) {
        Ok(tools) => {
            for (id, mut log) in tools {
                log.wear_vb_um = None; // withheld
                let model = import::turning_model(&log, 0.2);
                let a = match workflow::analyse(&model, &log, &topts()) {
                    Ok(a) => a,
                    Err(e) => {
                        println!("tool {id}: {e}");
                        continue;
                    }
                };
                println!(
                    "tool {id:>2}: rows {:>3} accepted {:?} amb {:?} unexpl {} sealed RMS {:.1} -> {:.1} N (refit {:.1}) fit {:.1}% -> {:.1}%",
                    log.len(), a.report.accepted, a.report.ambiguous.iter().map(|x| x.effects.clone()).collect::<Vec<_>>(),
                    a.report.unexplained.is_some(), a.report.sealed.nominal.rms, a.report.sealed.updated.rms,
                    a.report.sealed.nominal_refit.rms, a.report.sealed.nominal.fit_pct, a.report.sealed.updated.fit_pct
                );
                for p in
                    a.report.updated_params.iter().filter(|p| {
                        p.name.starts_with("tool_wear") || p.name.starts_with("feed_exp")
                    })
                {
                    println!(
                        "    {} = {:.4} [{:.4}, {:.4}]",
                        p.name, p.value, p.ci_low, p.ci_high
                    );
                }
                if std::env::var("VERBOSE").is_ok() {
                    for r in &a.report.rounds {
                        if let Some(e) = &r.encompassing {
                            println!("    r{} encompassing {e:?}", r.round);
                        }
                        for c in r.candidates.iter().filter(|c| c.applicable) {
                            println!("    r{} {:>20} gain {:6.2}% folds {} chi2 {:6.2} p {:.2e} ci {} sig {:.2}->{:.2} {} pass {} {:?}", r.round, c.effect, c.heldout_gain_pct, c.folds_improved, c.heldout_chi2, c.p_adjusted, c.ci_excludes_null, c.signature_r_before, c.signature_r_after, c.signature_gone, c.passed, c.params.iter().skip(1).map(|p| (p.name.as_str(), p.value, p.ci_low, p.ci_high)).collect::<Vec<_>>());
                        }
                    }
                }
            }
        }
        Err(e) => println!("skip turning: {e}"),
    }
    for k in 1..=12 {
        let p = root.join(format!("umich-cnc-mill/experiment_{k:02}.csv"));
        match import::umich_mill(&p) {
            Ok(log) => {
                let model = import::umich_model(&log);
                match workflow::analyse(&model, &log, &workflow::Options::default()) {
                    Ok(a) => println!(
                        "umich {k:02}: rows {:>4} σ {:.1} W ρ {:.2} accepted {:?} amb {:?} unexpl {} sealed RMS {:.1} -> {:.1} W",
                        log.len(), a.report.noise.sigma, a.report.noise.rho, a.report.accepted,
                        a.report.ambiguous.iter().map(|x| x.effects.clone()).collect::<Vec<_>>(),
                        a.report.unexplained.is_some(), a.report.sealed.nominal.rms, a.report.sealed.updated.rms
                    ),
                    Err(e) => println!("umich {k:02}: {e}"),
                }
            }
            Err(e) => println!("umich {k:02}: {e}"),
        }
    }
}

fn topts() -> workflow::Options {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse().ok());
    workflow::Options {
        folds: env("FOLDS").unwrap_or(5),
        fit_speed_exponent: env("GAMMA").unwrap_or(0) == 1,
        ..Default::default()
    }
}
