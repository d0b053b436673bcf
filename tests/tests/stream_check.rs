//! `gantry stream` checks the whole program with the board's setup before the
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

/// `--from-line` past a tool change. The preamble's `T1 M6` stops and prompts
/// like a program's own M6 (Enter continues it), the tool goes up to a safe height before XY and
/// comes down to the cut only over the start point, and the job ends where an uninterrupted run
/// ends. An abort during the preamble suggests the line the run started from, not line 1.
#[test]
fn run_from_line_past_a_tool_change_prompts_and_moves_xy_before_z() {
    const TC: &str = "G21 G90\nG0 Z5\nT1 M6\nM3 S1000\nG0 X10 Y10\nG1 Z-1 F300\nG1 X20\nG1 Y20\nG1 X10\nG0 Z5\nM30\n";
    let dir = Dir::new("from-line-m6");
    let emu = Emulator::start(&dir, None);
    let file = dir.file("tc.ngc", TC);
    // The machine stands low (Z -3) where the last run stopped.
    let out = gantry(&["--port", emu.port(), "mdi", "G53 G0 X40 Y40 Z-3"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let mut run = spawn(&[
        "--port",
        emu.port(),
        "stream",
        file.to_str().unwrap(),
        "--from-line",
        "7",
    ]);
    assert!(
        wait_for(Duration::from_secs(20), || (run.stdout() + &run.stderr())
            .contains("resume preamble: tool change: put tool 1")),
        "no prompt: {} {}",
        run.stdout(),
        run.stderr()
    );
    let before = emu.log();
    assert!(before.contains("ToolChange"), "{before}");
    run.answer("");
    let out = run.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("job done"), "{out:?}");
    // Preamble: up to the program's clearance (Z 5, higher than Z -3 where the tool stands and
    // Z -1 at the start point), then XY, then down: the preamble lines say so, in this order.
    let pre: Vec<&str> = out
        .stdout
        .lines()
        .skip_while(|l| !l.starts_with("resuming at line 7"))
        .skip(1)
        .take_while(|l| l.starts_with("    "))
        .map(str::trim)
        .collect();
    let z_up = pre.iter().position(|l| l.starts_with("G53 G0 Z")).unwrap();
    let xy = pre
        .iter()
        .position(|l| l.starts_with("G53 G0 X10 Y10"))
        .unwrap();
    let down = pre
        .iter()
        .position(|l| l.starts_with("G53 G1 Z-1"))
        .unwrap();
    assert!(z_up < xy && xy < down, "{pre:?}");
    assert_eq!(pre[z_up], "G53 G0 Z5", "{pre:?}");
    std::thread::sleep(Duration::from_millis(300));
    // Where an uninterrupted run ends: X10 Y20 Z5.
    let (steps, _) = emu.last_counts();
    assert_eq!(steps.trim(), "X 6400 Y 12800 Z 3200", "{}", emu.log());
}
