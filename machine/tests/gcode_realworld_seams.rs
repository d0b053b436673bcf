//! The real-world bugs: safe-start lines with G80, G64 Q, `N10.5`, `% text` lines, nested
//! comments and the setup's default retract mode, with exact positions.
#![allow(clippy::field_reassign_with_default)]

use gantry_machine::canon::{Action, Canon, PathMode};
use gantry_machine::gcode::{
    ErrorCode, GcodeError, InterpConfig, Interpreter, MemorySource, RetractMode,
};

const MM: i64 = 1_000_000;

fn run_with(program: &str, cfg: &InterpConfig) -> Vec<Result<Canon, GcodeError>> {
    let mut it = Interpreter::new(cfg);
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(x) = it.next(&mut src) {
        out.push(x);
        assert!(out.len() < 10_000, "runaway");
    }
    out
}

fn ok_with(program: &str, cfg: &InterpConfig) -> Vec<Canon> {
    run_with(program, cfg)
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("unexpected error {e:?} in\n{program}")))
        .collect()
}

fn ok(program: &str) -> Vec<Canon> {
    ok_with(program, &InterpConfig::default())
}

/// (line, x, y, z) of every rapid/feed end point, mm×10^6.
fn ends(a: &[Canon]) -> Vec<(u32, [i64; 3])> {
    a.iter()
        .filter_map(|c| match c.action {
            Action::Rapid { to } | Action::Feed { to, .. } => Some((c.line, [to[0], to[1], to[2]])),
            _ => None,
        })
        .collect()
}

#[test]
fn safe_start_lines_with_g80_run_and_cancel_the_cycle() {
    let a = ok("G0 Z5\nG81 X1 Y1 Z-1 R1 F100\nG0 G80 X10\nG00 G17 G40 G49 G80 G90\nG0 G90 G40 G21 G17 G94 G80 Y3\nX4\n");
    let e = ends(&a);
    // Line 3 is a rapid to X10 (no cycle), line 4 an explicit G0 with no axis word (no motion
    // beyond the zero-length rapid), line 5 a rapid to Y3, and line 6 stays in G0.
    let from3: Vec<_> = e.iter().filter(|(l, _)| *l >= 3).collect();
    assert_eq!(
        from3,
        [
            &(3, [10 * MM, MM, 5 * MM]),
            &(4, [10 * MM, MM, 5 * MM]),
            &(5, [10 * MM, 3 * MM, 5 * MM]),
            &(6, [4 * MM, 3 * MM, 5 * MM]),
        ]
    );
    // The cycle memory is gone: a cycle block without R after `G0 G80` needs its R again.
    let out = run_with(
        "G0 Z5\nG81 X1 Z-1 R1 F100\nG0 G80 X10\nG81 X2 Z-1\n",
        &InterpConfig::default(),
    );
    let e = out.iter().find_map(|r| r.as_ref().err()).unwrap();
    assert_eq!((e.line, e.code), (4, ErrorCode::CycleRMissing));
    for bad in ["G0 G1 X1", "G81 G0 X1 Z-1 R1 F1"] {
        let out = run_with(bad, &InterpConfig::default());
        assert_eq!(
            out[0].as_ref().unwrap_err().code,
            ErrorCode::ModalGroupConflict
        );
    }
}

#[test]
fn g64_p_q_and_fractional_n_are_accepted() {
    let a = ok("G21 G64 P0.01 Q0.01\nN10.5 G0 X1\n");
    assert_eq!(
        a[0].action,
        Action::PathMode(PathMode::Blend { tolerance: 10_000 })
    );
    assert_eq!(ends(&a), [(2, [MM, 0, 0])]);
    let out = run_with("G64 P0.01 Q-1\n", &InterpConfig::default());
    assert_eq!(
        out[0].as_ref().unwrap_err().code,
        ErrorCode::ValueOutOfRange
    );
}

#[test]
fn percent_text_inside_a_framed_program_is_an_error_on_its_line() {
    let out = run_with(
        "%\nG0 X1\n% vfd enable\nG0 X2\n%\n",
        &InterpConfig::default(),
    );
    let e = out.iter().find_map(|r| r.as_ref().err()).unwrap();
    assert_eq!((e.line, e.code), (3, ErrorCode::UnexpectedCharacter));
    // A program name on the opening line and a bare closing `%` stay fine.
    let a = ok("%O1234 (name)\nG0 X1\n%\nG0 X9\n");
    assert_eq!(ends(&a), [(2, [MM, 0, 0])]);
}

#[test]
fn nested_comment_is_an_error_on_its_line() {
    let out = run_with("G0 X1\n(a (b); c\nG0 X2\n", &InterpConfig::default());
    let e = out.iter().find_map(|r| r.as_ref().err()).unwrap();
    assert_eq!((e.line, e.code), (2, ErrorCode::NestedComment));
}

#[test]
fn default_retract_mode_comes_from_the_setup() {
    let program = "G0 X0 Y0 Z10\nG81 X5 Z-2 R2 F100\nX8\n";
    // G98 by default: between holes the tool returns to the initial level Z10.
    let a = ok(program);
    assert_eq!(
        ends(&a).last().unwrap(),
        &(3, [8 * MM, 0, 10 * MM]),
        "{:?}",
        ends(&a)
    );
    let mut cfg = InterpConfig::default();
    cfg.default_retract = RetractMode::RPlane;
    let a = ok_with(program, &cfg);
    assert_eq!(ends(&a).last().unwrap(), &(3, [8 * MM, 0, 2 * MM]));
    // M2 restores the setup's mode, not G98.
    let mut it = Interpreter::new(&cfg);
    let mut src = MemorySource::new(b"G98\nM2\n");
    while it.next(&mut src).is_some() {}
    assert!(it.state().retract_to_r);
}
