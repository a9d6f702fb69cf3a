//! An acceleration-limited feed: the feed drive's input may change by at most `a` along the
//! path, `|df/dt| ≤ 60·a` (f in mm/min, a in mm/s²), the way a motion controller's
//! trajectory planner limits the tangential acceleration (LinuxCNC's `[AXIS_*]
//! MAX_ACCELERATION` on a move along one axis). The limited feed then drives the lag(s) of
//! the feed drive ([`crate::machine::Machine::advance`]).

/// The feed's rate limit and its state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccelLimit {
    /// Largest change of the feed, mm/min per s (60 × the acceleration in mm/s²); 0: none.
    rate_mm_min_per_s: f64,
    /// The limited feed, mm/min.
    feed_mm_min: f64,
}

impl AccelLimit {
    /// A limit of `accel_mm_s2` (mm/s², 0: no limit), starting at rest.
    pub fn new(accel_mm_s2: f64) -> Self {
        AccelLimit {
            rate_mm_min_per_s: 60.0 * accel_mm_s2.max(0.0),
            feed_mm_min: 0.0,
        }
    }

    /// Whether the feed is limited at all.
    pub fn is_on(&self) -> bool {
        self.rate_mm_min_per_s > 0.0
    }

    /// The feed after `dt_s` (s) towards `target_mm_min` (mm/min): the target itself
    /// without a limit, else at most `60·a·dt` closer to it.
    pub fn step(&mut self, target_mm_min: f64, dt_s: f64) -> f64 {
        if !self.is_on() {
            self.feed_mm_min = target_mm_min;
            return target_mm_min;
        }
        let max = self.rate_mm_min_per_s * dt_s;
        self.feed_mm_min += (target_mm_min - self.feed_mm_min).clamp(-max, max);
        self.feed_mm_min
    }

    /// The time this limit needs to bring a feed of `feed_mm_min` (mm/min) from rest, s (0
    /// without a limit).
    pub fn ramp_time_s(&self, feed_mm_min: f64) -> f64 {
        if self.is_on() {
            feed_mm_min.abs() / self.rate_mm_min_per_s
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_feed_ramps_at_the_acceleration_and_is_the_target_without_a_limit() {
        // 50 mm/s² = 3000 mm/min per s: 450 mm/min in 0.15 s.
        let mut a = AccelLimit::new(50.0);
        let mut f = 0.0;
        for _ in 0..100 {
            f = a.step(450.0, 0.001);
        }
        assert!((f - 300.0).abs() < 1e-9, "{f}");
        for _ in 0..100 {
            f = a.step(450.0, 0.001);
        }
        assert_eq!(f, 450.0);
        assert!((a.ramp_time_s(450.0) - 0.15).abs() < 1e-12);
        let mut none = AccelLimit::new(0.0);
        assert_eq!(none.step(450.0, 0.001), 450.0);
        assert_eq!(none.ramp_time_s(450.0), 0.0);
    }
}
