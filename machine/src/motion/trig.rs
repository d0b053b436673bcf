//! Integer geometry helpers: square roots, overflow-safe `a × b / c`, and a CORDIC for arcs.
//!
//! Angles are *binary angles*: [`TURN`] units make a full turn (2⁴⁸), so wrapping is exact integer
//! arithmetic. The CORDIC runs 40 iterations on vectors pre-scaled by 2¹⁶, which keeps a point on a
//! 10 m radius within a few nanometres. The arctangent table was generated offline (Python, double
//! precision) as `round(atan(2⁻ⁱ) / 2π × 2⁴⁸)`.

/// Binary-angle units in one full turn.
pub const TURN: i64 = 1 << 48;
/// Half a turn.
pub const HALF_TURN: i64 = TURN / 2;
/// A quarter turn.
pub const QUARTER_TURN: i64 = TURN / 4;

const ITERATIONS: usize = 40;
/// Extra precision bits the CORDIC vectors carry.
const SCALE_BITS: u32 = 16;
/// CORDIC gain compensation ∏ 1/√(1+2⁻²ⁱ) in Q62.
const GAIN_Q62: i128 = 2_800_459_870_029_453_312;

const ATAN_TABLE: [i64; ITERATIONS] = [
    35184372088832,
    20770547670515,
    10974586953444,
    5570871696862,
    2796246208089,
    1399486241028,
    699913886760,
    349978300884,
    174991820497,
    87496244017,
    43748163730,
    21874087080,
    10937044192,
    5468522177,
    2734261099,
    1367130551,
    683565276,
    341782638,
    170891319,
    85445659,
    42722830,
    21361415,
    10680707,
    5340354,
    2670177,
    1335088,
    667544,
    333772,
    166886,
    83443,
    41722,
    20861,
    10430,
    5215,
    2608,
    1304,
    652,
    326,
    163,
    81,
];

/// ⌊√v⌋ of a 64-bit value.
pub fn isqrt_u64(v: u64) -> u64 {
    if v < 2 {
        return v;
    }
    // Start from a power of two above the root, then Newton steps (monotonically decreasing).
    let bits = 64 - v.leading_zeros();
    let mut x = 1u64 << bits.div_ceil(2);
    loop {
        let y = (x + v / x) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// ⌊√v⌋ of a 128-bit value.
pub fn isqrt_u128(v: u128) -> u128 {
    if v <= u64::MAX as u128 {
        return isqrt_u64(v as u64) as u128;
    }
    let bits = 128 - v.leading_zeros();
    let mut x = 1u128 << bits.div_ceil(2);
    loop {
        let y = (x + v / x) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// ⌊a × b / c⌋ without overflow (64-bit fast path); saturates at `u64::MAX`.
pub fn mul_div(a: u64, b: u64, c: u64) -> u64 {
    debug_assert!(c != 0);
    match a.checked_mul(b) {
        Some(p) => p / c,
        None => {
            let q = (a as u128 * b as u128) / c as u128;
            q.min(u64::MAX as u128) as u64
        }
    }
}

/// ⌈a × b / c⌉ without overflow; saturates at `u64::MAX`.
pub fn mul_div_ceil(a: u64, b: u64, c: u64) -> u64 {
    match a.checked_mul(b) {
        Some(p) => p.div_ceil(c),
        None => {
            let q = (a as u128 * b as u128).div_ceil(c as u128);
            q.min(u64::MAX as u128) as u64
        }
    }
}

/// Angle of the vector (x, y) in binary-angle units, in (−½ turn, ½ turn].
pub fn atan2(y: i64, x: i64) -> i64 {
    if x == 0 && y == 0 {
        return 0;
    }
    // Scale so the largest component sits near 2⁶⁰, leaving headroom for the CORDIC gain.
    let m = x.unsigned_abs().max(y.unsigned_abs());
    let shift = (m.leading_zeros() as i32 - 3).max(0) as u32;
    let (mut x, mut y) = ((x as i128) << shift, (y as i128) << shift);
    let mut angle = 0i64;
    // Rotate into the right half plane first; CORDIC converges within ±99.7°.
    if x < 0 {
        if y >= 0 {
            angle = HALF_TURN;
        } else {
            angle = -HALF_TURN;
        }
        x = -x;
        y = -y;
    }
    for (i, step) in ATAN_TABLE.iter().enumerate() {
        let (dx, dy) = (y >> i, x >> i);
        if y > 0 {
            x += dx;
            y -= dy;
            angle += step;
        } else {
            x -= dx;
            y += dy;
            angle -= step;
        }
    }
    if angle > HALF_TURN {
        angle -= TURN;
    }
    angle
}

/// (r·cos θ, r·sin θ) rounded to integers, for |r| below 2⁴⁶ (70 km in nm).
pub fn polar(r: i64, theta: i64) -> (i64, i64) {
    let mut t = theta.rem_euclid(TURN);
    // Fold into [−¼, ¼] turn, remembering a sign flip.
    let mut flip = false;
    if t > HALF_TURN {
        t -= TURN;
    }
    if t > QUARTER_TURN {
        t -= HALF_TURN;
        flip = true;
    } else if t < -QUARTER_TURN {
        t += HALF_TURN;
        flip = true;
    }
    let mut x: i128 = (((r as i128) << SCALE_BITS) * GAIN_Q62) >> 62;
    let mut y: i128 = 0;
    let mut residual = t;
    for (i, step) in ATAN_TABLE.iter().enumerate() {
        let (dx, dy) = (y >> i, x >> i);
        if residual >= 0 {
            x -= dx;
            y += dy;
            residual -= step;
        } else {
            x += dx;
            y -= dy;
            residual += step;
        }
    }
    let half = 1i128 << (SCALE_BITS - 1);
    let (mut cx, mut sy) = (
        ((x + half) >> SCALE_BITS) as i64,
        ((y + half) >> SCALE_BITS) as i64,
    );
    if flip {
        cx = -cx;
        sy = -sy;
    }
    (cx, sy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_roots_are_floors() {
        for v in [
            0u64,
            1,
            2,
            3,
            4,
            15,
            16,
            17,
            1 << 40,
            u64::MAX,
            999_999_999_999,
        ] {
            let r = isqrt_u64(v) as u128;
            assert!(r * r <= v as u128 && (r + 1) * (r + 1) > v as u128, "{v}");
        }
        let v = u128::MAX / 3;
        let r = isqrt_u128(v);
        assert!(r * r <= v && (r + 1) * (r + 1) > v);
    }

    #[test]
    fn atan2_hits_the_axes_and_diagonals() {
        let e = 1 << 12; // 2⁻³⁶ turn
        assert!((atan2(0, 5)).abs() < e);
        assert!((atan2(5, 0) - QUARTER_TURN).abs() < e);
        assert!((atan2(0, -5) - HALF_TURN).abs() < e);
        assert!((atan2(-5, 0) + QUARTER_TURN).abs() < e);
        assert!((atan2(7, 7) - TURN / 8).abs() < e);
        assert!((atan2(-7_000_000_000, -7_000_000_000) + 3 * TURN / 8).abs() < e);
    }

    #[test]
    fn polar_round_trips_within_a_nanometre() {
        let r = 5_000_000_000i64; // 5 m
        for k in 0..64 {
            let theta = k * (TURN / 64) + 12345;
            let (x, y) = polar(r, theta);
            let back = atan2(y, x);
            let d = (back - theta).rem_euclid(TURN);
            let d = if d > HALF_TURN { d - TURN } else { d };
            // One nm on 5 m is 3e-11 turn ≈ 9000 units.
            assert!(d.abs() < 20_000, "k {k} d {d}");
            let rr = isqrt_u128((x as i128 * x as i128 + y as i128 * y as i128) as u128) as i64;
            assert!((rr - r).abs() <= 2, "k {k} r {rr}");
        }
        assert_eq!(polar(1_000_000, 0), (1_000_000, 0));
        assert_eq!(polar(1_000_000, QUARTER_TURN), (0, 1_000_000));
        assert_eq!(polar(1_000_000, HALF_TURN), (-1_000_000, 0));
    }
}
