//! Jogging on the emulated board: host jogs (increment, continuous), the joystick's switches
//! through the pair selector in Accelerated, Instantaneous and Nudge modes, Mark and Release, the
//! analog stick, and the soft limits. Stops and the analog stick's speed changes are measured in
//! `controller_jog_stop.rs`.

mod controller_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{AdcReadings, State};

/// Steps per ms of the emulator's last main-loop pass on X (speed probe).
fn x_speed_mm_min(eb: &mut EmulatedBoard) -> f64 {
    let before = eb.pulses[0];
    eb.run_ms(10);
    (eb.pulses[0] - before) as f64 / STEPS_PER_MM as f64 * 6000.0
}

#[test]
fn a_host_jog_increment_moves_exactly_and_refuses_to_leave_the_travel() {
    let mut eb = board(|_| {});
    assert!(eb.board.jog(0, 600_000, 10_000_000));
    assert_eq!(eb.board.state(), State::Jog);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 10 * STEPS_PER_MM);
    // 300 mm is the X travel: 295 more would leave it.
    assert!(!eb.board.jog(0, 600_000, 295_000_000));
    eb.run_ms(100);
    assert_eq!(eb.isr.kernel.position()[0], 10 * STEPS_PER_MM);
    assert_eq!(eb.board.state(), State::Idle);
}

#[test]
fn a_continuous_host_jog_ends_on_the_soft_limit() {
    let mut eb = board(|s| s.axes[1].travel_max = 20 * MM);
    assert!(eb.board.jog(1, 3_000_000, 0));
    until_state_held(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[1], 20 * STEPS_PER_MM);
}

#[test]
fn joystick_nudge_moves_exactly_n_increments() {
    let mut eb = board(|s| s.jog.nudge_distance = 50_000);
    enter_joystick(&mut eb);
    set(&mut eb, Signal::Nudge, true);
    set(&mut eb, Signal::JogS3, true); // right = +X (pair 0)
    eb.run_ms(1200); // nudges at 0, 500 and 1000 ms
    set(&mut eb, Signal::JogS3, false);
    eb.run_ms(500);
    assert_eq!(eb.isr.kernel.position()[0], 3 * 32);
    // S1 (down) = -Y: one press, one nudge.
    set(&mut eb, Signal::JogS1, true);
    eb.run_ms(100);
    set(&mut eb, Signal::JogS1, false);
    eb.run_ms(300);
    assert_eq!(eb.isr.kernel.position()[..2], [96, -32]);
    assert_eq!(eb.board.state(), State::Jog);
}

#[test]
fn joystick_switches_drive_accelerated_jogs_both_ways() {
    // Stop distances are measured in controller_jog_stop.rs.
    let mut eb = board(|_| {});
    enter_joystick(&mut eb);
    set(&mut eb, Signal::Accelerated, true);
    set(&mut eb, Signal::JogS3, true);
    eb.run_ms(1500);
    let v = x_speed_mm_min(&mut eb);
    assert!((2900.0..=3100.0).contains(&v), "at {v} mm/min");
    set(&mut eb, Signal::JogS3, false);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.board.state(), State::Jog);
    // Reversing: S2 drives -X.
    let at = eb.isr.kernel.position()[0];
    set(&mut eb, Signal::JogS2, true);
    eb.run_ms(300);
    set(&mut eb, Signal::JogS2, false);
    until_at_rest(&mut eb, 5_000);
    assert!(eb.isr.kernel.position()[0] < at);
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
}

#[test]
fn instantaneous_mode_runs_at_the_jog_speed_and_stops_on_the_soft_limit() {
    let mut eb = board(|s| {
        s.axes[2].travel_max = 2 * MM;
        s.jog.instant_speed = 60 * MM;
    });
    enter_joystick(&mut eb);
    set(&mut eb, Signal::PairSelect, true);
    set(&mut eb, Signal::JogS4, true); // up = +Z in pair 1
    eb.run_ms(500);
    let before = eb.pulses[2];
    eb.run_ms(500);
    assert_eq!(eb.pulses[2] - before, 320); // 60 mm/min = 640 steps/s
    eb.run_ms(3000);
    assert_eq!(eb.isr.kernel.position()[2], 2 * STEPS_PER_MM);
    set(&mut eb, Signal::JogS4, false);
    eb.run_ms(10);
    assert_eq!(eb.isr.kernel.position()[2], 2 * STEPS_PER_MM);
}

#[test]
fn mark_reports_the_position_and_mark_with_release_leaves_jog() {
    let mut eb = board(|s| s.jog.nudge_distance = 50_000);
    assert!(eb.board.jog(0, 600_000, 5_000_000));
    until_state(&mut eb, State::Idle, 5_000);
    enter_joystick(&mut eb);
    set(&mut eb, Signal::Mark, true);
    eb.run_ms(2);
    set(&mut eb, Signal::Mark, false);
    eb.run_ms(2);
    let m = eb.board.take_mark().expect("mark event");
    assert_eq!((m.id, m.position[0]), (1, 5 * MM));
    assert_eq!(eb.board.take_mark(), None);
    enter_joystick_leave(&mut eb);
}

/// Mark ids count since power-up (docs/ports.md): a setup pushed between two marks does not
/// start them again at 1, so a teach-in list keeps one numbering.
#[test]
fn mark_ids_go_on_across_a_new_setup() {
    let mut eb = board(|_| {});
    let press_mark = |eb: &mut EmulatedBoard| {
        set(eb, Signal::Mark, true);
        eb.run_ms(2);
        set(eb, Signal::Mark, false);
        eb.run_ms(2);
        eb.board.take_mark().expect("mark event").id
    };
    enter_joystick(&mut eb);
    assert_eq!(press_mark(&mut eb), 1);
    enter_joystick_leave(&mut eb);
    let setup = eb.board.setup().clone();
    assert!(eb.board.set_setup(setup));
    enter_joystick(&mut eb);
    assert_eq!(press_mark(&mut eb), 2);
}

fn enter_joystick_leave(eb: &mut EmulatedBoard) {
    set(eb, Signal::Release, true);
    eb.run_ms(2);
    set(eb, Signal::Mark, true);
    eb.run_ms(2);
    set(eb, Signal::Mark, false);
    set(eb, Signal::Release, false);
    eb.run_ms(5);
    assert_eq!(eb.board.state(), State::Idle);
}

#[test]
fn the_analog_stick_drives_proportional_speed() {
    let mut eb = board(|s| s.jog.analog_max_speed = 1200 * MM);
    enter_joystick(&mut eb);
    // Full right on channel 0 (X), neutral on channel 1 (Y).
    eb.adc = AdcReadings {
        fro: None,
        stick: Some([4095, 2047]),
    };
    eb.run_ms(1000);
    let v = x_speed_mm_min(&mut eb);
    assert!((1150.0..=1250.0).contains(&v), "{v}");
    // Half deflection: half speed (quantised in eighths).
    eb.adc.stick = Some([2047 + 1024, 2047]);
    eb.run_ms(1500);
    let v = x_speed_mm_min(&mut eb);
    println!("analog half deflection: {v:.0} mm/min");
    assert!((590.0..=610.0).contains(&v), "{v}");
    assert_eq!(eb.isr.kernel.position()[1], 0);
    eb.adc.stick = Some([2047, 2047]);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.board.state(), State::Jog);
}

#[test]
fn slow_nudges_do_not_queue_up_behind_the_stick() {
    // 2 mm at 60 mm/min takes 2 s: holding the switch 1.2 s gives exactly one nudge.
    let mut eb = board(|s| s.jog.nudge_distance = 2 * MM);
    enter_joystick(&mut eb);
    set(&mut eb, Signal::Nudge, true);
    set(&mut eb, Signal::JogS3, true);
    eb.run_ms(1200);
    set(&mut eb, Signal::JogS3, false);
    eb.run_ms(3000);
    assert_eq!(eb.isr.kernel.position()[0], 2 * STEPS_PER_MM);
}
