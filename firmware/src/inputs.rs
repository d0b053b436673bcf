//! Input task: samples the switch inputs on every EXTI edge (and every millisecond) into one word
//! in the core's `InputBits` layout, and stops the step kernel when an armed limit switch closes.
//!
//! Runs on the high-priority interrupt executor, so a limit reaches the step ISR's `STOP` flag
//! within microseconds of the edge, not after whatever the thread executor is doing. The main
//! loop debounces [`PINS`] once per millisecond and hands it to the controller (feed hold, abort,
//! cycle start and the joystick switches work without the host, docs/controller.md "Safety rules as built").
//!
//! Electrical convention of both boards: internal pull-ups, switches close to ground. A closed
//! switch (pin low) reads as bit = 1 here; the setup's `inputs.invert` then marks normally-closed
//! switches. Boards without separate max-limit inputs (min and max switch of an axis wired to
//! one pin) report that pin as both the axis's min and max bit, so either kind of switch can be
//! declared installed (and homing can seek either end).

use crate::pin_table::{
    Inputs, ABORT, AXES, CYCLE_START0, EXTI_INPUTS, FEED_HOLD, JOYSTICK_SWITCHES, LIMIT0,
    LIMIT_MAX0, LIMIT_MAX_INPUTS,
};
use crate::step::STOP;
use core::sync::atomic::{AtomicU32, Ordering};
use embassy_futures::select::{select, select_array};
use embassy_time::{Duration, Timer};
use gantry_machine::board::inputs::{Signal, LIMIT_MAX_BIT, LIMIT_MIN_BIT};

/// Latest sample: bit = 1 where the switch is closed (pin low), `InputBits` layout.
pub static PINS: AtomicU32 = AtomicU32::new(0);
/// Limit bits that stop the kernel (`Board::limit_arm`), published by the main loop every pass.
pub static ARM: AtomicU32 = AtomicU32::new(0);
/// Polarity (`setup.inputs.invert`), published by the main loop.
pub static INVERT: AtomicU32 = AtomicU32::new(0);

#[allow(clippy::absurd_extreme_comparisons)] // no joystick switches on some boards (F411)
const _: () = assert!(
    JOYSTICK_SWITCHES <= (Signal::Release as usize - Signal::JogS1 as usize + 1),
    "joystick switches map onto JogS1..Release"
);

/// Bit of each EXTI input in the sample word (limits may set two bits: see the module doc).
const fn exti_bits() -> [u32; EXTI_INPUTS] {
    let mut bits = [0u32; EXTI_INPUTS];
    let mut axis = 0;
    while axis < AXES {
        bits[LIMIT0 + axis] = if LIMIT_MAX_INPUTS == 0 {
            (1 << (LIMIT_MIN_BIT as usize + axis)) | (1 << (LIMIT_MAX_BIT as usize + axis))
        } else {
            1 << (LIMIT_MIN_BIT as usize + axis)
        };
        axis += 1;
    }
    let mut i = 0;
    #[allow(clippy::absurd_extreme_comparisons)] // no max-limit inputs on some boards
    while i < LIMIT_MAX_INPUTS {
        bits[LIMIT_MAX0 + i] = 1 << (LIMIT_MAX_BIT as usize + i);
        i += 1;
    }
    bits[FEED_HOLD] = 1 << Signal::FeedHold as u32;
    bits[ABORT] = 1 << Signal::Abort as u32;
    bits[CYCLE_START0] = 1 << Signal::CycleStart1 as u32;
    bits[CYCLE_START0 + 1] = 1 << Signal::CycleStart2 as u32;
    bits
}

const EXTI_BITS: [u32; EXTI_INPUTS] = exti_bits();

const fn in_range(i: usize, start: usize, len: usize) -> bool {
    i >= start && i - start < len
}

/// The mapping is checked at compile time: every input has a bit, no two inputs share one, limit
/// inputs only set limit bits (which stop the kernel when armed) and the others never do.
const _: () = {
    let mut seen = 0u32;
    let mut i = 0;
    while i < EXTI_INPUTS {
        let bits = EXTI_BITS[i];
        assert!(bits != 0, "every EXTI input has a bit");
        assert!(seen & bits == 0, "no two inputs share a bit");
        let is_limit = in_range(i, LIMIT0, AXES) || in_range(i, LIMIT_MAX0, LIMIT_MAX_INPUTS);
        assert!(
            is_limit == (bits & gantry_machine::board::LIMIT_BITS == bits),
            "limit inputs set limit bits only, other inputs none"
        );
        seen |= bits;
        i += 1;
    }
    assert!(
        seen & (0xf << Signal::JogS1 as u32) == 0,
        "joystick switch bits stay free for the polled inputs"
    );
};

fn sample(inputs: &Inputs) -> u32 {
    let mut word = 0;
    for (input, bit) in inputs.exti.iter().zip(EXTI_BITS) {
        if input.is_low() {
            word |= bit;
        }
    }
    for (i, input) in inputs.joystick_switches.iter().enumerate() {
        if input.is_low() {
            word |= 1 << (Signal::JogS1 as usize + i);
        }
    }
    if inputs.probe.is_low() {
        word |= 1 << Signal::Probe as u32;
    }
    // Arc-OK, THC up, THC down: bits 29-31 in that order.
    for (i, input) in inputs.torch.iter().enumerate() {
        if input.is_low() {
            word |= 1 << (Signal::ArcOk as usize + i);
        }
    }
    word
}

/// True if an armed limit switch is active in `pins` (polarity applied).
pub fn armed_limit(pins: u32) -> bool {
    (pins ^ INVERT.load(Ordering::Relaxed)) & ARM.load(Ordering::Relaxed) != 0
}

#[embassy_executor::task]
pub async fn run(mut inputs: Inputs) {
    let mut last = u32::MAX;
    loop {
        let word = sample(&inputs);
        PINS.store(word, Ordering::Relaxed);
        if armed_limit(word) {
            STOP.store(true, Ordering::Relaxed);
        }
        if word != last {
            defmt::debug!("input pins {=u32:#010x}", word);
            last = word;
        }
        let edges = select_array(inputs.exti.each_mut().map(|i| i.wait_for_any_edge()));
        select(edges, Timer::after(Duration::from_millis(1))).await;
    }
}
