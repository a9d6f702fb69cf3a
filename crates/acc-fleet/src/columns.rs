//! The Arrow columns of the two tables (the schema of their Parquet files) and the rows of
//! [`crate::schema`] as record batches.

use std::sync::Arc;

use arrow::array::{
    ArrayRef, BooleanArray, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
    TimestampMicrosecondArray,
};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef, TimeUnit};
use arrow::error::ArrowError;

use crate::schema::{CutRow, PeriodRow};

fn ts_type() -> DataType {
    DataType::Timestamp(TimeUnit::Microsecond, Some("UTC".into()))
}

fn f(name: &str, t: DataType, nullable: bool) -> Field {
    Field::new(name, t, nullable)
}

/// Arrow schema of the `period` files (partition columns excluded).
pub fn period_schema() -> SchemaRef {
    use DataType::{Boolean, Float64, Int32, Int64, Utf8};
    Arc::new(Schema::new(vec![
        f("run_start", ts_type(), false),
        f("ts", ts_type(), false),
        f("period", Int64, false),
        f("t_s", Float64, false),
        f("flags", Utf8, false),
        f("state", Utf8, false),
        f("tool", Int32, true),
        f("program", Int32, true),
        f("block", Int32, true),
        f("spindle_rpm", Float64, true),
        f("programmed_feed_mm_min", Float64, true),
        f("feed_mm_min", Float64, true),
        f("power_w", Float64, true),
        f("force_n", Float64, true),
        f("force_valid", Boolean, false),
        f("force_ref_n", Float64, true),
        f("kc_hat", Float64, true),
        f("override_cmd_pct", Int32, true),
        f("override_applied_pct", Int32, true),
        f("override_operator_pct", Int32, true),
        f("feed_hold", Boolean, false),
        f("alarms", Int32, false),
    ]))
}

/// Arrow schema of the `cut` files (partition columns excluded).
pub fn cut_schema() -> SchemaRef {
    use DataType::{Float64, Int32, Utf8};
    Arc::new(Schema::new(vec![
        f("run_start", ts_type(), false),
        f("ts", ts_type(), false),
        f("tool", Int32, true),
        f("program", Int32, true),
        f("block_first", Int32, true),
        f("block_last", Int32, true),
        f("t_start_s", Float64, false),
        f("time_in_cut_s", Float64, false),
        f("force_mean_n", Float64, false),
        f("force_max_n", Float64, false),
        f("time_saved_s", Float64, false),
        f("alarms", Utf8, false),
    ]))
}

/// The schema of `table` (`period` or `cut`).
pub fn schema_of(table: &str) -> Option<SchemaRef> {
    match table {
        "period" => Some(period_schema()),
        "cut" => Some(cut_schema()),
        _ => None,
    }
}

fn ts_col(v: impl Iterator<Item = i64>) -> ArrayRef {
    Arc::new(TimestampMicrosecondArray::from_iter_values(v).with_timezone("UTC"))
}

/// The rows as one record batch of [`period_schema`].
pub fn period_batch(rows: &[PeriodRow]) -> Result<RecordBatch, ArrowError> {
    let f64s = |g: fn(&PeriodRow) -> Option<f64>| -> ArrayRef {
        Arc::new(rows.iter().map(g).collect::<Float64Array>())
    };
    let i32s = |g: fn(&PeriodRow) -> Option<i32>| -> ArrayRef {
        Arc::new(rows.iter().map(g).collect::<Int32Array>())
    };
    let cols: Vec<ArrayRef> = vec![
        ts_col(rows.iter().map(|r| r.run_start_us)),
        ts_col(rows.iter().map(PeriodRow::ts_us)),
        Arc::new(Int64Array::from_iter_values(rows.iter().map(|r| r.period))),
        Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.t_s))),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.flags.as_str()),
        )),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.state.as_str()),
        )),
        i32s(|r| r.tool),
        i32s(|r| r.program),
        i32s(|r| r.block),
        f64s(|r| r.spindle_rpm),
        f64s(|r| r.programmed_feed_mm_min),
        f64s(|r| r.feed_mm_min),
        f64s(|r| r.power_w),
        f64s(|r| r.force_n),
        Arc::new(BooleanArray::from(
            rows.iter().map(|r| r.force_valid).collect::<Vec<_>>(),
        )),
        f64s(|r| r.force_ref_n),
        f64s(|r| r.kc_hat),
        i32s(|r| r.override_cmd_pct),
        i32s(|r| r.override_applied_pct),
        i32s(|r| r.override_operator_pct),
        Arc::new(BooleanArray::from(
            rows.iter().map(|r| r.feed_hold).collect::<Vec<_>>(),
        )),
        Arc::new(Int32Array::from_iter_values(rows.iter().map(|r| r.alarms))),
    ];
    RecordBatch::try_new(period_schema(), cols)
}

/// The rows as one record batch of [`cut_schema`].
pub fn cut_batch(rows: &[CutRow]) -> Result<RecordBatch, ArrowError> {
    let f64s = |g: fn(&CutRow) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from_iter_values(rows.iter().map(g)))
    };
    let i32s = |g: fn(&CutRow) -> Option<i32>| -> ArrayRef {
        Arc::new(rows.iter().map(g).collect::<Int32Array>())
    };
    let cols: Vec<ArrayRef> = vec![
        ts_col(rows.iter().map(|r| r.run_start_us)),
        ts_col(rows.iter().map(CutRow::ts_us)),
        i32s(|r| r.tool),
        i32s(|r| r.program),
        i32s(|r| r.block_first),
        i32s(|r| r.block_last),
        f64s(|r| r.t_start_s),
        f64s(|r| r.time_in_cut_s),
        f64s(|r| r.force_mean_n),
        f64s(|r| r.force_max_n),
        f64s(|r| r.time_saved_s),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.alarms.as_str()),
        )),
    ];
    RecordBatch::try_new(cut_schema(), cols)
}

#[cfg(test)]
mod tests {
    use super::*;
    use acc_runtime::RunRecord;
    use arrow::array::Array;

    #[test]
    fn unknown_values_are_nulls_and_ts_is_run_start_plus_machine_time() {
        let r = RunRecord {
            period: 7,
            t_s: 0.7,
            tool: Some(12),
            kc_hat: Some(f64::NAN),
            force_n: Some(812.5),
            ..RunRecord::default()
        };
        let row = PeriodRow::of(&r, 1_000_000);
        assert_eq!(row.ts_us(), 1_700_000);
        let b = period_batch(&[row]).expect("batch");
        assert_eq!(b.num_rows(), 1);
        let kc = b
            .column_by_name("kc_hat")
            .expect("kc_hat")
            .as_any()
            .downcast_ref::<Float64Array>()
            .expect("f64");
        assert!(kc.is_null(0), "NaN is unknown, stored as null");
        let tool = b.column_by_name("tool").expect("tool");
        let tool = tool.as_any().downcast_ref::<Int32Array>().expect("i32");
        assert_eq!(tool.value(0), 12);
        assert!(b.column_by_name("program").expect("program").is_null(0));
    }
}
