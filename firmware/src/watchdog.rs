//! Independent watchdog (IWDG): resets the board when the main loop stops feeding it.
//!
//! The IWDG runs from the LSI oscillator (nominally 32 kHz, 17-47 kHz across parts and
//! temperature on the F4), independent of the main clock, and cannot be stopped once started.
//! Outputs are safe after any reset (pins float to inputs; steppers disabled, spindle and coolant
//! off until the firmware drives them), so a stalled main loop ends in a safe state.
//!
//! Normal timeout: 250 ms nominal (170-470 ms over the LSI range), far above a main-loop pass
//! (1 ms period) and below anything an operator would wait for. A settings save stalls the CPU
//! for up to about 2 s per 128 KiB sector erase, so [`long`] raises the timeout around it.

use embassy_stm32::pac;
use embassy_stm32::pac::iwdg::vals::{Key, Pr};

const IWDG: pac::iwdg::Iwdg = pac::IWDG;

/// Normal timeout: LSI / 32 (≈ 1 ms per count) × 250.
const NORMAL: (Pr, u16) = (Pr::DIVIDE_BY32, 250);
/// Around flash writes: LSI / 256 × 4095 ≈ 32 s nominal (≥ 22 s at the fastest LSI).
const LONG: (Pr, u16) = (Pr::DIVIDE_BY256, 4095);

fn configure((pr, rl): (Pr, u16)) {
    IWDG.kr().write(|w| w.set_key(Key::ENABLE));
    IWDG.pr().write(|w| w.set_pr(pr));
    IWDG.rlr().write(|w| w.set_rl(rl));
    // The new values cross into the LSI domain within a few LSI cycles (≈ 0.2 ms).
    while IWDG.sr().read().pvu() || IWDG.sr().read().rvu() {}
    feed();
}

/// Starts the watchdog with the normal timeout (it freezes while a debugger halts the core).
pub fn start() {
    pac::DBGMCU.apb1fzr().modify(|w| w.set_iwdg(true));
    IWDG.kr().write(|w| w.set_key(Key::START));
    configure(NORMAL);
}

/// Reloads the counter; the main loop calls it every pass.
#[inline]
pub fn feed() {
    IWDG.kr().write(|w| w.set_key(Key::RESET));
}

/// Long timeout for a flash write or erase (the CPU stalls; nothing can feed the watchdog).
pub fn long() {
    configure(LONG);
}

/// Back to the normal timeout.
pub fn normal() {
    configure(NORMAL);
}
