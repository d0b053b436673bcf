//! Jerk-limited speed tracking along the path: segment preparation (`motion/prep.rs`) runs it
//! when every axis in use has a jerk limit (`[axis.X] jerk`).
//!
//! The planner's trapezoid (`motion/planner.rs`, `motion/profile.rs`) stays the speed
//! *envelope*: junction speeds, cruise caps and the stop at the end of what is buffered. A
//! [`Tracker`] follows it in time, one prep segment (`dt` = 2 ms, `motion/prep.rs`'s
//! `SEGMENT_COUNTS`) at a time, with an acceleration that is linear inside each step and changes
//! by at most `J·dt` per step, so the acceleration is continuous and `|jerk| ≤ J` along the path,
//! across junctions (the ramps span blocks: nothing forces the acceleration to zero at a block
//! boundary).
//!
//! Braking looks ahead with the jerk-limited ramp itself: for every speed limit `w` at path
//! position `d` ahead, [`brake_distance`] is the length of the shortest jerk-limited deceleration
//! from the current speed and acceleration that ends at `w` with zero acceleration (jerk `-J`
//! down to at most `-A`, a constant `-A` stretch if needed, jerk `+J` back to 0). Each step takes
//! the highest new acceleration for which every such distance still fits before its point and
//! the speed, once the acceleration is released, stays under the cruise cap. Following the
//! deceleration ramp itself keeps the distance test true, so a state that can stop in what is
//! buffered stays one that can; adding blocks only raises the envelope.
//!
//! Kinematics are exact integers: speeds in pm/s, accelerations in nm/s², positions in
//! [`SUB`]-ths of a nm, so one step's `Δv = (a + a')·dt/2` and
//! `Δs = v·dt + (2a + a')·dt²/6` have no rounding at all (`dt` = 1/500 s). Braking distances
//! are rounded up and carry a small margin.

use crate::arith::{divrem_u128, isqrt_u128, mul_div};
use crate::step::kernel::KERNEL_TIMER_HZ;

/// Position sub-units per nm: `Δs = v·dt + (2a + a')·dt²/6` is a whole number of them for
/// speeds in pm/s and accelerations in nm/s² at `dt` = 1/500 s.
pub const SUB: u64 = 3_000_000;

/// Steps per second (`dt` = 2 ms, prep's segment duration).
pub const STEPS_PER_SECOND: u64 = 500;

/// Rounding margin added to every braking distance, nm.
const MARGIN_NM: u64 = 6;

/// At rest this close to a stop (nm) the tracker has arrived: moving on would take a ramp
/// shorter than the braking distances' margin (prep's last segment of a block ends on its
/// exact step count whatever the nm).
pub const ARRIVED_NM: u64 = 4 * MARGIN_NM;

/// Acceleration and jerk limits along the path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// nm/s², at least 1.
    pub accel: u64,
    /// nm/s³, at least [`STEPS_PER_SECOND`] (so one step may change the acceleration).
    pub jerk: u64,
}

impl Limits {
    /// Largest change of acceleration in one step, nm/s².
    pub fn step_accel(&self) -> u64 {
        (self.jerk / STEPS_PER_SECOND).max(1)
    }
}

/// A speed limit ahead on the path: at most `speed` (pm/s) at position `at` (nm) (a junction,
/// or 0 at the end of what is buffered), and the cruise cap `cap` (pm/s) of the block after it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limit {
    pub at: u64,
    pub speed: u64,
    pub cap: u64,
}

fn ceil_div(n: u128, d: u128) -> u128 {
    let (q, r) = divrem_u128(n, d);
    if r == 0 {
        q
    } else {
        q + 1
    }
}

/// Distance (nm, rounded up) of a constant-jerk phase from speed `v` (pm/s) and acceleration `a0`
/// changing by `da` (nm/s², of the jerk's sign) at `|jerk| = j`:
/// `Δs = v·t + a0·t²/2 + j·t³/6` with `t = |da|/j`.
fn jerk_phase(v: u64, a0: i128, da: i128, j: u64) -> u128 {
    if da == 0 {
        return 0;
    }
    // ⌈(6·v·|da|·J/1000 + 3·a0·da² + da³) / (6·J²)⌉ (the v term in pm/s), whose one-fraction
    // numerator overflows 128 bits at the settings' limits (2 m/s, 10 m/s², 10⁶ mm/s³): each
    // term divided on its own, `v·|da|/(1000J)` and `da²·(3a0 + da)/(6J²)`, and their two
    // remainders, under `6000·J²` together, add at most 2.
    let j = j as i128;
    let per_mille = 1000 * j;
    let speed = i128::from(v) * da.abs();
    let (q1, r1) = (speed / per_mille, speed % per_mille);
    let cube = da * da * (3 * a0 + da);
    let six_j2 = 6 * j * j;
    let q2 = crate::arith::div_euclid_i128(cube, six_j2);
    let r2 = cube - q2 * six_j2;
    let rest = 6 * j * r1 + 1000 * r2;
    let den = 1000 * six_j2;
    let up = if rest == 0 {
        0
    } else if rest <= den {
        1
    } else {
        2
    };
    (q1 + q2 + up).max(0) as u128
}

/// `k·d / 1000` rounded toward zero (as `i128` division rounds), split at `d`'s thousands so
/// that no 128-bit division is left: `divrem_u128` takes a loop pass per quotient bit, some 70
/// here, where the remainder's share is a 64-bit division by 1000 (hardware-assisted while
/// `k·999` fits in 64 bits: jerk limits under 1.8·10¹⁶ nm/s³, the setting's limit is 10¹⁵).
fn times_per_mille(k: u64, d: i128) -> i128 {
    let (q, r) = (d.unsigned_abs() / 1000, (d.unsigned_abs() % 1000) as u64);
    let m = i128::from(k) * q as i128 + i128::from(mul_div(k, r, 1000));
    if d < 0 {
        -m
    } else {
        m
    }
}

/// Length (nm) of the shortest jerk-limited deceleration from speed `v` (pm/s) and acceleration
/// `a` (nm/s²) to speed `w` (pm/s) with zero acceleration, under `lim`. 0 when no braking is
/// needed (releasing the acceleration ends at or under `w`). A state that is already bound to
/// end under `w` (decelerating too hard to settle at `w`) returns the length of releasing the
/// acceleration at once, which ends below `w`; for `w` = 0 such a state cannot stop within the
/// jerk limit at all: `u64::MAX`.
pub fn brake_distance(v: u64, a: i64, w: u64, lim: Limits) -> u64 {
    let (big_a, j) = (lim.accel as i128, lim.jerk as i128);
    let a = a as i128;
    let (vi, wi) = (v as i128, w as i128);
    // Speeds below are in pm/s: a²/(2J) nm/s is 1000·a²/(2J) pm/s.
    let release = 1000 * a * a / (2 * j);
    if a >= 0 && vi + release <= wi {
        return 0;
    }
    if a <= 0 && vi <= wi {
        return 0;
    }
    let d = if a < 0 && vi - wi < release {
        if w == 0 {
            // Bound to stop with the acceleration still negative: not a jerk-limited stop.
            return u64::MAX;
        }
        // Bound to end under `w`: release now.
        jerk_phase(v, a, -a, lim.jerk)
    } else {
        // Deepest acceleration m of the ramp: (a² − 2m²)/(2J) = −(v − w), at most A.
        let m_sq = (a * a + times_per_mille(2 * lim.jerk, v as i128 - w as i128)) / 2;
        let full = m_sq >= big_a * big_a;
        let m = if full {
            big_a
        } else {
            isqrt_u128(m_sq.max(0) as u128) as i128
        };
        // Phase 1: a → −m at jerk −J; its end speed vb.
        let s1 = jerk_phase(v, a, -(a + m), lim.jerk);
        let vb = vi + 1000 * (a * a - m * m) / (2 * j);
        // Phase 3 starts at vc = w + m²/(2J).
        let vc = wi + 1000 * m * m / (2 * j);
        let s2 = if full && vb > vc {
            // Constant −A from vb to vc: (vb² − vc²)/(2A), speeds in pm/s.
            ceil_div((vb * vb - vc * vc) as u128, (2 * big_a * 1_000_000) as u128)
        } else {
            0
        };
        let s3 = jerk_phase(vc.max(0) as u64, -m, m, lim.jerk);
        s1 + s2 + s3
    };
    (d.min(u64::MAX as u128 / 2) as u64).saturating_add(MARGIN_NM)
}

/// Speed (pm/s) reached by releasing acceleration `a` at once at jerk `J`: `v + a²/(2J)` when
/// accelerating.
pub fn release_speed(v: u64, a: i64, lim: Limits) -> u64 {
    if a <= 0 {
        return v;
    }
    let a = a as u128;
    v.saturating_add((1000 * a * a / (2 * lim.jerk as u128)) as u64)
}

/// Speed (pm/s) under the cap at which a tracker with no acceleration cruises: what the
/// search's rounding leaves of the ramp onto the cap (about 1.6 µm/s at 5,000 mm/s³).
const CRUISE_SLACK: u64 = 10_000_000;

/// Acceleration (nm/s²) under which a tracker at the cap cruises (the search's rounding leaves
/// about 0.004 mm/s² at 5,000 mm/s³).
const CRUISE_ACCEL: u64 = 10_000_000;

/// Path advance ([`SUB`]-ths of a nm) of one step per pm/s at constant speed.
const CRUISE_SUB_PER_PM_S: u64 = SUB / (STEPS_PER_SECOND * 1000);
const _: () = assert!(CRUISE_SUB_PER_PM_S * STEPS_PER_SECOND * 1000 == SUB);

/// Kernel timer counts of one whole step.
pub const STEP_COUNTS: u64 = KERNEL_TIMER_HZ as u64 / STEPS_PER_SECOND;

/// One step's result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Duration, kernel timer counts: [`STEP_COUNTS`], less for the step that comes to rest.
    pub counts: u64,
    /// Path advance, [`SUB`]-ths of a nm.
    pub ds: u64,
    /// Speed (pm/s) and acceleration (nm/s²) at the step's end.
    pub v: u64,
    pub a: i64,
    /// True when no acceleration kept every limit (the envelope cannot be met from here); the
    /// step then brakes as hard as allowed.
    pub forced: bool,
}

/// The jerk-limited state along the path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tracker {
    /// Path position, [`SUB`]-ths of a nm.
    pub s: u64,
    /// Speed, pm/s.
    pub v: u64,
    /// Acceleration, nm/s².
    pub a: i64,
}

impl Tracker {
    /// Path position, nm (rounded down).
    pub(crate) fn position_nm(&self) -> u64 {
        self.s / SUB
    }

    /// Room to the nearest stop (a limit of speed 0) ahead, [`SUB`]-ths of a nm.
    fn room(&self, limits: &[Limit]) -> u64 {
        limits
            .iter()
            .filter(|l| l.speed == 0)
            .map(|l| (l.at * SUB).saturating_sub(self.s))
            .min()
            .unwrap_or(u64::MAX)
    }

    /// The state after one step made of `pieces`: (length, jerk sign) with lengths in
    /// `1/(2q)`-ths of the step summing to `2q` (`q` = one step's acceleration change at full
    /// jerk), if the speed stays ≥ 0. Over `n` units at jerk sign `j` the doubled acceleration
    /// `a2 = 2a` changes by `j·n`, the speed scaled by `4q` (`V = 4q·v`, v in pm/s) by
    /// `2·a2·n + j·n²`, and the position scaled by `4q²` (sub-units) by
    /// `3·V·n + 3·a2·n² + j·n³`: `v·t + a·t²/2 + J·t³/6` at `t = n·dt/(2q)`, `J = q/dt`.
    fn pieces(&self, q: i64, pieces: &[(i128, i128)]) -> Option<Tracker> {
        let q = i128::from(q);
        let mut a2 = 2 * i128::from(self.a);
        let mut big_v = 4 * q * i128::from(self.v);
        let mut ds = 0i128;
        for &(n, j) in pieces {
            if n <= 0 {
                continue;
            }
            ds += 3 * big_v * n + 3 * a2 * n * n + j * n * n * n;
            big_v += 2 * a2 * n + j * n * n;
            a2 += j * n;
            if big_v < 0 {
                return None;
            }
        }
        // Truncating by 4q and then by q is truncating by 4q² (two 64-bit divisors, see
        // `jerk_phase`).
        let ds = crate::arith::div_i128(crate::arith::div_i128(ds, 4 * q), q);
        if ds < 0 {
            return None;
        }
        Some(Tracker {
            s: self.s + ds as u64,
            v: crate::arith::div_i128(big_v, 4 * q) as u64,
            a: (a2 / 2) as i64,
        })
    }

    /// The state after one step to acceleration `a1` (within `q` of the current one) in the
    /// shape of the braking ramp's corners, which fall inside steps: moving away from 0 the
    /// acceleration changes at full jerk first and then holds `a1` (reaching `−A`), and so
    /// it does reaching 0 (ending a release at its speed); moving towards 0 without reaching
    /// it, it holds first and changes at the end (starting a release). Whole steps are one ramp
    /// either way.
    fn advance(&self, a1: i64, q: i64) -> Option<Tracker> {
        let (a, d, q2) = (
            i128::from(self.a),
            i128::from(a1 - self.a),
            2 * i128::from(q),
        );
        let ramp = 2 * d.abs();
        let j = d.signum();
        if a1 != 0 && ((a < 0 && d > 0) || (a > 0 && d < 0)) {
            self.pieces(q, &[(q2 - ramp, 0), (ramp, j)])
        } else {
            self.pieces(q, &[(ramp, j), (q2 - ramp, 0)])
        }
    }

    /// The hardest-braking step to `a1` (within `q` of the current acceleration): down at full
    /// jerk, at most to `−A`, then up to `a1` (the braking ramp's turn from deepening to
    /// releasing, inside a step).
    fn advance_turn(&self, a1: i64, q: i64, big_a: i64) -> Option<Tracker> {
        let (a, a1, q, big_a) = (
            i128::from(self.a),
            i128::from(a1),
            i128::from(q),
            i128::from(big_a),
        );
        // Down n1 units then up n3 (2q in all): a − n1/2 + n3/2 = a1.
        let (mut n1, mut n3) = (q - (a1 - a), q + (a1 - a));
        let mut n2 = 0;
        if 2 * a - n1 < -2 * big_a {
            n1 = 2 * (a + big_a);
            n3 = 2 * (a1 + big_a);
            n2 = 2 * q - n1 - n3;
        }
        if n1 < 0 || n3 < 0 || n2 < 0 {
            return None;
        }
        self.pieces(q as i64, &[(n1, -1), (n2, 0), (n3, 1)])
    }

    /// How far (nm) the braking distance of state `t` to the most binding limit ahead exceeds
    /// the room to it (≤ 0 when all fit); `i128::MAX` when one cannot be met smoothly.
    fn excess(t: &Tracker, limits: &[Limit], lim: Limits) -> i128 {
        let here = t.position_nm();
        limits
            .iter()
            .filter(|l| l.at > here)
            .map(|l| match brake_distance(t.v, t.a, l.speed, lim) {
                u64::MAX => i128::MAX,
                d => i128::from(d) - i128::from(l.at - here),
            })
            .max()
            .unwrap_or(i128::MIN)
    }

    /// How far the step from speed `v0` to state `t` misses speed cap `cap` (pm/s) and the
    /// limits (≤ 0 when it keeps them all): the ones ahead must still be braked for (braking
    /// distance less room, nm), the ones the step passed must have been passed under their speed
    /// (inside one step the speed is within a few nm/s of its ends' highest) and the block after
    /// them entered under its cap (pm/s); `i128::MAX` when one ahead cannot be met smoothly.
    /// Rising with the step's end acceleration (braking distances and release speeds grow with
    /// it), which [`highest_fit`] relies on.
    fn miss(v0: u64, t: &Tracker, cap: u64, limits: &[Limit], lim: Limits) -> i128 {
        let release = i128::from(release_speed(t.v, t.a, lim));
        let here = t.position_nm();
        let mut worst = release - i128::from(cap);
        for l in limits {
            let m = if l.at <= here {
                (i128::from(v0.max(t.v)) - i128::from(l.speed)).max(release - i128::from(l.cap))
            } else {
                match brake_distance(t.v, t.a, l.speed, lim) {
                    u64::MAX => return i128::MAX,
                    d => i128::from(d) - i128::from(l.at - here),
                }
            };
            worst = worst.max(m);
        }
        worst
    }

    /// Moves to `next`, one whole step on.
    fn commit(&mut self, next: Tracker) -> Step {
        let ds = next.s - self.s;
        *self = next;
        Step {
            counts: STEP_COUNTS,
            ds,
            v: next.v,
            a: next.a,
            forced: false,
        }
    }

    /// Advances one step: the highest acceleration within one step's change that keeps the cap
    /// `cap` (pm/s) of the block the step starts in and every limit in `limits` (the junctions'
    /// own limits ahead of the current position, not the trapezoid's backward pass, which
    /// would force zero acceleration at every lowered junction; the last one the stop at the
    /// end of the buffer). When no acceleration fits (the rounding of a braking distance, by a
    /// few nm, while following the ramp exactly) the step brakes as hard as still stops
    /// smoothly, and never passes a stop.
    pub fn step(&mut self, cap: u64, limits: &[Limit], lim: Limits) -> Step {
        if self.v <= lim.step_accel() / 4 && self.room(limits) <= ARRIVED_NM * SUB {
            // At rest on a stop (to the braking distances' margin, and a speed under a quarter
            // of one step's change at full jerk from rest): stay there. What is left of the
            // speed and acceleration (at most one step's change) is dropped over one step.
            let counts = if self.a == 0 && self.v == 0 {
                0
            } else {
                STEP_COUNTS
            };
            self.v = 0;
            self.a = 0;
            return Step {
                counts,
                ds: 0,
                v: 0,
                a: 0,
                forced: false,
            };
        }
        let da = lim.step_accel() as i64;
        let big_a = lim.accel as i64;
        let step = |a1: i64| self.advance(a1, da);
        if self.a.unsigned_abs() <= CRUISE_ACCEL && self.v <= cap && cap - self.v <= CRUISE_SLACK {
            // Cruising at the cap (within the search's rounding): any more acceleration would
            // release above it, so none is the highest that fits, without a search.
            let cruise = if self.a == 0 {
                Some(Tracker {
                    s: self.s + self.v * CRUISE_SUB_PER_PM_S,
                    ..*self
                })
            } else {
                step(0)
            };
            if let Some(t) = cruise.filter(|t| Self::miss(self.v, t, cap, limits, lim) <= 0) {
                return self.commit(t);
            }
        }
        // Within the acceleration limit, or (after the limit dropped: a block of a lower path
        // acceleration came into reach) back towards it at full jerk.
        let lo = (self.a - da).max((-big_a).min(self.a + da));
        let hi = (self.a + da).min(big_a.max(self.a - da));
        // Acceleration `a1` leaves a state that can still stop within the jerk limit (no
        // braking distance is infinite); true from some acceleration up.
        let smooth = |a1: i64| {
            step(a1).is_some_and(|t| {
                let here = t.position_nm();
                limits
                    .iter()
                    .all(|l| l.at <= here || brake_distance(t.v, t.a, l.speed, lim) < u64::MAX)
            })
        };
        // The lowest such acceleration within the step's range, asked for only when holding
        // the acceleration does not fit.
        let floor = || lowest_true(lo, hi, &smooth);
        // Highest `a1` in [from, hi] whose step `shape` fits (fits are an interval reaching
        // down to `from` when `from` fits: braking distances grow with the acceleration). The
        // first guesses are `hi` and holding the acceleration, the last step's choice, which
        // the answer is usually within a few units of (steady braking for the end of the
        // buffer): three probes then, where the whole range takes five or six.
        let highest = |from: &dyn Fn() -> Option<i64>, shape: &dyn Fn(i64) -> Option<Tracker>| {
            let miss =
                |a1: i64| shape(a1).map_or(i128::MAX, |t| Self::miss(self.v, &t, cap, limits, lim));
            let at_hi = miss(hi);
            if at_hi <= 0 {
                return Some(hi);
            }
            let hold = self.a.clamp(lo, hi);
            let at_hold = if hold < hi { miss(hold) } else { at_hi };
            if at_hold <= 0 {
                return Some(highest_fit((hold, at_hold), (hi, at_hi), &miss));
            }
            let from = from()?;
            let at_from = miss(from);
            let upper = if from < hold {
                (hold, at_hold)
            } else {
                (hi, at_hi)
            };
            (at_from <= 0).then(|| highest_fit((from, at_from), upper, &miss))
        };
        let natural = |a1: i64| step(a1);
        let turn = |a1: i64| self.advance_turn(a1, da, big_a);
        let chosen = match highest(&floor, &natural) {
            Some(a1) => step(a1),
            // The braking ramp turns inside this step: the step deepens and releases.
            None => highest(&|| Some(lo), &turn).and_then(|a1| self.advance_turn(a1, da, big_a)),
        };
        if let Some(next) = chosen {
            return self.commit(next);
        }
        if self.a < 0 && step(hi).is_none() {
            // Every acceleration within one step's change reaches 0 inside the step: the
            // release ramp ends here. The acceleration rises linearly to 0 over
            // τ = 2v/|a| (jerk a²/2v, within J for a state that can stop: `brake_distance`),
            // covering v·τ/3.
            let (v, a) = (u128::from(self.v), u128::from(self.a.unsigned_abs()));
            let ds = ((2 * v * v / a) as u64).min(self.room(limits));
            // τ = 2v/|a| s with v in pm/s: 2v/(1000·|a|) s.
            let counts = mul_div(2 * self.v, KERNEL_TIMER_HZ as u64, 1000 * a as u64).max(1);
            self.s += ds;
            self.v = 0;
            self.a = 0;
            return Step {
                counts: counts.min(STEP_COUNTS),
                ds,
                v: 0,
                a: 0,
                forced: false,
            };
        }
        let forced = true;
        // Nothing fits (the braking distances' rounding, a few nm, while following the ramp):
        // of the hardest braking that still stops smoothly in either shape, the one that comes
        // closest.
        let turn_floor = {
            let smooth_turn = |a1: i64| {
                self.advance_turn(a1, da, big_a)
                    .is_some_and(|t| Self::excess(&t, limits, lim) < i128::MAX)
            };
            lowest_true(lo, hi, &smooth_turn)
        };
        let by_turn = turn_floor.and_then(|a1| self.advance_turn(a1, da, big_a));
        let by_ramp = floor().and_then(step);
        let pick = match (by_ramp, by_turn) {
            (Some(r), Some(t)) => {
                if Self::excess(&t, limits, lim) < Self::excess(&r, limits, lim) {
                    Some(t)
                } else {
                    Some(r)
                }
            }
            (r, t) => r.or(t),
        };
        if let Some(next) = pick {
            let ds = (next.s - self.s).min(self.room(limits));
            *self = Tracker {
                s: self.s + ds,
                ..next
            };
            return Step {
                counts: STEP_COUNTS,
                ds,
                v: next.v,
                a: next.a,
                forced,
            };
        }
        let a1 = hi;
        // Even that reverses: stop here (not reached from a state that fits, see above).
        let next = step(a1).unwrap_or(Tracker {
            s: self.s,
            v: 0,
            a: 0,
        });
        // The rounding of braking distances may leave a few nm too little room: a stop is never
        // passed, the step ends on it.
        let ds = (next.s - self.s).min(self.room(limits));
        *self = Tracker {
            s: self.s + ds,
            ..next
        };
        Step {
            counts: STEP_COUNTS,
            ds,
            v: next.v,
            a: next.a,
            forced,
        }
    }
}

/// The lowest `x` in `[lo, hi]` with `holds(x)`, for `holds` false below some point and true
/// from it on (`None` when it does not hold at `hi`), by halving.
fn lowest_true(lo: i64, hi: i64, holds: &dyn Fn(i64) -> bool) -> Option<i64> {
    if holds(lo) {
        return Some(lo);
    }
    if !holds(hi) {
        return None;
    }
    let (mut l, mut h) = (lo, hi);
    while h - l > 1 {
        let mid = l + (h - l) / 2;
        if holds(mid) {
            h = mid;
        } else {
            l = mid;
        }
    }
    Some(h)
}

/// The highest `x` in `[l, h)` with `miss(x) ≤ 0`, given `miss(l) ≤ 0 < miss(h)` and `miss`
/// rising through 0 once: false position with the Illinois rule (the end kept twice in a row
/// has its value halved, so both ends close in), every other probe a halving when the bracket
/// did not at least halve, which bounds it at twice the halving search's probes. On the
/// tracker's searches it takes about a quarter fewer (each probe is a step and a braking
/// distance per limit, in 128-bit arithmetic the Cortex-M4 does in software; the test
/// `the_false_position_search_finds_the_bound_the_halving_search_finds`).
fn highest_fit(l: (i64, i128), h: (i64, i128), miss: &dyn Fn(i64) -> i128) -> i64 {
    let ((mut l, mut ml), (mut h, mut mh)) = (l, h);
    if ml == 0 || ml == -1 {
        return l;
    }
    // Which end the last probe replaced: -1 low, 1 high.
    let mut last = 0i8;
    let mut halve = false;
    while h - l > 1 {
        let width = h - l;
        let x = if halve || mh == i128::MAX || ml == 0 {
            l + width / 2
        } else {
            // Where the line through both ends crosses 0, both values scaled into 30 bits.
            let (below, above) = ((-ml) as u128, mh as u128);
            let shift = (128 - (below | above).leading_zeros()).saturating_sub(30);
            let (below, above) = ((below >> shift) as u64, (above >> shift) as u64);
            let off = crate::arith::mul_div(width as u64, below, (below + above).max(1)) as i64;
            (l + off).clamp(l + 1, h - 1)
        };
        let m = miss(x);
        if m == 0 || m == -1 {
            // On the bound to the nm (or pm/s), which is all a miss resolves: a higher `x`
            // could only meet it as closely.
            return x;
        }
        if m <= 0 {
            if last == -1 {
                mh = (mh / 2).max(1);
            }
            (l, ml, last) = (x, m, -1);
        } else {
            if last == 1 {
                ml /= 2;
            }
            (h, mh, last) = (x, m, 1);
        }
        halve = !halve && (h - l) * 2 > width;
    }
    l
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::arith::XorShift;
    use crate::motion::profile::Profile;
    use std::vec;
    use std::vec::Vec;

    const MM: u64 = 1_000_000;
    /// 200 mm/s², 5,000 mm/s³.
    const LIM: Limits = Limits {
        accel: 200 * MM,
        jerk: 5_000 * MM,
    };

    /// Brakes with explicit phases at 2 µs steps and measures the distance, nm: the tracker's
    /// exact kinematics at a 1,000× finer step (speeds in fm/s, positions in thirds of 10⁻¹² nm).
    fn brake_numeric(v: u64, a: i64, w: u64, lim: Limits) -> u64 {
        let da = (lim.jerk / 500_000) as i128;
        let (j, big_a) = (lim.jerk as i128, lim.accel as i128);
        let (mut v, w, mut a) = (v as i128 * 1000, w as i128 * 1000, a as i128);
        let mut s = 0i128;
        let mut released = false;
        loop {
            if !released && a < 0 && v - 1_000_000 * a * a / (2 * j) <= w {
                released = true;
            }
            let a1 = if released {
                (a + da).min(0)
            } else {
                (a - da).max(-big_a)
            };
            s += 6 * v + 2 * (2 * a + a1);
            v += a + a1;
            a = a1;
            if released && a >= 0 {
                break;
            }
        }
        (s / 3_000_000_000_000) as u64
    }

    #[test]
    fn brake_distance_matches_the_ramp() {
        // From cruise at 50 mm/s to rest: 2·(A²/2J)·… the closed form of the full ramp:
        // jerk 40 ms, −A 210 ms, jerk 40 ms. Distance = v²/(2A) + v·A/(2J) = 6.25 + 1 mm.
        let d = brake_distance(50 * MM * 1000, 0, 0, LIM);
        assert!(d.abs_diff(7_250_000) <= MARGIN_NM + 3, "{d}");
        let cases = [
            (50 * MM * 1000, 0i64, 0u64),
            (50 * MM * 1000, 150 * MM as i64, 10 * MM * 1000),
            (20 * MM * 1000, -100 * MM as i64, 0),
            (3 * MM * 1000, 0, 0),
            (30 * MM * 1000, 200 * MM as i64, 29 * MM * 1000),
        ];
        for (v, a, w) in cases {
            let d = brake_distance(v, a, w, LIM);
            let n = brake_numeric(v, a, w, LIM);
            assert!(d.abs_diff(n) <= 150, "v {v} a {a} w {w}: {d} vs {n}");
        }
    }

    #[test]
    fn the_false_position_search_finds_the_bound_the_halving_search_finds() {
        // Rising misses of the shapes the tracker meets: a quadratic with a plateau at 0 below
        // its root (the cap once rounding hides small accelerations), a square root (a braking
        // distance) and a step in units (two limits of different kinds).
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D);
        let (mut probes, mut halvings) = (0u64, 0u64);
        for case in 0..300 {
            let (l, h) = (
                -((rng.next() % 20_000_000_000) as i64),
                (rng.next() % 20_000_000_000) as i64 + 1,
            );
            let root = l + (rng.next() % (h - l) as u64) as i64;
            let kind = case % 3;
            let miss = |x: i64| -> i128 {
                let d = i128::from(x) - i128::from(root);
                match kind {
                    0 => {
                        if d <= 0 {
                            (d / 1_000_000).min(0)
                        } else {
                            d * d / 1_000_000 + 1
                        }
                    }
                    1 => {
                        let m = crate::arith::isqrt_u128(d.unsigned_abs() * 1_000_000) as i128;
                        if d <= 0 {
                            -m
                        } else {
                            m + 1
                        }
                    }
                    _ => {
                        if d <= 0 {
                            d / 3
                        } else {
                            d * 1000 + 7
                        }
                    }
                }
            };
            let count = core::cell::Cell::new(0u64);
            let counted = |x: i64| {
                count.set(count.get() + 1);
                miss(x)
            };
            let found = highest_fit((l, miss(l)), (h, miss(h)), &counted);
            // The highest that fits, or one on the bound to the unit the miss resolves.
            let m = miss(found);
            assert!(
                m <= 0 && (found == root || m >= -1),
                "case {case}: {found} {m}"
            );
            probes += count.get();
            let (mut a, mut b) = (l, h);
            while b - a > 1 {
                let mid = a + (b - a) / 2;
                halvings += 1;
                if miss(mid) <= 0 {
                    a = mid
                } else {
                    b = mid
                }
            }
            assert_eq!(a, root);
        }
        // These shapes are the false position's worst (a plateau, a cusp, a jump): the halvings
        // interleaved keep it within twice the halving search (the tracker's own searches take
        // about a quarter fewer probes than halving, 17.4 against 23.7 over the random
        // programs of `random_programs_stay_under_the_envelope_and_stop_in_the_buffer`).
        assert!(
            probes <= 2 * halvings + 600,
            "{probes} probes, {halvings} halvings"
        );
    }

    #[test]
    fn jerk_phase_is_the_one_fraction_ceiling() {
        // Where `(6·v·da·J + 1000·(3·a0·da² + da³)) / (6000·J²)` fits in 128 bits, the split
        // sum is its ceiling exactly.
        let mut rng = XorShift(0x3C6E_F372_FE94_F82B);
        let mut checked = 0;
        for _ in 0..50_000 {
            let j = 50_000_000 + rng.next() % 1_000_000_000_000_000;
            let v = rng.next() % 2_000_000_000_000;
            let a0 = (rng.next() % 20_000_000_000) as i128 - 10_000_000_000;
            let da = (rng.next() % 20_000_000_000) as i128 - 10_000_000_000;
            let (ji, vi) = (j as i128, v as i128);
            let js = if da < 0 { -ji } else { ji };
            let num = (6 * vi)
                .checked_mul(da)
                .and_then(|x| x.checked_mul(js))
                .and_then(|x| x.checked_add(1000 * (3 * a0 * da * da + da * da * da)));
            let Some(num) = num else { continue };
            let want = if da == 0 || num <= 0 {
                0
            } else {
                (num as u128).div_ceil((6000 * ji * ji) as u128)
            };
            assert_eq!(
                jerk_phase(v, a0, da, j),
                want,
                "v {v} a0 {a0} da {da} j {j}"
            );
            checked += 1;
        }
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn times_per_mille_is_the_128_bit_division() {
        let mut rng = XorShift(0x6A09_E667_F3BC_C909);
        for _ in 0..20_000 {
            let k = rng.next() >> 4;
            let d = (rng.next() >> (rng.next() % 40)) as i128
                * if rng.next().is_multiple_of(2) { 1 } else { -1 };
            assert_eq!(times_per_mille(k, d), i128::from(k) * d / 1000, "{k} {d}");
        }
    }

    #[test]
    fn no_braking_when_release_ends_under_the_limit() {
        assert_eq!(brake_distance(10 * MM * 1000, 0, 10 * MM * 1000, LIM), 0);
        assert_eq!(
            brake_distance(10 * MM * 1000, -50 * MM as i64, 20 * MM * 1000, LIM),
            0
        );
        assert!(brake_distance(10 * MM * 1000, 100 * MM as i64, 10 * MM * 1000, LIM) > 0);
    }

    /// A block of a test program: length (nm) and cruise cap (nm/s).
    #[derive(Clone, Copy)]
    struct B {
        len: u64,
        cap: u64,
    }

    /// Junction speeds (nm/s) the trapezoid planner would give with all `blocks` buffered:
    /// `raw[k]` caps the speed at the end of block k, the last one is 0.
    fn junctions(blocks: &[B], raw: &[u64], accel: u64) -> Vec<u64> {
        let n = blocks.len();
        let mut w: Vec<u64> = raw.to_vec();
        w[n - 1] = 0;
        for k in 0..n - 1 {
            w[k] = w[k].min(blocks[k].cap).min(blocks[k + 1].cap);
        }
        // Backward: reachable to stop; forward: reachable from rest.
        for k in (0..n - 1).rev() {
            let lim = w[k + 1] * w[k + 1] + 2 * accel * blocks[k + 1].len;
            w[k] = w[k].min(crate::arith::isqrt_u64(lim));
        }
        let mut prev = 0u64;
        for k in 0..n {
            let lim = prev * prev + 2 * accel * blocks[k].len;
            w[k] = w[k].min(crate::arith::isqrt_u64(lim));
            prev = w[k];
        }
        w
    }

    /// The trapezoid's time, kernel timer counts.
    fn trapezoid_counts(blocks: &[B], w: &[u64], accel: u64) -> u64 {
        let mut counts = 0u64;
        let mut v_in = 0;
        for (k, b) in blocks.iter().enumerate() {
            let p = Profile::plan(0, v_in, b.len, b.cap, w[k] * w[k], accel);
            counts += p.duration();
            v_in = w[k];
        }
        counts
    }

    /// Trapezoid envelope speed (nm/s) at path position `s` (nm).
    fn envelope(starts: &[u64], blocks: &[B], w: &[u64], s: u64, accel: u64) -> u64 {
        let mut e = u64::MAX;
        for k in 0..blocks.len() {
            let end = starts[k] + blocks[k].len;
            let v_in = if k == 0 { 0 } else { w[k - 1] };
            if s >= starts[k] && s <= end {
                e = e.min(blocks[k].cap);
            }
            if s <= end {
                e = e.min(crate::arith::isqrt_u64(w[k] * w[k] + 2 * accel * (end - s)));
            }
            if s >= starts[k] {
                e = e.min(crate::arith::isqrt_u64(
                    v_in * v_in + 2 * accel * (s - starts[k]),
                ));
            }
        }
        e
    }

    struct Run {
        /// Kernel timer counts.
        counts: u64,
        max_jerk_step: u64,
        max_accel: u64,
    }

    /// Runs a program through the tracker with `window` blocks buffered (the last buffered one
    /// ends at rest), checking every step against the window's envelope.
    fn run(blocks: &[B], raw: &[u64], window: usize, lim: Limits) -> Run {
        let n = blocks.len();
        let mut starts = vec![0u64; n];
        for k in 1..n {
            starts[k] = starts[k - 1] + blocks[k - 1].len;
        }
        let total = starts[n - 1] + blocks[n - 1].len;
        let mut t = Tracker::default();
        let mut steps = 0u64;
        let (mut max_jerk_step, mut max_accel) = (0u64, 0u64);
        let mut head = 0usize;
        let mut counts = 0u64;
        loop {
            let here = t.position_nm();
            while head < n && starts[head] + blocks[head].len <= here {
                head += 1;
            }
            // At rest on the end: arrived.
            if head >= n || (here + ARRIVED_NM >= total && t.v == 0 && t.a == 0) {
                break;
            }
            let last = (head + window).min(n);
            let w = junctions(&blocks[..last], &raw[..last], lim.accel);
            // The junctions' own limits (and the stop at the window's end), not the trapezoid's
            // passes: the tracker brakes for each with its own ramp, and one that the backward
            // pass lowers for a limit further on is met by braking for that one.
            let limits: Vec<Limit> = (head..last)
                .map(|k| Limit {
                    at: starts[k] + blocks[k].len,
                    speed: if k + 1 == last {
                        0
                    } else {
                        raw[k].min(blocks[k].cap).min(blocks[k + 1].cap) * 1000
                    },
                    cap: blocks.get(k + 1).map_or(0, |b| b.cap * 1000),
                })
                .collect();
            // The cap of the block the step starts in; a lower cap ahead is a junction limit.
            let cap = blocks[head].cap * 1000;
            let a0 = t.a;
            let st = t.step(cap, &limits, lim);
            let jump = st.a.abs_diff(a0);
            max_jerk_step = max_jerk_step.max(jump);
            max_accel = max_accel.max(st.a.unsigned_abs());
            // The acceleration's change per time: within J (rounding: 1 nm/s² per step).
            assert!(
                u128::from(jump) * u128::from(KERNEL_TIMER_HZ)
                    <= (u128::from(lim.jerk) + 500) * u128::from(st.counts),
                "jerk step {jump} in {} counts at {here} nm (a {a0}, v {})",
                st.counts,
                t.v
            );
            counts += st.counts;
            assert!(st.a.unsigned_abs() <= lim.accel);
            let s_nm = t.position_nm();
            let end_of_window = starts[last - 1] + blocks[last - 1].len;
            assert!(
                s_nm <= end_of_window,
                "{s_nm} past the buffer {end_of_window}"
            );
            // Under the window's trapezoid envelope (2 nm/s for rounding).
            let e = envelope(
                &starts[..last],
                &blocks[..last],
                &w,
                s_nm.min(total),
                lim.accel,
            );
            assert!(
                t.v / 1000 <= e + 2,
                "at {s_nm} nm speed {} over the envelope {e}",
                t.v / 1000
            );
            steps += 1;
            assert!(steps < 1_000_000, "no progress at {s_nm} nm");
        }
        assert!(t.position_nm() <= total && t.position_nm() + ARRIVED_NM >= total);
        Run {
            counts,
            max_jerk_step,
            max_accel,
        }
    }

    fn program(rng: &mut XorShift, n: usize) -> (Vec<B>, Vec<u64>) {
        let mut blocks = Vec::new();
        let mut raw = Vec::new();
        for _ in 0..n {
            let len = match rng.next() % 3 {
                0 => 20_000 + rng.next() % 200_000,
                1 => 200_000 + rng.next() % 3 * MM,
                _ => MM + rng.next() % (30 * MM),
            };
            let cap = (5 + rng.next() % 76) * MM;
            blocks.push(B { len, cap });
            raw.push(rng.next() % (60 * MM));
        }
        (blocks, raw)
    }

    #[test]
    fn random_programs_stay_under_the_envelope_and_stop_in_the_buffer() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        for _ in 0..24 {
            let n = 2 + (rng.next() % 14) as usize;
            let (blocks, raw) = program(&mut rng, n);
            let window = 1 + (rng.next() % 8) as usize;
            let r = run(&blocks, &raw, window, LIM);
            assert!(r.max_accel <= LIM.accel);
            assert!(r.max_jerk_step <= LIM.step_accel());
        }
    }

    #[test]
    fn long_moves_cost_little_time() {
        // 3,000 mm/min, 200 mm/s², 5,000 mm/s³ over 20 mm moves stopping at each end.
        let blocks = [B {
            len: 20 * MM,
            cap: 50 * MM,
        }];
        let r = run(&blocks, &[0], 1, LIM);
        let w = junctions(&blocks, &[0], LIM.accel);
        let trap = trapezoid_counts(&blocks, &w, LIM.accel);
        // The jerk-limited ramps add A/J = 40 ms per ramp (two ramps) to 0.65 s: ~1.12×.
        assert!(r.counts * 100 < trap * 114, "{} vs {trap}", r.counts);
        assert!(r.counts > trap);
    }

    #[test]
    fn short_chords_ramp_across_blocks() {
        // A 0.03 mm contour: 1,000 chords of 0.03 mm at 50 mm/s with gentle corners (junction
        // 45 mm/s): the ramps span many blocks, so the time is near the trapezoid's.
        let blocks: Vec<B> = (0..1000)
            .map(|_| B {
                len: 30_000,
                cap: 50 * MM,
            })
            .collect();
        let raw = vec![45 * MM; 1000];
        let w = junctions(&blocks, &raw, LIM.accel);
        let trap = trapezoid_counts(&blocks, &w, LIM.accel);
        let r = run(&blocks, &raw, 1000, LIM);
        // Jerk limiting costs A/J (40 ms) for each of the two ramps of the whole chain, as for
        // one 30 mm move, not a ramp per block (a per-block S-curve, at zero acceleration on
        // every boundary, could not leave 0.03 mm chords above a few mm/s).
        let ramps = 2 * LIM.accel * KERNEL_TIMER_HZ as u64 / LIM.jerk;
        assert!(
            r.counts > trap && r.counts - trap <= ramps + ramps / 20,
            "{} vs {trap}",
            r.counts
        );
    }

    #[test]
    fn a_hold_mid_ramp_stops_within_the_jerk_limit_and_resumes() {
        // One 40 mm move; 24 ms into the ramp up (acceleration still rising) a hold places a
        // stop at the jerk-limited stopping distance: the tracker stops there smoothly, then
        // the hold is released and it goes on to the end.
        let end = Limit {
            at: 40 * MM,
            speed: 0,
            cap: 0,
        };
        let cap = 50 * MM * 1000;
        let q = LIM.step_accel();
        let mut t = Tracker::default();
        for _ in 0..12 {
            t.step(cap, &[end], LIM);
        }
        assert!(
            t.a > 0 && t.a < LIM.accel as i64 && t.v > 0,
            "mid-ramp: {t:?}"
        );
        let hold = Limit {
            at: t.position_nm() + brake_distance(t.v, t.a, 0, LIM),
            speed: 0,
            cap: 0,
        };
        let mut steps = 0;
        loop {
            let a0 = t.a;
            let st = t.step(cap, &[hold, end], LIM);
            assert!(
                st.a.abs_diff(a0) <= q,
                "jerk step {} at {t:?}",
                st.a.abs_diff(a0)
            );
            assert!(t.position_nm() <= hold.at);
            if st.v == 0 && st.a == 0 {
                break;
            }
            steps += 1;
            assert!(steps < 1_000);
        }
        assert!(
            hold.at - t.position_nm() <= ARRIVED_NM,
            "{} short",
            hold.at - t.position_nm()
        );
        // Resumed: on along the path to the end.
        let mut steps = 0;
        while !(t.v == 0 && t.position_nm() + ARRIVED_NM >= end.at) {
            let a0 = t.a;
            let st = t.step(cap, &[end], LIM);
            assert!(st.a.abs_diff(a0) <= q);
            assert!(t.position_nm() <= end.at);
            steps += 1;
            assert!(steps < 10_000);
        }
    }
}
