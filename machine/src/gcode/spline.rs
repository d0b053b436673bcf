//! G5 cubic and G5.1 quadratic splines in the XY plane, made into arcs as LinuxCNC's canon
//! layer does (its `NURBS_G5_FEED` and `biarc`): the curve is cut at 4 × (control points)
//! equal steps of its parameter, and each piece becomes a biarc (two tangent arcs) from the
//! piece's start point and tangent to its end point and tangent. A piece whose biarc degenerates
//! (equal tangents, or a biarc too long) is a straight feed, as in LinuxCNC.
//!
//! Integer arithmetic only (i128 intermediates, exact rational parameters), so host and board
//! agree to the bit. Points are in machine nm; tangents are unit vectors scaled by [`UNIT`].
//! One piece is made per [`SplineRun::step`], so a spline needs no more than two action slots
//! at a time (machine/src/gcode/interp/mod.rs, `before_next_line`).

use super::geometry::isqrt_round;
use crate::arith::div_i128;
use crate::canon::{Action, ArcDir, Canon, Plane};
use crate::units::{Nm, Pos};

/// Length of a unit tangent.
const UNIT: i128 = 1 << 24;
/// LinuxCNC's tangent step (`DU` = 10⁻⁵ of the parameter): tangents are the central difference
/// over ±DU, one-sided at the ends.
const DU_DEN: i128 = 100_000;
/// Degree of the curve; [`SplineRun::points`] holds `degree + 1` points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Degree {
    /// G5.1: start, control point, end.
    Quadratic,
    /// G5: start, two control points, end.
    Cubic,
}

/// A spline being made into arcs.
#[derive(Clone, Debug)]
pub(crate) struct SplineRun {
    pub line: u32,
    degree: Degree,
    /// Control points in the plane (machine nm).
    points: [(Nm, Nm); 4],
    /// Pieces made and pieces in all.
    done: u16,
    pieces: u16,
    /// Where the last piece ended, and the curve's tangent there.
    at: (Nm, Nm),
    tangent: (i128, i128),
    /// Everything but X and Y of the moves (Z and the other axes stay).
    base: Pos,
    feed: i64,
    /// LinuxCNC's "no arc" threshold for `den` (10⁻⁶ program units, in nm × UNIT).
    small: i128,
    /// LinuxCNC's longest biarc (`1 / CART_FUZZ` = 10⁸ program units), nm.
    longest: i128,
}

/// `den^deg × P(num / den)` of the curve, per axis (exact: de Casteljau over integers).
fn scaled_point(degree: Degree, p: &[(Nm, Nm); 4], num: i128, den: i128) -> (i128, i128) {
    let (a, b) = (den - num, num);
    let axis = |f: fn(&(Nm, Nm)) -> Nm| -> i128 {
        let v = |i: usize| f(&p[i]) as i128;
        match degree {
            Degree::Quadratic => a * a * v(0) + 2 * a * b * v(1) + b * b * v(2),
            Degree::Cubic => {
                a * a * a * v(0) + 3 * a * a * b * v(1) + 3 * a * b * b * v(2) + b * b * b * v(3)
            }
        }
    };
    (axis(|q| q.0), axis(|q| q.1))
}

/// The point at parameter `num / den`, rounded to nm.
fn point(degree: Degree, p: &[(Nm, Nm); 4], num: i128, den: i128) -> (Nm, Nm) {
    let d = match degree {
        Degree::Quadratic => den * den,
        Degree::Cubic => den * den * den,
    };
    let (x, y) = scaled_point(degree, p, num, den);
    (round_div(x, d) as Nm, round_div(y, d) as Nm)
}

/// The tangent at parameter `num / den` as LinuxCNC takes it: the chord from u − DU to u + DU
/// (clamped to [0, 1]), scaled to [`UNIT`].
fn tangent(degree: Degree, p: &[(Nm, Nm); 4], num: i128, den: i128) -> (i128, i128) {
    let d = den * DU_DEN;
    let lo = (num * DU_DEN - den).max(0);
    let hi = (num * DU_DEN + den).min(d);
    let (x1, y1) = scaled_point(degree, p, lo, d);
    let (x2, y2) = scaled_point(degree, p, hi, d);
    unit((x2 - x1, y2 - y1))
}

/// `n / d` rounded half away from zero.
fn round_div(n: i128, d: i128) -> i128 {
    let (n, d) = if d < 0 { (-n, -d) } else { (n, d) };
    let q = div_i128(n.abs() + d / 2, d);
    if n < 0 {
        -q
    } else {
        q
    }
}

/// `v` scaled to length [`UNIT`] (zero stays zero).
fn unit(v: (i128, i128)) -> (i128, i128) {
    let (mut x, mut y) = v;
    // Keep the squares within u128: both below 2^62 (they keep at least 2^61 of magnitude).
    while x.abs() >= 1 << 62 || y.abs() >= 1 << 62 {
        x >>= 1;
        y >>= 1;
    }
    let len = isqrt_round((x * x) as u128 + (y * y) as u128) as i128;
    if len == 0 {
        return (0, 0);
    }
    (round_div(x * UNIT, len), round_div(y * UNIT, len))
}

impl SplineRun {
    /// A spline from `start` (machine position) through the control points `ctrl` (machine nm
    /// in the XY plane: 1 for G5.1, 2 for G5) to `end`; `inch` picks LinuxCNC's thresholds.
    pub fn new(
        line: u32,
        start: Pos,
        ctrl: &[(Nm, Nm)],
        end: (Nm, Nm),
        feed: i64,
        inch: bool,
    ) -> Self {
        let s = (start[0], start[1]);
        let (degree, points) = match ctrl {
            [c] => (Degree::Quadratic, [s, *c, end, end]),
            [c1, c2, ..] => (Degree::Cubic, [s, *c1, *c2, end]),
            [] => (Degree::Quadratic, [s, s, end, end]),
        };
        let count = match degree {
            Degree::Quadratic => 3,
            Degree::Cubic => 4,
        };
        let unit_nm: i128 = if inch { 25_400_000 } else { 1_000_000 };
        SplineRun {
            line,
            degree,
            points,
            done: 0,
            pieces: 4 * count,
            at: s,
            tangent: tangent(degree, &points, 0, 1),
            base: start,
            feed,
            small: div_i128(unit_nm * UNIT, 1_000_000),
            longest: unit_nm * 100_000_000,
        }
    }

    /// Makes the next piece (one to three actions into `out`); false after the last one.
    pub fn step(&mut self, out: &mut impl FnMut(Canon)) -> bool {
        if self.done >= self.pieces {
            return false;
        }
        self.done += 1;
        let (num, den) = (self.done as i128, self.pieces as i128);
        let end = if self.done == self.pieces {
            self.points[match self.degree {
                Degree::Quadratic => 2,
                Degree::Cubic => 3,
            }]
        } else {
            point(self.degree, &self.points, num, den)
        };
        let t_end = tangent(self.degree, &self.points, num, den);
        self.biarc(self.at, self.tangent, end, t_end, out);
        self.at = end;
        self.tangent = t_end;
        self.done < self.pieces
    }

    /// LinuxCNC's `biarc` from `p0` (tangent `ts`) to `p4` (tangent `te`), r = 1.
    fn biarc(
        &self,
        p0: (Nm, Nm),
        ts: (i128, i128),
        p4: (Nm, Nm),
        te: (i128, i128),
        out: &mut impl FnMut(Canon),
    ) {
        let v = ((p0.0 - p4.0) as i128, (p0.1 - p4.1) as i128);
        if v.0.abs() > 1 << 38 || v.1.abs() > 1 << 38 {
            // A piece longer than 270 m: beyond the products' range, and beyond any machine.
            self.straight(p4, out);
            return;
        }
        let c = v.0 * v.0 + v.1 * v.1;
        let b = 2 * (v.0 * (ts.0 + te.0) + v.1 * (ts.1 + te.1));
        let a = 2 * (ts.0 * te.0 + ts.1 * te.1 - UNIT * UNIT);
        let discr = b * b - 4 * a * c;
        if a >= 0 || discr < 0 {
            // Equal tangents (LinuxCNC: an infinite root, a straight feed) or no biarc (LinuxCNC
            // makes nothing and the next piece starts where this one should have ended; Gantry
            // goes there straight so that the path stays connected).
            self.straight(p4, out);
            return;
        }
        let disq = isqrt_round(discr as u128) as i128;
        // Roots in nm: (−b ∓ √discr) / 2a, with b in nm × UNIT and a in UNIT².
        let beta1 = round_div((-b - disq) * UNIT, 2 * a);
        let beta2 = round_div((-b + disq) * UNIT, 2 * a);
        let beta = beta1.max(beta2);
        if (beta1 > 0 && beta2 > 0) || beta > self.longest || beta <= 0 {
            self.straight(p4, out);
            return;
        }
        // p1 = p0 + β ts, p3 = p4 − β te, p2 = (p1 + p3) / 2 (α = β): in nm × UNIT.
        let p1 = (
            p0.0 as i128 * UNIT + beta * ts.0,
            p0.1 as i128 * UNIT + beta * ts.1,
        );
        let p3 = (
            p4.0 as i128 * UNIT - beta * te.0,
            p4.1 as i128 * UNIT - beta * te.1,
        );
        // The joint, kept to 1/(2·UNIT) nm for the arcs' centres: a nearly straight arc's centre
        // moves by R/L² per nm of its chord.
        let p2 = (p1.0 + p3.0, p1.1 + p3.1);
        let tm = unit((p3.0 - p1.0, p3.1 - p1.1));
        let fine = |p: (Nm, Nm)| (p.0 as i128 * 2 * UNIT, p.1 as i128 * 2 * UNIT);
        self.arc(fine(p0), p2, ts, out);
        self.arc(p2, fine(p4), tm, out);
    }

    /// LinuxCNC's `arc`: from `p0` with tangent `t` to `p1`; a straight feed when the arc is
    /// flat (|den| ≤ 10⁻⁶ program units).
    /// Points are in nm × 2·UNIT.
    fn arc(
        &self,
        p0: (i128, i128),
        p1: (i128, i128),
        t: (i128, i128),
        out: &mut impl FnMut(Canon),
    ) {
        let s = 2 * UNIT;
        let p1_nm = (round_div(p1.0, s) as Nm, round_div(p1.1, s) as Nm);
        // The chord in nm × 2^-8 (enough for the centre, and its squares stay within i128).
        let fine = s >> 8;
        let (x, y) = (round_div(p1.0 - p0.0, fine), round_div(p1.1 - p0.1, fine));
        // den in nm × 2^-8 × UNIT.
        let den = 2 * (y * t.0 - x * t.1);
        if den.abs() <= self.small << 8 {
            self.straight(p1_nm, out);
            return;
        }
        // r = −(x² + y²) / den; the centre is p0 + r (t.y, −t.x), in nm × 2^-8.
        let q = x * x + y * y;
        let (ox, oy) = (round_div(-q * t.1, den), round_div(q * t.0, den));
        let center = (
            round_div(p0.0 + ox * fine, s) as Nm,
            round_div(p0.1 + oy * fine, s) as Nm,
        );
        let p1 = p1_nm;
        let mut to = self.base;
        (to[0], to[1]) = p1;
        out(Canon {
            line: self.line,
            action: Action::Arc {
                to,
                center: [center.0, center.1, self.base[2]],
                plane: Plane::XY,
                dir: if den > 0 { ArcDir::Ccw } else { ArcDir::Cw },
                turns: 1,
                feed: self.feed,
            },
        });
    }

    fn straight(&self, p: (Nm, Nm), out: &mut impl FnMut(Canon)) {
        let mut to = self.base;
        (to[0], to[1]) = p;
        out(Canon {
            line: self.line,
            action: Action::Feed {
                to,
                feed: self.feed,
            },
        });
    }
}
