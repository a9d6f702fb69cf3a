//! Shared helpers of the `ident_*` tests.
// Each test binary that includes this module uses a subset of it.
#![allow(dead_code)]

use acc_ident::synth::{self, Case, Hidden, Outcome};
use acc_ident::{workflow, EffectKind};

/// The synthetic experiment of the fast grid: 120 s at 10 Hz, 450 rpm (so that runout is
/// visible in period means), noise σ = 8 W with AR(1) correlation `rho`.
pub fn case(rho: f64) -> Case {
    Case {
        duration_s: 120.0,
        rpm: 450.0,
        noise_rho: rho,
        ..Case::default()
    }
}

/// Run one hidden-effect case at effect-to-noise ratio `enr`.
pub fn run(kind: EffectKind, enr: f64, rho: f64, seed: u64) -> (Hidden, Outcome) {
    let c = case(rho);
    let h = Hidden {
        kind,
        value: synth::value_for_enr(&c, kind, enr, seed),
    };
    let o = synth::evaluate(&c, &[h], seed, &workflow::Options::default())
        .expect("workflow runs on a synthetic log");
    (h, o)
}

/// The fast-grid check of one effect: white and AR(1) noise at ENR 4 — exactly the
/// effect named, its interval covering the truth at least once, and at least 80 % of the
/// sealed-part gap the true model closes closed by the updated model.
pub fn recover(kind: EffectKind) {
    let mut covered = 0;
    for (rho, seed) in [(0.0, 11u64), (0.6, 12)] {
        let (h, o) = run(kind, 4.0, rho, seed);
        assert!(
            o.exact,
            "{}: hidden {} = {:.4} (ρ = {rho}): named {:?}, ambiguous {:?}",
            kind.name(),
            kind.name(),
            h.value,
            o.named,
            o.ambiguous
        );
        assert!(
            o.gap_closed >= 0.8,
            "{}: sealed RMS nominal {:.2} → updated {:.2}, true {:.2}: gap closed {:.2}",
            kind.name(),
            o.rms_nominal,
            o.rms_updated,
            o.rms_true,
            o.gap_closed
        );
        if o.covered[0] == Some(true) {
            covered += 1;
        }
    }
    assert!(
        covered >= 1,
        "{}: interval never covered the truth",
        kind.name()
    );
}
