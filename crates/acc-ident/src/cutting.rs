//! What a model file says about the cutting force: the machine and tool the planner
//! (`acc plan --model`, `acc optimize --model`) evaluates the mean-force law with.
//!
//! The planner predicts the mean cutting force of seed 002 eq. (1),
//! `F = Ks·a_p·d^α·f^β·s^γ`, times the tool's wear factor. The model's effects that change
//! that force are carried into the tool section:
//!
//! - `tool_wear` into `tool.wear` (as [`Model::folded`] does: the growth added, the
//!   candidate's volume exponent);
//! - `feed_exponent` into `tool.process.beta`, with `calib_force_n` moved by
//!   `(f_cal / f_ref)^Δβ` so that the force is the replay's `F·(f / f_ref)^Δβ` at every feed;
//! - `depth_exponent` into `tool.process.alpha`, `Ks` re-solved at the calibration point
//!   (as the replay does).
//!
//! The other effects do not change the mean cutting force at a given engagement and feed:
//! they change what the sensor reports or how the feed follows the override (the spindle
//! power, the measurement, the drive), the ripple within a revolution (runout: its mean over
//! a revolution is the mean force), or belong to the part the log cut (`ks_step`: a material
//! boundary at a place of that part, not a property of the tool). They are listed as not
//! used.

use std::path::Path;

use acc_config::ConfigError;

use crate::effects::EffectKind;
use crate::model::{Machine, Model, Tool};

/// The effects the cutting-force law carries (see the module docs).
pub const CUTTING_EFFECTS: [EffectKind; 3] = [
    EffectKind::ToolWear,
    EffectKind::FeedExponent,
    EffectKind::DepthExponent,
];

/// The machine and tool of a model with its cutting-force effects folded in.
#[derive(Debug, Clone, PartialEq)]
pub struct CuttingModel {
    /// The simulator machine (spindle speed, rapid rate, override step).
    pub machine: Machine,
    /// The simulator tool: geometry, force law and wear law with the effects folded in.
    pub tool: Tool,
    /// The model's effects carried into the tool.
    pub used: Vec<EffectKind>,
    /// The model's effects that do not change the mean cutting force.
    pub not_used: Vec<EffectKind>,
}

impl Model {
    /// The model's cutting-force law ([`CuttingModel`]); `path` names the model file in
    /// errors (a folded key outside the simulator's range, e.g. `tool.process.beta`).
    pub fn cutting(&self, path: &Path) -> Result<CuttingModel, ConfigError> {
        let active = self.effects.active();
        let mut m = self.folded();
        if let Some(e) = m.effects.feed_exponent.take() {
            // F·(f/f_ref)^Δβ = F_cal·(f_cal/f_ref)^Δβ·(f/f_cal)^(β+Δβ) (seed 002 eq. 1).
            let p = &mut m.tool.process;
            p.calib_force_n *= (p.calib_feed_mm_min / e.feed_ref_mm_min).powf(e.delta_beta);
            p.beta += e.delta_beta;
        }
        if let Some(e) = m.effects.depth_exponent.take() {
            m.tool.process.alpha += e.delta_alpha;
        }
        m.validate(path)?;
        let (used, not_used) = active
            .into_iter()
            .partition(|k| CUTTING_EFFECTS.contains(k));
        Ok(CuttingModel {
            machine: m.machine,
            tool: m.tool,
            used,
            not_used,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::{DepthExponent, FeedExponent, SensorGainDrift, ToolWear};
    use acc_sim::process::ForceLaw;

    fn nominal() -> Model {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        Model::load(&root.join("configs/models/paper_vmc.toml")).expect("model")
    }

    /// Each cutting effect gives the force the replay's law gives; the others are listed.
    #[test]
    fn cutting_effects_fold_into_the_tool_and_the_others_are_listed() {
        let base = nominal();
        let mut m = base.clone();
        m.effects.tool_wear = Some(ToolWear {
            ks_growth_per_cm3: 0.02,
            volume_exponent: 1.0,
        });
        m.effects.feed_exponent = Some(FeedExponent {
            delta_beta: -0.2,
            feed_ref_mm_min: 300.0,
        });
        m.effects.depth_exponent = Some(DepthExponent { delta_alpha: 0.1 });
        m.effects.sensor_gain_drift = Some(SensorGainDrift { gain_per_min: 0.01 });
        let c = m.cutting(Path::new("m.toml")).expect("cutting");
        assert_eq!(c.used, CUTTING_EFFECTS.to_vec());
        assert_eq!(c.not_used, vec![EffectKind::SensorGainDrift]);
        assert!((c.tool.wear.growth_per_cm3 - 0.02).abs() < 1e-12);
        let law = ForceLaw::new(c.tool.process);
        let mut with_alpha = base.tool.process;
        with_alpha.alpha += 0.1;
        let replay_law = ForceLaw::new(with_alpha);
        for (r, f) in [(2.0, 200.0), (3.0, 120.0), (1.0, 450.0)] {
            let want = replay_law.mean_force_n(r, 16.0, f, 600.0, 1.0) * (f / 300.0).powf(-0.2);
            let got = law.mean_force_n(r, 16.0, f, 600.0, 1.0);
            assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
        }
        // Out of the simulator's range after folding: named by key.
        let mut bad = base.clone();
        bad.tool.process.beta = 0.2;
        bad.effects.feed_exponent = Some(FeedExponent {
            delta_beta: -0.15,
            feed_ref_mm_min: 300.0,
        });
        let e = bad.cutting(Path::new("m.toml")).expect_err("β below 0.1");
        assert!(e.to_string().contains("tool.process.beta"), "{e}");
    }
}
