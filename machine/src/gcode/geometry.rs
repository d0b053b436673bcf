//! Integer geometry for the interpreter: square roots, arc centres, radius checks and sweep angles.
//!
//! All arithmetic is on `i64` nanometres with `i128` intermediates; the angle routine is the
//! core's one CORDIC (`motion/trig.rs`), so results are bit-identical on every target and no float
//! is involved.

use super::error::ErrorCode;
// Wide i128 products out of line (each is a long inline expansion on the Cortex-M4).
use crate::arith::mul_i128 as mul;
use crate::units::Nm;

/// Floor of the square root of `v` (the motion core's, one copy in flash for every caller).
pub(crate) fn isqrt(v: u128) -> u128 {
    crate::arith::isqrt_u128(v)
}

/// Square root rounded to the nearest integer.
pub(crate) fn isqrt_round(v: u128) -> u128 {
    let r = isqrt(v);
    // (r + 0.5)^2 = r^2 + r + 0.25 ; round up when v > r^2 + r.
    if v > r * r + r {
        r + 1
    } else {
        r
    }
}

/// Length of a 2-D vector, rounded to the nearest nm.
pub(crate) fn hypot(a: Nm, b: Nm) -> Nm {
    let s = mul(a as i128, a as i128) + mul(b as i128, b as i128);
    isqrt_round(s as u128) as Nm
}

/// Length of a 3-D vector, rounded.
pub(crate) fn hypot3(a: Nm, b: Nm, c: Nm) -> Nm {
    let s = mul(a as i128, a as i128) + mul(b as i128, b as i128) + mul(c as i128, c as i128);
    isqrt_round(s as u128) as Nm
}

/// Divides rounding half away from zero.
pub(crate) fn div_round(n: i128, d: i128) -> i128 {
    let q = crate::arith::div_i128(n, d);
    let r = n - q * d;
    if 2 * r.abs() >= d.abs() {
        if (n < 0) != (d < 0) {
            q - 1
        } else {
            q + 1
        }
    } else {
        q
    }
}

/// LinuxCNC's arc tolerances for the current length units, in nm.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArcTolerances {
    /// Smallest radius (and largest R-format chord excess).
    pub radius: Nm,
    /// Absolute start/end radius difference allowed when the relative error exceeds 0.1 %.
    pub spiral_abs: Nm,
}

impl ArcTolerances {
    /// Metric: 0.00127 mm and 0.02·√2 mm; inch: 0.00005 in and 0.002·√2 in.
    pub(crate) fn for_units(inch: bool) -> Self {
        if inch {
            ArcTolerances {
                radius: 1_270,
                spiral_abs: 71_842,
            }
        } else {
            ArcTolerances {
                radius: 1_270,
                spiral_abs: 28_284,
            }
        }
    }
}

/// Checks an I/J/K arc: both radii above the minimum, end on the circle within LinuxCNC's rule
/// (error if |r1-r2| > 100·abs, or if the relative error > 0.1 % and |r1-r2| > abs).
pub(crate) fn check_center_arc(
    start: (Nm, Nm),
    end: (Nm, Nm),
    center: (Nm, Nm),
    tol: ArcTolerances,
) -> Result<(), ErrorCode> {
    let r1 = hypot(start.0 - center.0, start.1 - center.1);
    let r2 = hypot(end.0 - center.0, end.1 - center.1);
    if r1 < tol.radius || r2 < tol.radius {
        return Err(ErrorCode::ArcZeroRadius);
    }
    let abs_err = (r1 - r2).abs() as i128;
    let max_r = r1.max(r2) as i128;
    let spiral = tol.spiral_abs as i128;
    if abs_err > spiral * 100 || (abs_err * 1000 > max_r && abs_err > spiral) {
        return Err(ErrorCode::ArcRadiusMismatch);
    }
    Ok(())
}

/// Centre of an R-format arc (LinuxCNC `arc_data_r`): positive R is the short way, negative R the
/// long way; `cw` is G2.
pub(crate) fn r_format_center(
    start: (Nm, Nm),
    end: (Nm, Nm),
    radius: Nm,
    cw: bool,
    tol: ArcTolerances,
) -> Result<(Nm, Nm), ErrorCode> {
    if start == end {
        return Err(ErrorCode::ArcEndEqualsStart);
    }
    let abs_r = radius.unsigned_abs() as i128;
    let dx = (end.0 - start.0) as i128;
    let dy = (end.1 - start.1) as i128;
    let chord_sq = dx * dx + dy * dy;
    let chord = isqrt_round(chord_sq as u128) as i128;
    // half_length - |R| > tolerance  <=>  chord - 2|R| > 2 tolerance
    if chord - 2 * abs_r > 2 * tol.radius as i128 {
        return Err(ErrorCode::ArcRadiusTooSmall);
    }
    // Distance from the chord midpoint to the centre: sqrt(R^2 - (chord/2)^2), computed in
    // doubled units: 2*offset = sqrt(4R^2 - chord^2).
    let four_r_sq = mul(4 * abs_r, abs_r);
    let offset2 = if chord_sq >= four_r_sq {
        0
    } else {
        isqrt_round((four_r_sq - chord_sq) as u128) as i128
    };
    // Unit perpendicular: right of the chord for (G2, R>0) or (G3, R<0), else left.
    let right = cw == (radius > 0);
    let (px, py) = if right { (dy, -dx) } else { (-dy, dx) };
    // centre = mid + (offset2/2) * p / chord, everything doubled then halved once.
    let mid2x = (start.0 as i128) + (end.0 as i128);
    let mid2y = (start.1 as i128) + (end.1 as i128);
    let cx2 = mul(mid2x, chord) + mul(offset2, px);
    let cy2 = mul(mid2y, chord) + mul(offset2, py);
    let cx = div_round(cx2, 2 * chord);
    let cy = div_round(cy2, 2 * chord);
    Ok((cx as Nm, cy as Nm))
}

/// Angles in units of 2^-48 radian, π in them, and atan2 on them: the one CORDIC module's
/// (`crate::arith`).
pub use crate::arith::{atan2_rad as atan2, PI_RAD as PI, RAD as ANGLE_ONE};

/// Swept angle (2^-48 rad, > 0) of an arc from `start` to `end` about `center`, `turns` ≥ 1.
pub fn sweep(start: (Nm, Nm), end: (Nm, Nm), center: (Nm, Nm), ccw: bool, turns: u32) -> i128 {
    let (sx, sy) = ((start.0 - center.0) as i128, (start.1 - center.1) as i128);
    let (ex, ey) = ((end.0 - center.0) as i128, (end.1 - center.1) as i128);
    let cross = mul(sx, ey) - mul(sy, ex);
    let dot = mul(sx, ex) + mul(sy, ey);
    let a = atan2(cross, dot) as i128;
    let two_pi = 2 * PI as i128;
    let mut s = if ccw { a } else { -a };
    if s <= 0 {
        s += two_pi;
    }
    s + (turns.max(1) as i128 - 1) * two_pi
}

/// Path length of a helical arc: sqrt((sweep·r)^2 + normal^2), in nm.
pub(crate) fn arc_length(sweep: i128, radius: Nm, normal: Nm) -> i128 {
    let planar = mul(sweep, radius as i128) >> 48;
    let s = mul(planar, planar) + mul(normal as i128, normal as i128);
    isqrt_round(s as u128) as i128
}

/// LinuxCNC's polar coordinates: the XY end point (program coordinates) of a block with a
/// radius `@` (nm) and/or an angle `^` (10⁻⁶ degree) from `current`. In G90 a missing radius or
/// angle is the current point's; in G91 both add to the current point's.
pub(crate) fn polar_end(
    current: (Nm, Nm),
    radius: Option<Nm>,
    angle_udeg: Option<i64>,
    absolute: bool,
) -> Result<(Nm, Nm), ErrorCode> {
    use crate::arith::{atan2 as binary_atan2, polar, TURN};
    let at_origin = current == (0, 0);
    let angle = angle_udeg.map(|a| div_round(a as i128 * TURN as i128, 360_000_000) as i64);
    let now_radius = hypot(current.0, current.1);
    let now_angle = binary_atan2(current.1, current.0);
    let (r, a) = if absolute {
        match (radius, angle) {
            (Some(r), Some(a)) => (r, a),
            (Some(_), None) if at_origin => return Err(ErrorCode::MissingAxisWords),
            (Some(r), None) => (r, now_angle),
            (None, Some(a)) => (now_radius, a),
            (None, None) => return Ok(current),
        }
    } else {
        if at_origin {
            return Err(ErrorCode::MissingAxisWords);
        }
        (
            now_radius + radius.unwrap_or(0),
            now_angle + angle.unwrap_or(0),
        )
    };
    if r.unsigned_abs() >= 1 << 46 {
        return Err(ErrorCode::CoordinateOverflow);
    }
    Ok(polar(r, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_roots() {
        assert_eq!(isqrt(0), 0);
        assert_eq!(isqrt(15), 3);
        assert_eq!(isqrt(16), 4);
        assert_eq!(isqrt(u128::MAX), u64::MAX as u128);
        assert_eq!(isqrt_round(15), 4);
        assert_eq!(hypot(3_000_000, 4_000_000), 5_000_000);
    }

    #[test]
    fn r_format_centres_as_the_hurco_manual_gives_them() {
        let tol = ArcTolerances::for_units(false);
        // G2 X10 Y0 R10 from the origin: centre (5, -8.660254)
        let c = r_format_center((0, 0), (10_000_000, 0), 10_000_000, true, tol).unwrap();
        assert_eq!(c, (5_000_000, -8_660_254));
        let c = r_format_center((0, 0), (10_000_000, 0), -10_000_000, true, tol).unwrap();
        assert_eq!(c, (5_000_000, 8_660_254));
        // exact semicircle
        let c = r_format_center((0, 0), (10_000_000, 0), 5_000_000, true, tol).unwrap();
        assert_eq!(c, (5_000_000, 0));
        assert_eq!(
            r_format_center((0, 0), (10_000_000, 0), 4_000_000, true, tol),
            Err(ErrorCode::ArcRadiusTooSmall)
        );
    }

    #[test]
    fn polar_end_points() {
        // @10 ^30 from anywhere in G90: (8.660254, 5).
        assert_eq!(
            polar_end((1, 1), Some(10_000_000), Some(30_000_000), true),
            Ok((8_660_254, 5_000_000))
        );
        // G91 ^60 from (38.1, 0): the bolt circle of LinuxCNC's hole-circle.ngc.
        assert_eq!(
            polar_end((38_100_000, 0), None, Some(60_000_000), false),
            Ok((19_050_000, 32_995_568))
        );
        assert_eq!(
            polar_end((0, 0), None, Some(60_000_000), false),
            Err(ErrorCode::MissingAxisWords)
        );
    }

    #[test]
    fn cordic_angles() {
        let quarter = atan2(1, 0);
        assert!((quarter - PI / 2).abs() < 16, "{quarter}");
        assert!((atan2(0, -5) - PI).abs() < 16);
        assert!((atan2(-1, -1) + 3 * PI / 4).abs() < 16);
        let full = sweep((10, 0), (10, 0), (0, 0), true, 1);
        assert_eq!(full, 2 * PI as i128);
    }
}
