//! Extra names: every name after the first must improve the prediction of the sealed part
//! beyond its own noise.
//!
//! With the final model's residual `r` over the sealed rows and `d` the change the name
//! makes to the prediction there — the final model's prediction less that of the model the
//! name was added to, as that model was fitted without it — the sealed sum of squares
//! falls by `ΔSSE = Σ(r + d)² − Σr² = 2Σr·d + Σd²`. If the name is real, `r` is noise and
//! `ΔSSE ≈ ‖d‖²`; if it is not, `ΔSSE ≈ −‖d‖²`; the noise's share `2Σr·d` has the standard
//! deviation `2σ‖d‖·√((1 + ρ)/(1 − ρ))` (AR(1) noise σ, ρ). A name after the first stands
//! only when `ΔSSE` exceeds `z_{1−α}` of those. The first that does not is withheld, and
//! the updated model goes back to the one it was added to (with it go the names added
//! after it, fitted on top of it).
//!
//! The comparison is with the model fitted without the name, not with the final model
//! less the name's term: the earlier names' parameters move when a name joins them (the
//! wear curve of turning tool 3 bends to leave room for a `Ks` step), and only the model
//! that was fitted without the name tells what the name added.

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

/// The sealed-part test of a name: `model` the final model, `before` the model the name
/// was added to (fitted without it).
pub(super) fn sealed_gain(p: &Prepared, model: &Model, before: &Model, alpha: f64) -> SealedGain {
    let with = replay(model, &p.inp).predicted;
    let without = replay(before, &p.inp).predicted;
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

/// Test every name after the first in the order they were added; at the first that fails,
/// withhold it and every later name and put `s` back to the state it was added to.
pub(super) fn withhold_extra_names(s: &mut Selection, p: &Prepared, alpha: f64) {
    let unit = p.inp.channel.unit();
    let named = s.named();
    for e in named.iter().skip(1) {
        let Some(i) = s.accepted.iter().position(|k| k.name() == e) else {
            continue;
        };
        let g = sealed_gain(p, &s.base_model, &s.before[i].model, alpha);
        if g.passes() {
            continue;
        }
        let reason = format!(
            "as a name after the first it does not improve the prediction of the sealed part beyond its own noise: against the model fitted without it, the sealed sum of squares falls by {:.3} {unit}² against {:.3} {unit}² the noise makes of a change of {:.3} {unit} RMS; the updated model is the one without it",
            g.sse_drop, g.threshold, g.change_rms
        );
        s.withheld_extra.push(Withheld {
            effect: e.clone(),
            reason,
        });
        for later in &s.accepted[i + 1..] {
            s.withheld_extra.push(Withheld {
                effect: later.name().into(),
                reason: format!("added after `{e}`, which is not named, and fitted on top of it"),
            });
        }
        let state = s.before[i].clone();
        s.base_model = state.model;
        s.base_free = state.free;
        s.base_params = state.params;
        s.params_start = state.params_start;
        s.accepted.truncate(i);
        s.before.truncate(i);
        break;
    }
}
