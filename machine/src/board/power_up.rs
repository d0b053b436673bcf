//! How the previous run ended, read at power-up: was the board reset while the steppers were
//! moving (grbl alarm 3, "reset while in motion")?
//!
//! The firmware keeps a *motion marker* word in RAM that no reset clears (cortex-m-rt's `.uninit`
//! section): [`MARKER_MOVING`] while the step kernel has motion, [`MARKER_IDLE`] when it is
//! drained. After a reset it reads the word and the MCU's reset cause, and [`PowerUp::after_reset`]
//! decides. A power-on reset leaves the RAM undefined, so its marker means nothing (and a machine
//! that was switched off is not "interrupted": every power-up starts unhomed anyway). The emulated
//! board models the same word, so both take the same decision.

/// Marker word while the kernel has motion ("MOVE").
pub const MARKER_MOVING: u32 = 0x4d4f_5645;
/// Marker word while the kernel is drained ("IDLE").
pub const MARKER_IDLE: u32 = 0x4944_4c45;

/// Why the MCU (re)started, from its reset flags (STM32: `RCC_CSR`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power-on / power-down reset: RAM content is undefined.
    PowerOn,
    /// Brown-out: the supply dipped below the BOR threshold; RAM is normally retained.
    BrownOut,
    /// Independent or window watchdog (a stalled main loop, or a panic that stopped feeding it).
    Watchdog,
    /// Software reset (`SYSRESETREQ`, e.g. after a firmware update request).
    Software,
    /// Only the NRST pin (reset button, debugger).
    Pin,
    /// Low-power management reset, or no flag set.
    Other,
}

/// What the board starts with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PowerUp {
    /// A normal start (power-on, or a reset while nothing moved).
    Clean,
    /// The previous run was reset while motion was active: start in alarm 3, every axis unhomed.
    MotionInterrupted,
}

impl PowerUp {
    /// The decision from the marker word found in RAM and the reset cause.
    pub fn after_reset(marker: u32, cause: ResetCause) -> PowerUp {
        if cause != ResetCause::PowerOn && marker == MARKER_MOVING {
            PowerUp::MotionInterrupted
        } else {
            PowerUp::Clean
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_valid_moving_marker_after_a_warm_reset_counts() {
        use ResetCause::*;
        for cause in [BrownOut, Watchdog, Software, Pin, Other] {
            assert_eq!(
                PowerUp::after_reset(MARKER_MOVING, cause),
                PowerUp::MotionInterrupted
            );
            assert_eq!(PowerUp::after_reset(MARKER_IDLE, cause), PowerUp::Clean);
            assert_eq!(
                PowerUp::after_reset(MARKER_MOVING ^ 1, cause),
                PowerUp::Clean
            );
        }
        // Power-on: whatever the RAM holds is noise.
        assert_eq!(PowerUp::after_reset(MARKER_MOVING, PowerOn), PowerUp::Clean);
    }
}
