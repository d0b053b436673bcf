//! Interpreter behaviour with exact nanometre expectations (seed-002 §14 programs included).

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

#[test]
fn smoke() {
    let a = ok("G21 G90 G17\nG0 X10 Y5\nG1 Z-1 F100\nG2 X20 Y5 I5 J0\nM30\n");
    for c in &a {
        println!("{c:?}");
    }
    assert_eq!(a.len(), 5);
}
