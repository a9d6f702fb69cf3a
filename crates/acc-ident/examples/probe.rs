//! Scratch probe: one analysis per effect at a given ENR (development aid).
use acc_ident::{synth, workflow, EffectKind};

fn main() {
    let enr: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(6.0);
    let seed: u64 = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let case = synth::Case {
        duration_s: 120.0,
        rpm: 450.0,
        ..synth::Case::default()
    };
    let t0 = std::time::Instant::now();
    let (m, log, _) = synth::generate(&case, &[], seed);
    let a = workflow::analyse(&m, &log, &workflow::Options::default()).unwrap();
    println!(
        "none: accepted {:?} amb {:?} unexpl {} ({:.2}s)",
        a.report.accepted,
        a.report.ambiguous.len(),
        a.report.unexplained.is_some(),
        t0.elapsed().as_secs_f64()
    );
    for kind in EffectKind::ALL {
        let t0 = std::time::Instant::now();
        let v = synth::value_for_enr(&case, kind, enr, seed);
        let t1 = t0.elapsed().as_secs_f64();
        let (m, log, _) = synth::generate(&case, &[synth::Hidden { kind, value: v }], seed);
        let a = workflow::analyse(&m, &log, &workflow::Options::default()).unwrap();
        let est = a
            .report
            .updated_params
            .iter()
            .find(|p| p.name.starts_with(kind.name()))
            .map(|p| format!("{:.4} [{:.4},{:.4}]", p.value, p.ci_low, p.ci_high));
        println!("{:>20} true {:.4}: accepted {:?} amb {:?} unexpl {} est {:?} sealed {:.2}->{:.2} ({:.2}s enr-search {:.2}s)", kind.name(), v, a.report.accepted, a.report.ambiguous.iter().map(|x| x.effects.clone()).collect::<Vec<_>>(), a.report.unexplained.is_some(), est, a.report.sealed.nominal.rms, a.report.sealed.updated.rms, t0.elapsed().as_secs_f64()-t1, t1);
        if std::env::var("VERBOSE").is_ok() {
            for r in &a.report.rounds {
                for c in &r.candidates {
                    if c.applicable {
                        println!("    r{} {:>20} gain {:6.2}% folds {} z {:6.2} p {:.2e} ci {} sig {:.2}->{:.2} {} pass {}", r.round, c.effect, c.heldout_gain_pct, c.folds_improved, c.heldout_chi2, c.p_adjusted, c.ci_excludes_null, c.signature_r_before, c.signature_r_after, c.signature_gone, c.passed);
                    }
                }
            }
        }
    }
}
