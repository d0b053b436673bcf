//! Machine model for motion: exact step ratios, per-axis limits and path-blending settings.
//!
//! Speeds are stored in nm/s (or 1e-6 °/s) and accelerations in nm/s², integers throughout.
//! [`MotionConfig::from_setup`] derives the model from the persistent [`crate::setup::Setup`].

use super::laser::PwmMap;
use super::thc::{ThcConfig, THC_AXIS};
use crate::arith::{div_euclid_i128, div_floor_i64};
use crate::setup::Setup;
use crate::units::{Nm, Pos, MAX_AXES, NM_PER_MM};

/// Highest speed the planner represents, nm/s (≈ 257 m/min); keeps squared speeds in a `u64`.
pub(crate) const MAX_SPEED: u64 = u32::MAX as u64;

/// One axis of the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisConfig {
    /// `steps` motor steps move the axis `units` nanometres (exact ratio, the GIXA controller's "Ratiometric Steps").
    pub steps: u32,
    pub units: Nm,
    /// Highest speed, nm/s.
    pub max_rate: u64,
    /// Acceleration, nm/s².
    pub accel: u64,
    /// Jerk limit, nm/s³ (0: none, the trapezoid).
    pub jerk: u64,
    /// Speed reachable instantly from rest (the GIXA controller's "Starting Speed"), nm/s.
    pub start_speed: u64,
    /// Soft-limit box in machine coordinates, nm.
    pub travel_min: Nm,
    pub travel_max: Nm,
}

impl AxisConfig {
    /// 3200 steps per 5 mm, 3000 mm/min, 200 mm/s², start 60 mm/min, travel ±300 mm.
    pub const DEFAULT: AxisConfig = AxisConfig {
        steps: 3200,
        units: 5 * NM_PER_MM,
        max_rate: 50 * NM_PER_MM as u64,
        accel: 200 * NM_PER_MM as u64,
        jerk: 0,
        start_speed: NM_PER_MM as u64,
        travel_min: -300 * NM_PER_MM,
        travel_max: 300 * NM_PER_MM,
    };

    /// The step whose centre is nearest to `nm` (exact rational conversion, ties round up).
    pub fn nm_to_steps(&self, nm: Nm) -> i64 {
        let steps = self.steps as i64;
        let units = self.units;
        match nm.checked_mul(2 * steps) {
            Some(p) if units > 0 => div_floor_i64(p + units, 2 * units),
            Some(p) => (p + units).div_euclid(2 * units),
            None => div_euclid_i128(
                nm as i128 * 2 * steps as i128 + units as i128,
                2 * units as i128,
            ) as i64,
        }
    }

    /// Position in nm of a whole step count (rounded to the nearest nm).
    pub fn steps_to_nm(&self, steps: i64) -> Nm {
        let s = self.steps as i128;
        div_euclid_i128(steps as i128 * self.units as i128 * 2 + s, 2 * s) as Nm
    }
}

/// The motion model of the whole machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MotionConfig {
    /// Axes in use (X Y Z A B C order); moves on other axes are ignored.
    pub axis_count: u8,
    pub axes: [AxisConfig; MAX_AXES],
    /// grbl junction deviation, nm (0 = stop at every corner).
    pub junction_deviation: Nm,
    /// Vector-speed jump the steppers take at any junction (the GIXA controller's "Feed Shift"), nm/s: a corner
    /// runs at the larger of this jump's speed and junction deviation's; 0 = junction deviation alone.
    pub feed_shift: u64,
    /// Largest chord-to-arc error, nm (default 0.002 mm).
    pub chord_tolerance: Nm,
    /// Largest angle of one arc chord, millidegrees (0 = no limit; `gixa` "Segment Angle").
    pub arc_segment_angle_mdeg: u32,
    /// Most chords per arc (0 = no limit); overrides both tolerances (`gixa` "Max Segments").
    pub arc_max_segments: u32,
    /// Path tolerance `G64` without P blends with, nm (0 = off: junction deviation alone).
    pub blend_tolerance: Nm,
    /// Reject moves that leave the travel box.
    pub soft_limits: bool,
    /// Laser mode's S → PWM map (docs/laser-plasma.md); `None`: not a laser machine.
    pub laser: Option<PwmMap>,
    /// Torch height control in Z steps (docs/laser-plasma.md "Plasma"); `None`: none.
    pub thc: Option<ThcConfig>,
}

impl Default for MotionConfig {
    fn default() -> Self {
        MotionConfig {
            axis_count: 3,
            axes: [AxisConfig::DEFAULT; MAX_AXES],
            junction_deviation: 10_000,
            feed_shift: NM_PER_MM as u64,
            chord_tolerance: 2_000,
            arc_segment_angle_mdeg: 0,
            arc_max_segments: 0,
            blend_tolerance: 0,
            soft_limits: true,
            laser: None,
            thc: None,
        }
    }
}

/// Torch height control's rate and travel in steps of the Z axis `z` (`None` without a torch,
/// without height control or without a Z axis).
fn thc_config(setup: &Setup, z: &AxisConfig) -> Option<ThcConfig> {
    let t = setup.outputs.torch;
    if !(t.on && t.thc) || usize::from(setup.axis_count) <= THC_AXIS {
        return None;
    }
    // nm/min → steps/s, exactly as the axis's ratio: rate · steps / (units · 60).
    let rate =
        i128::from(t.thc_rate.max(0)) * i128::from(z.steps) / (i128::from(z.units.max(1)) * 60);
    Some(ThcConfig {
        rate: rate.clamp(1, i128::from(u32::MAX)) as u32,
        travel: z.nm_to_steps(t.thc_travel.max(0)).min(i64::from(i32::MAX)) as i32,
        anti_dive: t.thc_anti_dive.min(100),
    })
}

fn per_min_to_per_s(v: i64) -> u64 {
    (v.max(0) as u64 / 60).min(MAX_SPEED)
}

impl MotionConfig {
    /// The motion part of the persistent machine setup.
    pub fn from_setup(setup: &Setup) -> Self {
        let mut axes = [AxisConfig::DEFAULT; MAX_AXES];
        for (a, s) in axes.iter_mut().zip(setup.axes.iter()) {
            *a = AxisConfig {
                steps: s.steps.max(1),
                units: s.units_nm.max(1),
                max_rate: per_min_to_per_s(s.max_rate).max(1),
                accel: (s.accel.max(1)) as u64,
                jerk: s.jerk.max(0) as u64,
                start_speed: per_min_to_per_s(s.start_speed),
                travel_min: s.travel_min,
                travel_max: s.travel_max,
            };
        }
        MotionConfig {
            axis_count: setup.axis_count.max(1).min(MAX_AXES as u8),
            axes,
            junction_deviation: setup.path.junction_deviation.max(0),
            feed_shift: per_min_to_per_s(setup.path.feed_shift),
            chord_tolerance: setup.path.chord_tolerance.max(1),
            arc_segment_angle_mdeg: setup.path.arc_segment_angle_mdeg,
            arc_max_segments: setup.path.arc_max_segments,
            blend_tolerance: setup.path.blend_tolerance.max(0),
            soft_limits: true,
            laser: setup.outputs.laser.then_some(PwmMap {
                min_rpm: setup.outputs.spindle_min_rpm,
                max_rpm: setup.outputs.spindle_max_rpm,
                pwm_min: setup.outputs.pwm_min,
                pwm_max: setup.outputs.pwm_max,
            }),
            thc: thc_config(setup, &axes[THC_AXIS]),
        }
    }

    /// The axis count as an index bound the compiler knows is within `MAX_AXES` (loops over the
    /// axes then index without bounds checks).
    pub(crate) fn axis_count_in_bounds(&self) -> usize {
        usize::from(self.axis_count).min(MAX_AXES)
    }

    /// Step position of a machine position (exact rational conversion per axis). Out of line:
    /// its few callers (position changes, not the per-line path) share one copy.
    #[inline(never)]
    pub fn to_steps(&self, p: &Pos) -> [i64; MAX_AXES] {
        let mut s = [0; MAX_AXES];
        for i in 0..self.axis_count_in_bounds() {
            s[i] = self.axes[i].nm_to_steps(p[i]);
        }
        s
    }

    /// Machine position (nm) of a step position.
    pub fn to_nm(&self, s: &[i64; MAX_AXES]) -> Pos {
        let mut p = [0; MAX_AXES];
        for i in 0..self.axis_count_in_bounds() {
            p[i] = self.axes[i].steps_to_nm(s[i]);
        }
        p
    }

    /// First axis whose travel box `p` leaves, if soft limits are on.
    pub(crate) fn travel_violation(&self, p: &Pos) -> Option<usize> {
        if !self.soft_limits {
            return None;
        }
        (0..self.axis_count_in_bounds())
            .find(|&i| p[i] < self.axes[i].travel_min || p[i] > self.axes[i].travel_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_is_exact_over_long_travel() {
        let a = AxisConfig::DEFAULT; // 640 steps/mm
        assert_eq!(a.nm_to_steps(5_000_000), 3200);
        assert_eq!(a.nm_to_steps(10_000 * NM_PER_MM), 6_400_000);
        assert_eq!(a.nm_to_steps(-5_000_000), -3200);
        // 1 step = 1562.5 nm: ties round up.
        assert_eq!(a.nm_to_steps(781), 0);
        assert_eq!(a.nm_to_steps(782), 1);
        let odd = AxisConfig {
            steps: 3000,
            units: 78_816_200, // 3.103 in
            ..a
        };
        assert_eq!(odd.nm_to_steps(78_816_200 * 1000), 3_000_000);
        assert_eq!(odd.steps_to_nm(3000), 78_816_200);
    }

    #[test]
    fn from_default_setup() {
        let c = MotionConfig::from_setup(&Setup::default());
        assert_eq!(c.axis_count, 3);
        assert_eq!(c.axes[0].max_rate, 50_000_000);
        assert_eq!(c.chord_tolerance, 2_000);
    }
}
