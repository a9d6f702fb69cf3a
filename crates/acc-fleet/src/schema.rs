//! The two tables of the fleet store, their rows and their schema version (the Arrow
//! columns of the files: [`crate::columns`], in the build with the `store` feature).
//!
//! - `period`: one row per control period ([`PeriodRow`], from a [`RunRecord`] or an MQTT
//!   `<prefix>/period` message).
//! - `cut`: one row per cut ([`CutRow`], from a [`CutRecord`] or an MQTT `<prefix>/cut`
//!   message).
//!
//! The columns are those an MQTT message carries, so a store written beside the run
//! (`--fleet`) and one written by `acc collect` hold the same columns. The machine id and
//! the UTC date are not columns of the files: they are the Hive partitions
//! `machine=<id>/date=<YYYY-MM-DD>/` that every engine reads back as columns.
//!
//! Every file carries the key-value metadata [`VERSION_KEY`] = [`SCHEMA_VERSION`]; a file of
//! a newer version is refused ([`crate::check`]).

use acc_runtime::cuts::CutRecord;
use acc_runtime::RunRecord;

/// Version of the store's schema written by this build.
pub const SCHEMA_VERSION: u32 = 1;

/// Parquet key-value metadata entry holding the schema version.
pub const VERSION_KEY: &str = "acc.schema_version";

/// Parquet key-value metadata entry naming the table (`period` or `cut`).
pub const TABLE_KEY: &str = "acc.table";

/// The tables of the store (the top-level folders).
pub const TABLES: [&str; 2] = ["period", "cut"];

/// The partition columns, in folder order (`machine=<id>/date=<YYYY-MM-DD>/`).
pub const PARTITIONS: [&str; 2] = ["machine", "date"];

/// One control period as stored (units in the names; `None` is unknown, a Parquet null).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PeriodRow {
    /// Wall-clock start of the run, µs since the Unix epoch (UTC).
    pub run_start_us: i64,
    /// Period index in the run, 0-based.
    pub period: i64,
    /// Machine time of the period since the run began, s.
    pub t_s: f64,
    /// `;`-separated flags of the run log (`skipped`, `late`, `link:…`, …).
    pub flags: String,
    /// Policy state after the period (`active`, `idle`, latched reason).
    pub state: String,
    /// Active tool number.
    pub tool: Option<i32>,
    /// Program number.
    pub program: Option<i32>,
    /// Block number.
    pub block: Option<i32>,
    /// Spindle speed, rpm.
    pub spindle_rpm: Option<f64>,
    /// Programmed feed of the active block, mm/min.
    pub programmed_feed_mm_min: Option<f64>,
    /// Actual path feed, mm/min.
    pub feed_mm_min: Option<f64>,
    /// Spindle input power, W.
    pub power_w: Option<f64>,
    /// Estimated mean cutting force, N.
    pub force_n: Option<f64>,
    /// The force sample was used as valid.
    pub force_valid: bool,
    /// Force reference Fr, N.
    pub force_ref_n: Option<f64>,
    /// Estimated process gain Kc_hat, N/(mm/min).
    pub kc_hat: Option<f64>,
    /// Override ACC commanded, %.
    pub override_cmd_pct: Option<i32>,
    /// Override in force on the PMC, %.
    pub override_applied_pct: Option<i32>,
    /// Operator's override knob, %.
    pub override_operator_pct: Option<i32>,
    /// Feed hold requested by ACC.
    pub feed_hold: bool,
    /// Alarm bits (as the run log's `alarms`).
    pub alarms: i32,
}

impl PeriodRow {
    /// The row of run-log record `r` of the run that started at `run_start_us`.
    pub fn of(r: &RunRecord, run_start_us: i64) -> Self {
        let fin = |v: Option<f64>| v.filter(|x| x.is_finite());
        let int = |v: Option<u16>| v.map(i32::from);
        Self {
            run_start_us,
            period: i64::try_from(r.period).unwrap_or(i64::MAX),
            t_s: r.t_s,
            flags: r.flags.clone(),
            state: r.state.clone(),
            tool: int(r.tool),
            program: int(r.program),
            block: int(r.block),
            spindle_rpm: fin(r.spindle_rpm),
            programmed_feed_mm_min: fin(r.programmed_feed_mm_min),
            feed_mm_min: fin(r.feed_mm_min),
            power_w: fin(r.power_w),
            force_n: fin(r.force_n),
            force_valid: r.force_valid,
            force_ref_n: fin(r.force_ref_n),
            kc_hat: fin(r.kc_hat),
            override_cmd_pct: int(r.override_cmd_pct),
            override_applied_pct: int(r.override_applied_pct),
            override_operator_pct: int(r.override_operator_pct),
            feed_hold: r.feed_hold,
            alarms: i32::from(r.alarms),
        }
    }

    /// Wall-clock time of the period, µs since the Unix epoch: run start + machine time.
    pub fn ts_us(&self) -> i64 {
        self.run_start_us + secs_to_us(self.t_s)
    }
}

/// One cut as stored.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CutRow {
    /// Wall-clock start of the run, µs since the Unix epoch (UTC).
    pub run_start_us: i64,
    /// Tool number.
    pub tool: Option<i32>,
    /// Program number.
    pub program: Option<i32>,
    /// First block of the cut.
    pub block_first: Option<i32>,
    /// Last block of the cut.
    pub block_last: Option<i32>,
    /// Machine time of the first cutting period since the run began, s.
    pub t_start_s: f64,
    /// Time in cut, s.
    pub time_in_cut_s: f64,
    /// Mean force over the cutting periods, N.
    pub force_mean_n: f64,
    /// Peak force, N.
    pub force_max_n: f64,
    /// Time at 100 % override for the same path minus the actual time, s.
    pub time_saved_s: f64,
    /// Alarms raised in the cut, `;`-separated names.
    pub alarms: String,
}

impl CutRow {
    /// The row of cut `c` of the run that started at `run_start_us` (0 = unknown becomes
    /// null; the alarm names as published on MQTT).
    pub fn of(c: &CutRecord, run_start_us: i64) -> Self {
        let known = |v: u16| (v != 0).then_some(i32::from(v));
        Self {
            run_start_us,
            tool: known(c.tool),
            program: known(c.program),
            block_first: known(c.block_first),
            block_last: known(c.block_last),
            t_start_s: c.t_start_s,
            time_in_cut_s: c.time_in_cut_s,
            force_mean_n: c.force_mean_n,
            force_max_n: c.force_max_n,
            time_saved_s: c.time_saved_s,
            alarms: c.alarms().join(";"),
        }
    }

    /// Wall-clock time of the cut's start, µs since the Unix epoch.
    pub fn ts_us(&self) -> i64 {
        self.run_start_us + secs_to_us(self.t_start_s)
    }
}

/// Now, µs since the Unix epoch (the run start of a writer).
pub fn now_us() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(i64::MAX))
}

/// Seconds to whole microseconds (rounded; a non-finite value is 0).
pub fn secs_to_us(s: f64) -> i64 {
    if s.is_finite() {
        (s * 1e6).round() as i64
    } else {
        0
    }
}
