//! The modes of the block the machine executes, for status reports.
//!
//! The interpreter reads ahead of the motion (the planner holds up to [`super::PLANNER_BLOCKS`]
//! blocks), so its own offsets and units are those of the last line read, not of the move being
//! cut: a `G43 H2` read ahead would shift the work position shown while the tool still cuts with
//! H1 (issue 25 item 3). The board therefore notes, before it queues a motion canon, the modes it
//! runs under ([`BlockModes`]) when they differ from the ones before, tagged with the planner's
//! next sequence number and the canon's line; segment prep reaching that block makes them the
//! active ones. The motion itself is untouched: the tags are read, never planned.

use crate::gcode::state::ModalState;
use crate::units::Pos;
use heapless::Deque;

/// Mode changes the board remembers while the blocks they belong to wait in the planner. A
/// program that changes offsets or units more often than this within the planner's look-ahead
/// has the newest change merged into the one before (its modes are shown a few blocks early); the
/// motion is the same either way.
const CHANGES: usize = 3;

/// The modal offsets and units a block runs under.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockModes {
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

/// The active modes and the changes still ahead of the machine.
#[derive(Clone, Debug)]
pub struct Executing {
    active: BlockModes,
    changes: Deque<Change, CHANGES>,
    /// Programmed path speed of the block being executed, nm/s (rapids: their limit).
    programmed: u32,
}

impl Executing {
    pub fn new(modes: BlockModes) -> Self {
        Executing {
            active: modes,
            changes: Deque::new(),
            programmed: 0,
        }
    }

    /// The modes of the block being executed (or executed last).
    pub fn active(&self) -> &BlockModes {
        &self.active
    }

    /// Programmed path speed of the block being executed, nm/s.
    pub fn programmed(&self) -> u32 {
        self.programmed
    }

    /// A motion canon of source line `line` is about to be queued, its first block numbered at
    /// least `next_seq`, under `modes`. `at_rest`: nothing is queued, so they apply at once.
    pub fn note(&mut self, at_rest: bool, next_seq: u32, line: u32, modes: BlockModes) {
        if at_rest {
            self.changes.clear();
            self.active = modes;
            return;
        }
        let newest = self.changes.back().map_or(&self.active, |c| &c.modes);
        if *newest == modes {
            return;
        }
        let change = Change {
            from_seq: next_seq,
            line,
            modes,
        };
        if let Err(change) = self.changes.push_back(change) {
            if let Some(last) = self.changes.back_mut() {
                last.modes = change.modes;
            }
        }
    }

    /// Segment prep works on the block numbered `seq` of source line `line`, at programmed speed
    /// `programmed` (nm/s): the newest change it has reached becomes active, with those before.
    pub fn on_block(&mut self, seq: u32, line: u32, programmed: u32) {
        self.programmed = programmed;
        let reached = self
            .changes
            .iter()
            .rposition(|c| c.reached_by(seq, line))
            .map_or(0, |i| i + 1);
        for _ in 0..reached {
            if let Some(c) = self.changes.pop_front() {
                self.active = c.modes;
            }
        }
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
        let mut e = Executing::new(modes(0));
        e.note(true, 0, 2, modes(-10));
        assert_eq!(e.active().offset[2], -10);
        // Read ahead: line 9's modes, its first block numbered 5 or later.
        e.note(false, 5, 9, modes(-20));
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
        let mut e = Executing::new(modes(0));
        e.note(false, 1, 5, modes(-1));
        e.note(false, 2, 6, modes(-2));
        e.on_block(3, 7, 1);
        assert_eq!(e.active().offset[2], -2);
        // Unchanged modes add nothing.
        e.note(false, 4, 8, modes(-2));
        e.on_block(5, 9, 1);
        assert_eq!(e.active().offset[2], -2);
    }

    #[test]
    fn a_full_list_merges_the_newest_change() {
        let mut e = Executing::new(modes(0));
        for (i, z) in [-1, -2, -3, -4].into_iter().enumerate() {
            e.note(false, i as u32, 10 + i as u32, modes(z));
        }
        e.on_block(2, 12, 1);
        assert_eq!(e.active().offset[2], -4);
    }

    #[test]
    fn sequence_numbers_wrap() {
        let mut e = Executing::new(modes(0));
        e.note(false, u32::MAX, 3, modes(-7));
        e.on_block(u32::MAX - 1, 3, 1);
        assert_eq!(e.active().offset[2], 0);
        e.on_block(0, 3, 1);
        assert_eq!(e.active().offset[2], -7);
    }
}
