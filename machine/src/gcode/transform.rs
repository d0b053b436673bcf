//! The Fanuc coordinate transforms (docs/gcode-transforms.md): programmable mirror (G51.1),
//! scaling (G51) and rotation (G68), applied in that order to a program point of the linear axes
//! X, Y, Z before the work, G92 and tool offsets are added. One pipeline: every move, arc centre
//! and canned-cycle position goes through [`Transform::forward`].
//!
//! The interpreter keeps the program point (before the transforms) of the current position, so
//! incremental moves add to what the program wrote and rounding never accumulates; when the
//! position changed by another path (G28, G53, a probe, a tool change) the program point is the
//! inverse transform of where the tool is.

use crate::motion::trig::{polar, TURN};
use crate::units::Nm;

use super::geometry::div_round;

/// A scale factor of 1 (factors are in millionths).
pub const ONE: i64 = 1_000_000;
/// Binary point of the rotation's cosine and sine.
const ROT_BITS: u32 = 40;

/// The transforms in force (G51.1, G51, G68) and the polar mode (G16).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transform {
    /// Mirrored axes: bit `i` for axis `i` (X, Y, Z).
    pub mirror: u8,
    /// Twice the mirror coordinate of each axis (x' = twice − x), program nm.
    pub mirror_twice: [Nm; 3],
    /// Scaling factors (millionths; all [`ONE`] when G50) and the centre (after the mirror).
    pub factor: [i64; 3],
    pub scale_center: [Nm; 3],
    /// G68 in force: the plane axes it turns (first → second is positive), the centre (after
    /// mirror and scaling) and cos, sin of the angle (2⁻⁴⁰).
    pub rotating: bool,
    pub rot_axes: (u8, u8),
    pub rot_center: (Nm, Nm),
    pub cos: i64,
    pub sin: i64,
    /// G16 polar coordinates.
    pub polar: bool,
}

impl Transform {
    /// No transform (G50.1, G50, G69, G15).
    pub const OFF: Transform = Transform {
        mirror: 0,
        mirror_twice: [0; 3],
        factor: [ONE; 3],
        scale_center: [0; 3],
        rotating: false,
        rot_axes: (0, 1),
        rot_center: (0, 0),
        cos: 1 << ROT_BITS,
        sin: 0,
        polar: false,
    };

    /// True when G51 is in force.
    pub fn scaling(&self) -> bool {
        self.factor != [ONE; 3]
    }

    /// True when a point transform (mirror, scaling or rotation) is in force.
    pub fn active(&self) -> bool {
        self.mirror != 0 || self.scaling() || self.rotating
    }

    /// True when exactly one of plane axes `a`, `b` is mirrored: arcs, the side of cutter
    /// compensation and the rotation angle reverse.
    pub fn flips(&self, a: usize, b: usize) -> bool {
        ((self.mirror >> a) ^ (self.mirror >> b)) & 1 != 0
    }

    /// Mirror, then scaling (axis `keep` unscaled: a canned cycle's drilling axis; 3 for none).
    fn mirror_scale(&self, p: &mut [Nm; 3], keep: usize) {
        for i in 0..3 {
            if self.mirror >> i & 1 != 0 {
                p[i] = self.mirror_twice[i] - p[i];
            }
            if self.factor[i] != ONE && i != keep {
                let c = self.scale_center[i];
                p[i] =
                    c + div_round((p[i] - c) as i128 * self.factor[i] as i128, ONE as i128) as Nm;
            }
        }
    }

    /// The transformed point of program point `p` (work coordinates, offsets not added).
    pub fn forward(&self, mut p: [Nm; 3], keep: usize) -> [Nm; 3] {
        self.mirror_scale(&mut p, keep);
        if self.rotating {
            self.rotate(&mut p, self.sin);
        }
        p
    }

    /// The program point that [`Transform::forward`] takes to `w`.
    pub fn inverse(&self, mut w: [Nm; 3]) -> [Nm; 3] {
        if self.rotating {
            self.rotate(&mut w, -self.sin);
        }
        for i in 0..3 {
            if self.factor[i] != ONE {
                let c = self.scale_center[i];
                w[i] =
                    c + div_round((w[i] - c) as i128 * ONE as i128, self.factor[i] as i128) as Nm;
            }
            if self.mirror >> i & 1 != 0 {
                w[i] = self.mirror_twice[i] - w[i];
            }
        }
        w
    }

    /// Turns `p` about the rotation centre by the angle whose sine is `sin` (cosine `self.cos`).
    fn rotate(&self, p: &mut [Nm; 3], sin: i64) {
        let (a, b) = (self.rot_axes.0 as usize, self.rot_axes.1 as usize);
        let (ca, cb) = self.rot_center;
        let (da, db) = ((p[a] - ca) as i128, (p[b] - cb) as i128);
        let (c, s) = (self.cos as i128, sin as i128);
        let half = 1i128 << (ROT_BITS - 1);
        p[a] = ca + ((da * c - db * s + half) >> ROT_BITS) as Nm;
        p[b] = cb + ((da * s + db * c + half) >> ROT_BITS) as Nm;
    }

    /// Sets the rotation angle (10⁻⁶ degree, + turns the first plane axis toward the second).
    pub fn set_angle(&mut self, udeg: i64) {
        let angle = div_round(udeg as i128 * TURN as i128, 360_000_000) as i64;
        (self.cos, self.sin) = polar(1 << ROT_BITS, angle);
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
        t.set_angle(45_000_000);
        assert_eq!(t.forward([10 * MM, 0, 0], 3), [7_071_068, 7_071_068, 0]);
        t.set_angle(-75_000_000);
        // (10 cos −75°, 10 sin −75°) = (2.588190, −9.659258).
        assert_eq!(t.forward([10 * MM, 0, 0], 3), [2_588_190, -9_659_258, 0]);
    }
}
