//! On-the-fly output events (docs/controller.md, "On-the-fly outputs"): one user output switched on or off
//! at an exact point of the path, carried by the motion itself.
//!
//! An M code whose command list is exactly one `set n` or `clear n` does not stop the motion: the
//! pipeline attaches its [`OutputEvent`] to the next line block (planner `Block::output`), segment
//! prep puts it on that block's first [`super::kernel::Segment`], and the step kernel reports it in
//! the `TickOut` of the tick that starts the segment, so the output switches together with the
//! block's first step. One byte, so neither the planner ring nor the segment queue grows.

/// One user output switched to a level, or nothing. Bit 7: an event is present; bit 4: the level
/// (1 = on); bits 0-3: the output number (0..16).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputEvent(u8);

const PRESENT: u8 = 0x80;
/// Not a user output: torch height control switched off or on (`M62 P2` / `M63 P2`), applied by
/// segment prep at the block's start, never handed to the kernel (`motion/prep.rs`).
const THC: u8 = 0x40;
const LEVEL: u8 = 0x10;
const INDEX: u8 = 0x0f;

impl OutputEvent {
    /// No output change.
    pub const NONE: OutputEvent = OutputEvent(0);

    /// Output `n` (0..16) switched to `on`; `None` for an output number beyond 15.
    pub const fn new(n: u8, on: bool) -> Option<OutputEvent> {
        if n > INDEX {
            return None;
        }
        Some(OutputEvent(PRESENT | if on { LEVEL } else { 0 } | n))
    }

    /// Torch height control switched `on` or off with the block it rides on.
    pub const fn thc(on: bool) -> OutputEvent {
        OutputEvent(PRESENT | THC | if on { LEVEL } else { 0 })
    }

    /// The torch height control switch of [`Self::thc`]: `Some(on)`, else `None`.
    #[inline(always)]
    pub(crate) const fn thc_switch(self) -> Option<bool> {
        if self.0 & (PRESENT | THC) == PRESENT | THC {
            Some(self.0 & LEVEL != 0)
        } else {
            None
        }
    }

    /// True unless this is [`OutputEvent::NONE`].
    #[inline(always)]
    pub const fn is_some(self) -> bool {
        self.0 & PRESENT != 0
    }

    /// The output number (meaningful when [`Self::is_some`]).
    #[inline(always)]
    pub const fn index(self) -> usize {
        (self.0 & INDEX) as usize
    }

    /// The level the output is switched to (meaningful when [`Self::is_some`]).
    #[inline(always)]
    pub const fn level(self) -> bool {
        self.0 & LEVEL != 0
    }

    /// `level × 16 + output` (0..32): an index into a 32-entry table of pin writes, so a step
    /// interrupt can switch the pin with one lookup (meaningful when [`Self::is_some`]).
    #[inline(always)]
    pub const fn code(self) -> usize {
        (self.0 & (LEVEL | INDEX)) as usize
    }

    /// The user output word (bit n = output n) after this event.
    #[inline(always)]
    pub const fn apply(self, word: u16) -> u16 {
        if !self.is_some() {
            word
        } else if self.level() {
            word | 1 << self.index()
        } else {
            word & !(1 << self.index())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_switch_one_output_of_the_word() {
        let on = OutputEvent::new(15, true).unwrap();
        let off = OutputEvent::new(1, false).unwrap();
        assert!(on.is_some() && off.is_some() && !OutputEvent::NONE.is_some());
        assert_eq!((on.index(), on.level()), (15, true));
        assert_eq!((off.index(), off.level()), (1, false));
        assert_eq!(on.apply(0b10), 0x8002);
        assert_eq!(off.apply(0x8002), 0x8000);
        assert_eq!(OutputEvent::NONE.apply(0x1234), 0x1234);
        assert_eq!(OutputEvent::new(16, true), None);
        assert_eq!((on.code(), off.code()), (31, 1));
    }
}
