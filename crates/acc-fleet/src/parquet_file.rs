//! One table partition's rows written as a Parquet file (Snappy, the schema version and the
//! table name in its key-value metadata), through a hidden temporary file and a rename so
//! that a reader never sees half a file.

use std::fs::File;
use std::path::Path;

use arrow::array::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

use crate::columns::{cut_batch, period_batch};
use crate::schema::{CutRow, PeriodRow, SCHEMA_VERSION, TABLE_KEY, VERSION_KEY};
use crate::FleetError;

/// Write `rows` of the `period` table to `path`.
pub fn write_periods(path: &Path, rows: &[PeriodRow]) -> Result<(), FleetError> {
    let batch = period_batch(rows).map_err(|e| FleetError::write(path, e))?;
    write_file(path, "period", &batch)
}

/// Write `rows` of the `cut` table to `path`.
pub fn write_cuts(path: &Path, rows: &[CutRow]) -> Result<(), FleetError> {
    let batch = cut_batch(rows).map_err(|e| FleetError::write(path, e))?;
    write_file(path, "cut", &batch)
}

/// Write `batch` to `path` through a hidden temporary file and a rename.
fn write_file(path: &Path, table: &str, batch: &RecordBatch) -> Result<(), FleetError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| FleetError::io(dir, e))?;
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.tmp"));
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(Some(vec![
            KeyValue::new(VERSION_KEY.to_string(), SCHEMA_VERSION.to_string()),
            KeyValue::new(TABLE_KEY.to_string(), table.to_string()),
        ]))
        .build();
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| FleetError::io(&tmp, e))?;
        let mut w = ArrowWriter::try_new(file, batch.schema(), Some(props))
            .map_err(|e| FleetError::write(&tmp, e))?;
        w.write(batch).map_err(|e| FleetError::write(&tmp, e))?;
        let file = w.into_inner().map_err(|e| FleetError::write(&tmp, e))?;
        file.sync_all().map_err(|e| FleetError::io(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| FleetError::io(path, e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
