//! [`LiveCut`]: the simulated cutting process along a path that arrives sample by sample
//! (LinuxCNC's own axis positions): it cuts the Z-map stock with `acc_stock::Sweep` as
//! `acc sim --program` does (path steps of one cell, the cutter of the tool number from the
//! tool table, `acc_sim::program::cutter_for`), and gives the force of the scenario's force
//! law (`acc_plant::process::ForceLaw`) and the spindle's electrical power of the machine
//! file's spindle (`SpindleSpec::input_power_w`, the constant-speed spindle `acc board-sim`
//! reports).

use acc_plant::config::SpindleSpec;
use acc_plant::engagement::ToolGeometry;
use acc_plant::process::ForceLaw;
use acc_stock::{Move, Spindle, StepEngagement, Sweep, SweepOptions, ZMap};
use std::path::PathBuf;

/// A chord whose XY length is below this fraction of its Z length is cut as a vertical
/// move.
const VERTICAL_RATIO: f64 = 0.5;

/// One sample of the process: the engagement held since the last path step and what it
/// gives at the sample's feed and speed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CutSample {
    /// Effective radial depth of the last path step, mm (0 in air).
    pub radial_mm: f64,
    /// Axial depth of the last path step, mm.
    pub axial_mm: f64,
    /// True mean cutting force, N.
    pub force_n: f64,
    /// Cutting torque, N·m.
    pub torque_nm: f64,
    /// Spindle input (electrical) power, W; 0 with the spindle stopped.
    pub power_w: f64,
}

/// The stock being cut along a live path (see the module docs).
pub struct LiveCut {
    /// The stock and the cutter in use (`None` only while the cutter changes).
    sweep: Option<Sweep>,
    /// Tool number of the cutter in use.
    tool: u32,
    /// The tool table (`--tools`), if any, and its file for messages.
    table: Option<(acc_nc::ToolTable, PathBuf)>,
    /// The scenario's tool, for T0 and without a table.
    default_tool: ToolGeometry,
    /// Flute length of every cutter, mm: longer than any depth the stock has.
    flute_length_mm: f64,
    /// Where the last path step was cut (`None`: not yet, or after a tool change).
    last_cut_mm: Option<[f64; 3]>,
    /// The engagement of the last path step, and whether it was a plunge.
    radial_mm: f64,
    axial_mm: f64,
    plunge: bool,
    /// The previous sample's position, and the XY share of the path speed from it to the
    /// latest (the chip load of a side cut comes from the XY motion alone).
    prev_mm: Option<[f64; 3]>,
    xy_share: f64,
    law: ForceLaw,
    spindle: SpindleSpec,
    radius_mm: f64,
    buf: Vec<StepEngagement>,
    /// Tool numbers the table did not list (each reported once).
    unknown_tools: Vec<u32>,
}

impl LiveCut {
    /// The process of `scenario` (force law, tool, spindle) on `stock`, diameters per tool
    /// number from `table` (with its file) if given.
    pub fn new(
        scenario: &acc_sim::Scenario,
        stock: ZMap,
        table: Option<(acc_nc::ToolTable, PathBuf)>,
    ) -> anyhow::Result<Self> {
        // As `ProgramPath::build_within`: long enough for any depth the stock has.
        let flute_length_mm = (stock.max_height_mm() - stock.bottom_mm()).max(1.0) + 1.0;
        let default_tool = ToolGeometry::of(&scenario.tool);
        let mut cut = LiveCut {
            sweep: None,
            tool: 0,
            table,
            default_tool,
            flute_length_mm,
            last_cut_mm: None,
            radial_mm: 0.0,
            axial_mm: 0.0,
            plunge: false,
            prev_mm: None,
            xy_share: 1.0,
            law: ForceLaw::new(scenario.tool.process),
            spindle: scenario.machine.spindle,
            radius_mm: scenario.tool.radius_mm(),
            buf: Vec::new(),
            unknown_tools: Vec::new(),
        };
        cut.sweep = Some(cut.sweep_for(0, stock)?);
        Ok(cut)
    }

    /// A sweep of `stock` with tool number `tool`'s cutter (the scenario's for an unlisted
    /// number, reported once on stderr).
    fn sweep_for(&mut self, tool: u32, stock: ZMap) -> anyhow::Result<Sweep> {
        let file = self
            .table
            .as_ref()
            .map(|(_, p)| p.clone())
            .unwrap_or_default();
        let table = self.table.as_ref().map(|(t, _)| t);
        let cutter = match acc_sim::program::cutter_for(
            tool,
            table,
            &self.default_tool,
            self.flute_length_mm,
            &file,
        ) {
            Ok(c) => c,
            Err(e) => {
                if !self.unknown_tools.contains(&tool) {
                    self.unknown_tools.push(tool);
                    eprintln!("warning: {e}: cutting with the scenario's tool");
                }
                acc_sim::program::cutter_for(
                    0,
                    None,
                    &self.default_tool,
                    self.flute_length_mm,
                    &file,
                )?
            }
        };
        Sweep::new(
            stock,
            cutter,
            Spindle::cw(self.spindle.rpm),
            SweepOptions::default(),
        )
        .map_err(|e| anyhow::anyhow!("the stock's sweep: {e}"))
    }

    /// One sample: the tool tip at `position_mm` (program coordinates, mm) with tool number
    /// `tool`, moving at `feed_mm_min` with the spindle at `rpm`, `t_s` seconds after the
    /// spindle started. The path is cut in steps of at least one cell from the last step
    /// (the engagement holds in between); the force and power are those of the held
    /// engagement at this sample's XY feed (the whole feed for a plunge) and speed.
    pub fn sample(
        &mut self,
        position_mm: [f64; 3],
        tool: u32,
        feed_mm_min: f64,
        rpm: f64,
        t_s: f64,
    ) -> anyhow::Result<CutSample> {
        if !position_mm.iter().all(|v| v.is_finite()) {
            anyhow::bail!("axis position {position_mm:?} is not finite");
        }
        if tool != self.tool {
            if let Some(sw) = self.sweep.take() {
                let stock = sw.into_stock();
                self.sweep = Some(self.sweep_for(tool, stock)?);
            }
            self.tool = tool;
            self.last_cut_mm = None;
        }
        let Some(sweep) = self.sweep.as_mut() else {
            anyhow::bail!("no stock");
        };
        match self.last_cut_mm {
            None => self.last_cut_mm = Some(position_mm),
            Some(from) => {
                let d = ((position_mm[0] - from[0]).powi(2)
                    + (position_mm[1] - from[1]).powi(2)
                    + (position_mm[2] - from[2]).powi(2))
                .sqrt();
                if d >= sweep.step_mm() {
                    // A chord mostly along Z (a plunge or retract, with the servo's last
                    // micrometres of XY in it) is cut straight down or up: its tiny XY
                    // direction would otherwise aim the leading half at the wall the tool
                    // has just cut. The XY left over joins the next chord.
                    let dxy = (position_mm[0] - from[0]).hypot(position_mm[1] - from[1]);
                    let dz = (position_mm[2] - from[2]).abs();
                    let to = if dxy < VERTICAL_RATIO * dz {
                        [from[0], from[1], position_mm[2]]
                    } else {
                        position_mm
                    };
                    self.buf.clear();
                    let mv = Move::feed(from, to, feed_mm_min.max(0.0));
                    sweep.cut(&mv, &mut self.buf);
                    if let Some(last) = self.buf.last() {
                        self.radial_mm = last.radial_mm;
                        self.axial_mm = last.ap_mm;
                        self.plunge = last.kind == acc_stock::StepKind::Plunge;
                    }
                    self.last_cut_mm = Some(to);
                }
            }
        }
        if let Some(prev) = self.prev_mm {
            let d = [
                position_mm[0] - prev[0],
                position_mm[1] - prev[1],
                position_mm[2] - prev[2],
            ];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if len > 1e-7 {
                self.xy_share = d[0].hypot(d[1]) / len;
            }
        }
        self.prev_mm = Some(position_mm);
        // A side cut's chip load comes from the XY feed (a retract out of a slot cuts
        // nothing while it still holds the slot's engagement); a plunge's from the whole.
        let chip_feed = if self.plunge {
            feed_mm_min
        } else {
            feed_mm_min * self.xy_share
        };
        let rpm = rpm.abs();
        let force_n = self
            .law
            .mean_force_n(self.radial_mm, self.axial_mm, chip_feed, rpm, 1.0);
        let torque_nm = self.law.torque_nm(force_n, self.radius_mm);
        Ok(CutSample {
            radial_mm: self.radial_mm,
            axial_mm: self.axial_mm,
            force_n,
            torque_nm,
            power_w: self.spindle.input_power_w(torque_nm, rpm, t_s),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> acc_sim::Scenario {
        acc_sim::Scenario::load(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../configs/scenarios/paper_case3.toml"),
        )
        .expect("scenario")
    }

    #[test]
    fn a_slot_fed_in_small_samples_cuts_full_width_and_the_power_follows_the_force() {
        let sc = scenario();
        let stock = ZMap::from_box([0.0, -20.0, -10.0], [40.0, 20.0, 0.0], 0.25).expect("box");
        let mut cut = LiveCut::new(&sc, stock, None).expect("cut");
        // 300 mm/min = 5 mm/s, a sample every 2 ms: 0.01 mm per sample, along y = 0 at
        // z = -2 from x = -10 (in air) to x = 20.
        let (feed, rpm) = (300.0, 600.0);
        let mut air = None;
        let mut full = None;
        for k in 0..3000 {
            let x = -10.0 + 0.01 * f64::from(k);
            let s = cut
                .sample([x, 0.0, -2.0], 0, feed, rpm, 0.002 * f64::from(k))
                .expect("sample");
            if k == 100 {
                air = Some(s);
            }
            if k == 2900 {
                full = Some(s);
            }
        }
        let (air, full) = (air.expect("air"), full.expect("full"));
        assert_eq!(air.force_n, 0.0);
        assert!((air.power_w - sc.machine.spindle.no_load_power_w).abs() < 1e-9);
        // In the slot: a_e = D = 16 mm, a_p = 2 mm.
        assert!((full.radial_mm - 16.0).abs() < 0.3, "{full:?}");
        assert!((full.axial_mm - 2.0).abs() < 1e-6, "{full:?}");
        let expected = ForceLaw::new(sc.tool.process).mean_force_n(16.0, 2.0, feed, rpm, 1.0);
        assert!(
            (full.force_n - expected).abs() < 0.03 * expected,
            "{full:?} vs {expected}"
        );
        assert!(full.power_w > air.power_w + 100.0, "{full:?}");
        // A retract with a few micrometres of XY in it cuts nothing.
        for k in 1..=100 {
            let s = cut
                .sample(
                    [
                        19.99 + 1e-5 * f64::from(k),
                        1e-5 * f64::from(k),
                        -2.0 + 0.05 * f64::from(k),
                    ],
                    0,
                    feed,
                    rpm,
                    6.0 + 0.002 * f64::from(k),
                )
                .expect("sample");
            assert!(s.force_n < 1.0, "retract sample {k}: {s:?}");
        }
        // The spindle stopped: no force, no power.
        let stopped = cut
            .sample([20.5, 0.0, -2.0], 0, feed, 0.0, 7.0)
            .expect("sample");
        assert_eq!((stopped.force_n, stopped.power_w), (0.0, 0.0));
    }

    #[test]
    fn a_position_that_is_not_finite_is_refused() {
        let sc = scenario();
        let stock = ZMap::from_box([0.0, 0.0, -5.0], [10.0, 10.0, 0.0], 0.25).expect("box");
        let mut cut = LiveCut::new(&sc, stock, None).expect("cut");
        assert!(cut
            .sample([f64::NAN, 0.0, 0.0], 0, 100.0, 600.0, 0.0)
            .is_err());
    }
}
