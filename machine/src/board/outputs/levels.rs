//! Output levels the firmware maps to pins: spindle enable/direction/PWM duty, coolant and the
//! user outputs that M-code and homing command lists switch.
//!
//! Everything is derived from the program's spindle/coolant state and the setup's S → PWM
//! mapping, so the board and its emulation drive identical levels.

use crate::canon::Spindle;
use crate::setup::OutputSetup;

/// The level of every controlled output. [`OutputLevels::SAFE`] is the power-up, alarm and
/// program-stop state (docs/controller.md "Safety rules as built").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputLevels {
    pub spindle_enable: bool,
    /// Counter-clockwise (M4); meaningful while enabled.
    pub spindle_ccw: bool,
    /// PWM duty in timer counts (`0..=setup.outputs.pwm_max`); 0 in laser mode, where the step
    /// interrupt owns the PWM (docs/laser-plasma.md).
    pub spindle_pwm: u16,
    /// Laser mode: the pin drivers leave the PWM to the step interrupt.
    pub laser: bool,
    pub mist: bool,
    pub flood: bool,
    /// User outputs, bit n = output n.
    pub user: u16,
}

impl OutputLevels {
    /// Everything off.
    pub const SAFE: OutputLevels = OutputLevels {
        spindle_enable: false,
        spindle_ccw: false,
        spindle_pwm: 0,
        laser: false,
        mist: false,
        flood: false,
        user: 0,
    };
}

/// PWM duty for `rpm`: `spindle_min_rpm..=spindle_max_rpm` maps linearly onto
/// `pwm_min..=pwm_max` (clamped at both ends); a stopped spindle or S0 gives duty 0.
pub(crate) fn spindle_duty(setup: &OutputSetup, state: Spindle, rpm: u32) -> u16 {
    if state == Spindle::Off || rpm == 0 {
        return 0;
    }
    let (lo, hi) = (setup.spindle_min_rpm, setup.spindle_max_rpm.max(1));
    let r = rpm.max(lo).min(hi);
    let span = u64::from(setup.pwm_max.saturating_sub(setup.pwm_min));
    let num = u64::from(r - lo) * span;
    let den = u64::from(hi - lo).max(1);
    (u64::from(setup.pwm_min) + (num + den / 2) / den) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::setup::Setup;

    #[test]
    fn s_maps_linearly_between_min_and_max_rpm() {
        let mut o = Setup::default().outputs;
        o.spindle_min_rpm = 6000;
        o.spindle_max_rpm = 24_000;
        o.pwm_min = 100;
        o.pwm_max = 1000;
        assert_eq!(spindle_duty(&o, Spindle::Cw, 6000), 100);
        assert_eq!(spindle_duty(&o, Spindle::Cw, 15_000), 550);
        assert_eq!(spindle_duty(&o, Spindle::Ccw, 24_000), 1000);
        assert_eq!(spindle_duty(&o, Spindle::Cw, 1000), 100);
        assert_eq!(spindle_duty(&o, Spindle::Cw, 99_999), 1000);
        assert_eq!(spindle_duty(&o, Spindle::Off, 12_000), 0);
        assert_eq!(spindle_duty(&o, Spindle::Cw, 0), 0);
    }
}
