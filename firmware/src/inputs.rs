//! Input task: samples the switch inputs on every EXTI edge (and every 10 ms) into one word.
//!
//! Runs on the high-priority interrupt executor, so a limit or abort reaches the step ISR's `STOP`
//! flag within microseconds, not after whatever the thread executor is doing. Inputs follow
//! grbl's default wiring: pull-ups, normally-open switches to ground, asserted = low. Polarity
//! becomes a setting once the settings model lands; the controller state machine will own what an
//! asserted input means beyond the latched stop and the outputs' safe state.

use crate::board_def::{
    Inputs, Outputs, ABORT, AXES, CYCLE_START0, EXTI_INPUTS, FEED_HOLD, JOYSTICK_SWITCHES, LIMIT0,
    LIMIT_MAX0, LIMIT_MAX_INPUTS,
};
use crate::step::STOP;
use core::sync::atomic::{AtomicU32, Ordering};
use embassy_futures::select::{select, select_array};
use embassy_time::{Duration, Timer};

/// Asserted inputs: bit i = `Inputs::exti[i]`, then the joystick switches from bit `EXTI_INPUTS`.
pub static ASSERTED: AtomicU32 = AtomicU32::new(0);

/// Bits of `ASSERTED` that stop motion at once: every limit input and abort.
const STOP_MASK: u32 =
    (((1 << AXES) - 1) << LIMIT0) | (((1 << LIMIT_MAX_INPUTS) - 1) << LIMIT_MAX0) | (1 << ABORT);

const _: () = assert!(EXTI_INPUTS + JOYSTICK_SWITCHES <= 32, "inputs fit one word");

fn sample(inputs: &Inputs) -> u32 {
    let mut word = 0;
    for (i, input) in inputs.exti.iter().enumerate() {
        word |= (input.is_low() as u32) << i;
    }
    for (i, input) in inputs.joystick_switches.iter().enumerate() {
        word |= (input.is_low() as u32) << (EXTI_INPUTS + i);
    }
    word
}

/// Turns spindle, coolant and user outputs off (the safe state after a stop).
fn outputs_safe(outputs: &mut Outputs) {
    outputs.spindle_enable.set_low();
    outputs.spindle_dir.set_low();
    outputs.spindle_pwm.set_low();
    outputs.coolant_flood.set_low();
    outputs.coolant_mist.set_low();
    for o in &mut outputs.user {
        o.set_low();
    }
}

#[embassy_executor::task]
pub async fn run(mut inputs: Inputs, mut outputs: Outputs) {
    let mut last = u32::MAX;
    loop {
        let word = sample(&inputs);
        if word & STOP_MASK != 0 {
            STOP.store(true, Ordering::Relaxed);
            outputs_safe(&mut outputs);
        }
        ASSERTED.store(word, Ordering::Relaxed);
        if word != last {
            defmt::info!(
                "inputs: limits {=u32:b} max {=u32:b} hold {=bool} abort {=bool} cycle start {=u32:b} joystick {=u32:b}",
                (word >> LIMIT0) & ((1 << AXES) - 1),
                (word >> LIMIT_MAX0) & ((1 << LIMIT_MAX_INPUTS) - 1),
                word & (1 << FEED_HOLD) != 0,
                word & (1 << ABORT) != 0,
                (word >> CYCLE_START0) & 0b11,
                word >> EXTI_INPUTS,
            );
            last = word;
        }
        let edges = select_array(inputs.exti.each_mut().map(|i| i.wait_for_any_edge()));
        select(edges, Timer::after(Duration::from_millis(10))).await;
    }
}
