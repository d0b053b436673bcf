//! How each stop ends a job on the emulated board, on its virtual clock: an interpreter error,
//! an abort, alarms 1, 2 and 20, M30. Every ending but a hard limit takes effect at rest: the
//! spindle and coolant outputs stay on through the last step of the motion (or of the
//! deceleration) and go off in the first main-loop pass that finds the kernel drained.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{AlarmCode, OutputLevels, State};
use gantry_machine::board::{BoardEvent, JobEnd, ERROR_SOFT_LIMIT};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::step::kernel::StepTiming;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{continue_job, Flow};

/// Spindle on at S12000 (PWM 500 of 1000 with the default 0-24 000 rpm range).
const SPINDLE: OutputLevels = OutputLevels {
    spindle_enable: true,
    spindle_ccw: false,
    spindle_pwm: 500,
    laser: false,
    mist: false,
    flood: false,
    user: 0,
};
/// Spindle and flood on.
const CUTTING: OutputLevels = OutputLevels {
    flood: true,
    ..SPINDLE
};

/// The first main-loop pass (virtual time, counts) that sees the kernel drained after its timer
/// stopped at `idle_at`: passes run every millisecond, and a pass at the very count of that tick
/// runs before it.
fn first_pass_after(idle_at: u64) -> u64 {
    (idle_at / COUNTS_PER_MS + 1) * COUNTS_PER_MS
}

/// A board recording its output levels and capturing its events.
fn recording_board(edit: impl FnOnce(&mut gantry_machine::setup::Setup)) -> EmulatedBoard {
    let mut eb = board(edit);
    eb.capture_events();
    eb.output_changes = Some(Vec::new());
    eb
}

fn output_changes(eb: &mut EmulatedBoard) -> Vec<(u64, OutputLevels)> {
    eb.output_changes.replace(Vec::new()).unwrap()
}

// ---- an interpreter error ends the job ----

/// Line 6 has a word no G or M code uses (error 211 at column 8, the `Q`).
const ERROR_AT_LINE_6: &str =
    "G21 G90\nM3 S12000\nM8\nG1 X10 F600\nG1 X20\nG1 X30 Q2\nG1 X40\nM30\n";

#[test]
fn a_job_ending_on_an_error_machines_every_line_before_it_then_stops_spindle_and_coolant_at_rest() {
    let mut eb = recording_board(|_| {});
    job(&mut eb, ERROR_AT_LINE_6);
    // The interpreter meets line 6 at once (lines 4 and 5 are queued): the error is reported
    // then, and the motion before it goes on.
    eb.run_ms(5);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::Error {
            line: 6,
            code: 211,
            column: 8
        }]
    );
    assert_eq!(eb.board.state(), State::Run);
    assert_eq!(eb.board.output_levels(), CUTTING);
    until_state(&mut eb, State::Idle, 10_000);
    // Nothing lost: lines 4 and 5 ran to their end (X 20 mm), nothing of line 6 or after.
    assert_eq!(steps(&eb), [20 * STEPS_PER_MM, 0, 0, 0, 0, 0]);
    assert_eq!(eb.pulses[0], 20 * STEPS_PER_MM as u64);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 5,
            end: JobEnd::Failed
        }]
    );
    assert_eq!(eb.board.resume_line(), 6);
    assert_eq!(eb.board.line(), 5);
    // Spindle and flood ran through the last step of line 5 and went off in the first pass
    // at rest: the program-stop sequence.
    let off = first_pass_after(eb.kernel_idle_at);
    assert!(eb.last_step_at < eb.kernel_idle_at && eb.kernel_idle_at < off);
    assert_eq!(
        output_changes(&mut eb),
        vec![
            (COUNTS_PER_MS, SPINDLE),
            (2 * COUNTS_PER_MS, CUTTING),
            (off, OutputLevels::SAFE)
        ]
    );
    assert_eq!(off, 2049 * COUNTS_PER_MS);
    // The board takes a new job from there.
    job(&mut eb, "G91 G1 X1 F600\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(steps(&eb)[0], 21 * STEPS_PER_MM);
}

// ---- abort ----

/// 100 mm at 3000 mm/min with spindle and flood on.
const LONG_CUT: &str = "G21 G90\nM3 S12000\nM8\nG1 X100 F3000\nM30\n";

#[test]
fn an_abort_decelerates_along_the_cut_with_the_spindle_on_and_stops_it_at_rest() {
    let mut eb = recording_board(|_| {});
    job(&mut eb, LONG_CUT);
    assert!(eb.run_until(5_000, |b| b.now_ms() == 1000));
    set(&mut eb, Signal::Abort, true);
    eb.run_ms(1);
    // The pass at 1000 ms saw the abort: decelerating on the path, spindle and flood still on.
    assert_eq!(eb.board.state(), State::Run);
    assert_eq!(eb.board.motion().state(), MotionState::Holding);
    assert_eq!(eb.board.output_levels(), CUTTING);
    until_state(&mut eb, State::Idle, 5_000);
    let x = steps(&eb)[0];
    // X decelerated from 50 mm/s at 200 mm/s² (6.25 mm, 0.25 s) from the end of the kernel's
    // running segment: the last step 248 ms after the abort.
    assert_eq!(x, 32_054);
    assert_eq!(eb.last_step_at, 14_979_290);
    let off = first_pass_after(eb.kernel_idle_at);
    assert_eq!(off, 1251 * COUNTS_PER_MS);
    assert_eq!(
        output_changes(&mut eb),
        vec![
            (COUNTS_PER_MS, SPINDLE),
            (2 * COUNTS_PER_MS, CUTTING),
            (off, OutputLevels::SAFE)
        ]
    );
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 4,
            end: JobEnd::Aborted
        }]
    );
    assert_eq!(eb.board.resume_line(), 4);

    // A feed hold at that very millisecond stops on the same step: the abort is a hold's ramp.
    let mut twin = board(|_| {});
    job(&mut twin, LONG_CUT);
    assert!(twin.run_until(5_000, |b| b.now_ms() == 1000));
    twin.board.feed_hold();
    assert!(
        twin.run_until(5_000, |b| b.board.motion().state() == MotionState::Held
            && b.kernel_drained())
    );
    assert_eq!(steps(&twin)[0], x);
}

#[test]
fn an_abort_from_a_feed_hold_stops_spindle_and_coolant_in_the_next_pass() {
    // Seed 003 "abort from feed hold": the machine is already at rest. The pass that sees the
    // abort drops the held motion; the next one finds it at rest and ends the job.
    let mut eb = recording_board(|_| {});
    job(&mut eb, LONG_CUT);
    eb.run_ms(1000);
    eb.board.feed_hold();
    assert!(
        eb.run_until(5_000, |b| b.board.motion().state() == MotionState::Held
            && b.kernel_drained())
    );
    eb.run_ms(500);
    let at = steps(&eb);
    let abort_at = eb.now();
    assert_eq!(abort_at % COUNTS_PER_MS, 0);
    set(&mut eb, Signal::Abort, true);
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Run);
    assert_eq!(eb.board.output_levels(), CUTTING);
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(steps(&eb), at);
    assert_eq!(
        output_changes(&mut eb),
        vec![
            (COUNTS_PER_MS, SPINDLE),
            (2 * COUNTS_PER_MS, CUTTING),
            (abort_at + COUNTS_PER_MS, OutputLevels::SAFE)
        ]
    );
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 4,
            end: JobEnd::Aborted
        }]
    );
    assert_eq!(eb.board.resume_line(), 4);
}

// ---- M30 ----

#[test]
fn m30_stops_spindle_and_coolant_in_the_first_pass_after_the_motion() {
    let mut eb = recording_board(|_| {});
    job(&mut eb, "G21 G90\nM3 S12000\nM8\nG1 X10 F600\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(steps(&eb)[0], 10 * STEPS_PER_MM);
    let off = first_pass_after(eb.kernel_idle_at);
    assert!(eb.last_step_at < eb.kernel_idle_at);
    assert_eq!(
        output_changes(&mut eb),
        vec![
            (COUNTS_PER_MS, SPINDLE),
            (2 * COUNTS_PER_MS, CUTTING),
            (off, OutputLevels::SAFE)
        ]
    );
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 5,
            end: JobEnd::Completed
        }]
    );
}

// ---- alarm 1: immediate ----

#[test]
fn a_hard_limit_stops_at_once_and_switches_the_outputs_off_in_the_pass_that_sees_the_stop() {
    let mut eb = recording_board(|s| s.inputs.limit_max = 0b001);
    eb.add_switch(0, true, 10 * MM);
    job(&mut eb, "G21 G90\nM3 S12000\nM8\nG1 X50 F1200\nM30\n");
    until_state(&mut eb, State::Alarm, 10_000);
    // No deceleration: the kernel halted on the tick after the step that reached the switch
    // (docs/controller.md, "Safety rules as built"); the steps the interrupt had prepared went
    // out.
    assert_eq!(steps(&eb)[0], 10 * STEPS_PER_MM + AHEAD);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    // The last prepared step went out and the interrupt of its period (the pulse end, then the
    // entry) found the kernel halted with nothing prepared; the next pass switched everything
    // off.
    let timing = StepTiming::from_setup(&eb.board.setup().drivers);
    assert_eq!(
        eb.kernel_idle_at - eb.last_step_at,
        u64::from(timing.pulse + StepTiming::ENTRY_COUNTS)
    );
    let off = first_pass_after(eb.kernel_idle_at);
    assert_eq!(off, 550 * COUNTS_PER_MS);
    assert_eq!(
        output_changes(&mut eb),
        vec![
            (COUNTS_PER_MS, SPINDLE),
            (2 * COUNTS_PER_MS, CUTTING),
            (off, OutputLevels::SAFE)
        ]
    );
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Limit { axis: 0, max: true },
            BoardEvent::Alarm {
                code: AlarmCode::HardLimit,
                line: 4
            },
            BoardEvent::JobDone {
                line: 4,
                end: JobEnd::Alarm
            }
        ]
    );
}

// ---- alarm 20: a locally resumed job starving with the host gone ----

/// M3, M8, then 600 feeds of 0.25 mm along X at 1200 mm/min (lines 4-603, 150 mm), M30.
fn many_short_feeds() -> String {
    let mut p = String::from("G21 G90\nM3 S12000\nM8\n");
    for i in 1..=600 {
        p.push_str(&format!("G1 X{} F1200\n", i as f64 / 4.0));
    }
    p.push_str("M30\n");
    p
}

/// The host vanishes at line 4 after 2 s, the link holds the job, the operator resumes it with
/// cycle start 5 s later; it runs what the board had buffered and waits for more. Returns the
/// board once it waits, and the time (ms) of the first pass that found it waiting at rest.
fn resumed_locally_then_starving() -> (EmulatedBoard, u32) {
    let (mut eb, gone) = host_vanishes(|_| {}, &many_short_feeds(), 4);
    assert!(eb.run_until(5_000, |b| b.board.state() == State::Hold));
    assert_eq!(eb.now_ms() - 1 - gone, 1_001);
    eb.run_ms(5_000);
    // Held at rest for the lost host: spindle and coolant off; the local cycle start restores
    // them (docs/controller.md "Host lost").
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    eb.board.cycle_start();
    assert_eq!(eb.board.state(), State::Run);
    eb.run_ms(1);
    assert_eq!(eb.board.output_levels(), CUTTING);
    eb.output_changes = Some(Vec::new());
    assert!(eb.run_until(10_000, |b| b.board.waiting_for_lines()));
    let waiting = eb.now_ms() - 1;
    assert_eq!(
        u64::from(waiting) * COUNTS_PER_MS,
        first_pass_after(eb.kernel_idle_at),
        "waiting from the first pass at rest"
    );
    (eb, waiting)
}

#[test]
fn a_locally_resumed_job_that_runs_out_of_lines_with_the_host_gone_ends_with_alarm_20() {
    let (mut eb, waiting) = resumed_locally_then_starving();
    eb.capture_events();
    let at = steps(&eb);
    let line = eb.board.line();
    // It ran every line the board had, to its end.
    assert_eq!(at[0] % (STEPS_PER_MM / 4), 0);
    assert_eq!(at[0], (line as i64 - 3) * STEPS_PER_MM / 4);
    // Spindle and flood stay on while it waits, until the 60 s are up.
    assert!(eb.run_until(70_000, |b| b.now_ms() == waiting + 60_000));
    assert_eq!(eb.board.state(), State::Run);
    assert_eq!(eb.board.output_levels(), CUTTING);
    assert!(events(&mut eb).is_empty());
    eb.run_ms(1);
    // The pass at wait + 60 s ends the job (at rest already): alarm 20 at the last line run,
    // every output off, position kept.
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HostLost));
    assert_eq!(
        output_changes(&mut eb),
        vec![(
            u64::from(waiting + 60_000) * COUNTS_PER_MS,
            OutputLevels::SAFE
        )]
    );
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Alarm {
                code: AlarmCode::HostLost,
                line
            },
            BoardEvent::JobDone {
                line,
                end: JobEnd::Alarm
            }
        ]
    );
    assert_eq!(eb.board.resume_line(), line);
    assert_eq!(steps(&eb), at);
}

#[test]
fn a_host_back_before_the_limit_feeds_the_starving_job_again() {
    let (mut eb, waiting) = resumed_locally_then_starving();
    assert!(eb.run_until(70_000, |b| b.now_ms() == waiting + 59_000));
    let mut client = Client::connect(eb, 2000).unwrap();
    let program = Program::from_text(&many_short_feeds());
    let report = continue_job(&mut client, &program, &mut |_| Flow::Continue).unwrap();
    assert!(report.completed, "{:?} {:?}", report.errors, report.alarms);
    let eb = client.into_transport();
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(steps(&eb)[0], 150 * STEPS_PER_MM);
    assert!(eb.now_ms() > waiting + 60_000, "ran on past the limit");
}

#[test]
fn an_error_before_the_job_queued_anything_still_ends_it_with_the_program_stop_sequence() {
    let mut eb = recording_board(|_| {});
    for (text, code, column) in [("G0 X400", ERROR_SOFT_LIMIT, 0), ("G0 X1 Q2", 211, 7)] {
        // `gantry mdi "M3 S12000"`: the end of the lines (no M2/M30) keeps the outputs …
        job(&mut eb, "M3 S12000");
        until_state(&mut eb, State::Idle, 1_000);
        assert_eq!(eb.board.output_levels(), SPINDLE);
        events(&mut eb);
        // … a next command that fails ends its job like any error: nothing moved, spindle off.
        job(&mut eb, text);
        until_state(&mut eb, State::Idle, 1_000);
        let ev = events(&mut eb);
        assert_eq!(
            ev[0],
            BoardEvent::Error {
                line: 1,
                code,
                column
            }
        );
        assert!(
            matches!(
                ev[1..],
                [BoardEvent::JobDone {
                    end: JobEnd::Failed,
                    ..
                }]
            ),
            "{ev:?}"
        );
        assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
        assert_eq!(eb.board.resume_line(), 1);
        assert_eq!(eb.pulses, [0; 6]);
    }
}

/// A job that runs no line reports line 0 as its last, not the previous job's.
#[test]
fn a_job_that_runs_nothing_ends_on_line_zero() {
    let mut eb = recording_board(|_| {});
    job(&mut eb, "G1 X1 F600\nG1 X2");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 2,
            end: JobEnd::Completed
        }]
    );
    job(&mut eb, "(only a comment)");
    until_state(&mut eb, State::Idle, 1_000);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 0,
            end: JobEnd::Completed
        }]
    );
    assert_eq!(eb.board.line(), 0);
}
