//! Helpers shared by the interpreter tests that run a program through the RS274NGC interpreter
//! with the default setup and look at its moves or its first error (gcode_params.rs,
//! gcode_macro_b.rs).
#![allow(dead_code)]

use gantry_machine::canon::{Action, Canon};
use gantry_machine::gcode::{GcodeError, InterpConfig, Interpreter, MemorySource};

/// One millimetre in program units (nm).
pub const MM: i64 = 1_000_000;

/// Every canonical action (or the error that stopped it) of `program`, and the interpreter
/// after it.
pub fn run(program: &str) -> (Vec<Result<Canon, GcodeError>>, Interpreter) {
    let mut it = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(x) = it.next(&mut src) {
        let stop = x.is_err();
        out.push(x);
        assert!(out.len() < 100_000, "runaway");
        if stop {
            break;
        }
    }
    (out, it)
}

/// (line, [x, y, z]) of every rapid and straight feed end point, nm; panics on an error.
pub fn moves(program: &str) -> Vec<(u32, [i64; 3])> {
    run(program)
        .0
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("unexpected error {e:?} in\n{program}")))
        .filter_map(|c| match c.action {
            Action::Rapid { to } | Action::Feed { to, .. } => Some((c.line, [to[0], to[1], to[2]])),
            _ => None,
        })
        .collect()
}

/// The error that stops `program`; panics when it runs through.
pub fn first_error(program: &str) -> GcodeError {
    run(program)
        .0
        .into_iter()
        .find_map(|r| r.err())
        .unwrap_or_else(|| panic!("no error in\n{program}"))
}
