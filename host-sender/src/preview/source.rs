//! Program text → canonical actions with the core's interpreter, configured from the machine setup.

use super::model::{Interpreted, ProgramError};
use gantry_machine::gcode::{Interpreter, MemorySource};
use gantry_machine::setup::Setup;

/// Most actions one preview interprets (endless loops, huge repeat counts).
const MAX_ACTIONS: usize = 2_000_000;

/// Interprets a whole program. Stops at the first error (returned with its line and message),
/// after one pass of a main program that loops with M99, or after [`MAX_ACTIONS`] actions.
pub fn interpret(program: &[u8], setup: &Setup) -> Interpreted {
    let mut interp = Interpreter::new(&setup.interp_config());
    let mut src = MemorySource::new(program);
    let mut out = Vec::new();
    while let Some(item) = interp.next(&mut src) {
        match item {
            Ok(c) => out.push(c),
            Err(e) => {
                let message = format!("E{}: {}", e.code.number(), e.message());
                let line = e.line;
                return (out, Some(ProgramError { line, message }));
            }
        }
        if interp.restarts() > 0 {
            break;
        }
        if out.len() >= MAX_ACTIONS {
            let message = format!("more than {MAX_ACTIONS} actions, preview stopped");
            return (out, Some(ProgramError { line: 0, message }));
        }
    }
    (out, None)
}
