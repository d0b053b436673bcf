//! O-word loops stream like M98/M99: a `while` loop jumps back 1,000 times by asking the host for
//! its lines again (the board keeps no line it has interpreted), and ends with exactly the steps of
//! the same program unrolled.

use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{stream_program, Flow, StreamReport};
use system_tests::reference;

fn stream_emulated(text: &str) -> (StreamReport, EmulatedBoard) {
    let mut client = Client::connect(EmulatedBoard::new(Setup::default()), 2000).unwrap();
    let report = stream_program(&mut client, &Program::from_text(text), &mut |_| {
        Flow::Continue
    })
    .unwrap();
    (report, client.transport)
}

/// Comment lines in the loop body: the jump back lands 20 file lines before the `endwhile`.
const PADDING: usize = 20;

/// The loop body: a zig-zag of +0.5 mm / -0.49 mm on X with padding comments between.
fn body() -> String {
    let mut b = String::from("G91 G1 X0.5 F3000\n");
    for i in 0..PADDING {
        b.push_str(&format!(
            "(padding {i}: the body is longer than the line buffer)\n"
        ));
    }
    b.push_str("G1 X-0.49\n");
    b
}

#[test]
fn a_while_loop_of_1000_turns_streams_with_the_steps_of_the_unrolled_program() {
    let mut looped = String::from("G21 G90 G94\nG0 X0 Y0 Z0\n#1 = 0\no1 while [#1 LT 1000]\n");
    looped.push_str(&body());
    looped.push_str("#1 = [#1 + 1]\no1 endwhile\nG90 G0 Y1\nM30\n");
    let mut unrolled = String::from("G21 G90 G94\nG0 X0 Y0 Z0\n");
    for _ in 0..1000 {
        unrolled.push_str(&body());
    }
    unrolled.push_str("G90 G0 Y1\nM30\n");
    assert!(looped.lines().count() > PADDING + 5);

    let (report, board) = stream_emulated(&looped);
    assert!(report.completed, "{:?} {:?}", report.errors, report.alarms);
    // One jump back per turn, served by the host as M99's are.
    assert!(report.jumps_served >= 1000, "{}", report.jumps_served);
    let r = reference(&unrolled, &Setup::default());
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
    // 1000 × 0.01 mm = 10 mm on X at 640 steps/mm; Y1 = 640 steps.
    assert_eq!(&r.steps[..3], &[6400, 640, 0]);
    let (report, unrolled_board) = stream_emulated(&unrolled);
    assert!(report.completed);
    assert_eq!(unrolled_board.pulses, board.pulses);
}
