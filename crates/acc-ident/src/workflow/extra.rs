//! Extra names: every name after the first must improve the prediction of the sealed part
//! beyond its own noise.
//!
//! With the final model's residual `r` over the sealed rows and `d` the change the effect
//! makes to the prediction there (with − without it, the other parameters as fitted), the
//! sealed sum of squares falls by `ΔSSE = Σ(r + d)² − Σr² = 2Σr·d + Σd²`. If the effect is
//! real, `r` is noise and `ΔSSE ≈ ‖d‖²`; if it is not, `ΔSSE ≈ −‖d‖²`; the noise's share
//! `2Σr·d` has the standard deviation `2σ‖d‖·√((1 + ρ)/(1 − ρ))` (AR(1) noise σ, ρ). A
//! name after the first stands only when `ΔSSE` exceeds `z_{1−α}` of those.

use super::*;

/// The sealed-part test of one name.
pub(super) struct SealedGain {
    /// `ΔSSE` over the sealed rows, channel unit².
    pub sse_drop: f64,
    /// `z_{1−α}·2σ‖d‖·√((1 + ρ)/(1 − ρ))`, channel unit².
    pub threshold: f64,
    /// RMS of the effect's change to the sealed prediction `d`, channel unit.
    pub change_rms: f64,
}

impl SealedGain {
    /// Whether the name improves the sealed prediction beyond the noise.
    pub fn passes(&self) -> bool {
        self.sse_drop > self.threshold
    }
}

/// The sealed-part test of `kind` in `model` (the final model, effects as fitted deltas).
pub(super) fn sealed_gain(p: &Prepared, model: &Model, kind: EffectKind, alpha: f64) -> SealedGain {
    let with = replay(model, &p.inp).predicted;
    let mut m = model.clone();
    m.effects.remove(kind);
    let without = replay(&m, &p.inp).predicted;
    let r: Vec<f64> = (0..p.n).map(|i| p.inp.measured[i] - with[i]).collect();
    let noise = noise_of(&r, &p.sel_segs, &p.sel, p.q_floor);
    let (mut drop, mut dd) = (0.0, 0.0);
    for &i in &p.sealed_rows {
        let d = with[i] - without[i];
        drop += (r[i] + d).powi(2) - r[i].powi(2);
        dd += d * d;
    }
    let rho = noise.rho.clamp(0.0, 0.99);
    let inflation = ((1.0 + rho) / (1.0 - rho)).sqrt();
    SealedGain {
        sse_drop: drop,
        threshold: normal_quantile(1.0 - alpha) * 2.0 * noise.sigma * dd.sqrt() * inflation,
        change_rms: (dd / p.sealed_rows.len().max(1) as f64).sqrt(),
    }
}
