//! Lines up to 256 characters (LinuxCNC's limit) travel end to end: `gantry stream`
//! packs one into a batch, the board's line ring stores it and the interpreter reads it there.
//! Through the binary against `gantry emulate --pty`, as a user runs it. A 257-character line
//! is refused before anything moves, naming its line.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

/// A move to X = 2 × 5 mm written as one line of `len` characters without blanks: a named
/// parameter in an expression padded with `+0` terms, and a feed padded with leading zeros.
fn long_move(len: usize) -> String {
    let head = "G1X[#<x_distance_of_the_long_line_test>*2";
    let tail = "]F600";
    let pad = len - head.len() - tail.len();
    let line = format!("{head}{}{tail}", "+0".repeat(pad / 2));
    // An odd padding puts a leading zero in the feed.
    let line = if pad % 2 == 1 {
        line.replace("]F600", "]F0600")
    } else {
        line
    };
    assert_eq!(line.len(), len);
    line
}

fn program(len: usize) -> String {
    format!(
        "G21 G90 (a comment the host drops)\n#<x_distance_of_the_long_line_test> = 5\n{}\nM30\n",
        long_move(len)
    )
}

#[test]
fn a_256_character_line_streams_over_a_pty_and_257_is_refused() {
    let dir = Dir::new("long-lines");
    let emu = Emulator::start(&dir, None);
    let file = dir.file("long.ngc", &program(256));
    let out = gantry(&["--port", emu.port(), "stream", file.to_str().unwrap()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    // X 10 mm at 640 steps/mm.
    let (steps, _) = emu.idle_counts(T);
    assert_eq!(steps.trim(), "X 6400 Y 0 Z 0", "{}", emu.log());

    // Still where the 256-character line left it.
    let nothing_moved = || {
        let (steps, _) = emu.last_counts();
        assert_eq!(
            steps.trim(),
            "X 6400 Y 0 Z 0",
            "nothing moved: {}",
            emu.log()
        );
    };

    let file = dir.file("longer.ngc", &program(257));
    let out = gantry(&["--port", emu.port(), "stream", file.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stdout.contains(
            "longer.ngc:3: error: line too long for the board: 257 characters without comments and blanks, at most 256"
        ),
        "{out:?}"
    );
    std::thread::sleep(Duration::from_millis(300));
    nothing_moved();

    // Without the check the sender still refuses it as it reads the file, with its number.
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
    assert_eq!(out.code, Some(2), "{out:?}");
    assert_eq!(
        out.stderr,
        "gantry: line 3: 257 characters without comments and blanks, the board takes at most 256\n"
    );
    nothing_moved();
}
