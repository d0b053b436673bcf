//! The modes of the block the machine executes, for status reports.
//!
//! The interpreter reads ahead of the motion (the planner holds up to [`super::PLANNER_BLOCKS`]
//! blocks), so its own offsets and units are those of the last line read, not of the move being
//! cut: a `G43 H2` read ahead would shift the work position shown while the tool still cuts with
//! H1. The board therefore notes, before it queues a motion canon, the modes it
//! runs under ([`BlockModes`]) when they differ from the ones before, tagged with the planner's
//! next sequence number and the canon's line; segment prep reaching that block makes them the
//! active ones. The motion itself is untouched: the tags are read, never planned.

use crate::gcode::state::ModalState;
use crate::units::Pos;

/// Entries of the ring: the active modes and up to `RING - 1` changes still ahead of the machine
/// (a power of two: the index arithmetic is a mask).
/// A program that changes offsets or units more often than that within the planner's look-ahead
/// has its newest change merged into the one before (those modes are shown a few blocks early);
/// the motion is the same either way.
const RING: usize = 4;

/// The modal offsets and units a block runs under.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BlockModes {
    /// Total offset from program to machine coordinates (work offset + G92 + tool length), nm.
    pub offset: Pos,
    /// Work system 0..8 = G54..G59.3.
    pub work_system: u8,
    /// G20 (true) / G21.
    pub inch: bool,
}

impl BlockModes {
    /// The modes of the interpreter's state `s`.
    pub fn of(s: &ModalState) -> Self {
        BlockModes {
            offset: s.offset(),
            work_system: s.work_system,
            inch: s.inch,
        }
    }

    /// Work position of the machine position `machine`: minus these offsets.
    pub(crate) fn work_position(&self, machine: &Pos) -> Pos {
        let mut w = *machine;
        for (w, o) in w.iter_mut().zip(self.offset) {
            *w -= o;
        }
        w
    }
}

/// Modes that start with the first block numbered at least `from_seq` whose source line is at
/// least `line` (line numbers only fall at a jump, M98/M99 or a loop; a block of an earlier line
/// still queued from before the change, such as a blended leg held back, never starts them).
#[derive(Clone, Copy, Debug)]
struct Change {
    from_seq: u32,
    line: u32,
    modes: BlockModes,
}

impl Change {
    fn reached_by(&self, seq: u32, line: u32) -> bool {
        (seq.wrapping_sub(self.from_seq) as i32) >= 0 && line >= self.line
    }
}

/// The active modes and the changes still ahead of the machine, in a ring that is never shifted
/// (a `heapless::Deque` moved its 64-byte entries with a `memmove` the firmware had no other use
/// for: 1.5 KiB of F411 flash).
#[derive(Clone, Debug)]
pub(crate) struct Executing {
    ring: [Change; RING],
    /// Index of the active entry.
    active: usize,
    /// Index of the newest entry (`active` when no change is ahead).
    newest: usize,
    /// Programmed path speed of the block being executed, nm/s (rapids: their limit).
    programmed: u32,
}

impl Executing {
    /// Nothing noted yet: zero offsets, G54, millimetres, until the first motion of a job (noted
    /// at rest, [`Executing::note`]); [`super::Board::executing_modes`] reads the interpreter
    /// outside a job. All zero, so the firmware's board starts without copying modes around.
    pub const fn new() -> Self {
        const NONE: Change = Change {
            from_seq: 0,
            line: 0,
            modes: BlockModes {
                offset: [0; crate::units::MAX_AXES],
                work_system: 0,
                inch: false,
            },
        };
        Executing {
            ring: [NONE; RING],
            active: 0,
            newest: 0,
            programmed: 0,
        }
    }

    /// The modes of the block being executed (or executed last).
    pub fn active(&self) -> &BlockModes {
        &self.ring[self.active % RING].modes
    }

    /// Programmed path speed of the block being executed, nm/s.
    pub fn programmed(&self) -> u32 {
        self.programmed
    }

    /// A motion canon of source line `line` is about to be queued, its first block numbered at
    /// least `next_seq`, under the modes of `state`. `at_rest`: nothing is queued, so they apply
    /// at once.
    pub fn note(&mut self, at_rest: bool, next_seq: u32, line: u32, state: &ModalState) {
        self.note_modes(at_rest, next_seq, line, BlockModes::of(state));
    }

    /// [`Executing::note`] with the modes given.
    #[inline(always)]
    fn note_modes(&mut self, at_rest: bool, next_seq: u32, line: u32, modes: BlockModes) {
        if at_rest {
            self.newest = self.active;
        } else if self.ring[self.newest % RING].modes == modes {
            return;
        } else {
            let next = (self.newest + 1) % RING;
            if next != self.active {
                self.newest = next;
                self.ring[next].from_seq = next_seq;
                self.ring[next].line = line;
            }
        }
        self.ring[self.newest % RING].modes = modes;
    }

    /// Segment prep works on the block numbered `seq` of source line `line`, at programmed speed
    /// `programmed` (nm/s): the newest change it has reached becomes active, with those before.
    pub fn on_block(&mut self, seq: u32, line: u32, programmed: u32) {
        self.programmed = programmed;
        let mut i = self.active;
        while i != self.newest {
            i = (i + 1) % RING;
            if self.ring[i].reached_by(seq, line) {
                self.active = i;
            }
        }
    }
}

impl Default for Executing {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn modes(z: i64) -> BlockModes {
        BlockModes {
            offset: [0, 0, z, 0, 0, 0],
            work_system: 0,
            inch: false,
        }
    }

    #[test]
    fn a_change_waits_for_its_block() {
        let mut e = Executing::new();
        e.note_modes(true, 0, 2, modes(-10));
        assert_eq!(e.active().offset[2], -10);
        // Read ahead: line 9's modes, its first block numbered 5 or later.
        e.note_modes(false, 5, 9, modes(-20));
        e.on_block(3, 4, 100);
        assert_eq!(e.active().offset[2], -10);
        // A block queued after the note but of an earlier line (a leg held back) is not it.
        e.on_block(5, 8, 100);
        assert_eq!(e.active().offset[2], -10);
        e.on_block(6, 9, 200);
        assert_eq!(e.active().offset[2], -20);
        assert_eq!(e.programmed(), 200);
    }

    #[test]
    fn a_later_change_reached_retires_the_ones_before() {
        let mut e = Executing::new();
        e.note_modes(false, 1, 5, modes(-1));
        e.note_modes(false, 2, 6, modes(-2));
        e.on_block(3, 7, 1);
        assert_eq!(e.active().offset[2], -2);
        // Unchanged modes add nothing.
        e.note_modes(false, 4, 8, modes(-2));
        e.on_block(5, 9, 1);
        assert_eq!(e.active().offset[2], -2);
    }

    #[test]
    fn a_full_ring_merges_the_newest_change() {
        let mut e = Executing::new();
        for (i, z) in [-1, -2, -3, -4].into_iter().enumerate() {
            e.note_modes(false, i as u32, 10 + i as u32, modes(z));
        }
        // Three changes fit beside the active modes: line 12's took line 13's modes.
        e.on_block(0, 10, 1);
        assert_eq!(e.active().offset[2], -1);
        e.on_block(1, 11, 1);
        assert_eq!(e.active().offset[2], -2);
        e.on_block(2, 12, 1);
        assert_eq!(e.active().offset[2], -4);
        // Room again: the next change is kept apart.
        e.note_modes(false, 5, 20, modes(-5));
        e.on_block(4, 19, 1);
        assert_eq!(e.active().offset[2], -4);
        e.on_block(5, 20, 1);
        assert_eq!(e.active().offset[2], -5);
    }

    #[test]
    fn at_rest_the_modes_apply_at_once() {
        let mut e = Executing::new();
        e.note_modes(false, 1, 5, modes(-1));
        e.note_modes(true, 9, 9, modes(-9));
        assert_eq!(e.active().offset[2], -9);
        // The change noted before is gone: its block never ran.
        e.on_block(9, 9, 1);
        assert_eq!(e.active().offset[2], -9);
    }

    #[test]
    fn sequence_numbers_wrap() {
        let mut e = Executing::new();
        e.note_modes(false, u32::MAX, 3, modes(-7));
        e.on_block(u32::MAX - 1, 3, 1);
        assert_eq!(e.active().offset[2], 0);
        e.on_block(0, 3, 1);
        assert_eq!(e.active().offset[2], -7);
    }
}
