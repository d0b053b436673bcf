//! The dead-man of a continuous host jog (docs/controller.md "Jogging"): the board ends the jog
//! with a controlled stop when no keepalive came for 250 ms on its own clock, whatever the host
//! does; keepalives closer than that keep it going; a stepped jog needs none. Virtual time: every
//! figure is exact.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::State;
use gantry_machine::board::JOG_DEADMAN_MS;
use gantry_machine::board::{BoardEvent, ERROR_JOG_DEADMAN};
use gantry_machine::motion::pipeline::MotionState;

/// 3000 mm/min = 50 mm/s on X (default acceleration 200 mm/s²: 6.25 mm to stop).
const FEED_UM_MIN: i32 = 3_000_000;

/// The board ms of the dead-man's stop: runs a millisecond at a time until the board takes the
/// kernel's queue back (the stop's first act), at most `max_ms`.
fn ms_of_stop(eb: &mut EmulatedBoard, max_ms: u64) -> u32 {
    let before = eb.last_drop;
    assert!(
        eb.run_until(max_ms, |b| b.last_drop != before),
        "no stop within {max_ms} ms"
    );
    (eb.last_drop.unwrap().time / COUNTS_PER_MS) as u32
}

fn deadman_errors(eb: &mut EmulatedBoard) -> usize {
    events(eb)
        .iter()
        .filter(|e| {
            matches!(
                e,
                BoardEvent::Error {
                    line: 0,
                    code: ERROR_JOG_DEADMAN,
                    column: 0
                }
            )
        })
        .count()
}

#[test]
fn a_continuous_jog_stops_250_ms_after_its_last_keepalive() {
    assert_eq!(JOG_DEADMAN_MS, 250);
    let mut eb = board(|_| {});
    eb.capture_events();
    eb.run_ms(10);
    assert!(eb.board.jog(0, FEED_UM_MIN, 0));
    // Kept alive for 1 s (every 50 ms): at full speed, no stop.
    run_held(&mut eb, 1000);
    assert_eq!(eb.board.state(), State::Jog);
    assert_eq!(eb.last_drop, None);
    // The last keepalive, then silence.
    eb.board.jog_keepalive();
    let heard = eb.board.now_ms();
    let at = ms_of_stop(&mut eb, 1000);
    assert_eq!(
        at,
        heard + JOG_DEADMAN_MS,
        "stopped at {at} ms, last keepalive at {heard} ms"
    );
    // A controlled stop: it decelerates from 50 mm/s over v²/2a = 6.25 mm (plus what the
    // running segment still had, < 0.2 mm), then nothing moves.
    let from = steps(&eb)[0];
    until_state(&mut eb, State::Idle, 2000);
    let travelled = (steps(&eb)[0] - from) as f64 / STEPS_PER_MM as f64;
    assert!(
        (6.25 - 0.01..6.25 + 0.2).contains(&travelled),
        "stopped in {travelled} mm"
    );
    assert_eq!(deadman_errors(&mut eb), 1);
    let rest = steps(&eb);
    eb.run_ms(500);
    assert_eq!(steps(&eb), rest);
    assert_eq!(eb.board.motion().state(), MotionState::Idle);
    // Nothing lost: the board's position is the kernel's.
    assert_eq!(eb.board.motion().prepared_steps(), rest);
}

#[test]
fn the_jog_request_itself_starts_the_250_ms() {
    let mut eb = board(|_| {});
    eb.capture_events();
    eb.run_ms(10);
    assert!(eb.board.jog(0, -FEED_UM_MIN, 0));
    let asked = eb.board.now_ms();
    assert_eq!(ms_of_stop(&mut eb, 1000), asked + JOG_DEADMAN_MS);
    until_state(&mut eb, State::Idle, 2000);
    assert_eq!(deadman_errors(&mut eb), 1);
}

#[test]
fn keepalives_249_ms_apart_keep_it_going() {
    let mut eb = board(|s| s.axes[0].travel_max = 1000 * MM);
    eb.capture_events();
    assert!(eb.board.jog(0, FEED_UM_MIN, 0));
    for _ in 0..12 {
        eb.run_ms(u64::from(JOG_DEADMAN_MS) - 1);
        assert_eq!(eb.last_drop, None);
        eb.board.jog_keepalive();
    }
    // 3 s at 50 mm/s less the ramp up (0.125 mm): still going, never stopped.
    assert_eq!(eb.board.state(), State::Jog);
    let x = steps(&eb)[0] as f64 / STEPS_PER_MM as f64;
    assert!(x > 140.0, "at X {x}");
    assert_eq!(deadman_errors(&mut eb), 0);
    eb.board.jog_stop();
    until_state(&mut eb, State::Idle, 2000);
    assert_eq!(deadman_errors(&mut eb), 0, "a jog stop is no dead-man stop");
}

#[test]
fn a_stepped_jog_runs_its_whole_distance_without_keepalives() {
    let mut eb = board(|_| {});
    eb.capture_events();
    // 50 mm at 50 mm/s: over a second, four times the dead-man's time, with no keepalive.
    assert!(eb.board.jog(0, FEED_UM_MIN, 50 * MM as u64));
    until_state(&mut eb, State::Idle, 5000);
    assert_eq!(steps(&eb)[0], 50 * STEPS_PER_MM);
    assert_eq!(eb.last_drop, None);
    assert_eq!(deadman_errors(&mut eb), 0);
    // A keepalive with no continuous jog does nothing.
    eb.board.jog_keepalive();
    eb.run_ms(300);
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(steps(&eb)[0], 50 * STEPS_PER_MM);
}

/// A stepped jog after a continuous one does not inherit the continuous jog's dead-man.
#[test]
fn the_deadman_ends_with_its_jog() {
    let mut eb = board(|_| {});
    eb.capture_events();
    assert!(eb.board.jog(0, FEED_UM_MIN, 0));
    run_held(&mut eb, 300);
    eb.board.jog_stop();
    until_state(&mut eb, State::Idle, 2000);
    let from = steps(&eb)[0];
    eb.last_drop = None;
    assert!(eb.board.jog(0, -FEED_UM_MIN, 40 * MM as u64));
    until_state(&mut eb, State::Idle, 5000);
    assert_eq!(steps(&eb)[0], from - 40 * STEPS_PER_MM);
    assert_eq!(eb.last_drop, None);
    assert_eq!(deadman_errors(&mut eb), 0);
}
