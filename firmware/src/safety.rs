//! The safe output state from any context, and the two handlers that use it: the panic handler
//! and the HardFault handler (a fault must not leave the spindle running until the watchdog).
//!
//! Safe state (docs/controller.md "Safety rules as built"): spindle enable/direction/PWM, coolant and user outputs low, stepper
//! drivers disabled (enable pin high, active low), step timer stopped. Reset gives the same state
//! (pins are inputs until `pin_table::split` drives them to these levels), so after a panic the
//! watchdog's reset keeps it.

use crate::pin_map::{gpio_block, safe_bsrr};
use crate::pin_table::{SAFE_LOW, STEPPER_ENABLE};
use core::panic::PanicInfo;
use cortex_m_rt::{exception, ExceptionFrame};
use embassy_stm32::pac;

/// One BSRR word per port A-E, computed at compile time from the board table.
const SAFE_WORDS: [u32; 5] = safe_bsrr(&SAFE_LOW, &[STEPPER_ENABLE]);

/// Stops the step timer and drives every output to its safe level with single register writes.
///
/// Safe while the output drivers are borrowed elsewhere: BSRR writes
/// set or reset exactly the named pins atomically (no read-modify-write), so they cannot corrupt
/// a driver's or an interrupted ISR's view of the port, and the `Output` drivers hold no shadow
/// state of the level. Clearing TIM2's enable bit stops the step interrupt from emitting more
/// edges. Register access through the PAC needs no `unsafe`; what is bypassed is only the
/// ownership of the pins by their drivers, which is sound for the reasons above.
///
/// The spindle PWM pin is a timer output (alternate function), which BSRR does not reach: it is
/// switched back to a plain GPIO output first. That is a read-modify-write of MODER, so this
/// function must run with interrupts disabled (the panic handler does).
fn force_safe() {
    pac::TIM2.cr1().modify(|w| w.set_cen(false));
    let pwm = SAFE_LOW[2];
    gpio_block(pwm.port)
        .moder()
        .modify(|w| w.set_moder(pwm.pin as usize, pac::gpio::vals::Moder::OUTPUT));
    let mut port = 0;
    while port < SAFE_WORDS.len() {
        if SAFE_WORDS[port] != 0 {
            gpio_block(port as u8)
                .bsrr()
                .write_value(pac::gpio::regs::Bsrr(SAFE_WORDS[port]));
        }
        port += 1;
    }
}

/// Panic: outputs safe first, then where it happened (file:line) over defmt, then a
/// breakpoint-style halt (`udf`) that a probe reports; without a probe the HardFault loop starves
/// the watchdog, which resets the board into the same safe state.
///
/// The message itself is not formatted: that would link `core::fmt` (several KiB of flash) for
/// a text that file:line identifies as well.
#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    force_safe();
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    cortex_m::asm::udf()
}

/// HardFault (a bus or usage fault escalated, an undefined instruction, the panic handler's own
/// `udf`): the same handling as a panic. Outputs safe first, with interrupts masked so nothing
/// can switch a pin back; then the faulting PC over defmt; then a spin that starves the
/// watchdog, whose reset keeps the safe state.
///
/// `unsafe` because cortex-m-rt's `#[exception]` requires the HardFault handler to be an
/// `unsafe fn`: it is entered with whatever state the fault left (the stacked frame may come from
/// a corrupt stack). This handler relies on none of it for safety: `force_safe` only writes
/// fixed peripheral registers, and the frame is read only for the log line, after the outputs
/// are safe.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    cortex_m::interrupt::disable();
    force_safe();
    defmt::error!("hard fault at pc {=u32:#010x}", frame.pc());
    loop {
        cortex_m::asm::nop();
    }
}
