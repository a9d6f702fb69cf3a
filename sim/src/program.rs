//! An NC program on the simulated machine: the path from `acc_nc` (the interpreter's
//! canonical calls as straight pieces), the engagement from `acc_stock` (a Z-map stock cut
//! by the program's tools), behind the plant's one [`EngagementSource`] trait.
//!
//! The engagement depends on the geometry only (the stock, the cutter and the path), not on
//! the feed, so it is computed once for the whole program before the run — every
//! [`acc_stock::Sweep`] step along the path, material removed as the tool passes — and the
//! plant reads it at the tool's path position as the overridden feed moves it. The feed the
//! plant follows is the program's (F words; G0 at the machine's rapid rate, not
//! overridden), and the board reports the block (the N word, else the line number) and the
//! tool of the piece the tool is in.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use acc_nc::PathSegment;
use acc_plant::engagement::{
    Engagement, EngagementProfile, EngagementSource, PathPoint, ToolGeometry,
};
use acc_stock::{Cutter, Move, Spindle, StepKind, Sweep, SweepOptions, ZMap};

use crate::SimError;

/// Without a tool table, T0 ..= T this are the scenario's tool.
const DEFAULT_TOOLS: u32 = 999;

/// Chord tolerance of the arcs' straight pieces, mm.
pub const CHORD_TOL_MM: f64 = 0.005;

/// Where the stock comes from.
#[derive(Debug, Clone)]
pub enum StockSource {
    /// A `stock.toml` (a box or a height map; `acc_stock::StockFile`).
    File(PathBuf),
    /// `--stock-box X0,Y0,Z0,X1,Y1,Z1`, mm, on cells of `cell_mm`.
    Box(acc_stock::BoxSpec, f64),
}

impl StockSource {
    /// The stock's Z-map.
    pub fn build(&self) -> Result<ZMap, SimError> {
        match self {
            StockSource::File(p) => acc_stock::load_stock(p),
            StockSource::Box(b, cell) => b.zmap(*cell),
        }
        .map_err(|e| SimError::Program(e.to_string()))
    }
}

/// What a program run needs besides the scenario.
#[derive(Debug, Clone)]
pub struct ProgramSpec {
    /// The NC program.
    pub program: PathBuf,
    /// The stock.
    pub stock: StockSource,
    /// A LinuxCNC tool table (`.tbl`) for the diameters of the program's T numbers; without
    /// it (or for a tool it does not list) the scenario's tool.
    pub tools: Option<PathBuf>,
}

/// The program's path with the engagement of every step along it. The data is immutable
/// once built and shared behind an [`Arc`]: a copy (one per plant copy the oracle tries,
/// [`EngagementSource::boxed_clone`]) is a reference count, not a copy of the path, the
/// engagement steps and the stock picture.
#[derive(Debug, Clone)]
pub struct ProgramPath {
    data: Arc<PathData>,
}

/// What [`ProgramPath`] shares between its copies.
#[derive(Debug)]
struct PathData {
    /// The program's canonical calls (what `segments` came from).
    calls: Vec<acc_nc::CanonCall>,
    /// The straight pieces, each with its block (N word, else line), tool and feed.
    segments: Vec<PathSegment>,
    /// Path position where each segment starts, mm.
    start_mm: Vec<f64>,
    length_mm: f64,
    rapid_mm_min: f64,
    profile: EngagementProfile,
    /// Steps whose rapid move ran through stock.
    rapid_collisions: usize,
    /// Steps with material above the flutes.
    beyond_flutes: usize,
    /// Material the whole program removes, mm³.
    removed_mm3: f64,
    /// The stock after the whole program.
    stock_after: ZMap,
    /// Path positions of the engagement steps, mm, and their engagement.
    steps: Vec<(f64, acc_stock::StepEngagement)>,
}

/// The tool table of a program run without `--tools`: T0 ..= T999 all the scenario's tool
/// (diameter `diameter_mm`, mm; no length offset).
pub fn scenario_tool_table(diameter_mm: f64) -> acc_nc::ToolTable {
    let mut t = acc_nc::ToolTable::default();
    for n in 0..=DEFAULT_TOOLS {
        t.insert(acc_nc::ToolEntry {
            tool: n,
            pocket: n,
            length_mm: 0.0,
            diameter_mm,
            comment: "the scenario's tool".into(),
        });
    }
    t
}

/// The cutter of tool number `tool`: the tool table's diameter for it when it lists it, else
/// the scenario's tool `default` (flutes always the scenario's); T0 or no table: `default`.
/// An error (naming `file`) for a T number the table does not list. `acc linuxcnc-process`
/// cuts with it too.
pub fn cutter_for(
    tool: u32,
    table: Option<&acc_nc::ToolTable>,
    default: &ToolGeometry,
    flute_length_mm: f64,
    file: &Path,
) -> Result<Cutter, SimError> {
    let d = match (table, tool) {
        (Some(t), tool) if tool > 0 => t.get(tool).map(|e| e.diameter_mm).ok_or_else(|| {
            SimError::Program(format!(
                "{}: tool T{tool} is not in the tool table",
                file.display()
            ))
        })?,
        _ => default.diameter_mm,
    };
    let d = if d > 0.0 { d } else { default.diameter_mm };
    Cutter::flat(d, default.flutes, flute_length_mm).map_err(|e| SimError::Program(e.to_string()))
}

impl ProgramPath {
    /// Interpret `spec.program`, build the stock and sweep the program's path through it
    /// with `tool` (the scenario's cutter; a tool table's diameters per T number), at
    /// `rpm` (chip load only) and the machine's `rapid_mm_min` (mm/min).
    pub fn build(
        spec: &ProgramSpec,
        tool: &ToolGeometry,
        rpm: f64,
        rapid_mm_min: f64,
    ) -> Result<Self, SimError> {
        Self::build_within(spec, tool, rpm, rapid_mm_min, None)
    }

    /// [`ProgramPath::build`] of `spec` with `scenario`'s cutter, spindle speed and rapid
    /// rate, as `acc sim SCENARIO --program … --stock…` builds it.
    pub fn for_scenario(spec: &ProgramSpec, scenario: &crate::Scenario) -> Result<Self, SimError> {
        Self::build(
            spec,
            &ToolGeometry::of(&scenario.tool),
            scenario.machine.spindle.rpm,
            scenario.machine.feed_drive.rapid_mm_min,
        )
    }

    /// [`ProgramPath::build`], refusing a program that leaves the machine's `travel` (the
    /// machine file's `[travel]`): the error names the program's file, line and the axis.
    pub fn build_within(
        spec: &ProgramSpec,
        tool: &ToolGeometry,
        rpm: f64,
        rapid_mm_min: f64,
        travel: Option<&acc_plant::config::Travel>,
    ) -> Result<Self, SimError> {
        let table = match &spec.tools {
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .map_err(|e| SimError::Program(format!("{}: {e}", p.display())))?;
                Some(
                    acc_nc::ToolTable::parse_tbl(
                        &p.display().to_string(),
                        &text,
                        acc_nc::Units::Mm,
                    )
                    .map_err(|e| SimError::Program(e.to_string()))?,
                )
            }
            None => None,
        };
        // Without a tool table every T number is the scenario's tool (no length offset).
        let tools = table
            .clone()
            .unwrap_or_else(|| scenario_tool_table(tool.diameter_mm));
        let setup = acc_nc::Setup {
            tools,
            ..acc_nc::Setup::default()
        };
        let program = acc_nc::interpret_file(&spec.program, &setup)
            .map_err(|e| SimError::Program(e.to_string()))?;
        let segments: Vec<PathSegment> = program
            .path(CHORD_TOL_MM)
            .into_iter()
            .filter(|s| s.length_mm() > 1e-9)
            .collect();
        if let Some(t) = travel {
            for s in &segments {
                if let Some((axis, v, r)) = t.outside(&s.to) {
                    return Err(SimError::Program(format!(
                        "{}:{}: {axis} {v:.3} mm leaves the machine's travel {axis} {} ..= {} mm \
                         (machine file [travel])",
                        spec.program.display(),
                        s.line,
                        r[0],
                        r[1]
                    )));
                }
            }
        }
        if segments.is_empty() {
            return Err(SimError::Program(format!(
                "{}: the program has no motion",
                spec.program.display()
            )));
        }
        let stock = spec.stock.build()?;
        // Long enough for any depth the stock has.
        let flute_length_mm = (stock.max_height_mm() - stock.bottom_mm()).max(1.0) + 1.0;
        let mut start_mm = Vec::with_capacity(segments.len());
        let mut at = 0.0;
        for s in &segments {
            start_mm.push(at);
            at += s.length_mm();
        }
        let mut sweep: Option<(u32, Sweep)> = None;
        let mut stock = Some(stock);
        let mut steps: Vec<(f64, acc_stock::StepEngagement)> = Vec::new();
        let mut buf = Vec::new();
        let (mut collisions, mut beyond, mut removed) = (0, 0, 0.0);
        for (seg, s0) in segments.iter().zip(&start_mm) {
            if sweep.as_ref().is_none_or(|(t, _)| *t != seg.tool) {
                let z = match sweep.take() {
                    Some((_, sw)) => sw.into_stock(),
                    None => stock
                        .take()
                        .ok_or_else(|| SimError::Program("stock".into()))?,
                };
                let cutter = cutter_for(
                    seg.tool,
                    table.as_ref(),
                    tool,
                    flute_length_mm,
                    &spec.program,
                )?;
                let sw = Sweep::new(z, cutter, Spindle::cw(rpm), SweepOptions::default())
                    .map_err(|e| SimError::Program(e.to_string()))?;
                sweep = Some((seg.tool, sw));
            }
            let Some((_, sw)) = sweep.as_mut() else {
                continue;
            };
            let mv = if seg.rapid {
                Move::rapid(seg.from, seg.to)
            } else {
                Move::feed(seg.from, seg.to, seg.feed_mm_min)
            };
            buf.clear();
            let summary = sw.cut(&mv, &mut buf);
            removed += summary.removed_mm3;
            for st in buf.drain(..) {
                let d = dist(&seg.from, &st.position_mm).min(seg.length_mm());
                collisions += usize::from(st.kind == StepKind::RapidCollision);
                beyond += usize::from(st.beyond_flutes);
                steps.push((s0 + d, st));
            }
        }
        let stock_after = match sweep {
            Some((_, sw)) => sw.into_stock(),
            None => stock.ok_or_else(|| SimError::Program("stock".into()))?,
        };
        // Monotone positions for the profile (steps of one piece are in order; a piece
        // starts where the last ended).
        let mut x = Vec::with_capacity(steps.len());
        let mut points = Vec::with_capacity(steps.len());
        let mut last = f64::NEG_INFINITY;
        for (p, st) in &steps {
            let p = p.max(last);
            last = p;
            x.push(p);
            points.push(Engagement {
                radial_mm: st.radial_mm,
                axial_mm: st.ap_mm,
                ks_factor: 1.0,
            });
        }
        let profile = EngagementProfile::new(x, points)
            .ok_or_else(|| SimError::Program("engagement profile out of order".into()))?;
        Ok(ProgramPath {
            data: Arc::new(PathData {
                calls: program.calls,
                segments,
                start_mm,
                length_mm: at,
                rapid_mm_min,
                profile,
                rapid_collisions: collisions,
                beyond_flutes: beyond,
                removed_mm3: removed,
                stock_after,
                steps,
            }),
        })
    }

    /// Steps whose rapid move ran through stock.
    pub fn rapid_collisions(&self) -> usize {
        self.data.rapid_collisions
    }

    /// Steps with material above the flutes.
    pub fn beyond_flutes(&self) -> usize {
        self.data.beyond_flutes
    }

    /// Material the whole program removes, mm³.
    pub fn removed_mm3(&self) -> f64 {
        self.data.removed_mm3
    }

    /// The stock after the whole program.
    pub fn stock_after(&self) -> &ZMap {
        &self.data.stock_after
    }

    /// Path positions of the engagement steps, mm, and their engagement, for the plan's
    /// figures (entries, corners).
    pub fn steps(&self) -> &[(f64, acc_stock::StepEngagement)] {
        &self.data.steps
    }

    /// The program's canonical calls, in execution order (the interpreter's output the
    /// path was made of).
    pub fn calls(&self) -> &[acc_nc::CanonCall] {
        &self.data.calls
    }

    /// The straight pieces of the path.
    pub fn segments(&self) -> &[PathSegment] {
        &self.data.segments
    }

    /// Path position where each piece starts, mm.
    pub fn piece_starts_mm(&self) -> &[f64] {
        &self.data.start_mm
    }

    /// Index of the piece at path position `x_mm` (the last one past the end).
    fn segment_at(&self, x_mm: f64) -> usize {
        self.data
            .start_mm
            .partition_point(|s| *s <= x_mm)
            .saturating_sub(1)
            .min(self.data.segments.len().saturating_sub(1))
    }

    /// The tool's position in space at path position `x_mm`, mm.
    pub fn position_at(&self, x_mm: f64) -> [f64; 3] {
        let i = self.segment_at(x_mm);
        let s = &self.data.segments[i];
        let len = s.length_mm().max(1e-12);
        let t = ((x_mm - self.data.start_mm[i]) / len).clamp(0.0, 1.0);
        [0, 1, 2].map(|k| s.from[k] + t * (s.to[k] - s.from[k]))
    }

    /// The machine time of the whole path at its programmed feeds (rapids at the rapid
    /// rate), s.
    pub fn nominal_time_s(&self) -> f64 {
        self.data
            .segments
            .iter()
            .map(|s| {
                let f = if s.rapid {
                    self.data.rapid_mm_min
                } else {
                    s.feed_mm_min.min(self.data.rapid_mm_min)
                };
                60.0 * s.length_mm() / f.max(1e-9)
            })
            .sum()
    }

    /// `scenario` set up to run this program: the mean force model (the tooth model reads a
    /// 1-D workpiece's geometry), and a time limit of twenty times the program's time at
    /// its programmed feeds plus 30 s (the loop may hold a program far too fast for the
    /// tool at a few per cent), at most a day.
    pub fn scenario_for(&self, scenario: &crate::Scenario) -> crate::Scenario {
        let mut sc = scenario.clone();
        sc.force_model = crate::ForceModel::Mean;
        sc.max_time_s = (20.0 * self.nominal_time_s() + 30.0).min(86_400.0);
        sc
    }

    /// Whether no step of the program engages the stock (it cuts air: a warning).
    pub fn cuts_air_only(&self) -> bool {
        self.data.steps.iter().all(|(_, s)| s.kind != StepKind::Cut)
    }
}

/// Where the engagement changes along a program's path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventKind {
    /// The tool enters material (air or plunge → cut).
    Entry,
    /// The path turns by more than [`CORNER_DEG`] while cutting.
    Corner,
}

/// A turn of the path sharper than this, while cutting, is a corner, degrees.
pub const CORNER_DEG: f64 = 30.0;

/// An engagement change at a path position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathEvent {
    /// Entry or corner.
    pub kind: EventKind,
    /// Path position, mm.
    pub at_mm: f64,
    /// Block of the piece it is in (N word, else line).
    pub block: u32,
}

impl ProgramPath {
    /// The entries and corners of the path, in path order.
    pub fn events(&self) -> Vec<PathEvent> {
        let mut out = Vec::new();
        let block_at = |x: f64| {
            let s = &self.data.segments[self.segment_at(x)];
            s.block.unwrap_or(s.line)
        };
        let mut was_cut = false;
        for (x, st) in &self.data.steps {
            let cut = st.kind == StepKind::Cut;
            if cut && !was_cut {
                out.push(PathEvent {
                    kind: EventKind::Entry,
                    at_mm: *x,
                    block: block_at(*x),
                });
            }
            was_cut = cut;
        }
        let dir = |s: &PathSegment| {
            let d = [s.to[0] - s.from[0], s.to[1] - s.from[1]];
            let n = d[0].hypot(d[1]);
            (n > 1e-9).then(|| [d[0] / n, d[1] / n])
        };
        let cos_max = CORNER_DEG.to_radians().cos();
        for k in 1..self.data.segments.len() {
            let (a, b) = (&self.data.segments[k - 1], &self.data.segments[k]);
            if a.rapid || b.rapid {
                continue;
            }
            let (Some(u), Some(v)) = (dir(a), dir(b)) else {
                continue;
            };
            let at = self.data.start_mm[k];
            let cutting = self.data.profile.at(at + 0.5 * self.steps_mm()).radial_mm > 0.0;
            if u[0] * v[0] + u[1] * v[1] < cos_max && cutting {
                out.push(PathEvent {
                    kind: EventKind::Corner,
                    at_mm: at,
                    block: b.block.unwrap_or(b.line),
                });
            }
        }
        out.sort_by(|a, b| a.at_mm.total_cmp(&b.at_mm));
        out
    }

    /// The engagement steps' spacing along the path, mm.
    fn steps_mm(&self) -> f64 {
        self.data
            .steps
            .windows(2)
            .map(|w| w[1].0 - w[0].0)
            .find(|d| *d > 0.0)
            .unwrap_or(0.25)
    }
}

/// The peak force at each event of a run: over the rows from the one where the tool
/// (`x_true_mm`, the plant's path position) reaches the event to `window_s` later, the
/// largest true force, N (`None`: the run never got there).
pub fn event_peaks(
    rows: &[acc_runtime::record::RunRecord],
    events: &[PathEvent],
    window_s: f64,
) -> Vec<(PathEvent, Option<f64>)> {
    events
        .iter()
        .map(|e| {
            let start = rows
                .iter()
                .position(|r| r.x_true_mm.is_some_and(|x| x >= e.at_mm));
            let peak = start.map(|i| {
                let t0 = rows[i].t_s;
                rows[i..]
                    .iter()
                    .take_while(|r| r.t_s <= t0 + window_s + 1e-9)
                    .filter_map(|r| r.force_true_n)
                    .fold(0.0, f64::max)
            });
            (*e, peak)
        })
        .collect()
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl EngagementSource for ProgramPath {
    fn engagement_at(&mut self, _tool: &ToolGeometry, x_mm: f64) -> Engagement {
        self.data.profile.at(x_mm)
    }

    fn path_at(&self, x_mm: f64) -> Option<PathPoint> {
        let s = &self.data.segments[self.segment_at(x_mm)];
        Some(PathPoint {
            // The control clamps an F word at the machine's fastest feed (the rapid rate).
            feed_mm_min: if s.rapid {
                self.data.rapid_mm_min
            } else {
                s.feed_mm_min.min(self.data.rapid_mm_min)
            },
            rapid: s.rapid,
            block: s.block.unwrap_or(s.line),
            tool: s.tool,
        })
    }

    fn path_length_mm(&self) -> Option<f64> {
        Some(self.data.length_mm)
    }

    fn boxed_clone(&self) -> Option<Box<dyn EngagementSource>> {
        Some(Box::new(self.clone()))
    }
}
