//! Move geometry for drawing: arcs as cubic Bézier pieces built from their centre and ends, path
//! lengths and the job's exact extents.
//!
//! Arcs are cut into pieces of at most 45° and each piece becomes one cubic Bézier whose control
//! points lie in machine space. Every view is a linear projection, so projecting the control points
//! projects the curve itself: a circle seen at an angle becomes a smooth ellipse, not a polygon.

use super::model::{ArcGeom, Box3, MoveKind, PreviewMove, P3};
use gantry_machine::canon::Plane;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, TAU};

/// One cubic Bézier piece: start, two control points, end (machine space, mm).
pub(crate) type Cubic = [P3; 4];

/// Plane axes (first, second) and the normal axis, ordered so that CCW turns first → second.
pub(crate) fn plane_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

/// An arc in polar form around its centre: the radius and the normal-axis value change linearly
/// with the angle, so the curve starts and ends exactly on the move's end points.
struct Polar {
    a: usize,
    b: usize,
    n: usize,
    ca: f64,
    cb: f64,
    start_angle: f64,
    /// Signed sweep, radians (positive = CCW).
    sweep: f64,
    r0: f64,
    r1: f64,
    n0: f64,
    n1: f64,
}

impl Polar {
    fn new(from: P3, to: P3, arc: &ArcGeom) -> Polar {
        let (a, b, n) = plane_axes(arc.plane);
        let (ca, cb) = (arc.center[a], arc.center[b]);
        let start_angle = (from[b] - cb).atan2(from[a] - ca);
        let end_angle = (to[b] - cb).atan2(to[a] - ca);
        let extra = TAU * arc.turns.saturating_sub(1) as f64;
        // Angle from start to end in the arc's direction, in (0, 2π]; equal ends make a full turn.
        let raw = if arc.ccw {
            end_angle - start_angle
        } else {
            start_angle - end_angle
        };
        let mut part = raw.rem_euclid(TAU);
        if part < 1e-9 {
            part = TAU;
        }
        let sweep = if arc.ccw {
            part + extra
        } else {
            -(part + extra)
        };
        Polar {
            a,
            b,
            n,
            ca,
            cb,
            start_angle,
            sweep,
            r0: (from[a] - ca).hypot(from[b] - cb),
            r1: (to[a] - ca).hypot(to[b] - cb),
            n0: from[n],
            n1: to[n],
        }
    }

    /// The point at fraction `t` (0..=1) of the sweep.
    fn at(&self, t: f64) -> P3 {
        let ang = self.start_angle + self.sweep * t;
        let r = self.r0 + (self.r1 - self.r0) * t;
        let mut p = [0.0; 3];
        p[self.a] = self.ca + r * ang.cos();
        p[self.b] = self.cb + r * ang.sin();
        p[self.n] = self.n0 + (self.n1 - self.n0) * t;
        p
    }

    /// Unit tangent direction of the circle (not the helix) at fraction `t`, times the signed sweep.
    fn tangent(&self, t: f64) -> (f64, f64) {
        let ang = self.start_angle + self.sweep * t;
        (-ang.sin(), ang.cos())
    }
}

/// Points along an arc from `from` to `to` for a polyline: the interior points only (the caller
/// has both ends), about one every `step_mm` of the sweep, between `min` and `max` segments.
pub(crate) fn arc_interior(
    from: P3,
    to: P3,
    arc: &ArcGeom,
    step_mm: f64,
    (min, max): (usize, usize),
) -> impl Iterator<Item = P3> {
    let p = Polar::new(from, to, arc);
    let steps = ((p.sweep.abs() * p.r0 / step_mm) as usize).clamp(min, max);
    (1..steps).map(move |i| p.at(i as f64 / steps as f64))
}

/// Cubic Bézier pieces (≤ 45° each) of an arc from `from` to `to`; they start at `from` and end
/// exactly at `to`.
pub fn arc_cubics(from: P3, to: P3, arc: &ArcGeom) -> Vec<Cubic> {
    let p = Polar::new(from, to, arc);
    let pieces = ((p.sweep.abs() / FRAC_PI_4).ceil() as usize).max(1);
    let mut out = Vec::with_capacity(pieces);
    for k in 0..pieces {
        let (t0, t1) = (k as f64 / pieces as f64, (k + 1) as f64 / pieces as f64);
        let d = p.sweep / pieces as f64;
        let h = 4.0 / 3.0 * (d / 4.0).tan();
        let p0 = if k == 0 { from } else { p.at(t0) };
        let p3 = if k + 1 == pieces { to } else { p.at(t1) };
        let (r0, r1) = (p.r0 + (p.r1 - p.r0) * t0, p.r0 + (p.r1 - p.r0) * t1);
        let (u0, u1) = (p.tangent(t0), p.tangent(t1));
        let mut c1 = p0;
        let mut c2 = p3;
        c1[p.a] += h * r0 * u0.0;
        c1[p.b] += h * r0 * u0.1;
        c2[p.a] -= h * r1 * u1.0;
        c2[p.b] -= h * r1 * u1.1;
        // The normal axis moves linearly in the Bézier parameter.
        c1[p.n] = p0[p.n] + (p3[p.n] - p0[p.n]) / 3.0;
        c2[p.n] = p0[p.n] + (p3[p.n] - p0[p.n]) * 2.0 / 3.0;
        out.push([p0, c1, c2, p3]);
    }
    out
}

/// Path length of a move, mm (helices exactly, spirals to within the radius change).
pub(crate) fn length(m: &PreviewMove) -> f64 {
    match &m.kind {
        MoveKind::Rapid | MoveKind::Feed => dist(m.from, m.to),
        MoveKind::Arc(arc) => {
            let p = Polar::new(m.from, m.to, arc);
            let planar = p.sweep.abs() * (p.r0 + p.r1) / 2.0;
            planar.hypot(p.n1 - p.n0)
        }
    }
}

/// Euclidean distance, mm.
pub(crate) fn dist(a: P3, b: P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Adds a move's exact bounding box to `b`: its end points and, for arcs, every point where the
/// arc crosses a plane axis (each quarter turn).
pub(crate) fn extend(b: &mut Box3, m: &PreviewMove) {
    b.add(m.from);
    b.add(m.to);
    if let MoveKind::Arc(arc) = &m.kind {
        let p = Polar::new(m.from, m.to, arc);
        // Quarter-turn angles k·π/2 that lie strictly inside the sweep.
        let (lo, hi) = if p.sweep >= 0.0 {
            (p.start_angle, p.start_angle + p.sweep)
        } else {
            (p.start_angle + p.sweep, p.start_angle)
        };
        let mut k = (lo / FRAC_PI_2).floor() as i64 + 1;
        while (k as f64) * FRAC_PI_2 < hi {
            let ang = k as f64 * FRAC_PI_2;
            b.add(p.at((ang - p.start_angle) / p.sweep));
            k += 1;
        }
    }
}

/// The bounding box of all moves (empty if there are none).
#[cfg(test)]
pub(crate) fn extents<'a>(moves: impl IntoIterator<Item = &'a PreviewMove>) -> Box3 {
    let mut b = Box3::EMPTY;
    for m in moves {
        extend(&mut b, m);
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(from: P3, to: P3, center: P3, ccw: bool, turns: u32) -> PreviewMove {
        PreviewMove {
            line: 1,
            kind: MoveKind::Arc(ArcGeom {
                center,
                plane: Plane::XY,
                ccw,
                turns,
            }),
            from,
            to,
            speed_mm_min: None,
        }
    }

    fn cubic_at(c: &Cubic, t: f64) -> P3 {
        let mut p = [0.0; 3];
        let s = 1.0 - t;
        for (i, v) in p.iter_mut().enumerate() {
            *v = s * s * s * c[0][i]
                + 3.0 * s * s * t * c[1][i]
                + 3.0 * s * t * t * c[2][i]
                + t * t * t * c[3][i];
        }
        p
    }

    #[test]
    fn quarter_circle_is_smooth_and_ends_exactly() {
        let m = arc([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], true, 1);
        let MoveKind::Arc(a) = m.kind else {
            unreachable!()
        };
        let cs = arc_cubics(m.from, m.to, &a);
        assert_eq!(cs.len(), 2);
        assert_eq!(cs.last().unwrap()[3], m.to);
        for c in &cs {
            for k in 0..=20 {
                let p = cubic_at(c, k as f64 / 20.0);
                let r = p[0].hypot(p[1]);
                assert!((r - 10.0).abs() < 0.001, "radius {r}");
            }
        }
        assert!((length(&m) - 10.0 * FRAC_PI_2).abs() < 1e-9);
    }

    #[test]
    fn full_helix_and_extents() {
        // Full CW turn from (25, 20) around (20, 20), descending 1 mm.
        let m = arc(
            [25.0, 20.0, 0.0],
            [25.0, 20.0, -1.0],
            [20.0, 20.0, 0.0],
            false,
            1,
        );
        let MoveKind::Arc(a) = m.kind else {
            unreachable!()
        };
        let cs = arc_cubics(m.from, m.to, &a);
        assert_eq!(cs.len(), 8);
        let b = extents([&m]);
        assert!((b.min[0] - 15.0).abs() < 1e-9 && (b.max[0] - 25.0).abs() < 1e-9);
        assert!((b.min[1] - 15.0).abs() < 1e-9 && (b.max[1] - 25.0).abs() < 1e-9);
        assert_eq!((b.min[2], b.max[2]), (-1.0, 0.0));
        // CW from angle 0 goes to negative Y first.
        assert!(cubic_at(&cs[1], 1.0)[1] < 20.0);
        let len = length(&m);
        assert!((len - (TAU * 5.0).hypot(1.0)).abs() < 1e-9);
    }

    #[test]
    fn two_turns_sweep_twice() {
        let m = arc([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0; 3], true, 2);
        assert!((length(&m) - 2.0 * TAU).abs() < 1e-9);
    }
}
