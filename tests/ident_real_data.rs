//! Real data (issue 6). Data: `../shared/data/` — Vicomtech turning tool-wear data
//! (CC BY-SA 4.0; Ferrando Chacón et al., Int. J. Adv. Manuf. Technol. 125 (2023)
//! 4027–4045; raw data Mondragon Unibertsitatea) and the University of Michigan SMART lab
//! CNC mill tool-wear data (CC0). Skipped with a message when the folder is absent.

use std::path::PathBuf;

use acc_ident::{import, workflow, EffectKind};

fn data() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!("skip: {} not found", p.display());
        None
    }
}

/// Turning, flank-wear column withheld, constant-Ks model calibrated on the first 20 % of
/// each tool: tool wear is the only effect named, on most tools, and on every tool where
/// it is named the sealed late part's RMS error shrinks against the refitted nominal.
#[test]
fn turning_names_tool_wear_and_shrinks_the_late_gap() {
    let Some(root) = data() else { return };
    let tools = import::vicomtech_turning(&root.join("vicomtech-turning/tool_wear_tools_3-10.csv"))
        .expect("imports");
    assert_eq!(tools.len(), 7);
    let mut wear_named = 0;
    let mut shrink = Vec::new();
    for (id, mut log) in tools {
        log.wear_vb_um = None;
        let model = import::turning_model(&log, 0.2);
        let a = workflow::analyse(&model, &log, &workflow::Options::default()).expect("runs");
        let r = &a.report;
        let others: Vec<&String> = r.accepted.iter().filter(|n| *n != "tool_wear").collect();
        assert!(others.is_empty(), "tool {id}: named {:?}", r.accepted);
        for amb in &r.ambiguous {
            assert!(
                amb.effects.iter().any(|e| e == "tool_wear"),
                "tool {id}: {amb:?}"
            );
        }
        if r.accepted.iter().any(|n| n == EffectKind::ToolWear.name()) {
            wear_named += 1;
            let s = &r.sealed;
            assert!(
                s.updated.rms < s.nominal_refit.rms && s.updated.rms < s.nominal.rms,
                "tool {id}: late RMS nominal {:.1}, refit {:.1}, updated {:.1}",
                s.nominal.rms,
                s.nominal_refit.rms,
                s.updated.rms
            );
            shrink.push(s.rms_reduction_pct);
        }
    }
    assert!(
        wear_named >= 4,
        "tool wear named on {wear_named} of 7 tools"
    );
    let mean = shrink.iter().sum::<f64>() / shrink.len() as f64;
    assert!(mean > 50.0, "mean late-part RMS reduction {mean:.1} %");
}

/// Wax milling: spindle power is no-load loss plus noise; no effect may be named.
#[test]
fn wax_milling_invents_no_effect() {
    let Some(root) = data() else { return };
    let mut analysed = 0;
    for k in 1..=12 {
        let log = import::umich_mill(&root.join(format!("umich-cnc-mill/experiment_{k:02}.csv")))
            .expect("imports");
        let model = import::umich_model(&log);
        match workflow::analyse(&model, &log, &workflow::Options::default()) {
            Ok(a) => {
                analysed += 1;
                assert!(
                    a.report.accepted.is_empty() && a.report.ambiguous.is_empty(),
                    "experiment {k}: {}",
                    a.report.conclusion
                );
                // The noise floor is the README's ≈ 19 W sample-to-sample noise.
                assert!(
                    (10.0..40.0).contains(&a.report.noise.sigma),
                    "σ {}",
                    a.report.noise.sigma
                );
            }
            Err(workflow::WorkflowError::TooShort { .. }) => {}
            Err(e) => panic!("experiment {k}: {e}"),
        }
    }
    assert!(analysed >= 10, "{analysed} experiments analysed");
}
