//! The Fanuc coordinate transforms (docs/gcode-transforms.md) through the interpreter: the
//! errors the manuals name, the pipeline's interplay with compensation, offsets, G53 and
//! program end, with hand-checked positions; and the Fanuc cycles G74, G76, G84.2, G84.3 and M19.
//! The manuals' example programs are in
//! tests/golden/transforms/ (through `gantry check --canon`).
mod gcode_support;

use gantry_machine::canon::{Action, ArcDir};
use gantry_machine::gcode::{ErrorCode, InterpConfig, Interpreter, MemorySource};
use gcode_support::{first_error, moves, run, MM};

#[test]
fn the_errors_the_manuals_name() {
    use ErrorCode::*;
    let cases: &[(&str, u32, ErrorCode)] = &[
        // Hurco P11: G51 alone, not nested; P6: G92 needs G50.
        ("G51 P2.\nG51 P3.", 2, TransformOrder),
        ("G51 P2. F100", 1, TransformNotAlone),
        ("G1 G51 P2. F100", 1, TransformNotAlone),
        ("G51 P2.\nG92 X0", 2, TransformOffset),
        ("G68 R30.\nG52 X1", 2, TransformOffset),
        ("G51.1 X0\nG10 L20 P1 X0", 2, TransformOffset),
        // P13: G68 not nested, no plane change under it.
        ("G68 R30.\nG68 R10.", 2, TransformOrder),
        ("G68 R30.\nG19", 2, TransformPlane),
        // P12: the mirror is not set under rotation or scaling; G51 is not set under G68.
        ("G68 R30.\nG51.1 X0", 2, TransformOrder),
        ("G51 P2.\nG51.1 X0", 2, TransformOrder),
        ("G51 P2.\nG50.1", 2, TransformOrder),
        ("G68 R30.\nG51 P2.", 2, TransformOrder),
        ("G68 R30.\nG50", 2, TransformOrder),
        // Arcs under unequal factors of their plane (no manual defines them).
        ("G51 I.5 J2.\nG2 X1 I.5 F1", 2, TransformArcScaled),
        // Words: R45000 is 45000 deg in the default setup; a factor is P or I/J/K.
        ("G68 R45000", 1, TransformValue),
        ("G68 X0 Y0", 1, TransformValue),
        ("G68 X0 Y0 Z1 R30.", 1, TransformValue),
        ("G51 P1. I2.", 1, TransformValue),
        ("G51 X0", 1, TransformValue),
        ("G51 P0", 1, TransformValue),
        ("G51 I.5 J-1.", 1, TransformValue),
        ("G51.1", 1, TransformValue),
        ("G69 X0", 1, UnusedWord),
        // G16: a radius in G91 would move the polar origin (Fanuc); only G17.
        ("G16\nG91 G1 X10 Y5 F1", 2, NotSupported),
        ("G18 G16 G1 X1 F1", 1, NotSupported),
        // A canned cycle drilling along a mirrored axis.
        ("G51.1 Z0\nG81 X1 Y1 Z-1 R1 F1", 2, NotSupported),
        // Not while cutter compensation is on.
        ("G41.1 D2 G1 X10 F1\nG68 R30.", 2, CompForbidden),
    ];
    for &(program, line, code) in cases {
        let e = first_error(program);
        assert_eq!((e.line, e.code), (line, code), "{program}");
    }
}

#[test]
fn a_failing_block_leaves_the_transforms_as_they_were() {
    // The second G68 fails (nested) and leaves no trace: the first (90 deg) still turns X10
    // into Y10, and the failing block's X5 did not move the program point.
    let mut it = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(b"G68 R90.\nG0 X5 G68 R10.\nG1 X10 F100\nG91 Y1\n");
    let mut got = Vec::new();
    while let Some(r) = it.next(&mut src) {
        match r {
            Ok(c) => {
                if let Action::Feed { to, .. } = c.action {
                    got.push((c.line, [to[0], to[1], to[2]]));
                }
            }
            Err(e) => assert_eq!((e.line, e.code), (2, ErrorCode::AxisWordsConflict)),
        }
    }
    assert_eq!(got, vec![(3, [0, 10 * MM, 0]), (4, [-MM, 10 * MM, 0])]);
}

#[test]
fn program_end_cancels_every_transform() {
    let (out, it) = run("G51.1 X0\nG51 P2.\nG68 R30.\nG16\nM30\n");
    assert!(out.iter().all(|r| r.is_ok()));
    assert!(!it.state().xf.active() && !it.state().xf.polar);
}

#[test]
fn one_mirrored_axis_swaps_g41_and_g42() {
    // Mirrored about X0 the path runs toward -X; G41 (left of the program's +X path, +Y) acts
    // as G42 on the mirrored path, which is +Y again: the mirror image of the compensated path.
    let m = moves("G0 X0 Y-5\nG51.1 X0\nG41.1 D2 G1 X10 Y0 F100\nX20\nG40 X30 Y-5\n");
    let at_x20 = m.iter().find(|(line, _)| *line == 4).unwrap().1;
    assert_eq!(at_x20, [-20 * MM, MM, 0]);
}

#[test]
fn offsets_and_tool_length_apply_after_the_transform() {
    // G54 X100, G43.1 Z5: the rotated point is offset, the offset is not rotated.
    let m = moves("G10 L2 P1 X100\nG43.1 Z5\nG68 X0 Y0 R90.\nG1 X10 Y0 Z0 F100\n");
    assert_eq!(m, vec![(4, [100 * MM, 10 * MM, 5 * MM])]);
}

#[test]
fn after_g53_the_program_point_is_where_the_tool_is() {
    // Under G68 R90. the tool goes to machine 0,0 by G53; the next increment starts from the
    // program point of 0,0 (the inverse transform), X10 -> 0,10.
    let m = moves("G68 X0 Y0 R90.\nG1 X10 F100\nG53 G0 X0 Y0\nG91 G1 X10\n");
    assert_eq!(
        m,
        vec![(2, [0, 10 * MM, 0]), (3, [0, 0, 0]), (4, [0, 10 * MM, 0])]
    );
}

#[test]
fn g18_rotation_turns_z_toward_x() {
    // Positive about +Y (as G3 in G18): X10 Z0 -> X0 Z-10.
    let m = moves("G18 G68 X0 Z0 R90.\nG1 X10 Z0 F100\n");
    assert_eq!(m, vec![(2, [0, 0, -10 * MM])]);
}

#[test]
fn a_g69_with_a_plane_change_in_one_block_is_allowed() {
    let m = moves("G68 R30.\nG69 G18\nG1 X1 F1\n");
    assert_eq!(m, vec![(3, [MM, 0, 0])]);
}

#[test]
fn scaled_arc_keeps_its_direction_and_doubles_its_radius() {
    let (out, _) = run("G51 X0 Y0 P2.\nG2 X10 Y0 R5 F100\n");
    match out[0].as_ref().unwrap().action {
        Action::Arc {
            to, center, dir, ..
        } => {
            assert_eq!((to[0], center[0], dir), (20 * MM, 10 * MM, ArcDir::Cw));
        }
        ref a => panic!("{a:?}"),
    }
}

// --- The Fanuc cycles (docs/gcode-transforms.md "Fanuc cycles") ---

fn actions(program: &str, cfg: &InterpConfig) -> Vec<Result<Action, ErrorCode>> {
    let mut it = Interpreter::new(cfg);
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(r) = it.next(&mut src) {
        let stop = r.is_err();
        out.push(r.map(|c| c.action).map_err(|e| e.code));
        if stop {
            break;
        }
    }
    out
}

#[test]
fn g74_taps_left_handed_and_reverses_at_the_bottom() {
    use gantry_machine::canon::Spindle;
    let got = actions(
        "G0 X0 Y0 Z10\nM4 S500\nG98 G74 X10 Y5 Z-8 R2 P0.5 F500\n",
        &InterpConfig::default(),
    );
    let spindle = |state, rpm| Ok(Action::Spindle { state, rpm });
    let to = |x: i64, y: i64, z: i64| [x * MM, y * MM, z * MM, 0, 0, 0];
    assert_eq!(
        got,
        vec![
            Ok(Action::Rapid { to: to(0, 0, 10) }),
            spindle(Spindle::Ccw, 500),
            Ok(Action::Rapid { to: to(10, 5, 10) }),
            Ok(Action::Rapid { to: to(10, 5, 2) }),
            Ok(Action::Feed {
                to: to(10, 5, -8),
                feed: 500 * MM
            }),
            spindle(Spindle::Off, 0),
            spindle(Spindle::Cw, 500),
            Ok(Action::Dwell { micros: 500_000 }),
            Ok(Action::Feed {
                to: to(10, 5, 10),
                feed: 500 * MM
            }),
            spindle(Spindle::Off, 0),
            spindle(Spindle::Ccw, 500),
        ]
    );
}

#[test]
fn the_board_refuses_the_cycles_it_cannot_run_safely() {
    use ErrorCode::*;
    for (program, code) in [
        // G74 needs the spindle turning counter-clockwise (M4).
        ("M3 S500\nG74 X1 Z-1 R1 F10", CycleSpindleState),
        // No oriented spindle stop, no spindle synchronisation.
        ("M3 S500\nG76 X1 Z-1 R1 Q.1 F10", CycleNotSupported),
        ("M3 S500\nG84.2 X1 Z-1 R1 F10", CycleNotSupported),
        ("M4 S500\nG84.3 X1 Z-1 R1 F10", CycleNotSupported),
    ] {
        let e = first_error(program);
        assert_eq!((e.line, e.code), (2, code), "{program}");
    }
}

#[test]
fn m19_is_an_output_the_setup_maps() {
    // Without a mapping M19 is unknown (nothing orients the spindle); with `user_mcodes = [19]`
    // and its `[[mcode]]` list it is a user M code like any other.
    assert_eq!(first_error("M5\nM19").code, ErrorCode::UnknownMCode);
    let mut cfg = InterpConfig::default();
    assert!(cfg.add_user_m_code(19));
    let got = actions("M5\nM19\n", &cfg);
    assert!(got
        .iter()
        .any(|a| matches!(a, Ok(Action::UserMCode { code: 19, .. }))));
}

#[test]
fn a_tool_number_must_be_in_the_setups_tool_table() {
    // LinuxCNC: `T212` with no such tool is an error when the setup has a tool table.
    let mut cfg = InterpConfig::default();
    assert!(cfg.set_tool(1, 0) && cfg.set_tool(7, 5 * MM));
    let got = actions("T7 M6\nT0\nT212 M6\n", &cfg);
    assert_eq!(got.last(), Some(&Err(ErrorCode::ToolNotInTable)));
    assert!(got[..got.len() - 1].iter().all(|a| a.is_ok()));
    // A tool G10 L1 adds is in the table from then on; without a table any T is accepted.
    assert!(actions("G10 L1 P212 Z1\nT212 M6\n", &cfg)
        .iter()
        .all(|a| a.is_ok()));
    assert!(actions("T212 M6\n", &InterpConfig::default())
        .iter()
        .all(|a| a.is_ok()));
}
