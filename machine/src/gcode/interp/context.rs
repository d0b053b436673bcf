//! LinuxCNC's modal state save and restore: `M70` saves the modal state at the current call
//! level, `M71` forgets it, `M72` restores it, `M73` saves it and restores it when the
//! subroutine returns (`o… endsub`/`o… return`, or `M99` of an `M98` call).
//!
//! What is saved and restored is what LinuxCNC's `restore_settings` puts back
//! (docs/gcode-parameters.md "Modal state"): units, plane, distance and arc-distance mode,
//! feed mode and F, the coordinate system, the tool length offset, the retract mode, the path
//! mode, S and the spindle, mist and flood, cutter compensation when it was off (a subroutine
//! that left it on is ended as by G40; LinuxCNC's restore runs `G40` then) and a G92 offset that
//! was in force and is now cleared (as `G92.3`). The motion mode is not (LinuxCNC: "a real bad
//! idea").

use super::*;

/// The modal state `M70`/`M73` saved.
#[derive(Clone, Copy, Debug)]
pub(super) struct Saved {
    inch: bool,
    plane: Plane,
    absolute: bool,
    arc_absolute: bool,
    inverse_time: bool,
    work_system: u8,
    path: PathMode,
    retract_to_r: bool,
    feed: i64,
    feed_raw: i64,
    spindle: Spindle,
    rpm: u32,
    mist: bool,
    flood: bool,
    tool_offset: Pos,
    /// Cutter compensation was on (G41/G42/G41.1/G42.1).
    comp: bool,
    /// A G92 offset was in force (LinuxCNC's "G92 applied", its parameter #5210).
    g92: bool,
}

/// A saved modal state and the call level it belongs to.
#[derive(Clone, Copy, Debug)]
pub(super) struct Context {
    level: u8,
    /// `M73`: restored when the subroutine of this level returns.
    auto_restore: bool,
    saved: Saved,
}

/// Saved states kept at once: one a call level (the main program and the o-word call levels).
pub(super) const MAX_CONTEXTS: usize = MAX_O_CALLS + 1;

impl Interpreter {
    /// The call level of `M70`-`M73`: the main program is 0, each open o-word call or `M98`
    /// call adds one (LinuxCNC's `call_level`).
    pub(super) fn call_level(&self) -> u8 {
        (self.ocalls.len() + self.stack.len()).min(u8::MAX as usize) as u8
    }

    /// Phase 2's `M70`-`M73` (after the spindle, before coolant, as LinuxCNC's `convert_m`).
    pub(super) fn modal_context(&mut self, b: &Block, line: u32) -> Res<()> {
        let Some(&(_, code)) = b.m.iter().find(|(g, _)| *g == MGroup::Context) else {
            return Ok(());
        };
        let level = self.call_level();
        let at = self.contexts.iter().position(|c| c.level == level);
        match code.code {
            70 | 73 => {
                let s = &self.state;
                let context = Context {
                    level,
                    // At the top level there is nothing to return to: saved, never restored by
                    // itself (LinuxCNC warns and stores it anyway).
                    auto_restore: code.code == 73 && level > 0,
                    saved: Saved {
                        inch: s.inch,
                        plane: s.plane,
                        absolute: s.absolute,
                        arc_absolute: s.arc_absolute,
                        inverse_time: s.inverse_time,
                        work_system: s.work_system,
                        path: s.path,
                        retract_to_r: s.retract_to_r,
                        feed: s.feed,
                        feed_raw: s.feed_raw,
                        spindle: s.spindle,
                        rpm: s.rpm,
                        mist: s.mist,
                        flood: s.flood,
                        tool_offset: s.tool_offset,
                        comp: self.comp.is_on(),
                        g92: s.g92 != [0; MAX_AXES],
                    },
                };
                match at.and_then(|i| self.contexts.get_mut(i)) {
                    Some(slot) => *slot = context,
                    None => self
                        .contexts
                        .push(context)
                        .map_err(|_| (ErrorCode::ParameterTableFull, Some(code.cols)))?,
                }
            }
            71 => {
                if let Some(i) = at {
                    self.contexts.remove(i);
                }
            }
            _ => {
                let saved = at
                    .and_then(|i| self.contexts.get(i))
                    .map(|c| c.saved)
                    .ok_or((ErrorCode::NoSavedModalState, Some(code.cols)))?;
                self.restore_modes(line, &saved)?;
            }
        }
        Ok(())
    }

    /// A subroutine of call level `level` returned (the level is gone): its `M73` state comes
    /// back, and every state saved at that level or deeper is forgotten.
    pub(super) fn leave_level(&mut self, level: u8, line: u32) -> Res<()> {
        let restore = self
            .contexts
            .iter()
            .find(|c| c.level == level && c.auto_restore)
            .map(|c| c.saved);
        let mut i = 0;
        while i < self.contexts.len() {
            if self.contexts[i].level >= level {
                self.contexts.swap_remove(i);
            } else {
                i += 1;
            }
        }
        match restore {
            Some(saved) => self.restore_modes(line, &saved),
            None => Ok(()),
        }
    }

    /// Puts a saved modal state back; compensation is turned off if it was off, the spindle and
    /// coolant are switched only if they differ.
    fn restore_modes(&mut self, line: u32, saved: &Saved) -> Res<()> {
        if !saved.comp && self.comp.is_on() {
            // LinuxCNC's restore executes `G40`: the compensated move that waits ends first.
            self.comp_off(None)?;
        }
        let s = &mut self.state;
        if saved.g92 && s.g92 == [0; MAX_AXES] {
            // The offset was cleared (G92.1/G92.2): LinuxCNC's restore runs `G92.3`, which puts
            // back the stored values — the last G92's, perhaps the subroutine's own.
            s.g92 = s.g92_saved;
        }
        s.inch = saved.inch;
        s.plane = saved.plane;
        s.absolute = saved.absolute;
        s.arc_absolute = saved.arc_absolute;
        s.inverse_time = saved.inverse_time;
        s.work_system = saved.work_system;
        s.path = saved.path;
        s.retract_to_r = saved.retract_to_r;
        s.feed = saved.feed;
        s.feed_raw = saved.feed_raw;
        s.tool_offset = saved.tool_offset;
        let spindle =
            s.spindle != saved.spindle || (saved.spindle != Spindle::Off && s.rpm != saved.rpm);
        let coolant = (s.mist, s.flood) != (saved.mist, saved.flood);
        s.spindle = saved.spindle;
        s.rpm = saved.rpm;
        s.mist = saved.mist;
        s.flood = saved.flood;
        if spindle {
            let (state, rpm) = (saved.spindle, saved.rpm);
            self.push(line, Action::Spindle { state, rpm })?;
        }
        if coolant {
            let (mist, flood) = (saved.mist, saved.flood);
            self.push(line, Action::Coolant { mist, flood })?;
        }
        Ok(())
    }
}
