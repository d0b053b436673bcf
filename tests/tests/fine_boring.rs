//! G76 fine boring (docs/gcode-transforms.md "Fanuc cycles"): refused without an oriented
//! spindle stop in the setup (E411); with `[spindle] orient_output` the Hurco cycle — feed to
//! the bottom, dwell, spindle stop, orient, shift by I/J, rapid out, shift back, spindle on —
//! as `gantry check --canon` prints it, and on the emulated board the orient output set at the
//! bottom with the shift waiting for the done input (or the dwell).

mod controller_support;
mod serial_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::setup::OrientSetup;
use serial_support::{gantry, Dir};
use std::time::Duration;

const S: Duration = Duration::from_secs(1);
const ORIENT_SETUP: &str =
    "[spindle]\norient_output = 3\norient_done_input = \"in20\"\norient_dwell_ms = 2000\n";

/// `gantry check --canon PROGRAM [--setup SETUP]`'s stdout (the program and setup written to
/// `dir`); the exit code must be `code`.
fn canon(dir: &Dir, program: &str, setup: Option<&str>, code: i32) -> String {
    let prog = dir.file("prog.ngc", program);
    let mut args = vec!["check".to_string(), "--canon".to_string()];
    if let Some(text) = setup {
        args.push("--setup".into());
        args.push(dir.file("setup.toml", text).to_str().unwrap().into());
    }
    args.push(prog.to_str().unwrap().into());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = gantry(&args, 60 * S);
    assert_eq!(out.code, Some(code), "{out:?}");
    out.stdout
}

const TWO_HOLES: &str = "G21 G90 G17 G94
G0 X0 Y0 Z10
M3 S1000
G98 G76 X20 Y10 Z-5 R2 I-0.5 J0.25 P0.5 F100
X30
G80
M5
M2
";

#[test]
fn g76_with_an_orient_output_bores_shifts_retracts_and_shifts_back() {
    let dir = Dir::new("g76-canon");
    let out = canon(&dir, TWO_HOLES, Some(ORIENT_SETUP), 0);
    // Each hole: down at F, dwell P, spindle off, orient, off the wall by I/J at the bottom,
    // out to the initial level (G98), back over the hole, spindle on as before. The second
    // block keeps R, Z, P, I, J and F.
    let mut want = String::from(
        "{\"line\":2,\"op\":\"rapid\",\"to\":[0,0,10]}
{\"line\":3,\"op\":\"spindle\",\"state\":\"cw\",\"rpm\":1000}
",
    );
    for (line, x) in [(4, 20.0), (5, 30.0)] {
        want += &format!("{{\"line\":{line},\"op\":\"rapid\",\"to\":[{x},10,10]}}\n");
        want += &format!(
            "{{\"line\":{line},\"op\":\"rapid\",\"to\":[{x},10,2]}}
{{\"line\":{line},\"op\":\"feed\",\"to\":[{x},10,-5],\"feed\":100}}
{{\"line\":{line},\"op\":\"dwell\",\"seconds\":0.5}}
{{\"line\":{line},\"op\":\"spindle\",\"state\":\"off\",\"rpm\":0}}
{{\"line\":{line},\"op\":\"orient\"}}
{{\"line\":{line},\"op\":\"rapid\",\"to\":[{sx},10.25,-5]}}
{{\"line\":{line},\"op\":\"rapid\",\"to\":[{sx},10.25,10]}}
{{\"line\":{line},\"op\":\"rapid\",\"to\":[{x},10,10]}}
{{\"line\":{line},\"op\":\"spindle\",\"state\":\"cw\",\"rpm\":1000}}
",
            sx = x - 0.5
        );
    }
    want += "{\"line\":7,\"op\":\"spindle\",\"state\":\"off\",\"rpm\":1000}
{\"line\":8,\"op\":\"stop\",\"kind\":\"end\"}
";
    assert_eq!(out, want);
}

#[test]
fn g76_in_g91_g99_with_repeats_retracts_to_r() {
    let dir = Dir::new("g76-g91");
    let program = "G21 G90 G17
G0 X0 Y0 Z10
M4 S500
G91 G99 G76 X10 Y0 Z-7 R-8 J-1 L2 F50
G90 G80
M2
";
    let out = canon(&dir, program, Some(ORIENT_SETUP), 0);
    // G91: R is 8 below the initial level (Z2), the bottom 7 below R (Z-5); each repeat
    // moves X by 10; G99: out to R only. The spindle turned M4 and restarts M4.
    let mut want = String::from(
        "{\"line\":2,\"op\":\"rapid\",\"to\":[0,0,10]}
{\"line\":3,\"op\":\"spindle\",\"state\":\"ccw\",\"rpm\":500}
{\"line\":4,\"op\":\"rapid\",\"to\":[10,0,10]}
",
    );
    for x in [10, 20] {
        if x == 20 {
            want += "{\"line\":4,\"op\":\"rapid\",\"to\":[20,0,2]}\n";
        } else {
            want += "{\"line\":4,\"op\":\"rapid\",\"to\":[10,0,2]}\n";
        }
        want += &format!(
            "{{\"line\":4,\"op\":\"feed\",\"to\":[{x},0,-5],\"feed\":50}}
{{\"line\":4,\"op\":\"spindle\",\"state\":\"off\",\"rpm\":0}}
{{\"line\":4,\"op\":\"orient\"}}
{{\"line\":4,\"op\":\"rapid\",\"to\":[{x},-1,-5]}}
{{\"line\":4,\"op\":\"rapid\",\"to\":[{x},-1,2]}}
{{\"line\":4,\"op\":\"rapid\",\"to\":[{x},0,2]}}
{{\"line\":4,\"op\":\"spindle\",\"state\":\"ccw\",\"rpm\":500}}
"
        );
    }
    want += "{\"line\":6,\"op\":\"stop\",\"kind\":\"end\"}\n";
    assert_eq!(out, want);
}

#[test]
fn g76_without_an_orient_output_stays_e411_and_q_is_e413() {
    let dir = Dir::new("g76-refused");
    let out = canon(&dir, TWO_HOLES, None, 1);
    let last = out.lines().last().unwrap();
    assert!(
        last.starts_with("{\"line\":4,\"op\":\"error\",\"message\":\"E411:"),
        "{out}"
    );
    assert!(!out.contains("\"orient\""), "{out}");
    // The Fanuc shift Q (its direction a machine parameter) is refused even with the output.
    let q = "G21 G90\nM3 S100\nG76 X1 Y1 Z-1 R1 Q0.5 F10\nM2\n";
    let out = canon(&dir, q, Some(ORIENT_SETUP), 1);
    let last = out.lines().last().unwrap();
    assert!(
        last.starts_with("{\"line\":3,\"op\":\"error\",\"message\":\"E413:"),
        "{out}"
    );
    // G76 needs the spindle turning, as the other boring cycles that stop and restart it.
    let off = "G21 G90\nG76 X1 Y1 Z-1 R1 I-0.1 F10\nM2\n";
    let out = canon(&dir, off, Some(ORIENT_SETUP), 1);
    assert!(
        out.lines()
            .last()
            .unwrap()
            .starts_with("{\"line\":2,\"op\":\"error\",\"message\":\"E406:"),
        "{out}"
    );
}

const ONE_HOLE: &str = "G21 G90 G94
M3 S1000
G0 X0 Y0 Z0
G99 G76 X5 Y0 Z-2 R1 I-1 F600
G80
M5
M2
";

const ORIENT_BIT: u16 = 1 << 3;

fn orient_board(done_input: u8, dwell_ms: u16) -> EmulatedBoard {
    board(|s| {
        s.outputs.orient = OrientSetup {
            output: 3,
            done_input,
            dwell_ms,
        }
    })
}

/// Runs until the orient output is set; the machine stands at the hole's bottom, spindle off.
fn until_oriented(eb: &mut EmulatedBoard) {
    assert!(
        eb.run_until(20_000, |b| b.board.output_levels().user & ORIENT_BIT != 0),
        "the orient output never came on"
    );
    assert_eq!(steps(eb)[..3], [5 * STEPS_PER_MM, 0, -2 * STEPS_PER_MM]);
    assert!(!eb.board.output_levels().spindle_enable);
}

#[test]
fn on_the_board_the_shift_waits_for_the_orient_done_input() {
    let mut eb = orient_board(20, 0);
    job(&mut eb, ONE_HOLE);
    until_oriented(&mut eb);
    // Two seconds without the done input: nothing moves, the output stays on.
    eb.run_ms(2000);
    assert_eq!(steps(&eb)[..3], [5 * STEPS_PER_MM, 0, -2 * STEPS_PER_MM]);
    assert_eq!(eb.board.output_levels().user, ORIENT_BIT);
    eb.set_pin(20, true);
    // The shift by I-1 at the bottom comes first (X moves while Z stands at the bottom), then
    // the retract to R.
    assert!(eb.run_until(10_000, |b| steps(b)[0] != 5 * STEPS_PER_MM));
    assert_eq!(
        steps(&eb)[..3],
        [5 * STEPS_PER_MM - 1, 0, -2 * STEPS_PER_MM]
    );
    assert!(eb.run_until(10_000, |b| steps(b)[2] != -2 * STEPS_PER_MM));
    assert!(steps(&eb)[0] <= 4 * STEPS_PER_MM + 2, "{:?}", steps(&eb));
    until_state(&mut eb, State::Idle, 20_000);
    assert_eq!(steps(&eb)[..3], [5 * STEPS_PER_MM, 0, STEPS_PER_MM]);
    // The spindle restart released the orient output.
    assert_eq!(eb.board.output_levels().user, 0);
}

#[test]
fn on_the_board_without_a_done_input_the_orient_takes_its_dwell() {
    let mut eb = orient_board(OrientSetup::NONE, 700);
    job(&mut eb, ONE_HOLE);
    until_oriented(&mut eb);
    let set_at = eb.now_ms();
    assert!(eb.run_until(10_000, |b| steps(b)[0] != 5 * STEPS_PER_MM));
    let waited = eb.now_ms().wrapping_sub(set_at);
    assert!(
        (700..760).contains(&waited),
        "moved {waited} ms after the orient"
    );
    until_state(&mut eb, State::Idle, 20_000);
    assert_eq!(steps(&eb)[..3], [5 * STEPS_PER_MM, 0, STEPS_PER_MM]);
    assert_eq!(eb.board.output_levels().user, 0);
}

#[test]
fn on_the_board_an_orient_that_never_completes_alarms_after_its_timeout() {
    let mut eb = orient_board(20, 500);
    job(&mut eb, ONE_HOLE);
    until_oriented(&mut eb);
    until_state(&mut eb, State::Alarm, 5_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ListInputTimeout));
    assert_eq!(steps(&eb)[..3], [5 * STEPS_PER_MM, 0, -2 * STEPS_PER_MM]);
}
