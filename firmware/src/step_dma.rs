//! The three DMA1 streams that make the step pulses from TIM2's events (`step.rs`).
//!
//! Why DMA to BSRR: it is the only way that works on both boards. The step pins are not all on
//! timer channels (Black Pill: PB12 has none, PB13-PB15 only TIM1's complementary outputs, and
//! TIM1 drives the spindle PWM on both boards), while a DMA write to a GPIO BSRR reaches any pin.
//! TIM2's requests go to DMA1 only (STM32F411/F446 reference manuals RM0383/RM0390, "DMA1 request
//! mapping", channel 3; the same table is in stm32-metapac's chip data), and DMA1's *peripheral*
//! port reaches APB1 alone, not the GPIO ports on AHB1; its *memory* port goes through the bus
//! matrix and reaches them (RM0383 "System architecture"; AN4031, "Using the STM32F2, STM32F4
//! and STM32F7 Series DMA controller"). So every stream runs peripheral-to-memory: the source
//! is a TIM2 register on the peripheral port, the destination a GPIO BSRR (or TIM2's own CCR3)
//! on the memory port. TIM2's CCR3 and CCR4 are 32-bit and unused as compare channels (their
//! compare flags rise and are ignored: no interrupt or DMA request is enabled for them), so they
//! hold the two words:
//!
//! | stream (channel 3) | request | copies | to | effect |
//! |---|---|---|---|---|
//! | 1 | update | CCR3 (step word) | step port BSRR | the step edges |
//! | 5 | compare 1 at `pulse` | CCR4 (reset word) | step port BSRR | the pulse end |
//! | 6 | compare 2 at `pulse` | CCR4 (reset word) | CCR3 | an update the interrupt does not prepare raises nothing |
//!
//! Each stream is circular with one transfer of one word, so it is armed once and never touched
//! again: the interrupt only writes CCR3. Streams 1, 5 and 6 of DMA1 are taken out of embassy's
//! `Peripherals` ([`StepDma`]), so no driver can claim them.

use embassy_stm32::pac;
use embassy_stm32::pac::dma::vals::{Dir, Pl, Size};
use embassy_stm32::peripherals::{DMA1_CH1, DMA1_CH5, DMA1_CH6};
use embassy_stm32::Peri;

/// The DMA1 streams the step pulses use: moved out of embassy's `Peripherals` so no driver can
/// claim them; the streams are programmed by register ([`start`]), never through these tokens.
#[allow(dead_code)]
pub struct StepDma {
    pub update: Peri<'static, DMA1_CH1>,
    pub pulse_end: Peri<'static, DMA1_CH5>,
    pub clear: Peri<'static, DMA1_CH6>,
}

/// TIM2 compare register (0-based index) that holds the step word of the next update.
pub const STEP_WORD_CCR: usize = 2;
/// TIM2 compare register that holds the reset word (every step pin low).
const RESET_WORD_CCR: usize = 3;
/// DMA1 request channel of every TIM2 request.
const TIM2_CHANNEL: u8 = 3;
const UPDATE_STREAM: usize = 1;
const PULSE_END_STREAM: usize = 5;
const CLEAR_STREAM: usize = 6;

const TIM: pac::timer::TimGp32 = pac::TIM2;

/// Moves both compare points (pulse end and step-word clear) to `pulse` counts after the update.
pub fn set_pulse(pulse: u32) {
    TIM.ccr(0).write_value(pulse);
    TIM.ccr(1).write_value(pulse);
}

/// Arms the three streams and TIM2's DMA requests. TIM2 must be stopped; `step_reset` drops
/// every step pin, `step_bsrr` is the step port's BSRR address.
pub fn start(_streams: StepDma, step_reset: u32, step_bsrr: u32, pulse: u32) {
    pac::RCC.ahb1enr().modify(|w| w.set_dma1en(true));
    set_pulse(pulse);
    TIM.ccr(STEP_WORD_CCR).write_value(step_reset);
    TIM.ccr(RESET_WORD_CCR).write_value(step_reset);
    let step_word = TIM.ccr(STEP_WORD_CCR).as_ptr() as u32;
    let reset_word = TIM.ccr(RESET_WORD_CCR).as_ptr() as u32;
    word_copy(UPDATE_STREAM, step_word, step_bsrr);
    word_copy(PULSE_END_STREAM, reset_word, step_bsrr);
    word_copy(CLEAR_STREAM, reset_word, step_word);
    TIM.dier().modify(|w| {
        w.set_ude(true);
        w.set_ccde(0, true);
        w.set_ccde(1, true);
    });
}

/// Sets `stream` of DMA1 to copy the word at `from` (a TIM2 register) to `to` on every TIM2
/// request of its channel, for ever (circular, one transfer).
fn word_copy(stream: usize, from: u32, to: u32) {
    let st = pac::DMA1.st(stream);
    st.cr().write(|w| w.set_en(false));
    while st.cr().read().en() {}
    // A stream starts only with its event flags clear.
    pac::DMA1.ifcr(stream / 4).write(|w| {
        let n = stream % 4;
        w.set_feif(n, true);
        w.set_dmeif(n, true);
        w.set_teif(n, true);
        w.set_htif(n, true);
        w.set_tcif(n, true);
    });
    st.par().write_value(from);
    st.m0ar().write_value(to);
    st.ndtr().write(|w| w.set_ndt(1));
    st.cr().write(|w| {
        w.set_chsel(TIM2_CHANNEL);
        w.set_pl(Pl::VERY_HIGH);
        w.set_dir(Dir::PERIPHERAL_TO_MEMORY);
        w.set_psize(Size::BITS32);
        w.set_msize(Size::BITS32);
        w.set_circ(true);
        w.set_en(true);
    });
}
