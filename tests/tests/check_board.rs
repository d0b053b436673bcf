//! `gantry check`, `simulate` and `preview` measure a program against the machine: with a board
//! (`--port`, through the binary against `gantry emulate --pty`) its setup and where it stands,
//! with `--setup FILE` the file, with neither the built-in defaults; each says which on stderr.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

/// The `Y extents` line of a check summary.
fn y_extents(stdout: &str) -> &str {
    stdout
        .lines()
        .find(|l| l.trim_start().starts_with("Y extents"))
        .unwrap_or("")
}

#[test]
fn check_uses_the_boards_travel_and_position() {
    let dir = Dir::new("check-board");
    // The board's Y runs 0 .. 400 mm (the defaults: -200 .. 200).
    let machine = dir.file("router.toml", "[axis.Y]\ntravel = [0.0, 400.0]\n");
    let emu = Emulator::start(&dir, Some(&machine));
    let far = dir.file("far.ngc", "G21 G90\nG0 X10 Y300\nM2\n");
    let near = dir.file("near.ngc", "G21 G90\nG0 X10 Y-100\nM2\n");

    // Fits the board, not the defaults.
    let out = gantry(&["--port", emu.port(), "check", far.to_str().unwrap()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains(&format!(
            "gantry check: the board's setup on {}, machine at X 0 Y 0 Z 0",
            emu.port()
        )),
        "{out:?}"
    );
    assert!(
        y_extents(&out.stdout).contains("(travel 0.000 .. 400.000)"),
        "{out:?}"
    );
    assert!(out.stdout.contains("far.ngc: ok, "), "{out:?}");
    let out = gantry(&["check", far.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stderr.contains("gantry check: built-in defaults"),
        "{out:?}"
    );
    // Not "ok" followed by an exceeded travel: the first line says it.
    assert!(
        out.stdout
            .contains("far.ngc: no program errors, 2 actions, but line 2 leaves the Y travel"),
        "{out:?}"
    );
    // Fits the defaults, not the board.
    let out = gantry(&["--port", emu.port(), "check", near.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("line 2 leaves the Y travel"), "{out:?}");
    // --setup FILE: the file, whatever the board.
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "check",
            "--setup",
            machine.to_str().unwrap(),
            far.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains(&format!(
            "gantry check: setup file {}, machine at 0, 0, 0",
            machine.display()
        )),
        "{out:?}"
    );

    // Where the machine stands: Y 50, so 60 mm down in G91 ends at Y -10, outside the board's
    // travel; the extents start at Y 50.
    let out = gantry(&["--port", emu.port(), "mdi", "G21 G90 G0 Y50"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let down = dir.file("down.ngc", "G21 G91\nG0 Y-60\nM2\n");
    let out = gantry(&["--port", emu.port(), "check", down.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stderr.contains("machine at X 0 Y 50 Z 0"), "{out:?}");
    let y = y_extents(&out.stdout);
    assert!(
        y.contains("-10.000 ..") && y.contains(" 50.000 mm"),
        "{out:?}"
    );
    assert!(out.stdout.contains("line 2 leaves the Y travel"), "{out:?}");

    // simulate: the board's setup, and the planned time from where it stands (a rapid of
    // 50 mm from Y 50 to Y 100 rather than 100 mm from 0).
    let up = dir.file("up.ngc", "G21 G90\nG0 Y100\nM2\n");
    let out = gantry(&["--port", emu.port(), "simulate", up.to_str().unwrap()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains("gantry simulate: the board's setup on"),
        "{out:?}"
    );
    let from_board = total_seconds(&out.stdout);
    let out = gantry(&["simulate", up.to_str().unwrap()], T);
    let from_zero = total_seconds(&out.stdout);
    // 3000 mm/min, 200 mm/s²: 50 mm take 1.15 s, 100 mm 2.15 s.
    assert!(
        (from_zero - from_board - 1.0).abs() < 0.01,
        "{from_board} {from_zero}"
    );

    // preview: the board's setup too.
    let png = dir.0.join("up.svg");
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "preview",
            up.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains("gantry preview: the board's setup on"),
        "{out:?}"
    );
}

/// The total of `gantry simulate`'s last line, s.
fn total_seconds(stdout: &str) -> f64 {
    let last = stdout.lines().last().unwrap_or("");
    last.split_whitespace()
        .find_map(|w| w.trim_end_matches('s').parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no total in {last:?}"))
}
