//! Readers of the two public data sets in `../shared/data/` (see their README files):
//!
//! * `vicomtech-turning/tool_wear_tools_3-10.csv`: 1 s segments of turning with dynamometer
//!   force and spindle power (Vicomtech / Mondragon Unibertsitatea, CC BY-SA 4.0;
//!   Ferrando Chacón et al., Int. J. Adv. Manuf. Technol. 125:4027–4045, 2023);
//! * `umich-cnc-mill/experiment_NN.csv`: 100 ms drive logs of wax milling (University of
//!   Michigan SMART lab, CC0).
//!
//! Errors name the file, the line and the column.

use std::path::{Path, PathBuf};

/// A data set could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {where_}{message}", file = .file.display(), where_ = match .line { Some(l) => format!("line {l}: "), None => String::new() })]
pub struct DatasetError {
    /// File path.
    pub file: PathBuf,
    /// 1-based line, if known.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
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
}

impl MillRow {
    /// `true` for the rows of a cutting layer.
    pub fn is_cutting(&self) -> bool {
        self.process.starts_with("Layer")
    }
}

fn err(file: &Path, line: Option<u64>, message: impl Into<String>) -> DatasetError {
    DatasetError {
        file: file.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Read a CSV file with a header and pick the named columns of every row.
fn read_columns<const K: usize>(
    path: &Path,
    names: [&str; K],
    text_col: Option<&str>,
) -> Result<Vec<(u64, [f64; K], String)>, DatasetError> {
    let mut rd = csv::Reader::from_path(path).map_err(|e| err(path, None, e.to_string()))?;
    let headers = rd
        .headers()
        .map_err(|e| err(path, Some(1), e.to_string()))?
        .clone();
    let find = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| err(path, Some(1), format!("missing column `{name}`")))
    };
    let mut idx = [0usize; K];
    for (i, n) in idx.iter_mut().zip(names) {
        *i = find(n)?;
    }
    let text_idx = text_col.map(find).transpose()?;
    let mut out = Vec::new();
    for rec in rd.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line());
            err(path, line, e.to_string())
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        let mut vals = [0.0; K];
        for ((v, &i), name) in vals.iter_mut().zip(&idx).zip(names) {
            let text = rec.get(i).unwrap_or("");
            *v = text.trim().parse::<f64>().map_err(|_| {
                err(
                    path,
                    Some(line),
                    format!("column `{name}`: `{text}` is not a number"),
                )
            })?;
        }
        let text = text_idx.and_then(|i| rec.get(i)).unwrap_or("").to_string();
        out.push((line, vals, text));
    }
    Ok(out)
}

/// Read the turning data set. Rows with a programmed feed of 0 are skipped (one in the
/// file); the count of skipped rows is returned.
pub fn read_turning(path: &Path) -> Result<(Vec<TurningRow>, usize), DatasetError> {
    let names = [
        "tool",
        "F_c_MEAN",
        "TV50.S_MEAN",
        "TV51.S_MEAN",
        "CON.SV2.S",
        "CON.G.FREAL",
        "CV3.Z_MEAN",
        "Vb",
    ];
    let rows = read_columns(path, names, None)?;
    let mut skipped = 0;
    let mut out = Vec::with_capacity(rows.len());
    for (line, v, _) in rows {
        if v[5] <= 0.0 {
            skipped += 1;
            continue;
        }
        out.push(TurningRow {
            line,
            tool: v[0] as u32,
            force_n: v[1],
            power_w: v[2],
            power_elec: v[3],
            speed: v[4],
            feed: v[5],
            feed_current_a: v[6],
            vb_um: v[7],
        });
    }
    Ok((out, skipped))
}

/// Read one wax-milling experiment.
pub fn read_mill(path: &Path) -> Result<Vec<MillRow>, DatasetError> {
    let names = [
        "S1_ActualVelocity",
        "S1_ActualAcceleration",
        "S1_OutputPower",
    ];
    Ok(read_columns(path, names, Some("Machining_Process"))?
        .into_iter()
        .map(|(line, v, process)| MillRow {
            line,
            process,
            spindle_velocity: v[0],
            spindle_accel: v[1],
            spindle_power_w: v[2] * 1000.0,
        })
        .collect())
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
    let names = ["rpm", "power_w", "current_a", "force_ref_n", "air"];
    read_columns(path, names, None)?
        .into_iter()
        .map(|(line, v, _)| {
            let air = match v[4] {
                0.0 => false,
                1.0 => true,
                x => {
                    return Err(err(
                        path,
                        Some(line),
                        format!("column `air`: {x} is not 0 or 1"),
                    ))
                }
            };
            Ok(CalRecord {
                line,
                rpm: v[0],
                power_w: v[1],
                current_a: v[2],
                force_ref_n: v[3],
                air,
            })
        })
        .collect()
}

/// The shared data folder `../shared/data` next to the workspace root, if it exists.
pub fn shared_data_dir(workspace_root: &Path) -> Option<PathBuf> {
    let d = workspace_root.join("../shared/data");
    d.is_dir().then_some(d)
}
