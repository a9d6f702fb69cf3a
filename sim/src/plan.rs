//! The planner of `acc plan`: the cutting plan of a path ([`acc_runtime::plan::Plan`]),
//! from the engagement known before the run and the plant's own force law.
//!
//! It asks the same [`EngagementSource`] the plant asks ([`EngagementSource::engagement_at`]
//! for the engagement, [`EngagementSource::path_at`] for the programmed feed, block and
//! tool) and evaluates the same mean-force law (seed 002 eq. 1,
//! [`acc_plant::process::ForceLaw::mean_force_n`]) with the scenario's constants: the tool's
//! `Ks` calibration, the spindle's commanded speed, the tool's initial wear factor. So on
//! a noise-free run at a constant override the plan's force and the plant's agree up to
//! what the plant adds over time (wear growth, a sagging spindle speed, the feed drive's
//! transient).
//!
//! With a wear law ([`PlanParams::wearing`], `acc plan --model`: the wear a model file
//! learned from a run log) the tool's `Ks` factor grows along the path as the plant's does
//! ([`acc_plant::process::WearSpec::factor`]): with the volume the path removed before each
//! point (the engagement's cross-section swept along the path, rapids included, as the
//! plant counts it) and the cutting time at the programmed feed.
//!
//! The path is cut into intervals between knots (the source's engagement breakpoints and
//! the pieces' starts, where the feed changes); the engagement is linear between knots, so
//! the largest force of an interval is at one of its ends, and the plan's bound holds over
//! the whole interval. Per interval: the largest force at 100 % override `F₁₀₀`, and the
//! planned override, the largest position of the board's grid at or below
//! `100 · (Fr / F₁₀₀)^(1/β)` (the force law solved for the feed), clamped to the tool's
//! limits and at least one grid step (an override of 0 stops the program); the grid's
//! maximum in air and on rapids. Consecutive intervals with the same block, tool, kind of
//! move, planned override and cutting or not, along which the force is constant, are one
//! row (its smallest and largest force kept: the band the look-ahead checks the measured
//! force against); an interval along which the force rises or falls is a row of its own,
//! with its `profile` (the look-ahead reads the force the tool can reach inside it).

use acc_core::OverrideSpec;
use acc_plant::engagement::{EngagementSource, ToolGeometry};
use acc_plant::process::{ForceLaw, WearSpec};
use acc_runtime::plan::{ForceProfile, Plan, PlanRow};

use crate::program::ProgramPath;
use crate::Scenario;

/// The constants of the plan: the tool, the force law and the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanParams {
    /// The cutter.
    pub tool: ToolGeometry,
    /// The plant's mean-force law (seed 002 eq. 1).
    pub law: ForceLaw,
    /// Spindle speed, rpm.
    pub rpm: f64,
    /// The tool's wear law: its `Ks` factor `initial · (1 + g_V·V^p + g_t·t)` after the
    /// volume `V` the path removed so far (cm³) and the cutting time `t` (min, at the
    /// programmed feed). [`PlanParams::of`]: the initial factor, no growth.
    pub wear: WearSpec,
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// The board's grid and the tool's override limits, percent.
    pub grid: OverrideSpec,
}

impl PlanParams {
    /// The constants of `scenario`: its tool and force law, the spindle's commanded speed,
    /// the tool's initial wear factor (held along the path), its Fr and its override grid
    /// within the fault policy's limits.
    pub fn of(scenario: &Scenario) -> Self {
        let mut grid = scenario.controller.override_spec;
        grid.min_pct = grid.min_pct.max(scenario.policy.min_override_pct);
        grid.max_pct = grid.max_pct.min(scenario.policy.max_override_pct);
        PlanParams {
            tool: ToolGeometry::of(&scenario.tool),
            law: ForceLaw::new(scenario.tool.process),
            rpm: scenario.machine.spindle.rpm,
            wear: WearSpec {
                initial_factor: scenario.wear.initial_factor,
                ..WearSpec::default()
            },
            force_ref_n: scenario.controller.force_ref_n,
            grid,
        }
    }

    /// These constants with the tool's `Ks` factor following the wear law `wear` along the
    /// path (`acc plan --model`: the scenario's tool replaced by a model file's).
    pub fn wearing(self, wear: WearSpec) -> Self {
        PlanParams { wear, ..self }
    }

    /// The planned override for a largest force `f100_n` (N) at 100 %: the grid position at
    /// or below the one that gives Fr, at least one step; the maximum without force.
    pub fn override_for(&self, f100_n: f64) -> u16 {
        let step = self.grid.step_pct.max(1);
        let top = self.grid.floor(self.grid.max_pct).0;
        if f100_n <= 0.0 {
            return top;
        }
        let beta = self.law.spec.beta;
        let exact = acc_core::force_law::feed_for_force(100.0, f100_n, self.force_ref_n, beta);
        let pct = exact.floor().clamp(0.0, f64::from(top)) as u16;
        self.grid.floor(pct).0.max(step.max(self.grid.min_pct))
    }
}

/// One interval of the path between two knots: what it says and the largest force on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Path position where the interval starts, mm.
    pub a: f64,
    /// Path position where it ends, mm.
    pub b: f64,
    /// Block (BLOCK_NUMBER) at its middle.
    pub block: u32,
    /// Tool at its middle.
    pub tool: u32,
    /// A rapid move.
    pub rapid: bool,
    /// Programmed feed (clamped at the rapid rate; a rapid: the rapid rate), mm/min.
    pub feed: f64,
    /// Largest predicted mean force at 100 % override (at one of its ends), N.
    pub f100: f64,
    /// Smallest predicted mean force at 100 % override, N.
    pub fmin: f64,
    /// Radial engagement where the force is largest, mm.
    pub radial: f64,
    /// Axial engagement where the force is largest, mm.
    pub axial: f64,
    /// Force at 100 % at the interval's end `b`, N.
    pub f_end: f64,
    /// The force is linear along the interval within [`LINEAR_TOLERANCE`] of `fmin`: no step
    /// just inside either end, and the middle no higher than the chord.
    pub linear: bool,
}

/// How far the force may depart from the chord between an interval's ends for the interval
/// to count as linear (a `rising` or `falling` plan row), × its smaller end's force: 1 %.
pub const LINEAR_TOLERANCE: f64 = 0.01;

impl Interval {
    /// The force along the interval: rising or falling where it is linear between its
    /// ends; flat (its largest force throughout, the safe reading) where both ends agree,
    /// in air, on a rapid, or where the force is not linear along it (a step just inside
    /// an end, or a middle above the chord: with a radial exponent α < 1 of eq. 1 the
    /// force is concave in the radial depth).
    pub fn profile(&self) -> ForceProfile {
        if self.rapid
            || !self.linear
            || self.f100 <= 0.0
            || self.f100 - self.fmin <= 1e-9 * self.f100
        {
            ForceProfile::Flat
        } else if self.f_end >= self.f100 {
            ForceProfile::Rising
        } else {
            ForceProfile::Falling
        }
    }
}

/// The intervals of the path of `source` between the increasing path positions `knots`
/// (mm): the engagement is linear between knots, so an interval's largest force is at one
/// of its ends (seed 002 eq. 1 at the interval's programmed feed; the wear factor of
/// [`PlanParams::wear`] after the volume removed up to that end, which only grows).
pub fn intervals(
    source: &mut dyn EngagementSource,
    knots: &[f64],
    p: &PlanParams,
) -> Vec<Interval> {
    // Removed volume (cm³) and cutting time (min) before the interval.
    let (mut volume_cm3, mut cut_min) = (0.0, 0.0);
    let force = |e: &acc_plant::engagement::Engagement, feed: f64, wear: f64| {
        let f = p
            .law
            .mean_force_n(e.radial_mm, e.axial_mm, feed, p.rpm, e.ks_factor * wear);
        (f, e.radial_mm, e.axial_mm)
    };
    let mut out: Vec<Interval> = Vec::with_capacity(knots.len());
    for w in knots.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let mid = 0.5 * (a + b);
        let pt = source.path_at(mid);
        let (feed, block, tool, rapid) = pt.map_or((0.0, 0, 0, false), |q| {
            (q.feed_mm_min, q.block, q.tool, q.rapid)
        });
        let ea = source.engagement_at(&p.tool, a);
        let eb = source.engagement_at(&p.tool, b);
        let wear_a = p.wear.factor(volume_cm3, cut_min);
        let (fa, ra, aa) = force(&ea, feed, wear_a);
        // The cross-section is linear between knots: the trapezoid is the swept volume
        // when one of radial and axial depth is constant along the interval.
        let vol_cm3 =
            0.5 * (ea.radial_mm * ea.axial_mm + eb.radial_mm * eb.axial_mm) * (b - a) * 1e-3;
        if vol_cm3 > 0.0 {
            volume_cm3 += vol_cm3;
            if feed > 0.0 {
                cut_min += (b - a) / feed;
            }
        }
        let wear_b = p.wear.factor(volume_cm3, cut_min);
        let (fb, rb, ab) = force(&eb, feed, wear_b);
        let (f100, radial, axial) = if fb > fa { (fb, rb, ab) } else { (fa, ra, aa) };
        // Linear along it? Just inside both ends and the middle (the end's wear: it only
        // grows, so the check is on the safe side). The smallest force is read just inside
        // the ends too (an engagement step at a knot belongs to the side the interval lies
        // on); the largest stays the ends' (the step's high side: the safe reading).
        let (linear, fmin) = if !rapid && f100 > 0.0 {
            let mut inside_at =
                |x: f64, wear: f64| force(&source.engagement_at(&p.tool, x), feed, wear).0;
            let d = (b - a) * 1e-6;
            let (fa_in, fb_in) = (inside_at(a + d, wear_b), inside_at(b - d, wear_b));
            let fmin = inside_at(a + d, wear_a).min(fb_in);
            let mut inside = |x: f64| inside_at(x, wear_b);
            // Relative to the smaller end's force: near the low end of a steep row 1 % of
            // the largest force would be several percent of the force there.
            let tol = LINEAR_TOLERANCE * fa.min(fb) + 1e-9 * f100;
            let linear = (fa_in - fa).abs() <= tol
                && (fb_in - fb).abs() <= tol
                && inside(mid) <= 0.5 * (fa + fb) + tol;
            (linear, fmin.min(f100))
        } else {
            (false, fa.min(fb))
        };
        out.push(Interval {
            a,
            b,
            block,
            tool,
            rapid,
            feed,
            f100,
            fmin,
            radial,
            axial,
            f_end: fb,
            linear,
        });
    }
    out
}

/// Whether a row whose force at 100 % lies in `lo ..= hi` (N) predicts it well enough for
/// the look-ahead to judge the plan's scale by it: within ±
/// [`acc_runtime::LookAheadConfig::DEFAULT_SCALE_BAND_HALF_WIDTH`] of its middle (air, both
/// 0, counts as narrow).
fn narrow_band(lo: f64, hi: f64) -> bool {
    hi - lo <= acc_runtime::LookAheadConfig::DEFAULT_SCALE_BAND_HALF_WIDTH * (hi + lo)
}

/// The plan of the path of `source` between the increasing path positions `knots` (mm;
/// the first is the start of the path, the last its end), with `position` the tool's
/// position in space at a path position (mm).
pub fn plan_along(
    source: &mut dyn EngagementSource,
    knots: &[f64],
    position: impl Fn(f64) -> [f64; 3],
    p: &PlanParams,
) -> Plan {
    let intervals = intervals(source, knots, p);
    let top = p.grid.floor(p.grid.max_pct).0;
    let beta = p.law.spec.beta;
    let mut rows: Vec<PlanRow> = Vec::new();
    for iv in intervals {
        let ov = if iv.rapid {
            top
        } else {
            p.override_for(iv.f100)
        };
        let same = rows.last().is_some_and(|r| {
            r.block == iv.block
                && r.tool == iv.tool
                && r.rapid == iv.rapid
                && r.override_pct == ov
                && r.cuts() == (iv.f100 > 0.0)
                // A row keeps its force's shape only as one interval: a rising or falling
                // interval is a row of its own.
                && r.profile == ForceProfile::Flat
                && iv.profile() == ForceProfile::Flat
                // A row's band stays narrow enough for the look-ahead to judge the plan's
                // scale by it (an entry's rising force is not merged into the cut after it).
                && narrow_band(
                    r.force_min_100_n.min(iv.fmin),
                    r.force_100_n.max(iv.f100),
                )
        });
        if same {
            if let Some(r) = rows.last_mut() {
                r.end_mm = iv.b;
                r.force_min_100_n = r.force_min_100_n.min(iv.fmin);
                if iv.f100 > r.force_100_n {
                    r.force_100_n = iv.f100;
                    r.radial_mm = iv.radial;
                    r.axial_mm = iv.axial;
                }
            }
            continue;
        }
        let [x, y, z] = position(iv.a);
        rows.push(PlanRow {
            block: iv.block,
            tool: iv.tool,
            start_mm: iv.a,
            end_mm: iv.b,
            x_mm: x,
            y_mm: y,
            z_mm: z,
            rapid: iv.rapid,
            feed_mm_min: iv.feed,
            radial_mm: iv.radial,
            axial_mm: iv.axial,
            force_100_n: iv.f100,
            force_min_100_n: iv.fmin,
            override_pct: ov,
            force_planned_n: 0.0,
            feed_exponent: beta,
            profile: iv.profile(),
            force_ref_n: Some(p.force_ref_n),
        });
    }
    for r in &mut rows {
        let scale = if r.rapid {
            1.0
        } else {
            f64::from(r.override_pct) / 100.0
        };
        r.force_planned_n = r.force_100_n * scale.powf(beta);
    }
    Plan { rows }
}

impl ProgramPath {
    /// The plan of this program ([`plan_along`] on a copy of its engagement, between its
    /// [`ProgramPath::knots`]).
    pub fn plan(&self, p: &PlanParams) -> Plan {
        let mut source = self.clone();
        plan_along(&mut source, &self.knots(), |x| self.position_at(x), p)
    }

    /// The program's constant safe feed on `scenario` (the one override on the grid whose
    /// predicted peak over the whole program is ≤ Fr: [`PlanFigures::safe_override_pct`] of
    /// this program's plan), percent: `acc sim --law constant-safe` and the oracle's peak
    /// budget.
    pub fn safe_override_pct(&self, scenario: &Scenario) -> u16 {
        let params = PlanParams::of(scenario);
        PlanFigures::of(&self.plan(&params), params.grid.max_pct).safe_override_pct
    }

    /// Law `kind` on `scenario` for this program: [`Scenario::build_law`], except that the
    /// constant safe feed is the program's own ([`ProgramPath::safe_override_pct`]).
    pub fn build_law(
        &self,
        scenario: &Scenario,
        kind: crate::LawKind,
    ) -> Result<Box<dyn acc_core::OverrideLaw>, crate::SimError> {
        if kind != crate::LawKind::ConstantSafeFeed {
            return scenario.build_law(kind);
        }
        Ok(Box::new(crate::baselines::ConstantFeed::at(
            scenario.controller.override_spec,
            scenario.controller.force_ref_n,
            self.safe_override_pct(scenario),
            "constant-safe",
        )))
    }

    /// The [`intervals`] of this program between its [`ProgramPath::knots`].
    pub fn intervals(&self, p: &PlanParams) -> Vec<Interval> {
        let mut source = self.clone();
        intervals(&mut source, &self.knots(), p)
    }

    /// The knots of the plan: the path's start and end, its engagement steps and its
    /// pieces' starts (where the feed changes), in order, mm.
    pub fn knots(&self) -> Vec<f64> {
        let mut knots: Vec<f64> = self.steps().iter().map(|(x, _)| *x).collect();
        knots.extend(self.piece_starts_mm());
        knots.push(EngagementSource::path_length_mm(self).unwrap_or(0.0));
        knots.push(0.0);
        knots.sort_by(f64::total_cmp);
        knots.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        knots
    }
}

/// What a plan says about a program, for the summary of `acc plan` and the program table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanFigures {
    /// Rows of the plan.
    pub rows: usize,
    /// Rows with a predicted force (cutting).
    pub cutting_rows: usize,
    /// Largest predicted force of the feed moves at 100 % override, N.
    pub peak_100_n: f64,
    /// Rows of rapid moves through the stock (not overridden: the plan cannot help).
    pub rapid_cut_rows: usize,
    /// Largest predicted force of the feed moves at the planned overrides, N.
    pub peak_planned_n: f64,
    /// The program's constant safe feed: the lowest planned override of the cutting rows
    /// (one override for the whole program whose predicted peak is ≤ Fr), percent.
    pub safe_override_pct: u16,
    /// Machine time of the path at the planned overrides (rapids at the rapid rate; no
    /// acceleration), s.
    pub planned_time_s: f64,
    /// Machine time at 100 %, s.
    pub nominal_time_s: f64,
    /// Machine time at the constant safe feed, s.
    pub safe_time_s: f64,
}

impl PlanFigures {
    /// The figures of `plan` on the grid's maximum `max_pct` (%).
    pub fn of(plan: &Plan, max_pct: u16) -> Self {
        let cutting: Vec<&PlanRow> = plan.rows.iter().filter(|r| r.cuts() && !r.rapid).collect();
        let safe = cutting
            .iter()
            .map(|r| r.override_pct)
            .min()
            .unwrap_or(max_pct);
        let time = |ov: &dyn Fn(&PlanRow) -> u16| {
            plan.rows
                .iter()
                .map(|r| {
                    let pct = if r.rapid { 100.0 } else { f64::from(ov(r)) };
                    let f = r.feed_mm_min * pct / 100.0;
                    if f > 0.0 {
                        60.0 * (r.end_mm - r.start_mm) / f
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
        };
        PlanFigures {
            rows: plan.rows.len(),
            cutting_rows: cutting.len(),
            peak_100_n: cutting.iter().map(|r| r.force_100_n).fold(0.0, f64::max),
            peak_planned_n: cutting
                .iter()
                .map(|r| r.force_planned_n)
                .fold(0.0, f64::max),
            rapid_cut_rows: plan.rows.iter().filter(|r| r.rapid && r.cuts()).count(),
            safe_override_pct: safe,
            planned_time_s: time(&|r| r.override_pct),
            nominal_time_s: time(&|_| 100),
            safe_time_s: time(&|_| safe),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use acc_plant::engagement::{Engagement, EngagementProfile};
    use acc_plant::process::ProcessSpec;

    fn params() -> PlanParams {
        PlanParams {
            tool: ToolGeometry {
                diameter_mm: 16.0,
                flutes: 4,
            },
            law: ForceLaw::new(ProcessSpec::paper()),
            rpm: 600.0,
            wear: WearSpec::default(),
            force_ref_n: 800.0,
            grid: OverrideSpec {
                step_pct: 10,
                min_pct: 0,
                max_pct: 150,
                ..OverrideSpec::default()
            },
        }
    }

    #[test]
    fn override_solves_the_force_law_on_the_grid() {
        let p = params();
        // Paper law: 2 mm × 16 mm at 200 mm/min gives 800 N; at 4 mm, 1600 N → 50 %.
        assert_eq!(p.override_for(1600.0), 50);
        assert_eq!(p.override_for(1700.0), 40);
        assert_eq!(p.override_for(0.0), 150);
        assert_eq!(p.override_for(1e9), 10);
        assert_eq!(p.override_for(100.0), 150);
    }

    /// A 1-D profile with a program's feed (200 mm/min) and blocks (10 before 20 mm, 20 after).
    #[derive(Debug, Clone)]
    struct Prog(EngagementProfile);

    impl EngagementSource for Prog {
        fn engagement_at(&mut self, _tool: &ToolGeometry, x_mm: f64) -> Engagement {
            self.0.at(x_mm)
        }
        fn path_at(&self, x_mm: f64) -> Option<acc_plant::engagement::PathPoint> {
            Some(acc_plant::engagement::PathPoint {
                feed_mm_min: 200.0,
                rapid: false,
                block: if x_mm < 20.0 { 10 } else { 20 },
                tool: 1,
            })
        }
    }

    #[test]
    fn a_wear_law_raises_the_force_with_the_volume_removed() {
        // 2 mm × 16 mm at 200 mm/min: 800 N on a new tool, 32 mm³ removed per mm.
        let e2 = Engagement {
            radial_mm: 2.0,
            axial_mm: 16.0,
            ks_factor: 1.0,
        };
        let mut prog =
            Prog(EngagementProfile::new(vec![0.0, 20.0], vec![e2, e2]).expect("profile"));
        let knots = [0.0, 5.0, 10.0, 20.0];
        let f = |p: &PlanParams, prog: &mut Prog| -> Vec<(f64, f64)> {
            intervals(prog, &knots, p)
                .iter()
                .map(|i| (i.fmin, i.f100))
                .collect()
        };
        assert!(f(&params(), &mut prog)
            .iter()
            .all(|&(a, b)| (a - 800.0).abs() < 1e-9 && (b - 800.0).abs() < 1e-9));
        let wearing = params().wearing(WearSpec {
            growth_per_cm3: 0.25,
            ..WearSpec::default()
        });
        let got = f(&wearing, &mut prog);
        // After 0.16, 0.32 and 0.64 cm³: × 1.04, 1.08, 1.16.
        let want = [(800.0, 832.0), (832.0, 864.0), (864.0, 928.0)];
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g.0 - w.0).abs() < 1e-6 && (g.1 - w.1).abs() < 1e-6,
                "{got:?}"
            );
        }
    }

    #[test]
    fn a_row_keeps_its_force_profile_only_where_the_force_is_linear_along_it() {
        let e = |r: f64, ax: f64| Engagement {
            radial_mm: r,
            axial_mm: ax,
            ks_factor: 1.0,
        };
        let plan_of = |xs: Vec<f64>, es: Vec<Engagement>| {
            let knots: Vec<f64> = xs.iter().fold(Vec::new(), |mut k, &x| {
                if k.last() != Some(&x) {
                    k.push(x);
                }
                k
            });
            let mut prog = Prog(EngagementProfile::new(xs, es).expect("profile"));
            plan_along(&mut prog, &knots, |x| [x, 0.0, 0.0], &params())
        };
        // Axial 2 → 4 mm at a constant radial depth: the force is linear in it.
        let rising = plan_of(vec![0.0, 10.0], vec![e(4.0, 2.0), e(4.0, 4.0)]);
        assert_eq!(rising.rows[0].profile, ForceProfile::Rising);
        let falling = plan_of(vec![0.0, 10.0], vec![e(4.0, 4.0), e(4.0, 2.0)]);
        assert_eq!(falling.rows[0].profile, ForceProfile::Falling);
        // A step at a knot: the interval after it is at the step's far side throughout
        // (not a ramp from the near side), and both rows are flat.
        let step = plan_of(
            vec![0.0, 5.0, 5.0, 10.0],
            vec![e(4.0, 2.0), e(4.0, 2.0), e(4.0, 4.0), e(4.0, 4.0)],
        );
        assert!(step.rows.iter().all(|r| r.profile == ForceProfile::Flat));
    }

    #[test]
    fn rows_of_one_override_merge_only_while_their_band_stays_narrow() {
        let e = |r: f64| Engagement {
            radial_mm: r,
            axial_mm: 16.0,
            ks_factor: 1.0,
        };
        let plan_of = |r1: f64| {
            let xs = vec![0.0, 5.0, 5.0, 10.0];
            let mut prog = Prog(
                EngagementProfile::new(xs, vec![e(1.0), e(1.0), e(r1), e(r1)]).expect("profile"),
            );
            plan_along(&mut prog, &[0.0, 5.0, 10.0], |x| [x, 0.0, 0.0], &params())
        };
        // 400 N then 380 N at 100 %: both planned at 150 %, within ±10 % of their middle:
        // one row.
        let near = plan_of(0.95);
        assert_eq!(near.rows.len(), 1, "{:?}", near.rows);
        assert!((near.rows[0].force_min_100_n - 380.0).abs() < 1e-6);
        // 400 N then 200 N: the same override, but one row would not tell the look-ahead
        // the force within ±10 %: two rows; the second reads its start, on the step, at
        // the step's high side (the largest force stays the ends').
        let far = plan_of(0.5);
        assert_eq!(far.rows.len(), 2, "{:?}", far.rows);
        assert!(far.rows.iter().all(|r| r.override_pct == 150));
        // The first row is 400 N throughout; the second is 200 N (its start, on the step,
        // read at the step's high side).
        assert_eq!(far.rows[0].force_min_100_n, far.rows[0].force_100_n);
        assert!((far.rows[1].force_min_100_n - 200.0).abs() < 1e-6);
    }

    #[test]
    fn rows_follow_the_engagement_and_bound_the_force() {
        // Air to 10 mm, 2 mm deep to 20 mm, 4 mm deep to 30 mm, 16 mm axial.
        let e = |r: f64| Engagement {
            radial_mm: r,
            axial_mm: 16.0,
            ks_factor: 1.0,
        };
        let mut prog = Prog(
            EngagementProfile::new(
                vec![0.0, 10.0, 10.0, 20.0, 20.0, 30.0],
                vec![e(0.0), e(0.0), e(2.0), e(2.0), e(4.0), e(4.0)],
            )
            .expect("profile"),
        );
        let knots = [0.0, 10.0, 15.0, 20.0, 25.0, 30.0];
        let plan = plan_along(&mut prog, &knots, |x| [x, 0.0, 0.0], &params());
        let got: Vec<(u32, f64, f64, u16)> = plan
            .rows
            .iter()
            .map(|r| (r.block, r.start_mm, r.end_mm, r.override_pct))
            .collect();
        assert_eq!(
            got,
            vec![
                (10, 0.0, 10.0, 150),
                (10, 10.0, 20.0, 100),
                (20, 20.0, 30.0, 50)
            ]
        );
        assert!((plan.rows[2].force_100_n - 1600.0).abs() < 1e-6);
        assert!(plan.rows.iter().all(|r| r.force_planned_n <= 800.0 + 1e-6));
        let figs = PlanFigures::of(&plan, 150);
        assert_eq!(figs.safe_override_pct, 50);
        assert_eq!(figs.cutting_rows, 2);
        // 30 mm at 200 mm/min is 9 s at 100 %; at 50 % throughout 18 s.
        assert!((figs.nominal_time_s - 9.0).abs() < 1e-9);
        assert!((figs.safe_time_s - 18.0).abs() < 1e-9);
        assert!((figs.planned_time_s - (3.0 / 1.5 + 3.0 + 3.0 / 0.5)).abs() < 1e-9);
    }
}
