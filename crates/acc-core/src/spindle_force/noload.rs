//! No-load (air-cut) power and current of the spindle as a function of speed.
//!
//! Every estimator subtracts what the spindle draws without cutting: `P_air` in the power
//! method (seed 000 eq. 14), `I_air` in the current methods (seed 000 eq. 6). Both depend
//! on speed (friction ∝ n, windage and iron loss grow faster), so the model keeps one bin
//! per learned speed and interpolates linearly between bins.
//!
//! # Learning and adaptation
//!
//! * **Learning** ([`NoLoadModel::learn`]) is explicit: the caller knows the period is an
//!   air cut (a calibration run, or the NC reports a rapid/air move). It creates a bin for
//!   a new speed or averages into an existing one, and records the period-to-period
//!   scatter (σ) that sets the noise floor.
//! * **Adaptation while running** ([`NoLoadModel::observe`]) tracks slow drift (warm-up
//!   lowers bearing friction, the drive heats up). The rule, all parts required
//!   ([`AdaptRule`]):
//!   1. adaptation is enabled;
//!   2. the speed has been steady (within `speed_tolerance`) for `steady_periods`
//!      consecutive periods — a speed change makes acceleration power;
//!   3. a bin exists at this speed (adaptation never invents a speed);
//!   4. the period looks like air: `|P − P_air(n)| ≤ max(band_sigma·σ, min_band_frac·P_air)`,
//!      and this has held for `air_periods` consecutive periods (so tool entries do not
//!      count);
//!   5. the bin moves by `rate·(P − P_air)` (an EWMA) and never further than
//!      `max_drift_frac·P_air,cal` from its learned value.
//!
//!   A cut that is clearly above the band never adapts the model. A load hidden inside the
//!   band is at most `band` watts (about the estimator's 3σ noise floor), absorbed at `rate`
//!   per period, and the drift limit bounds what any sequence of such periods can do.

use serde::{Deserialize, Serialize};

use super::SpindleError;

/// Most speeds the model holds (the table is allocated once, at construction).
pub const MAX_BINS: usize = 64;

/// One learned speed of the no-load model (also the TOML form).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoLoadPoint {
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// Mean no-load input power `P_air`, W.
    pub power_w: f64,
    /// Mean no-load RMS current `I_air`, A.
    pub current_a: f64,
    /// Period-to-period standard deviation of the air-cut power, W.
    #[serde(default)]
    pub sigma_power_w: f64,
    /// Period-to-period standard deviation of the air-cut current, A.
    #[serde(default)]
    pub sigma_current_a: f64,
    /// Number of periods averaged.
    #[serde(default)]
    pub periods: u32,
}

/// The adaptation rule (see the module documentation). TOML keys are the field names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdaptRule {
    /// Adapt while running. Default `true`.
    pub enabled: bool,
    /// Relative speed tolerance for "same speed" and "steady", −. Default 0.01.
    pub speed_tolerance: f64,
    /// Consecutive steady-speed periods required. Default 5.
    pub steady_periods: u32,
    /// Consecutive air-looking periods required before an update. Default 10.
    pub air_periods: u32,
    /// Half-width of the air band in σ of the learned air-cut power. Default 4.
    pub band_sigma: f64,
    /// Lower bound of the band as a fraction of `P_air`, −. Default 0.01.
    pub min_band_frac: f64,
    /// EWMA weight per update, −. Default 0.02.
    pub rate: f64,
    /// Largest total drift from the learned value, fraction of it, −. Default 0.1.
    pub max_drift_frac: f64,
    /// How far outside the learned speed range the model may be used, fraction of the
    /// range end, −. Default 0.1.
    pub extrapolate_frac: f64,
}

impl Default for AdaptRule {
    fn default() -> Self {
        Self {
            enabled: true,
            speed_tolerance: 0.01,
            steady_periods: 5,
            air_periods: 10,
            band_sigma: 4.0,
            min_band_frac: 0.01,
            rate: 0.02,
            max_drift_frac: 0.1,
            extrapolate_frac: 0.1,
        }
    }
}

/// The no-load values at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoLoad {
    /// `P_air`, W.
    pub power_w: f64,
    /// `I_air`, A.
    pub current_a: f64,
    /// σ of the air-cut power, W.
    pub sigma_power_w: f64,
    /// σ of the air-cut current, A.
    pub sigma_current_a: f64,
    /// `true` if the speed lies outside the learned range (linear extrapolation).
    pub extrapolated: bool,
}

/// What [`NoLoadModel::observe`] did with a period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AdaptOutcome {
    /// Adaptation is off.
    Disabled,
    /// The speed changed recently.
    SpeedUnsteady,
    /// No learned bin at this speed.
    NoBin,
    /// Outside the air band: a cut (or a transient).
    Loaded,
    /// Air-looking, but not yet for `air_periods` periods.
    Waiting,
    /// The bin moved by this many watts.
    Adapted(f64),
}

#[derive(Debug, Clone, Copy)]
struct Bin {
    point: NoLoadPoint,
    /// Learned `P_air` (the anchor of the drift limit), W.
    learned_power_w: f64,
    /// Welford sums of squares for σ.
    m2_power: f64,
    m2_current: f64,
}

/// The no-load model: learned speeds, interpolation, adaptation state.
#[derive(Debug, Clone)]
pub struct NoLoadModel {
    bins: Vec<Bin>,
    rule: AdaptRule,
    last_rpm: f64,
    steady_count: u32,
    air_count: u32,
    adaptations: u64,
}

impl NoLoadModel {
    /// An empty model.
    pub fn new(rule: AdaptRule) -> Self {
        Self {
            bins: Vec::with_capacity(MAX_BINS),
            rule,
            last_rpm: f64::NAN,
            steady_count: 0,
            air_count: 0,
            adaptations: 0,
        }
    }

    /// A model from saved points (e.g. a calibration file).
    pub fn from_points(points: &[NoLoadPoint], rule: AdaptRule) -> Result<Self, SpindleError> {
        let mut m = Self::new(rule);
        for p in points {
            if !(p.rpm > 0.0 && p.power_w.is_finite() && p.current_a >= 0.0) {
                return Err(SpindleError::BadNoLoadPoint { rpm: p.rpm });
            }
            let i = m.insert_index(p.rpm)?;
            let n = f64::from(p.periods.max(1));
            m.bins.insert(
                i,
                Bin {
                    point: *p,
                    learned_power_w: p.power_w,
                    m2_power: p.sigma_power_w.powi(2) * (n - 1.0),
                    m2_current: p.sigma_current_a.powi(2) * (n - 1.0),
                },
            );
        }
        Ok(m)
    }

    /// The learned points, sorted by speed.
    pub fn points(&self) -> impl Iterator<Item = NoLoadPoint> + '_ {
        self.bins.iter().map(|b| b.point)
    }

    /// The adaptation rule.
    pub fn rule(&self) -> &AdaptRule {
        &self.rule
    }

    /// Turn adaptation on or off.
    pub fn set_adapt(&mut self, enabled: bool) {
        self.rule.enabled = enabled;
    }

    /// Number of adaptation updates so far.
    pub fn adaptations(&self) -> u64 {
        self.adaptations
    }

    /// `true` when nothing has been learned.
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    fn find(&self, rpm: f64) -> Option<usize> {
        let tol = self.rule.speed_tolerance;
        self.bins
            .iter()
            .position(|b| (b.point.rpm - rpm).abs() <= tol * b.point.rpm)
    }

    fn insert_index(&self, rpm: f64) -> Result<usize, SpindleError> {
        if self.bins.len() >= MAX_BINS {
            return Err(SpindleError::TooManySpeeds { max: MAX_BINS });
        }
        Ok(self.bins.partition_point(|b| b.point.rpm < rpm))
    }

    /// Learn one known air-cut period at `rpm` (explicit: the caller knows there is no cut).
    pub fn learn(&mut self, rpm: f64, power_w: f64, current_a: f64) -> Result<(), SpindleError> {
        if !(rpm > 0.0 && power_w.is_finite() && current_a.is_finite() && current_a >= 0.0) {
            return Err(SpindleError::BadNoLoadPoint { rpm });
        }
        let i = match self.find(rpm) {
            Some(i) => i,
            None => {
                let i = self.insert_index(rpm)?;
                self.bins.insert(
                    i,
                    Bin {
                        point: NoLoadPoint {
                            rpm,
                            power_w: 0.0,
                            current_a: 0.0,
                            sigma_power_w: 0.0,
                            sigma_current_a: 0.0,
                            periods: 0,
                        },
                        learned_power_w: 0.0,
                        m2_power: 0.0,
                        m2_current: 0.0,
                    },
                );
                i
            }
        };
        let b = &mut self.bins[i];
        // Welford's running mean and variance.
        b.point.periods = b.point.periods.saturating_add(1);
        let n = f64::from(b.point.periods);
        let dp = power_w - b.point.power_w;
        b.point.power_w += dp / n;
        b.m2_power += dp * (power_w - b.point.power_w);
        let di = current_a - b.point.current_a;
        b.point.current_a += di / n;
        b.m2_current += di * (current_a - b.point.current_a);
        if n > 1.0 {
            b.point.sigma_power_w = (b.m2_power / (n - 1.0)).sqrt();
            b.point.sigma_current_a = (b.m2_current / (n - 1.0)).sqrt();
        }
        b.learned_power_w = b.point.power_w;
        Ok(())
    }

    /// The no-load values at `rpm`: the bin within `speed_tolerance`, else linear
    /// interpolation between the neighbouring bins, else linear extrapolation within
    /// `extrapolate_frac` of the range end (one bin: its value). `None` outside that.
    pub fn lookup(&self, rpm: f64) -> Option<NoLoad> {
        let n = self.bins.len();
        if n == 0 || !rpm.is_finite() {
            return None;
        }
        if let Some(i) = self.find(rpm) {
            return Some(Self::value(&self.bins[i].point, false));
        }
        let lo = self.bins[0].point.rpm;
        let hi = self.bins[n - 1].point.rpm;
        let x = self.rule.extrapolate_frac;
        if rpm < lo * (1.0 - x) || rpm > hi * (1.0 + x) {
            return None;
        }
        if n == 1 {
            return Some(Self::value(&self.bins[0].point, true));
        }
        let j = self
            .bins
            .partition_point(|b| b.point.rpm < rpm)
            .clamp(1, n - 1);
        let (a, b) = (&self.bins[j - 1].point, &self.bins[j].point);
        let t = (rpm - a.rpm) / (b.rpm - a.rpm);
        let lerp = |u: f64, v: f64| u + t * (v - u);
        Some(NoLoad {
            power_w: lerp(a.power_w, b.power_w),
            current_a: lerp(a.current_a, b.current_a).max(0.0),
            sigma_power_w: lerp(a.sigma_power_w, b.sigma_power_w).abs(),
            sigma_current_a: lerp(a.sigma_current_a, b.sigma_current_a).abs(),
            extrapolated: !(0.0..=1.0).contains(&t),
        })
    }

    fn value(p: &NoLoadPoint, extrapolated: bool) -> NoLoad {
        NoLoad {
            power_w: p.power_w,
            current_a: p.current_a,
            sigma_power_w: p.sigma_power_w,
            sigma_current_a: p.sigma_current_a,
            extrapolated,
        }
    }

    /// Half-width of the air band at a bin, W.
    fn band_w(&self, p: &NoLoadPoint) -> f64 {
        (self.rule.band_sigma * p.sigma_power_w).max(self.rule.min_band_frac * p.power_w.abs())
    }

    /// Feed one running period to the adaptation rule (module documentation). Call it once
    /// per valid period, cutting or not; it decides.
    pub fn observe(&mut self, rpm: f64, power_w: f64, current_a: f64) -> AdaptOutcome {
        let tol = self.rule.speed_tolerance;
        let steady = self.last_rpm.is_finite() && (rpm - self.last_rpm).abs() <= tol * rpm.abs();
        self.last_rpm = rpm;
        if steady {
            self.steady_count = self.steady_count.saturating_add(1);
        } else {
            self.steady_count = 0;
            self.air_count = 0;
        }
        if !self.rule.enabled {
            return AdaptOutcome::Disabled;
        }
        if self.steady_count < self.rule.steady_periods {
            return AdaptOutcome::SpeedUnsteady;
        }
        let Some(i) = self.find(rpm) else {
            self.air_count = 0;
            return AdaptOutcome::NoBin;
        };
        let p = self.bins[i].point;
        let dev = power_w - p.power_w;
        if !dev.is_finite() || dev.abs() > self.band_w(&p) {
            self.air_count = 0;
            return AdaptOutcome::Loaded;
        }
        self.air_count = self.air_count.saturating_add(1);
        if self.air_count < self.rule.air_periods {
            return AdaptOutcome::Waiting;
        }
        let b = &mut self.bins[i];
        let limit = self.rule.max_drift_frac * b.learned_power_w.abs();
        let target = (b.point.power_w + self.rule.rate * dev)
            .clamp(b.learned_power_w - limit, b.learned_power_w + limit);
        let moved = target - b.point.power_w;
        b.point.power_w = target;
        if current_a.is_finite() {
            b.point.current_a += self.rule.rate * (current_a - b.point.current_a);
        }
        self.adaptations += 1;
        AdaptOutcome::Adapted(moved)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> NoLoadModel {
        let mut m = NoLoadModel::new(AdaptRule::default());
        for k in 0..20 {
            let e = if k % 2 == 0 { 5.0 } else { -5.0 };
            m.learn(1000.0, 400.0 + e, 20.0).unwrap();
            m.learn(2000.0, 900.0 + e, 22.0).unwrap();
        }
        m
    }

    #[test]
    fn learns_mean_sigma_and_interpolates() {
        let m = model();
        let a = m.lookup(1005.0).unwrap();
        assert!((a.power_w - 400.0).abs() < 1e-9);
        assert!((a.sigma_power_w - 5.13).abs() < 0.01, "{}", a.sigma_power_w);
        let mid = m.lookup(1500.0).unwrap();
        assert!((mid.power_w - 650.0).abs() < 1e-9 && !mid.extrapolated);
        let ext = m.lookup(2150.0).unwrap();
        assert!(ext.extrapolated && (ext.power_w - 975.0).abs() < 1e-9);
        assert!(m.lookup(2300.0).is_none());
        assert!(m.lookup(850.0).is_none());
    }

    #[test]
    fn adaptation_follows_drift_but_not_cuts() {
        let mut m = model();
        // Warm-up: true no-load power falls by 20 W; no cut.
        for _ in 0..400 {
            m.observe(1000.0, 380.0, 20.0);
        }
        let p = m.lookup(1000.0).unwrap().power_w;
        assert!((p - 380.0).abs() < 1.0, "tracked drift: {p}");
        // A cut adding 300 W for a long time never moves the model.
        for _ in 0..400 {
            assert_eq!(m.observe(1000.0, 680.0, 25.0), AdaptOutcome::Loaded);
        }
        assert_eq!(m.lookup(1000.0).unwrap().power_w, p);
    }

    #[test]
    fn drift_is_bounded_and_rule_can_be_disabled() {
        let mut m = model();
        // A persistent small offset inside the band: the bin may move at most 10 %.
        for _ in 0..5000 {
            let p = m.lookup(1000.0).unwrap().power_w;
            m.observe(1000.0, p - 15.0, 20.0);
        }
        assert!((m.lookup(1000.0).unwrap().power_w - 360.0).abs() < 1e-6);
        let mut m = model();
        m.set_adapt(false);
        for _ in 0..100 {
            assert_eq!(m.observe(1000.0, 380.0, 20.0), AdaptOutcome::Disabled);
        }
        assert_eq!(m.lookup(1000.0).unwrap().power_w, 400.0);
    }

    #[test]
    fn speed_change_resets_the_count() {
        let mut m = model();
        for _ in 0..30 {
            m.observe(1000.0, 398.0, 20.0);
        }
        assert_eq!(m.observe(2000.0, 900.0, 22.0), AdaptOutcome::SpeedUnsteady);
        assert_eq!(m.observe(1500.0, 650.0, 21.0), AdaptOutcome::SpeedUnsteady);
        for _ in 0..5 {
            m.observe(1500.0, 650.0, 21.0);
        }
        assert_eq!(m.observe(1500.0, 650.0, 21.0), AdaptOutcome::NoBin);
    }
}
