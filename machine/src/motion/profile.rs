//! Speed profile of the block being executed: ramp, cruise, ramp, with exact time at any point.
//!
//! A profile starts at path position `s0` (nm into the block) with speed `v0` and has three
//! phases: a first ramp (up or down) to `vm`, a cruise at `vm`, and a final deceleration to `v3`
//! at `s3`. Because acceleration is constant in each ramp, the time at any position is closed-form
//! (`Δv / a` in ramps, `Δs / v` in the cruise), so segment times never accumulate rounding error.
//! Speeds are nm/s, accelerations nm/s², times kernel timer counts.

use crate::arith::{div_u64, isqrt_u64, mul_div, sat_mul};
use crate::step::kernel::KERNEL_TIMER_HZ;

const HZ: u64 = KERNEL_TIMER_HZ as u64;

/// A three-phase speed profile over `[s0, s3]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Profile {
    pub s0: u64,
    pub v0: u64,
    pub accel: u64,
    /// End of the first ramp and the speed reached there.
    pub s1: u64,
    pub vm: u64,
    /// Start of the final deceleration.
    pub s2: u64,
    /// End of the profile and the speed there.
    pub s3: u64,
    pub v3: u64,
    t1: u64,
    t2: u64,
}

fn ramp_len(v_hi_sq: u64, v_lo_sq: u64, two_a: u64) -> u64 {
    let d = v_hi_sq.saturating_sub(v_lo_sq);
    if d == 0 {
        0
    } else {
        div_u64(d - 1, two_a) + 1
    }
}

impl Profile {
    /// An empty profile (at rest at the start of a block).
    pub const ZERO: Profile = Profile {
        s0: 0,
        v0: 0,
        accel: 1,
        s1: 0,
        vm: 0,
        s2: 0,
        s3: 0,
        v3: 0,
        t1: 0,
        t2: 0,
    };

    /// Profile from `(s0, v0)` to the block end `length`, cruising at `vc` at most and ending at
    /// `exit_sq` at most. Exits are lowered when the block is too short to reach them and raised
    /// only when it is too short to shed `v0` (after an override cut).
    pub fn plan(s0: u64, v0: u64, length: u64, vc: u64, exit_sq: u64, accel: u64) -> Self {
        let mut p = Profile::ZERO;
        p.replan(s0, v0, length, vc, exit_sq, accel);
        p
    }

    /// [`Self::plan`] in place: segment prep (`motion/prep.rs`) re-plans its profile at every
    /// block start, and building it where it lives saves two 80-byte copies on the MCU.
    pub(crate) fn replan(
        &mut self,
        s0: u64,
        v0: u64,
        length: u64,
        vc: u64,
        exit_sq: u64,
        accel: u64,
    ) {
        let two_a = accel.saturating_mul(2);
        let rem = length.saturating_sub(s0);
        let gain = sat_mul(two_a, rem);
        let (v0sq, vcsq) = (v0 * v0, vc * vc);
        let vxsq = exit_sq.min(vcsq);
        // √(vc²) is vc: the square root only when the exit limit is below the cruise speed.
        let vx = if exit_sq >= vcsq { vc } else { isqrt_u64(vxsq) };
        *self = Profile {
            s0,
            v0,
            accel,
            s1: s0,
            vm: v0,
            s2: s0,
            s3: length,
            v3: vx,
            t1: 0,
            t2: 0,
        };
        let p = self;
        let d1 = ramp_len(v0sq.max(vcsq), v0sq.min(vcsq), two_a);
        let d3 = ramp_len(vcsq, vxsq, two_a);
        if d1.saturating_add(d3) <= rem {
            p.s1 = s0 + d1;
            p.vm = vc;
            p.s2 = length - d3;
        } else if v0 <= vc && vxsq >= v0sq.saturating_add(gain) {
            // Too short to reach the exit: accelerate all the way.
            p.vm = isqrt_u64(v0sq.saturating_add(gain)).min(vc);
            p.s1 = length;
            p.s2 = length;
            p.v3 = p.vm;
        } else if vxsq.saturating_add(gain) <= v0sq {
            // Too short to shed v0: decelerate all the way.
            p.v3 = isqrt_u64(v0sq - gain);
        } else {
            // Triangle: accelerate to the peak, then decelerate to the exit.
            let peak_sq = ((gain as u128 + v0sq as u128 + vxsq as u128) / 2) as u64;
            p.vm = isqrt_u64(peak_sq).max(v0).min(vc.max(v0));
            p.s1 = (s0 + ramp_len(peak_sq, v0sq, two_a)).min(length);
            p.s2 = p.s1;
        }
        p.finish();
    }

    /// Feed-hold profile: decelerate from `(s0, v0)` at once; stops inside the block if it can.
    pub fn hold(s0: u64, v0: u64, length: u64, accel: u64) -> Self {
        let two_a = accel.saturating_mul(2);
        let rem = length.saturating_sub(s0);
        let gain = sat_mul(two_a, rem);
        let v0sq = v0 * v0;
        let (s3, v3) = if v0sq <= gain {
            (s0 + div_u64(v0sq, two_a), 0)
        } else {
            (length, isqrt_u64(v0sq - gain))
        };
        let mut p = Profile {
            s0,
            v0,
            accel,
            s1: s0,
            vm: v0,
            s2: s0,
            s3,
            v3,
            t1: 0,
            t2: 0,
        };
        p.finish();
        p
    }

    /// Fills in the times at the first ramp's end and at the cruise's end.
    fn finish(&mut self) {
        self.t1 = self.ramp_time(self.v0, self.vm);
        self.t2 = self.t1
            + if self.s2 > self.s1 {
                mul_div(self.s2 - self.s1, HZ, self.vm.max(1))
            } else {
                0
            };
    }

    fn ramp_time(&self, a: u64, b: u64) -> u64 {
        match a.abs_diff(b) {
            0 => 0,
            dv => mul_div(dv, HZ, self.accel),
        }
    }

    /// Speed at path position `s` (nm/s).
    pub(crate) fn speed_at(&self, s: u64) -> u64 {
        let two_a = self.accel.saturating_mul(2);
        if s <= self.s1 {
            if s <= self.s0 {
                // √(v0²) is v0, within [vm, v0] or [v0, vm] either way: no square root.
                return self.v0;
            }
            let d = sat_mul(two_a, s - self.s0);
            if self.vm >= self.v0 {
                isqrt_u64((self.v0 * self.v0).saturating_add(d)).min(self.vm)
            } else {
                isqrt_u64((self.v0 * self.v0).saturating_sub(d)).max(self.vm)
            }
        } else if s <= self.s2 {
            self.vm
        } else {
            let d = sat_mul(two_a, s - self.s2);
            isqrt_u64((self.vm * self.vm).saturating_sub(d)).max(self.v3)
        }
    }

    /// Time from `s0` to `s`, kernel timer counts.
    pub fn time_at(&self, s: u64) -> u64 {
        self.time_speed_at(s).0
    }

    /// Time from `s0` to `s` (kernel timer counts) and the speed there (nm/s): [`Self::time_at`]
    /// and [`Self::speed_at`] with one square root instead of two in the ramps.
    pub(crate) fn time_speed_at(&self, s: u64) -> (u64, u64) {
        if s <= self.s1 {
            let v = self.speed_at(s);
            (self.ramp_time(self.v0, v), v)
        } else if s < self.s2 {
            (self.t1 + mul_div(s - self.s1, HZ, self.vm.max(1)), self.vm)
        } else if s == self.s2 {
            // The cruise's end (s1 < s2 here): its time is `t2`, without dividing again.
            (self.t2, self.vm)
        } else {
            let v = self.speed_at(s);
            (self.t2 + self.ramp_time(self.vm, v), v)
        }
    }

    /// Time from `s0` to the end of the profile (`s3`), kernel timer counts: the closed-form
    /// duration of a block, which segment prep (`motion/prep.rs`) emits in ~2 ms pieces and host
    /// tools take whole (`Prep::next_block`).
    pub fn duration(&self) -> u64 {
        self.time_at(self.s3)
    }

    /// Highest speed of the profile.
    pub fn peak(&self) -> u64 {
        self.v0.max(self.vm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MM: u64 = 1_000_000;

    #[test]
    fn trapezoid_times() {
        // 0 → 20 mm/s → 0 at 200 mm/s² over 10 mm: ramps of 1 mm / 0.1 s, cruise 8 mm / 0.4 s.
        let p = Profile::plan(0, 0, 10 * MM, 20 * MM, 0, 200 * MM);
        assert_eq!((p.s1, p.s2, p.vm, p.v3), (MM, 9 * MM, 20 * MM, 0));
        assert_eq!(p.time_at(MM), HZ / 10);
        assert_eq!(p.time_at(9 * MM), HZ / 2);
        assert_eq!(p.time_at(10 * MM), HZ * 6 / 10);
        assert_eq!(p.speed_at(MM / 4), 10 * MM);
    }

    #[test]
    fn triangle_and_short_blocks() {
        let p = Profile::plan(0, 0, MM, 20 * MM, 0, 200 * MM);
        // Peak √(200·1) mm/s = 14.14 mm/s at 0.5 mm.
        assert_eq!(p.s1, MM / 2);
        assert!((14_142_000..14_143_000).contains(&p.vm));
        let p = Profile::plan(0, 0, MM, 50 * MM, u64::MAX, 200 * MM);
        assert_eq!(p.v3, 20 * MM);
        let p = Profile::plan(0, 40 * MM, MM, 10 * MM, 0, 200 * MM);
        assert!(p.v3 > 30 * MM, "cannot shed 40 mm/s in 1 mm");
    }

    #[test]
    fn hold_stops_in_v_squared_over_2a() {
        let p = Profile::hold(MM, 20 * MM, 100 * MM, 200 * MM);
        assert_eq!((p.s3, p.v3), (2 * MM, 0));
        assert_eq!(p.time_at(2 * MM), HZ / 10);
        let p = Profile::hold(0, 20 * MM, MM / 2, 200 * MM);
        assert_eq!(p.s3, MM / 2);
        assert!((14_142_000..14_143_000).contains(&p.v3));
    }
}
