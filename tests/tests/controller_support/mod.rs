//! Helpers shared by the controller scenario tests: an emulated board with switches, jobs fed
//! straight into the board, and waits on the virtual clock.
#![allow(dead_code)]

use gantry_emulator::EmulatedBoard;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::BoardEvent;
use gantry_machine::board::State;
use gantry_machine::setup::Setup;
use gantry_machine::units::NM_PER_MM;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{stream_program, Flow};

pub const MM: i64 = NM_PER_MM;
/// Default axes: 3200 steps per 5 mm.
pub const STEPS_PER_MM: i64 = 640;
/// Steps the step interrupt has computed ahead of the pins (machine/src/step/isr.rs): a limit
/// stop latched by the kernel on the tick after the step that reached the switch still lets
/// them out, so the machine stands this many steps past the switch step.
pub const AHEAD: i64 = gantry_machine::step::TICKS_AHEAD as i64;

/// A board with no debounce delay beyond one sample and the given setup changes.
pub fn board(edit: impl FnOnce(&mut Setup)) -> EmulatedBoard {
    let mut s = Setup::default();
    s.inputs.debounce_ms = 1;
    edit(&mut s);
    EmulatedBoard::new(s)
}

/// Starts a job and feeds `text` to the board line by line as it takes them.
pub fn job(eb: &mut EmulatedBoard, text: &str) {
    assert!(
        eb.board.start_job(),
        "start refused in {:?}",
        eb.board.state()
    );
    for (i, l) in text.lines().enumerate() {
        let mut tries = 0;
        while !eb.board.push_line(0, i as u32 + 1, l) {
            eb.run_ms(1);
            tries += 1;
            if tries > 600_000 || !matches!(eb.board.state(), State::Run | State::Hold) {
                return;
            }
        }
    }
    eb.board.end_of_lines(0);
}

/// Runs until the board is in `state` (at most `max_ms`).
pub fn until_state(eb: &mut EmulatedBoard, state: State, max_ms: u64) {
    let ok = eb.run_until(max_ms, |b| b.board.state() == state);
    assert!(
        ok,
        "still {:?} after {max_ms} ms, wanted {state:?}",
        eb.board.state()
    );
}

/// How often a test's host keeps its continuous jog alive, ms (senders: at least every 100 ms;
/// the board's dead-man ends the jog after 250 ms without one).
pub const KEEPALIVE_MS: u64 = 50;

/// Runs `ms` as a host holding a continuous jog does: a keepalive every [`KEEPALIVE_MS`].
pub fn run_held(eb: &mut EmulatedBoard, ms: u64) {
    let mut left = ms;
    while left > 0 {
        eb.board.jog_keepalive();
        let n = left.min(KEEPALIVE_MS);
        eb.run_ms(n);
        left -= n;
    }
}

/// [`until_state`] while the host keeps its continuous jog alive ([`run_held`]).
pub fn until_state_held(eb: &mut EmulatedBoard, state: State, max_ms: u64) {
    let mut waited = 0;
    while eb.board.state() != state && waited < max_ms {
        eb.board.jog_keepalive();
        let n = (max_ms - waited).min(KEEPALIVE_MS);
        eb.run_until(n, |b| b.board.state() == state);
        waited += n;
    }
    until_state(eb, state, 0);
}

/// Runs until the kernel has stopped stepping and the board is idle-ish (no motion queued).
pub fn until_at_rest(eb: &mut EmulatedBoard, max_ms: u64) {
    let ok = eb.run_until(max_ms, |b| {
        b.board.motion().state() == gantry_machine::motion::pipeline::MotionState::Idle
            && b.kernel_drained()
    });
    assert!(ok, "still moving after {max_ms} ms");
}

/// Presses (`true`) or releases an input given by its logical level (no inverted pins here).
pub fn set(eb: &mut EmulatedBoard, s: Signal, on: bool) {
    eb.set_pin(s as u32, on);
}

/// Mark and Release pressed together, then let go: the board enters joystick jog mode.
pub fn enter_joystick(eb: &mut EmulatedBoard) {
    set(eb, Signal::Mark, true);
    set(eb, Signal::Release, true);
    eb.run_ms(2);
    set(eb, Signal::Mark, false);
    set(eb, Signal::Release, false);
    eb.run_ms(2);
    assert_eq!(eb.board.state(), State::Jog);
}

/// The events the board raised since the last call: those the emulator captured (after
/// `EmulatedBoard::capture_events`) and any still queued on the board.
pub fn events(eb: &mut EmulatedBoard) -> Vec<BoardEvent> {
    let mut v = std::mem::take(&mut eb.events);
    v.extend(std::iter::from_fn(|| eb.board.take_event()));
    v
}

pub fn steps(eb: &EmulatedBoard) -> [i64; 6] {
    eb.isr.kernel.position()
}

/// Streams `text` from a host that vanishes (stops sending anything) once the board runs line
/// `line` at 2 s link time; returns the board and the time (ms) its last bytes arrived.
pub fn host_vanishes(edit: impl FnOnce(&mut Setup), text: &str, line: u32) -> (EmulatedBoard, u32) {
    let mut client = Client::connect(board(edit), 2000).unwrap();
    let program = Program::from_text(text);
    let report = stream_program(&mut client, &program, &mut |p| {
        if p.line >= line && p.elapsed_ms >= 2000 {
            Flow::Detach
        } else {
            Flow::Continue
        }
    })
    .unwrap();
    assert!(report.alarms.is_empty());
    let eb = client.into_transport();
    let gone = eb.last_received_ms.unwrap();
    (eb, gone)
}
