//! Cutter radius compensation (G40, G41, G42, G41.1, G42.1) in the XY (G17) and XZ (G18)
//! plane, computed as LinuxCNC's interpreter computes it (`convert_straight_comp1/2`,
//! `convert_arc_comp1/2`, `move_endpoint_and_flush`), so that the motions agree with `rs274`.
//!
//! All geometry is on the plane's first and second axis (`u`, `v`: X Y in G17, Z X in G18);
//! the coordinate along the normal follows the programmed one. The tool keeps `radius` to
//! the left (G41) or right (G42) of the programmed path, seen along the direction of
//! motion:
//!
//! - **Entry** (the first move after G41/G42): a line ends where a line from the current
//!   point touches the tool circle about the programmed end, at right angles to that line;
//!   an arc ends one radius off its programmed end, and its centre is moved so that it
//!   still starts at the current point. The move must be longer than the radius.
//! - **Every later move** is offset by the radius (a line parallel to the programmed one, an
//!   arc about the same centre with the radius one tool radius larger or smaller). Its end
//!   is not final: the move is held back until the next move shows the corner between them.
//!   - **Concave (inside) corner**: the held move's end goes back to where the two offset
//!     paths meet (line–line, line–arc, arc–line and arc–arc intersections); a move that would
//!     have to run backwards, or an arc that would have to sweep further, is an error
//!     (the tool would gouge).
//!   - **Convex (outside) corner** (the direction turns away from the tool by more than
//!     [`CORNER_TOLERANCE_RAD`]): an arc of the tool radius about the programmed corner is
//!     added (a straight traverse for G0).
//!   - **Tangent** (within the tolerance): nothing is added.
//! - **G40** gives out the held move as it is; the next move (which must be straight)
//!   starts at the compensated end and goes to its programmed end.
//!
//! Calls made while a move is held back (feed, spindle, coolant, dwell) are queued behind it,
//! so the stream keeps LinuxCNC's order. Each held move keeps its own block's line and N
//! number (rs274 prints, instead, the N number of the block that releases it).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use super::plane_geometry::{add, angle, dir, dist, signed_turn, sweep};
use super::{Block, State, Val};
use crate::canon::{Canon, CanonCall, Plane, Units};
use crate::error::{At, ErrorKind};

/// The angle (rad) within which two directions count as tangent at a corner (LinuxCNC's
/// `TOLERANCE_CONCAVE_CORNER`).
pub const CORNER_TOLERANCE_RAD: f64 = 0.05;

/// Below this |cos| the entry arc's centre cannot be found (LinuxCNC's `TOLERANCE_EQUAL`).
const TOLERANCE_EQUAL: f64 = 1e-4;

/// Which side of the programmed path the tool keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    /// G41 / G41.1.
    Left,
    /// G42 / G42.1.
    Right,
}

/// A call held back behind a compensated move.
#[derive(Debug, Clone)]
struct Held {
    call: CanonCall,
    /// For a line: the direction of the programmed motion in the plane, to find a line
    /// that an inside corner turned around. For an arc: its sweep as programmed (rad,
    /// signed; 0 for an added corner arc).
    dir: [f64; 2],
    sweep: f64,
}

/// The state of cutter radius compensation.
#[derive(Debug, Clone, Default)]
pub(super) struct Comp {
    /// G41/G42 in force.
    side: Option<Side>,
    /// Tool radius, mm (>= 0; a negative D swapped the side).
    radius: f64,
    /// The entry move was made (LinuxCNC: not `cutter_comp_firstmove`).
    entered: bool,
    /// The programmed end of the last move, work coordinates, mm (once `entered`).
    program: [f64; 3],
    /// The move held back and what followed it.
    held: Vec<Held>,
    /// Start (plane coordinates) of the last held move, when known (LinuxCNC's
    /// `endpoint`): what the checks against gouging measure from.
    endpoint: Option<[f64; 2]>,
    /// G40 gave out a held move: the next move must be a line (LinuxCNC's
    /// `arc_not_allowed`), and it starts at the compensated end.
    after_exit: bool,
}

impl Comp {
    /// G41/G42 in force with a radius above zero: motions are compensated.
    pub(super) fn active(&self) -> bool {
        self.side.is_some() && self.radius > 0.0
    }

    /// A move is held back: other calls queue behind it.
    pub(super) fn holds_back(&self) -> bool {
        !self.held.is_empty()
    }

    /// Queues a call behind the held move.
    pub(super) fn queue_other(&mut self, call: CanonCall) {
        self.held.push(Held {
            call,
            dir: [0.0; 2],
            sweep: 0.0,
        });
    }

    /// The programmed point words are read from, while compensated moves are made.
    pub(super) fn programmed(&self) -> Option<[f64; 3]> {
        (self.side.is_some() && self.entered).then_some(self.program)
    }

    /// Whether compensation shapes the motions of the block now running.
    pub(super) fn shapes_motion(&self) -> bool {
        self.active() || self.after_exit
    }

    /// The move after G40 was made.
    pub(super) fn exit_done(&mut self) {
        self.after_exit = false;
    }
}

/// The tool is inside an arc of `turn` (its centre on the tool's side).
fn inside(side: Side, turn: i64) -> bool {
    (side == Side::Left && turn > 0) || (side == Side::Right && turn < 0)
}

/// An arc held back: centre, end (plane coordinates) and turn.
struct HeldArc {
    center: [f64; 2],
    end: [f64; 2],
    turn: i64,
}

impl State<'_> {
    fn comp_err(w: &Val, detail: String) -> At {
        w.err(ErrorKind::Compensation { detail })
    }

    /// Refuses `what` while compensation is on (as LinuxCNC: planes, units, tool length,
    /// work offsets, tool changes, canned cycles).
    pub(super) fn comp_refuses(&self, w: &Val, what: &str) -> Result<(), At> {
        if self.comp.side.is_some() {
            return Err(Self::comp_err(
                w,
                format!("{what} while it is on; cancel it with G40 first"),
            ));
        }
        Ok(())
    }

    /// G40, G41, G42, G41.1, G42.1 and the D word of block `b`.
    pub(super) fn cutter_comp(&mut self, b: &Block) -> Result<(), At> {
        let code = b.g_in(&[400, 410, 420, 411, 421]);
        if let (Some(d), None | Some((400, _))) = (b.word('D'), code) {
            return Err(Self::missing(
                d,
                "G41, G42, G41.1 or G42.1 to use the D word",
            ));
        }
        let Some((code, g)) = code else {
            return Ok(());
        };
        if code == 400 {
            if self.comp.active() && self.comp.entered {
                let end = self.plane.project(self.pos);
                self.move_end_and_flush(end, g)?;
                self.comp_dequeue();
                self.pos = self.comp.program;
                self.comp.after_exit = true;
            }
            self.comp.side = None;
            self.comp.entered = false;
            return Ok(());
        }
        if self.plane == Plane::Yz {
            return Err(Self::comp_err(
                g,
                "in the YZ plane (G19); it works in G17 and G18".into(),
            ));
        }
        if self.comp.side.is_some() {
            return Err(Self::comp_err(
                g,
                "it is already on; cancel it with G40 before turning it on again".into(),
            ));
        }
        let d = b.word('D');
        let radius = if code == 411 || code == 421 {
            let d = d.ok_or_else(|| Self::missing(g, "D (the tool diameter) for G41.1/G42.1"))?;
            d.v * self.units.mm_per_unit() / 2.0
        } else {
            let tool = match d {
                Some(d) if (d.v - d.v.round()).abs() >= 1e-4 || d.v < -0.5 => {
                    return Err(d.err(ErrorKind::Range {
                        allowed: "D a whole tool number >= 0 with G41/G42 (G41.1/G42.1 take \
                                  the diameter)"
                            .into(),
                    }))
                }
                Some(d) if d.v.round() != 0.0 => self.tool_number(d)?,
                _ => self.tool,
            };
            self.setup
                .tools
                .get(tool)
                .map_or(0.0, |t| t.diameter_mm / 2.0)
        };
        let left = code == 410 || code == 411;
        // A negative radius swaps the side.
        self.comp.side = Some(if left == (radius >= 0.0) {
            Side::Left
        } else {
            Side::Right
        });
        self.comp.radius = radius.abs();
        self.comp.entered = false;
        Ok(())
    }

    /// Checks a motion against the rule after G40 (the next move is a line).
    pub(super) fn comp_allows_motion(&mut self, arc: bool, at: &Val) -> Result<(), At> {
        if !self.comp.after_exit {
            return Ok(());
        }
        if arc {
            return Err(Self::comp_err(
                at,
                "the move after G40 must be straight (G0 or G1), not an arc".into(),
            ));
        }
        Ok(())
    }

    /// A stop (M0 M1 M2 M30 M60, `w`): the held move is given out where it ends now.
    pub(super) fn comp_flush_here(&mut self, w: &Val) -> Result<(), At> {
        let end = self.plane.project(self.pos);
        self.move_end_and_flush(end, w)?;
        self.comp_dequeue();
        Ok(())
    }

    /// Gives out everything held back.
    pub(super) fn comp_dequeue(&mut self) {
        self.comp.endpoint = None;
        for h in std::mem::take(&mut self.comp.held) {
            self.push_out(h.call);
        }
    }

    /// Moves the end of every held motion to `p` (plane coordinates) and gives them out
    /// (LinuxCNC's `move_endpoint_and_flush`); `w` names the block for errors.
    fn move_end_and_flush(&mut self, p: [f64; 2], w: &Val) -> Result<(), At> {
        if self.comp.held.is_empty() {
            return Ok(());
        }
        let plane = self.plane;
        let [a, b, _] = plane.axes();
        let start = self.comp.endpoint;
        let tol = 0.01 * self.units.mm_per_unit();
        // How much further (rad) the held arc may sweep to the corner: LinuxCNC's slack,
        // which depends on the program's units (0.0254 in G21, 0.001 in G20).
        let sweep_slack = match self.units {
            Units::Mm => 0.0254,
            Units::Inch => 0.001,
        };
        for h in &mut self.comp.held {
            let sweep_before = h.sweep;
            let dir_before = h.dir;
            match &mut h.call.call {
                Canon::Arc {
                    to,
                    center,
                    clockwise,
                    turns,
                    ..
                } => {
                    let r1 = dist(plane.project(*to), *center);
                    let r2 = dist(p, *center);
                    if (r1 - r2).abs() > tol {
                        return Err(Self::comp_err(
                            w,
                            format!(
                                "the compensated arc would change its radius from {r1:.4} to \
                                 {r2:.4} mm at this corner"
                            ),
                        ));
                    }
                    let turn = signed_turn(*turns, *clockwise);
                    if let Some(s) = start {
                        let after = sweep(s, *center, turn, p);
                        if sweep_before != 0.0 && after.abs() > sweep_before.abs() + sweep_slack {
                            return Err(Self::comp_err(
                                w,
                                "the arc before this concave corner cannot be reached by \
                                 the tool without gouging"
                                    .into(),
                            ));
                        }
                    }
                    to[a] = p[0];
                    to[b] = p[1];
                }
                Canon::Traverse { to, .. } | Canon::Feed { to, .. } => {
                    if let Some(s) = start {
                        let d = dir_before[0] * (p[0] - s[0]) + dir_before[1] * (p[1] - s[1]);
                        if d < 0.0 {
                            return Err(Self::comp_err(
                                w,
                                "the line before this concave corner cannot be reached by the \
                                 tool without gouging (it would have to run backwards)"
                                    .into(),
                            ));
                        }
                    }
                    to[a] = p[0];
                    to[b] = p[1];
                }
                _ => {}
            }
        }
        self.comp_dequeue();
        self.comp.endpoint = Some(p);
        Ok(())
    }

    /// Holds back a motion of the current block.
    fn hold(&mut self, call: Canon, dir: [f64; 2], sweep: f64) {
        let call = self.canon_call(call);
        self.comp.held.push(Held { call, dir, sweep });
    }

    /// Holds back a line (traverse for G0) to `to`.
    fn hold_line(&mut self, rapid: bool, to: [f64; 3], dir: [f64; 2]) {
        let call = self.line_to(rapid, to);
        self.hold(call, dir, 0.0);
    }

    /// The start (plane coordinates) of the entry `kind` (line or arc) to `p`, which must
    /// end farther than the tool radius from it.
    fn entry_start(&self, p: [f64; 2], kind: &str, at: &Val) -> Result<[f64; 2], At> {
        let c = self.plane.project(self.pos);
        let (span, r) = (dist(p, c), self.comp.radius);
        if span <= r {
            return Err(Self::comp_err(
                at,
                format!(
                    "the entry move (the first after G41/G42, a {kind}) is {span:.4} mm long \
                     from start to end, not longer than the tool radius {r:.4} mm"
                ),
            ));
        }
        Ok(c)
    }

    /// Holds back an arc to `end` (plane coordinates) and `w` along the normal.
    fn hold_arc(&mut self, end: [f64; 2], w: f64, center: [f64; 2], turn: i64, sweep: f64) {
        let call = Canon::Arc {
            from: self.pos,
            to: self.plane.point(end, w),
            center,
            plane: self.plane,
            clockwise: turn < 0,
            turns: u32::try_from(turn.unsigned_abs()).unwrap_or(u32::MAX),
            feed_mm_min: self.feed_mm_min,
        };
        self.hold(call, [0.0; 2], sweep);
    }

    /// The held arc at the front of the queue, if the held move is an arc.
    fn held_arc(&self) -> Option<HeldArc> {
        match &self.comp.held.first()?.call.call {
            Canon::Arc {
                to,
                center,
                clockwise,
                turns,
                plane,
                ..
            } => Some(HeldArc {
                center: *center,
                end: plane.project(*to),
                turn: signed_turn(*turns, *clockwise),
            }),
            _ => None,
        }
    }

    /// A compensated motion (`m`: 0, 10, 20, 30) of block `b` to the programmed end `to`.
    pub(super) fn comp_motion(
        &mut self,
        m: u16,
        b: &Block,
        to: [f64; 3],
        at: &Val,
    ) -> Result<(), At> {
        let plane = self.plane;
        let p = plane.project(to);
        let w = to[plane.axes()[2]];
        let side = self.comp.side.unwrap_or(Side::Left);
        let entered = self.comp.entered;
        self.comp.after_exit = false;
        let end = match (m, entered) {
            (0 | 10, false) => self.line_entry(m == 0, p, w, side, at)?,
            (0 | 10, true) => self.line_next(m == 0, p, w, side, at)?,
            (_, false) => self.arc_entry(m == 20, p, w, side, b, at)?,
            (_, true) => self.arc_next(m == 20, p, w, side, b, at)?,
        };
        self.comp.entered = true;
        self.comp.program = to;
        self.pos = plane.point(end, w);
        Ok(())
    }

    /// The entry line to `p`: ends one radius off `p`, square to the line from the current
    /// point.
    fn line_entry(
        &mut self,
        rapid: bool,
        p: [f64; 2],
        w: f64,
        side: Side,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let c = self.entry_start(p, "line", at)?;
        let r = self.comp.radius;
        let normal = angle(c, p)
            + match side {
                Side::Left => FRAC_PI_2,
                Side::Right => -FRAC_PI_2,
            };
        let end = add(p, r, dir(normal));
        self.comp.endpoint = Some(c);
        self.hold_line(rapid, self.plane.point(end, w), dir(normal));
        Ok(end)
    }

    /// A later line to `p`: the corner with the held move decides what happens to it.
    fn line_next(
        &mut self,
        rapid: bool,
        p: [f64; 2],
        w: f64,
        side: Side,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let plane = self.plane;
        let c = plane.project(self.pos);
        let op = plane.project(self.comp.program);
        if p == op {
            // No motion in the plane: straight along the normal, held with the move.
            self.hold_line(rapid, plane.point(c, w), [0.0; 2]);
            return Ok(c);
        }
        let r = self.comp.radius;
        let small = CORNER_TOLERANCE_RAD;
        let (mut theta, mut alpha) = (angle(op, c), angle(op, p));
        let (beta, gamma) = match side {
            Side::Left => {
                if theta < alpha {
                    theta += TAU;
                }
                (theta - alpha - FRAC_PI_2, FRAC_PI_2)
            }
            Side::Right => {
                if alpha < theta {
                    alpha += TAU;
                }
                (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
            }
        };
        let offset = dir(alpha + gamma);
        let end = add(p, r, offset);
        let mid = add(op, r, offset);
        let prev = self.held_arc();
        // Past a half turn over an arc that has the tool outside ("h" shape): stay outside.
        let over_arc = prev
            .as_ref()
            .is_some_and(|a| !inside(side, a.turn) && beta > PI - small);
        let concave = beta < -small || beta > PI + small || over_arc;
        if concave {
            let corner = match prev {
                None => {
                    let half = (beta + PI) / 2.0;
                    if half == 0.0 {
                        return Err(Self::comp_err(at, "a zero-degree inside corner".into()));
                    }
                    add(c, r / half.tan(), dir(theta + gamma))
                }
                Some(arc) => self.arc_then_line(&arc, op, p, side, at)?,
            };
            self.move_end_and_flush(corner, at)?;
        } else if beta > small {
            // Convex: around the programmed corner on an arc of the tool radius (a
            // traverse for G0).
            self.move_end_and_flush(c, at)?;
            let cw = self.pos[plane.axes()[2]];
            if rapid {
                self.hold_line(true, plane.point(mid, cw), [0.0; 2]);
            } else {
                let turn = if side == Side::Left { -1 } else { 1 };
                self.hold_arc(mid, cw, op, turn, 0.0);
            }
            self.comp_dequeue();
            self.comp.endpoint = Some(mid);
        } else {
            self.comp_dequeue();
            self.comp.endpoint = Some(c);
        }
        self.hold_line(rapid, plane.point(end, w), [p[0] - op[0], p[1] - op[1]]);
        Ok(end)
    }

    /// Where a line from `op` to `p` meets the held (compensated) arc in a concave corner.
    fn arc_then_line(
        &self,
        arc: &HeldArc,
        op: [f64; 2],
        p: [f64; 2],
        side: Side,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let r = self.comp.radius;
        let old = dist(arc.center, arc.end);
        let toward = angle(op, p) + if arc.turn > 0 { FRAC_PI_2 } else { -FRAC_PI_2 };
        let phi = angle(op, arc.center);
        let tool_inside = inside(side, arc.turn);
        let programmed = if tool_inside { old + r } else { old - r };
        let d = programmed * (toward - phi).cos();
        let l = (if tool_inside { d - r } else { d + r }) / old;
        if !(-1.0..=1.0).contains(&l) {
            return Err(Self::comp_err(
                at,
                "this line after an arc makes a corner the tool cannot fit in without \
                 gouging"
                    .into(),
            ));
        }
        let a = if tool_inside == (arc.turn > 0) {
            -l.acos()
        } else {
            l.acos()
        } + toward
            + PI;
        Ok(add(arc.center, old, dir(a)))
    }

    /// The entry arc to `p`: ends one radius off `p`, its centre moved so that it still
    /// starts at the current point.
    fn arc_entry(
        &mut self,
        cw: bool,
        p: [f64; 2],
        w: f64,
        side: Side,
        b: &Block,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let c = self.entry_start(p, "arc", at)?;
        let r = self.comp.radius;
        let (center, turn) = self.signed_arc(cw, c, p, b, at)?;
        let tool_inside = inside(side, turn);
        self.radius_fits(tool_inside, dist(center, c), at)?;
        let gamma = if tool_inside {
            angle(p, center)
        } else {
            angle(center, p)
        };
        let end = add(p, r, dir(gamma));
        let half = dist(c, end) / 2.0;
        let towards_centre = angle(end, center);
        let a = angle(end, c) - towards_centre;
        if a.cos().abs() < TOLERANCE_EQUAL {
            return Err(Self::comp_err(
                at,
                format!("the tool radius {r:.4} mm does not fit this entry arc"),
            ));
        }
        let new_center = add(end, half / a.cos(), dir(towards_centre));
        let (r_end, r_start) = (dist(new_center, end), dist(new_center, c));
        if (r_end - r_start).abs() > self.setup.arc_radius_tolerance_mm.max(1e-6) {
            return Err(Self::comp_err(
                at,
                format!(
                    "the compensated entry arc has radii {r_start:.4} and {r_end:.4} mm at \
                     its ends"
                ),
            ));
        }
        self.hold_arc(end, w, new_center, turn, sweep(c, new_center, turn, end));
        Ok(end)
    }

    /// The centre and the signed turns (positive counter-clockwise, as LinuxCNC's `turn`) of
    /// the arc of block `b` from `start` to `p`.
    fn signed_arc(
        &self,
        cw: bool,
        start: [f64; 2],
        p: [f64; 2],
        b: &Block,
        at: &Val,
    ) -> Result<([f64; 2], i64), At> {
        let (center, turns) = self.arc_centre(cw, start, p, b, at)?;
        Ok((center, signed_turn(turns, cw)))
    }

    /// Refuses a tool radius not below the arc's radius with the tool inside the arc.
    fn radius_fits(&self, tool_inside: bool, arc_radius: f64, at: &Val) -> Result<(), At> {
        let r = self.comp.radius;
        if tool_inside && arc_radius <= r {
            return Err(Self::comp_err(
                at,
                format!(
                    "the tool radius {r:.4} mm is not less than the radius {arc_radius:.4} mm \
                     of this arc, on whose inside (concave side) the tool is"
                ),
            ));
        }
        Ok(())
    }

    /// A later arc to `p`: offset by the radius about its programmed centre; the corner with
    /// the held move decides what happens to that.
    fn arc_next(
        &mut self,
        cw: bool,
        p: [f64; 2],
        w: f64,
        side: Side,
        b: &Block,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let plane = self.plane;
        let op = plane.project(self.comp.program);
        let c = plane.project(self.pos);
        let (center, turn) = self.signed_arc(cw, op, p, b, at)?;
        let r = self.comp.radius;
        let small = CORNER_TOLERANCE_RAD;
        let arc_radius = dist(center, p);
        let theta = angle(op, c)
            + match side {
                Side::Left => -FRAC_PI_2,
                Side::Right => FRAC_PI_2,
            };
        let mut delta = angle(op, center);
        let alpha = if cw {
            delta + FRAC_PI_2
        } else {
            delta - FRAC_PI_2
        };
        let mut beta = match side {
            Side::Left => theta - alpha,
            Side::Right => alpha - theta,
        };
        if beta > 1.5 * PI {
            beta -= TAU;
        } else if beta < -FRAC_PI_2 {
            beta += TAU;
        }
        let tool_inside = inside(side, turn);
        let gamma = if tool_inside {
            self.radius_fits(true, arc_radius, at)?;
            angle(p, center)
        } else {
            delta += PI;
            angle(center, p)
        };
        let end = add(p, r, dir(gamma));
        let programmed_sweep = sweep(op, center, turn, p);
        let concave =
            beta < -small || beta > PI + small || ((beta - PI).abs() < small && !tool_inside);
        if concave {
            let corner = match self.held_arc() {
                None => {
                    let across = arc_radius * (beta - FRAC_PI_2).sin();
                    let (reach, toward) = if tool_inside {
                        (arc_radius - r, across + r)
                    } else {
                        (arc_radius + r, across - r)
                    };
                    let l = toward / reach;
                    if !(-1.0..=1.0).contains(&l) {
                        return Err(Self::comp_err(
                            at,
                            "this arc in a concave corner cannot be reached by the tool \
                             without gouging"
                                .into(),
                        ));
                    }
                    let a = match (tool_inside, turn > 0) {
                        (true, true) => theta + l.asin(),
                        (true, false) => theta - l.asin(),
                        (false, true) => theta + PI - l.asin(),
                        (false, false) => theta + PI + l.asin(),
                    };
                    add(center, reach, dir(a))
                }
                Some(prev) => Self::arc_then_arc(&prev, center, arc_radius, turn, side, r, at)?,
            };
            self.move_end_and_flush(corner, at)?;
        } else if beta > small {
            // Convex: an arc of the tool radius about the programmed corner first.
            let mid = add(op, r, dir(delta));
            self.comp_dequeue();
            let corner_turn = if side == Side::Left { -1 } else { 1 };
            let cw_now = self.pos[plane.axes()[2]];
            self.hold_arc(mid, cw_now, op, corner_turn, 0.0);
            self.comp_dequeue();
            self.comp.endpoint = Some(mid);
        } else {
            self.comp_dequeue();
            self.comp.endpoint = Some(c);
        }
        self.hold_arc(end, w, center, turn, programmed_sweep);
        Ok(end)
    }

    /// Where the offset of an arc (`center`, `radius`, `turn`) meets the held compensated
    /// arc `prev` in a concave corner.
    fn arc_then_arc(
        prev: &HeldArc,
        center: [f64; 2],
        radius: f64,
        turn: i64,
        side: Side,
        r: f64,
        at: &Val,
    ) -> Result<[f64; 2], At> {
        let old = dist(prev.center, prev.end);
        let new = if inside(side, turn) {
            radius - r
        } else {
            radius + r
        };
        let apart = dist(prev.center, center);
        if old == 0.0 || apart == 0.0 {
            return Err(Self::comp_err(
                at,
                "an arc after an arc with the same centre in a concave corner".into(),
            ));
        }
        let a = (old * old + apart * apart - new * new) / (2.0 * old * apart);
        if !(-1.0..=1.0).contains(&a) {
            return Err(Self::comp_err(
                at,
                "this arc after an arc makes a corner the tool cannot fit in without gouging"
                    .into(),
            ));
        }
        let pullback = a.acos();
        let towards = angle(prev.center, center);
        let d = if inside(side, prev.turn) == (turn > 0) {
            towards + pullback
        } else {
            towards - pullback
        };
        Ok(add(prev.center, old, dir(d)))
    }
}
