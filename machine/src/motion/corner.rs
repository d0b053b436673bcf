//! Corner rounding under `G64 P<tolerance>`: the corner between two feed moves is cut off by a
//! tangent arc, run as a few short segments ([`super::pipeline`] queues them as line blocks).
//!
//! The arc is tangent to both moves and passes the programmed corner point `p` at a distance of
//! at most the tolerance, so its radius is `r = tol·cos(α/2)/(1 − cos(α/2))` (α the turning
//! angle), and it takes at most half of either move: `r·tan(α/2) ≤ min(len_a, len_b)/2`. The
//! path runs along a polygon of `n` vertices outside the arc whose segments are tangent to it
//! (the first vertex lies on the first move, the last on the second), with `n` the fewest for
//! which every vertex lies within the chord tolerance of the arc (`r/cos(α/2n) − r`, at most
//! [`MAX_VERTICES`]). The polygon stays between the arc and the programmed corner: every point
//! of it is within `r·(1 − cos(α/2)) ≤ tol` of the programmed moves, and it passes the corner
//! point within `tol`.
//!
//! Speed: a vertex turning by φ at speed v is grbl's junction with a deviation equal to the
//! vertex's distance from the arc, whose limit is exactly `v² = a·r`; `a` is the least over the
//! vertices of the acceleration every axis allows along that vertex's normal. The corner runs at
//! `√(a·r)` (capped by the feed): entry, every vertex and exit
//! (docs/settings.md, "Path blending (`G61`, `G64`, `G64 P`)").
//!
//! Integer arithmetic only (binary angles and the CORDIC of [`super::trig`]), bit-identical on
//! every target.

use super::config::MotionConfig;
use super::planner::{direction, UNIT};
use crate::arith::{atan2, div_i128, isqrt_u128, mul_div, mul_i128, polar, sat_mul};
use crate::units::{Pos, MAX_AXES};
use heapless::Vec;

/// Most vertices of one rounded corner (its polygon is `n − 1` planner blocks).
pub(crate) const MAX_VERTICES: usize = 6;

/// Corners turning by less than this (sin(α/2) in 2³⁰ units: about 0.11°) are not rounded:
/// their junction speed is far above any feed.
const MIN_HALF_SIN: u64 = (UNIT as u64) >> 10;

/// A rounded corner.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Corner {
    /// The path leaves the first move at the first vertex, runs through each in turn and joins
    /// the second move at the last (one vertex: the programmed corner point itself).
    pub vertices: Vec<Pos, MAX_VERTICES>,
    /// Arc radius, nm.
    pub radius: u64,
    /// Centripetal speed² limit through the corner, `a·r`, nm²/s².
    pub speed_sq: u64,
}

/// The rounded corner at `p` between the moves `a → p` and `p → b`, taking at most half of
/// `len_a` and `len_b` (their programmed lengths, nm), within `tolerance` nm of `p`. `None` for
/// no corner to round: a move without length, a turn below 0.11°, a near reversal or a radius
/// below 1 nm.
pub fn round(
    cfg: &MotionConfig,
    a: &Pos,
    p: &Pos,
    b: &Pos,
    lengths: (u64, u64),
    tolerance: u64,
) -> Option<Corner> {
    let axes = (cfg.axis_count as usize).min(MAX_AXES);
    let u1 = direction(cfg, &sub(p, a))?.unit;
    let u2 = direction(cfg, &sub(b, p))?.unit;
    let unit = i128::from(UNIT);
    let one = unit * unit;
    let dot: i128 = (0..axes)
        .map(|i| mul_i128(i128::from(u1[i]), i128::from(u2[i])))
        .sum();
    // cos(α/2), sin(α/2) in 2³⁰ units.
    let half_cos = isqrt_u128(((one + dot).max(0) >> 1) as u128) as u64;
    let half_sin = isqrt_u128(((one - dot).max(0) >> 1) as u128) as u64;
    if half_sin < MIN_HALF_SIN || half_cos < MIN_HALF_SIN || half_cos >= UNIT as u64 {
        return None;
    }
    let r_tol = mul_div(tolerance, half_cos, UNIT as u64 - half_cos);
    let r_half = mul_div(lengths.0.min(lengths.1), half_cos, 2 * half_sin);
    let r = r_tol.min(r_half);
    if r == 0 {
        return None;
    }
    // Tangent length r·tan(α/2), sin α and cos α in 2³⁰ units, and α as a binary angle.
    let t = mul_div(r, half_sin, half_cos) as i128;
    let sin_a = mul_i128(i128::from(half_sin), i128::from(half_cos)) >> 29;
    let cos_a = dot >> 30;
    let alpha = atan2(sin_a as i64, cos_a as i64);
    // w: the unit normal of the first move toward the second (2³⁰), (u2 − cos α·u1)/sin α.
    let mut w = [0i64; MAX_AXES];
    for i in 0..axes {
        let num = i128::from(u2[i]) * one - mul_i128(dot, i128::from(u1[i]));
        w[i] = div_i128(num, mul_i128(sin_a, unit)) as i64;
    }
    // Fewest vertices that keep each within the chord tolerance of the arc.
    let chord_tolerance = cfg.chord_tolerance.max(1) as u64;
    let mut n = MAX_VERTICES as i64;
    let mut vertex_cos = 0u64;
    // A half-open range: with `1..=` the compiler kept a division-by-zero check below.
    for k in 1..MAX_VERTICES as i64 + 1 {
        let c = polar(UNIT, alpha / (2 * k)).0.max(1) as u64;
        if mul_div(r, UNIT as u64, c) - r <= chord_tolerance || k == MAX_VERTICES as i64 {
            (n, vertex_cos) = (k, c);
            break;
        }
    }
    let big_r = mul_div(r, UNIT as u64, vertex_cos) as i64;
    // Centre: p − t·u1 + r·w.
    let mut center = *p;
    for i in 0..axes {
        let off = mul_i128(i128::from(r), i128::from(w[i])) - mul_i128(t, i128::from(u1[i]));
        center[i] += div_i128(off, unit) as i64;
    }
    let mut vertices = Vec::new();
    let mut accel = u64::MAX;
    for k in 0..n {
        // Vertex k at turning angle (k + ½)·α/n, radius R = r/cos(α/2n) from the centre.
        let theta = div_i128(
            mul_i128(i128::from(alpha), i128::from(2 * k + 1)),
            i128::from(2 * n),
        ) as i64;
        let (c, s) = polar(UNIT, theta);
        let (rc, rs) = polar(big_r, theta);
        let mut v = center;
        for i in 0..axes {
            v[i] += cross_unit(u1[i], rs, w[i], rc) as i64;
            // The vertex's normal (toward the centre): w·cos θ − u1·sin θ.
            let normal = cross_unit(w[i], c, u1[i], s).unsigned_abs() as u64;
            if normal > 0 {
                accel = accel.min(mul_div(cfg.axes[i].accel, UNIT as u64, normal));
            }
        }
        let _ = vertices.push(if n == 1 { *p } else { v });
    }
    Some(Corner {
        vertices,
        radius: r,
        speed_sq: sat_mul(accel.max(1), r),
    })
}

/// `a − b` per axis.
/// `(a·b − c·d) / 2³⁰`, truncated toward zero: one copy of the wide products for the vertex
/// loop's two projections.
#[inline(never)]
fn cross_unit(a: i64, b: i64, c: i64, d: i64) -> i128 {
    let wide = |x: i64, y: i64| mul_i128(i128::from(x), i128::from(y));
    div_i128(wide(a, b) - wide(c, d), i128::from(UNIT))
}

fn sub(a: &Pos, b: &Pos) -> Pos {
    let mut d = [0; MAX_AXES];
    for i in 0..MAX_AXES {
        d[i] = a[i] - b[i];
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arith::isqrt_u64;

    const MM: i64 = 1_000_000;

    fn xy(x: i64, y: i64) -> Pos {
        [x, y, 0, 0, 0, 0]
    }

    #[test]
    fn a_right_angle_at_ten_microns() {
        let cfg = MotionConfig::default();
        let c = round(
            &cfg,
            &xy(0, 0),
            &xy(10 * MM, 0),
            &xy(10 * MM, 10 * MM),
            (10 * MM as u64, 10 * MM as u64),
            10_000,
        )
        .unwrap();
        // r = 10 µm·cos45/(1 − cos45) = 24.142 µm.
        assert_eq!(c.radius, 24_142);
        // Vertices within 2 µm of the arc: r/cos(45°/n) − r ≤ 2 µm → n = 2 (22.5°: 1.99 µm).
        assert_eq!(c.vertices.len(), 2);
        // The first on the X move, the last on the Y move, symmetric about the bisector.
        let (v0, v1) = (c.vertices[0], c.vertices[1]);
        assert_eq!(v0[1], 0);
        assert_eq!(v1[0], 10 * MM);
        assert_eq!(10 * MM - v0[0], v1[1]);
        // r·tan(45°) − r·tan(22.5°) short of the corner: 24.142 − 10 = 14.142 µm.
        assert_eq!(10 * MM - v0[0], 14_142, "{c:?}");
        // a = 200 mm/s² / cos 22.5° (both vertex normals), v = √(216.478 mm/s² · 24.142 µm).
        let v = isqrt_u64(c.speed_sq);
        assert_eq!(v, 2_286_093, "{c:?}");
        // A straight continuation or a reversal is no corner.
        let straight = round(
            &cfg,
            &xy(0, 0),
            &xy(MM, 0),
            &xy(2 * MM, 0),
            (MM as u64, MM as u64),
            10_000,
        );
        assert!(straight.is_none());
        let back = round(
            &cfg,
            &xy(0, 0),
            &xy(MM, 0),
            &xy(0, 0),
            (MM as u64, MM as u64),
            10_000,
        );
        assert!(back.is_none());
    }
}
