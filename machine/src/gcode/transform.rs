//! The Fanuc coordinate transforms (docs/gcode-transforms.md): programmable mirror (G51.1),
//! scaling (G51) and rotation (G68), applied in that order to a program point of the linear axes
//! X, Y, Z before the work, G92 and tool offsets are added. One pipeline: every move, arc centre
//! and canned-cycle position goes through [`Transform::forward`].
//!
//! The interpreter keeps the program point (before the transforms) of the current position, so
//! incremental moves add to what the program wrote and rounding never accumulates; when the
//! position changed by another path (G28, G53, a probe, a tool change) the program point is the
//! inverse transform of where the tool is.

use crate::arith::{atan2, polar, TURN};
use crate::units::Nm;

use super::geometry::{div_round, hypot};

/// A scale factor of 1 (factors are in millionths).
pub const ONE: i32 = 1_000_000;

/// The transforms in force (G51.1, G51, G68) and the polar mode (G16).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transform {
    /// A mirror, scaling or rotation is in force (kept by [`Transform::update`]).
    pub on: bool,
    /// Mirrored axes: bit `i` for axis `i` (X, Y, Z).
    pub mirror: u8,
    /// Twice the mirror coordinate of each axis (x' = twice − x), program nm.
    pub mirror_twice: [Nm; 3],
    /// Scaling factors (millionths; all [`ONE`] when G50) and the centre (after the mirror).
    pub factor: [i32; 3],
    pub scale_center: [Nm; 3],
    /// G68 in force: the plane axes it turns (first → second is positive), the centre (after
    /// mirror and scaling) and the angle (binary, [`TURN`] a full turn).
    pub rotating: bool,
    pub rot_axes: (u8, u8),
    pub rot_center: (Nm, Nm),
    pub angle: i64,
    /// G16 polar coordinates.
    pub polar: bool,
}

impl Transform {
    /// No transform (G50.1, G50, G69, G15).
    pub(crate) const OFF: Transform = Transform {
        on: false,
        mirror: 0,
        mirror_twice: [0; 3],
        factor: [ONE; 3],
        scale_center: [0; 3],
        rotating: false,
        rot_axes: (0, 1),
        rot_center: (0, 0),
        angle: 0,
        polar: false,
    };

    /// True when G51 is in force.
    pub fn scaling(&self) -> bool {
        self.factor != [ONE; 3]
    }

    /// True when a point transform (mirror, scaling or rotation) is in force.
    pub fn active(&self) -> bool {
        self.on
    }

    /// Sets [`Transform::on`] after a change.
    pub fn update(&mut self) {
        self.on = self.mirror != 0 || self.scaling() || self.rotating;
    }

    /// True when exactly one of plane axes `a`, `b` is mirrored: arcs, the side of cutter
    /// compensation and the rotation angle reverse.
    pub fn flips(&self, a: usize, b: usize) -> bool {
        ((self.mirror >> a) ^ (self.mirror >> b)) & 1 != 0
    }

    /// The transformed point of program point `p` (work coordinates, offsets not added):
    /// mirror, then scaling (axis `keep` unscaled: a canned cycle's drilling axis; 3 for none),
    /// then rotation.
    pub fn forward(&self, p: [Nm; 3], keep: usize) -> [Nm; 3] {
        self.map(p, false, keep)
    }

    /// The program point that [`Transform::forward`] takes to `w`.
    pub fn inverse(&self, w: [Nm; 3]) -> [Nm; 3] {
        self.map(w, true, 3)
    }

    #[inline(never)]
    fn map(&self, mut p: [Nm; 3], inverse: bool, keep: usize) -> [Nm; 3] {
        let turn = |p: &mut [Nm; 3], angle: i64| {
            // About the centre through the core's one CORDIC (motion/trig.rs).
            let (a, b) = (self.rot_axes.0 as usize, self.rot_axes.1 as usize);
            let (ca, cb) = self.rot_center;
            let (da, db) = (p[a] - ca, p[b] - cb);
            let (x, y) = polar(hypot(da, db), atan2(db, da) + angle);
            (p[a], p[b]) = (ca + x, cb + y);
        };
        if inverse && self.rotating {
            turn(&mut p, -self.angle);
        }
        // Zipped rather than indexed: no bounds-check panic paths.
        let per_axis = self
            .mirror_twice
            .iter()
            .zip(&self.factor)
            .zip(&self.scale_center);
        for (i, (v, ((&twice, &f), &c))) in p.iter_mut().zip(per_axis).enumerate() {
            let mirror = self.mirror >> i & 1 != 0;
            if mirror && !inverse {
                *v = twice - *v;
            }
            if f != ONE && i != keep {
                let (n, d) = if inverse { (ONE, f) } else { (f, ONE) };
                *v = c + div_round((*v - c) as i128 * n as i128, d as i128) as Nm;
            }
            if mirror && inverse {
                *v = twice - *v;
            }
        }
        if !inverse && self.rotating {
            turn(&mut p, self.angle);
        }
        p
    }

    /// Sets the rotation angle (10⁻⁶ degree, + turns the first plane axis toward the second).
    pub(crate) fn set_angle(&mut self, udeg: i64) {
        self.angle = div_round(udeg as i128 * TURN as i128, 360_000_000) as i64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MM: Nm = 1_000_000;

    #[test]
    fn mirror_then_scale_then_rotate_and_back() {
        let mut t = Transform::OFF;
        t.mirror = 1;
        t.mirror_twice[0] = 2 * 15 * MM / 10;
        t.factor = [ONE / 2; 3];
        t.scale_center = [40 * MM, 40 * MM, 0];
        t.rotating = true;
        t.rot_axes = (0, 1);
        t.set_angle(90_000_000);
        t.update();
        // (10, 0, 4): mirror about X1.5 → (−7, 0, 4); half about (40, 40, 0) → (16.5, 20, 2);
        // +90° about the origin → (−20, 16.5, 2).
        let w = t.forward([10 * MM, 0, 4 * MM], 3);
        assert_eq!(w, [-20 * MM, 16_500_000, 2 * MM]);
        assert_eq!(t.inverse(w), [10 * MM, 0, 4 * MM]);
        // A cycle's drilling axis (Z) is not scaled.
        assert_eq!(t.forward([10 * MM, 0, 4 * MM], 2)[2], 4 * MM);
        assert!(t.flips(0, 1) && t.flips(0, 2) && !t.flips(1, 2));
    }

    #[test]
    fn rotation_of_45_degrees() {
        let mut t = Transform::OFF;
        t.rotating = true;
        t.update();
        t.set_angle(45_000_000);
        assert_eq!(t.forward([10 * MM, 0, 0], 3), [7_071_068, 7_071_068, 0]);
        t.set_angle(-75_000_000);
        // (10 cos −75°, 10 sin −75°) = (2.588190, −9.659258).
        assert_eq!(t.forward([10 * MM, 0, 0], 3), [2_588_190, -9_659_258, 0]);
    }
}
