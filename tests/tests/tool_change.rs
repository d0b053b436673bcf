//! M6 with a setup-defined tool-change position on the emulated board, in process
//! (docs/probing.md "Tool change"): spindle and coolant off, Z up first, then the other axes, a
//! stop at rest until cycle start, the next move from the change position; and the soft-limit
//! refusal of a position outside the travel.

mod controller_support;

use controller_support::*;
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::State;
use gantry_machine::board::{BoardEvent, JobEnd};
use gantry_machine::canon::Spindle;
use gantry_machine::setup::ToolChangePosition;

/// X -20, Y 30, Z 10 mm in machine coordinates.
const PLACE: ToolChangePosition = ToolChangePosition {
    axes: 0b111,
    at: [-20 * MM, 30 * MM, 10 * MM, 0, 0, 0],
};
const PLACE_STEPS: [i64; 6] = [
    -20 * STEPS_PER_MM,
    30 * STEPS_PER_MM,
    10 * STEPS_PER_MM,
    0,
    0,
    0,
];

/// Two tools, each M6 after a cut with spindle and flood on (serial_cli.rs streams the same job
/// through the binary).
const TWO_TOOL_JOB: &str = "G21 G90\nG0 X10 Y5 Z-2\nM3 S1000 M8\nG1 X20 F600\nT2 M6\nG0 X30\nG1 Z-1 F300\nT3 M6\nG91 G0 X5\nM2\n";

/// One tool change as the job reached it: tool, line, steps where it waits, and Z (steps) when
/// X or Y first moved on the M6's line.
#[derive(Debug, PartialEq)]
struct Change {
    tool: u32,
    line: u32,
    at: [i64; 6],
    z_when_sideways: i64,
}

#[test]
fn a_two_tool_job_changes_at_the_setup_s_position_z_first_and_goes_on_from_there() {
    let mut eb = board(|s| s.program.tool_change_position = PLACE);
    eb.capture_events();
    job(&mut eb, TWO_TOOL_JOB);
    let mut changes = Vec::new();
    for _ in 0..3 {
        // On an M6's line: spindle and flood are off before anything moves, and X/Y keep still
        // until Z stands at the change height.
        let mut start: Option<[i64; 6]> = None;
        let mut sideways_from = None;
        let done = eb.run_until(100_000, |b| {
            let line = b.board.line();
            if line == 5 || line == 8 {
                let p = b.isr.kernel.position();
                let s = *start.get_or_insert(p);
                if p != s {
                    let outputs = b.board.outputs();
                    assert_eq!(outputs.spindle, Spindle::Off, "line {line} at {p:?}");
                    assert!(!outputs.flood, "line {line} at {p:?}");
                }
                if sideways_from.is_none() && (p[0] != s[0] || p[1] != s[1]) {
                    sideways_from = Some(p[2]);
                }
            }
            matches!(b.board.state(), State::Idle | State::ToolChange) && b.kernel_drained()
        });
        assert!(done, "still {:?}: {:?}", eb.board.state(), events(&mut eb));
        if eb.board.state() == State::Idle {
            break;
        }
        changes.push(Change {
            tool: eb.board.tool_change().unwrap(),
            line: eb.board.line(),
            at: steps(&eb),
            z_when_sideways: sideways_from.unwrap(),
        });
        eb.run_ms(100);
        assert_eq!(
            eb.board.state(),
            State::ToolChange,
            "waits for the operator"
        );
        set(&mut eb, Signal::CycleStart1, true);
        eb.run_ms(5);
        set(&mut eb, Signal::CycleStart1, false);
    }
    let m = STEPS_PER_MM;
    assert_eq!(
        changes,
        vec![
            // From X20 Y5 Z-2: Z up to 10 alone, then X/Y.
            Change {
                tool: 2,
                line: 5,
                at: PLACE_STEPS,
                z_when_sideways: 10 * m,
            },
            // From X30 Y30 Z-1 (line 6's G0 X30 started at the change position's Y30 Z10).
            Change {
                tool: 3,
                line: 8,
                at: PLACE_STEPS,
                z_when_sideways: 10 * m,
            },
        ]
    );
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 10,
            end: JobEnd::Completed
        }]
    );
    // G91 G0 X5 after the second change: from.
    assert_eq!(steps(&eb), [-15 * m, 30 * m, 10 * m, 0, 0, 0]);
    assert_eq!(eb.board.outputs().tool, 3);
}

#[test]
fn a_tool_change_position_outside_the_travel_ends_the_job_at_the_m6_before_anything_moves() {
    // Z travel is ±100 mm; the change position's Z 150 mm would leave it.
    let mut eb = board(|s| {
        s.program.tool_change_position = ToolChangePosition {
            axes: 0b100,
            at: [0, 0, 150 * MM, 0, 0, 0],
        }
    });
    eb.capture_events();
    job(&mut eb, "G21 G90\nT1 M6\nG0 X10\nM2\n");
    until_state(&mut eb, State::Idle, 2_000);
    let ev = events(&mut eb);
    assert!(
        ev.contains(&BoardEvent::Error {
            line: 2,
            code: 900,
            column: 0
        }),
        "{ev:?}"
    );
    assert_eq!(steps(&eb), [0; 6], "nothing moved");
    assert_eq!(eb.board.tool_change(), None);
}
