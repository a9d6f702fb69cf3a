//! Importers for the real data in `../shared/data/`, mapped onto the run-log schema.
//!
//! **Vicomtech turning** (`vicomtech-turning/tool_wear_tools_3-10.csv`, CC BY-SA 4.0,
//! Ferrando Chacón et al., Int. J. Adv. Manuf. Technol. 125 (2023) 4027–4045; raw data
//! Mondragon Unibertsitatea): one 1 s segment per row, in time order within a tool.
//!
//! | run-log column | source | unit |
//! | --- | --- | --- |
//! | `t_s` | row index within the tool × 1 s | s (segment time; gaps between passes are not recorded) |
//! | `force_n` | `F_c_MEAN` (dynamometer cutting force) | N |
//! | `power_w` | `TV50.S_MEAN` (spindle mechanical power) | W |
//! | `spindle_rpm` | `CON.SV2.S / 1000` (encoder speed; the data's internal scale, proportional to rpm, factor undocumented) | "rpm" (scaled) |
//! | `feed_mm_min` | `CON.G.FREAL` (programmed feed; proportional to speed, i.e. constant feed per revolution) | data's unit (mm/min assumed) |
//! | `radial_depth_mm`, `axial_depth_mm` | not recorded: 1 (placeholder: every row is cutting) | mm |
//! | `wear_vb_um` | `Vb` (flank wear, interpolated) — never read by the workflow | µm |
//!
//! Rows with zero programmed feed are skipped (one row of tool 3).
//!
//! **UMich CNC mill** (`umich-cnc-mill/experiment_NN.csv`, CC0, University of Michigan
//! SMART lab 2018): wax, one row every 100 ms.
//!
//! | run-log column | source | unit |
//! | --- | --- | --- |
//! | `t_s` | row index × 0.1 s | s |
//! | `power_w` | `S1_OutputPower × 1000` | W (source in kW) |
//! | `spindle_rpm` | `S1_ActualVelocity × 60` | rpm, assuming the undocumented unit is rev/s (≈ 53.3 → 3 200 rpm) |
//! | `feed_mm_min` | `60·√(X1_ActualVelocity² + Y1_ActualVelocity²)` | mm/min (source mm/s) |
//! | `programmed_feed_mm_min` | `M1_CURRENT_FEEDRATE × 60` | mm/min (source mm/s, matches the path speed) |
//! | `radial_depth_mm`, `axial_depth_mm` | 1 while `Machining_Process` is a `Layer …` phase, else 0 (placeholder depth; wax cut depth not recorded) | mm |
//! | `phase` | `Machining_Process` | text |

use std::collections::BTreeMap;
use std::path::Path;

use crate::runlog::{RunLog, RunLogError};

fn open(path: &Path) -> Result<csv::Reader<std::fs::File>, RunLogError> {
    let f = std::fs::File::open(path).map_err(|e| RunLogError::Io {
        file: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    Ok(csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(f))
}

struct Cols<'a> {
    path: &'a Path,
    header: csv::StringRecord,
}

impl Cols<'_> {
    fn idx(&self, name: &str) -> Result<usize, RunLogError> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| RunLogError::MissingColumn {
                file: self.path.to_path_buf(),
                column: name.into(),
                required: "see acc_ident::import docs".into(),
            })
    }

    fn num(&self, rec: &csv::StringRecord, col: usize) -> Result<f64, RunLogError> {
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let text = rec.get(col).unwrap_or("");
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| RunLogError::BadValue {
                file: self.path.to_path_buf(),
                line,
                col: col + 1,
                column: self.header.get(col).unwrap_or("").into(),
                message: format!("`{text}` is not a finite number"),
            })
    }
}

/// Import the Vicomtech turning file: one run log per tool id, in file order.
pub fn vicomtech_turning(path: &Path) -> Result<BTreeMap<u32, RunLog>, RunLogError> {
    let mut rdr = open(path)?;
    let csv_err = |e: csv::Error| RunLogError::Csv {
        file: path.to_path_buf(),
        line: e.position().map(|p| p.line()).unwrap_or(0),
        message: e.to_string(),
    };
    let cols = Cols {
        path,
        header: rdr.headers().map_err(csv_err)?.clone(),
    };
    let (c_f, c_p, c_s, c_feed, c_tool, c_vb) = (
        cols.idx("F_c_MEAN")?,
        cols.idx("TV50.S_MEAN")?,
        cols.idx("CON.SV2.S")?,
        cols.idx("CON.G.FREAL")?,
        cols.idx("tool")?,
        cols.idx("Vb")?,
    );
    let mut out: BTreeMap<u32, RunLog> = BTreeMap::new();
    for rec in rdr.records() {
        let rec = rec.map_err(csv_err)?;
        let feed = cols.num(&rec, c_feed)?;
        if feed <= 0.0 {
            continue;
        }
        let tool = cols.num(&rec, c_tool)? as u32;
        let log = out.entry(tool).or_insert_with(|| RunLog {
            force_n: Some(Vec::new()),
            power_w: Some(Vec::new()),
            wear_vb_um: Some(Vec::new()),
            ..RunLog::default()
        });
        let t = log.t_s.len() as f64 + 1.0;
        log.t_s.push(t);
        log.radial_depth_mm.push(1.0);
        log.axial_depth_mm.push(1.0);
        log.spindle_rpm.push(cols.num(&rec, c_s)? / 1000.0);
        log.feed_mm_min.push(feed);
        let push = |v: &mut Option<Vec<f64>>, x: f64| {
            if let Some(v) = v.as_mut() {
                v.push(x);
            }
        };
        push(&mut log.force_n, cols.num(&rec, c_f)?);
        push(&mut log.power_w, cols.num(&rec, c_p)?);
        push(&mut log.wear_vb_um, cols.num(&rec, c_vb)?);
    }
    for log in out.values() {
        log.validate(path)?;
    }
    Ok(out)
}

/// Import one UMich CNC-mill experiment file.
pub fn umich_mill(path: &Path) -> Result<RunLog, RunLogError> {
    let mut rdr = open(path)?;
    let csv_err = |e: csv::Error| RunLogError::Csv {
        file: path.to_path_buf(),
        line: e.position().map(|p| p.line()).unwrap_or(0),
        message: e.to_string(),
    };
    let cols = Cols {
        path,
        header: rdr.headers().map_err(csv_err)?.clone(),
    };
    let (c_p, c_s, c_vx, c_vy, c_feed, c_phase) = (
        cols.idx("S1_OutputPower")?,
        cols.idx("S1_ActualVelocity")?,
        cols.idx("X1_ActualVelocity")?,
        cols.idx("Y1_ActualVelocity")?,
        cols.idx("M1_CURRENT_FEEDRATE")?,
        cols.idx("Machining_Process")?,
    );
    let mut log = RunLog {
        power_w: Some(Vec::new()),
        programmed_feed_mm_min: Some(Vec::new()),
        phase: Some(Vec::new()),
        ..RunLog::default()
    };
    let mut power = Vec::new();
    let mut prog = Vec::new();
    let mut phases = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(csv_err)?;
        let phase = rec.get(c_phase).unwrap_or("").to_string();
        let cutting = phase.starts_with("Layer");
        let t = (log.t_s.len() + 1) as f64 * 0.1;
        log.t_s.push(t);
        let d = if cutting { 1.0 } else { 0.0 };
        log.radial_depth_mm.push(d);
        log.axial_depth_mm.push(d);
        log.spindle_rpm.push((cols.num(&rec, c_s)? * 60.0).max(0.0));
        let (vx, vy) = (cols.num(&rec, c_vx)?, cols.num(&rec, c_vy)?);
        log.feed_mm_min.push(60.0 * (vx * vx + vy * vy).sqrt());
        prog.push(cols.num(&rec, c_feed)? * 60.0);
        power.push(cols.num(&rec, c_p)? * 1000.0);
        phases.push(phase);
    }
    log.power_w = Some(power);
    log.programmed_feed_mm_min = Some(prog);
    log.phase = Some(phases);
    log.validate(path)?;
    Ok(log)
}
