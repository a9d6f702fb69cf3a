//! Hidden-effect recovery, fast grid, process and spindle effects: for each
//! effect, one log with white and one with AR(1) noise at effect-to-noise ratio 4; the
//! nominal model lacks the effect. The full sweep (confusion matrix, recovery against
//! size, 200-seed false-discovery rate) is `cargo run --release -p acc-ident --example twin_lab -- sweep`.

use acc_ident::EffectKind;

#[test]
fn tool_wear_is_recovered() {
    crate::ident_common::recover(EffectKind::ToolWear);
}

#[test]
fn motor_efficiency_is_recovered() {
    crate::ident_common::recover(EffectKind::MotorEfficiency);
}

#[test]
fn feed_exponent_is_recovered() {
    crate::ident_common::recover(EffectKind::FeedExponent);
}

#[test]
fn runout_is_recovered() {
    crate::ident_common::recover(EffectKind::Runout);
}
