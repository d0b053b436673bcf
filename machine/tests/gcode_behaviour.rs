//! Interpreter behaviour with exact nanometre expectations (the Hurco ISNC manual's §14 programs included).
#![allow(clippy::field_reassign_with_default, clippy::type_complexity)]

use gantry_machine::canon::{Action, ArcDir, Canon, PathMode, Plane, Spindle, StopKind};
use gantry_machine::gcode::{
    DwellUnits, ErrorCode, GcodeError, InterpConfig, Interpreter, MemorySource, MotionMode,
};

const MM: i64 = 1_000_000;

fn run_with(program: &str, cfg: &InterpConfig) -> Vec<Result<Canon, GcodeError>> {
    let mut it = Interpreter::new(cfg);
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(x) = it.next(&mut src) {
        out.push(x);
        assert!(out.len() < 100_000, "runaway");
    }
    out
}

fn run(program: &str) -> Vec<Result<Canon, GcodeError>> {
    run_with(program, &InterpConfig::default())
}

/// Actions of a program that must not fail.
fn ok(program: &str) -> Vec<Canon> {
    run(program)
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("unexpected error {e:?} in\n{program}")))
        .collect()
}

fn moves(actions: &[Canon]) -> Vec<(char, [i64; 3])> {
    actions
        .iter()
        .filter_map(|c| match c.action {
            Action::Rapid { to } => Some(('r', [to[0], to[1], to[2]])),
            Action::Feed { to, .. } => Some(('f', [to[0], to[1], to[2]])),
            Action::Arc { to, .. } => Some(('a', [to[0], to[1], to[2]])),
            _ => None,
        })
        .collect()
}

fn first_error(program: &str) -> GcodeError {
    run(program)
        .into_iter()
        .find_map(|r| r.err())
        .unwrap_or_else(|| panic!("no error in\n{program}"))
}

fn p3(x: f64, y: f64, z: f64) -> [i64; 3] {
    // test helper only: exact for the decimal literals used below
    [
        (x * 1e6).round() as i64,
        (y * 1e6).round() as i64,
        (z * 1e6).round() as i64,
    ]
}

fn r(x: f64, y: f64, z: f64) -> (char, [i64; 3]) {
    ('r', p3(x, y, z))
}
fn f(x: f64, y: f64, z: f64) -> (char, [i64; 3]) {
    ('f', p3(x, y, z))
}

fn arcs(actions: &[Canon]) -> Vec<([i64; 3], [i64; 3], Plane, ArcDir, u32)> {
    actions
        .iter()
        .filter_map(|c| match c.action {
            Action::Arc {
                to,
                center,
                plane,
                dir,
                turns,
                ..
            } => Some(([to[0], to[1], to[2]], center, plane, dir, turns)),
            _ => None,
        })
        .collect()
}

#[test]
fn basic_moves_and_line_numbers() {
    let a = ok("G21 G90 G17\nG0 X10 Y5\nG1 Z-1 F100\nG2 X20 Y5 I5 J0\nM30\n");
    assert_eq!(a.len(), 4);
    assert_eq!(
        a[1],
        Canon {
            line: 3,
            action: Action::Feed {
                to: [10 * MM, 5 * MM, -MM, 0, 0, 0],
                feed: 100 * MM
            }
        }
    );
    assert_eq!(
        arcs(&a),
        vec![(
            [20 * MM, 5 * MM, -MM],
            [15 * MM, 5 * MM, -MM],
            Plane::XY,
            ArcDir::Cw,
            1
        )]
    );
    assert_eq!(a[3].action, Action::Stop(StopKind::EndRewind));
    assert_eq!(a[3].line, 5);
}

#[test]
fn lexical_forms() {
    let a = ok("g01 x1. y.5 z-.25 f+3\nG0X0010Y-0.5\n");
    assert_eq!(moves(&a), vec![f(1.0, 0.5, -0.25), r(10.0, -0.5, -0.25)]);
    // spaces inside numbers, as RS274NGC
    assert_eq!(moves(&ok("G0 X 1 2 . 5")), vec![r(12.5, 0.0, 0.0)]);
}

#[test]
fn seed_14_1_g18_and_g19_arc_direction() {
    let a = ok("G18\nG0 X10 Y0 Z0\nG2 X0 Z10 I-10 K0 F100\n");
    let (to, center, plane, dir, turns) = arcs(&a)[0];
    assert_eq!(
        (to, center, plane, dir, turns),
        ([0, 0, 10 * MM], [0, 0, 0], Plane::ZX, ArcDir::Cw, 1)
    );
    // G2 in ZX (first axis Z, second X) from (z0,x10) to (z10,x0): a 90 degree sweep.
    let sweep =
        gantry_machine::gcode::geometry::sweep((0, 10 * MM), (10 * MM, 0), (0, 0), false, 1);
    let quarter = gantry_machine::gcode::geometry::PI as i128 / 2;
    assert!((sweep - quarter).abs() < 1000, "{sweep} vs {quarter}");
    let a = ok("G19\nG0 Y10 Z0\nG3 Y0 Z10 J-10 K0 F100\n");
    let (to, center, plane, dir, _) = arcs(&a)[0];
    assert_eq!(
        (to, center, plane, dir),
        ([0, 0, 10 * MM], [0, 0, 0], Plane::YZ, ArcDir::Ccw)
    );
    let sweep = gantry_machine::gcode::geometry::sweep((10 * MM, 0), (0, 10 * MM), (0, 0), true, 1);
    assert!((sweep - quarter).abs() < 1000);
}

#[test]
fn seed_14_2_incremental_centres_not_modal() {
    let a = ok("G0 X10 Y0\nG3 X0 Y10 I-10 J0 F100\nX-10 Y0 I0 J-10\nX0 Y-10 I10\n");
    let c: Vec<_> = arcs(&a).iter().map(|x| (x.0, x.1)).collect();
    assert_eq!(
        c,
        vec![
            ([0, 10 * MM, 0], [0, 0, 0]),
            ([-10 * MM, 0, 0], [0, 0, 0]),
            ([0, -10 * MM, 0], [0, 0, 0]),
        ]
    );
    // Treating I/J as absolute (G90.1) gives a radius mismatch error, not a strange arc.
    let e = first_error("G0 X10 Y0\nG90.1 G3 X0 Y10 I-10 J0 F100\n");
    assert_eq!((e.code, e.line), (ErrorCode::ArcRadiusMismatch, 2));
}

#[test]
fn seed_14_3_signed_r_and_r_too_small() {
    let a = ok("G0 X0 Y0\nG2 X10 Y0 R10 F100\nG0 X0 Y0\nG2 X10 Y0 R-10\nG0 X0 Y0\nG2 X10 Y0 R5\n");
    let c: Vec<_> = arcs(&a).iter().map(|x| x.1).collect();
    assert_eq!(
        c,
        vec![
            [5 * MM, -8_660_254, 0],
            [5 * MM, 8_660_254, 0],
            [5 * MM, 0, 0]
        ]
    );
    let e = first_error("G0 X0 Y0\nG2 X10 Y0 R4 F100\n");
    assert_eq!(
        (e.code, e.line, e.columns),
        (ErrorCode::ArcRadiusTooSmall, 2, Some((10, 12)))
    );
    let e = first_error("G0 X0 Y0\nG2 X10 Y0 R10 F100\nG1 X20\nG2 X30 Y0\n");
    assert_eq!((e.code, e.line), (ErrorCode::ArcCenterMissing, 4));
}

#[test]
fn seed_14_4_canned_cycle_r_plane_in_g91_with_repeats() {
    let a = ok("G0 X0 Y0 Z10\nG91 G99 G81 X10 Z-5 R-8 K3 F100\nG80 G90\n");
    assert_eq!(
        moves(&a),
        vec![
            r(0.0, 0.0, 10.0),
            r(10.0, 0.0, 10.0),
            r(10.0, 0.0, 2.0),
            f(10.0, 0.0, -3.0),
            r(10.0, 0.0, 2.0),
            r(20.0, 0.0, 2.0),
            f(20.0, 0.0, -3.0),
            r(20.0, 0.0, 2.0),
            r(30.0, 0.0, 2.0),
            f(30.0, 0.0, -3.0),
            r(30.0, 0.0, 2.0),
        ]
    );
    // G98: every retract and XY move at the initial level Z10; L works like K.
    let a = ok("G0 X0 Y0 Z10\nG91 G98 G81 X10 Z-5 R-8 L3 F100\n");
    assert_eq!(
        moves(&a)[1..],
        [
            r(10.0, 0.0, 10.0),
            r(10.0, 0.0, 2.0),
            f(10.0, 0.0, -3.0),
            r(10.0, 0.0, 10.0),
            r(20.0, 0.0, 10.0),
            r(20.0, 0.0, 2.0),
            f(20.0, 0.0, -3.0),
            r(20.0, 0.0, 10.0),
            r(30.0, 0.0, 10.0),
            r(30.0, 0.0, 2.0),
            f(30.0, 0.0, -3.0),
            r(30.0, 0.0, 10.0),
        ]
    );
    // K0 stores the cycle without drilling; the next block drills with the stored data.
    let a = ok("G0 X0 Y0 Z10\nG81 X5 Z-1 R1 K0 F100\nX6\n");
    assert_eq!(
        moves(&a)[1..],
        [
            r(6.0, 0.0, 10.0),
            r(6.0, 0.0, 1.0),
            f(6.0, 0.0, -1.0),
            r(6.0, 0.0, 10.0)
        ]
    );
}

#[test]
fn seed_14_5_modal_state_after_m30() {
    let mut cfg = InterpConfig::default();
    cfg.set_tool(1, 50 * MM);
    let program_a = "G91 G18\nG43 H1\nG17 G81 X1 Y1 R1 Z-1 F100\nM3 S1000 M8\nG92 X0\nM30\n";
    let mut it = Interpreter::new(&cfg);
    let mut src = MemorySource::new(program_a.as_bytes());
    while let Some(x) = it.next(&mut src) {
        x.unwrap();
    }
    let s = *it.state();
    assert_eq!(s.spindle, Spindle::Off);
    assert!(!s.mist && !s.flood);
    assert!(s.absolute);
    assert_eq!(s.plane, Plane::XY);
    assert_eq!(s.motion, MotionMode::Rapid);
    assert_eq!(s.work_system, 0);
    assert_eq!(s.g92, [0; 6], "G92 offsets are cleared by M30");
    assert_eq!(s.tool_offset[2], 50 * MM, "tool length offset survives M30");
    assert!(!s.inch, "units survive M30");
    it.rewind();
    let mut src = MemorySource::new(b"X5 Y5\n");
    let c = it.next(&mut src).unwrap().unwrap();
    let before = s.position;
    assert_eq!(
        c.action,
        Action::Rapid {
            to: [5 * MM, 5 * MM, before[2], 0, 0, 0]
        }
    );
    assert!(it.next(&mut src).is_none());
}

#[test]
fn seed_14_6_cycle_cancelled_by_group_1() {
    let a = ok("G0 Z10\nG81 X1 Y1 Z-2 R1 F100\nX2\nG0 X3 Y3\nX4\nG1 X6 Z-1\n");
    assert_eq!(
        moves(&a),
        vec![
            r(0.0, 0.0, 10.0),
            r(1.0, 1.0, 10.0),
            r(1.0, 1.0, 1.0),
            f(1.0, 1.0, -2.0),
            r(1.0, 1.0, 10.0),
            r(2.0, 1.0, 10.0),
            r(2.0, 1.0, 1.0),
            f(2.0, 1.0, -2.0),
            r(2.0, 1.0, 10.0),
            r(3.0, 3.0, 10.0),
            r(4.0, 3.0, 10.0),
            f(6.0, 3.0, -1.0),
        ]
    );
    let e = first_error("G0 Z10\nG81 X1 Y1 Z-2 R1 F100\nG0 X3\nG81 X7 Y1 Z-2 F100\n");
    assert_eq!((e.code, e.line), (ErrorCode::CycleRMissing, 4));
    // Project policy: a cycle and a group-1 code in one block is a modal-group conflict.
    let e = first_error("G0 G81 X8 Z-2 R1 F100\n");
    assert_eq!(e.code, ErrorCode::ModalGroupConflict);
}

#[test]
fn seed_14_7_g83_peck_arithmetic() {
    let mut cfg = InterpConfig::default();
    cfg.peck_clearance = MM / 2;
    let a: Vec<Canon> = run_with("G0 X0 Y0 Z5\nG98 G83 Z-10 R1 Q4 F100\n", &cfg)
        .into_iter()
        .map(Result::unwrap)
        .collect();
    let z: Vec<(char, i64)> = moves(&a)[1..].iter().map(|m| (m.0, m.1[2])).collect();
    assert_eq!(
        z,
        vec![
            ('r', 5 * MM),
            ('r', MM),
            ('f', -3 * MM),
            ('r', MM),
            ('r', -2_500_000),
            ('f', -7 * MM),
            ('r', MM),
            ('r', -6_500_000),
            ('f', -10 * MM),
            ('r', 5 * MM),
        ]
    );
    let e = first_error("G0 X0 Y0 Z5\nG83 Z-10 R1 Q4 F100\nG80\nG83 Z-10 R1 F100\n");
    assert_eq!((e.code, e.line), (ErrorCode::CycleQInvalid, 4));
}

#[test]
fn default_peck_clearance_is_0_254_mm_and_g73_backs_off() {
    let a = ok("G0 Z5\nG73 Z-3 R1 Q2 F100\n");
    let z: Vec<(char, i64)> = moves(&a)[1..].iter().map(|m| (m.0, m.1[2])).collect();
    assert_eq!(
        z,
        vec![
            ('r', 5 * MM),
            ('r', MM),
            ('f', -MM),
            ('r', -MM + 254_000),
            ('f', -3 * MM),
            ('r', 5 * MM),
        ]
    );
}

#[test]
fn seed_14_8_dwell_and_decimal_point_rules() {
    let dwell = |a: &[Canon]| -> Vec<u64> {
        a.iter()
            .filter_map(|c| match c.action {
                Action::Dwell { micros } => Some(micros),
                _ => None,
            })
            .collect()
    };
    let mut cfg = InterpConfig::default();
    cfg.dwell_units = DwellUnits::FanucIntegerMillis;
    let a: Vec<Canon> = run_with("G4 P500\nG4 P0.5\nG4 X1.5\n", &cfg)
        .into_iter()
        .map(Result::unwrap)
        .collect();
    assert_eq!(dwell(&a), vec![500_000, 500_000, 1_500_000]);
    assert!(moves(&a).is_empty(), "G4 X is a dwell, not a move");
    // LinuxCNC default: P is seconds.
    assert_eq!(dwell(&ok("G4 P2\nG4 P0.25\n")), vec![2_000_000, 250_000]);
    // X1 means 1 mm; F100 and F100. are equal.
    let a = ok("G1 X1 F100\nG1 X2 F100.\n");
    assert_eq!(moves(&a), vec![f(1.0, 0.0, 0.0), f(2.0, 0.0, 0.0)]);
    let feeds: Vec<i64> = a
        .iter()
        .filter_map(|c| match c.action {
            Action::Feed { feed, .. } => Some(feed),
            _ => None,
        })
        .collect();
    assert_eq!(feeds, vec![100 * MM, 100 * MM]);
    assert_eq!(first_error("G4\n").code, ErrorCode::DwellTimeMissing);
}

#[test]
fn seed_14_9_block_delete_comments_framing() {
    let program =
        "%\nO1234 (MAIN)\n/G0 X100\nG0 X1 (G1 X99 Y99 M30)\nN10 G0 X2\nN10 G0 X3\nM30\n%\nE\n";
    let mut cfg = InterpConfig::default();
    cfg.block_delete = true;
    let a: Vec<Canon> = run_with(program, &cfg)
        .into_iter()
        .map(Result::unwrap)
        .collect();
    assert_eq!(
        moves(&a),
        vec![r(1.0, 0.0, 0.0), r(2.0, 0.0, 0.0), r(3.0, 0.0, 0.0)]
    );
    assert_eq!(a.last().unwrap().action, Action::Stop(StopKind::EndRewind));
    let a = ok(program);
    assert_eq!(moves(&a)[0], r(100.0, 0.0, 0.0));
    assert_eq!(first_error("N5 N6 G0 X1\n").code, ErrorCode::RepeatedWord);
    let e = first_error("G0 X1 X2\n");
    assert_eq!((e.code, e.columns), (ErrorCode::RepeatedWord, Some((6, 8))));
    // The switch can be changed at run time.
    let mut it = Interpreter::new(&InterpConfig::default());
    it.set_block_delete(true);
    let mut src = MemorySource::new(b"/G0 X5\nG0 X6\n");
    assert_eq!(
        it.next(&mut src).unwrap().unwrap().action,
        Action::Rapid {
            to: [6 * MM, 0, 0, 0, 0, 0]
        }
    );
}

#[test]
fn seed_14_10_full_circle_helix() {
    let a = ok("G0 X10 Y0 Z0\nG3 X10 Y0 Z-5 I-10 J0 F600\nG2 I-10\n");
    let x = arcs(&a);
    assert_eq!(
        x[0],
        ([10 * MM, 0, -5 * MM], [0, 0, 0], Plane::XY, ArcDir::Ccw, 1)
    );
    // IJK with no end point is a full circle (LinuxCNC); its centre's Z is the start Z.
    assert_eq!(
        x[1],
        (
            [10 * MM, 0, -5 * MM],
            [0, 0, -5 * MM],
            Plane::XY,
            ArcDir::Cw,
            1
        )
    );
    // P gives more turns.
    let a = ok("G0 X10\nG3 X10 Y0 Z-10 I-10 P3 F600\n");
    assert_eq!(arcs(&a)[0].4, 3);
}

#[test]
fn seed_14_11_g91_g28_idiom_and_g53() {
    let mut cfg = InterpConfig::default();
    cfg.work_offsets[0] = [100 * MM, 0, 0, 0, 0, 0];
    let a: Vec<Canon> = run_with(
        "G0 X5 Y5 Z2\nG91 G28 Z0\nG28 X0 Y0\nG90\nG53 G0 Z-10\nG0 X1\n",
        &cfg,
    )
    .into_iter()
    .map(Result::unwrap)
    .collect();
    assert_eq!(
        moves(&a),
        vec![
            r(105.0, 5.0, 2.0),
            r(105.0, 5.0, 2.0),
            r(105.0, 5.0, 0.0),
            r(105.0, 5.0, 0.0),
            r(0.0, 0.0, 0.0),
            r(0.0, 0.0, -10.0),
            r(101.0, 0.0, -10.0),
        ]
    );
    let e = first_error("G91 G53 G0 X1\n");
    assert_eq!(e.code, ErrorCode::G53Invalid);
}

#[test]
fn seed_14_12_g92_shifts_every_work_system() {
    let mut cfg = InterpConfig::default();
    cfg.work_offsets[0][0] = 100 * MM;
    cfg.work_offsets[1][0] = 200 * MM;
    // LinuxCNC: G52 sets the same offset G92 does (to the value given), so X0 is machine 205.
    let a: Vec<Canon> = run_with(
        "G54 G0 X10\nG92 X0\nG55 G0 X0\nG52 X5\nG0 X0\nG92.1\nG0 X0\n",
        &cfg,
    )
    .into_iter()
    .map(Result::unwrap)
    .collect();
    assert_eq!(
        moves(&a),
        vec![
            r(110.0, 0.0, 0.0),
            r(210.0, 0.0, 0.0),
            r(205.0, 0.0, 0.0),
            r(200.0, 0.0, 0.0)
        ]
    );
    assert_eq!(first_error("G52\n").code, ErrorCode::MissingAxisWords);
}

#[test]
fn feed_keeps_its_physical_value_across_units_and_g94_clears_it() {
    let feeds = |a: &[Canon]| -> Vec<i64> {
        a.iter()
            .filter_map(|c| match c.action {
                Action::Feed { feed, .. } => Some(feed),
                _ => None,
            })
            .collect()
    };
    assert_eq!(
        feeds(&ok("G21 G1 X1 F254\nG20\nG1 X1\nG21 G1 X2\n")),
        vec![254 * MM, 254 * MM, 254 * MM]
    );
    let e = first_error("G93 G1 X10 F2\nG94 G1 X20\n");
    assert_eq!((e.code, e.line), (ErrorCode::ZeroFeedRate, 2));
    // A redundant G94 keeps the feed (Fanuc; LinuxCNC would clear it).
    assert_eq!(
        feeds(&ok("G1 X1 F100\nG94 G1 X2\n")),
        vec![100 * MM, 100 * MM]
    );
}

#[test]
fn g10_l1_writes_the_tool_table() {
    let a = ok("G10 L1 P5 Z10 R2\nG43 H5\nG0 Z0\n");
    assert_eq!(moves(&a), vec![r(0.0, 0.0, 10.0)]);
    // The bad block leaves the table untouched.
    let out = run("G10 L1 P6 Z10 Q1\nG43 H6\n");
    assert_eq!(out[0].as_ref().unwrap_err().code, ErrorCode::UnusedWord);
    assert_eq!(out[1].as_ref().unwrap_err().code, ErrorCode::ToolNotInTable);
}

#[test]
fn seed_14_14_cutter_compensation_must_start_with_a_straight_move() {
    // Fanuc: compensation starts on a G0/G1 (LinuxCNC would also start on an arc).
    let e = first_error("G0 X0\nG41.1 D2 G2 X10 Y0 R5 F100\n");
    assert_eq!((e.code, e.line), (ErrorCode::CutterCompNotSupported, 2));
    assert!(run("G41.1 D2 G1 X10 F100\nG40 G0 X1\n")
        .iter()
        .all(|r| r.is_ok()));
}

#[test]
fn seed_14_15_subprogram_repeat_encoding() {
    let a = ok("M98 P30050\nM30\nO0050 G91 G0 X1 M99\n");
    assert_eq!(
        moves(&a),
        vec![r(1.0, 0.0, 0.0), r(2.0, 0.0, 0.0), r(3.0, 0.0, 0.0)]
    );
    let e = first_error("M98 P350\nM30\nO0050 G91 G0 X1 M99\n");
    assert_eq!(
        (e.code, e.columns),
        (ErrorCode::UnknownProgram, Some((4, 8)))
    );
    let a = ok("M98 P1\nM30\nO1\nG0 X7\nM99\n");
    assert_eq!(moves(&a), vec![r(7.0, 0.0, 0.0)]);
    let e = first_error("M98 P50\nM30\nO0050 G0 X1 M99\nO0050 G0 X2 M99\n");
    assert_eq!(e.code, ErrorCode::DuplicateProgram);
}

#[test]
fn subprograms_nest_eight_deep_with_l_repeats() {
    let mut p = String::from("G91\nM98 P1 L2\nM30\n");
    for i in 1..=8 {
        p.push_str(&format!("O{i}\nG0 X1\n"));
        if i < 8 {
            p.push_str(&format!("M98 P{}\n", i + 1));
        }
        p.push_str("M99\n");
    }
    let a = ok(&p);
    assert_eq!(moves(&a).len(), 16);
    assert_eq!(moves(&a).last().unwrap().1[0], 16 * MM);
    // 17 levels overflow the stack
    let mut p = String::from("M98 P1\nM30\n");
    for i in 1..=17 {
        p.push_str(&format!("O{i}\nM98 P{}\nM99\n", i + 1));
    }
    p.push_str("O18\nM99\n");
    assert_eq!(first_error(&p).code, ErrorCode::NestingTooDeep);
}

#[test]
fn m99_in_main_restarts_the_program() {
    let mut it = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(b"G91 G0 X1\nM99\n");
    let mut xs = Vec::new();
    for _ in 0..3 {
        if let Action::Rapid { to } = it.next(&mut src).unwrap().unwrap().action {
            xs.push(to[0]);
        }
    }
    assert_eq!(xs, vec![MM, 2 * MM, 3 * MM]);
    assert_eq!(it.restarts(), 2);
}

#[test]
fn end_of_file_inside_subprogram_is_an_error() {
    assert_eq!(
        first_error("M98 P5\nM30\nO5\nG0 X1\n").code,
        ErrorCode::SubprogramWithoutM99
    );
}

#[test]
fn inch_units_convert_exactly() {
    let a = ok("G20 G0 X1 Y-0.5\nG1 Z0.0001 F10\nG21 G0 X1\n");
    assert_eq!(
        moves(&a),
        vec![
            r(25.4, -12.7, 0.0),
            f(25.4, -12.7, 0.00254),
            r(1.0, -12.7, 0.00254)
        ]
    );
    let feed = a.iter().find_map(|c| match c.action {
        Action::Feed { feed, .. } => Some(feed),
        _ => None,
    });
    assert_eq!(feed, Some(254 * MM));
    // 100 000 incremental steps of 0.0001 in: exactly 10 in, no drift.
    let mut p = String::from("G20 G91\n");
    for _ in 0..1000 {
        p.push_str("G0 X0.01\n");
    }
    let a = ok(&p);
    assert_eq!(moves(&a).last().unwrap().1[0], 254 * MM);
}

#[test]
fn work_offsets_g10_and_p0() {
    let a = ok("G10 L2 P1 X10 Y20\nG0 X0 Y0\nG10 L2 P0 Z-5\nG0 Z0\nG10 L20 P2 X1\nG55 G0 X0\n");
    assert_eq!(
        moves(&a),
        vec![r(10.0, 20.0, 0.0), r(10.0, 20.0, -5.0), r(9.0, 20.0, -5.0)]
    );
    assert_eq!(first_error("G10 L3 P1 X1\n").code, ErrorCode::G10Invalid);
    assert_eq!(first_error("G10 L2 P12 X1\n").code, ErrorCode::G10Invalid);
    // G59.1..G59.3 exist
    let a = ok("G10 L2 P9 X3\nG59.3 G0 X0\n");
    assert_eq!(moves(&a), vec![r(3.0, 0.0, 0.0)]);
}

#[test]
fn g92_family() {
    let a = ok("G0 X10\nG92 X0\nG0 X5\nG92.2\nG0 X5\nG92.3\nG0 X0\n");
    assert_eq!(
        moves(&a),
        vec![
            r(10.0, 0.0, 0.0),
            r(15.0, 0.0, 0.0),
            r(5.0, 0.0, 0.0),
            r(10.0, 0.0, 0.0)
        ]
    );
    assert_eq!(first_error("G92\n").code, ErrorCode::MissingAxisWords);
}

#[test]
fn g28_g30_positions_and_set() {
    let mut cfg = InterpConfig::default();
    cfg.g30_position = [MM, 2 * MM, 3 * MM, 0, 0, 0];
    let a: Vec<Canon> = run_with("G0 X7 Y7 Z7\nG28.1\nG0 X0 Y0 Z0\nG28 X1\nG30\n", &cfg)
        .into_iter()
        .map(Result::unwrap)
        .collect();
    assert_eq!(
        moves(&a),
        vec![
            r(7.0, 7.0, 7.0),
            r(0.0, 0.0, 0.0),
            r(1.0, 0.0, 0.0),
            r(7.0, 0.0, 0.0),
            r(7.0, 0.0, 0.0),
            r(1.0, 2.0, 3.0),
        ]
    );
    assert_eq!(
        first_error("G28 G1 X0\n").code,
        ErrorCode::AxisWordsConflict
    );
}

#[test]
fn tool_length_offsets() {
    let mut cfg = InterpConfig::default();
    cfg.set_tool(3, 40 * MM);
    let a: Vec<Canon> = run_with(
        "T3 M6\nG43 H3\nG0 Z0\nG43\nG0 Z1\nG43.1 Z2\nG0 Z0\nG49\nG0 Z0\n",
        &cfg,
    )
    .into_iter()
    .map(Result::unwrap)
    .collect();
    assert_eq!(a[0].action, Action::ToolChange { tool: 3 });
    assert_eq!(
        moves(&a),
        vec![
            r(0.0, 0.0, 40.0),
            r(0.0, 0.0, 41.0),
            r(0.0, 0.0, 2.0),
            r(0.0, 0.0, 0.0)
        ]
    );
    let e = run_with("G43 H4\n", &cfg).remove(0).unwrap_err();
    assert_eq!(
        (e.code, e.columns),
        (ErrorCode::ToolNotInTable, Some((4, 6)))
    );
}

#[test]
fn spindle_coolant_tools_user_codes_and_stops() {
    let mut cfg = InterpConfig::default();
    cfg.add_user_m_code(100);
    cfg.optional_stop = true;
    let a: Vec<Canon> = run_with(
        "T2 M6 M3 S1200\nS800\nM4\nM7 M8\nM9\nM100\nM5\nM0\nM1\nG64 P0.01\nG61\nM2\nG0 X1\n",
        &cfg,
    )
    .into_iter()
    .map(Result::unwrap)
    .collect();
    let acts: Vec<Action> = a.iter().map(|c| c.action).collect();
    assert_eq!(
        acts,
        vec![
            Action::ToolChange { tool: 2 },
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 1200
            },
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 800
            },
            Action::Spindle {
                state: Spindle::Ccw,
                rpm: 800
            },
            Action::Coolant {
                mist: true,
                flood: true
            },
            Action::Coolant {
                mist: false,
                flood: false
            },
            Action::UserMCode {
                code: 100,
                at_rest: false
            },
            Action::Spindle {
                state: Spindle::Off,
                rpm: 800
            },
            Action::Stop(StopKind::Pause),
            Action::Stop(StopKind::OptionalPause),
            Action::PathMode(PathMode::Blend { tolerance: 10_000 }),
            Action::PathMode(PathMode::ExactStop),
            Action::Stop(StopKind::End),
        ]
    );
    // M1 with the switch off does nothing.
    assert!(ok("M1\n").is_empty());
}

#[test]
fn inverse_time_feed_becomes_a_per_move_feed() {
    let a = ok("G93 G1 X10 F2\nG1 X10 Y10 F0.5\nG94 G1 X0 F100\n");
    let feeds: Vec<i64> = a
        .iter()
        .filter_map(|c| match c.action {
            Action::Feed { feed, .. } => Some(feed),
            _ => None,
        })
        .collect();
    assert_eq!(feeds, vec![20 * MM, 5 * MM, 100 * MM]);
    assert_eq!(
        first_error("G93 G1 X10 F2\nG1 X20\n").code,
        ErrorCode::InverseTimeFeedMissing
    );
    // A quarter circle of radius 10 in 1/4 min: 15.708 mm long, 62.83 mm/min.
    let a = ok("G0 X10\nG93 G3 X0 Y10 I-10 F4\n");
    let feed = a.iter().find_map(|c| match c.action {
        Action::Arc { feed, .. } => Some(feed),
        _ => None,
    });
    let expect = 62_831_853;
    assert!((feed.unwrap() - expect).abs() < 10, "{feed:?}");
}

#[test]
fn rotary_only_feed_is_in_degrees() {
    let a = ok("G1 A90 F360\n");
    assert_eq!(
        a[0].action,
        Action::Feed {
            to: [0, 0, 0, 90 * MM, 0, 0],
            feed: 360 * MM
        }
    );
    let mut cfg = InterpConfig::default();
    cfg.axis_count = 3;
    let e = run_with("G0 A1\n", &cfg).remove(0).unwrap_err();
    assert_eq!(e.code, ErrorCode::AxisNotConfigured);
}

#[test]
fn other_cycles_follow_linuxcnc() {
    // G82: dwell at the bottom; G85 feeds out; G89 dwell then feed to clear; G86 stops the spindle.
    let a = ok("G0 Z5\nM3 S500\nG82 X1 Z-1 R1 P0.5 F60\nG85 X2 Z-1 R1\nG89 X3 Z-1 R1 P1\nG86 X4 Z-1 R1 P0\nG80\n");
    let acts: Vec<Action> = a.iter().map(|c| c.action).skip(2).collect();
    let feed = 60 * MM;
    let at = |x: i64, z: i64| [x * MM, 0, z, 0, 0, 0];
    assert_eq!(
        acts,
        vec![
            Action::Rapid { to: at(1, 5 * MM) },
            Action::Rapid { to: at(1, MM) },
            Action::Feed {
                to: at(1, -MM),
                feed
            },
            Action::Dwell { micros: 500_000 },
            Action::Rapid { to: at(1, 5 * MM) },
            Action::Rapid { to: at(2, 5 * MM) },
            Action::Rapid { to: at(2, MM) },
            Action::Feed {
                to: at(2, -MM),
                feed
            },
            Action::Feed {
                to: at(2, MM),
                feed
            },
            Action::Rapid { to: at(2, 5 * MM) },
            Action::Rapid { to: at(3, 5 * MM) },
            Action::Rapid { to: at(3, MM) },
            Action::Feed {
                to: at(3, -MM),
                feed
            },
            Action::Dwell { micros: 1_000_000 },
            Action::Feed {
                to: at(3, 5 * MM),
                feed
            },
            Action::Rapid { to: at(4, 5 * MM) },
            Action::Rapid { to: at(4, MM) },
            Action::Feed {
                to: at(4, -MM),
                feed
            },
            Action::Dwell { micros: 0 },
            Action::Spindle {
                state: Spindle::Off,
                rpm: 0
            },
            Action::Rapid { to: at(4, 5 * MM) },
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 500
            },
        ]
    );
}

#[test]
fn g84_taps_with_spindle_reversal() {
    let a = ok("G0 Z5\nM3 S300\nG99 G84 X1 Z-2 R1 F150\n");
    let acts: Vec<Action> = a.iter().map(|c| c.action).skip(2).collect();
    let at = |z: i64| [MM, 0, z, 0, 0, 0];
    assert_eq!(
        acts,
        vec![
            Action::Rapid { to: at(5 * MM) },
            Action::Rapid { to: at(MM) },
            Action::Feed {
                to: at(-2 * MM),
                feed: 150 * MM
            },
            Action::Spindle {
                state: Spindle::Off,
                rpm: 0
            },
            Action::Spindle {
                state: Spindle::Ccw,
                rpm: 300
            },
            Action::Feed {
                to: at(MM),
                feed: 150 * MM
            },
            Action::Spindle {
                state: Spindle::Off,
                rpm: 0
            },
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 300
            },
        ]
    );
    assert_eq!(
        first_error("G0 Z5\nG84 X1 Z-2 R1 F150\n").code,
        ErrorCode::CycleSpindleState
    );
}

#[test]
fn cycles_in_g18_drill_along_y() {
    let a = ok("G18 G0 X0 Y10 Z0\nG81 X1 Z2 Y-1 R1 F60\n");
    assert_eq!(
        moves(&a)[1..],
        [
            r(1.0, 10.0, 2.0),
            r(1.0, 1.0, 2.0),
            f(1.0, -1.0, 2.0),
            r(1.0, 10.0, 2.0)
        ]
    );
}

#[test]
fn cycle_starting_below_r_rises_first() {
    let a = ok("G0 Z0\nG81 X1 Z-1 R2 F60\n");
    assert_eq!(
        moves(&a)[1..],
        [
            r(0.0, 0.0, 2.0),
            r(1.0, 0.0, 2.0),
            f(1.0, 0.0, -1.0),
            r(1.0, 0.0, 2.0)
        ]
    );
}

#[test]
fn huge_peck_count_is_generated_lazily() {
    // 100 000 pecks of 0.001 mm: the interpreter never holds more than a few actions.
    let mut it = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(b"G0 Z1\nG73 Z-100 R0 Q0.001 F100\n");
    let mut n = 0;
    while let Some(x) = it.next(&mut src) {
        x.unwrap();
        n += 1;
    }
    assert_eq!(n, 1 + 2 + 2 * 99_999 + 2);
}

#[test]
fn bad_block_produces_no_action_and_keeps_state() {
    let out = run("G0 X1\nG91 M3 S100 G1 X5 Q1 F100\nG0 X2\n");
    assert_eq!(out.len(), 3);
    assert_eq!(out[1].as_ref().unwrap_err().code, ErrorCode::UnusedWord);
    // The G91, the spindle start and the F of the bad block left no trace: X2 is absolute.
    assert_eq!(
        out[2].as_ref().unwrap().action,
        Action::Rapid {
            to: [2 * MM, 0, 0, 0, 0, 0]
        }
    );
}

#[test]
fn errors_report_line_n_word_and_columns() {
    let e = first_error("G0 X1\n\nN40 G1 X2 F100 Y3 Y4\n");
    assert_eq!(e.line, 3);
    assert_eq!(e.n_word, Some(40));
    assert_eq!(e.columns, Some((18, 20)));
}

#[test]
fn absolute_arc_centres_with_g90_1() {
    let a = ok("G10 L2 P1 X100\nG0 X10 Y0\nG90.1 G3 X0 Y10 I0 J0 F100\nG91.1 G3 X-10 Y0 I0 J-10\n");
    let c: Vec<_> = arcs(&a).iter().map(|x| x.1).collect();
    assert_eq!(c, vec![[100 * MM, 0, 0], [100 * MM, 0, 0]]);
}

#[test]
fn g19_cycle_drills_along_x() {
    let a = ok("G19 G0 X10 Y0 Z0\nG99 G81 Y1 Z2 X-1 R1 F60\n");
    assert_eq!(
        moves(&a)[1..],
        [
            r(10.0, 1.0, 2.0),
            r(1.0, 1.0, 2.0),
            f(-1.0, 1.0, 2.0),
            r(1.0, 1.0, 2.0)
        ]
    );
}

#[test]
fn small_settings_and_framing() {
    // M98 L0 calls nothing; G43 H0 cancels the length; lines after the closing % are not read.
    let a = ok("%\nM98 P5 L0\nG43 H0\nG0 Z1\n%\nG0 X99\n");
    assert_eq!(moves(&a), vec![r(0.0, 0.0, 1.0)]);
    // G30.1 stores the position for G30; CRLF and lower case are fine.
    let a = ok("g0 x3 y4\r\ng30.1\r\ng0 x0 y0\r\ng30\r\n");
    assert_eq!(moves(&a)[3], r(3.0, 4.0, 0.0));
}

#[test]
fn pulling_reads_only_what_it_needs() {
    use gantry_machine::gcode::{ProgramSource, SourceError};
    struct Counting<'a> {
        inner: MemorySource<'a>,
        reads: u32,
    }
    impl ProgramSource for Counting<'_> {
        fn next_line(&mut self) -> Option<(u32, &[u8])> {
            self.reads += 1;
            self.inner.next_line()
        }
        fn jump_to_program(&mut self, p: u32) -> Result<u32, SourceError> {
            self.inner.jump_to_program(p)
        }
        fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
            self.inner.jump_to_sequence(n)
        }
        fn jump_to_line(&mut self, l: u32) -> Result<(), SourceError> {
            self.inner.jump_to_line(l)
        }
    }
    let mut src = Counting {
        inner: MemorySource::new(b"(header)\nG0 X1\nG91 G81 X1 Z-1 R1 L1000 F100\nG0 X9\n"),
        reads: 0,
    };
    let mut it = Interpreter::new(&InterpConfig::default());
    it.next(&mut src).unwrap().unwrap();
    assert_eq!(
        src.reads, 2,
        "one action needs only the lines up to its block"
    );
    // A thousand drilled holes come out of one block without reading further.
    for _ in 0..3000 {
        it.next(&mut src).unwrap().unwrap();
    }
    assert_eq!(src.reads, 3);
}

#[test]
fn bare_motion_codes_move_nowhere_like_linuxcnc() {
    // A CAM safety line with an explicit G0 and no axis words is a zero-length rapid in rs274.
    let a = ok("G0 X1\nG0 G17 G40 G49 G90\nY2\n");
    assert_eq!(
        moves(&a),
        vec![r(1.0, 0.0, 0.0), r(1.0, 0.0, 0.0), r(1.0, 2.0, 0.0)]
    );
    assert_eq!(first_error("G1\n").code, ErrorCode::ZeroFeedRate);
    // Non-motion blocks in a modal motion mode do not move.
    assert!(moves(&ok("G1 F100\nF200\nM8\n")).len() == 1);
}

#[test]
fn the_busiest_block_fits_the_action_queue() {
    let mut cfg = InterpConfig::default();
    cfg.add_user_m_code(100);
    cfg.add_user_m_code(101);
    // G4 and G28 share modal group 0, so the busiest block has one or the other.
    let out = run_with("T1 M6 M3 S100 M8 M100 M101 G64 G28 X0\n", &cfg);
    assert_eq!(out.len(), 8);
    assert!(out.iter().all(|r| r.is_ok()), "{out:?}");
}
