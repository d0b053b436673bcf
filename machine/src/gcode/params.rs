//! Parameter storage: numbered `#1`-`#5601` and named `#<local>` / `#<_global>`, in fixed tables.
//!
//! Only parameters a program has written take room: [`MAX_NUMBERED`] numbered and [`MAX_NAMED`]
//! named entries (a full table is error E707). The system parameters LinuxCNC defines are views of
//! the modal state. As in LinuxCNC, the stored offsets and positions are in the machine's units
//! (Gantry's are millimetres, whatever G20/G21 says) and the current position in the program's
//! units: #5161-#5169 G28 and #5181-#5189 G30 positions,
//! #5211-#5219 the G92 offset, #5220 the coordinate system (1-9), #5221-#5399 the G54-G59.3
//! offsets (20 per system), #5400 the tool in the spindle, #5401-#5409 its offsets, #5420-#5428
//! the current position in program coordinates; #5061-#5070 (probe results) read as stored
//! (written by a G38 probe move: `Interpreter::probe_done`). Writing #5161-#5399 moves the offset or position it names.
//! Named locals belong to the subroutine level that set them and vanish when it returns.

use super::error::ErrorCode;
use super::expr::{Fx, ParamRef, ONE};
use super::state::ModalState;
use crate::units::{Nm, MAX_AXES};

/// Numbered parameters a program may hold at once.
pub(crate) const MAX_NUMBERED: usize = 96;
/// Named parameters a program may hold at once (locals of every call level and globals).
pub(crate) const MAX_NAMED: usize = 64;
/// Fanuc Macro B local variables per G65 call level (#1-#33).
pub(crate) const LOCALS: usize = 33;
/// Largest parameter number (LinuxCNC's: its parameter file runs to #5601).
pub(crate) const MAX_NUMBER: u16 = 5601;
/// LinuxCNC's `(DEBUG,…)` output switch: 1 at start, any value may be written. Gantry keeps
/// `(DEBUG,…)` a comment, so the switch is stored and read back and changes nothing.
pub(crate) const DEBUG_SWITCH: u16 = 5599;

/// The parameter tables.
#[derive(Clone, Debug, Default)]
pub struct Params {
    numbered: heapless::Vec<(u16, Fx), MAX_NUMBERED>,
    /// (name hash, call level, value); globals have level 0xFF.
    named: heapless::Vec<(u32, u8, Fx), MAX_NAMED>,
}

const GLOBAL: u8 = 0xFF;

/// Keeps the entries `wanted` accepts, in their order: `retain` without heapless's drop guard,
/// whose overlapping copy links a 1.5 KiB `memmove` into the firmware.
/// Checked splits and `get` rather than indexing: no bounds-check panic paths.
fn keep<T: Copy, const N: usize>(v: &mut heapless::Vec<T, N>, wanted: impl Fn(&T) -> bool) {
    let mut kept = 0;
    for i in 0..v.len() {
        let Some((front, back)) = v.split_at_mut_checked(i) else {
            break;
        };
        let Some(entry) = back.first() else {
            break;
        };
        if wanted(entry) {
            // Slot `kept` lies before entry `i` once an earlier entry was dropped.
            if let Some(slot) = front.get_mut(kept) {
                copy_entry(slot, entry);
            }
            kept += 1;
        }
    }
    v.truncate(kept);
}

/// One entry copied between two distinct slots: as a call of its own the compiler knows they
/// do not overlap and copies plainly (inlined into `keep`, it called `memmove`).
#[inline(never)]
fn copy_entry<T: Copy>(to: &mut T, from: &T) {
    *to = *from;
}

/// nm to the program's length units as an [`Fx`] (mm ×10⁹ or inch ×10⁹).
pub(crate) fn nm_to_fx(nm: Nm, inch: bool) -> Fx {
    if inch {
        crate::arith::div_i128(nm as i128 * 10_000, 254) as i64
    } else {
        nm.saturating_mul(1000)
    }
}

/// An [`Fx`] length in program units to nm, rounded.
pub(crate) fn fx_to_nm(v: Fx, inch: bool) -> Nm {
    let n = if inch {
        crate::arith::div_i128(v as i128 * 254, 10_000)
    } else {
        v as i128
    };
    let nm = if inch {
        n
    } else {
        // Through `div_i128` (same truncation as `/`): an i128 `/` is a ~0.7 KiB inline
        // expansion on the Cortex-M4.
        crate::arith::div_i128(n + n.signum() * 500, 1000)
    };
    nm as Nm
}

/// A system parameter's place in the modal state.
enum System {
    G28(usize),
    G30(usize),
    G92(usize),
    ActiveWorkOffset,
    Work(usize, usize),
    Tool,
    ToolOffset(usize),
    /// #5410-#5413: the tool's diameter, front and back angle and orientation (LinuxCNC's lathe
    /// tool data): read-only, 0.
    ToolGeometry,
    /// #5600-#5601: LinuxCNC's tool changer fault flag and reason, set by its tool changer;
    /// Gantry has none, so they read 0 and a write is accepted and has no effect (as in
    /// rs274, which reloads them from the tool changer).
    ToolChangerFault,
    Position(usize),
}

fn system(n: u16) -> Option<System> {
    let axis = |base: u16| -> Option<usize> {
        let i = (n - base) as usize;
        (i < MAX_AXES).then_some(i)
    };
    match n {
        5161..=5169 => axis(5161).map(System::G28),
        5181..=5189 => axis(5181).map(System::G30),
        5211..=5219 => axis(5211).map(System::G92),
        5220 => Some(System::ActiveWorkOffset),
        5221..=5399 => {
            let k = n - 5221;
            let (sys, i) = ((k / 20) as usize, (k % 20) as usize);
            (i < MAX_AXES && sys < 9).then_some(System::Work(sys, i))
        }
        5400 => Some(System::Tool),
        5401..=5409 => axis(5401).map(System::ToolOffset),
        5410..=5413 => Some(System::ToolGeometry),
        5600..=5601 => Some(System::ToolChangerFault),
        5420..=5428 => axis(5420).map(System::Position),
        _ => None,
    }
}

/// Length `i` of the modal state's lengths `p` (a system parameter's): one bounds check for
/// all of them (each indexing had its panic path).
#[inline(never)]
fn at(p: &[Nm], i: usize) -> Nm {
    p[i]
}

/// The length [`at`] reads, to write.
#[inline(never)]
fn at_mut(p: &mut [Nm], i: usize) -> &mut Nm {
    &mut p[i]
}

impl Params {
    /// Empty tables.
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads a parameter at call `level`, with the modal state for the system ones.
    pub fn read(&self, p: ParamRef, level: u8, s: &ModalState) -> Result<Fx, ErrorCode> {
        match p {
            ParamRef::Numbered(n) => {
                if n == 0 || n > MAX_NUMBER {
                    return Err(ErrorCode::ParameterNumberInvalid);
                }
                if let Some(sys) = system(n) {
                    let len = |nm: Nm| nm_to_fx(nm, false);
                    return Ok(match sys {
                        System::G28(i) => len(at(&s.g28, i)),
                        System::G30(i) => len(at(&s.g30, i)),
                        System::G92(i) => len(at(&s.g92, i)),
                        System::ActiveWorkOffset => (s.work_system as Fx + 1) * ONE,
                        System::Work(w, i) => {
                            len(at(s.work_offsets.as_flattened(), w * MAX_AXES + i))
                        }
                        System::Tool => s.tool_loaded as Fx * ONE,
                        System::ToolOffset(i) => len(at(&s.tool_offset, i)),
                        System::ToolGeometry | System::ToolChangerFault => 0,
                        System::Position(i) => nm_to_fx(at(&s.program_position(), i), s.inch),
                    });
                }
                let unset = if n == DEBUG_SWITCH { ONE } else { 0 };
                Ok(self
                    .numbered
                    .iter()
                    .find(|e| e.0 == n)
                    .map_or(unset, |e| e.1))
            }
            ParamRef::Named { hash, global } => {
                let level = if global { GLOBAL } else { level };
                self.named
                    .iter()
                    .find(|e| e.0 == hash && e.1 == level)
                    .map(|e| e.2)
                    .ok_or(ErrorCode::UndefinedParameter)
            }
        }
    }

    /// True if a named parameter is set at `level` (numbered ones always exist).
    pub fn exists(&self, p: ParamRef, level: u8) -> bool {
        match p {
            ParamRef::Numbered(n) => (1..=MAX_NUMBER).contains(&n),
            ParamRef::Named { hash, global } => {
                let level = if global { GLOBAL } else { level };
                self.named.iter().any(|e| e.0 == hash && e.1 == level)
            }
        }
    }

    /// Writes a parameter (system ones change the modal state).
    pub fn write(
        &mut self,
        p: ParamRef,
        v: Fx,
        level: u8,
        s: &mut ModalState,
    ) -> Result<(), ErrorCode> {
        match p {
            ParamRef::Numbered(n) => {
                if n == 0 || n > MAX_NUMBER {
                    return Err(ErrorCode::ParameterNumberInvalid);
                }
                if let Some(sys) = system(n) {
                    let nm = fx_to_nm(v, false);
                    match sys {
                        System::G28(i) => *at_mut(&mut s.g28, i) = nm,
                        System::G30(i) => *at_mut(&mut s.g30, i) = nm,
                        System::G92(i) => *at_mut(&mut s.g92, i) = nm,
                        System::Work(w, i) => {
                            *at_mut(s.work_offsets.as_flattened_mut(), w * MAX_AXES + i) = nm
                        }
                        System::ToolChangerFault => {}
                        _ => return Err(ErrorCode::ParameterNumberInvalid),
                    }
                    return Ok(());
                }
                if let Some(e) = self.numbered.iter_mut().find(|e| e.0 == n) {
                    e.1 = v;
                    return Ok(());
                }
                self.numbered
                    .push((n, v))
                    .map_err(|_| ErrorCode::ParameterTableFull)
            }
            ParamRef::Named { hash, global } => {
                let level = if global { GLOBAL } else { level };
                if let Some(e) = self.named.iter_mut().find(|e| e.0 == hash && e.1 == level) {
                    e.2 = v;
                    return Ok(());
                }
                self.named
                    .push((hash, level, v))
                    .map_err(|_| ErrorCode::ParameterTableFull)
            }
        }
    }

    /// True if numbered parameter `n` has been written (and not made vacant).
    pub(crate) fn is_set(&self, n: u16) -> bool {
        self.numbered.iter().any(|e| e.0 == n)
    }

    /// Fanuc `#n = #0`: numbered parameter `n` becomes unset (vacant in a G65 macro, 0 elsewhere).
    /// System parameters and named ones cannot be vacant (E706).
    pub(crate) fn make_vacant(&mut self, p: ParamRef) -> Result<(), ErrorCode> {
        match p {
            ParamRef::Numbered(n) if (1..=MAX_NUMBER).contains(&n) && system(n).is_none() => {
                keep(&mut self.numbered, |e| e.0 != n);
                Ok(())
            }
            _ => Err(ErrorCode::ParameterNumberInvalid),
        }
    }

    /// Forgets the named locals of every level above `level` (a subroutine returned).
    pub(crate) fn drop_locals_above(&mut self, level: u8) {
        keep(&mut self.named, |e| e.1 == GLOBAL || e.1 <= level);
    }

    /// Numbered parameters #1-#30 as (bit mask of the set ones, values), for a call to save.
    pub(crate) fn save_args(&self) -> (u32, [Fx; 30]) {
        let mut mask = 0u32;
        let mut v = [0; 30];
        for &(n, x) in &self.numbered {
            if (1..=30).contains(&n) {
                mask |= 1 << (n - 1);
                v[n as usize - 1] = x;
            }
        }
        (mask, v)
    }

    /// Replaces #1-#30 by a saved set (a call's arguments, or the caller's on return).
    pub(crate) fn restore_args(&mut self, mask: u32, values: &[Fx; 30]) -> Result<(), ErrorCode> {
        keep(&mut self.numbered, |e| !(1..=30).contains(&e.0));
        for (i, &v) in values.iter().enumerate() {
            if mask & (1 << i) != 0 {
                self.numbered
                    .push((i as u16 + 1, v))
                    .map_err(|_| ErrorCode::ParameterTableFull)?;
            }
        }
        Ok(())
    }

    /// Fanuc's local variables #1-#[`LOCALS`] as (bit mask of the set ones, values): a G65 macro
    /// call saves the caller's.
    pub(crate) fn save_locals(&self) -> (u64, [Fx; LOCALS]) {
        let mut mask = 0u64;
        let mut v = [0; LOCALS];
        for &(n, x) in &self.numbered {
            if (1..=LOCALS as u16).contains(&n) {
                mask |= 1 << (n - 1);
                v[n as usize - 1] = x;
            }
        }
        (mask, v)
    }

    /// Replaces #1-#[`LOCALS`] by a saved set (a macro's arguments, or the caller's on M99).
    pub(crate) fn restore_locals(
        &mut self,
        mask: u64,
        values: &[Fx; LOCALS],
    ) -> Result<(), ErrorCode> {
        keep(&mut self.numbered, |e| !(1..=LOCALS as u16).contains(&e.0));
        for (i, &v) in values.iter().enumerate() {
            if mask & (1 << i) != 0 {
                self.numbered
                    .push((i as u16 + 1, v))
                    .map_err(|_| ErrorCode::ParameterTableFull)?;
            }
        }
        Ok(())
    }

    /// Forgets every parameter (a new program).
    pub fn clear(&mut self) {
        self.numbered.clear();
        self.named.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keep_compacts_the_kept_entries_in_their_order() {
        let mut v: heapless::Vec<(u16, Fx), 8> = heapless::Vec::new();
        for n in [5, 1, 7, 2, 9, 3] {
            v.push((n, Fx::from(n) * 10)).unwrap();
        }
        keep(&mut v, |e| e.0 > 3);
        assert_eq!(v.as_slice(), &[(5, 50), (7, 70), (9, 90)]);
        keep(&mut v, |e| e.0 != 5);
        assert_eq!(v.as_slice(), &[(7, 70), (9, 90)]);
        keep(&mut v, |_| false);
        assert!(v.is_empty());
    }

    #[test]
    fn a_vacant_parameter_leaves_the_others_in_place() {
        let mut p = Params::new();
        let mut s = ModalState::new(&crate::gcode::config::InterpConfig::default());
        for n in 1..=4u16 {
            p.write(ParamRef::Numbered(n), Fx::from(n) * ONE, 0, &mut s)
                .unwrap();
        }
        p.make_vacant(ParamRef::Numbered(2)).unwrap();
        assert!(!p.is_set(2));
        for n in [1u16, 3, 4] {
            assert_eq!(p.read(ParamRef::Numbered(n), 0, &s), Ok(Fx::from(n) * ONE));
        }
    }
}
