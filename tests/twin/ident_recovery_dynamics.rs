//! Hidden-effect recovery, fast grid, dynamic and drift effects: for each
//! effect, one log with white and one with AR(1) noise at effect-to-noise ratio 4; the
//! nominal model lacks the effect. The full sweep is
//! `cargo run --release -p acc-ident --example twin_lab -- sweep`.

use acc_ident::EffectKind;

#[test]
fn feed_drive_lag_is_recovered() {
    crate::ident_common::recover(EffectKind::FeedDriveLag);
}

#[test]
fn sensor_lowpass_is_recovered() {
    crate::ident_common::recover(EffectKind::SensorLowpass);
}

#[test]
fn override_dead_time_is_recovered() {
    crate::ident_common::recover(EffectKind::OverrideDeadTime);
}

#[test]
fn noload_drift_is_recovered() {
    crate::ident_common::recover(EffectKind::NoloadDrift);
}
