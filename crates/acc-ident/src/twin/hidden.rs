//! The hidden effects of the twin's evaluation ([`Hidden`]): what the simulated machine or
//! its logger does that the nominal model does not, with the library effect (or pair) each
//! one is, its label and its `twin_one` key.

use crate::model::Channel;

/// A hidden effect of the evaluation: what the simulated machine does that the nominal
/// model (the scenario's own, [`model_for_scenario`]) does not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hidden {
    /// Nothing hidden.
    Null,
    /// In the library: tool wear, `Ks` growth per cm³.
    ToolWear(f64),
    /// In the library: extra feed-drive lag, s.
    FeedDriveLag(f64),
    /// In the library: extra override-path dead time, s.
    OverrideDeadTime(f64),
    /// In the library: copper loss ∝ torque² (`motor_efficiency`), 1/kW (power only).
    CopperLoss(f64),
    /// In the library: no-load drift ΔP, W (τ 60 s; power only).
    NoloadDrift(f64),
    /// In the library: power-sensor low-pass τ, s (power only).
    SensorLowpass(f64),
    /// In the library: runout amplitude.
    Runout(f64),
    /// In the library (`depth_exponent`, Δα = α − the model's α): depth exponent α of the
    /// force law.
    DepthExponent(f64),
    /// In the library (`ks_step`, δ = factor − 1): a `Ks` step at a material boundary
    /// (factor from mid-part).
    KsStep(f64),
    /// Out of the library: the tooth-level force model against a mean-force model.
    ToothModel,
    /// Out of the library: the workpiece's radial depths are this factor of the model's
    /// (a geometry error of the part), −.
    DepthScale(f64),
    /// Out of the library: the part sits this far further along the path than the model's
    /// workpiece (a fixture offset), mm.
    PositionOffset(f64),
    /// Out of the library: hard bands — every other 10 mm of material has `Ks` × this.
    HardBands(f64),
    /// Out of the library: each cut starts with a chamfer this long (the depth ramps from 0)
    /// where the model has a step, mm.
    EntryChamfer(f64),
    /// Out of the library: `Ks` grows with cutting time (thermal), 1/min.
    KsTimeDrift(f64),
    /// In the library (`sensor_gain_drift`), the logging path (applied to the logged
    /// measured column after the closed-loop run): a gain drift of the logged channel, 1/min.
    LogGainDrift(f64),
    /// In the library (`measurement_delay`), the logging path: the logged measured column
    /// is late by this many periods (a pure delay).
    LogDelay(usize),
    /// In the library (`second_order_drive`): a second-order feed drive (a second lag of
    /// this τ in series), s.
    SecondOrderDrive(f64),
    /// Out of the library, the logging path: spikes of ± this fraction of the channel's
    /// median on 2 % of the logged rows.
    LogSpikes(f64),
    /// Out of the library, the logging path: a zero shift of the sensor half-way through
    /// the log — from then on the logged column is offset by this fraction of the
    /// channel's median |value| (a step, where `noload_drift` is a first-order drift).
    LogZeroShift(f64),
    /// Out of the library, the logging path: a 0.3 Hz interference on the logged column,
    /// amplitude this fraction of the channel's median |value| (mains beat, a fan).
    LogInterference(f64),
    /// Out of the library, the logging path: the logged column saturates at this
    /// fraction of its largest value (an amplifier or ADC range set too low).
    LogClip(f64),
    /// Out of the library, the logging path: the logged column is quantised to steps of
    /// this fraction of the channel's median |value| (a coarse ADC or an integer register).
    LogQuantize(f64),
    /// Out of the library, the logging path: the logger repeats the previous sample on
    /// this fraction of the rows (stale samples: a bus read that missed its slot).
    LogStale(f64),
    /// Out of the library: the force rises above a radial depth of
    /// [`DEPTH_THRESHOLD_MM`] (chatter, a built-up edge): `Ks × (1 + k·(d − d₀)/d₀)` where
    /// the part's depth `d` exceeds `d₀`; `k` here, −. Set on the workpiece's `Ks` factor
    /// (a ramp in pieces of 2 mm at their middle depth).
    DepthThreshold(f64),
    /// Out of the library, the logging path: the sensor's zero drifts linearly (a
    /// transducer warming up) from 0 at the log's start to this fraction of the channel's
    /// median |value| at its end.
    LogZeroDrift(f64),
    /// Out of the library: the NC caps the override at this percent whatever the board
    /// writes (`override_path.nc_max_pct`; the log shows the board's register).
    NcOverrideCap(u16),
    /// Two in the library at once: tool wear (`Ks` growth per cm³, this value) and a
    /// no-load drift of [`PAIR_NOLOAD_DRIFT_W`] (τ 60 s). Both should be named.
    WearAndNoloadDrift(f64),
    /// Two in the library at once: tool wear (`Ks` growth per cm³, this value) and an extra
    /// feed-drive lag of [`PAIR_FEED_LAG_S`]. Both should be named.
    WearAndFeedDriveLag(f64),
}

/// The no-load drift of [`Hidden::WearAndNoloadDrift`], W.
pub const PAIR_NOLOAD_DRIFT_W: f64 = 60.0;
/// The extra feed-drive lag of [`Hidden::WearAndFeedDriveLag`], s.
pub const PAIR_FEED_LAG_S: f64 = 0.05;

/// The radial depth above which [`Hidden::DepthThreshold`] raises the force, mm.
pub const DEPTH_THRESHOLD_MM: f64 = 2.5;

impl Hidden {
    /// The library effect this hidden effect is (None: null or out of library).
    pub fn library(self) -> Option<crate::EffectKind> {
        use crate::EffectKind as K;
        Some(match self {
            Hidden::ToolWear(_) => K::ToolWear,
            Hidden::FeedDriveLag(_) => K::FeedDriveLag,
            Hidden::OverrideDeadTime(_) => K::OverrideDeadTime,
            Hidden::CopperLoss(_) => K::MotorEfficiency,
            Hidden::NoloadDrift(_) => K::NoloadDrift,
            Hidden::SensorLowpass(_) => K::SensorLowpass,
            Hidden::Runout(_) => K::Runout,
            Hidden::LogGainDrift(_) => K::SensorGainDrift,
            Hidden::LogDelay(_) => K::MeasurementDelay,
            Hidden::DepthExponent(_) => K::DepthExponent,
            Hidden::KsStep(_) => K::KsStep,
            Hidden::SecondOrderDrive(_) => K::SecondOrderDrive,
            _ => return None,
        })
    }

    /// The two library effects of a hidden pair (None: not a pair).
    pub fn library_pair(self) -> Option<[crate::EffectKind; 2]> {
        use crate::EffectKind as K;
        match self {
            Hidden::WearAndNoloadDrift(_) => Some([K::ToolWear, K::NoloadDrift]),
            Hidden::WearAndFeedDriveLag(_) => Some([K::ToolWear, K::FeedDriveLag]),
            _ => None,
        }
    }

    /// Short label with the amplitude.
    pub fn label(self) -> String {
        match self {
            Hidden::Null => "null".into(),
            Hidden::ToolWear(v) => format!("tool_wear {v}/cm³"),
            Hidden::FeedDriveLag(v) => format!("feed_drive_lag +{v} s"),
            Hidden::OverrideDeadTime(v) => format!("override_dead_time +{v} s"),
            Hidden::CopperLoss(v) => format!("copper loss {v}/kW"),
            Hidden::NoloadDrift(v) => format!("noload_drift {v} W"),
            Hidden::SensorLowpass(v) => format!("sensor_lowpass {v} s"),
            Hidden::Runout(v) => format!("runout A={v}"),
            Hidden::DepthExponent(v) => format!("depth exponent α={v}"),
            Hidden::KsStep(v) => format!("Ks step ×{v}"),
            Hidden::ToothModel => "tooth-level force".into(),
            Hidden::DepthScale(v) => format!("depth scale ×{v}"),
            Hidden::PositionOffset(v) => format!("part offset +{v} mm"),
            Hidden::HardBands(v) => format!("hard bands ×{v}"),
            Hidden::EntryChamfer(v) => format!("entry chamfer {v} mm"),
            Hidden::KsTimeDrift(v) => format!("Ks time drift {v}/min"),
            Hidden::LogGainDrift(v) => format!("log gain drift {v}/min"),
            Hidden::LogDelay(k) => format!("log delay {k} periods"),
            Hidden::SecondOrderDrive(v) => format!("second-order drive τ₂={v} s"),
            Hidden::LogSpikes(v) => format!("log spikes ±{v}"),
            Hidden::LogZeroShift(v) => format!("log zero shift {v}"),
            Hidden::LogInterference(v) => format!("log 0.3 Hz interference {v}"),
            Hidden::LogClip(v) => format!("log clipped at {v}·max"),
            Hidden::LogQuantize(v) => format!("log quantised {v}"),
            Hidden::LogStale(v) => format!("log stale samples {v}"),
            Hidden::DepthThreshold(v) => format!("force rise above {DEPTH_THRESHOLD_MM} mm ×{v}"),
            Hidden::LogZeroDrift(v) => format!("log zero drift {v}"),
            Hidden::NcOverrideCap(p) => format!("NC override cap {p} %"),
            Hidden::WearAndNoloadDrift(v) => {
                format!("tool_wear {v}/cm³ + noload_drift {PAIR_NOLOAD_DRIFT_W} W")
            }
            Hidden::WearAndFeedDriveLag(v) => {
                format!("tool_wear {v}/cm³ + feed_drive_lag +{PAIR_FEED_LAG_S} s")
            }
        }
    }

    /// Parse `name` or `name=value` (`null`, `tool_wear=0.08`, `feed_drive_lag=0.08`,
    /// `override_dead_time=0.12`, `copper_loss=0.3`, `noload_drift=120`,
    /// `sensor_lowpass=0.3`, `runout=0.15`, `depth_exponent=1.15`, `ks_step=1.3`, `tooth`,
    /// `log_zero_shift=0.05`, `log_interference=0.03`, `log_clip=0.75`,
    /// `log_quantize=0.05`, `log_stale=0.2`, …: the keys below).
    pub fn parse(s: &str) -> Option<Hidden> {
        let (k, v) = match s.split_once('=') {
            Some((k, v)) => (k, v.parse::<f64>().ok()?),
            None => (s, f64::NAN),
        };
        Some(match k {
            "null" => Hidden::Null,
            "tooth" => Hidden::ToothModel,
            "tool_wear" => Hidden::ToolWear(v),
            "feed_drive_lag" => Hidden::FeedDriveLag(v),
            "override_dead_time" => Hidden::OverrideDeadTime(v),
            "copper_loss" => Hidden::CopperLoss(v),
            "noload_drift" => Hidden::NoloadDrift(v),
            "sensor_lowpass" => Hidden::SensorLowpass(v),
            "runout" => Hidden::Runout(v),
            "depth_exponent" => Hidden::DepthExponent(v),
            "ks_step" => Hidden::KsStep(v),
            "depth_scale" => Hidden::DepthScale(v),
            "part_offset" => Hidden::PositionOffset(v),
            "hard_bands" => Hidden::HardBands(v),
            "entry_chamfer" => Hidden::EntryChamfer(v),
            "ks_time_drift" => Hidden::KsTimeDrift(v),
            "log_gain_drift" => Hidden::LogGainDrift(v),
            "log_delay" => Hidden::LogDelay(v as usize),
            "second_order_drive" => Hidden::SecondOrderDrive(v),
            "log_spikes" => Hidden::LogSpikes(v),
            "log_zero_shift" => Hidden::LogZeroShift(v),
            "log_interference" => Hidden::LogInterference(v),
            "log_clip" => Hidden::LogClip(v),
            "log_quantize" => Hidden::LogQuantize(v),
            "log_stale" => Hidden::LogStale(v),
            "depth_threshold" => Hidden::DepthThreshold(v),
            "log_zero_drift" => Hidden::LogZeroDrift(v),
            "nc_override_cap" if v.is_finite() && (10.0..=250.0).contains(&v) => {
                Hidden::NcOverrideCap(v as u16)
            }
            "wear_and_noload_drift" => Hidden::WearAndNoloadDrift(v),
            "wear_and_feed_drive_lag" => Hidden::WearAndFeedDriveLag(v),
            _ => return None,
        })
    }

    /// Whether the effect is applied to a logged column after the run
    /// ([`super::apply_logging_path`]) rather than set in the simulated machine.
    pub fn on_logging_path(self) -> bool {
        matches!(
            self,
            Hidden::LogGainDrift(_)
                | Hidden::LogDelay(_)
                | Hidden::LogSpikes(_)
                | Hidden::LogZeroShift(_)
                | Hidden::LogInterference(_)
                | Hidden::LogClip(_)
                | Hidden::LogQuantize(_)
                | Hidden::LogStale(_)
                | Hidden::LogZeroDrift(_)
        )
    }

    /// Whether the effect acts on `channel` at all; `estimated_force`: the force channel is
    /// a spindle-power estimate (it then sees every power effect).
    pub fn acts_on(self, channel: Channel, estimated_force: bool) -> bool {
        estimated_force
            || !matches!(
                (self, channel),
                (
                    Hidden::CopperLoss(_)
                        | Hidden::NoloadDrift(_)
                        | Hidden::SensorLowpass(_)
                        | Hidden::WearAndNoloadDrift(_),
                    Channel::Force
                )
            )
    }
}
