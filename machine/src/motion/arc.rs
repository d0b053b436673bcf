//! Arc linearisation: turns a G2/G3 arc or helix into chords that the planner takes as lines.
//!
//! Chords are equal-angle (as `gixa` does). Their count is the largest of what the chord tolerance
//! and the segment-angle limit need, capped by the max-segments setting (which wins, as in `gixa`).
//! Every intermediate point is computed directly from the start angle (no accumulated rotation), the
//! radius is interpolated linearly when start and end radii differ, the normal and extra axes move
//! linearly (helix), and the last chord ends exactly on the programmed end point.

use super::config::MotionConfig;
use crate::arith::{atan2, div_i128, isqrt_u128, mul_i128, polar, HALF_TURN, QUARTER_TURN, TURN};
use crate::canon::{ArcDir, Plane};
use crate::units::{Nm, Pos, MAX_AXES};

/// An arc being cut into chords; yields the end point of each chord in turn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArcChords {
    start: Pos,
    to: Pos,
    /// Plane axes (first, second) and the centre on them.
    axes: (usize, usize),
    center: (Nm, Nm),
    r_start: i64,
    r_end: i64,
    theta_start: i64,
    /// Signed sweep in binary-angle units (positive = counter-clockwise).
    sweep: i64,
    count: u32,
    done: u32,
}

/// Plane axes in the order that makes counter-clockwise positive (G17 XY, G18 ZX, G19 YZ).
pub(crate) fn plane_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

fn radius(dx: i64, dy: i64) -> i64 {
    let sq = |v: i64| mul_i128(v as i128, v as i128);
    isqrt_u128((sq(dx) + sq(dy)) as u128) as i64
}

impl ArcChords {
    /// Plans the chords of an arc from `from` to `to` around `center` (X, Y, Z slots).
    pub fn new(
        cfg: &MotionConfig,
        from: &Pos,
        to: &Pos,
        center: &[Nm; 3],
        plane: Plane,
        dir: ArcDir,
        turns: u32,
    ) -> Self {
        let (a0, a1, _) = plane_axes(plane);
        let c = (center[a0], center[a1]);
        let (sx, sy) = (from[a0] - c.0, from[a1] - c.1);
        let (ex, ey) = (to[a0] - c.0, to[a1] - c.1);
        let r_start = radius(sx, sy);
        let r_end = radius(ex, ey);
        let theta_start = atan2(sy, sx);
        let theta_end = atan2(ey, ex);
        let extra = (turns.max(1) - 1) as i64 * TURN;
        let sweep = match dir {
            ArcDir::Ccw => {
                let d = (theta_end - theta_start).rem_euclid(TURN);
                let d = if d == 0 || (sx == ex && sy == ey) {
                    TURN
                } else {
                    d
                };
                d + extra
            }
            ArcDir::Cw => {
                let d = (theta_start - theta_end).rem_euclid(TURN);
                let d = if d == 0 || (sx == ex && sy == ey) {
                    TURN
                } else {
                    d
                };
                -(d + extra)
            }
        };
        let count = chord_count(cfg, r_start.max(r_end), sweep.unsigned_abs());
        ArcChords {
            start: *from,
            to: *to,
            axes: (a0, a1),
            center: c,
            r_start,
            r_end,
            theta_start,
            sweep,
            count,
            done: 0,
        }
    }

    /// Number of chords.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Signed sweep in binary-angle units ([`TURN`] per turn).
    pub fn sweep(&self) -> i64 {
        self.sweep
    }

    /// True once every chord has been handed out.
    pub(crate) fn is_done(&self) -> bool {
        self.done >= self.count
    }

    /// The end point of the next chord.
    pub fn next_point(&mut self) -> Option<Pos> {
        if self.done >= self.count {
            return None;
        }
        self.done += 1;
        if self.done == self.count {
            return Some(self.to);
        }
        let (i, n) = (self.done as i128, self.count as i128);
        let lerp = |a: i64, b: i64| a + div_i128(mul_i128(b as i128 - a as i128, i), n) as i64;
        let mut p = [0; MAX_AXES];
        for (k, v) in p.iter_mut().enumerate() {
            *v = lerp(self.start[k], self.to[k]);
        }
        let theta = self.theta_start + div_i128(mul_i128(self.sweep as i128, i), n) as i64;
        let r = lerp(self.r_start, self.r_end);
        let (dx, dy) = polar(r, theta);
        p[self.axes.0] = self.center.0 + dx;
        p[self.axes.1] = self.center.1 + dy;
        Some(p)
    }
}

/// Chords needed for `sweep` (binary angle, unsigned) on `radius` nm.
fn chord_count(cfg: &MotionConfig, radius: i64, sweep: u64) -> u32 {
    let tol = cfg.chord_tolerance.max(1);
    // Largest chord angle φ with r·(1 − cos φ/2) ≤ tol: φ/2 = atan2(√(2·r·tol − tol²), r − tol).
    let by_tolerance = if radius <= tol {
        QUARTER_TURN
    } else {
        let h = isqrt_u128(
            (mul_i128(2 * radius as i128, tol as i128) - tol as i128 * tol as i128) as u128,
        );
        (2 * atan2(h as i64, radius - tol) - 1)
            .max(1)
            .min(QUARTER_TURN)
    };
    let mut n = sweep.div_ceil(by_tolerance as u64);
    if cfg.arc_segment_angle_mdeg > 0 {
        let by_angle = div_i128(cfg.arc_segment_angle_mdeg as i128 * TURN as i128, 360_000)
            .max(1)
            .min(HALF_TURN as i128) as u64;
        n = n.max(sweep.div_ceil(by_angle));
    }
    if cfg.arc_max_segments > 0 {
        n = n.min(cfg.arc_max_segments as u64);
    }
    n.max(1).min(u32::MAX as u64) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::NM_PER_MM;

    fn chord_error(r: i64, a: &Pos, b: &Pos, c: (i64, i64)) -> i64 {
        // Distance from the centre to the chord's midpoint, subtracted from r.
        let mx = (a[0] + b[0]) / 2 - c.0;
        let my = (a[1] + b[1]) / 2 - c.1;
        r - radius(mx, my)
    }

    #[test]
    fn quarter_circle_meets_tolerance_and_ends_exactly() {
        let cfg = MotionConfig::default();
        let from = [10 * NM_PER_MM, 0, 0, 0, 0, 0];
        let to = [0, 10 * NM_PER_MM, 0, 0, 0, 0];
        let mut arc = ArcChords::new(&cfg, &from, &to, &[0, 0, 0], Plane::XY, ArcDir::Ccw, 1);
        // φ = 2·acos(1 − 0.002/10) ≈ 2.292°, so 90° needs 40 chords.
        assert_eq!(arc.count(), 40);
        let mut prev = from;
        let mut last = from;
        while let Some(p) = arc.next_point() {
            let r = radius(p[0], p[1]);
            assert!((r - 10 * NM_PER_MM).abs() <= 2, "radius {r}");
            let e = chord_error(10 * NM_PER_MM, &prev, &p, (0, 0));
            assert!(e <= 2_000 && e > 1_000, "chord error {e}");
            prev = p;
            last = p;
        }
        assert_eq!(last, to);
    }

    #[test]
    fn full_circle_cw_helix_with_turns() {
        let cfg = MotionConfig::default();
        let from = [5 * NM_PER_MM, 0, 0, 0, 0, 0];
        let to = [5 * NM_PER_MM, 0, -2 * NM_PER_MM, 0, 0, 0];
        let mut arc = ArcChords::new(&cfg, &from, &to, &[0, 0, 0], Plane::XY, ArcDir::Cw, 2);
        assert_eq!(arc.sweep(), -2 * TURN);
        let n = arc.count();
        let first = arc.next_point().unwrap();
        assert!(first[1] < 0, "clockwise starts towards −Y");
        let mut last = first;
        let mut z_prev = first[2];
        while let Some(p) = arc.next_point() {
            assert!(p[2] <= z_prev);
            z_prev = p[2];
            last = p;
        }
        assert_eq!(last, to);
        assert!(n > 100);
    }

    #[test]
    fn gixa_limits() {
        let mut cfg = MotionConfig {
            arc_segment_angle_mdeg: 5_000,
            ..Default::default()
        };
        let from = [100 * NM_PER_MM, 0, 0, 0, 0, 0];
        let c = [0, 0, 0];
        // 8° arc with a loose tolerance: 2 × 4°.
        cfg.chord_tolerance = NM_PER_MM;
        let (x, y) = polar(100 * NM_PER_MM, TURN / 45);
        let to = [x, y, 0, 0, 0, 0];
        let arc = ArcChords::new(&cfg, &from, &to, &c, Plane::XY, ArcDir::Ccw, 1);
        assert_eq!(arc.count(), 2);
        cfg.arc_max_segments = 1;
        let arc = ArcChords::new(&cfg, &from, &to, &c, Plane::XY, ArcDir::Ccw, 1);
        assert_eq!(arc.count(), 1);
    }
}
