//! An effect outside the library is reported as unexplained, with where, and not
//! misnamed as one of the library's effects.

use acc_ident::replay::{replay, Inputs};
use acc_ident::{synth, workflow};

/// A hard inclusion: `Ks` +40 % for 8 s of cutting (t = 48–56 s), not a candidate.
#[test]
fn hard_inclusion_is_unexplained_not_misnamed() {
    let c = crate::ident_common::case(0.0);
    let (model, mut log, _) = synth::generate(&c, &[], 31);
    let inp = Inputs::from_log(&log, &model).expect("inputs");
    let r = replay(&model, &inp);
    let spindle = model.machine.spindle;
    if let Some(p) = log.power_w.as_mut() {
        for ((p, t), pc) in p.iter_mut().zip(&log.t_s).zip(&r.cut_power_w) {
            if (48.0..56.0).contains(t) {
                *p += 0.4 * pc / spindle.efficiency;
            }
        }
    }
    let a = workflow::analyse(&model, &log, &workflow::Options::default()).expect("runs");
    assert!(
        a.report.accepted.is_empty() && a.report.ambiguous.is_empty(),
        "misnamed: {:?} {:?}",
        a.report.accepted,
        a.report.ambiguous
    );
    let un = a
        .report
        .unexplained
        .as_ref()
        .expect("reported as unexplained");
    assert!(
        un.segments
            .iter()
            .any(|s| s.t_start_s < 56.0 && s.t_end_s > 48.0),
        "no flagged segment overlaps 48–56 s: {:?}",
        un.segments
    );
    assert!(a.report.conclusion.contains("Unexplained"));
}
