//! Run from a line: rebuild the modal state a program has at line `n` by interpreting every line
//! before it without motion, and turn that state into a short preamble of blocks that brings the
//! board there (offsets, tool, spindle, coolant, position, modes) before line `n` is streamed.
//!
//! Limits (said to the user): `n` must be a line of the main program (not inside a subprogram),
//! nor inside O-word control flow (the refusal names the block's first line, which works:
//! `crate::resume_blocks`),
//! G28.1/G30.1 positions set before `n` are not restored, a modal arc or canned-cycle mode is
//! not restored (the resumed line must name its own G2/G3 or cycle), and numbered parameters
//! (`#1 = 0` before a loop) are not set by the preamble: the board's interpreter reads its own.

use crate::check::mm_text;
use crate::program::Program;
use anyhow::{bail, Context};
use gantry_machine::canon::{Action, PathMode, Plane, Spindle};
use gantry_machine::gcode::source::SourceError;
use gantry_machine::gcode::{
    InterpConfig, Interpreter, MemorySource, ModalState, MotionMode, ProgramSource,
};
use gantry_machine::setup::Setup;
use gantry_machine::units::{Pos, AXIS_LETTERS};

/// Serves a program but ends just before line `stop` (the resume line).
struct UpTo<'a> {
    inner: MemorySource<'a>,
    stop: u32,
    stopped: bool,
}

impl ProgramSource for UpTo<'_> {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        if self.stopped {
            return None;
        }
        let (n, text) = self.inner.next_line()?;
        if n == self.stop {
            self.stopped = true;
            return None;
        }
        Some((n, text))
    }
    fn jump_to_program(&mut self, program: u32) -> Result<u32, SourceError> {
        self.inner.jump_to_program(program)
    }
    fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
        self.inner.jump_to_sequence(n)
    }
    fn jump_to_line(&mut self, line: u32) -> Result<(), SourceError> {
        self.inner.jump_to_line(line)
    }
}

/// The modal state and the tool in the spindle when line `line` is about to run, and the highest
/// Z (machine nm) the program moved to before it: its clearance height, where the preamble may
/// cross the part.
pub(crate) fn state_and_clearance_before(
    text: &str,
    line: u32,
    config: &InterpConfig,
) -> anyhow::Result<(ModalState, Option<i64>)> {
    let mut clearance: Option<i64> = None;
    let mut interp = Interpreter::new(config);
    let mut src = UpTo {
        inner: MemorySource::new(text.as_bytes()),
        stop: line,
        stopped: false,
    };
    while let Some(r) = interp.next(&mut src) {
        match r {
            Err(e) => bail!(
                "line {}: {} (while rebuilding the state before line {line})",
                e.line,
                e.message()
            ),
            Ok(c) => {
                if let Action::Rapid { to } | Action::Feed { to, .. } | Action::Arc { to, .. } =
                    c.action
                {
                    clearance = Some(clearance.map_or(to[2], |z: i64| z.max(to[2])));
                }
            }
        }
    }
    if !src.stopped {
        bail!("line {line} is never reached by the main program (past its end, or only inside a subprogram)");
    }
    if interp.call_depth() > 0 {
        bail!("line {line} is inside a subprogram: resume from a line of the main program");
    }
    Ok((*interp.state(), clearance))
}

fn axis_words(p: &Pos, axes: usize) -> String {
    (0..axes)
        .map(|i| format!("{}{}", AXIS_LETTERS[i], mm_text(p[i])))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The blocks that bring a board standing at machine position `current` to the state `s`, its XY
/// move crossing at `clearance` (machine nm Z) at least: the program's own clearance height
/// ([`state_and_clearance_before`]). Lengths are written in mm (G21) until the final block
/// restores the program's units.
pub(crate) fn preamble_above(
    s: &ModalState,
    setup: &Setup,
    current: &Pos,
    clearance: Option<i64>,
) -> Vec<String> {
    let axes = setup.axis_count as usize;
    let config = setup.interp_config();
    let mut out = vec!["G21 G90 G94 G17 G40 G49 G80 G92.1".to_owned()];
    for (i, (now, start)) in s
        .work_offsets
        .iter()
        .zip(config.work_offsets.iter())
        .enumerate()
    {
        if now != start {
            out.push(format!("G10 L2 P{} {}", i + 1, axis_words(now, axes)));
        }
    }
    if s.tool_loaded != 0 {
        out.push(format!("T{} M6", s.tool_loaded));
    }
    // Clear the work, then go to the start point above it, then down. Above means no lower than
    // where the tool stands, the start point, the tool-change position the M6 just went to, or
    // the highest Z the program reached before (its clearance), so Z never comes down before XY
    // is over the start point and XY never crosses the part lower than the program would.
    let target = s.position;
    let mut safe = *current;
    safe[2] = current[2].max(target[2]);
    let tc = setup.program.tool_change_position;
    if s.tool_loaded != 0 && tc.axes & 0b100 != 0 {
        safe[2] = safe[2].max(tc.at[2]);
    }
    if let Some(z) = clearance {
        safe[2] = safe[2].max(z);
    }
    if axes >= 3 {
        out.push(format!("G53 G0 Z{}", mm_text(safe[2])));
    }
    let mut xy = target;
    xy[2] = safe[2];
    out.push(format!("G53 G0 {}", axis_words(&xy, axes)));
    match s.spindle {
        Spindle::Cw => out.push(format!("S{} M3", s.rpm)),
        Spindle::Ccw => out.push(format!("S{} M4", s.rpm)),
        Spindle::Off => {}
    }
    if s.mist {
        out.push("M7".into());
    }
    if s.flood {
        out.push("M8".into());
    }
    if axes >= 3 && target[2] != safe[2] {
        let plunge = if !s.inverse_time && s.feed > 0 {
            s.feed
        } else {
            100_000_000
        };
        out.push(format!(
            "G53 G1 Z{} F{}",
            mm_text(target[2]),
            mm_text(plunge)
        ));
    }
    let ws = match s.work_system {
        0..=5 => format!("G{}", 54 + s.work_system),
        n => format!("G59.{}", n - 5),
    };
    out.push(ws);
    if s.tool_offset.iter().any(|&v| v != 0) {
        out.push(format!("G43.1 {}", axis_words(&s.tool_offset, axes)));
    }
    if s.g92.iter().any(|&v| v != 0) {
        // Here the machine stands at the start point, so G92 with the program coordinates the
        // program had there recreates its G92 offset exactly.
        out.push(format!("G92 {}", axis_words(&s.program_position(), axes)));
    }
    let mut modes = vec![
        if s.inch { "G20" } else { "G21" }.to_owned(),
        match s.plane {
            Plane::XY => "G17",
            Plane::ZX => "G18",
            Plane::YZ => "G19",
        }
        .to_owned(),
        if s.absolute { "G90" } else { "G91" }.to_owned(),
        if s.inverse_time { "G93" } else { "G94" }.to_owned(),
        match s.path {
            PathMode::ExactStop => "G61".to_owned(),
            PathMode::Blend { tolerance: 0 } => "G64".to_owned(),
            PathMode::Blend { tolerance } => format!("G64 P{}", mm_text(tolerance)),
        },
        if s.retract_to_r { "G99" } else { "G98" }.to_owned(),
    ];
    if !s.inverse_time && s.feed > 0 {
        // The feed in the program's units (the F word comes after G20/G21 in this block).
        let f = if s.inch {
            format!("{:.4}", s.feed as f64 / 25_400_000.0)
        } else {
            mm_text(s.feed)
        };
        modes.push(format!("F{f}"));
    }
    out.push(modes.join(" "));
    match s.motion {
        MotionMode::Rapid => out.push("G0".into()),
        MotionMode::Linear => out.push("G1".into()),
        _ => {}
    }
    out
}

/// The preamble for resuming `program` at `line` on a board standing at `current`.
pub fn resume_preamble(
    program: &Program,
    text: &str,
    line: u32,
    setup: &Setup,
    current: &Pos,
) -> anyhow::Result<Vec<String>> {
    anyhow::ensure!(
        line >= 1 && line <= program.len(),
        "--from-line {line}: the program has lines 1 to {}",
        program.len()
    );
    if let Some(b) = crate::resume_blocks::enclosing_block(text, line).filter(|b| !b.sub) {
        bail!(
            "cannot resume from line {line}: it is inside the O-word block that starts at line {0} \
             (`{1}`), whose end the board would meet without its start; resume from line {0} \
             (--from-line {0}): the block runs again from its start",
            b.line,
            b.text
        );
    }
    let (state, clearance) = state_and_clearance_before(text, line, &setup.interp_config())
        .with_context(|| format!("cannot resume from line {line}"))?;
    Ok(preamble_above(&state, setup, current, clearance))
}
