//! The override mapping between acc's law (0–150 %) and LinuxCNC 2.9's
//! `motion.adaptive-feed`, which is clamped to [−1, 1] (docs/linuxcnc.md, "The override
//! mapping").
//!
//! The machine runs under acc with `[DISPLAY] MAX_FEED_OVERRIDE = 1.5` and the operator's
//! feed override at 150 %; the two multiply, so the feed is
//! `F × feed_override × adaptive_feed`, and the law's override `u` reaches the motion as
//! `adaptive_feed = u / 150 %`.

/// The law's highest override, percent; 1.0 on the adaptive-feed pin.
pub const LAW_MAX_PCT: f64 = 150.0;

/// `motion.motion-type` of a traverse (G0), 2.9.
pub const MOTION_TYPE_TRAVERSE: i32 = 1;

/// The adaptive feed for the law's override `law_pct` (percent): `law_pct / 150`, in [0, 1].
/// During a traverse it is 1.0: the pin scales rapids too, and acc never slows a rapid.
pub fn adaptive_feed(law_pct: u16, motion_type: i32) -> f64 {
    if motion_type == MOTION_TYPE_TRAVERSE {
        return 1.0;
    }
    (f64::from(law_pct) / LAW_MAX_PCT).clamp(0.0, 1.0)
}

/// The override the motion applies, percent of the programmed feed, in the law's frame:
/// `100 × feed_override × adaptive_feed` (the operator's override as a ratio, 1.5 = 150 %).
pub fn applied_pct(feed_override: f64, adaptive_feed: f64) -> u16 {
    ratio_pct(feed_override * adaptive_feed)
}

/// A ratio (1.5) as whole percent (150), clamped to `0..=u16::MAX`.
pub fn ratio_pct(ratio: f64) -> u16 {
    (100.0 * ratio).round().clamp(0.0, f64::from(u16::MAX)) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_laws_range_maps_onto_the_clamped_pin_and_back() {
        assert_eq!(adaptive_feed(150, 0), 1.0);
        assert_eq!(adaptive_feed(75, 2), 0.5);
        assert_eq!(adaptive_feed(0, 2), 0.0);
        // The operator at 150 %: the motion applies the law's override.
        for law in [0u16, 30, 75, 100, 120, 150] {
            assert_eq!(applied_pct(1.5, adaptive_feed(law, 2)), law);
        }
        // The operator turns down to 100 %: the feed drops by a third at once.
        assert_eq!(applied_pct(1.0, adaptive_feed(150, 2)), 100);
    }

    #[test]
    fn a_traverse_is_never_slowed() {
        assert_eq!(adaptive_feed(30, MOTION_TYPE_TRAVERSE), 1.0);
    }

    #[test]
    fn checked_on_linuxcnc_f600_at_150_percent() {
        // docs/linuxcnc.md: adaptive 1.0 / 0.5 gave 900 / 450 mm/min on F600.
        let feed = |adaptive: f64| 600.0 * f64::from(applied_pct(1.5, adaptive)) / 100.0;
        assert_eq!(feed(1.0), 900.0);
        assert_eq!(feed(0.5), 450.0);
    }
}
