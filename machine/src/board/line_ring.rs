//! The board's store of streamed program text: a ring of variable-length line records in the
//! link's own format, defined once in `shared-proto/src/lines.rs` (line number `u32` LE, length
//! `u16` LE, text), so a batch from a frame is copied in as it came and the interpreter reads each
//! line where it lies.
//!
//! Of the buffer's `B` bytes, the first `B - RECORD_MAX` are the ring ([`LineRing::capacity`]). A
//! record always starts inside the ring and lies in one piece: one that starts near the ring's end
//! runs on into the last [`RECORD_MAX`] bytes, and the next one starts at the front again, past
//! the bytes that run-on counted for. So the used bytes are exactly the records' bytes, and the
//! free room ([`LineRing::free`]) is exact: it is the credit the board grants the host.

pub use gantry_proto::lines::{split_record, write_record, LINE_MAX, RECORD_HEADER, RECORD_MAX};

/// Checks that `run` is a whole number of valid records; their count, and the last one's line
/// number, or `None` when it is not.
pub fn check_run(run: &[u8]) -> Option<(usize, Option<u32>)> {
    gantry_proto::lines::check_records(run).map(|r| (r.lines, r.last_line))
}

/// A buffer of `B` bytes holding line records.
pub struct LineRing<const B: usize> {
    buf: [u8; B],
    /// Start of the oldest record (inside the ring).
    head: usize,
    /// Bytes of records held.
    used: usize,
    /// Records held.
    lines: usize,
}

impl<const B: usize> Default for LineRing<B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const B: usize> LineRing<B> {
    /// Bytes of records the ring holds.
    pub(crate) const CAPACITY: usize = B - RECORD_MAX;
    const FITS: () = assert!(
        B >= 2 * RECORD_MAX && Self::CAPACITY <= u16::MAX as usize,
        "a ring holds the longest record and its size fits the link's credit"
    );

    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let _ = Self::FITS;
        LineRing {
            buf: [0; B],
            head: 0,
            used: 0,
            lines: 0,
        }
    }

    /// Bytes of records the ring holds when empty.
    pub fn capacity(&self) -> usize {
        Self::CAPACITY
    }

    /// Free bytes: any run of records this long fits.
    pub fn free(&self) -> usize {
        Self::CAPACITY - self.used
    }

    /// Records held.
    pub fn lines(&self) -> usize {
        self.lines
    }

    pub fn is_empty(&self) -> bool {
        self.lines == 0
    }

    /// Forgets every record.
    pub fn clear(&mut self) {
        self.head = 0;
        self.used = 0;
        self.lines = 0;
    }

    /// Where the next record goes (inside the ring).
    fn tail(&self) -> usize {
        (self.head + self.used) % Self::CAPACITY
    }

    /// Appends `run`, a valid run of `lines` records ([`check_run`]); false
    /// (nothing stored) when it does not fit.
    pub fn push_run(&mut self, run: &[u8], lines: usize) -> bool {
        if run.len() > self.free() {
            return false;
        }
        let tail = self.tail();
        if tail + run.len() <= Self::CAPACITY {
            // The usual case: one block copy.
            let Some(to) = self.buf.get_mut(tail..tail + run.len()) else {
                return false;
            };
            to.copy_from_slice(run);
        } else {
            // Record by record, each in one piece from where it starts (the last one to start
            // before the ring's end runs on).
            let mut at = tail;
            let mut rest = run;
            while let Some((_, text, after)) = split_record(rest) {
                let len = RECORD_HEADER + text.len();
                if let (Some(to), Some(from)) = (self.buf.get_mut(at..at + len), rest.get(..len)) {
                    to.copy_from_slice(from);
                }
                at = (at + len) % Self::CAPACITY;
                rest = after;
            }
        }
        self.used += run.len();
        self.lines += lines;
        true
    }

    /// Appends one line; false when it does not fit (or is longer than a record allows).
    pub fn push_line(&mut self, line_no: u32, text: &[u8]) -> bool {
        let len = RECORD_HEADER + text.len();
        if text.len() > LINE_MAX || len > self.free() {
            return false;
        }
        let at = self.tail();
        let Some(to) = self.buf.get_mut(at..at + len) else {
            return false;
        };
        write_record(to, line_no, text);
        self.used += len;
        self.lines += 1;
        true
    }

    /// The oldest record: its line number and text.
    pub fn front(&self) -> Option<(u32, &[u8])> {
        if self.lines == 0 {
            return None;
        }
        let (n, text, _) = split_record(self.buf.get(self.head..)?)?;
        Some((n, text))
    }

    /// Drops the oldest record.
    pub fn pop(&mut self) {
        let Some((_, text)) = self.front() else {
            return;
        };
        let len = RECORD_HEADER + text.len();
        self.head = (self.head + len) % Self::CAPACITY;
        self.used -= len;
        self.lines -= 1;
        if self.lines == 0 {
            // Empty: start over at the front (the next batch is one block copy).
            self.clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    fn push_record(batch: &mut Vec<u8>, line_no: u32, text: &[u8]) {
        batch.extend_from_slice(&line_no.to_le_bytes());
        batch.extend_from_slice(&(text.len() as u16).to_le_bytes());
        batch.extend_from_slice(text);
    }

    /// The ring against a queue of lines, over random batches and pops, with records that run on
    /// past the ring's end.
    #[test]
    fn matches_a_queue_of_lines() {
        use std::collections::VecDeque;
        let mut ring: LineRing<{ 600 + RECORD_MAX }> = LineRing::new();
        let mut model: VecDeque<(u32, Vec<u8>)> = VecDeque::new();
        let mut seed = 99u64;
        let mut rnd = |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        let mut next = 1u32;
        let mut run_ons = 0;
        for step in 0..100_000 {
            if rnd(2) == 0 {
                let mut batch = Vec::new();
                let mut lines = Vec::new();
                for _ in 0..1 + rnd(4) {
                    let len = if rnd(8) == 0 {
                        LINE_MAX
                    } else {
                        rnd(40) as usize
                    };
                    let text: Vec<u8> = (0..len)
                        .map(|i| b'A' + ((next as usize + i) % 26) as u8)
                        .collect();
                    push_record(&mut batch, next, &text);
                    lines.push((next, text));
                    next += 1;
                }
                assert_eq!(check_run(&batch), Some((lines.len(), Some(next - 1))));
                assert_eq!(check_run(&batch[..batch.len() - 1]), None);
                let fits = batch.len() <= ring.free();
                let tail = ring.tail();
                if fits && tail + batch.len() > LineRing::<{ 600 + RECORD_MAX }>::CAPACITY {
                    run_ons += 1;
                }
                assert_eq!(ring.push_run(&batch, lines.len()), fits, "{step}");
                if fits {
                    model.extend(lines);
                }
            } else {
                let got = ring.front().map(|(n, t)| (n, t.to_vec()));
                assert_eq!(got.as_ref(), model.front(), "{step}");
                ring.pop();
                model.pop_front();
            }
            let used: usize = model.iter().map(|(_, t)| RECORD_HEADER + t.len()).sum();
            assert_eq!(ring.free(), ring.capacity() - used);
            assert_eq!(ring.lines(), model.len());
        }
        assert!(
            run_ons > 1000,
            "records ran on past the end {run_ons} times"
        );
    }

    #[test]
    fn single_lines_and_a_full_ring() {
        let mut ring: LineRing<{ 2 * RECORD_MAX }> = LineRing::new();
        assert_eq!(ring.capacity(), RECORD_MAX);
        assert!(!ring.push_line(1, &[b'X'; LINE_MAX + 1]));
        assert!(ring.push_line(1, &[b'X'; LINE_MAX]));
        assert_eq!(ring.free(), 0);
        assert!(!ring.push_line(2, b""));
        assert_eq!(ring.front(), Some((1, &[b'X'; LINE_MAX][..])));
        ring.pop();
        assert!(ring.is_empty());
        assert_eq!(ring.free(), RECORD_MAX);
    }
}
