//! The motion marker and the reset cause: how the previous run ended (grbl alarm 3, "reset while
//! in motion"). The decision itself is the core's (`gantry_machine::board::power_up`); this
//! module only owns the RAM word and reads the MCU's reset flags.
//!
//! The marker is one `u32` in cortex-m-rt's `.uninit` section (NOLOAD, inside RAM, neither
//! zeroed nor initialised by the startup code), so it keeps its value across every reset that
//! keeps the SRAM powered: watchdog (a stalled main loop, or a panic, whose handler ends in a
//! fault loop that starves the watchdog), software reset, the reset pin, a brown-out. The main loop
//! writes [`MARKER_MOVING`] before it hands the step interrupt a segment and [`MARKER_IDLE`] once
//! the kernel is drained again (and the board's position is not lost).
//!
//! Only the main-loop task (thread mode) and [`power_up`] (called once in `main`, before that
//! task exists) touch the word, so there is never a concurrent access.

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};
use embassy_stm32::pac;
use gantry_machine::board::power_up::{PowerUp, ResetCause, MARKER_IDLE, MARKER_MOVING};

#[link_section = ".uninit.GANTRY_MOTION_MARKER"]
static mut MARKER: MaybeUninit<u32> = MaybeUninit::uninit();

fn read() -> u32 {
    // SAFETY: a volatile read of the marker's 4 aligned bytes in SRAM. After a power-on reset
    // they hold whatever the SRAM powered up with; the volatile access makes the compiler read
    // that physical content rather than reason about an "uninitialised" value, and every bit
    // pattern is a valid `u32`. The core only trusts it when it equals `MARKER_MOVING` and the
    // reset kept the RAM (not a power-on reset). No other access runs concurrently (module doc).
    unsafe { core::ptr::read_volatile(addr_of!(MARKER).cast::<u32>()) }
}

fn write(value: u32) {
    // SAFETY: a volatile write of an aligned `u32` into the marker's own static, which nothing
    // else aliases; single-threaded access as the module doc explains.
    unsafe { core::ptr::write_volatile(addr_of_mut!(MARKER).cast::<u32>(), value) }
}

/// Why the MCU started, from `RCC_CSR`; the flags are then cleared (`RMVF`) so the next reset
/// reports only its own cause. Power-on wins over everything (the RAM is undefined then).
fn reset_cause() -> ResetCause {
    let csr = pac::RCC.csr().read();
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    if csr.porrstf() {
        ResetCause::PowerOn
    } else if csr.borrstf() {
        ResetCause::BrownOut
    } else if csr.wdgrstf() || csr.wwdgrstf() {
        ResetCause::Watchdog
    } else if csr.sftrstf() {
        ResetCause::Software
    } else if csr.padrstf() {
        // Internal resets also pulse NRST, so the pin flag alone means the pin itself.
        ResetCause::Pin
    } else {
        ResetCause::Other
    }
}

/// How this power-up starts: call once, first thing in `main`. After a warm reset the marker is
/// left as found (a further reset before the position is re-established must still count; the
/// main loop clears it); after a power-on reset its noise is replaced at once.
pub fn power_up() -> (PowerUp, ResetCause) {
    let marker = read();
    let cause = reset_cause();
    if cause == ResetCause::PowerOn {
        idle();
    }
    (PowerUp::after_reset(marker, cause), cause)
}

/// The kernel is about to get motion: a reset from now on is a reset during motion.
#[inline]
pub fn moving() {
    write(MARKER_MOVING);
}

/// The kernel is drained and the board knows its position.
#[inline]
pub fn idle() {
    write(MARKER_IDLE);
}

/// The reset cause and power-up kind for the boot log (plain strings: `Debug2Format` would link
/// `core::fmt` code for them).
pub fn describe(how: PowerUp, cause: ResetCause) -> (&'static str, &'static str) {
    let cause = match cause {
        ResetCause::PowerOn => "power-on",
        ResetCause::BrownOut => "brown-out",
        ResetCause::Watchdog => "watchdog",
        ResetCause::Software => "software",
        ResetCause::Pin => "reset pin",
        ResetCause::Other => "other",
    };
    let how = match how {
        PowerUp::Clean => "clean start",
        PowerUp::MotionInterrupted => "motion was interrupted (alarm 3)",
    };
    (cause, how)
}
