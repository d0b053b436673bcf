//! The streamed program as the board's interpreter sees it: the lines the host sent, held once in
//! a [`LineRing`] (the interpreter reads each where it lies), plus the jump requests subprograms
//! need (the board owns the call stack, the host serves
//! "program O from line n" on request: `ProgramRequest` in docs/protocol.md).
//!
//! Every jump gets a new request id; lines that arrive for an older id (already in flight when the
//! jump happened) are dropped, so a jump can never mix lines of two places. Jumps to a subprogram
//! return a *token* instead of a file line number (the board does not know where `O<n>` stands in
//! the host's file); jumping to that token later (an `L` repeat) asks for the same subprogram again.

use super::line_ring::LineRing;
use crate::gcode::source::{ProgramSource, SourceError};

/// Longest line the board accepts (bytes), equal to the protocol's line limit.
pub const LINE_CAPACITY: usize = super::line_ring::LINE_MAX;

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

/// What [`StreamSource::push_run`] did with a run of lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pushed {
    /// Stored.
    Stored,
    /// Dropped: for an older place, or after the place's end.
    Stale,
    /// Not stored: the ring has no room for it.
    Full,
}

/// Streamed lines in a ring of `B` bytes ([`LineRing`]) with jump bookkeeping.
pub struct StreamSource<const B: usize> {
    lines: LineRing<B>,
    /// The interpreter holds the front line (handed out by `next_line`, dropped at the next call).
    front_taken: bool,
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

impl<const B: usize> Default for StreamSource<B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const B: usize> StreamSource<B> {
    pub const fn new() -> Self {
        StreamSource {
            lines: LineRing::new(),
            front_taken: false,
            id: 0,
            ended: false,
            pending: None,
            origin: JumpTarget::Line(1),
            last_out: None,
            jumps_served: true,
        }
    }

    /// Whether the host serves jumps (subprograms, O-word loops); set for each job.
    pub(crate) fn serve_jumps(&mut self, served: bool) {
        self.jumps_served = served;
    }

    /// Forgets everything (new job).
    pub fn reset(&mut self) {
        self.lines.clear();
        self.front_taken = false;
        self.id = 0;
        self.ended = false;
        self.pending = None;
        self.origin = JumpTarget::Line(1);
        self.last_out = None;
        self.jumps_served = true;
    }

    /// Free bytes of line records (`line_ring.rs`): the credit the host gets.
    pub fn free(&self) -> usize {
        self.lines.free()
    }

    /// Lines buffered and not yet handed to the interpreter.
    pub fn len(&self) -> usize {
        self.lines.lines() - usize::from(self.front_taken)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
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
        self.lines.push_line(line_no, text.as_bytes())
    }

    /// Accepts `run`, a valid run of `lines` line records ([`super::line_ring::check_run`])
    /// for place `id`, copied in as it is.
    pub fn push_run(&mut self, id: u16, run: &[u8], lines: usize) -> Pushed {
        if id != self.id || self.ended {
            Pushed::Stale
        } else if self.lines.push_run(run, lines) {
            Pushed::Stored
        } else {
            Pushed::Full
        }
    }

    /// The host has no more lines for place `id` (end of file or of the main job).
    pub fn end(&mut self, id: u16) {
        if id == self.id {
            self.ended = true;
        }
    }

    /// The next jump request to send to the host.
    pub(crate) fn take_request(&mut self) -> Option<JumpRequest> {
        self.pending.take()
    }

    /// True when the place has ended and every line was consumed.
    pub fn is_exhausted(&self) -> bool {
        self.ended && self.is_empty()
    }

    /// Drops the line the interpreter was given last (it is done with it).
    fn release_front(&mut self) {
        if core::mem::take(&mut self.front_taken) {
            self.lines.pop();
        }
    }

    fn jump(&mut self, target: JumpTarget) -> Result<(), SourceError> {
        if !self.jumps_served {
            return Err(SourceError::NotServed);
        }
        self.id = self.id.wrapping_add(1).max(1);
        self.lines.clear();
        self.front_taken = false;
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

impl<const B: usize> ProgramSource for StreamSource<B> {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        // The line is read where it lies in the ring (no copy); it stays there until the next
        // call, when the interpreter is done with it.
        self.release_front();
        let (n, text) = self.lines.front()?;
        self.front_taken = true;
        self.last_out = Some(n);
        Some((n, text))
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
        let mut s: StreamSource<{ 4 * crate::board::line_ring::RECORD_MAX }> = StreamSource::new();
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
        let mut s: StreamSource<{ 4 * crate::board::line_ring::RECORD_MAX }> = StreamSource::new();
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
        extern crate std;
        // A ring of 262 bytes: "M30" (6 + 3) and a 247-character line fill it.
        let mut s: StreamSource<{ 2 * crate::board::line_ring::RECORD_MAX }> = StreamSource::new();
        assert!(!s.is_exhausted());
        assert_eq!(s.next_line(), None);
        assert!(
            !s.is_exhausted(),
            "an empty buffer is starved, not finished"
        );
        assert!(s.push(0, 1, "M30"));
        let long = std::format!("G0 X1{}", "0".repeat(242));
        assert!(s.push(0, 2, &long));
        assert_eq!(s.free(), 0);
        assert!(!s.push(0, 3, "G0"), "full");
        s.end(0);
        assert!(!s.is_exhausted());
        s.next_line();
        s.next_line();
        assert!(s.is_exhausted());
    }
}
