//! Outputs and run modes on the emulated board: spindle PWM from S, user M-code command lists
//! (outputs, dwell, input wait with timeout), the feed-override potentiometer, dry run, single
//! block, block delete and check mode.

mod controller_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{AdcReadings, AlarmCode, OutputLevels, State};
use gantry_machine::setup::{ListCommand, McodeList, Setup};

fn x_speed_mm_min(eb: &mut EmulatedBoard) -> f64 {
    let before = eb.pulses[0];
    eb.run_ms(100);
    (eb.pulses[0] - before) as f64 / STEPS_PER_MM as f64 * 600.0
}

fn with_m100(s: &mut Setup, timeout_ms: u16) {
    s.program.user_mcodes.push(100).unwrap();
    let mut l = McodeList {
        code: 100,
        dry_run_disabled: true,
        commands: Default::default(),
    };
    for c in [
        ListCommand::Set(2),
        ListCommand::DwellMs(200),
        ListCommand::WaitInput {
            bit: 30,
            level: true,
            timeout_ms,
        },
        ListCommand::Clear(2),
        ListCommand::Set(5),
    ] {
        l.commands.push(c).unwrap();
    }
    s.outputs.mcode_lists.push(l).unwrap();
}

#[test]
fn spindle_and_coolant_outputs_follow_the_program() {
    let mut eb = board(|s| {
        s.outputs.spindle_min_rpm = 1000;
        s.outputs.spindle_max_rpm = 21_000;
        s.outputs.pwm_min = 50;
        s.outputs.pwm_max = 1050;
    });
    job(&mut eb, "M3 S11000\nM8\nG4 P1\nM30\n");
    eb.run_ms(500);
    assert_eq!(
        eb.board.output_levels(),
        OutputLevels {
            spindle_enable: true,
            spindle_ccw: false,
            spindle_pwm: 550,
            laser: false,
            mist: false,
            flood: true,
            user: 0
        }
    );
    until_state(&mut eb, State::Idle, 5_000);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
}

#[test]
fn a_user_m_code_list_sets_outputs_dwells_and_waits_for_an_input() {
    let mut eb = board(|s| with_m100(s, 0));
    job(&mut eb, "G21 G90\nG1 X5 F600\nM100\nG1 X10\nM30\n");
    eb.run_until(10_000, |b| b.board.output_levels().user != 0);
    assert_eq!(eb.isr.kernel.position()[0], 5 * STEPS_PER_MM);
    assert_eq!(eb.board.output_levels().user, 0b100);
    eb.run_ms(2000);
    // Waiting for input 30: nothing moved, output 2 still on.
    assert_eq!(eb.isr.kernel.position()[0], 5 * STEPS_PER_MM);
    assert_eq!(eb.board.output_levels().user, 0b100);
    eb.set_pin(30, true);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 10 * STEPS_PER_MM);
    // The list's outputs stay after M30 (only spindle and coolant are program-stop outputs).
    assert_eq!(eb.board.output_levels().user, 0b10_0000);
}

#[test]
fn an_input_wait_that_times_out_alarms() {
    let mut eb = board(|s| with_m100(s, 500));
    job(&mut eb, "G21 G90\nG1 X5 F600\nM100\nG1 X10\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ListInputTimeout));
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    eb.run_ms(500);
    assert_eq!(eb.isr.kernel.position()[0], 5 * STEPS_PER_MM);
}

#[test]
fn the_feed_override_pot_scales_the_feed_and_the_host_can_still_override() {
    let mut eb = board(|s| {
        s.inputs.fro_pot = true;
        s.operator.fro_low = 30;
        s.operator.fro_high = 130;
    });
    eb.adc = AdcReadings {
        fro: Some(0),
        stick: None,
    };
    job(&mut eb, "G21 G90\nG1 X200 F1200\nM30\n");
    eb.run_ms(1000);
    assert_eq!(eb.board.feed_override(), 30);
    let v = x_speed_mm_min(&mut eb);
    assert!((355.0..=365.0).contains(&v), "{v}");
    eb.adc.fro = Some(4095);
    eb.run_ms(1000);
    assert_eq!(eb.board.feed_override(), 130);
    let v = x_speed_mm_min(&mut eb);
    assert!((1550.0..=1570.0).contains(&v), "{v}");
    // The host's override holds until the knob moves again.
    eb.board.set_feed_override(100);
    eb.run_ms(1000);
    assert_eq!(eb.board.feed_override(), 100);
    let v = x_speed_mm_min(&mut eb);
    assert!((1190.0..=1210.0).contains(&v), "{v}");
    eb.adc.fro = Some(2048);
    eb.run_ms(10);
    assert_eq!(eb.board.feed_override(), 80);
}

#[test]
fn dry_run_feeds_at_the_dry_run_rate_and_skips_outputs() {
    let mut eb = board(|s| {
        s.operator.dry_run_feed = 1200 * MM;
        with_m100(s, 0);
    });
    assert!(eb.board.set_dry_run(true));
    job(&mut eb, "G21 G90\nM3 S1000\nM8\nG1 X100 F60\nM100\nM30\n");
    eb.run_ms(2000);
    let v = x_speed_mm_min(&mut eb);
    assert!((1190.0..=1210.0).contains(&v), "{v}");
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    until_state(&mut eb, State::Idle, 20_000);
    // M100's list is "disabled for dry run": it neither waited nor switched anything.
    assert_eq!(eb.board.output_levels().user, 0);
    assert_eq!(eb.isr.kernel.position()[0], 100 * STEPS_PER_MM);
}

#[test]
fn single_block_stops_after_each_block() {
    let mut eb = board(|_| {});
    set(&mut eb, Signal::SingleBlock, true);
    eb.run_ms(2);
    job(
        &mut eb,
        "G21 G90\nM3 S1000\nG1 X1 F600\nG1 X2\nG1 X3\nM30\n",
    );
    for x in 1..=2 {
        until_state(&mut eb, State::Hold, 10_000);
        eb.run_ms(100);
        assert_eq!(eb.isr.kernel.position()[0], x * STEPS_PER_MM);
        // Stopped like M0: spindle off, restored on cycle start.
        assert!(!eb.board.output_levels().spindle_enable);
        eb.board.cycle_start();
        eb.run_ms(2);
        assert!(eb.board.output_levels().spindle_enable);
    }
    // Switch off: the rest runs through.
    set(&mut eb, Signal::SingleBlock, false);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 3 * STEPS_PER_MM);
}

#[test]
fn the_block_delete_switch_skips_slashed_blocks() {
    let mut eb = board(|_| {});
    set(&mut eb, Signal::BlockDelete, true);
    eb.run_ms(2);
    job(&mut eb, "G21 G90\n/G1 X5 F600\nG1 Y2 F600\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[..2], [0, 2 * STEPS_PER_MM]);
}

#[test]
fn check_mode_interprets_without_motion() {
    let mut eb = board(|_| {});
    assert!(eb.board.start_check());
    assert_eq!(eb.board.state(), State::Check);
    for (i, l) in "G21 G90\nM3 S1000\nG1 X50 F600\nG0 Y-20\nM30\n"
        .lines()
        .enumerate()
    {
        assert!(eb.board.push_line(0, i as u32 + 1, l));
    }
    eb.board.end_of_lines(0);
    until_state(&mut eb, State::Idle, 1_000);
    assert_eq!(eb.isr.kernel.position(), [0; 6]);
    assert_eq!(eb.pulses, [0; 6]);
    assert_eq!(eb.board.line(), 5);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    // A block beyond the travel ends the check at that block.
    assert!(eb.board.start_check());
    for (i, l) in "G21 G90\nG1 X50 F600\nG0 X400\nG0 X0\nM30\n"
        .lines()
        .enumerate()
    {
        assert!(eb.board.push_line(0, i as u32 + 1, l));
    }
    eb.board.end_of_lines(0);
    until_state(&mut eb, State::Idle, 1_000);
    assert_eq!(eb.board.line(), 2);
    assert_eq!(eb.pulses, [0; 6]);
}
