//! Laser power carried by the motion (docs/laser-plasma.md): in laser mode every line block
//! says what the beam does while it runs ([`LaserPower`]), segment prep turns that into a PWM
//! duty per segment ([`PwmMap::segment_duty`]), and the step kernel latches each segment's duty
//! at its first tick, so the power changes at the exact step where the block or the speed does.
//!
//! A duty of [`KEEP_DUTY`] means "leave the PWM alone": every segment of a machine without laser
//! mode carries it, so a milling spindle's PWM stays the main loop's (board/outputs/mod.rs).

use crate::canon::Spindle;

use crate::step::kernel::KEEP_DUTY;

/// What the beam does during one line block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LaserPower {
    /// Not a laser machine: the block leaves the spindle PWM alone.
    #[default]
    Keep,
    /// Beam off (G0, M5, S0, a jog, a homing or probe move).
    Off,
    /// M3: the duty of S, whatever the speed.
    Constant { rpm: u32 },
    /// M4: the duty of S × current speed ÷ programmed speed.
    Dynamic { rpm: u32 },
}

impl LaserPower {
    /// S scaled by the spindle override `pct` (percent).
    pub fn scaled(self, pct: u16) -> LaserPower {
        let scale =
            |rpm: u32| (u64::from(rpm) * u64::from(pct) / 100).min(u64::from(u32::MAX)) as u32;
        match self {
            _ if pct == 100 => self,
            LaserPower::Constant { rpm } => LaserPower::Constant { rpm: scale(rpm) },
            LaserPower::Dynamic { rpm } => LaserPower::Dynamic { rpm: scale(rpm) },
            other => other,
        }
    }

    /// The power of a program's feed move under spindle state `state` and speed `rpm`.
    pub const fn of(state: Spindle, rpm: u32) -> LaserPower {
        match state {
            _ if rpm == 0 => LaserPower::Off,
            Spindle::Off => LaserPower::Off,
            Spindle::Cw => LaserPower::Constant { rpm },
            Spindle::Ccw => LaserPower::Dynamic { rpm },
        }
    }
}

/// The setup's S → PWM duty map: `min_rpm..=max_rpm` linearly onto `pwm_min..=pwm_max`,
/// clamped at both ends; S0 gives duty 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmMap {
    pub min_rpm: u32,
    pub max_rpm: u32,
    pub pwm_min: u16,
    pub pwm_max: u16,
}

impl PwmMap {
    /// The duty for `rpm` (0 for 0), at most `pwm_max` and below [`KEEP_DUTY`].
    pub fn duty(&self, rpm: u32) -> u16 {
        if rpm == 0 {
            return 0;
        }
        let (lo, hi) = (self.min_rpm, self.max_rpm.max(1));
        let r = rpm.max(lo).min(hi);
        let span = u64::from(self.pwm_max.saturating_sub(self.pwm_min));
        let num = u64::from(r.saturating_sub(lo)) * span;
        let den = u64::from(hi.saturating_sub(lo)).max(1);
        let d = u64::from(self.pwm_min) + (num + den / 2) / den;
        d.min(u64::from(KEEP_DUTY - 1)) as u16
    }

    /// The duty of a segment of a block with power `power` and programmed speed `programmed`
    /// (nm/s) whose average speed is `speed` (nm/s): M4 scales S by `speed ÷ programmed`
    /// (never above S), then maps it like S. Runs in segment prep, never in the interrupt.
    pub(crate) fn segment_duty(&self, power: LaserPower, speed: u64, programmed: u32) -> u16 {
        match power {
            LaserPower::Keep => KEEP_DUTY,
            LaserPower::Off => 0,
            LaserPower::Constant { rpm } => self.duty(rpm),
            LaserPower::Dynamic { rpm } => {
                let programmed = u64::from(programmed.max(1));
                let speed = speed.min(programmed);
                // Rounded to the nearest rpm; a moving segment keeps at least 1 rpm, so the
                // beam stays on (at the low end of the range) while the machine moves.
                let scaled = (u64::from(rpm) * speed + programmed / 2) / programmed;
                let scaled = if speed > 0 { scaled.max(1) } else { 0 };
                self.duty(scaled as u32)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: PwmMap = PwmMap {
        min_rpm: 0,
        max_rpm: 1000,
        pwm_min: 0,
        pwm_max: 1000,
    };

    #[test]
    fn m4_scales_with_the_speed_and_m3_does_not() {
        let m4 = LaserPower::of(Spindle::Ccw, 800);
        let m3 = LaserPower::of(Spindle::Cw, 800);
        assert_eq!(MAP.segment_duty(m4, 50_000, 100_000), 400);
        assert_eq!(MAP.segment_duty(m4, 100_000, 100_000), 800);
        // Above the programmed speed (feed override): never more than S.
        assert_eq!(MAP.segment_duty(m4, 150_000, 100_000), 800);
        assert_eq!(MAP.segment_duty(m4, 0, 100_000), 0);
        assert_eq!(MAP.segment_duty(m3, 1, 100_000), 800);
        assert_eq!(MAP.segment_duty(LaserPower::Off, 100_000, 100_000), 0);
        assert_eq!(
            MAP.segment_duty(LaserPower::Keep, 100_000, 100_000),
            KEEP_DUTY
        );
        assert_eq!(LaserPower::of(Spindle::Ccw, 0), LaserPower::Off);
        assert_eq!(LaserPower::of(Spindle::Off, 500), LaserPower::Off);
    }

    #[test]
    fn the_duty_is_clamped_to_the_s_range() {
        let m = PwmMap {
            min_rpm: 100,
            max_rpm: 1100,
            pwm_min: 50,
            pwm_max: u16::MAX,
        };
        assert_eq!(m.duty(0), 0);
        assert_eq!(m.duty(1), 50);
        assert_eq!(m.duty(5000), KEEP_DUTY - 1);
        let m4 = LaserPower::Dynamic { rpm: 1100 };
        // 1 % of the speed: 11 rpm, below the range's low end: its duty.
        assert_eq!(m.segment_duty(m4, 1, 100), 50);
    }
}
