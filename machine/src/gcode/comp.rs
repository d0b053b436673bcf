//! Cutter radius compensation (G40, G41/G42 with D, G41.1/G42.1), following LinuxCNC's rules.
//!
//! A compensated move can only be emitted once the next move is known: the corner between them
//! decides whether the move ends where it was aimed (convex corner: a corner arc about the
//! programmed point follows), or earlier (concave corner: the move is trimmed to where the two
//! offset paths cross). So the last compensated move, and every action that follows it until
//! the next move in the plane (Z-only moves, spindle, coolant...), waits in a small fixed queue
//! ([`PENDING`]); the next move moves the end point of what waits there and releases it.
//!
//! All geometry is in the compensation plane's two axes `(u, v)`: X, Y in G17 and Z, X in G18
//! (as `interp.rs`'s `arc_axes`), machine nanometres, integer vector arithmetic with `i128`
//! intermediates; angles only for LinuxCNC's 0.01 rad corner tolerance (the core's CORDIC).
//! The entry move, the convex corner arcs, the trimming of concave corners (line-line,
//! line-arc, arc-line, arc-arc) and the gouge checks are those of LinuxCNC's `rs274`
//! (see tests/golden/rs274/README.md); a compensated program is checked against it by the
//! golden tests. One deliberate difference: compensation must start with a straight move
//! (Fanuc), where LinuxCNC also accepts an arc.

use heapless::Deque;

use super::error::ErrorCode;
use super::geometry::{self, div_round, isqrt};
use crate::canon::{Action, ArcDir, Canon, Plane};
// i128 products out of line (a dozen here; each is a long inline expansion on the Cortex-M4).
use crate::arith::mul_i128 as mul;
use crate::units::{Nm, Pos};

/// Actions that can wait for the next compensated move (the move itself and what follows it).
pub(crate) const PENDING: usize = 6;

/// LinuxCNC's tolerance for "no corner" and for concave corners: 0.05 rad in 2⁻⁴⁸ rad
/// (`TOLERANCE_CONCAVE_CORNER`; a comment in its source says 0.01, the value is 0.05). A line
/// turning 178° into an arc is thus a 182° turn away from the tool (convex, a corner arc), not
/// a concave corner (tests/golden/rs274/143-comp-g42-line-turning-178-into-arc).
const SMALL: i64 = 14_073_748_835_533;
/// LinuxCNC's allowance for a trimmed arc growing instead of shrinking (it compares the sweep
/// in radians with 0.0254 in mm programs and 0.001 in inch programs).
const SWEEP_GROWTH_MM: i64 = 7_149_464_408_451;
const SWEEP_GROWTH_INCH: i64 = 281_474_976_711;

/// The side of the programmed path the tool runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// G41: left of the path, looking along the motion.
    Left,
    /// G42: right of the path.
    Right,
}

/// Compensation mode (G-code group 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// G40.
    Off,
    /// G41/G42 with the tool radius in nm (0: on, but the path is not changed).
    On {
        side: Side,
        radius: Nm,
        /// The next move in the plane is the entry move.
        entry: bool,
    },
}

/// One waiting action and what LinuxCNC's gouge check needs of it.
#[derive(Clone, Copy, Debug)]
struct Held {
    canon: Canon,
    /// Straight moves: the direction the end point may move along without reversing the
    /// move (`(0, 0)`: no check).
    dir: (i64, i64),
    /// Arcs: the sweep as emitted (2⁻⁴⁸ rad; 0 = a corner arc, never checked).
    sweep: i64,
}

/// Cutter compensation state and its queue of waiting actions.
#[derive(Clone, Debug)]
pub struct Comp {
    mode: Mode,
    plane: Plane,
    /// Programmed (uncompensated) end of the last compensated move, machine nm.
    programmed: Pos,
    /// The compensated tool position at the end of the last compensated move.
    tool: Pos,
    held: Deque<Held, PENDING>,
    /// Where the waiting moves start (LinuxCNC's `set_endpoint`), if known.
    start: Option<(Nm, Nm)>,
    /// The first move after G40 with compensation in effect must be straight.
    arc_not_allowed: bool,
    inch: bool,
    /// While the interpreter computes a compensated block's programmed move, its motion
    /// action is caught here instead of being queued.
    capture: Capture,
}

/// Whether a block's programmed move is being caught (see [`Comp::catch`]).
#[derive(Clone, Copy, Debug)]
enum Capture {
    Idle,
    Waiting,
    Caught(Canon),
}

/// Plane axes (first, second) of the compensation planes.
fn axes(plane: Plane) -> (usize, usize) {
    match plane {
        Plane::ZX => (2, 0),
        _ => (0, 1),
    }
}

// Out of line, as `with_uv`: inlined into each of their callers in this file they cost 1,176 B
// of F411 flash (measured; `sub` and `add` out of line cost more than they save).
#[inline(never)]
fn uv(p: &Pos, plane: Plane) -> (Nm, Nm) {
    let (a, b) = axes(plane);
    (p[a], p[b])
}

#[inline(never)]
fn with_uv(mut p: Pos, plane: Plane, q: (Nm, Nm)) -> Pos {
    let (a, b) = axes(plane);
    p[a] = q.0;
    p[b] = q.1;
    p
}

fn sub(a: (Nm, Nm), b: (Nm, Nm)) -> (i128, i128) {
    ((a.0 - b.0) as i128, (a.1 - b.1) as i128)
}

fn add(a: (Nm, Nm), d: (i128, i128)) -> (Nm, Nm) {
    ((a.0 as i128 + d.0) as Nm, (a.1 as i128 + d.1) as Nm)
}

// Out of line: i128 products are long on the Cortex-M4 and these have many callers.
#[inline(never)]
fn cross(a: (i128, i128), b: (i128, i128)) -> i128 {
    a.0 * b.1 - a.1 * b.0
}

// Out of line: i128 products are long on the Cortex-M4 and these have many callers.
#[inline(never)]
fn dot(a: (i128, i128), b: (i128, i128)) -> i128 {
    a.0 * b.0 + a.1 * b.1
}

fn bits(v: u128) -> u32 {
    128 - v.leading_zeros()
}

/// `v` scaled to length `len` (rounded to nm), with extra bits so short vectors keep their
/// direction exactly enough.
fn scale_to(v: (i128, i128), len: i128) -> (i128, i128) {
    let s = dot(v, v) as u128;
    if s == 0 {
        return (0, 0);
    }
    let big = v.0.unsigned_abs().max(v.1.unsigned_abs()) * len.unsigned_abs().max(1);
    let k = ((125 - bits(s) as i32) / 2)
        .min(125 - bits(big) as i32)
        .max(0) as u32;
    let norm = isqrt(s << (2 * k)) as i128;
    (
        div_round(mul(len, v.0) << k, norm),
        div_round(mul(len, v.1) << k, norm),
    )
}

/// Length of a vector, rounded to nm.
// Out of line: i128 products are long on the Cortex-M4 and these have many callers.
#[inline(never)]
fn length(v: (i128, i128)) -> i128 {
    geometry::isqrt_round(dot(v, v) as u128) as i128
}

/// The unit normal towards `side` of direction `d`, times `r`.
fn side_normal(d: (i128, i128), side: Side, r: Nm) -> (i128, i128) {
    let n = match side {
        Side::Left => (-d.1, d.0),
        Side::Right => (d.1, -d.0),
    };
    scale_to(n, r as i128)
}

/// Where the line `a + t·dir` meets the circle (`center`, `radius`): the crossing nearest `a`.
fn line_circle(a: (Nm, Nm), dir: (i128, i128), center: (Nm, Nm), radius: i128) -> Option<(Nm, Nm)> {
    let w = sub(a, center);
    let len = length(dir);
    if len == 0 {
        return None;
    }
    // Signed distance of the centre's foot along the line, and the line's distance from it.
    let along = div_round(dot(w, dir), len);
    let off = div_round(cross(w, dir), len);
    let h2 = mul(radius, radius) - mul(off, off);
    if h2 < 0 {
        return None;
    }
    let h = geometry::isqrt_round(h2 as u128) as i128;
    let t = if (-along - h).abs() < (-along + h).abs() {
        -along - h
    } else {
        -along + h
    };
    Some(add(a, scale_to(dir, t)))
}

/// The crossing of two circles nearest `near`.
fn circle_circle(
    c1: (Nm, Nm),
    r1: i128,
    c2: (Nm, Nm),
    r2: i128,
    near: (Nm, Nm),
) -> Option<(Nm, Nm)> {
    let d = sub(c2, c1);
    let d2 = dot(d, d);
    if d2 == 0 {
        return None;
    }
    let dl = length(d);
    let r1_sq = mul(r1, r1);
    let a = div_round(r1_sq - mul(r2, r2) + d2, 2 * dl);
    let h2 = r1_sq - mul(a, a);
    if h2 < 0 {
        return None;
    }
    let h = geometry::isqrt_round(h2 as u128) as i128;
    let base = add(c1, scale_to(d, a));
    let perp = scale_to((-d.1, d.0), h);
    let p1 = add(base, perp);
    let p2 = add(base, (-perp.0, -perp.1));
    let dist = |p: (Nm, Nm)| {
        let v = sub(p, near);
        dot(v, v)
    };
    Some(if dist(p1) <= dist(p2) { p1 } else { p2 })
}

/// Signed turn from direction `a` to direction `b` (2⁻⁴⁸ rad, left turns positive).
fn turn(a: (i128, i128), b: (i128, i128)) -> i64 {
    let scale = |v: (i128, i128)| scale_to(v, 1 << 40);
    let (a, b) = (scale(a), scale(b));
    geometry::atan2(cross(a, b), dot(a, b))
}

/// Whether the tool runs inside an arc of this direction.
fn inside(side: Side, dir: ArcDir) -> bool {
    matches!(
        (side, dir),
        (Side::Left, ArcDir::Ccw) | (Side::Right, ArcDir::Cw)
    )
}

/// A waiting arc in the plane: (centre, end, direction).
type HeldArc = ((Nm, Nm), (Nm, Nm), ArcDir);

/// A compensated move after the entry move, as [`Comp::straight`] and [`Comp::arc`] take it: the
/// block, its programmed end `to` (`p` in the plane), the programmed start `op` and the tool's
/// place `c` in the plane, the side and the tool radius `r`.
#[derive(Clone, Copy)]
struct Next {
    canon: Canon,
    to: Pos,
    p: (Nm, Nm),
    op: (Nm, Nm),
    c: (Nm, Nm),
    side: Side,
    r: Nm,
}

/// The programmed move the interpreter computed, in the plane.
enum Programmed {
    Straight { rapid: bool },
    Arc { center: (Nm, Nm), dir: ArcDir },
}

impl Default for Comp {
    fn default() -> Self {
        Comp::new()
    }
}

impl Comp {
    /// Compensation off, nothing waiting.
    pub const fn new() -> Self {
        Comp {
            mode: Mode::Off,
            plane: Plane::XY,
            programmed: [0; crate::units::MAX_AXES],
            tool: [0; crate::units::MAX_AXES],
            held: Deque::new(),
            start: None,
            arc_not_allowed: false,
            inch: false,
            capture: Capture::Idle,
        }
    }

    /// Starts catching the next motion action (the programmed move of a compensated block).
    pub(crate) fn start_catching(&mut self) {
        self.capture = Capture::Waiting;
    }

    /// Takes `canon` if a programmed move is being caught; false if it must be queued.
    pub fn catch(&mut self, canon: Canon) -> bool {
        match self.capture {
            Capture::Waiting => {
                self.capture = Capture::Caught(canon);
                true
            }
            _ => false,
        }
    }

    /// The caught programmed move, if the block made one; catching ends.
    pub(crate) fn caught(&mut self) -> Option<Canon> {
        let c = match self.capture {
            Capture::Caught(c) => Some(c),
            _ => None,
        };
        self.capture = Capture::Idle;
        c
    }

    /// The mode in force.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// True when G41/G42 is in force (whatever the radius).
    pub(crate) fn is_on(&self) -> bool {
        self.mode != Mode::Off
    }

    /// True when nothing here differs from [`Comp::new`].
    pub(crate) fn is_idle(&self) -> bool {
        self.mode == Mode::Off && self.held.is_empty() && !self.arc_not_allowed
    }

    /// True while actions wait for the next move (every action goes through [`Comp::hold`]).
    pub fn holds(&self) -> bool {
        !self.held.is_empty()
    }

    /// True when moves are being offset: on, radius above zero, entry move made.
    fn compensating(&self) -> bool {
        matches!(self.mode, Mode::On { radius, entry: false, .. } if radius > 0)
    }

    /// The point relative moves and missing axis words start from: the programmed end of the
    /// last compensated move instead of the tool position (LinuxCNC's `find_ends`).
    pub(crate) fn program_base(&self, position: Pos) -> Pos {
        if self.compensating() {
            with_uv(position, self.plane, uv(&self.programmed, self.plane))
        } else {
            position
        }
    }

    /// G41/G42 (radius = half the diameter; negative swaps the side, as LinuxCNC).
    pub(crate) fn turn_on(
        &mut self,
        side: Side,
        radius: Nm,
        plane: Plane,
    ) -> Result<(), ErrorCode> {
        if plane == Plane::YZ {
            return Err(ErrorCode::CompPlane);
        }
        if self.is_on() {
            return Err(ErrorCode::CompAlreadyOn);
        }
        let side = match (radius < 0, side) {
            (true, Side::Left) => Side::Right,
            (true, Side::Right) => Side::Left,
            (false, s) => s,
        };
        self.mode = Mode::On {
            side,
            radius: radius.abs(),
            entry: true,
        };
        self.plane = plane;
        Ok(())
    }

    /// G40: releases what waits (the last move ends where it was aimed). Returns the point the
    /// interpreter continues from in the plane (the programmed end, as LinuxCNC), if it moved.
    pub(crate) fn turn_off(
        &mut self,
        out: &mut dyn FnMut(Canon),
    ) -> Result<Option<Pos>, ErrorCode> {
        let mut back = None;
        if self.compensating() {
            let tool = uv(&self.tool, self.plane);
            self.move_end_and_release(tool, out)?;
            back = Some(self.programmed);
            self.arc_not_allowed = true;
        }
        self.mode = Mode::Off;
        Ok(back)
    }

    /// A program stop (M0, M1, M2, M30) releases what waits, as LinuxCNC's `convert_stop`.
    pub fn release(&mut self, out: &mut dyn FnMut(Canon)) -> Result<(), ErrorCode> {
        if self.held.is_empty() {
            return Ok(());
        }
        let tool = uv(&self.tool, self.plane);
        self.move_end_and_release(tool, out)
    }

    /// Ends LinuxCNC's state at M2/M30: compensation off (after [`Comp::release`]).
    pub fn reset(&mut self) {
        *self = Comp::new();
    }

    /// Keeps a non-motion action behind the waiting move.
    pub fn hold(&mut self, canon: Canon) -> Result<(), ErrorCode> {
        self.held
            .push_back(Held {
                canon,
                dir: (0, 0),
                sweep: 0,
            })
            .map_err(|_| ErrorCode::CompLookAheadFull)
    }

    /// A straight move was made without compensation: the next arc is allowed again.
    pub(crate) fn straight_done(&mut self) {
        self.arc_not_allowed = false;
    }

    /// An arc is about to be made: refused right after G40 and as the entry move.
    pub(crate) fn check_arc(&self) -> Result<(), ErrorCode> {
        if self.arc_not_allowed {
            return Err(ErrorCode::CompArcAfterExit);
        }
        if matches!(self.mode, Mode::On { radius, entry: true, .. } if radius > 0) {
            return Err(ErrorCode::CutterCompNotSupported);
        }
        Ok(())
    }

    /// True when this move must go through [`Comp::motion`].
    pub fn applies(&self) -> bool {
        matches!(self.mode, Mode::On { radius, .. } if radius > 0)
    }

    /// Compensates a programmed move (`canon`: a rapid, feed or arc from `from`, the tool
    /// position, in machine nm; for all but the entry move `from` is replaced by the
    /// programmed end of the last move). Returns the compensated tool position after it.
    #[inline(never)]
    pub fn motion(
        &mut self,
        canon: Canon,
        from: Pos,
        inch: bool,
        out: &mut dyn FnMut(Canon),
    ) -> Result<Pos, ErrorCode> {
        let Mode::On {
            side,
            radius: r,
            entry,
        } = self.mode
        else {
            return Ok(from);
        };
        self.inch = inch;
        let plane = self.plane;
        let (to, programmed) = match canon.action {
            Action::Rapid { to } => (to, Programmed::Straight { rapid: true }),
            Action::Feed { to, .. } => (to, Programmed::Straight { rapid: false }),
            Action::Arc {
                to, center, dir, ..
            } => {
                let (a, b) = axes(plane);
                (
                    to,
                    Programmed::Arc {
                        center: (center[a], center[b]),
                        dir,
                    },
                )
            }
            _ => return Ok(from),
        };
        let p = uv(&to, plane);
        let line = canon.line;
        if entry {
            // The entry move: straight from the tool to the programmed end, ending with the
            // tool beside it, square to the move (LinuxCNC `convert_straight_comp1`).
            let c = uv(&from, plane);
            let d = sub(p, c);
            if length(d) <= r as i128 {
                return Err(ErrorCode::CompEntryTooShort);
            }
            let n = side_normal(d, side, r);
            let end = with_uv(to, plane, add(p, n));
            self.push_held(
                Canon {
                    line,
                    action: retarget(canon.action, end),
                },
                n,
                0,
            )?;
            self.start = Some(c);
            self.mode = Mode::On {
                side,
                radius: r,
                entry: false,
            };
            self.programmed = to;
            self.tool = end;
            return Ok(end);
        }
        let op = uv(&self.programmed, plane);
        let c = uv(&self.tool, plane);
        let next = Next {
            canon,
            to,
            p,
            op,
            c,
            side,
            r,
        };
        // `straight` and `arc` leave the compensated tool position in `self.tool`.
        match programmed {
            Programmed::Straight { rapid } => self.straight(next, rapid, out)?,
            Programmed::Arc { center, dir } => self.arc(next, center, dir, out)?,
        }
        self.programmed = to;
        Ok(self.tool)
    }

    /// A straight move after the entry move (LinuxCNC `convert_straight_comp2`).
    #[inline(never)]
    fn straight(
        &mut self,
        next: Next,
        rapid: bool,
        out: &mut dyn FnMut(Canon),
    ) -> Result<(), ErrorCode> {
        let (canon, to, p, op) = (next.canon, next.to, next.p, next.op);
        let (c, side, r, plane) = (next.c, next.side, next.r, self.plane);
        let line = canon.line;
        if p == op {
            // No motion in the plane: the tool stays beside the programmed point.
            let end = with_uv(to, plane, c);
            self.push_held(
                Canon {
                    line,
                    action: retarget(canon.action, end),
                },
                (0, 0),
                0,
            )?;
            self.tool = end;
            return Ok(());
        }
        let b = sub(p, op);
        let n_new = side_normal(b, side, r);
        let end = with_uv(to, plane, add(p, n_new));
        let mid = add(op, n_new);
        let (d, beta) = self.corner(op, c, b, side);
        let front_arc_turning_away = match self.front_arc() {
            Some((_, _, dir)) => !inside(side, dir),
            None => false,
        };
        let pi = geometry::PI;
        let concave =
            beta < -SMALL || beta > pi + SMALL || (beta > pi - SMALL && front_arc_turning_away);
        if !concave && beta > SMALL {
            // Convex corner: around it on an arc about the programmed corner (a rapid goes
            // straight to the arc's end).
            self.move_end_and_release(c, out)?;
            let corner = with_uv(self.tool, plane, mid);
            let corner = with_axes_from(corner, to, plane);
            let action = if rapid {
                Action::Rapid { to: corner }
            } else {
                corner_arc(canon.action, corner, op, self.tool, plane, side)
            };
            out(Canon { line, action });
            self.start = Some(mid);
        } else if concave {
            let trim = match self.front_arc() {
                None => {
                    // Line to line: back along the last move to where the offset lines cross.
                    let dl = length(d);
                    let denom = mul(dl, length(b)) + dot(d, b);
                    if denom <= 0 {
                        return Err(ErrorCode::CompGouge);
                    }
                    let s = if side == Side::Left { 1 } else { -1 };
                    let retreat = div_round(mul(s * r as i128, cross(d, b)), denom);
                    add(c, scale_to(d, -retreat))
                }
                Some((center, end, _)) => {
                    // Arc to line: where the offset line meets the last (offset) arc.
                    let radius = length(sub(end, center));
                    line_circle(add(op, n_new), b, center, radius).ok_or(ErrorCode::CompGouge)?
                }
            };
            self.move_end_and_release(trim, out)?;
        } else {
            self.release_as_is(out);
            self.start = Some(c);
        }
        self.push_held(
            Canon {
                line,
                action: retarget(canon.action, end),
            },
            b,
            0,
        )?;
        self.tool = end;
        Ok(())
    }

    /// An arc after the entry move (LinuxCNC `convert_arc_comp2`).
    #[inline(never)]
    fn arc(
        &mut self,
        next: Next,
        center: (Nm, Nm),
        dir: ArcDir,
        out: &mut dyn FnMut(Canon),
    ) -> Result<(), ErrorCode> {
        let (canon, to, p, op) = (next.canon, next.to, next.p, next.op);
        let (c, side, r, plane) = (next.c, next.side, next.r, self.plane);
        let line = canon.line;
        let arc_radius = length(sub(p, center));
        let to_center = sub(center, op);
        // Tangent at the start of the programmed arc.
        let b = match dir {
            ArcDir::Ccw => (to_center.1, -to_center.0),
            ArcDir::Cw => (-to_center.1, to_center.0),
        };
        let is_inside = inside(side, dir);
        if is_inside && arc_radius <= r as i128 {
            return Err(ErrorCode::CompArcTooSmall);
        }
        let out_of_center = sub(p, center);
        let toward = if is_inside {
            (-out_of_center.0, -out_of_center.1)
        } else {
            out_of_center
        };
        let new_end = add(p, scale_to(toward, r as i128));
        let end = with_uv(to, plane, new_end);
        let (d, beta) = self.corner(op, c, b, side);
        let pi = geometry::PI;
        let concave =
            beta < -SMALL || beta > pi + SMALL || ((beta - pi).abs() < SMALL && !is_inside);
        let new_radius = if is_inside {
            arc_radius - r as i128
        } else {
            arc_radius + r as i128
        };
        let mut arc_start = c;
        if concave {
            let trim = match self.front_arc() {
                None => {
                    // Line to arc: where the last line's parallel offset through the tool meets
                    // the offset arc. After the entry move that is the programmed entry line's
                    // parallel, not the tool's actual (slanted) entry line (LinuxCNC's
                    // `convert_arc_comp2` uses the direction square to the tool's offset;
                    // tests/golden/rs274/142-comp-entry-then-concave-arc).
                    line_circle(c, d, center, new_radius).ok_or(ErrorCode::CompGouge)?
                }
                Some((old_center, old_end, _)) => {
                    if old_center == center {
                        return Err(ErrorCode::CompGouge);
                    }
                    let old_radius = length(sub(old_end, old_center));
                    circle_circle(old_center, old_radius, center, new_radius, c)
                        .ok_or(ErrorCode::CompGouge)?
                }
            };
            self.move_end_and_release(trim, out)?;
            arc_start = trim;
        } else if beta > SMALL {
            // Convex corner: a corner arc about the programmed point first.
            self.release_as_is(out);
            let away = if is_inside {
                to_center
            } else {
                (-to_center.0, -to_center.1)
            };
            let mid = add(op, scale_to(away, r as i128));
            let corner = with_uv(self.tool, plane, mid);
            let corner = with_axes_from(corner, to, plane);
            out(Canon {
                line,
                action: corner_arc(canon.action, corner, op, self.tool, plane, side),
            });
            arc_start = mid;
        } else {
            self.release_as_is(out);
        }
        self.start = Some(arc_start);
        let action = match canon.action {
            Action::Arc {
                center: c3,
                plane,
                dir,
                turns,
                feed,
                ..
            } => Action::Arc {
                to: end,
                center: c3,
                plane,
                dir,
                turns,
                feed,
            },
            a => a,
        };
        let sweep = geometry::sweep(arc_start, new_end, center, dir == ArcDir::Ccw, 1);
        self.push_held(Canon { line, action }, (0, 0), sweep)?;
        self.tool = end;
        Ok(())
    }

    /// The last move's direction `d` at its end (from the tool's offset beside the programmed
    /// point) and LinuxCNC's corner angle β towards the new direction `b`: positive = the path
    /// turns away from the tool (convex), in [−π/2, 3π/2).
    fn corner(
        &self,
        op: (Nm, Nm),
        c: (Nm, Nm),
        b: (i128, i128),
        side: Side,
    ) -> ((i128, i128), i64) {
        let n = sub(c, op);
        let d = match side {
            Side::Left => (n.1, -n.0),
            Side::Right => (-n.1, n.0),
        };
        let t = turn(d, b);
        let mut beta = match side {
            Side::Left => -t,
            Side::Right => t,
        };
        if beta < -geometry::PI / 2 {
            beta += 2 * geometry::PI;
        }
        (d, beta)
    }

    /// The waiting arc at the front of the queue: (centre, end, direction).
    fn front_arc(&self) -> Option<HeldArc> {
        match self.held.front()?.canon.action {
            Action::Arc {
                to, center, dir, ..
            } => {
                let (a, b) = axes(self.plane);
                Some(((center[a], center[b]), uv(&to, self.plane), dir))
            }
            _ => None,
        }
    }

    fn push_held(&mut self, canon: Canon, dir: (i128, i128), sweep: i128) -> Result<(), ErrorCode> {
        let dir = (dir.0 as i64, dir.1 as i64);
        let sweep = sweep.min(i64::MAX as i128) as i64;
        self.held
            .push_back(Held { canon, dir, sweep })
            .map_err(|_| ErrorCode::CompLookAheadFull)
    }

    fn release_as_is(&mut self, out: &mut dyn FnMut(Canon)) {
        while let Some(h) = self.held.pop_front() {
            out(h.canon);
        }
        self.start = None;
    }

    /// Moves the end of every waiting move to `q` in the plane and releases them all, after
    /// LinuxCNC's gouge checks (a straight move must not reverse, an arc must not grow).
    fn move_end_and_release(
        &mut self,
        q: (Nm, Nm),
        out: &mut dyn FnMut(Canon),
    ) -> Result<(), ErrorCode> {
        let plane = self.plane;
        let growth = if self.inch {
            SWEEP_GROWTH_INCH
        } else {
            SWEEP_GROWTH_MM
        } as i128;
        for h in self.held.iter() {
            match h.canon.action {
                Action::Rapid { .. } | Action::Feed { .. } => {
                    if let Some(s) = self.start {
                        let dir = (h.dir.0 as i128, h.dir.1 as i128);
                        if dot(dir, sub(q, s)) < 0 {
                            return Err(ErrorCode::CompGouge);
                        }
                    }
                }
                Action::Arc { center, dir, .. } => {
                    if let (Some(s), true) = (self.start, h.sweep != 0) {
                        let (a, b) = axes(plane);
                        let sweep =
                            geometry::sweep(s, q, (center[a], center[b]), dir == ArcDir::Ccw, 1);
                        if sweep > h.sweep as i128 + growth {
                            return Err(ErrorCode::CompGouge);
                        }
                    }
                }
                _ => {}
            }
        }
        while let Some(mut h) = self.held.pop_front() {
            h.canon.action = match h.canon.action {
                Action::Rapid { to } => Action::Rapid {
                    to: with_uv(to, plane, q),
                },
                Action::Feed { to, feed } => Action::Feed {
                    to: with_uv(to, plane, q),
                    feed,
                },
                Action::Arc {
                    to,
                    center,
                    plane: pl,
                    dir,
                    turns,
                    feed,
                } => Action::Arc {
                    to: with_uv(to, plane, q),
                    center,
                    plane: pl,
                    dir,
                    turns,
                    feed,
                },
                a => a,
            };
            out(h.canon);
        }
        self.tool = with_uv(self.tool, plane, q);
        self.start = Some(q);
        Ok(())
    }
}

/// A move's action with a new end point.
fn retarget(action: Action, to: Pos) -> Action {
    match action {
        Action::Rapid { .. } => Action::Rapid { to },
        Action::Feed { feed, .. } => Action::Feed { to, feed },
        Action::Arc {
            center,
            plane,
            dir,
            turns,
            feed,
            ..
        } => Action::Arc {
            to,
            center,
            plane,
            dir,
            turns,
            feed,
        },
        a => a,
    }
}

/// The corner arc keeps the tool where it is on the axes outside the plane except the rotary
/// ones, which move on it (LinuxCNC puts a block's rotary motion on its corner arc).
fn with_axes_from(mut corner: Pos, to: Pos, _plane: Plane) -> Pos {
    corner[3..].copy_from_slice(&to[3..]);
    corner
}

/// The arc around a convex corner: about the programmed corner `op`, clockwise with the tool
/// on the left, at the move's feed.
fn corner_arc(
    action: Action,
    to: Pos,
    op: (Nm, Nm),
    from: Pos,
    plane: Plane,
    side: Side,
) -> Action {
    let feed = match action {
        Action::Feed { feed, .. } | Action::Arc { feed, .. } => feed,
        _ => 0,
    };
    let (a, b) = axes(plane);
    let normal = 3 - a - b;
    let mut center = [0; 3];
    center[a] = op.0;
    center[b] = op.1;
    center[normal] = from[normal];
    Action::Arc {
        to,
        center,
        plane,
        dir: match side {
            Side::Left => ArcDir::Cw,
            Side::Right => ArcDir::Ccw,
        },
        turns: 1,
        feed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_vectors_keep_their_direction() {
        assert_eq!(scale_to((3, 4), 5_000_000), (3_000_000, 4_000_000));
        assert_eq!(scale_to((1, 1), 1_000_000), (707_107, 707_107));
        assert_eq!(
            scale_to((0, -7), 2_540_000),
            (0, -2_540_000),
            "short vectors scale exactly"
        );
    }

    #[test]
    fn inside_corner_trims_the_entry_move() {
        let mut c = Comp::new();
        c.turn_on(Side::Left, 2_540_000, Plane::XY).unwrap();
        let mut out = heapless::Vec::<Canon, 8>::new();
        let feed = |x: Nm, y: Nm| Canon {
            line: 1,
            action: Action::Feed {
                to: [x, y, 0, 0, 0, 0],
                feed: 1,
            },
        };
        let from = [20_000_000, 20_000_000, 0, 0, 0, 0];
        let tool = c
            .motion(feed(20_000_000, 0), from, false, &mut |k| {
                out.push(k).unwrap();
            })
            .unwrap();
        assert_eq!(tool[..2], [22_540_000, 0]);
        assert!(out.is_empty());
        let base = c.program_base(tool);
        assert_eq!(base[..2], [20_000_000, 0]);
        c.motion(feed(40_000_000, 0), base, false, &mut |k| {
            out.push(k).unwrap();
        })
        .unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].action, feed(22_540_000, 2_540_000).action);
    }

    #[test]
    fn crossings() {
        // Line y = 1 mm across a circle of radius 2 mm about the origin: x = ±√3 mm.
        let q = line_circle((-5_000_000, 1_000_000), (1, 0), (0, 0), 2_000_000).unwrap();
        assert_eq!(q, (-1_732_051, 1_000_000));
        // Circles of radius 5 about (0,0) and (8,0) meet at (4, ±3).
        let q = circle_circle(
            (0, 0),
            5_000_000,
            (8_000_000, 0),
            5_000_000,
            (4_000_000, 2_000_000),
        )
        .unwrap();
        assert_eq!(q, (4_000_000, 3_000_000));
    }
}
