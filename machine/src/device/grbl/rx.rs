//! Line assembly with grbl's receive accounting. grbl's serial RX buffer holds the bytes of lines
//! not yet taken by its protocol loop; a line it takes leaves the buffer (into grbl's line buffer
//! and planner), and its `ok` follows once it is planned. So here: the bytes of lines not yet read
//! out ("unread") count against [`RX_SIZE`] — advertised in `$I`'s `[OPT:…]`, reported in `Bf:`
//! and the room the link reads the port by (`device/link.rs` `BoardLink::rx_room`) — and a line
//! read out for the board ([`Rx::next_line`]) leaves that count at once, though its bytes stay
//! stored until it is answered ([`Rx::answered`]), to be read again after the board dropped it
//! unread ([`Rx::rewind`]). A character-counting sender keeps at most 128 unanswered bytes, so
//! the unread ones never exceed the count; the link reads no more than [`Rx::free`] (flow
//! control: the bytes wait in the port), so nothing is dropped. A line that cannot fit (longer
//! than the buffer, or bytes pushed past the room by a caller that ignored it) is cut: its bytes
//! are dropped up to its end and it is answered `error:11` in its turn (a marker line takes its
//! place), never merged with the next.
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

/// Bytes of received lines not yet read out the board accepts (grbl's serial RX buffer).
pub const RX_SIZE: usize = 128;

/// Bytes stored: the unread lines and those read out and not yet answered. The front end keeps
/// at most `FLIGHTS` lines in flight (`grbl/mod.rs`), each at most [`RX_SIZE`] bytes raw; a
/// counting sender's unanswered bytes (128 and a few `$G`) stay far below this.
const STORE: usize = 1024;

/// Stands for a line that was cut (its text dropped): answered `error:11`.
const CUT: u8 = 0x00;

/// A line as [`Rx::peek_line`] found it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Peeked {
    /// Length without blanks, comments and end (bytes past the output's length are not copied).
    pub len: usize,
    /// Stored length, its end included (what [`Rx::consume`] and [`Rx::answered`] take).
    pub raw: usize,
    /// The line was cut (overflow): its text is gone, it answers `error:11`.
    pub cut: bool,
}

/// The received bytes, oldest unanswered first.
pub(crate) struct Rx {
    buf: [u8; STORE],
    /// Index of the oldest unanswered byte.
    head: usize,
    /// Bytes stored from `head` on.
    len: usize,
    /// Bytes from `head` already read out as lines (unanswered, in flight).
    read: usize,
    /// Complete lines among the unread bytes.
    complete: usize,
    /// Bytes of the line being received (no end yet).
    partial: usize,
    /// The last byte was a `\r` (a following `\n` belongs to the same line end).
    after_cr: bool,
    /// The current line was cut: its bytes are skipped up to its end.
    cutting: bool,
}

impl Default for Rx {
    fn default() -> Self {
        Self::new()
    }
}

impl Rx {
    pub const fn new() -> Self {
        Rx {
            buf: [0; STORE],
            head: 0,
            len: 0,
            read: 0,
            complete: 0,
            partial: 0,
            after_cr: false,
            cutting: false,
        }
    }

    /// Forgets everything (soft reset, new connection).
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Bytes not yet read out.
    fn unread(&self) -> usize {
        self.len - self.read
    }

    /// Free bytes (grbl's `Bf:` second field), and the bytes the link may read from the port
    /// now without a cut: the advertised buffer's room, and the store's (a few bytes kept for
    /// a line end and a cut line's marker).
    pub fn free(&self) -> usize {
        RX_SIZE
            .saturating_sub(self.unread())
            .min((STORE - 4).saturating_sub(self.len))
    }

    fn store(&mut self, b: u8) {
        if self.len < STORE {
            self.buf[(self.head + self.len) % STORE] = b;
            self.len += 1;
        }
    }

    /// One received byte of line text (realtime bytes are taken out before).
    pub fn push(&mut self, b: u8) {
        let end = b == b'\n' || b == b'\r';
        if b == b'\n' && self.after_cr {
            self.after_cr = false;
            return;
        }
        self.after_cr = b == b'\r';
        if self.cutting {
            self.cutting = !end;
            return;
        }
        if end {
            // (Ends past the store's room come only from a caller that pushed far more than
            // [`Rx::free`]: the link never does. They are not stored.)
            if self.len < STORE - 2 {
                self.store(b'\n');
                self.partial = 0;
                self.complete += 1;
            }
            return;
        }
        if self.free() == 0 {
            // No room: the line being received is cut (its bytes so far dropped), a marker line
            // answers it `error:11` in its turn, and the rest of it is skipped.
            self.len -= self.partial;
            self.partial = 0;
            self.store(CUT);
            self.store(b'\n');
            self.complete += 1;
            self.cutting = true;
            return;
        }
        // A NUL is no text (and stands for a cut line here): kept as a character the parser
        // refuses.
        self.store(if b == CUT { 0x7F } else { b });
        self.partial += 1;
    }

    /// The next complete unread line without its blanks, comments and end, copied into `out`.
    /// Not consumed: [`Rx::consume`] does that.
    pub(crate) fn peek_line(&self, out: &mut [u8]) -> Option<Peeked> {
        if self.complete == 0 {
            return None;
        }
        // As grbl, blanks and comments (`(…)`, `;` to the end) are dropped as the line is read,
        // so a line's length limit counts only what the interpreter needs.
        let mut comment = Comment::None;
        let mut n = 0;
        let mut i = 0;
        let mut cut = false;
        loop {
            let b = self.buf[(self.head + self.read + i) % STORE];
            i += 1;
            if b == b'\n' {
                return Some(Peeked {
                    len: n,
                    raw: i,
                    cut,
                });
            }
            if b == CUT && i == 1 {
                cut = true;
                continue;
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

    /// The line [`Rx::peek_line`] returned (`raw` bytes) is read out: it leaves the free count
    /// and stays stored, in flight, until answered.
    pub fn consume(&mut self, raw: usize) {
        self.read += raw;
        self.complete -= 1;
    }

    /// The oldest in-flight line (`raw` bytes) was answered: its bytes are gone.
    pub fn answered(&mut self, raw: usize) {
        let raw = raw.min(self.read);
        self.head = (self.head + raw) % STORE;
        self.len -= raw;
        self.read -= raw;
    }

    /// Every in-flight line is unread again (the board dropped them unread).
    pub fn rewind(&mut self) {
        let mut lines = 0;
        for i in 0..self.read {
            if self.buf[(self.head + i) % STORE] == b'\n' {
                lines += 1;
            }
        }
        self.complete += lines;
        self.read = 0;
    }

    /// A complete line waits to be read.
    pub(crate) fn has_line(&self) -> bool {
        self.complete > 0
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

    fn next(rx: &mut Rx) -> Option<(Vec<u8>, Peeked)> {
        let mut buf = [0u8; 160];
        let p = rx.peek_line(&mut buf)?;
        rx.consume(p.raw);
        Some((buf[..p.len.min(160)].to_vec(), p))
    }

    extern crate std;
    use std::vec::Vec;

    #[test]
    fn read_lines_leave_the_count_and_stay_until_answered() {
        let mut rx = Rx::new();
        feed(&mut rx, b"G0 X1\r\nG1");
        let (text, p) = next(&mut rx).unwrap();
        assert_eq!((&text[..], p.raw, p.cut), (&b"G0X1"[..], 6, false));
        // Read out: only the unfinished `G1` counts.
        assert_eq!(rx.free(), RX_SIZE - 2);
        assert!(rx.peek_line(&mut [0; 8]).is_none(), "G1 has no end yet");
        feed(&mut rx, b" Y2\n");
        rx.rewind();
        assert_eq!(rx.free(), RX_SIZE - 12, "unread again after a rewind");
        assert_eq!(next(&mut rx).unwrap().0, b"G0X1");
        rx.answered(6);
        assert_eq!(next(&mut rx).unwrap().0, b"G1Y2");
        rx.answered(6);
        assert_eq!(rx.free(), RX_SIZE);
    }

    #[test]
    fn a_sender_counting_128_bytes_plus_extras_never_overflows_while_lines_are_read() {
        // 144 bytes of lines with 8 `$G` beside them, the board reading each line as it ends.
        let mut rx = Rx::new();
        let mut read = 0;
        for i in 0..12 {
            feed(&mut rx, format_line(i).as_bytes());
            feed(&mut rx, b"$G\n");
            while let Some((_, p)) = next(&mut rx) {
                assert!(!p.cut);
                read += 1;
            }
        }
        assert_eq!(read, 24);
    }

    fn format_line(i: usize) -> std::string::String {
        std::format!("G1 X{} F9000\n", i % 10)
    }

    #[test]
    fn a_line_that_does_not_fit_is_cut_and_answered_in_its_turn() {
        let mut rx = Rx::new();
        // 120 bytes of complete lines, then a line that runs past the room.
        for _ in 0..40 {
            feed(&mut rx, b"G0\n");
        }
        feed(&mut rx, b"G1 X123456789 Y1\nG0 X2\n");
        let mut lines = Vec::new();
        while let Some((text, p)) = next(&mut rx) {
            lines.push((text, p.cut));
        }
        assert_eq!(lines.len(), 42);
        assert!(lines[..40].iter().all(|(t, c)| t == b"G0" && !c));
        assert!(lines[40].1, "the line that overran the room is cut");
        assert_eq!(
            lines[41],
            (b"G0X2".to_vec(), false),
            "never merged: {lines:?}"
        );
        // An endless line is cut once the room is gone, and skipped to its end.
        let mut rx = Rx::new();
        for _ in 0..RX_SIZE + 10 {
            rx.push(b'X');
        }
        assert!(rx.has_line(), "the cut line's marker waits");
        rx.push(b'\n');
        feed(&mut rx, b"G0\n");
        let (_, p) = next(&mut rx).unwrap();
        assert!(p.cut);
        rx.answered(p.raw);
        assert_eq!(next(&mut rx).unwrap().0, b"G0");
    }
}
