//! The mean-force law solved for the feed: the feed (or override) at which a force becomes
//! the reference.

/// The feed at which the force `force_n` (N), predicted at feed `feed`, becomes the
/// reference `force_ref_n` (N): `feed · (Fr / F)^(1/β)`, in the unit of `feed` (mm/min, or
/// percent of the programmed feed for an override: `feed` = 100 gives `100 · (Fr/F)^(1/β)`).
///
/// Source: the process model `F = Ks · d^α · f^β · s^γ` (seed 002 eq. 1, `physics.md`
/// §1): at fixed engagement and speed `F ∝ f^β`, so `F(f') = F · (f'/f)^β`, and
/// `F(f') = Fr` gives `f' = f · (Fr/F)^(1/β)`. `feed_exponent` is β (> 0). The caller
/// checks that `force_n` and `force_ref_n` are positive.
///
/// ```
/// // 2 400 N at 100 % with β = 1: 800 N at a third of the feed.
/// let o = acc_core::force_law::feed_for_force(100.0, 2400.0, 800.0, 1.0);
/// assert!((o - 100.0 / 3.0).abs() < 1e-12);
/// ```
pub fn feed_for_force(feed: f64, force_n: f64, force_ref_n: f64, feed_exponent: f64) -> f64 {
    feed * (force_ref_n / force_n).powf(1.0 / feed_exponent)
}
