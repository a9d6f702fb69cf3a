//! Readers of the two public data sets in `../shared/data/` (see their README files):
//!
//! * `vicomtech-turning/tool_wear_tools_3-10.csv`: 1 s segments of turning with dynamometer
//!   force and spindle power (Vicomtech / Mondragon Unibertsitatea, CC BY-SA 4.0;
//!   Ferrando Chacón et al., Int. J. Adv. Manuf. Technol. 125:4027–4045, 2023);
//! * `umich-cnc-mill/experiment_NN.csv`: 100 ms drive logs of wax milling (University of
//!   Michigan SMART lab, CC0).
//!
//! Every CSV file with a header line that `acc` reads as input goes through one reader,
//! [`CsvFile`]: columns are found by name, fields are trimmed, numbers must be finite, and
//! errors ([`DatasetError`]) name the file, the line and the column. `acc-ident` imports
//! the same data sets through [`read_turning`] and [`read_mill`].

use std::fs::File;
use std::path::{Path, PathBuf};

/// A CSV input file could not be read; every variant names the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DatasetError {
    /// The file could not be opened.
    #[error("{}: cannot open: {reason}", .file.display())]
    Open {
        /// File path.
        file: PathBuf,
        /// OS error text.
        reason: String,
    },
    /// A column the reader needs is not in the header line.
    #[error("{}: line 1: missing column `{column}`", .file.display())]
    MissingColumn {
        /// File path.
        file: PathBuf,
        /// The missing column.
        column: String,
    },
    /// A field is not a finite number, or not one of the allowed values.
    #[error("{}: line {line}, column {col} (`{column}`): {message}", .file.display())]
    BadValue {
        /// File path.
        file: PathBuf,
        /// 1-based line (the header is line 1).
        line: u64,
        /// 1-based column number.
        col: usize,
        /// Column name.
        column: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Malformed CSV (bad quoting, wrong field count, not UTF-8).
    #[error("{}: line {line}: malformed CSV: {message}", .file.display())]
    Csv {
        /// File path.
        file: PathBuf,
        /// 1-based line (0 if the parser does not know it).
        line: u64,
        /// Parser message.
        message: String,
    },
}

impl DatasetError {
    /// The file the error is about.
    pub fn file(&self) -> &Path {
        match self {
            Self::Open { file, .. }
            | Self::MissingColumn { file, .. }
            | Self::BadValue { file, .. }
            | Self::Csv { file, .. } => file,
        }
    }
}

/// A CSV file with a header line, read row by row (see the module docs). `R` is the byte
/// source: a file ([`CsvFile::open`]) or any reader ([`CsvFile::from_reader`], e.g. text
/// already in memory); `file` names it in errors.
#[derive(Debug)]
pub struct CsvFile<R: std::io::Read = File> {
    file: PathBuf,
    header: csv::StringRecord,
    reader: csv::Reader<R>,
}

impl CsvFile<File> {
    /// Open `path` and read its header line; fields are trimmed.
    pub fn open(path: &Path) -> Result<Self, DatasetError> {
        let f = File::open(path).map_err(|e| DatasetError::Open {
            file: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        Self::from_reader(f, path)
    }
}

impl<R: std::io::Read> CsvFile<R> {
    /// Read the header line of `reader`; fields are trimmed; `path` names it in errors.
    pub fn from_reader(reader: R, path: &Path) -> Result<Self, DatasetError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(reader);
        let header = reader.headers().map_err(|e| csv_error(path, e))?.clone();
        Ok(Self {
            file: path.to_path_buf(),
            header,
            reader,
        })
    }

    /// The 0-based index of the column called `name`, if the header has it.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// The 0-based index of the column called `name`.
    pub fn column(&self, name: &str) -> Result<usize, DatasetError> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| DatasetError::MissingColumn {
                file: self.file.clone(),
                column: name.into(),
            })
    }

    /// The indices of the columns called `names`, in order.
    pub fn columns<const K: usize>(&self, names: [&str; K]) -> Result<[usize; K], DatasetError> {
        let mut idx = [0usize; K];
        for (i, n) in idx.iter_mut().zip(names) {
            *i = self.column(n)?;
        }
        Ok(idx)
    }

    /// The data rows, in file order.
    pub fn rows(&mut self) -> impl Iterator<Item = Result<CsvRow<'_>, DatasetError>> + '_ {
        let Self {
            file,
            header,
            reader,
        } = self;
        let (file, header) = (&*file, &*header);
        reader.records().map(move |rec| {
            let record = rec.map_err(|e| csv_error(file, e))?;
            Ok(CsvRow {
                line: record.position().map_or(0, |p| p.line()),
                record,
                file,
                header,
            })
        })
    }
}

/// One data row of a [`CsvFile`].
#[derive(Debug, Clone)]
pub struct CsvRow<'a> {
    line: u64,
    record: csv::StringRecord,
    file: &'a Path,
    header: &'a csv::StringRecord,
}

impl CsvRow<'_> {
    /// 1-based line of the row in its file.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The (trimmed) text of column `col` (0-based; empty past the end of the row).
    pub fn text(&self, col: usize) -> &str {
        self.record.get(col).unwrap_or("")
    }

    /// Column `col` as a finite number.
    pub fn num(&self, col: usize) -> Result<f64, DatasetError> {
        let text = self.text(col);
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.bad(col, format!("`{text}` is not a finite number")))
    }

    /// A [`DatasetError::BadValue`] for column `col` of this row.
    pub fn bad(&self, col: usize, message: impl Into<String>) -> DatasetError {
        DatasetError::BadValue {
            file: self.file.to_path_buf(),
            line: self.line,
            col: col + 1,
            column: self.header.get(col).unwrap_or("").into(),
            message: message.into(),
        }
    }
}

/// A CSV-layer error naming the file and line.
fn csv_error(file: &Path, e: csv::Error) -> DatasetError {
    DatasetError::Csv {
        file: file.to_path_buf(),
        line: e.position().map_or(0, |p| p.line()),
        message: e.to_string(),
    }
}

/// One 1 s turning segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurningRow {
    /// Line in the file.
    pub line: u64,
    /// Tool id.
    pub tool: u32,
    /// Mean cutting force (dynamometer `F_c_MEAN`), N.
    pub force_n: f64,
    /// Mean spindle mechanical power (`TV50.S_MEAN`), W.
    pub power_w: f64,
    /// Mean spindle electrical power (`TV51.S_MEAN`), unit undocumented (≈ 12 W per unit).
    pub power_elec: f64,
    /// Spindle speed, encoder units (`CON.SV2.S`; proportional to rpm).
    pub speed: f64,
    /// Programmed feed (`CON.G.FREAL`), CNC units.
    pub feed: f64,
    /// Mean Z (feed) axis drive current (`CV3.Z_MEAN`), A.
    pub feed_current_a: f64,
    /// Flank wear `Vb`, µm.
    pub vb_um: f64,
    /// 0-based index of the segment within its tool, in file (time) order.
    pub segment: u32,
}

/// One 100 ms row of the wax-milling drive log.
#[derive(Debug, Clone, PartialEq)]
pub struct MillRow {
    /// Line in the file.
    pub line: u64,
    /// `Machining_Process` (`Prep`, `Layer 1 Up`, …, `Repositioning`, `End`).
    pub process: String,
    /// Spindle actual velocity (`S1_ActualVelocity`, unit undocumented, ≈ 53.3 cutting).
    pub spindle_velocity: f64,
    /// Spindle actual acceleration (`S1_ActualAcceleration`).
    pub spindle_accel: f64,
    /// Spindle output power (`S1_OutputPower` × 1000), W.
    pub spindle_power_w: f64,
    /// X axis actual velocity (`X1_ActualVelocity`), mm/s.
    pub x_velocity_mm_s: f64,
    /// Y axis actual velocity (`Y1_ActualVelocity`), mm/s.
    pub y_velocity_mm_s: f64,
    /// Programmed feed (`M1_CURRENT_FEEDRATE`), mm/s.
    pub programmed_feed_mm_s: f64,
}

impl MillRow {
    /// `true` for the rows of a cutting layer.
    pub fn is_cutting(&self) -> bool {
        self.process.starts_with("Layer")
    }
}

/// Read the turning data set. Rows with a programmed feed of 0 are skipped (one in the
/// file); the count of skipped rows is returned.
pub fn read_turning(path: &Path) -> Result<(Vec<TurningRow>, usize), DatasetError> {
    let mut f = CsvFile::open(path)?;
    let c = f.columns([
        "tool",
        "F_c_MEAN",
        "TV50.S_MEAN",
        "TV51.S_MEAN",
        "CON.SV2.S",
        "CON.G.FREAL",
        "CV3.Z_MEAN",
        "Vb",
    ])?;
    let mut skipped = 0;
    let mut out = Vec::new();
    let mut segments: std::collections::BTreeMap<u32, u32> = std::collections::BTreeMap::new();
    for row in f.rows() {
        let row = row?;
        let feed = row.num(c[5])?;
        if feed <= 0.0 {
            skipped += 1;
            continue;
        }
        let tool = row.num(c[0])? as u32;
        let segment = segments.entry(tool).or_default();
        out.push(TurningRow {
            line: row.line(),
            tool,
            segment: *segment,
            force_n: row.num(c[1])?,
            power_w: row.num(c[2])?,
            power_elec: row.num(c[3])?,
            speed: row.num(c[4])?,
            feed,
            feed_current_a: row.num(c[6])?,
            vb_um: row.num(c[7])?,
        });
        *segment += 1;
    }
    Ok((out, skipped))
}

/// Read one wax-milling experiment.
pub fn read_mill(path: &Path) -> Result<Vec<MillRow>, DatasetError> {
    let mut f = CsvFile::open(path)?;
    let c = f.columns([
        "S1_ActualVelocity",
        "S1_ActualAcceleration",
        "S1_OutputPower",
        "X1_ActualVelocity",
        "Y1_ActualVelocity",
        "M1_CURRENT_FEEDRATE",
        "Machining_Process",
    ])?;
    let mut out = Vec::new();
    for row in f.rows() {
        let row = row?;
        out.push(MillRow {
            line: row.line(),
            process: row.text(c[6]).to_string(),
            spindle_velocity: row.num(c[0])?,
            spindle_accel: row.num(c[1])?,
            spindle_power_w: row.num(c[2])? * 1000.0,
            x_velocity_mm_s: row.num(c[3])?,
            y_velocity_mm_s: row.num(c[4])?,
            programmed_feed_mm_s: row.num(c[5])?,
        });
    }
    Ok(out)
}

/// One period of a calibration recording (`acc estimate-eval --calibrate-from`): CSV with
/// the header `rpm,power_w,current_a,force_ref_n,air` — spindle speed (rpm), mean input
/// power (W), RMS current (A), reference force from the dynamometer (N) and `air` = 1 for
/// air-cut periods (they teach the no-load model), 0 for cutting periods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalRecord {
    /// Line in the file.
    pub line: u64,
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// Mean input power, W.
    pub power_w: f64,
    /// RMS current, A.
    pub current_a: f64,
    /// Reference force, N.
    pub force_ref_n: f64,
    /// Air-cut period.
    pub air: bool,
}

/// Read a calibration recording (see [`CalRecord`]); `air` must be 0 or 1.
pub fn read_calibration_periods(path: &Path) -> Result<Vec<CalRecord>, DatasetError> {
    let mut f = CsvFile::open(path)?;
    let c = f.columns(["rpm", "power_w", "current_a", "force_ref_n", "air"])?;
    let mut out = Vec::new();
    for row in f.rows() {
        let row = row?;
        let air = match row.num(c[4])? {
            0.0 => false,
            1.0 => true,
            x => return Err(row.bad(c[4], format!("{x} is not 0 or 1"))),
        };
        out.push(CalRecord {
            line: row.line(),
            rpm: row.num(c[0])?,
            power_w: row.num(c[1])?,
            current_a: row.num(c[2])?,
            force_ref_n: row.num(c[3])?,
            air,
        });
    }
    Ok(out)
}

/// The shared data folder `../shared/data` next to the workspace root, if it exists.
pub fn shared_data_dir(workspace_root: &Path) -> Option<PathBuf> {
    let d = workspace_root.join("../shared/data");
    d.is_dir().then_some(d)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn file_with(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.csv");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    #[test]
    fn columns_by_name_trimmed_and_errors_name_file_line_column() {
        let (_d, path) = file_with("b, a ,c\n1, 2 ,x\n3,4,y\n5,oops,z\n");
        let mut f = CsvFile::open(&path).unwrap();
        let [a, c] = f.columns(["a", "c"]).unwrap();
        let mut got = Vec::new();
        let mut err = None;
        for row in f.rows() {
            let row = row.unwrap();
            match row.num(a) {
                Ok(v) => got.push((row.line(), v, row.text(c).to_string())),
                Err(e) => err = Some(e),
            }
        }
        assert_eq!(got, vec![(2, 2.0, "x".into()), (3, 4.0, "y".into())]);
        let e = err.unwrap();
        assert_eq!(
            e,
            DatasetError::BadValue {
                file: path.clone(),
                line: 4,
                col: 2,
                column: "a".into(),
                message: "`oops` is not a finite number".into(),
            }
        );
        assert_eq!(
            e.to_string(),
            format!(
                "{}: line 4, column 2 (`a`): `oops` is not a finite number",
                path.display()
            )
        );
        let missing = CsvFile::open(&path).unwrap().column("nope").unwrap_err();
        assert_eq!(
            missing.to_string(),
            format!("{}: line 1: missing column `nope`", path.display())
        );
        assert_eq!(missing.file(), path.as_path());
    }

    #[test]
    fn non_finite_numbers_and_missing_files_are_refused() {
        let (_d, path) = file_with("x\nNaN\n");
        let mut f = CsvFile::open(&path).unwrap();
        let row = f.rows().next().unwrap().unwrap();
        assert!(matches!(
            row.num(0),
            Err(DatasetError::BadValue { line: 2, .. })
        ));
        let e = CsvFile::open(Path::new("/nonexistent/d.csv")).unwrap_err();
        assert!(matches!(e, DatasetError::Open { .. }), "{e}");
    }
}
