//! The look-ahead's tuning: one struct, read once at construction. Every field names its
//! unit and its default ([`LookAheadConfig::new`]); docs/plan.md explains each rule.

/// The run's values and the tuning of the look-ahead and the plan's lead.
///
/// Two sizes are not tuning but the capacity of rings kept without allocation:
/// [`super::scale::SCALE_SAMPLES`] and [`super::block_start::RECENT_PERIODS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LookAheadConfig {
    /// The grid's maximum override, % (the policy's `max_override_pct`; no default).
    pub max_pct: u16,
    /// The loop's force reference Fr, N (the scenario's or the tool's; no default): inside
    /// a row whose force is linear along it, the cap is the override that gives Fr at the
    /// part the tool can reach.
    pub force_ref_n: f64,
    /// The plan's lead sets the command while the tool cuts and the plan agrees with the
    /// measurement (`--plan-lead`); default `false`: the plan only caps the law's command.
    pub lead: bool,
    /// How far ahead the cap looks, s of travel at the override in force or the cap found
    /// so far. Default 2 T: the period, the override delay and the feed drive's lag of the
    /// shipped machines (16 ms and 8 ms against T = 0.1 s).
    pub horizon_s: f64,
    /// Time from writing a command to the feed following it, s: the board's override delay
    /// plus the feed drive's lag, with margin. Default 0.3 T (30 ms against the shipped
    /// machines' 16 ms + 8 ms at T = 0.1 s). The lead judges every period that can start
    /// within it.
    pub command_delay_s: f64,
    /// Relative tolerance of the disagreement check, − (default 0.25).
    pub tolerance: f64,
    /// Absolute tolerance of the disagreement check, N (default 5 % of Fr).
    pub tolerance_n: f64,
    /// Periods in a row outside the band before a disagreement is declared (default 3).
    pub persist_periods: u32,
    /// How far `ACTUAL_FEED` may be from the period's path feed, mm/min: half its unit
    /// (a whole number of mm/min; default 0.5).
    pub feed_rounding_mm_min: f64,
    /// Ratios the plan's scale needs before the lead acts, − (default 3; at most
    /// [`super::scale::SCALE_SAMPLES`]).
    pub scale_min_samples: usize,
    /// A period samples the scale when the plan's band lies within ± this share of its
    /// middle, − (default [`Self::DEFAULT_SCALE_BAND_HALF_WIDTH`], 0.1).
    pub scale_band_half_width: f64,
    /// The tool cuts: the plan's force and the measured force above this share of Fr, −
    /// (default 0.2).
    pub cutting_share_of_fr: f64,
    /// No lead while the measured force is above this share of Fr, − (default 1.1).
    pub lead_max_force_share_of_fr: f64,
    /// The lead needs a period judged and agreeing within this many periods (default 5: a
    /// corner's wide band and the slow periods of its exit are not judged, four on the
    /// pocket's).
    pub scale_confirm_periods: u32,
    /// A period's ratio agrees with the scale within ± this share of it, − (default 0.15).
    pub scale_agreement: f64,
    /// No period the lead governs is predicted above this share of Fr, − (default
    /// [`Self::DEFAULT_LEAD_CEILING_SHARE_OF_FR`], 1.03: the peak target at entries and
    /// corners, 1.05, less a margin for the plan's error).
    pub lead_ceiling_share_of_fr: f64,
    /// The window of period starts the lead judges is sampled at this many intervals, plus
    /// every row boundary in it (default 4).
    pub window_intervals: u16,
}

impl LookAheadConfig {
    /// Default of [`Self::scale_band_half_width`], −.
    pub const DEFAULT_SCALE_BAND_HALF_WIDTH: f64 = 0.1;
    /// Default of [`Self::lead_ceiling_share_of_fr`], −.
    pub const DEFAULT_LEAD_CEILING_SHARE_OF_FR: f64 = 1.03;

    /// The defaults for control period `period_s` (s), force reference `force_ref_n` (N)
    /// and the grid's maximum override `max_pct` (%).
    pub fn new(period_s: f64, force_ref_n: f64, max_pct: u16) -> Self {
        LookAheadConfig {
            max_pct,
            force_ref_n,
            lead: false,
            horizon_s: 2.0 * period_s,
            command_delay_s: 0.3 * period_s,
            tolerance: 0.25,
            tolerance_n: 0.05 * force_ref_n,
            persist_periods: 3,
            feed_rounding_mm_min: 0.5,
            scale_min_samples: 3,
            scale_band_half_width: Self::DEFAULT_SCALE_BAND_HALF_WIDTH,
            cutting_share_of_fr: 0.2,
            lead_max_force_share_of_fr: 1.1,
            scale_confirm_periods: 5,
            scale_agreement: 0.15,
            lead_ceiling_share_of_fr: Self::DEFAULT_LEAD_CEILING_SHARE_OF_FR,
            window_intervals: 4,
        }
    }

    /// The lead's ceiling, N: [`Self::lead_ceiling_share_of_fr`] × Fr.
    pub fn lead_ceiling_n(&self) -> f64 {
        self.lead_ceiling_share_of_fr * self.force_ref_n
    }

    /// Whether a measured force `f` (N) is low enough for the lead
    /// ([`Self::lead_max_force_share_of_fr`] × Fr at most).
    pub fn lead_may_act_at(&self, f: f64) -> bool {
        f <= self.lead_max_force_share_of_fr * self.force_ref_n
    }

    /// The force above which the tool cuts, N: [`Self::cutting_share_of_fr`] × Fr.
    pub fn cutting_n(&self) -> f64 {
        self.cutting_share_of_fr * self.force_ref_n
    }
}
