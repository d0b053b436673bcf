//! Program text → canonical actions with the core's interpreter, configured from the machine setup.

use super::model::{Interpreted, ProgramError};
use gantry_machine::gcode::{self, InterpConfig, Interpreter, MemorySource};
use gantry_machine::setup::{self, Setup};

/// Most actions one preview interprets (endless loops, huge repeat counts).
const MAX_ACTIONS: usize = 2_000_000;

/// The interpreter settings the setup implies (dialect, axes, offsets, homes, tools, pecks).
pub fn interp_config(s: &Setup) -> InterpConfig {
    let mut c = match s.program.dialect {
        setup::Dialect::Ngc => InterpConfig::default(),
        setup::Dialect::Gixa => InterpConfig::gixa(),
    };
    c.axis_count = s.axis_count;
    c.work_offsets = s.program.work_offsets;
    c.g28_position = s.program.g28_home;
    c.g30_position = s.program.g30_home;
    c.peck_clearance = s.program.peck_clearance;
    c.dwell_units = match s.program.dwell_units {
        setup::DwellUnits::Seconds => gcode::DwellUnits::Seconds,
        setup::DwellUnits::Milliseconds => gcode::DwellUnits::FanucIntegerMillis,
    };
    for t in &s.program.tools {
        c.set_tool(t.number, t.length);
    }
    for m in &s.program.user_mcodes {
        c.add_user_m_code(*m);
    }
    c
}

/// Interprets a whole program. Stops at the first error (returned with its line and message),
/// after one pass of a main program that loops with M99, or after [`MAX_ACTIONS`] actions.
pub fn interpret(program: &[u8], setup: &Setup) -> Interpreted {
    let mut interp = Interpreter::new(&interp_config(setup));
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
