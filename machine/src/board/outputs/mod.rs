//! The outputs the board drives: spindle, coolant and tool as the program set them
//! ([`Outputs`]), what a stop saved to restore, the spindle a spindle stop switched off, the user
//! output word and its exchange with the step kernel, and the user M-code list switching them at
//! its sync point. The stop/restore rules (docs/controller.md "Outputs", "Safety rules as built")
//! are the methods of [`OutputState`]; when they apply is decided in `board/mod.rs`.

pub mod levels;
pub(crate) mod lists;

use crate::board::inputs::InputBits;
use crate::canon::Spindle;
use crate::setup::{ListCommand, OutputSetup};
use levels::{spindle_duty, OutputLevels};
use lists::{ListRunner, ListStatus};

/// Output levels the controller drives (spindle, coolant, tool), as the program set them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    pub spindle: Spindle,
    pub rpm: u32,
    pub mist: bool,
    pub flood: bool,
    pub tool: u32,
}

impl Outputs {
    /// Everything off: the power-up and program-stop state (docs/controller.md "Safety rules as built").
    pub const SAFE: Outputs = Outputs {
        spindle: Spindle::Off,
        rpm: 0,
        mist: false,
        flood: false,
        tool: 0,
    };

    /// Spindle and coolant off (rpm and tool kept).
    fn spindle_and_coolant_off(&mut self) {
        self.spindle = Spindle::Off;
        self.mist = false;
        self.flood = false;
    }
}

/// Spindle and coolant as the grbl safety door found them (`machine/src/device/grbl/door.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DoorOutputs {
    spindle: Spindle,
    flood: bool,
    mist: bool,
}

/// Every output the board drives, with what its stops saved.
pub(super) struct OutputState {
    /// As the program set them (and the operator's toggles).
    program: Outputs,
    /// Outputs to restore when a stopped program resumes (stop/restore rules, docs/controller.md "Outputs").
    saved: Option<Outputs>,
    /// The spindle a spindle stop switched off in a feed hold, restored by cycle start
    /// (`board/overrides.rs`).
    stopped_spindle: Option<Spindle>,
    /// User outputs (bit n = output n): set by command lists, and by the kernel's on-the-fly
    /// events once [`OutputState::sync_user`] learns of them.
    user: u16,
    /// The user output word last exchanged with the kernel (`None`: the board must load its own,
    /// e.g. the safe state).
    user_loaded: Option<u16>,
    /// A user M-code list running at its sync point.
    list: Option<ListRunner>,
}

impl OutputState {
    /// Everything off, the kernel's word known to be 0 (power-up).
    #[inline(always)]
    pub(super) const fn new() -> Self {
        OutputState {
            program: Outputs::SAFE,
            saved: None,
            stopped_spindle: None,
            user: 0,
            user_loaded: Some(0),
            list: None,
        }
    }

    /// Spindle, coolant and tool as the program (and the operator) set them.
    pub(super) fn program(&self) -> Outputs {
        self.program
    }

    /// M3/M4/M5 at its sync point (a spindle stop is forgotten).
    pub(super) fn set_spindle(&mut self, state: Spindle, rpm: u32) {
        self.stopped_spindle = None;
        self.program.spindle = state;
        self.program.rpm = rpm;
    }

    /// Switches the orient output `output` (a user output) off: the spindle starts again.
    pub(super) fn release_orient(&mut self, output: u8) {
        self.user &= !1u16.checked_shl(u32::from(output)).unwrap_or(0);
    }

    /// M7/M8/M9 at its sync point.
    pub(super) fn set_coolant(&mut self, mist: bool, flood: bool) {
        self.program.mist = mist;
        self.program.flood = flood;
    }

    /// A manual tool change to `tool` (docs/probing.md "Tool change"): spindle and coolant off,
    /// not restored.
    pub(super) fn tool_change(&mut self, tool: u32) {
        self.program.tool = tool;
        self.saved = None;
        self.program.spindle_and_coolant_off();
    }

    /// An M0/M1 or single-block stop (the GIXA controller's stop rule): spindle and coolant off
    /// while stopped, restored on resume.
    pub(super) fn pause(&mut self) {
        self.saved = Some(self.program);
        self.program.spindle_and_coolant_off();
    }

    /// A job held for a lost host, at rest: spindle and coolant off, kept to restore on resume
    /// (nothing happens when a stop saved them already).
    pub(super) fn host_lost_off(&mut self) {
        if self.saved.is_none() {
            self.restore_stopped_spindle();
            self.saved = Some(self.program);
            self.program.spindle_and_coolant_off();
        }
    }

    /// A held job resumes: the spindle a spindle stop switched off comes back, and with
    /// `restore_saved` what a stop saved.
    pub(super) fn resume(&mut self, restore_saved: bool) {
        self.restore_stopped_spindle();
        if restore_saved {
            if let Some(saved) = self.saved.take() {
                self.program = saved;
            }
        }
    }

    /// Switches the spindle a spindle stop switched off back on.
    pub(super) fn restore_stopped_spindle(&mut self) {
        if let Some(s) = self.stopped_spindle.take() {
            self.program.spindle = s;
        }
    }

    /// A job is stopping: nothing is restored any more (an M0 stop's outputs included, a stopped
    /// spindle too) and its M-code list ends.
    pub(super) fn forget_restores(&mut self) {
        self.saved = None;
        self.stopped_spindle = None;
        self.list = None;
    }

    /// The program-stop sequence (docs/controller.md "How a job ends"): spindle and coolant off,
    /// nothing saved to restore; the tool stays, and user outputs stay as the program left them
    /// (alarms switch those off too, [`OutputState::safe`]).
    pub(super) fn program_stop(&mut self) {
        self.program = Outputs {
            tool: self.program.tool,
            ..Outputs::SAFE
        };
        self.saved = None;
        self.stopped_spindle = None;
    }

    /// Everything off (alarms, a new setup): the program-stop sequence and the user outputs.
    pub(super) fn safe(&mut self) {
        self.program_stop();
        self.user = 0;
        // Loaded into the kernel even if the board's word was 0 already: an on-the-fly event
        // may have switched an output since the last exchange.
        self.user_loaded = None;
        self.list = None;
    }

    /// Flips flood (`flood`) or mist coolant by hand.
    pub(super) fn toggle_coolant(&mut self, flood: bool) {
        let o = &mut self.program;
        if flood {
            o.flood = !o.flood;
        } else {
            o.mist = !o.mist;
        }
    }

    /// Spindle stop in a feed hold at rest: switches a running spindle off, or back on when a
    /// spindle stop had switched it off.
    pub(super) fn toggle_spindle_stop(&mut self) {
        if self.stopped_spindle.is_some() {
            self.restore_stopped_spindle();
        } else if self.program.spindle != Spindle::Off {
            self.stopped_spindle = Some(self.program.spindle);
            self.program.spindle = Spindle::Off;
        }
    }

    /// The safety door: spindle and coolant off; returns them for [`OutputState::door_restore`].
    pub(super) fn door_off(&mut self) -> DoorOutputs {
        let o = &mut self.program;
        let was = DoorOutputs {
            spindle: o.spindle,
            flood: o.flood,
            mist: o.mist,
        };
        o.spindle = Spindle::Off;
        o.flood = false;
        o.mist = false;
        was
    }

    /// Spindle and coolant as the door found them.
    pub(super) fn door_restore(&mut self, was: DoorOutputs) {
        let o = &mut self.program;
        o.spindle = was.spindle;
        o.flood = was.flood;
        o.mist = was.mist;
    }

    /// Starts the user M-code list `commands` at its sync point.
    pub(super) fn run_list(&mut self, commands: &[ListCommand]) {
        self.list = Some(ListRunner::new(commands));
    }

    /// One step of the user M-code list, if one runs (`None` otherwise); a finished list is
    /// dropped.
    pub(super) fn step_list(&mut self, now_ms: u32, levels: InputBits) -> Option<ListStatus> {
        let list = self.list.as_mut()?;
        let status = list.step(now_ms, levels, &mut self.user);
        if status == ListStatus::Done {
            self.list = None;
        }
        Some(status)
    }

    /// The user output word, for a homing cycle's command lists to switch.
    pub(super) fn user_mut(&mut self) -> &mut u16 {
        &mut self.user
    }

    /// Output levels for the pins, the spindle's rpm scaled by `spindle_override` percent.
    pub(super) fn levels(&self, setup: &OutputSetup, spindle_override: u16) -> OutputLevels {
        let o = &self.program;
        let rpm = o.rpm.saturating_mul(u32::from(spindle_override)) / 100;
        OutputLevels {
            spindle_enable: o.spindle != Spindle::Off,
            spindle_ccw: o.spindle == Spindle::Ccw,
            // Laser mode: the step interrupt sets the duty per segment (motion/laser.rs).
            spindle_pwm: if setup.laser {
                0
            } else {
                spindle_duty(setup, o.spindle, rpm)
            },
            laser: setup.laser,
            mist: o.mist,
            flood: o.flood,
            user: self.user,
        }
    }

    /// Exchanges the user output word with the kernel ([`super::Board::sync_user_outputs`]):
    /// the board's own word when it switched outputs since the last exchange, else the kernel's
    /// is taken.
    pub(super) fn sync_user(&mut self, kernel_word: u16) -> Option<u16> {
        if self.user_loaded != Some(self.user) {
            self.user_loaded = Some(self.user);
            return Some(self.user);
        }
        self.user = kernel_word;
        self.user_loaded = Some(kernel_word);
        None
    }
}
