//! Controller state machine: what the operator, the host and the machine's switches do to a board.
//!
//! The firmware and the emulated board both drive this one implementation, so a board and its
//! emulation behave identically (DESIGN §1).

pub mod inputs;

use serde::{Deserialize, Serialize};

/// The controller's state, as reported in every status.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum State {
    /// Nothing running; ready for a job, jog, homing or setup changes.
    Idle,
    /// Executing a program.
    Run,
    /// Feed hold: decelerating or stopped on the path, resumable.
    Hold,
    /// Motion refused until the alarm is cleared (reset/unlock, and rehoming where required).
    Alarm,
    /// Seeking limit switches.
    Homing,
    /// Jogging from the host or the joystick.
    Jog,
    /// Interpreting without motion (like grbl's `$C`).
    Check,
}

/// Why the controller is in [`State::Alarm`]. Codes follow grbl's numbering where the meaning is
/// the same, so grbl users recognise them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum AlarmCode {
    /// A hard limit switch tripped during motion; position of that axis is lost (rehome it).
    HardLimit = 1,
    /// A motion would leave the soft-limit box (only raised for jogs and MDI beyond the checked program).
    SoftLimit = 2,
    /// Abort during motion: position is kept, but the job stopped mid-block.
    AbortDuringMotion = 3,
    /// Homing: the switch was not found within the axis travel.
    HomingSwitchNotFound = 9,
    /// Homing: the switch did not release during the retract.
    HomingPullOffFailed = 8,
    /// The host link was lost during a job and the board held the machine (resume on reconnect).
    HostLost = 20,
}

impl AlarmCode {
    /// One-line explanation for the host's display.
    pub const fn message(self) -> &'static str {
        match self {
            AlarmCode::HardLimit => "hard limit tripped: step output stopped; rehome the axis",
            AlarmCode::SoftLimit => "motion would exceed the machine travel",
            AlarmCode::AbortDuringMotion => "aborted during motion; position kept",
            AlarmCode::HomingSwitchNotFound => "homing: limit switch not found within the travel",
            AlarmCode::HomingPullOffFailed => "homing: switch still active after the retract",
            AlarmCode::HostLost => "host link lost during a job; machine held",
        }
    }
}
