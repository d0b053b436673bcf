//! Line batches: how program lines travel host → board, several per frame, and how the board
//! stores them.
//!
//! A [`crate::HostMsg::Lines`] message carries a place id and a run of *records*, one per line:
//!
//! | size | field |
//! |---|---|
//! | 4 | `line_no` (LE): the line's number in the host's file (0 = a resume preamble block) |
//! | 2 | `len` (LE): bytes of text, at most [`LINE_MAX`] |
//! | `len` | the text, comments and blanks stripped by the host |
//!
//! This module is the one definition of the format. The board stores these records exactly as
//! they arrive (its line ring, `machine/src/board/line_ring.rs`, reads and writes them with these
//! functions), so a batch is copied once from the decoded frame into the ring and the interpreter
//! reads each line where it lies. The queued lane's credit the board grants is counted
//! in the same bytes: a batch costs its record bytes ([`crate::Wire::charge`]).

/// Longest G-code line (bytes, comments and blanks stripped) the link carries and the board
/// takes: LinuxCNC's limit, enough for CAM output with named parameters.
pub const LINE_MAX: usize = 256;

/// Bytes of a record's header (`line_no` and `len`).
pub const RECORD_HEADER: usize = 6;

/// Largest record: a [`LINE_MAX`] line with its header.
pub const RECORD_MAX: usize = RECORD_HEADER + LINE_MAX;

/// Largest run of records in one `Lines` message: the frame's payload less the message's own
/// bytes (variant tag 1, id varint ≤ 3, length varint 2).
pub const BATCH_MAX: usize = crate::frame::MAX_PAYLOAD - 6;

const _: () = assert!(BATCH_MAX >= RECORD_MAX, "a frame carries the longest line");

/// The records of a batch as the host builds and sends them.
pub type LineBatch = heapless::Vec<u8, BATCH_MAX>;

/// Appends the record of line `line_no` to `batch`; false (batch unchanged) when the text is longer
/// than [`LINE_MAX`] or the batch has no room for it.
pub fn push_record(batch: &mut LineBatch, line_no: u32, text: &[u8]) -> bool {
    if text.len() > LINE_MAX || batch.capacity() - batch.len() < RECORD_HEADER + text.len() {
        return false;
    }
    let at = batch.len();
    // Cannot fail: room checked above.
    let _ = batch.resize(at + record_len(text.len()), 0);
    write_record(&mut batch[at..], line_no, text);
    true
}

/// Writes the record of line `line_no` into `to`, exactly [`record_len`] of `text` bytes long
/// (the board's line ring writes a line in place with it).
pub fn write_record(to: &mut [u8], line_no: u32, text: &[u8]) {
    let (head, body) = to.split_at_mut(RECORD_HEADER);
    head[..4].copy_from_slice(&line_no.to_le_bytes());
    head[4..].copy_from_slice(&(text.len() as u16).to_le_bytes());
    body.copy_from_slice(text);
}

/// The bytes [`push_record`] would add for a line of `text_len` bytes.
pub const fn record_len(text_len: usize) -> usize {
    RECORD_HEADER + text_len
}

/// The first record of `bytes`: its line number, its text and the bytes after it; `None` when
/// `bytes` does not start with a whole, valid record.
pub fn split_record(bytes: &[u8]) -> Option<(u32, &[u8], &[u8])> {
    let (head, rest) = bytes.split_first_chunk::<RECORD_HEADER>()?;
    let line_no = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
    let len = u16::from_le_bytes([head[4], head[5]]) as usize;
    if len > LINE_MAX || len > rest.len() {
        return None;
    }
    let (text, rest) = rest.split_at(len);
    Some((line_no, text, rest))
}

/// What [`check_records`] found in a valid run of records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunSummary {
    /// Records in the run.
    pub lines: usize,
    /// `line_no` of the last record (`None` for an empty run).
    pub last_line: Option<u32>,
}

/// Checks that `records` is a whole number of valid records; `None` when it is not.
pub fn check_records(records: &[u8]) -> Option<RunSummary> {
    let mut rest = records;
    let mut summary = RunSummary {
        lines: 0,
        last_line: None,
    };
    while !rest.is_empty() {
        let (line_no, _, after) = split_record(rest)?;
        summary.lines += 1;
        summary.last_line = Some(line_no);
        rest = after;
    }
    Some(summary)
}

/// The variant index of [`crate::HostMessage::Lines`] on the wire (its first byte).
pub const LINES_TAG: u8 = 0;

/// A `Lines` message read where it lies: its place id and its records (not checked), or `None`
/// when `payload` is not a whole `Lines` message. The same bytes as postcard's (variant index,
/// varint id, varint length, the records), read without a deserializer, so a board decodes every
/// other message with the one it has for the realtime lane.
pub fn batch_in_place(payload: &[u8]) -> Option<(u16, &[u8])> {
    let (&tag, rest) = payload.split_first()?;
    if tag != LINES_TAG {
        return None;
    }
    let (id, rest) = varint(rest, 3)?;
    let (len, rest) = varint(rest, 2)?;
    (rest.len() == len as usize).then_some((u16::try_from(id).ok()?, rest))
}

/// An unsigned LEB128 varint of at most `max` bytes, and the bytes after it.
fn varint(bytes: &[u8], max: usize) -> Option<(u32, &[u8])> {
    let mut value = 0u32;
    for (i, &b) in bytes.iter().enumerate().take(max) {
        value |= u32::from(b & 0x7F) << (7 * i);
        if b & 0x80 == 0 {
            return Some((value, bytes.get(i + 1..)?));
        }
    }
    None
}

/// The records of a valid run, in order, as (line number, text).
pub fn records(run: &[u8]) -> impl Iterator<Item = (u32, &[u8])> {
    let mut rest = run;
    core::iter::from_fn(move || {
        let (n, text, after) = split_record(rest)?;
        rest = after;
        Some((n, text))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_bad_runs_are_refused() {
        let mut b = LineBatch::new();
        assert!(push_record(&mut b, 7, b"G1 X1"));
        assert!(push_record(&mut b, 0x0102_0304, b""));
        assert_eq!(
            &b[..],
            &[7, 0, 0, 0, 5, 0, b'G', b'1', b' ', b'X', b'1', 4, 3, 2, 1, 0, 0][..]
        );
        assert_eq!(
            check_records(&b),
            Some(RunSummary {
                lines: 2,
                last_line: Some(0x0102_0304)
            })
        );
        let got: Vec<_> = records(&b).collect();
        assert_eq!(got, [(7, &b"G1 X1"[..]), (0x0102_0304, &b""[..])]);
        // Cut anywhere inside a record: not a valid run.
        for cut in 1..b.len() {
            if cut != 11 {
                assert_eq!(check_records(&b[..cut]), None, "cut at {cut}");
            }
        }
        // A length beyond LINE_MAX is refused even with the bytes present.
        let mut long = [0u8; RECORD_HEADER + LINE_MAX + 1];
        long[4..6].copy_from_slice(&((LINE_MAX + 1) as u16).to_le_bytes());
        assert_eq!(check_records(&long), None);
    }

    #[test]
    fn batches_read_in_place_match_postcard() {
        let mut records = LineBatch::new();
        assert!(push_record(&mut records, 5, &[b'G'; 200]));
        for id in [0u16, 1, 127, 128, 300, u16::MAX] {
            let msg = crate::HostMsg::Lines {
                id,
                records: records.clone(),
            };
            let mut buf = [0u8; crate::frame::MAX_PAYLOAD];
            let n = crate::codec::encode(&msg, &mut buf).unwrap();
            assert_eq!(
                batch_in_place(&buf[..n]),
                Some((id, &records[..])),
                "id {id}"
            );
            // Cut short or one byte longer: not a whole message.
            assert_eq!(batch_in_place(&buf[..n - 1]), None);
            let mut longer = buf;
            longer[n] = 0;
            assert_eq!(batch_in_place(&longer[..n + 1]), None);
        }
        let mut buf = [0u8; 16];
        let n = crate::codec::encode(&crate::HostMsg::EndOfJob, &mut buf).unwrap();
        assert_eq!(batch_in_place(&buf[..n]), None);
    }

    #[test]
    fn a_batch_takes_the_longest_line_and_refuses_what_does_not_fit() {
        let mut b = LineBatch::new();
        assert!(!push_record(&mut b, 1, &[b'X'; LINE_MAX + 1]));
        assert!(push_record(&mut b, 1, &[b'X'; LINE_MAX]));
        assert_eq!(b.len(), RECORD_MAX);
        let room = BATCH_MAX - RECORD_MAX;
        assert!(!push_record(
            &mut b,
            2,
            &vec![b'Y'; room - RECORD_HEADER + 1]
        ));
        assert!(push_record(&mut b, 2, &vec![b'Y'; room - RECORD_HEADER]));
        assert_eq!(b.len(), BATCH_MAX);
    }
}
