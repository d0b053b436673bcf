//! The controller's state and alarm codes, as every status reports them. The state machine
//! itself is [`crate::board::Board`].

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
    /// A job stands at rest at its M6 until the operator has changed the tool and presses cycle
    /// start (or the host resumes); [`crate::board::Board::tool_change`] names the tool.
    ToolChange,
}

/// Why the controller is in [`State::Alarm`]. Codes follow grbl's numbering where the meaning is
/// the same, so grbl users recognise them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum AlarmCode {
    /// A hard limit switch tripped during motion; position of that axis is lost (rehome it).
    HardLimit = 1,
    /// A block of a running job would have left the soft-limit box: the job stopped on its
    /// path before it (position kept).
    SoftLimit = 2,
    /// The previous run ended in a reset (watchdog, panic, reset pin, brown-out) while the
    /// steppers were moving: the position is unknown and the job was cut mid-block.
    ResetDuringMotion = 3,
    /// A G38 probe move found the probe already in the state it should reach (touching for
    /// G38.2/G38.3, clear for G38.4/G38.5) before it moved (grbl's alarm 4).
    ProbeFailInitial = 4,
    /// G38.2/G38.4 reached the end of the move without the probe changing state (grbl's alarm 5).
    ProbeFailContact = 5,
    /// Homing was aborted (abort input or host) before it finished; the axes stay unhomed.
    HomingAborted = 6,
    /// Homing: the switch did not release during the retract.
    HomingPullOffFailed = 8,
    /// Homing: the switch was not found within the axis travel.
    HomingSwitchNotFound = 9,
    /// Homing is required before motion (setup `homing.required`, or a reset during motion).
    HomingRequired = 11,
    /// The host link was lost while the job stood still (a feed hold, or waiting at rest for
    /// lines only the host could send), for longer than `link.host_lost_stop_s`: the board ended
    /// the job.
    HostLost = 20,
    /// A command list waited for an input longer than its timeout.
    ListInputTimeout = 21,
    /// A plasma torch fired and its arc-OK input did not come within `arc_ok_timeout_ms`
    /// (docs/laser-plasma.md "Plasma"): torch off, the job ended at rest.
    NoArc = 22,
}

impl AlarmCode {
    /// Every alarm, by number.
    pub const ALL: [AlarmCode; 12] = [
        AlarmCode::HardLimit,
        AlarmCode::SoftLimit,
        AlarmCode::ResetDuringMotion,
        AlarmCode::ProbeFailInitial,
        AlarmCode::ProbeFailContact,
        AlarmCode::HomingAborted,
        AlarmCode::HomingPullOffFailed,
        AlarmCode::HomingSwitchNotFound,
        AlarmCode::HomingRequired,
        AlarmCode::HostLost,
        AlarmCode::ListInputTimeout,
        AlarmCode::NoArc,
    ];

    /// The alarm with this number (as sent over the link).
    pub fn from_number(n: u16) -> Option<AlarmCode> {
        Self::ALL.iter().copied().find(|a| *a as u16 == n)
    }

    /// Short name for the host's display.
    pub const fn name(self) -> &'static str {
        match self {
            AlarmCode::HardLimit => "hard limit",
            AlarmCode::SoftLimit => "soft limit",
            AlarmCode::ResetDuringMotion => "reset during motion",
            AlarmCode::ProbeFailInitial => "probe fail (initial state)",
            AlarmCode::ProbeFailContact => "probe fail (no contact)",
            AlarmCode::HomingAborted => "homing aborted",
            AlarmCode::HomingPullOffFailed => "homing pull-off failed",
            AlarmCode::HomingSwitchNotFound => "homing switch not found",
            AlarmCode::HomingRequired => "homing required",
            AlarmCode::HostLost => "host lost",
            AlarmCode::ListInputTimeout => "list input timeout",
            AlarmCode::NoArc => "no arc",
        }
    }

    /// One-line explanation for the host's display.
    pub const fn message(self) -> &'static str {
        match self {
            AlarmCode::HardLimit => {
                "a limit switch stopped the machine; the job ended; rehome the tripped axis"
            }
            AlarmCode::SoftLimit => {
                "a block would leave the machine travel: the job stopped on its path before it; position kept"
            }
            AlarmCode::ResetDuringMotion => {
                "the board reset while the steppers were moving: position unknown, job lost; home (or unlock)"
            }
            AlarmCode::ProbeFailInitial => {
                "probe move refused: the probe was already in the state the move looks for (check the probe and its wiring)"
            }
            AlarmCode::ProbeFailContact => {
                "probe move ended without the probe changing state within the programmed distance"
            }
            AlarmCode::HomingAborted => "homing aborted; axes not homed",
            AlarmCode::HomingPullOffFailed => "homing: switch still active after the retract",
            AlarmCode::HomingSwitchNotFound => "homing: limit switch not found within the travel",
            AlarmCode::HomingRequired => "homing required before motion",
            AlarmCode::HostLost => {
                "the host stayed away while the job stood still: job ended, spindle and coolant off"
            }
            AlarmCode::ListInputTimeout => "command list: input wait timed out",
            AlarmCode::NoArc => {
                "the torch fired but arc-OK did not come within arc_ok_timeout_ms: torch off, job ended at rest"
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alarm_numbers_round_trip() {
        for a in AlarmCode::ALL {
            assert_eq!(AlarmCode::from_number(a as u16), Some(a));
        }
        assert_eq!(AlarmCode::from_number(2), Some(AlarmCode::SoftLimit));
        assert_eq!(AlarmCode::from_number(4), Some(AlarmCode::ProbeFailInitial));
        assert_eq!(AlarmCode::from_number(7), None);
    }
}
