//! Line assembly with honest RX buffer accounting. Every byte of a line stays in this ring from
//! its arrival until the line is answered (`ok` / `error:N`), so the bytes a character-counting
//! sender has in flight are exactly the ring's content, and [`RX_SIZE`] — advertised in `$I`'s
//! `[OPT:…]` and reported in `Bf:` — is never exceeded: a byte that does not fit is dropped, as
//! grbl drops it. A line is read out once for the board ([`Rx::next_line`]), kept until answered
//! ([`Rx::answered`]), and read again after the board dropped it unread ([`Rx::rewind`]).
//!
//! Line ends: `\n` or `\r`; the `\n` of a `\r\n` pair is not stored (the sender counted it, so
//! its own count stays above ours, on the safe side).

/// Where [`Rx::peek_line`] stands in a line's comments.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Comment {
    None,
    /// Inside `( … )`.
    Paren,
    /// After `;`: the rest of the line.
    ToEnd,
}

/// Bytes of received, unanswered lines the board accepts (grbl's serial RX buffer).
pub const RX_SIZE: usize = 128;

/// The received bytes, oldest unanswered first.
pub struct Rx {
    buf: [u8; RX_SIZE],
    /// Index of the oldest unanswered byte.
    head: usize,
    /// Bytes stored from `head` on.
    len: usize,
    /// Bytes from `head` already read out as lines (unanswered, in flight).
    read: usize,
    /// Complete lines among the unread bytes.
    complete: usize,
    /// The last byte was a `\r` (a following `\n` belongs to the same line end).
    after_cr: bool,
    /// The current line outgrew the ring: it is skipped up to its end and answered error 11.
    overflowed: bool,
    /// Lines that overflowed and ended, waiting for their error 11.
    overflow_lines: u8,
}

impl Default for Rx {
    fn default() -> Self {
        Self::new()
    }
}

impl Rx {
    pub const fn new() -> Self {
        Rx {
            buf: [0; RX_SIZE],
            head: 0,
            len: 0,
            read: 0,
            complete: 0,
            after_cr: false,
            overflowed: false,
            overflow_lines: 0,
        }
    }

    /// Forgets everything (soft reset, new connection).
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Free bytes (grbl's `Bf:` second field).
    pub fn free(&self) -> usize {
        RX_SIZE - self.len
    }

    /// One received byte of line text (realtime bytes are taken out before).
    pub fn push(&mut self, b: u8) {
        let end = b == b'\n' || b == b'\r';
        if b == b'\n' && self.after_cr {
            self.after_cr = false;
            return;
        }
        self.after_cr = b == b'\r';
        if self.overflowed {
            if end {
                self.overflowed = false;
                self.overflow_lines = self.overflow_lines.saturating_add(1);
            }
            return;
        }
        if self.len == RX_SIZE {
            if self.complete == 0 && self.read == 0 {
                // One line fills the whole ring: it can never be answered in time. Skip it.
                self.len = 0;
                self.overflowed = !end;
                if end {
                    self.overflow_lines = self.overflow_lines.saturating_add(1);
                }
            }
            // Otherwise the sender overran the advertised size: the byte is lost, as in grbl.
            return;
        }
        self.buf[(self.head + self.len) % RX_SIZE] = if end { b'\n' } else { b };
        self.len += 1;
        if end {
            self.complete += 1;
        }
    }

    /// A line that outgrew the ring ended: answer it with error 11 (once).
    pub fn take_overflow(&mut self) -> bool {
        if self.overflow_lines > 0 && self.read == 0 && self.complete == 0 {
            self.overflow_lines -= 1;
            return true;
        }
        false
    }

    /// The next complete unread line without its blanks, comments and end, copied into `out`:
    /// its length (bytes past `out`'s length are cut: the caller sees a length longer than what
    /// it got) and its stored length including the end. Not consumed: [`Rx::consume`] does that.
    pub fn peek_line(&self, out: &mut [u8]) -> Option<(usize, usize)> {
        if self.complete == 0 {
            return None;
        }
        // As grbl, blanks and comments (`(…)`, `;` to the end) are dropped as the line is read,
        // so a line's length limit counts only what the interpreter needs.
        let mut comment = Comment::None;
        let mut n = 0;
        let mut i = 0;
        loop {
            let b = self.buf[(self.head + self.read + i) % RX_SIZE];
            i += 1;
            if b == b'\n' {
                return Some((n, i));
            }
            comment = match (comment, b) {
                (Comment::None, b'(') => Comment::Paren,
                (Comment::None, b';') => Comment::ToEnd,
                (Comment::Paren, b')') => Comment::None,
                (Comment::None, b' ' | b'\t') => Comment::None,
                (Comment::None, _) => {
                    if let Some(o) = out.get_mut(n) {
                        *o = b;
                    }
                    n += 1;
                    Comment::None
                }
                (c, _) => c,
            };
        }
    }

    /// The line [`Rx::peek_line`] returned (`raw` bytes) is read out: it stays stored, in
    /// flight, until answered.
    pub fn consume(&mut self, raw: usize) {
        self.read += raw;
        self.complete -= 1;
    }

    /// The oldest in-flight line (`raw` bytes) was answered: its bytes are free.
    pub fn answered(&mut self, raw: usize) {
        let raw = raw.min(self.read);
        self.head = (self.head + raw) % RX_SIZE;
        self.len -= raw;
        self.read -= raw;
    }

    /// Every in-flight line is unread again (the board dropped them unread).
    pub fn rewind(&mut self) {
        let mut lines = 0;
        for i in 0..self.read {
            if self.buf[(self.head + i) % RX_SIZE] == b'\n' {
                lines += 1;
            }
        }
        self.complete += lines;
        self.read = 0;
    }

    /// A complete line waits to be read.
    pub fn has_line(&self) -> bool {
        self.complete > 0 || self.overflow_lines > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(rx: &mut Rx, s: &[u8]) {
        for &b in s {
            rx.push(b);
        }
    }

    #[test]
    fn lines_stay_counted_until_answered() {
        let mut rx = Rx::new();
        feed(&mut rx, b"G0 X1\r\nG1");
        let mut buf = [0u8; 16];
        let (n, raw) = rx.peek_line(&mut buf).unwrap();
        assert_eq!((&buf[..n], raw), (&b"G0X1"[..], 6));
        rx.consume(raw);
        assert_eq!(rx.free(), RX_SIZE - 8);
        assert!(rx.peek_line(&mut buf).is_none(), "G1 has no end yet");
        rx.answered(raw);
        assert_eq!(rx.free(), RX_SIZE - 2);
        feed(&mut rx, b" Y2\n");
        let (n, raw) = rx.peek_line(&mut buf).unwrap();
        assert_eq!((&buf[..n], raw), (&b"G1Y2"[..], 6));
        rx.consume(raw);
        rx.rewind();
        assert_eq!(
            rx.peek_line(&mut buf),
            Some((4, 6)),
            "read again after a rewind"
        );
    }

    #[test]
    fn a_full_ring_drops_bytes_and_an_endless_line_is_skipped() {
        let mut rx = Rx::new();
        for _ in 0..RX_SIZE / 4 {
            feed(&mut rx, b"G0\n\n");
        }
        assert_eq!(rx.free(), 0);
        feed(&mut rx, b"X\n");
        assert_eq!(rx.free(), 0);
        let mut rx = Rx::new();
        for _ in 0..RX_SIZE + 10 {
            rx.push(b'X');
        }
        assert!(!rx.has_line());
        rx.push(b'\n');
        assert!(rx.take_overflow());
        assert_eq!(rx.free(), RX_SIZE);
    }
}
