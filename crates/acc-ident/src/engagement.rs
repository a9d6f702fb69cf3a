//! The engagement of a production log, rebuilt from the workpiece along the path.
//!
//! A log from `acc run` has the production columns only: a real machine never knows its
//! depth of cut, so `radial_depth_mm` and `axial_depth_mm` are empty. What it does log is
//! the path position `x_mm`, the integral of the actual feed since the run began, the
//! first row's period included. With the workpiece (`acc discrepancy --workpiece`) the
//! engagement of every row is the simulator's own
//! ([`acc_sim::engagement::EngagementSource`] of the workpiece, down milling, the material ahead of the
//! tool centre) at the workpiece coordinate `u = x0_mm + (x_mm − x_mm of the first row)`,
//! for the model's tool diameter; the axial depth is the workpiece's.
//!
//! **The offset `x0_mm`** is the workpiece coordinate of the tool centre when `acc run`
//! first read the machine (the end of the first row's period). `u` is 0 at the start of the
//! workpiece's first segment, where the simulated machine (`acc_sim::machine::Machine::new`)
//! starts its tool centre, at rest: under `acc board-sim --wait-for-controller` the first
//! read sees that held machine, so `x0_mm = 0` (the default) whatever the feed. A plant
//! replay is anchored the same way ([`crate::runlog::RunLog::path_start_mm`]: its tool starts
//! one period of the first row's feed before `x0_mm`) and then moves with its own feed;
//! the logged `x_mm` places the depth columns and a period-based replay. On a real machine
//! `--x0-mm` is where the tool centre stood when `acc run` began to log (negative: before
//! the first segment). A simulator's log (`x_true_mm` in every row) places itself: its
//! true positions are the workpiece coordinates, and the replay starts at its first one
//! less its true first-period travel, the simulator's own start (`--x0-mm` does not apply;
//! the simulator's first read comes after its first period).

use std::path::{Path, PathBuf};

use acc_config::ConfigError;
use acc_sim::engagement::Engagement;
use acc_sim::workpiece::Workpiece;

/// Default workpiece coordinate of the tool centre at the log's first read, mm: the
/// simulated machine waits for the controller with its tool centre at the start of the
/// workpiece's first segment.
pub const DEFAULT_X0_MM: f64 = 0.0;

/// Allowed range of `--x0-mm`, mm.
pub const X0_RANGE_MM: (f64, f64) = (-1e5, 1e5);

/// Engagement from the path position: a workpiece, the tool diameter and the offset.
#[derive(Debug, Clone)]
pub struct PathEngagement {
    /// The workpiece along the path.
    pub workpiece: Workpiece,
    /// File the workpiece came from (a workpiece file, or the scenario that names one).
    pub source: PathBuf,
    /// Tool diameter, mm (the model's `tool.diameter_mm`).
    pub tool_diameter_mm: f64,
    /// Workpiece coordinate of the tool centre at the log's first read, mm.
    pub x0_mm: f64,
}

impl PathEngagement {
    /// Load a workpiece file (`configs/workpieces/*.toml`), or a scenario file
    /// (`configs/scenarios/*.toml`, which names its workpiece), for a tool of
    /// `tool_diameter_mm` (mm) and the offset `x0_mm` (mm, [`X0_RANGE_MM`]). Errors name the
    /// file and the key with its allowed range; a depth larger than the tool diameter is
    /// refused.
    pub fn load(path: &Path, tool_diameter_mm: f64, x0_mm: f64) -> Result<Self, ConfigError> {
        if !(x0_mm.is_finite() && (X0_RANGE_MM.0..=X0_RANGE_MM.1).contains(&x0_mm)) {
            return Err(ConfigError::OutOfRange(
                acc_config::RangeError::new(
                    "--x0-mm",
                    x0_mm,
                    format!("{} ..= {} mm", X0_RANGE_MM.0, X0_RANGE_MM.1),
                )
                .in_file(path),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
            file: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        let table: toml::Table = toml::from_str(&text).map_err(|e| ConfigError::Parse {
            file: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let workpiece = if table.contains_key("segment") {
            Workpiece::load(path)?
        } else if table.contains_key("workpiece") {
            acc_sim::Scenario::load(path)
                .map_err(|e| ConfigError::Invalid {
                    file: path.to_path_buf(),
                    key: "workpiece".into(),
                    message: format!("the scenario does not load: {e}"),
                })?
                .workpiece
        } else {
            return Err(ConfigError::Invalid {
                file: path.to_path_buf(),
                key: "segment".into(),
                message: "neither a workpiece file ([[segment]] tables) nor a scenario file (a `workpiece` key)".into(),
            });
        };
        workpiece.check_tool(path, tool_diameter_mm)?;
        Ok(PathEngagement {
            workpiece,
            source: path.to_path_buf(),
            tool_diameter_mm,
            x0_mm,
        })
    }

    /// The workpiece's engagement ([`acc_sim::engagement::EngagementSource`]) `travel_mm`
    /// (mm) along the path from where the log began (the log's `x_mm` minus its first
    /// row's).
    pub fn at(&self, travel_mm: f64) -> Engagement {
        self.workpiece
            .engagement(travel_mm + self.x0_mm, 0.5 * self.tool_diameter_mm)
    }

    /// Whether any segment has a `ks_factor` other than 1 (a material change the model,
    /// which has one `Ks`, does not replay).
    pub fn has_material_changes(&self) -> bool {
        self.workpiece
            .segments
            .iter()
            .any(|s| (s.ks_factor - 1.0).abs() > 1e-12)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn configs() -> PathBuf {
        acc_sim::run::configs_dir()
    }

    #[test]
    fn workpiece_and_scenario_files_give_the_same_engagement() {
        let wp = configs().join("workpieces/steps_2_3_4.toml");
        let sc = configs().join("scenarios/paper_case3.toml");
        let a = PathEngagement::load(&wp, 16.0, 0.0).expect("workpiece");
        let b = PathEngagement::load(&sc, 16.0, 0.0).expect("scenario");
        for x in [0.0, 10.0, 14.0, 30.0, 60.0, 100.0, 140.0] {
            assert_eq!(a.at(x), b.at(x), "x = {x}");
        }
        // 15 mm of air, then 2 mm: fully engaged 10 mm in, nothing 15 mm before.
        assert_eq!((a.at(25.0).radial_mm, a.at(25.0).axial_mm), (2.0, 16.0));
        assert_eq!(a.at(5.0).radial_mm, 0.0);
        // The offset shifts the workpiece: 10 mm further along.
        let c = PathEngagement::load(&wp, 16.0, 10.0).expect("workpiece");
        assert_eq!(c.at(15.0), a.at(25.0));
        assert!(!a.has_material_changes());
        let hard = configs().join("workpieces/hard_inclusion.toml");
        assert!(PathEngagement::load(&hard, 16.0, 0.0)
            .expect("hard inclusion")
            .has_material_changes());
    }

    #[test]
    fn bad_inputs_name_the_file_and_the_key() {
        let wp = configs().join("workpieces/steps_2_3_4.toml");
        let e = PathEngagement::load(&wp, 16.0, f64::NAN).expect_err("NaN offset");
        assert!(e.to_string().contains("--x0-mm"), "{e}");
        // A 3 mm tool cannot take a 4 mm radial depth.
        let e = PathEngagement::load(&wp, 3.0, 0.0).expect_err("depth > diameter");
        let s = e.to_string();
        assert!(
            s.contains("steps_2_3_4.toml") && s.contains("segment[3].depth_mm"),
            "{s}"
        );
        let model = configs().join("models/paper_vmc.toml");
        let e = PathEngagement::load(&model, 16.0, 0.0).expect_err("not a workpiece");
        assert!(
            e.to_string().contains("paper_vmc.toml") && e.to_string().contains("segment"),
            "{e}"
        );
    }
}

#[cfg(test)]
mod record_tests {
    use super::*;
    use crate::runlog::{from_records, from_records_with, RunLogError};
    use acc_runtime::RunRecord;

    /// A production log: 40 rows at 200 mm/min from 5 mm to 18.3 mm along `steps_2_3_4.toml`.
    fn production_rows() -> Vec<RunRecord> {
        (0..40)
            .map(|k| RunRecord {
                t_s: 0.1 * (k + 1) as f64,
                period: k,
                x_mm: Some(200.0 / 60.0 * 0.1 * (k + 1) as f64 + 5.0),
                spindle_rpm: Some(600.0),
                programmed_feed_mm_min: Some(200.0),
                feed_mm_min: Some(200.0),
                power_w: Some(700.0),
                force_n: Some(0.0),
                ..RunRecord::default()
            })
            .collect()
    }

    #[test]
    fn a_production_log_needs_the_workpiece_and_gets_its_engagement_from_it() {
        let rows = production_rows();
        let p = Path::new("run.csv");
        let e = from_records(&rows, p).expect_err("no engagement");
        assert!(
            matches!(
                e,
                RunLogError::MissingEngagement {
                    line: 2,
                    last_line: 41,
                    empty_rows: 40,
                    rows: 40,
                    radial_col: 35,
                    axial_col: 36,
                    x_col: 8,
                    ..
                }
            ),
            "{e:?}"
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with("run.csv: line 2:") && msg.contains("--workpiece"),
            "{msg}"
        );
        let wp = acc_sim::run::configs_dir().join("workpieces/steps_2_3_4.toml");
        // The first read at 5.333 mm: the travel since then is placed from there.
        let x_first = rows[0].x_mm.expect("x");
        let eng = PathEngagement::load(&wp, 16.0, x_first).expect("workpiece");
        let log = from_records_with(&rows, p, Some(&eng)).expect("engagement from x_mm");
        for (i, r) in rows.iter().enumerate() {
            let x = r.x_mm.expect("x");
            assert_eq!(log.radial_depth_mm[i], eng.at(x - x_first).radial_mm);
            assert_eq!(log.axial_depth_mm[i], 16.0);
        }
        // Air before the cut (x = 5.3 mm: the material starts 9.7 mm ahead, beyond the
        // radius), fully engaged at the end (x = 18.3 mm: 2 mm from 15 mm on).
        assert_eq!(log.radial_depth_mm[0], 0.0);
        assert_eq!(*log.radial_depth_mm.last().expect("rows"), 2.0);
        // A row without a path position is refused with its line and column.
        let mut holed = rows.clone();
        holed[5].x_mm = None;
        let e = from_records_with(&holed, p, Some(&eng)).expect_err("no x_mm");
        assert!(
            e.to_string()
                .starts_with("run.csv: line 7, column 8 (`x_mm`): empty"),
            "{e}"
        );
    }
}
