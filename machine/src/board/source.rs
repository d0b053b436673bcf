//! The streamed program as the board's interpreter sees it: a small buffer of lines the host sent,
//! plus the jump requests subprograms need (the board owns the call stack, the host serves
//! "program O from line n" on request: `ProgramRequest` in docs/protocol.md).
//!
//! Every jump gets a new request id; lines that arrive for an older id (already in flight when the
//! jump happened) are dropped, so a jump can never mix lines of two places. Jumps to a subprogram
//! return a *token* instead of a file line number (the board does not know where `O<n>` stands in
//! the host's file); jumping to that token later (an `L` repeat) asks for the same subprogram again.

use crate::gcode::source::{ProgramSource, SourceError};
use heapless::{Deque, String};

/// Longest line the board accepts (bytes), equal to the protocol's line limit.
pub const LINE_CAPACITY: usize = 104;

/// Tokens at or above this value stand for "the start of subprogram `u32::MAX - token`".
const PROGRAM_TOKEN_BASE: u32 = 0xF000_0000;

/// Where a jump asks the host to continue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JumpTarget {
    /// The `O<program>` line of a subprogram.
    Program(u32),
    /// Block with N word `n` (gixa subroutines).
    Sequence(u32),
    /// A line of the file (1-based).
    Line(u32),
}

/// A jump the host must serve: send lines from `target` on, tagged with `id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JumpRequest {
    pub id: u16,
    pub target: JumpTarget,
}

/// Buffer of `N` streamed lines with jump bookkeeping.
pub struct StreamSource<const N: usize> {
    lines: Deque<(u32, String<LINE_CAPACITY>), N>,
    /// The line handed to the interpreter (its first bytes, as long as the line).
    current: [u8; LINE_CAPACITY],
    /// Id of the place lines are accepted for: 0 = the linear main stream.
    id: u16,
    /// The host said no line follows for the current id.
    ended: bool,
    /// A jump not yet sent to the host.
    pending: Option<JumpRequest>,
    /// Where the current place started (the last jump's target), and the last line handed to
    /// the interpreter from it: enough to ask a reconnected host for exactly what is missing.
    origin: JumpTarget,
    last_out: Option<u32>,
    /// The host serves jumps (Gantry's program server); a line sender cannot, and a jump is
    /// then [`SourceError::NotServed`].
    jumps_served: bool,
}

impl<const N: usize> Default for StreamSource<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> StreamSource<N> {
    pub const fn new() -> Self {
        StreamSource {
            lines: Deque::new(),
            current: [0; LINE_CAPACITY],
            id: 0,
            ended: false,
            pending: None,
            origin: JumpTarget::Line(1),
            last_out: None,
            jumps_served: true,
        }
    }

    /// Whether the host serves jumps (subprograms, O-word loops); set for each job.
    pub fn serve_jumps(&mut self, served: bool) {
        self.jumps_served = served;
    }

    /// Forgets everything (new job).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Free line slots; the board takes lines from the link only while this is non-zero.
    pub fn free(&self) -> usize {
        N - self.lines.len()
    }

    /// Lines buffered.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// Id of the current place (0 = main stream).
    pub fn current_id(&self) -> u16 {
        self.id
    }

    /// Accepts a line for place `id`; returns false (line dropped) when it belongs to an older
    /// place, the buffer is full or the text is too long.
    pub fn push(&mut self, id: u16, line_no: u32, text: &str) -> bool {
        if id != self.id || self.ended {
            return false;
        }
        let Ok(text) = String::try_from(text) else {
            return false;
        };
        self.lines.push_back((line_no, text)).is_ok()
    }

    /// The host has no more lines for place `id` (end of file or of the main job).
    pub fn end(&mut self, id: u16) {
        if id == self.id {
            self.ended = true;
        }
    }

    /// The next jump request to send to the host.
    pub fn take_request(&mut self) -> Option<JumpRequest> {
        self.pending.take()
    }

    /// True when the place has ended and every line was consumed.
    pub fn is_exhausted(&self) -> bool {
        self.ended && self.lines.is_empty()
    }

    /// Line number of the next line to be interpreted, if buffered.
    pub fn next_line_no(&self) -> Option<u32> {
        self.lines.front().map(|(n, _)| *n)
    }

    fn jump(&mut self, target: JumpTarget) -> Result<(), SourceError> {
        if !self.jumps_served {
            return Err(SourceError::NotServed);
        }
        self.id = self.id.wrapping_add(1).max(1);
        self.lines.clear();
        self.ended = false;
        self.origin = target;
        self.last_out = None;
        self.pending = Some(JumpRequest {
            id: self.id,
            target,
        });
        Ok(())
    }

    /// A (re)connected host knows nothing of what was in flight: drop the buffered lines and ask
    /// for everything after the last line the interpreter took (or the place's start), under a new
    /// id, so nothing is lost and nothing runs twice.
    pub fn resync(&mut self) {
        let target = match self.last_out {
            Some(n) => JumpTarget::Line(n + 1),
            None => self.origin,
        };
        // (A line sender's job is never resynchronised: `Board::resync_stream` is the program
        // server's.)
        let _ = self.jump(target);
    }
}

impl<const N: usize> ProgramSource for StreamSource<N> {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        // Copied from the front in place, then popped: moving the popped `String` into
        // `current` compiled to a `memmove` (the firmware's only other user of it). One
        // `memcpy`: `String::push_str` copied byte by byte, ~170 Cortex-M4 instructions a short
        // line (target-tests/src/bin/bench_motion.rs).
        let (n, text) = self.lines.front()?;
        let n = *n;
        // Same capacity: every byte fits. No slice index that could fail (its panic would link
        // the formatting code).
        let src = text.as_bytes();
        for (to, &from) in self.current.iter_mut().zip(src) {
            *to = from;
        }
        let len = src.len();
        self.lines.pop_front();
        self.last_out = Some(n);
        Some((n, self.current.get(..len).unwrap_or(&[])))
    }

    fn is_exhausted(&self) -> bool {
        StreamSource::is_exhausted(self)
    }

    fn jump_to_program(&mut self, program: u32) -> Result<u32, SourceError> {
        if program >= u32::MAX - PROGRAM_TOKEN_BASE {
            return Err(SourceError::UnknownProgram);
        }
        self.jump(JumpTarget::Program(program))?;
        Ok(u32::MAX - program)
    }

    fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
        self.jump(JumpTarget::Sequence(n))?;
        // The host answers from the N block's line; a repeat asks for the same sequence again.
        Ok(u32::MAX - n.min(u32::MAX - PROGRAM_TOKEN_BASE - 1))
    }

    fn jump_to_line(&mut self, line: u32) -> Result<(), SourceError> {
        let target = if line >= PROGRAM_TOKEN_BASE {
            JumpTarget::Program(u32::MAX - line)
        } else {
            JumpTarget::Line(line)
        };
        self.jump(target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_come_out_in_order_and_stale_ones_are_dropped() {
        let mut s: StreamSource<4> = StreamSource::new();
        assert!(s.push(0, 1, "G0 X1"));
        assert!(s.push(0, 2, "M98 P7"));
        assert_eq!(s.next_line(), Some((1, &b"G0 X1"[..])));
        let token = s.jump_to_program(7).unwrap();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 1,
                target: JumpTarget::Program(7)
            })
        );
        // Line 2 was cleared; a main-stream line still in flight is refused.
        assert!(!s.push(0, 3, "G0 X2"));
        assert!(s.push(1, 20, "O7"));
        assert_eq!(s.next_line(), Some((20, &b"O7"[..])));
        // An L repeat jumps to the token: the same subprogram is asked for again, with a new id.
        s.jump_to_line(token).unwrap();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 2,
                target: JumpTarget::Program(7)
            })
        );
        assert!(!s.push(1, 21, "G1 X1"));
        s.jump_to_line(3).unwrap();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 3,
                target: JumpTarget::Line(3)
            })
        );
    }

    #[test]
    fn resync_asks_for_the_line_after_the_last_one_interpreted() {
        let mut s: StreamSource<4> = StreamSource::new();
        s.resync();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 1,
                target: JumpTarget::Line(1)
            })
        );
        assert!(s.push(1, 1, "G0 X1"));
        assert!(s.push(1, 2, "G0 X2"));
        s.next_line();
        s.resync();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 2,
                target: JumpTarget::Line(2)
            })
        );
        assert_eq!(s.len(), 0);
        s.jump_to_program(9).unwrap();
        s.take_request();
        s.resync();
        assert_eq!(
            s.take_request(),
            Some(JumpRequest {
                id: 4,
                target: JumpTarget::Program(9)
            })
        );
    }

    #[test]
    fn exhausted_only_after_the_end_and_the_last_line() {
        let mut s: StreamSource<2> = StreamSource::new();
        assert!(!s.is_exhausted());
        assert_eq!(s.next_line(), None);
        assert!(
            !s.is_exhausted(),
            "an empty buffer is starved, not finished"
        );
        assert!(s.push(0, 1, "M30"));
        assert!(s.push(0, 2, "G0"));
        assert!(!s.push(0, 3, "G0"), "full");
        s.end(0);
        assert!(!s.is_exhausted());
        s.next_line();
        s.next_line();
        assert!(s.is_exhausted());
    }
}
