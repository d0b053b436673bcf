//! Stops take precedence: a feed hold, a cycle start or a second abort that
//! arrives while an abort or an alarm-2 stop decelerates must not cancel it. Whatever comes in
//! during the deceleration, the job ends at rest with spindle and coolant off, the job-end event
//! (and the alarm) reported, and the board in Idle (abort) or Alarm 2 (soft-limit stop).

mod controller_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{AlarmCode, OutputLevels, State};
use gantry_machine::board::{BoardEvent, JobEnd};
use gantry_machine::motion::pipeline::MotionState;

/// 100 mm at 3000 mm/min with spindle and flood on.
const LONG_CUT: &str = "G21 G90\nM3 S12000\nM8\nG1 X100 F3000\nM30\n";

/// What arrives during the deceleration.
#[derive(Clone, Copy, Debug)]
enum Intrusion {
    /// `Board::feed_hold` (the host's FeedHold message).
    HostHold,
    /// The feed-hold input closes (and stays closed).
    HoldInput,
    /// `Board::resume` (the host's Resume message).
    HostResume,
    /// The cycle-start input.
    CycleStartInput,
    /// A second abort from the host.
    Abort,
    /// A feed hold, then a resume.
    HoldThenResume,
}

const ALL: [Intrusion; 6] = [
    Intrusion::HostHold,
    Intrusion::HoldInput,
    Intrusion::HostResume,
    Intrusion::CycleStartInput,
    Intrusion::Abort,
    Intrusion::HoldThenResume,
];

fn intrude(eb: &mut EmulatedBoard, what: Intrusion) {
    match what {
        Intrusion::HostHold => eb.board.feed_hold(),
        Intrusion::HoldInput => set(eb, Signal::FeedHold, true),
        Intrusion::HostResume => eb.board.resume(),
        Intrusion::CycleStartInput => set(eb, Signal::CycleStart1, true),
        Intrusion::Abort => eb.board.abort(),
        Intrusion::HoldThenResume => {
            eb.board.feed_hold();
            eb.run_ms(5);
            eb.board.resume();
        }
    }
    eb.run_ms(2);
    if matches!(what, Intrusion::CycleStartInput) {
        set(eb, Signal::CycleStart1, false);
    }
}

/// Runs until the kernel has drained and the motion is idle, then a few passes more.
fn settle(eb: &mut EmulatedBoard) {
    assert!(
        eb.run_until(5_000, |b| b.board.motion().state() == MotionState::Idle
            && b.kernel_drained())
    );
    eb.run_ms(5);
}

#[test]
fn an_abort_decelerating_ends_the_job_at_rest_with_outputs_off_whatever_arrives_meanwhile() {
    // Reference: the abort alone.
    let mut reference = board(|s| s.inputs.feed_hold = true);
    job(&mut reference, LONG_CUT);
    assert!(reference.run_until(5_000, |b| b.now_ms() == 1000));
    reference.board.abort();
    settle(&mut reference);
    let x = steps(&reference)[0];
    assert_eq!(reference.board.state(), State::Idle);

    for what in ALL {
        let mut eb = board(|s| s.inputs.feed_hold = true);
        eb.capture_events();
        job(&mut eb, LONG_CUT);
        assert!(eb.run_until(5_000, |b| b.now_ms() == 1000));
        eb.board.abort();
        eb.run_ms(20);
        assert_eq!(
            eb.board.motion().state(),
            MotionState::Holding,
            "{what:?}: decelerating"
        );
        assert!(eb.board.output_levels().spindle_enable);
        intrude(&mut eb, what);
        settle(&mut eb);
        assert_eq!(eb.board.state(), State::Idle, "{what:?}: the job ended");
        assert_eq!(
            eb.board.output_levels(),
            OutputLevels::SAFE,
            "{what:?}: spindle and coolant off"
        );
        assert_eq!(
            events(&mut eb),
            vec![BoardEvent::JobDone {
                line: 4,
                end: JobEnd::Aborted
            }],
            "{what:?}: one JobDone"
        );
        assert_eq!(eb.board.resume_line(), 4, "{what:?}");
        // At rest where the abort alone stopped: the intrusion changed nothing of the ramp.
        assert_eq!(steps(&eb)[0], x, "{what:?}: stopped where the abort stops");
        let at = steps(&eb);
        eb.run_ms(500);
        assert_eq!(steps(&eb), at, "{what:?}: at rest");
        assert_eq!(eb.board.state(), State::Idle);
    }
}

/// M3, M8, 200 one-millimetre feeds along X at 1200 mm/min (lines 4-203), then a block beyond
/// the travel (line 204).
fn beyond_travel_job() -> String {
    let mut p = String::from("G90 G21\nM3 S12000\nM8\n");
    for i in 1..=200 {
        p.push_str(&format!("G1 X{i} F1200\n"));
    }
    p.push_str("G1 X400\nG0 X0\nM30\n");
    p
}

#[test]
fn an_alarm_2_stop_decelerating_ends_in_the_alarm_at_rest_with_outputs_off_whatever_arrives() {
    let mut reference = board(|s| s.inputs.feed_hold = true);
    job(&mut reference, &beyond_travel_job());
    assert!(reference.run_until(20_000, |b| b.board.motion().state() == MotionState::Holding));
    settle(&mut reference);
    assert_eq!(reference.board.alarm(), Some(AlarmCode::SoftLimit));
    let x = steps(&reference)[0];
    let line = reference.board.line();

    for what in ALL {
        let mut eb = board(|s| s.inputs.feed_hold = true);
        eb.capture_events();
        job(&mut eb, &beyond_travel_job());
        assert!(eb.run_until(20_000, |b| b.board.motion().state() == MotionState::Holding));
        intrude(&mut eb, what);
        settle(&mut eb);
        assert_eq!(eb.board.state(), State::Alarm, "{what:?}: in the alarm");
        assert_eq!(eb.board.alarm(), Some(AlarmCode::SoftLimit), "{what:?}");
        assert_eq!(
            eb.board.output_levels(),
            OutputLevels::SAFE,
            "{what:?}: spindle and coolant off"
        );
        assert_eq!(
            events(&mut eb),
            vec![
                BoardEvent::Alarm {
                    code: AlarmCode::SoftLimit,
                    line: 204
                },
                BoardEvent::JobDone {
                    line,
                    end: JobEnd::Alarm
                }
            ],
            "{what:?}"
        );
        assert_eq!(
            steps(&eb)[0],
            x,
            "{what:?}: stopped where the stop alone stops"
        );
        let at = steps(&eb);
        eb.run_ms(500);
        assert_eq!(steps(&eb), at, "{what:?}: at rest");
    }
}
