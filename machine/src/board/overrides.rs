//! The operator's spindle and coolant overrides (grbl's realtime bytes 0x99-0x9E, 0xA0, 0xA1;
//! docs/grbl.md): a spindle speed override that scales the PWM duty, a spindle stop in a feed
//! hold, and flood/mist toggles. The program's own spindle and coolant state lives in
//! [`Outputs`](super::Outputs); these act on top of it.

use super::mode::{JobPhase, Mode};
use super::Board;
use crate::canon::Spindle;
use crate::motion::pipeline::MotionState;

impl Board {
    /// Spindle speed override in force, percent.
    pub fn spindle_override(&self) -> u16 {
        self.spindle_override
    }

    /// Sets the spindle speed override (clamped to grbl's 10-200 %). It scales the PWM duty of
    /// [`Board::output_levels`]; the programmed rpm (`outputs().rpm`) stays as programmed.
    pub fn set_spindle_override(&mut self, pct: u16) {
        self.spindle_override = pct.clamp(10, 200);
    }

    /// The programmed rpm scaled by the spindle override.
    pub(super) fn overridden_rpm(&self) -> u32 {
        self.outputs
            .rpm
            .saturating_mul(u32::from(self.spindle_override))
            / 100
    }

    /// Flips flood (`flood`) or mist coolant by hand. Only idle, in a running job or in a feed
    /// hold (grbl's Idle/Run/Hold); an M0/M1 or M6 stop, which switched the coolant off, keeps
    /// it off. The program's next M7/M8/M9 sets the coolant again.
    pub fn toggle_coolant(&mut self, flood: bool) {
        let allowed = match self.mode {
            Mode::Idle => true,
            _ => self.feed_held() || matches!(self.machine_job(), Some(JobPhase::Running(_))),
        };
        if allowed {
            let o = &mut self.outputs;
            if flood {
                o.flood = !o.flood;
            } else {
                o.mist = !o.mist;
            }
        }
    }

    /// Spindle stop: only in a feed hold at rest. Switches a running spindle off, or back on
    /// when a spindle stop had switched it off; cycle start (or the feed-hold switch closing)
    /// restores it before the motion resumes (grbl's rule), a job's end forgets it.
    pub fn toggle_spindle_stop(&mut self) {
        if !self.feed_held() || self.motion.state() != MotionState::Held {
            return;
        }
        if self.stopped_spindle.is_some() {
            self.restore_stopped_spindle();
        } else if self.outputs.spindle != Spindle::Off {
            self.stopped_spindle = Some(self.outputs.spindle);
            self.outputs.spindle = Spindle::Off;
        }
    }

    /// Switches the spindle a spindle stop switched off back on.
    pub(super) fn restore_stopped_spindle(&mut self) {
        if let Some(s) = self.stopped_spindle.take() {
            self.outputs.spindle = s;
        }
    }
}

/// Spindle and coolant as the grbl safety door found them (`machine/src/grbl/door.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DoorOutputs {
    spindle: Spindle,
    flood: bool,
    mist: bool,
}

impl Board {
    /// The machine stands still where the door may switch spindle and coolant: idle, or a feed
    /// hold at rest.
    pub fn door_may_switch(&self) -> bool {
        match self.mode {
            Mode::Idle => self.motion.state() == MotionState::Idle,
            _ => self.feed_held() && self.motion.state() == MotionState::Held,
        }
    }

    /// The safety door at rest: spindle and coolant off; returns them for
    /// [`Board::door_restore`]. `None` (nothing switched) unless [`Board::door_may_switch`].
    pub fn door_outputs_off(&mut self) -> Option<DoorOutputs> {
        if !self.door_may_switch() {
            return None;
        }
        let o = &mut self.outputs;
        let was = DoorOutputs {
            spindle: o.spindle,
            flood: o.flood,
            mist: o.mist,
        };
        o.spindle = Spindle::Off;
        o.flood = false;
        o.mist = false;
        Some(was)
    }

    /// Cycle start after the door: spindle and coolant as the door found them (only where
    /// [`Board::door_may_switch`]; the caller then resumes a held job).
    pub fn door_restore(&mut self, was: DoorOutputs) {
        if self.door_may_switch() {
            let o = &mut self.outputs;
            o.spindle = was.spindle;
            o.flood = was.flood;
            o.mist = was.mist;
        }
    }
}
