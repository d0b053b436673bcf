//! Hard limits on the emulated board: switches modelled at machine positions trip from the step
//! position, the kernel stops at the next tick, the board alarms, unhomes only the tripped axis,
//! drives the outputs safe and refuses motion until unlock (and homing where required).

mod controller_support;

use controller_support::*;
use gantry_machine::board::{AlarmCode, OutputLevels, State};
use gantry_machine::board::{ERROR_HOMING_REQUIRED, ERROR_LIMIT_PRESSED};

/// X and Y with min switches at -2 mm for homing, X with a max switch at 50 mm.
fn machine() -> gantry_emulator::EmulatedBoard {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b011;
        s.inputs.limit_max = 0b001;
        for a in 0..2 {
            s.homing.axes[a].priority = 1 + a as u8;
            s.homing.axes[a].retract = MM;
        }
    });
    eb.add_switch(0, false, -2 * MM);
    eb.add_switch(1, false, -2 * MM);
    eb.add_switch(0, true, 50 * MM);
    eb
}

#[test]
fn a_limit_hit_at_rapid_stops_within_one_tick_and_unhomes_only_that_axis() {
    let mut eb = machine();
    assert!(eb.board.home(0));
    until_state(&mut eb, State::Idle, 20_000);
    assert_eq!(eb.board.homed(), 0b011);
    let before = eb.physical();
    // Each axis's fast seek and slow locate ended on limit stops of their own.
    assert_eq!(eb.limit_stops, 4);
    job(&mut eb, "G90 G21\nM3 S12000\nM8\nG0 X100 Y20\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    // The switch sits at physical 50 mm: the kernel stopped on the tick after the step that
    // reached it, and the steps the interrupt had prepared went out (as on the board).
    let p = eb.physical();
    assert_eq!(p[0], 50 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.limit_stops, 5);
    // Y stopped with X on the same tick: the rapid is a straight line from the start.
    let (dx, dy) = (p[0] - before[0], p[1] - before[1]);
    assert!(dy > 0 && dy < dx, "Y moved {dy} steps while X moved {dx}");
    // Only X lost its home; outputs are safe; the job ended.
    assert_eq!(eb.board.homed(), 0b010);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    // The board reports the stopped position as its machine position.
    let pos = eb.board.machine_position(&eb.isr.kernel.position());
    assert_eq!(eb.board.motion().queued_position(), pos);
    // Motion is refused until unlock, and the unlock while the switch is pressed (905).
    assert!(!eb.board.start_job());
    assert!(!eb.board.jog(0, 60_000, MM as u64));
    assert_eq!(eb.board.try_unlock(), Err(ERROR_LIMIT_PRESSED));
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    // The pressed switch is disarmed (it does not trip again), and the one motion allowed is a
    // jog off it: Y or toward the switch are refused, -X runs, and the alarm stays.
    assert_eq!(eb.board.limit_arm() & (1 << 22), 0);
    assert!(!eb.board.jog(1, -600_000, MM as u64));
    assert!(eb.board.jog(0, -600_000, 5 * MM as u64));
    until_state(&mut eb, State::Alarm, 5_000);
    assert_eq!(eb.physical()[0], 45 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    // Released, it re-arms; now the unlock clears the alarm.
    assert_ne!(eb.board.limit_arm() & (1 << 22), 0);
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
}

#[test]
fn a_feed_into_a_switch_stops_on_the_switch_step_and_the_program_does_not_continue() {
    let mut eb = machine();
    job(&mut eb, "G90 G21\nG1 X60 F1200\nG0 X0\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    eb.run_ms(200);
    assert_eq!(eb.isr.kernel.position()[0], 50 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.pulses[0], (50 * STEPS_PER_MM + AHEAD) as u64);
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.line(), 2);
}

#[test]
fn with_homing_required_motion_waits_for_homing_after_a_hard_limit() {
    let mut eb = machine();
    let mut s = eb.board.setup().clone();
    s.homing.required = true;
    let mut eb2 = gantry_emulator::EmulatedBoard::new(s);
    eb2.add_switch(0, false, -2 * MM);
    eb2.add_switch(1, false, -2 * MM);
    eb2.add_switch(0, true, 50 * MM);
    eb = eb2;
    // Power-up: locked until homed.
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingRequired));
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Alarm);
    assert!(eb.board.home(0));
    until_state(&mut eb, State::Idle, 20_000);
    job(&mut eb, "G90 G21\nG0 X80\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    // On the max switch: neither unlock nor homing (X homes to its min switch), both 905.
    assert_eq!(eb.board.try_unlock(), Err(ERROR_LIMIT_PRESSED));
    assert!(!eb.board.home(0b001));
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    assert_eq!(eb.board.homed(), 0b010);
    // A jog off it though X is unhomed, then the unlock leaves the homing lock.
    assert!(eb.board.jog(0, -600_000, 2 * MM as u64));
    until_state(&mut eb, State::Alarm, 5_000);
    eb.run_ms(20);
    eb.board.unlock();
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingRequired));
    assert!(!eb.board.start_job());
    assert_eq!(eb.board.state(), State::Alarm);
    // Rehoming X clears it.
    assert!(eb.board.home(0b001));
    until_state(&mut eb, State::Idle, 60_000);
    assert_eq!(eb.board.homed(), 0b011);
    let _ = ERROR_HOMING_REQUIRED;
}

#[test]
fn a_switch_hit_during_a_jog_alarms_and_active_low_switches_work() {
    // The Y max switch is wired active low (switch to ground, pull-up).
    let mut eb = board(|s| {
        s.inputs.limit_max = 0b010;
        s.inputs.invert = 1 << 23;
    });
    eb.add_switch(1, true, 12 * MM);
    // Idle with the switch released: the pin reads high.
    eb.run_ms(5);
    assert_eq!(eb.raw_pins() & (1 << 23), 1 << 23);
    assert!(eb.board.jog(1, 1_200_000, 0));
    until_state_held(&mut eb, State::Alarm, 10_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    assert_eq!(eb.isr.kernel.position()[1], 12 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.raw_pins() & (1 << 23), 0);
}

#[test]
fn switches_do_not_stop_motion_when_hard_limits_are_off_or_not_installed() {
    let mut eb = board(|s| {
        s.inputs.limit_max = 0b001;
        s.inputs.hard_limits = false;
    });
    eb.add_switch(0, true, 5 * MM);
    eb.add_switch(1, true, 5 * MM); // wired but not installed in the setup
    job(&mut eb, "G90 G21\nG1 X10 Y10 F3000\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(
        eb.isr.kernel.position()[..2],
        [10 * STEPS_PER_MM, 10 * STEPS_PER_MM]
    );
    assert_eq!(eb.limit_stops, 0);
    // The debounced levels still show them (status reports the inputs).
    assert_eq!(eb.inputs & ((1 << 22) | (1 << 23)), (1 << 22) | (1 << 23));
}
