//! Cutter radius compensation (machine/src/gcode/comp.rs): exact compensated paths, the moves
//! held back until the next one, and LinuxCNC's errors. The same programs' rs274 output is
//! compared by tests/tests/golden_rs274.rs (tests/golden/rs274/114-130).

use gantry_machine::canon::{Action, ArcDir, Canon};
use gantry_machine::gcode::{ErrorCode, GcodeError, InterpConfig, Interpreter, MemorySource};

const MM: i64 = 1_000_000;

/// The setup with T5 of 5.08 mm diameter (radius 2.54 mm).
fn config() -> InterpConfig {
    let mut cfg = InterpConfig::default();
    assert!(cfg.set_tool(5, 0));
    cfg.tools
        .iter_mut()
        .find(|t| t.number == 5)
        .unwrap()
        .diameter = 5_080_000;
    cfg
}

fn run(program: &str) -> Vec<Result<Canon, GcodeError>> {
    let mut it = Interpreter::new(&config());
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(x) = it.next(&mut src) {
        out.push(x);
        assert!(out.len() < 10_000, "runaway");
    }
    out
}

/// Moves as (kind, line, x, y, z); arcs also give their centre through `arcs`.
fn moves(program: &str) -> Vec<(char, u32, [i64; 3])> {
    run(program)
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("unexpected error {e:?}")))
        .filter_map(|c| match c.action {
            Action::Rapid { to } => Some(('r', c.line, [to[0], to[1], to[2]])),
            Action::Feed { to, .. } => Some(('f', c.line, [to[0], to[1], to[2]])),
            Action::Arc { to, dir, .. } => Some((
                if dir == ArcDir::Cw { 'w' } else { 'c' },
                c.line,
                [to[0], to[1], to[2]],
            )),
            _ => None,
        })
        .collect()
}

fn first_error(program: &str) -> (ErrorCode, u32) {
    run(program)
        .into_iter()
        .find_map(|r| r.err())
        .map(|e| (e.code, e.line))
        .unwrap_or_else(|| panic!("no error in\n{program}"))
}

const R: i64 = 2_540_000;

#[test]
fn right_of_a_clockwise_square_runs_inside_with_an_arc_round_the_entry_corner() {
    // tests/golden/rs274/114: rs274 gives the same points (to its 4 decimals).
    let m = moves(
        "G21 G90 G17\nG0 X-10 Y-10\nF300\nG42 D5 G1 X0 Y0\nY40\nX40\nY0\nX0\nG40 G1 X-10 Y-10\nM2\n",
    );
    let e = 1_796_051; // 2.54 / sqrt(2): square to the 45° entry move, right of it
    assert_eq!(m[1], ('f', 4, [e, -e, 0]));
    // The entry corner is convex: an arc about the programmed corner, then up the inside.
    assert_eq!(m[2], ('c', 5, [R, 0, 0]));
    assert_eq!(m[3], ('f', 5, [R, 40 * MM - R, 0]));
    assert_eq!(m[4], ('f', 6, [40 * MM - R, 40 * MM - R, 0]));
    assert_eq!(m[5], ('f', 7, [40 * MM - R, R, 0]));
    // G40 releases the last move as aimed: beside X0 Y0; the exit goes straight on.
    assert_eq!(m[6], ('f', 8, [0, R, 0]));
    assert_eq!(m[7], ('f', 9, [-10 * MM, -10 * MM, 0]));
    assert_eq!(m.len(), 8);
}

#[test]
fn inside_square_trims_its_concave_corners() {
    // tests/golden/rs274/115.
    let m = moves(
        "G21 G90 G17\nG0 X20 Y20\nF300\nG41 D5 G1 X20 Y0\nX40\nY40\nX0\nY0\nX20\nG40 X20 Y20\nM2\n",
    );
    // The entry move ends beside (20, 0), trimmed back to the offset of the bottom side.
    assert_eq!(m[1], ('f', 4, [20 * MM + R, R, 0]));
    assert_eq!(m[2], ('f', 5, [40 * MM - R, R, 0]));
    assert_eq!(m[3], ('f', 6, [40 * MM - R, 40 * MM - R, 0]));
    assert_eq!(m[4], ('f', 7, [R, 40 * MM - R, 0]));
    assert_eq!(m[5], ('f', 8, [R, R, 0]));
    assert_eq!(m[6], ('f', 9, [20 * MM, R, 0]));
    assert_eq!(m[7], ('f', 10, [20 * MM, 20 * MM, 0]));
    assert_eq!(m.len(), 8);
}

#[test]
fn a_compensated_move_waits_for_the_next_one() {
    let mut it = Interpreter::new(&config());
    let mut src = MemorySource::new(b"G0 X-10 Y0\nG41 D5 G1 X0 Y0 F100\nX10\n");
    let first = it.next(&mut src).unwrap().unwrap();
    assert!(matches!(first.action, Action::Rapid { .. }));
    // The entry move comes out only once X10 (line 3) decided its corner.
    let entry = it.next(&mut src).unwrap().unwrap();
    assert_eq!(entry.line, 2);
    assert!(matches!(entry.action, Action::Feed { to, .. } if to[0] == 0 && to[1] == R));
    // The end of the program releases the last move as aimed.
    let last = it.next(&mut src).unwrap().unwrap();
    assert!(matches!(last.action, Action::Feed { to, .. } if to[0] == 10 * MM && to[1] == R));
    assert!(it.next(&mut src).is_none());
}

#[test]
fn zero_diameter_compensation_leaves_the_path_alone() {
    let m = moves("G0 X-10 Y0\nG41 G1 X0 Y0 F100\nG3 X10 Y0 R5\nG40 G0 X20\nM2\n");
    assert_eq!(m[1], ('f', 2, [0, 0, 0]));
    assert_eq!(m[2], ('c', 3, [10 * MM, 0, 0]));
}

#[test]
fn errors_as_linuxcnc() {
    let head = "G21 G90 G17\nG0 X0 Y0\n";
    for (body, code, line) in [
        ("G41 D5 G1 X2 Y0 F100\n", ErrorCode::CompEntryTooShort, 3),
        (
            "G41 D5 G1 X10 Y0 F100\nG3 X12 Y2 I0 J2\n",
            ErrorCode::CompArcTooSmall,
            4,
        ),
        (
            "G41 D5 G1 X10 Y0 F100\nX20\nY1\nX0\n",
            ErrorCode::CompGouge,
            6,
        ),
        ("G41 D5 G1 X10 Y0 F100\nG18 X20\n", ErrorCode::CompPlane, 4),
        (
            "G41 D5 G1 X10 Y0 F100\nG42 D5 X20\n",
            ErrorCode::CompAlreadyOn,
            4,
        ),
        (
            "G41 D5 G1 X10 Y0 F100\nX20\nG40 G2 X30 Y0 R5\n",
            ErrorCode::CompArcAfterExit,
            5,
        ),
        (
            // T5: a tool of this table (T1 would be E502 first, as in LinuxCNC).
            "G41 D5 G1 X10 Y0 F100\nX20\nT5 M6\n",
            ErrorCode::CompForbidden,
            5,
        ),
        (
            "G41 D5 G1 X10 Y0 F100\nG92 X0\n",
            ErrorCode::CompForbidden,
            4,
        ),
        (
            "G41 D5 G1 X10 Y0 F100\nG38.2 Z-10\n",
            ErrorCode::CompForbidden,
            4,
        ),
        (
            "G41 D5 G1 X10 Y0 F100\nG81 X10 Y10 Z-1 R1\n",
            ErrorCode::CompForbidden,
            4,
        ),
        ("G19\nG41 D5\n", ErrorCode::CompPlane, 4),
        ("G41.1 G1 X10 Y0 F100\n", ErrorCode::CompDiameterMissing, 3),
        (
            "G41 D5 G2 X10 Y0 R5 F100\n",
            ErrorCode::CutterCompNotSupported,
            3,
        ),
        ("G41 D7 G1 X10 F100\n", ErrorCode::ToolNotInTable, 3),
    ] {
        assert_eq!(
            first_error(&format!("{head}{body}")),
            (code, line),
            "{body}"
        );
    }
}

#[test]
fn the_cross_target_vector_program_runs_without_errors() {
    // The program of the "gcode/cutter-comp" vector (machine/src/vectors/gcode.rs).
    let program = "G21 G90 G17\nG0 X10 Y-10\nG41.1 D5.08 G1 X10 Y0 F200\nX50\n\
G3 X50 Y30 R15\nG1 X35\nG2 X25 Y30 R5\nG1 X10\nG3 X10 Y0 R15\nG1 Z-1\nG40 G1 X10 Y-10\n\
G42.1 D3 X0 Y0\nY40\nX40\nY0\nX0\nG40 X-10 Y-10\nG18\nG42.1 D4 G1 X10 Z0\nZ-10\n\
G2 X15 Z-15 I5 K0\nG1 X20 Z-20\nG40 G0 X30\nG17 G0 X38.1 Y0\nG91 G81 R1 Z-3 ^60 L6\nG90 G80 G0 @10 ^45\nM2\n";
    let m = moves(program);
    // The line-arc corner of the slot's bay (rs274: X37.0993 Y27.46, tests/golden/rs274/132).
    assert!(m.contains(&('f', 6, [37_099_296, 27_460_000, 0])), "{m:?}");
    // The bolt circle: six holes 60° apart on a 38.1 mm radius, the last back at X38.1 Y0.
    let holes: Vec<_> = m.iter().filter(|mv| mv.1 == 25 && mv.0 == 'f').collect();
    assert_eq!(holes.len(), 6);
    assert_eq!(holes[0].2[..2], [19_050_000, 32_995_568]);
    assert_eq!(holes[5].2[..2], [38_100_000, 0]);
    // @10 ^45.
    assert_eq!(m.last().unwrap().2[..2], [7_071_068, 7_071_068]);
}
