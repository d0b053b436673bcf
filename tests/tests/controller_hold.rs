//! Feed hold, cycle start and abort inputs on the emulated board, and the stop/restore
//! rules for spindle and coolant (docs/controller.md).

mod controller_support;

use controller_support::*;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{OutputLevels, State};
use gantry_machine::canon::Spindle;
use gantry_machine::motion::pipeline::MotionState;

const ARC_JOB: &str = "G21 G90\nM3 S12000\nM8\nG1 X10 F600\nG2 X30 Y0 I10 J0 F600\nG1 Y5\nM30\n";

fn uninterrupted() -> ([i64; 6], [u64; 6]) {
    let mut eb = board(|_| {});
    job(&mut eb, ARC_JOB);
    eb.run_ms(1);
    until_state(&mut eb, State::Idle, 60_000);
    (eb.isr.kernel.position(), eb.pulses)
}

/// Holds mid-arc with the feed-hold input; returns the board stopped in the hold.
fn held_mid_arc(
    edit: impl FnOnce(&mut gantry_machine::setup::Setup),
) -> gantry_emulator::EmulatedBoard {
    let mut eb = board(edit);
    job(&mut eb, ARC_JOB);
    eb.run_until(60_000, |b| b.board.line() == 5);
    eb.run_ms(1000);
    assert_eq!(eb.board.line(), 5, "on the arc");
    set(&mut eb, Signal::FeedHold, true);
    eb.run_ms(2);
    assert_eq!(eb.board.state(), State::Hold);
    eb.run_until(5_000, |b| {
        b.board.motion().state() == MotionState::Held && b.kernel_drained()
    });
    let at = eb.isr.kernel.position();
    eb.run_ms(500);
    assert_eq!(eb.isr.kernel.position(), at, "stopped while held");
    // A hold keeps spindle and coolant running (docs/controller.md, "Outputs": no automatic outputs).
    assert!(eb.board.output_levels().spindle_enable && eb.board.output_levels().flood);
    eb
}

#[test]
fn releasing_a_hold_mid_arc_ends_exactly_where_an_uninterrupted_run_ends() {
    let (end, pulses) = uninterrupted();
    let mut eb = held_mid_arc(|_| {});
    set(&mut eb, Signal::FeedHold, false);
    eb.run_ms(2);
    assert_eq!(eb.board.state(), State::Run);
    until_state(&mut eb, State::Idle, 60_000);
    assert_eq!(eb.isr.kernel.position(), end);
    assert_eq!(eb.pulses, pulses);
    assert_eq!(&end[..2], &[30 * STEPS_PER_MM, 5 * STEPS_PER_MM]);
    // M30 cleared the outputs.
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
}

#[test]
fn with_resume_needs_cycle_start_the_release_waits_for_the_start_button() {
    let (end, _) = uninterrupted();
    let mut eb = held_mid_arc(|s| s.operator.resume_needs_cycle_start = true);
    let at = eb.isr.kernel.position();
    // Cycle start while the hold switch is still open does nothing.
    set(&mut eb, Signal::CycleStart1, true);
    eb.run_ms(5);
    set(&mut eb, Signal::CycleStart1, false);
    set(&mut eb, Signal::FeedHold, false);
    eb.run_ms(300);
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.isr.kernel.position(), at);
    set(&mut eb, Signal::CycleStart1, true);
    eb.run_ms(5);
    assert_eq!(eb.board.state(), State::Run);
    until_state(&mut eb, State::Idle, 60_000);
    assert_eq!(eb.isr.kernel.position(), end);
}

#[test]
fn two_hand_start_needs_both_buttons() {
    let mut eb = held_mid_arc(|s| {
        s.operator.resume_needs_cycle_start = true;
        s.operator.two_hand_start = true;
    });
    set(&mut eb, Signal::FeedHold, false);
    set(&mut eb, Signal::CycleStart1, true);
    eb.run_ms(50);
    assert_eq!(eb.board.state(), State::Hold);
    set(&mut eb, Signal::CycleStart2, true);
    eb.run_ms(2);
    assert_eq!(eb.board.state(), State::Run);
}

#[test]
fn abort_input_stops_runs_the_program_stop_and_remembers_the_line() {
    let mut eb = held_mid_arc(|_| {});
    let at = eb.isr.kernel.position();
    set(&mut eb, Signal::Abort, true);
    eb.run_ms(2);
    set(&mut eb, Signal::Abort, false);
    until_state(&mut eb, State::Idle, 5_000);
    assert_eq!(
        eb.isr.kernel.position(),
        at,
        "abort from a hold does not move"
    );
    assert_eq!(eb.board.resume_line(), 5);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    // The board continues from where it stopped: a new job moves from there (once the hold
    // switch is closed again; with it open the job would start held).
    set(&mut eb, Signal::FeedHold, false);
    eb.run_ms(2);
    assert_eq!(eb.board.state(), State::Idle);
    job(&mut eb, "G91 G1 X1 F600\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], at[0] + STEPS_PER_MM);
}

#[test]
fn abort_while_running_decelerates_on_the_path_and_stops() {
    let mut eb = board(|_| {});
    job(&mut eb, "G21 G90\nG0 X200\nM30\n");
    eb.run_ms(1500);
    set(&mut eb, Signal::Abort, true);
    until_state(&mut eb, State::Idle, 5_000);
    let x = eb.isr.kernel.position()[0];
    assert!(x > 0 && x < 200 * STEPS_PER_MM, "stopped at {x}");
    assert_eq!(eb.isr.kernel.position()[1], 0);
}

#[test]
fn m0_switches_spindle_and_coolant_off_and_cycle_start_restores_them() {
    let mut eb = board(|s| {
        s.outputs.spindle_min_rpm = 0;
        s.outputs.spindle_max_rpm = 24_000;
        s.outputs.pwm_max = 1000;
    });
    job(
        &mut eb,
        "G21 G90\nM4 S6000\nM7\nG1 X5 F600\nM0\nG1 X10\nM1\nG1 X15\nM30\n",
    );
    until_state(&mut eb, State::Hold, 10_000);
    let stopped = eb.board.output_levels();
    assert_eq!(stopped, OutputLevels::SAFE);
    assert_eq!(eb.isr.kernel.position()[0], 5 * STEPS_PER_MM);
    set(&mut eb, Signal::CycleStart1, true);
    eb.run_ms(2);
    set(&mut eb, Signal::CycleStart1, false);
    assert_eq!(
        eb.board.output_levels(),
        OutputLevels {
            spindle_enable: true,
            spindle_ccw: true,
            spindle_pwm: 250,
            laser: false,
            mist: true,
            flood: false,
            user: 0
        }
    );
    assert_eq!(eb.board.outputs().spindle, Spindle::Ccw);
    // M1 with the optional-stop switch off runs through; M30 clears everything.
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 15 * STEPS_PER_MM);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
}

#[test]
fn optional_stop_switch_makes_m1_stop() {
    let mut eb = board(|_| {});
    set(&mut eb, Signal::OptionalStop, true);
    eb.run_ms(2);
    job(&mut eb, "G21 G90\nG1 X5 F600\nM1\nG1 X10\nM30\n");
    until_state(&mut eb, State::Hold, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 5 * STEPS_PER_MM);
    eb.board.cycle_start();
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 10 * STEPS_PER_MM);
}

#[test]
fn a_job_started_with_the_hold_switch_open_waits_for_it() {
    let mut eb = board(|_| {});
    set(&mut eb, Signal::FeedHold, true);
    eb.run_ms(2);
    job(&mut eb, "G21 G90\nG1 X2 F600\nM30\n");
    eb.run_ms(500);
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.pulses[0], 0);
    // Cycle start cannot override the open switch.
    eb.board.cycle_start();
    eb.run_ms(100);
    assert_eq!(eb.pulses[0], 0);
    set(&mut eb, Signal::FeedHold, false);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 2 * STEPS_PER_MM);
}

#[test]
fn a_feed_hold_decelerates_from_the_kernels_running_segment_and_resumes_exactly() {
    // grbl-like: the hold ramps down from the end of the segment the kernel is running; the
    // segments queued behind it are taken back. At 3000 mm/min (50 mm/s, 200 mm/s²) the ideal
    // stop is v²/2a = 6.25 mm.
    let mut eb = board(|_| {});
    job(&mut eb, "G21 G90\nG1 X100 F3000\nM30\n");
    eb.run_until(10_000, |b| b.isr.kernel.position()[0] >= 20 * STEPS_PER_MM);
    eb.run_for(gantry_emulator::COUNTS_PER_MS / 3);
    let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
    set(&mut eb, Signal::FeedHold, true);
    eb.run_until(5_000, |b| {
        b.board.motion().state() == MotionState::Held && b.kernel_drained()
    });
    let drop = eb.last_drop.expect("the hold took the queue back");
    let ms = |c: u64| c as f64 / gantry_emulator::COUNTS_PER_MS as f64;
    let (left, delay) = (ms(drop.running_left), ms(drop.time - t0));
    let (v, a, step) = (50.0, 200.0, 1.0 / STEPS_PER_MM as f64);
    let travelled = (eb.isr.kernel.position()[0] - from) as f64 * step;
    let ideal = v * v / (2.0 * a);
    println!(
        "feed hold at 3000 mm/min: stopped in {travelled:.4} mm, ideal {ideal:.4} mm, running \
         segment left {left:.2} ms, waited {delay:.2} ms, took back {} segments of {queued:.1} ms",
        drop.dropped
    );
    assert!(delay <= 1.0 && drop.dropped > 0);
    assert!(travelled <= ideal + v * (left + delay) / 1000.0 + step);
    assert!(travelled >= ideal - step);
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
    set(&mut eb, Signal::FeedHold, false);
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 100 * STEPS_PER_MM);
    assert_eq!(eb.pulses[0], 100 * STEPS_PER_MM as u64);
}
