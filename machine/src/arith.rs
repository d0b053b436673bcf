//! Integer arithmetic the interpreter (`gcode/`) and motion (`motion/`) both stand on: square
//! roots, overflow-safe `a × b / c`, and the core's one CORDIC (arcs in the planner, sweep angles
//! in the interpreter's `gcode/geometry.rs`). It depends on nothing else in the crate.
//!
//! The planner's angles are *binary angles*: [`TURN`] units make a full turn (2⁴⁸), so wrapping is
//! exact integer arithmetic. The CORDIC runs 40 iterations on vectors pre-scaled by 2¹⁶, which
//! keeps a point on a 10 m radius within a few nanometres. The arctangent table was generated
//! offline (Python, double precision) as `round(atan(2⁻ⁱ) / 2π × 2⁴⁸)`.
//!
//! The interpreter measures sweeps in 2⁻⁴⁸ radian ([`RAD`], [`atan2_rad`]) with its own 48-entry
//! table `round(atan(2⁻ⁱ) × 2⁴⁸)`; both arctangents run the same vectoring loop ([`vector`]).

/// Binary-angle units in one full turn.
pub const TURN: i64 = 1 << 48;
/// Half a turn.
pub(crate) const HALF_TURN: i64 = TURN / 2;
/// A quarter turn.
pub(crate) const QUARTER_TURN: i64 = TURN / 4;

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
    if v <= u32::MAX as u64 {
        return isqrt_u32(v as u32) as u64;
    }
    // Start from the square root of the top 32 bits (hardware division in `isqrt_u32`): with
    // `v << s` normalized to bits 62-63, `(⌊√hi⌋ + 1)·2^16` is above `√(v << s)` by at most
    // 2^-15 relative, so one Newton step lands within 3 above ⌊√v⌋ (and never below it: integer
    // Newton steps stay ≥ ⌊√v⌋), and a few multiplies finish. One 64-bit division instead of
    // four or five from a power-of-two start.
    let s = v.leading_zeros() & !1;
    let hi = ((v << s) >> 32) as u32;
    let x0 = (isqrt_u32(hi) as u64 + 1) << (16 - s / 2);
    let mut x = (x0 + div_u64(v, x0)) >> 1;
    while checked_mul_u64(x, x).is_none_or(|sq| sq > v) {
        x -= 1;
    }
    x
}

/// ⌊√v⌋ of a 32-bit value (hardware 32-bit division on Cortex-M4).
fn isqrt_u32(v: u32) -> u32 {
    let k = (31 - v.leading_zeros()) / 2;
    let mut x = if k == 0 {
        v
    } else {
        (v >> (k + 1)) + (1u32 << (k - 1)) + 1
    };
    loop {
        let y = (x + v / x) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// `a.saturating_mul(b)` on u64, out of line: a 64-bit multiply with its overflow check is
/// ~100 bytes of Cortex-M code, and the motion core needs it in a dozen places.
#[inline(never)]
pub(crate) fn sat_mul(a: u64, b: u64) -> u64 {
    checked_mul_u64(a, b).unwrap_or(u64::MAX)
}

/// `a.checked_mul(b)` on u64 with a fast path for two 32-bit factors: one 32×32→64-bit
/// multiply (`umull`) on the Cortex-M4 instead of three multiplies and the overflow check
/// (the usual case of the planner's speeds, lengths and accelerations).
#[inline(always)]
fn checked_mul_u64(a: u64, b: u64) -> Option<u64> {
    if (a | b) >> 32 == 0 {
        Some(u64::from(a as u32) * u64::from(b as u32))
    } else {
        a.checked_mul(b)
    }
}

/// `n / d` and `n % d` on u128 (`d` ≠ 0), out of line.
///
/// Every 128-bit division in the core goes through here. Cortex-M has no 128-bit divide and
/// LLVM uses no library call for one on 32-bit Arm: it expands each `/` or `%` on `u128`/`i128`
/// inline into a shift-subtract loop of ~1 KiB, which a dozen call sites made ~10 KiB of the
/// F411's flash. Here: operands that fit 64 bits (the usual case) take the 64-bit division, the
/// rest a binary long division (one compare-and-subtract per quotient bit) written out, a
/// quarter of the expansion's size. The results are those of the operators.
#[inline(never)]
pub(crate) fn divrem_u128(n: u128, d: u128) -> (u128, u128) {
    if let (Ok(n), Ok(d)) = (u64::try_from(n), u64::try_from(d)) {
        return (u128::from(n / d), u128::from(n % d));
    }
    if d > n {
        return (0, n);
    }
    if let Ok(d) = u64::try_from(d) {
        // A 64-bit divisor: two 64-by-32-bit quotient digits instead of a pass per bit.
        let (hi, lo) = ((n >> 64) as u64, n as u64);
        let (q_hi, r_hi) = (hi / d, hi % d);
        let (q_lo, r) = div_128_by_64(r_hi, lo, d);
        return ((u128::from(q_hi) << 64) | u128::from(q_lo), u128::from(r));
    }
    // d > u64::MAX here (n ≥ d). Align d's top bit with n's.
    let shift = d.leading_zeros() - n.leading_zeros();
    let mut d = d << shift;
    let (mut q, mut r) = (0u128, n);
    for _ in 0..=shift {
        q <<= 1;
        if r >= d {
            r -= d;
            q |= 1;
        }
        d >>= 1;
    }
    (q, r)
}

/// `(hi·2⁶⁴ + lo) / d` and its remainder for `hi < d` (the quotient fits in 64 bits): Knuth's
/// algorithm D on 32-bit digits (Hacker's Delight, `divlu`), each quotient digit estimated
/// from a 64-by-32-bit division ([`div_u64`], the Cortex-M4's hardware divider) and corrected
/// at most twice.
fn div_128_by_64(hi: u64, lo: u64, d: u64) -> (u64, u64) {
    const B: u64 = 1 << 32;
    debug_assert!(hi < d);
    let s = d.leading_zeros();
    let d = d << s;
    let (dn1, dn0) = (d >> 32, d & (B - 1));
    let un32 = if s == 0 {
        hi
    } else {
        (hi << s) | (lo >> (64 - s))
    };
    let un10 = lo << s;
    let (un1, un0) = (un10 >> 32, un10 & (B - 1));
    let digit = |un: u64, low: u64| {
        let mut q = div_u64(un, dn1);
        let mut rhat = un - q * dn1;
        while q >= B || q * dn0 > (rhat << 32) + low {
            q -= 1;
            rhat += dn1;
            if rhat >= B {
                break;
            }
        }
        q
    };
    let q1 = digit(un32, un1);
    let un21 = (un32 << 32)
        .wrapping_add(un1)
        .wrapping_sub(q1.wrapping_mul(d));
    let q0 = digit(un21, un0);
    let r = (un21 << 32)
        .wrapping_add(un0)
        .wrapping_sub(q0.wrapping_mul(d))
        >> s;
    ((q1 << 32) | q0, r)
}

/// `a * b` on i128 (overflow as `*`). Out of line for the wide products of the geometry code
/// (cutter compensation, arc centres and lengths): LLVM expands each i128 product inline on the
/// Cortex-M4 (~60-90 bytes for operands it cannot prove to be 64-bit, a call is ~20).
#[inline(never)]
pub(crate) fn mul_i128(a: i128, b: i128) -> i128 {
    a * b
}

/// `n / d` on i128, truncated toward zero like `/` (through [`divrem_u128`]).
#[inline(never)]
pub(crate) fn div_i128(n: i128, d: i128) -> i128 {
    let q = divrem_u128(n.unsigned_abs(), d.unsigned_abs()).0 as i128;
    if (n < 0) != (d < 0) {
        -q
    } else {
        q
    }
}

/// `n.div_euclid(d)` on i128 (the remainder is never negative), through [`divrem_u128`].
#[inline(never)]
pub(crate) fn div_euclid_i128(n: i128, d: i128) -> i128 {
    let q = div_i128(n, d);
    if n - q * d < 0 {
        if d > 0 {
            q - 1
        } else {
            q + 1
        }
    } else {
        q
    }
}

/// The greatest common divisor of `a` and `b` (`a` when `b` is 0), by Stein's binary method
/// (no division).
pub(crate) fn gcd_u64(mut a: u64, mut b: u64) -> u64 {
    if a == 0 || b == 0 {
        return a | b;
    }
    let shift = (a | b).trailing_zeros();
    a >>= a.trailing_zeros();
    loop {
        b >>= b.trailing_zeros();
        if a > b {
            core::mem::swap(&mut a, &mut b);
        }
        b -= a;
        if b == 0 {
            return a << shift;
        }
    }
}

/// ⌊√v⌋ of a 128-bit value.
pub(crate) fn isqrt_u128(v: u128) -> u128 {
    if v <= u64::MAX as u128 {
        return isqrt_u64(v as u64) as u128;
    }
    let bits = 128 - v.leading_zeros();
    let mut x = 1u128 << bits.div_ceil(2);
    loop {
        let y = (x + divrem_u128(v, x).0) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// ⌊n / d⌋ for `d ≠ 0`, using the Cortex-M4's 32-bit divider where the operands allow.
///
/// A 64-by-64 division is a ~250-instruction library call on ARMv7-M; with a 32-bit divisor this
/// runs Hacker's Delight `divlu` (two 16-bit quotient digits on the hardware `udiv`) instead.
#[inline]
pub(crate) fn div_u64(n: u64, d: u64) -> u64 {
    debug_assert!(d != 0);
    if d > u32::MAX as u64 {
        return n / d;
    }
    let d = d as u32;
    let hi = (n >> 32) as u32;
    if hi == 0 {
        return ((n as u32) / d) as u64;
    }
    let q_hi = hi / d;
    let r = hi % d;
    ((q_hi as u64) << 32) | divlu(r, n as u32, d) as u64
}

/// `n.div_euclid(d)` for `d > 1` through [`div_u64`] (the signed 64-bit library division is a
/// ~150-instruction call on ARMv7-M).
#[inline]
pub(crate) fn div_floor_i64(n: i64, d: i64) -> i64 {
    debug_assert!(d > 1);
    let d = d as u64;
    if n >= 0 {
        div_u64(n as u64, d) as i64
    } else {
        // ⌊n/d⌋ = −⌈|n|/d⌉; |n| ≤ 2⁶³ and d < 2⁶³, so the sum fits, and the quotient ≤ 2⁶² does too.
        -(div_u64(n.unsigned_abs() + (d - 1), d) as i64)
    }
}

/// Quotient of `(u1·2³² + u0) / v` when `u1 < v` (so it fits 32 bits).
fn divlu(u1: u32, u0: u32, v: u32) -> u32 {
    const B: u32 = 1 << 16;
    let s = v.leading_zeros();
    let v = v << s;
    let (vn1, vn0) = (v >> 16, v & 0xFFFF);
    let un32 = if s == 0 {
        u1
    } else {
        (u1 << s) | (u0 >> (32 - s))
    };
    let un10 = u0 << s;
    let (un1, un0) = (un10 >> 16, un10 & 0xFFFF);
    let mut q1 = un32 / vn1;
    let mut rhat = un32 - q1 * vn1;
    while q1 >= B || (q1 as u64) * (vn0 as u64) > ((rhat as u64) << 16 | un1 as u64) {
        q1 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    let un21 = (((un32 as u64) << 16 | un1 as u64) - (q1 as u64) * (v as u64)) as u32;
    let mut q0 = un21 / vn1;
    rhat = un21 - q0 * vn1;
    while q0 >= B || (q0 as u64) * (vn0 as u64) > ((rhat as u64) << 16 | un0 as u64) {
        q0 -= 1;
        rhat += vn1;
        if rhat >= B {
            break;
        }
    }
    (q1 << 16) | q0
}

/// ⌊a × b / c⌋ without overflow (64-bit fast path); saturates at `u64::MAX`.
pub fn mul_div(a: u64, b: u64, c: u64) -> u64 {
    debug_assert!(c != 0);
    match checked_mul_u64(a, b) {
        Some(p) => div_u64(p, c),
        None => {
            let q = divrem_u128(a as u128 * b as u128, c as u128).0;
            q.min(u64::MAX as u128) as u64
        }
    }
}

/// ⌈a × b / c⌉ without overflow; saturates at `u64::MAX`.
pub fn mul_div_ceil(a: u64, b: u64, c: u64) -> u64 {
    match checked_mul_u64(a, b) {
        Some(p) => div_u64(p.saturating_add(c - 1), c),
        None => {
            let (q, r) = divrem_u128(a as u128 * b as u128, c as u128);
            (q + u128::from(r != 0)).min(u64::MAX as u128) as u64
        }
    }
}

/// Angle of the vector (x, y) in binary-angle units, in (−½ turn, ½ turn].
pub(crate) fn atan2(y: i64, x: i64) -> i64 {
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
    angle += vector(x, y, &ATAN_TABLE);
    if angle > HALF_TURN {
        angle -= TURN;
    }
    angle
}

/// One radian in the interpreter's angle unit (2⁻⁴⁸ rad).
pub const RAD: i64 = 1 << 48;
/// π in 2⁻⁴⁸ rad.
pub const PI_RAD: i64 = 884_279_719_003_555;

/// atan(2⁻ⁱ) in 2⁻⁴⁸ rad.
const ATAN_TABLE_RAD: [i64; 48] = [
    221069929750889,
    130505199945453,
    68955363498242,
    35002819193903,
    17569333089919,
    8793231387230,
    4397688649582,
    2198978517948,
    1099506035422,
    549755114839,
    274877819563,
    137438942549,
    68719475371,
    34359738197,
    17179869163,
    8589934589,
    4294967296,
    2147483648,
    1073741824,
    536870912,
    268435456,
    134217728,
    67108864,
    33554432,
    16777216,
    8388608,
    4194304,
    2097152,
    1048576,
    524288,
    262144,
    131072,
    65536,
    32768,
    16384,
    8192,
    4096,
    2048,
    1024,
    512,
    256,
    128,
    64,
    32,
    16,
    8,
    4,
    2,
];

/// CORDIC vectoring: turns (x, y) (x ≥ 0) onto the positive x axis by the angles of `table`
/// (`atan(2⁻ⁱ)` in the caller's unit) and returns the angle turned, i.e. the angle of (x, y).
/// The vector grows by the CORDIC gain (×1.65): the callers scale it to leave room for that.
fn vector(mut x: i128, mut y: i128, table: &[i64]) -> i64 {
    let mut angle = 0i64;
    for (i, step) in table.iter().enumerate() {
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
    angle
}

/// atan2(y, x) in 2⁻⁴⁸ rad, in (−π, π]; 0 for the zero vector.
pub fn atan2_rad(y: i128, x: i128) -> i64 {
    if y == 0 {
        return if x < 0 { PI_RAD } else { 0 };
    }
    let m = x.unsigned_abs().max(y.unsigned_abs());
    let bits = 128 - m.leading_zeros();
    // Normalise into [2⁵⁷, 2⁵⁸): full precision, and room for the CORDIC gain within i64.
    let (mut x, mut y) = if bits > 58 {
        let shift = bits - 58;
        ((x >> shift) as i64, (y >> shift) as i64)
    } else {
        let shift = 58 - bits;
        ((x << shift) as i64, (y << shift) as i64)
    };
    let mut angle: i64 = 0;
    if x < 0 {
        if y >= 0 {
            (x, y) = (y, -x);
            angle = PI_RAD / 2;
        } else {
            (x, y) = (-y, x);
            angle = -PI_RAD / 2;
        }
    }
    angle += vector(x.into(), y.into(), &ATAN_TABLE_RAD);
    if angle <= -PI_RAD {
        angle += 2 * PI_RAD;
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

/// Xorshift64 random numbers for the core's exhaustive-comparison tests (each test its own seed).
#[cfg(test)]
pub(crate) struct XorShift(pub u64);

#[cfg(test)]
impl XorShift {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::XorShift;

    #[test]
    fn divrem_u128_is_the_division() {
        let mut rng = XorShift(0xBB67_AE85_84CA_A73B);
        for _ in 0..200_000 {
            let n = (u128::from(rng.next()) << 64 | u128::from(rng.next())) >> (rng.next() % 128);
            let d = (u128::from(rng.next()) << 64 | u128::from(rng.next())) >> (rng.next() % 128);
            if d == 0 {
                continue;
            }
            assert_eq!(super::divrem_u128(n, d), (n / d, n % d), "{n} / {d}");
        }
        for (n, d) in [
            (u128::MAX, 1),
            (u128::MAX, u64::MAX as u128),
            (1 << 64, 3),
            (u128::MAX, 1 << 63),
        ] {
            assert_eq!(super::divrem_u128(n, d), (n / d, n % d), "{n} / {d}");
        }
    }

    #[test]
    fn gcd_u64_divides_both_and_leaves_coprime_quotients() {
        let mut rng = XorShift(0x853C_49E6_748F_EA9B);
        for _ in 0..2_000 {
            let k = 1 + rng.next() % 1_000_000;
            let (a, b) = (k * (rng.next() % 10_000_000), k * (rng.next() % 10_000_000));
            let g = super::gcd_u64(a, b);
            if a == 0 && b == 0 {
                assert_eq!(g, 0);
                continue;
            }
            assert!(a % g == 0 && b % g == 0, "{a} {b} {g}");
            assert_eq!(super::gcd_u64(a / g, b / g), 1, "{a} {b} {g}");
        }
        assert_eq!(super::gcd_u64(5_000_000_000_000, 200_000_000), 200_000_000);
    }

    #[test]
    fn div_floor_i64_is_div_euclid() {
        use super::div_floor_i64;
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D);
        for i in 0..200_000u32 {
            let x = rng.next();
            let n = (x as i64) >> (i % 64);
            let d = ((x.rotate_left(17) >> (i % 63 + 1)) as i64).max(2);
            for (n, d) in [(n, d), (n, 3), (-n, 2 * 781_250), (n.saturating_sub(1), d)] {
                assert_eq!(div_floor_i64(n, d), n.div_euclid(d), "{n} / {d}");
            }
        }
        for (n, d) in [
            (i64::MIN, 2),
            (i64::MIN + 1, 3),
            (i64::MAX, 2),
            (-1, 2),
            (-2, 2),
        ] {
            assert_eq!(div_floor_i64(n, d), n.div_euclid(d), "{n} / {d}");
        }
    }

    #[test]
    fn isqrt_u64_is_the_floor_square_root() {
        use super::isqrt_u64;
        let is_floor = |v: u64| {
            let x = isqrt_u64(v) as u128;
            x * x <= v as u128 && (x + 1) * (x + 1) > v as u128
        };
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        for i in 0..200_000u64 {
            let x = rng.next();
            // Every magnitude, squares and their neighbours.
            let v = x >> (i % 64);
            let r = (v >> 32).max(1);
            for v in [v, r * r, r * r - 1, r * r + 1] {
                assert!(is_floor(v), "isqrt_u64({v}) = {}", isqrt_u64(v));
            }
        }
        for v in [
            u64::MAX,
            u64::MAX - 1,
            (u32::MAX as u64) * (u32::MAX as u64),
            (u32::MAX as u64) * (u32::MAX as u64) - 1,
            1 << 32,
            (1 << 32) + 1,
            u32::MAX as u64,
            1 << 62,
            (1 << 62) - 1,
        ] {
            assert!(is_floor(v), "isqrt_u64({v}) = {}", isqrt_u64(v));
        }
    }

    #[test]
    fn the_128_bit_division_is_the_operators() {
        use super::{div_euclid_i128, div_i128, divrem_u128};
        let mut x = 0x9E37_79B9_7F4A_7C15_F39C_C060_5CED_C834u128;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for i in 0..200_000u32 {
            // Mixed widths: each operand cut to a random number of bits.
            let n = next() >> (next() % 128);
            let d = (next() >> (next() % 128)).max(1);
            assert_eq!(divrem_u128(n, d), (n / d, n % d), "{n} / {d}");
            // Every sign combination (the operands as i128, kept off i128::MIN).
            let (sn, sd) = ((n >> 1) as i128, ((d >> 1) as i128).max(1));
            let sn = if i % 2 == 0 { sn } else { -sn };
            let sd = if i % 3 == 0 { -sd } else { sd };
            assert_eq!(div_i128(sn, sd), sn / sd, "{sn} / {sd}");
            assert_eq!(div_euclid_i128(sn, sd), sn.div_euclid(sd), "{sn} / {sd}");
        }
        for (n, d) in [
            (u128::MAX, 1),
            (u128::MAX, u128::MAX),
            (u128::MAX - 1, u128::MAX),
            (1u128 << 64, 3),
        ] {
            assert_eq!(divrem_u128(n, d), (n / d, n % d));
        }
    }

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
        for k in 0..64 {
            for v in [
                (1u64 << k) - 1,
                1u64 << k,
                (1u64 << k) + 1,
                (1u64 << k) / 3 * 2,
            ] {
                let r = isqrt_u64(v) as u128;
                assert!(r * r <= v as u128 && (r + 1) * (r + 1) > v as u128, "{v}");
            }
        }
        let v = u128::MAX / 3;
        let r = isqrt_u128(v);
        assert!(r * r <= v && (r + 1) * (r + 1) > v);
    }

    #[test]
    fn fast_division_matches_native() {
        let mut rng = XorShift(0x1234_5678_9abc_def0);
        let mut next = || rng.next();
        for i in 0..200_000 {
            let n = next() >> (i % 64);
            let d = (next() >> (32 + i % 32)).max(1);
            assert_eq!(div_u64(n, d), n / d, "{n} / {d}");
            let d = next().max(1);
            assert_eq!(div_u64(n, d), n / d, "{n} / {d}");
        }
        for (n, d) in [
            (u64::MAX, 1),
            (u64::MAX, u32::MAX as u64),
            (u64::MAX, 3),
            (1 << 63, 0x8000_0001),
        ] {
            assert_eq!(div_u64(n, d), n / d);
        }
    }

    #[test]
    fn square_roots_of_random_values() {
        let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
        for i in 0..100_000 {
            let v = rng.next() >> (i % 64);
            let r = isqrt_u64(v) as u128;
            assert!(
                r * r <= v as u128 && (r + 1) * (r + 1) > v as u128,
                "{v} -> {r}"
            );
        }
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
