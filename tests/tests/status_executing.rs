//! The status describes the move being executed, not the lines the board has read ahead:
//! work position, work system, units and programmed feed are those of the block the step
//! kernel runs (machine/src/board/executing.rs), in Gantry's status and in grbl's `?` report.

mod controller_support;
mod serial_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::State;
use gantry_machine::device::link::status_of;
use gantry_machine::gcode::config::Tool;
use gantry_machine::setup::Setup;

/// T1 10 mm long, T2 22.5 mm.
fn with_tools(s: &mut Setup) {
    for (number, length) in [(1, 10 * MM), (2, 22_500_000)] {
        s.program
            .tools
            .push(Tool {
                number,
                length,
                diameter: 6 * MM,
            })
            .unwrap();
    }
}

/// Cuts 100 mm along X at work Z −1 with H1; `G43 H2` and its retract follow, read ahead long
/// before the cut ends.
const TWO_TOOLS: &str = "G21 G90\nG10 L2 P1 X0 Y0 Z-80\nG43 H1\nG0 X0 Y0 Z5\nG1 Z-1 F300\n\
G1 X100 F600\nG43 H2\nG0 Z5\nM30\n";

fn mid_cut(eb: &mut EmulatedBoard) {
    job(eb, TWO_TOOLS);
    // 2 s into the 10 s cut along X: everything after it is read and queued.
    assert!(eb.run_until(60_000, |b| b.board.line() == 6));
    eb.run_ms(2_000);
    assert_eq!(eb.board.state(), State::Run);
    assert_eq!(eb.board.line(), 6);
    assert_eq!(
        eb.board.lines_buffered(),
        0,
        "the rest of the program is read"
    );
}

#[test]
fn a_tool_length_read_ahead_does_not_move_the_work_position_of_the_cut() {
    let mut eb = board(with_tools);
    mid_cut(&mut eb);
    // The interpreter already has H2 (its Z offset −80 + 22.5 mm) ...
    let ahead = eb.board.interpreter().state().offset()[2];
    assert_eq!(ahead, -57_500_000);
    // ... but the cut runs with H1: machine Z −80 + 10 − 1 = −71 mm, work Z −1 mm exactly.
    let s = status_of(&eb.board, &eb.kernel_view());
    assert_eq!(s.machine_pos[2], -71 * MM);
    assert_eq!(s.work_pos[2], -MM);
    assert_eq!(s.work_pos[1], 0);
    assert_eq!(s.machine_pos[0] - s.work_pos[0], 0);
    assert_eq!(s.programmed_feed_um_min, 600_000);
    assert_eq!(s.work_system, 0);
    assert!(!s.inch);
    // Once the retract under H2 runs, the status has H2: machine Z −80 + 22.5 + 5.
    until_state(&mut eb, State::Idle, 30_000);
    let s = status_of(&eb.board, &eb.kernel_view());
    assert_eq!(s.machine_pos[2], -52_500_000);
    assert_eq!(s.work_pos[2], 5 * MM);
    assert_eq!(s.programmed_feed_um_min, 0, "nothing queued");
}

#[test]
fn grbl_reports_the_offset_of_the_cut_in_wco() {
    let mut eb = board(with_tools);
    let mut seen = String::new();
    let run = |eb: &mut EmulatedBoard, ms: u64, seen: &mut String| {
        for _ in 0..ms {
            eb.run_ms(1);
            seen.push_str(&String::from_utf8_lossy(&eb.take_output()));
        }
    };
    // A grbl sender: each line after the `ok` of the one before (the planner takes them all).
    for line in TWO_TOOLS.lines().filter(|l| *l != "M30") {
        let oks = seen.matches("ok\r\n").count();
        eb.receive(format!("{line}\n").as_bytes());
        for _ in 0..2_000 {
            if seen.matches("ok\r\n").count() > oks {
                break;
            }
            run(&mut eb, 1, &mut seen);
        }
        assert!(
            seen.matches("ok\r\n").count() > oks,
            "no ok for {line}: {seen}"
        );
    }
    assert!(eb.run_until(60_000, |b| b.board.line() == 6));
    eb.run_ms(2_000);
    assert_eq!(eb.board.state(), State::Run);
    seen.clear();
    eb.receive(b"?");
    run(&mut eb, 50, &mut seen);
    // MPos Z −71 and WCO Z = G54 −80 + H1 10 = −70 mm (not −57.5 with the H2 read ahead), so
    // the sender's work Z is −1.
    let report = seen
        .lines()
        .find(|l| l.starts_with("<Run"))
        .unwrap_or_else(|| panic!("{seen}"));
    assert!(report.contains(",0.000,-71.000|Ln:6|FS:600,0|"), "{report}");
    assert!(report.contains("|WCO:0.000,0.000,-70.000"), "{report}");
}

#[test]
fn units_and_work_system_read_ahead_wait_for_their_move() {
    let mut eb = board(|_| {});
    // 1.6 in = 40.64 mm along X at 20 in/min (5 s), then G21 G55 read ahead.
    job(&mut eb, "G20 G90 G54\nG1 X1.6 F20\nG21 G55\nG0 X0\n");
    assert!(eb.run_until(10_000, |b| b.board.line() == 2));
    eb.run_ms(2_000);
    assert_eq!(eb.board.line(), 2);
    assert!(!eb.board.interpreter().state().inch, "G21 is read");
    let s = status_of(&eb.board, &eb.kernel_view());
    assert!(s.inch);
    assert_eq!(s.work_system, 0);
    // 20 in/min = 508 mm/min.
    assert_eq!(s.programmed_feed_um_min, 508_000);
    assert!(
        (500_000..=516_000).contains(&s.feed_um_min),
        "{}",
        s.feed_um_min
    );
    until_state(&mut eb, State::Idle, 20_000);
    let s = status_of(&eb.board, &eb.kernel_view());
    assert!(!s.inch);
    assert_eq!(s.work_system, 1);
}

#[test]
fn the_spindle_override_scales_the_output_not_the_programmed_speed() {
    let mut eb = board(|_| {});
    job(&mut eb, "M3 S10000\nG4 P5\nM30\n");
    assert!(eb.run_until(5_000, |b| b.board.outputs().rpm == 10_000));
    // 0-24000 rpm on PWM 0-1000 (the default setup).
    assert_eq!(eb.board.output_levels().spindle_pwm, 417);
    eb.board.set_spindle_override(150);
    let s = status_of(&eb.board, &eb.kernel_view());
    assert_eq!(s.spindle_override, 150);
    assert_eq!(s.outputs.rpm, 10_000, "programmed S stays");
    assert_eq!(eb.board.output_levels().spindle_pwm, 625, "15000 rpm");
    eb.board.set_spindle_override(5);
    assert_eq!(eb.board.spindle_override(), 10, "clamped to 10 %");
}

/// Through the binary: `gantry status` from another terminal while `gantry stream` runs the job
/// under `gantry serve`, against `gantry emulate --pty` with the two tools in its setup.
mod through_the_binary {
    use super::serial_support::*;
    use std::time::Duration;

    const S: Duration = Duration::from_secs(1);

    #[test]
    fn gantry_status_shows_the_work_position_of_the_cut_not_of_the_lines_read_ahead() {
        let dir = Dir::new("status-executing");
        let setup = dir.file(
            "tools.toml",
            "[[tool]]\nnumber = 1\nlength = 10.0\n[[tool]]\nnumber = 2\nlength = 22.5\n",
        );
        let emu = Emulator::start(&dir, Some(&setup));
        let port = emu.port();
        let server = spawn(&["serve", "--port", port]);
        assert!(wait_for(10 * S, || server
            .stderr()
            .contains("is served on")));
        let job = dir.file("two-tools.nc", super::TWO_TOOLS);
        let _sender = spawn(&["stream", job.to_str().unwrap(), "--port", port]);
        // The cut along X (line 6) takes 10 s; the rest of the program is read ahead by then.
        let mut text = String::new();
        assert!(
            wait_for(30 * S, || {
                text = gantry(&["status", "--port", port], 10 * S).stdout;
                text.contains("line:      6\n")
            }),
            "{text}\n{}",
            emu.log()
        );
        std::thread::sleep(S);
        let text = gantry(&["status", "--port", port], 10 * S).stdout;
        assert!(text.contains("\nline:      6\n"), "{text}");
        // H1 in force for the cut: machine Z −80 + 10 − 1 = −71, work Z −1 (main showed −13.500:
        // the H2 read ahead).
        let z = |name: &str| {
            let line = text.lines().find(|l| l.starts_with(name)).unwrap();
            line.split_whitespace()
                .skip_while(|w| *w != "Z")
                .nth(1)
                .unwrap()
                .to_owned()
        };
        assert_eq!(z("machine:"), "-71.000", "{text}");
        assert_eq!(z("work:"), "-1.000", "{text}");
        assert!(text.contains("\nprogram:   G54, G21 (mm)\n"), "{text}");
        assert!(text.contains(", programmed 600.0 mm/min ("), "{text}");
        let out = gantry(&["abort", "--port", port], 10 * S);
        assert_eq!(out.code, Some(0), "{out:?}");
    }

    #[test]
    fn gantry_override_spindle_sets_the_spindle_speed_override() {
        let dir = Dir::new("override-spindle");
        let emu = Emulator::start(&dir, None);
        let port = emu.port();
        let out = gantry(&["override", "--spindle", "150", "--port", port], 10 * S);
        assert_eq!(out.code, Some(0), "{out:?}");
        assert!(
            out.stdout
                .contains("(override feed 100 %, rapid 100 %, spindle 150 %)"),
            "{out:?}"
        );
        let out = gantry(&["status", "--port", port], 10 * S);
        assert!(out.stdout.contains("spindle 150 %)"), "{out:?}");
        let out = gantry(&["override", "--spindle", "5", "--port", port], 10 * S);
        assert_eq!(out.code, Some(2), "{out:?}");
        assert!(
            out.stderr.contains("--spindle 5: must be 10-200 %"),
            "{out:?}"
        );
        let out = gantry(&["override", "--port", port], 10 * S);
        assert_eq!(out.code, Some(2), "{out:?}");
        assert!(
            out.stderr.contains("give --feed, --rapid and/or --spindle"),
            "{out:?}"
        );
    }
}
