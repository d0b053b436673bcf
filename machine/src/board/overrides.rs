//! The operator's overrides of the program: feed override (host or potentiometer), rapid
//! override, the spindle speed override that scales the PWM duty, the spindle stop in a feed
//! hold, flood/mist toggles (grbl's realtime bytes 0x90-0x9E, 0xA0, 0xA1; docs/grbl.md), the run
//! switches (dry run, single block) and the grbl safety door's spindle and coolant switching. The
//! program's own spindle and coolant state lives in [`OutputState`](super::outputs::OutputState);
//! these act on top of it.

use super::inputs::operator::RunSwitches;
use super::mode::{JobPhase, Mode};
use super::outputs::DoorOutputs;
use super::Board;
use crate::motion::pipeline::MotionState;

/// The overrides in force.
pub(super) struct Overrides {
    /// Feed override (host or potentiometer), percent, clamped to 10-200.
    feed: u16,
    /// The potentiometer's last reading, percent: a host override stays until the knob is turned.
    fro_pot: Option<u16>,
    /// Spindle speed override, percent, clamped to 10-200.
    spindle: u16,
    /// Dry run and single block.
    pub(super) switches: RunSwitches,
}

impl Overrides {
    /// 100 %, switches off.
    #[inline(always)]
    pub(super) const fn new() -> Self {
        Overrides {
            feed: 100,
            fro_pot: None,
            spindle: 100,
            switches: RunSwitches {
                dry_run: false,
                single_block: false,
            },
        }
    }

    /// Feed override in force, percent.
    pub(super) fn feed(&self) -> u16 {
        self.feed
    }

    /// Spindle speed override in force, percent.
    pub(super) fn spindle(&self) -> u16 {
        self.spindle
    }

    /// The potentiometer reads `pct`: true when that is a new reading (it then applies).
    pub(super) fn pot_moved(&mut self, pct: u16) -> bool {
        if self.fro_pot == Some(pct) {
            return false;
        }
        self.fro_pot = Some(pct);
        true
    }
}

impl Board {
    /// Feed-rate override in force, percent.
    pub fn feed_override(&self) -> u16 {
        self.overrides.feed()
    }

    pub fn set_feed_override(&mut self, pct: u16) {
        self.overrides.feed = pct.max(10).min(200);
        self.motion.set_feed_override(pct);
    }

    pub(crate) fn set_rapid_override(&mut self, pct: u16) {
        self.motion.set_rapid_override(pct);
    }

    /// Spindle speed override in force, percent.
    pub fn spindle_override(&self) -> u16 {
        self.overrides.spindle
    }

    /// Sets the spindle speed override (clamped to grbl's 10-200 %). It scales the PWM duty of
    /// [`Board::output_levels`] (in laser mode: of the segments prepared from now on, never above
    /// the S range); the programmed rpm (`outputs().rpm`) stays as programmed.
    pub fn set_spindle_override(&mut self, pct: u16) {
        self.overrides.spindle = pct.clamp(10, 200);
    }

    /// Dry run on or off (only while idle): feed moves at `operator.dry_run_feed`, spindle and
    /// coolant untouched, M-code lists flagged `dry_run_disabled` skipped.
    pub fn set_dry_run(&mut self, on: bool) -> bool {
        if !matches!(self.mode, Mode::Idle) {
            return false;
        }
        self.overrides.switches.dry_run = on;
        true
    }

    /// Single block on or off (any time): the job stops after each block until cycle start.
    pub fn set_single_block(&mut self, on: bool) {
        self.overrides.switches.single_block = on;
    }

    /// Flips flood (`flood`) or mist coolant by hand. Only idle, in a running job or in a feed
    /// hold (grbl's Idle/Run/Hold); an M0/M1 or M6 stop, which switched the coolant off, keeps
    /// it off. The program's next M7/M8/M9 sets the coolant again.
    pub(crate) fn toggle_coolant(&mut self, flood: bool) {
        let allowed = match self.mode {
            Mode::Idle => true,
            _ => self.feed_held() || matches!(self.machine_job(), Some(JobPhase::Running(_))),
        };
        if allowed {
            self.outputs.toggle_coolant(flood);
        }
    }

    /// Spindle stop: only in a feed hold at rest. Switches a running spindle off, or back on
    /// when a spindle stop had switched it off; cycle start (or the feed-hold switch closing)
    /// restores it before the motion resumes (grbl's rule), a job's end forgets it.
    pub(crate) fn toggle_spindle_stop(&mut self) {
        if !self.feed_held() || self.motion.state() != MotionState::Held {
            return;
        }
        self.outputs.toggle_spindle_stop();
    }

    /// The machine stands still where the door may switch spindle and coolant: idle, or a feed
    /// hold at rest.
    pub(crate) fn door_may_switch(&self) -> bool {
        match self.mode {
            Mode::Idle => self.motion.state() == MotionState::Idle,
            _ => self.feed_held() && self.motion.state() == MotionState::Held,
        }
    }

    /// The safety door at rest: spindle and coolant off; returns them for
    /// [`Board::door_restore`]. `None` (nothing switched) unless [`Board::door_may_switch`].
    pub(crate) fn door_outputs_off(&mut self) -> Option<DoorOutputs> {
        if !self.door_may_switch() {
            return None;
        }
        Some(self.outputs.door_off())
    }

    /// Cycle start after the door: spindle and coolant as the door found them (only where
    /// [`Board::door_may_switch`]; the caller then resumes a held job).
    pub(crate) fn door_restore(&mut self, was: DoorOutputs) {
        if self.door_may_switch() {
            self.outputs.door_restore(was);
        }
    }
}
