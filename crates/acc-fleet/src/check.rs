//! Reading a store's files before a query: every `*.parquet` file under `DIR/period` and
//! `DIR/cut` must open as Parquet and carry a schema version this build reads
//! (≤ [`SCHEMA_VERSION`]); a corrupt file, a file without the version, or a newer one is
//! refused with one line naming the file.

use std::fs::File;
use std::path::{Path, PathBuf};

use parquet::file::reader::{FileReader, SerializedFileReader};

use crate::schema::{SCHEMA_VERSION, TABLES, VERSION_KEY};
use crate::FleetError;

/// What the check found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct StoreInfo {
    /// Files per table, in [`TABLES`] order.
    pub files: [u64; 2],
    /// Rows per table (from the footers), in [`TABLES`] order.
    pub rows: [u64; 2],
}

/// Check one file; returns its row count.
pub fn check_file(path: &Path) -> Result<u64, FleetError> {
    let file = File::open(path).map_err(|e| FleetError::io(path, e))?;
    let reader = SerializedFileReader::new(file).map_err(|e| FleetError::Corrupt {
        file: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let meta = reader.metadata().file_metadata();
    let version = meta
        .key_value_metadata()
        .and_then(|kv| kv.iter().find(|k| k.key == VERSION_KEY))
        .and_then(|k| k.value.clone());
    let Some(text) = version else {
        return Err(FleetError::NoVersion(path.to_path_buf()));
    };
    let found: u32 = text.trim().parse().map_err(|_| FleetError::Corrupt {
        file: path.to_path_buf(),
        message: format!("{VERSION_KEY} = `{text}` is not a whole number"),
    })?;
    if found > SCHEMA_VERSION {
        return Err(FleetError::NewerVersion {
            file: path.to_path_buf(),
            found,
            supported: SCHEMA_VERSION,
        });
    }
    Ok(u64::try_from(meta.num_rows()).unwrap_or(0))
}

/// Every `*.parquet` file under `dir`, sorted (hidden entries skipped, as engines do).
pub fn parquet_files(dir: &Path) -> Result<Vec<PathBuf>, FleetError> {
    let mut out = Vec::new();
    if !dir.exists() {
        return Ok(out);
    }
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).map_err(|e| FleetError::io(&d, e))? {
            let p = entry.map_err(|e| FleetError::io(&d, e))?.path();
            let hidden = p
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if hidden {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "parquet") {
                out.push(p);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Check every file of store `root`. A folder without `period/` or `cut/` is not a store.
pub fn check_store(root: &Path) -> Result<StoreInfo, FleetError> {
    if !TABLES.iter().any(|t| root.join(t).is_dir()) {
        return Err(FleetError::NoStore(root.to_path_buf()));
    }
    let mut info = StoreInfo::default();
    for (i, t) in TABLES.iter().enumerate() {
        for f in parquet_files(&root.join(t))? {
            info.rows[i] += check_file(&f)?;
            info.files[i] += 1;
        }
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::columns::period_batch;
    use crate::schema::{PeriodRow, TABLE_KEY};
    use parquet::arrow::ArrowWriter;
    use parquet::file::metadata::KeyValue;
    use parquet::file::properties::WriterProperties;

    fn write_with_version(path: &Path, version: &str) {
        std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
        let batch = period_batch(&[PeriodRow::default()]).expect("batch");
        let props = WriterProperties::builder()
            .set_key_value_metadata(Some(vec![
                KeyValue::new(VERSION_KEY.to_string(), version.to_string()),
                KeyValue::new(TABLE_KEY.to_string(), "period".to_string()),
            ]))
            .build();
        let mut w = ArrowWriter::try_new(
            File::create(path).expect("create"),
            batch.schema(),
            Some(props),
        )
        .expect("writer");
        w.write(&batch).expect("write");
        w.close().expect("close");
    }

    #[test]
    fn a_newer_version_is_refused_naming_the_file_and_both_versions() {
        let dir = tempfile::tempdir().expect("tempdir");
        let ok = dir
            .path()
            .join("period/machine=m/date=2026-01-01/a.parquet");
        write_with_version(&ok, "1");
        assert_eq!(check_store(dir.path()).expect("store").rows, [1, 0]);
        let newer = dir
            .path()
            .join("period/machine=m/date=2026-01-01/b.parquet");
        write_with_version(&newer, "2");
        let e = check_store(dir.path()).expect_err("newer").to_string();
        assert!(e.contains("b.parquet"), "{e}");
        assert!(e.contains("version 2") && e.contains("version 1"), "{e}");
    }

    #[test]
    fn corrupt_files_and_missing_stores_get_one_clear_line() {
        let dir = tempfile::tempdir().expect("tempdir");
        let e = check_store(dir.path()).expect_err("no store").to_string();
        assert!(e.contains("no period/ or cut/"), "{e}");
        let bad = dir.path().join("cut/machine=m/date=2026-01-01/x.parquet");
        std::fs::create_dir_all(bad.parent().expect("parent")).expect("mkdir");
        std::fs::write(&bad, b"PAR1 this is not parquet").expect("write");
        let e = check_store(dir.path()).expect_err("corrupt").to_string();
        assert!(
            e.contains("x.parquet") && e.contains("not a readable Parquet file"),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
