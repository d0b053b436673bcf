//! A limit switch still pressed (docs/controller.md "Limit switches"): after a hard limit the
//! machine stands on its switch, which is disarmed so it does not trip again at once, and so
//! cannot stop motion further into it. Until it releases the board refuses an unlock and a homing
//! cycle (error 905: the operator hears why and what to do) and any motion toward it; the one
//! motion it takes is a host jog off the switch, allowed from alarm 1 and alarm 11 as from Idle,
//! which returns to the alarm it came from. As grbl's "unlock, then jog off the switch", without
//! the moment in which the unlocked machine could be driven further into it.

use super::{Board, LIMIT_BITS};
use crate::board::inputs::{LIMIT_MAX_BIT, LIMIT_MIN_BIT};
use crate::board::state::AlarmCode;
use crate::units::{Pos, MAX_AXES};

/// Error code of a request refused while a limit switch is pressed: jog the axis off it first.
pub const ERROR_LIMIT_PRESSED: u16 = 905;

impl Board {
    /// The installed limit switches (hard limits on) that are pressed now, as limit input bits:
    /// the debounced levels, and the switches disarmed by the last hard limit (pressed then, not
    /// released since; they may not show in the debounced levels yet).
    pub(crate) fn pressed_limits(&self) -> u32 {
        let i = &self.setup.inputs;
        if !i.hard_limits {
            return 0;
        }
        let installed =
            (u32::from(i.limit_min) << LIMIT_MIN_BIT) | (u32::from(i.limit_max) << LIMIT_MAX_BIT);
        (self.sensed.levels.0 | self.sensed.disarmed_bits()) & installed & LIMIT_BITS
    }

    /// Whether a move from `from` to `to` goes toward a pressed switch (on an axis whose max
    /// switch is pressed, any positive motion; min switch, negative).
    pub(super) fn toward_pressed(&self, from: &Pos, to: &Pos) -> bool {
        let pressed = self.pressed_limits();
        (0..MAX_AXES).any(|i| {
            let (min, max) = (
                pressed >> (LIMIT_MIN_BIT as usize + i) & 1 != 0,
                pressed >> (LIMIT_MAX_BIT as usize + i) & 1 != 0,
            );
            (max && to[i] > from[i]) || (min && to[i] < from[i])
        })
    }

    /// A jog from `from` to `to` was accepted (it moves away from every pressed switch): the
    /// pressed switches of its axes are disarmed until they release, so a switch the machine
    /// stood on at power-up does not stop the jog that takes it off.
    pub(super) fn jogging_off(&mut self, from: &Pos, to: &Pos) {
        let axes = (0..MAX_AXES).fold(0u32, |m, i| {
            if to[i] != from[i] {
                m | 1 << (LIMIT_MIN_BIT as usize + i) | 1 << (LIMIT_MAX_BIT as usize + i)
            } else {
                m
            }
        });
        let bits = self.pressed_limits() & axes;
        if bits != 0 {
            self.sensed.disarm(bits);
        }
    }

    /// The alarm a jog from `from` to `to` may leave to jog off a pressed switch: alarm 1 (hard
    /// limit) or 11 (homing required) while a switch is pressed, for a move of only the axes of
    /// pressed switches, each away from its switch.
    pub(super) fn jog_off_from(&self, from: &Pos, to: &Pos) -> Option<AlarmCode> {
        let code = self.alarm()?;
        let pressed = self.pressed_limits();
        if pressed == 0
            || !matches!(code, AlarmCode::HardLimit | AlarmCode::HomingRequired)
            || self.toward_pressed(from, to)
        {
            return None;
        }
        let axis_pressed = |i: usize| {
            pressed >> (LIMIT_MIN_BIT as usize + i) & 1 != 0
                || pressed >> (LIMIT_MAX_BIT as usize + i) & 1 != 0
        };
        let only_those = (0..MAX_AXES).all(|i| to[i] == from[i] || axis_pressed(i));
        only_those.then_some(code)
    }
}
