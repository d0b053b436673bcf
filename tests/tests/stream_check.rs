//! Issue 25 item 7: `gantry stream` checks the whole program with the board's setup before the
//! first move, as LinuxCNC does: a typo on line 5 is reported in `gantry check`'s format and
//! nothing moves; `--no-check` streams it and the board stops at the bad line.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);
const PROGRAM: &str = "G21 G90\nG1 Z-1 F300\nG1 X10\nG1 X11\nG1 X12 Q5\nG1 X20\nM30\n";

#[test]
fn a_program_with_an_error_is_refused_before_the_first_move() {
    let dir = Dir::new("stream-check");
    let emu = Emulator::start(&dir, None);
    let file = dir.file("typo.ngc", PROGRAM);
    let out = gantry(&["--port", emu.port(), "stream", file.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stdout.contains("typo.ngc:5: error E211")
            && out.stdout.contains("G1 X12 Q5")
            && out.stdout.contains("nothing was run"),
        "{out:?}"
    );
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        !emu.log().contains(" Run line"),
        "the board ran: {}",
        emu.log()
    );
    let (steps, _) = emu.last_counts();
    assert_eq!(steps.trim(), "X 0 Y 0 Z 0");

    // --no-check: the board runs lines 1-4 and stops at line 5.
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "stream",
            "--no-check",
            file.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stdout.contains("E211") || out.stderr.contains("E211"),
        "{out:?}"
    );
    std::thread::sleep(Duration::from_millis(300));
    let (steps, _) = emu.last_counts();
    assert_eq!(steps.trim(), "X 7040 Y 0 Z -640", "{}", emu.log());
}
