//! SQL over the store with embedded DataFusion: the tables `period` and `cut` are listing
//! tables over `DIR/period` and `DIR/cut`, with the partitions `machine` and `date` (text,
//! `YYYY-MM-DD`) as columns after the file columns.

use std::path::Path;

use arrow::array::RecordBatch;
use arrow::datatypes::DataType;
use arrow::util::display::{ArrayFormatter, FormatOptions};
use datafusion::prelude::{ParquetReadOptions, SessionContext};

use crate::check::check_store;
use crate::columns::schema_of;
use crate::schema::{PARTITIONS, TABLES};
use crate::FleetError;

/// `acc history query`: run `sql` over store `root` and format the result as an aligned
/// table ([`format_table`]) or, with `csv`, as CSV ([`format_csv`]).
pub fn query_text(root: &Path, sql: &str, csv: bool) -> Result<String, FleetError> {
    let batches = query(root, sql)?;
    if csv {
        format_csv(&batches)
    } else {
        format_table(&batches)
    }
}

/// Run `sql` over store `root` (every file checked first: [`check_store`]).
pub fn query(root: &Path, sql: &str) -> Result<Vec<RecordBatch>, FleetError> {
    check_store(root)?;
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .map_err(|e| FleetError::io(root, e))?;
    rt.block_on(run(root, sql))
}

async fn run(root: &Path, sql: &str) -> Result<Vec<RecordBatch>, FleetError> {
    let ctx = SessionContext::new();
    let parts: Vec<(String, DataType)> = PARTITIONS
        .iter()
        .map(|p| ((*p).to_string(), DataType::Utf8))
        .collect();
    for t in TABLES {
        let dir = root.join(t);
        std::fs::create_dir_all(&dir).map_err(|e| FleetError::io(&dir, e))?;
        let schema = schema_of(t)
            .ok_or_else(|| FleetError::io(&dir, std::io::ErrorKind::NotFound.into()))?;
        let url = format!(
            "{}/",
            dir.canonicalize()
                .map_err(|e| FleetError::io(&dir, e))?
                .display()
        );
        let opts = ParquetReadOptions::default()
            .table_partition_cols(parts.clone())
            .schema(&schema);
        ctx.register_parquet(t, &url, opts)
            .await
            .map_err(|e| FleetError::Query(format!("table `{t}` ({url}): {e}")))?;
    }
    let df = ctx
        .sql(sql)
        .await
        .map_err(|e| FleetError::Sql(first_line(&e.to_string())))?;
    df.collect()
        .await
        .map_err(|e| FleetError::Query(first_line(&e.to_string())))
}

fn first_line(s: &str) -> String {
    s.lines().next().unwrap_or_default().to_string()
}

/// Cells of the result as text (nulls empty), with the column names.
fn cells(batches: &[RecordBatch]) -> Result<(Vec<String>, Vec<Vec<String>>), FleetError> {
    let names: Vec<String> = batches.first().map_or_else(Vec::new, |b| {
        b.schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect()
    });
    let opts = FormatOptions::default().with_null("");
    let mut rows = Vec::new();
    for b in batches {
        let fmts = b
            .columns()
            .iter()
            .map(|c| ArrayFormatter::try_new(c.as_ref(), &opts))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| FleetError::Query(e.to_string()))?;
        for i in 0..b.num_rows() {
            rows.push(fmts.iter().map(|f| f.value(i).to_string()).collect());
        }
    }
    Ok((names, rows))
}

/// The result as an aligned text table: a header, a rule, one line per row; numbers are
/// right-aligned.
pub fn format_table(batches: &[RecordBatch]) -> Result<String, FleetError> {
    let (names, rows) = cells(batches)?;
    let numeric: Vec<bool> = batches.first().map_or_else(Vec::new, |b| {
        b.schema()
            .fields()
            .iter()
            .map(|f| f.data_type().is_numeric())
            .collect()
    });
    let widths: Vec<usize> = names
        .iter()
        .enumerate()
        .map(|(j, n)| {
            rows.iter()
                .map(|r| r[j].chars().count())
                .chain([n.chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: &[String]| {
        let v: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(j, c)| {
                if numeric.get(j).copied().unwrap_or(false) {
                    format!("{c:>w$}", w = widths[j])
                } else {
                    format!("{c:<w$}", w = widths[j])
                }
            })
            .collect();
        v.join("  ").trim_end().to_string()
    };
    let mut out = line(&names);
    out.push('\n');
    let rule: Vec<String> = widths.iter().map(|w| "-".repeat(*w)).collect();
    out.push_str(&rule.join("  "));
    out.push('\n');
    for r in &rows {
        out.push_str(&line(r));
        out.push('\n');
    }
    out.push_str(&format!("({} rows)\n", rows.len()));
    Ok(out)
}

/// The result as CSV with a header line (nulls empty).
pub fn format_csv(batches: &[RecordBatch]) -> Result<String, FleetError> {
    let (names, rows) = cells(batches)?;
    let mut w = csv::Writer::from_writer(Vec::new());
    let err = |e: csv::Error| FleetError::Query(e.to_string());
    w.write_record(&names).map_err(err)?;
    for r in &rows {
        w.write_record(r).map_err(err)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| FleetError::Query(e.to_string()))?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}
