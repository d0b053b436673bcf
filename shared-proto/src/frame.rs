//! Frame layout, `encode_frame` and the streaming [`FrameDecoder`].
//!
//! On the wire a frame is `COBS(header ‖ payload ‖ crc32_le) ‖ 0x00`:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | kind (low nibble) and flags (high nibble) |
//! | 1 | 2 | `seq` (LE): sequence number of a Data or Realtime frame, else 0 |
//! | 3 | 2 | `ack` (LE): next queued-lane seq the sender of this frame expects |
//! | 5 | 2 | `win` (LE): queued-lane credit after `ack` (free slots; the board: free line-ring bytes) |
//! | 7 | 2 | `rt_ack` (LE): next realtime-lane seq expected |
//! | 9 | 1 | `rt_win`: free realtime-lane slots |
//! | 10 | n | postcard payload (empty for Ack and Desync) |
//! | 10+n | 4 | CRC-32/ISO-HDLC over bytes 0..10+n, little-endian |
//!
//! COBS (the `cobs` crate) removes every 0x00 from the frame so 0x00 marks
//! frame boundaries; a receiver that starts mid-stream or sees garbage loses
//! at most the frame in progress and resynchronises on the next 0x00.

use crate::codec;
use crate::crc::{crc32, CRC_LEN};

/// Bytes of the fixed header.
pub const HEADER_LEN: usize = 10;
/// Largest raw frame (header + payload + CRC) before COBS: room for a batch holding the longest
/// line ([`crate::lines::BATCH_MAX`]), or several short ones.
pub const MAX_RAW: usize = 320;
/// Largest payload.
pub const MAX_PAYLOAD: usize = MAX_RAW - HEADER_LEN - CRC_LEN;
/// Largest frame on the wire, COBS overhead and delimiter included. Buffers
/// passed to [`encode_frame`] and `poll_transmit` must be at least this long.
pub const MAX_FRAME_LEN: usize = MAX_RAW + MAX_RAW.div_ceil(254) + 1;

/// Declares [`Kind`] and its decoder from one list of `Name = nibble` entries.
macro_rules! frame_kinds {
    ($( $(#[$doc:meta])* $name:ident = $value:literal, )*) => {
        /// Frame kind (low nibble of byte 0).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[repr(u8)]
        pub enum Kind {
            $( $(#[$doc])* $name = $value, )*
        }

        impl Kind {
            /// The kind whose nibble is `v`; `None` for a nibble no kind uses.
            fn from_u8(v: u8) -> Option<Self> {
                match v {
                    $( $value => Some(Kind::$name), )*
                    _ => None,
                }
            }
        }
    };
}

frame_kinds! {
    /// Acknowledgement / window update / probe only; no payload.
    Ack = 0,
    /// A sequenced message of the queued lane.
    Data = 1,
    /// A sequenced message of the realtime lane.
    Realtime = 2,
    /// Handshake request (payload [`crate::messages::Hello`]).
    Hello = 3,
    /// Handshake answer (payload [`crate::messages::HelloAck`]).
    HelloAck = 4,
    /// "I have no session with you, say Hello first" (board → host, no payload).
    Desync = 5,
}

/// Flag: the sender of this frame saw a gap in the queued lane (fast retransmit hint).
pub const FLAG_NAK: u8 = 0x10;
/// Flag: the sender of this frame saw a gap in the realtime lane.
pub const FLAG_RT_NAK: u8 = 0x20;
/// Flag: please answer with an Ack (window probe / keepalive).
pub const FLAG_POLL: u8 = 0x40;
const FLAGS_KNOWN: u8 = FLAG_NAK | FLAG_RT_NAK | FLAG_POLL;

/// The fixed frame header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub kind: Kind,
    pub flags: u8,
    pub seq: u16,
    pub ack: u16,
    pub win: u16,
    pub rt_ack: u16,
    pub rt_win: u8,
}

impl Header {
    /// A header of `kind` with every other field zero.
    pub fn new(kind: Kind) -> Self {
        Self {
            kind,
            flags: 0,
            seq: 0,
            ack: 0,
            win: 0,
            rt_ack: 0,
            rt_win: 0,
        }
    }

    fn write(&self, b: &mut [u8]) {
        b[0] = self.kind as u8 | (self.flags & FLAGS_KNOWN);
        b[1..3].copy_from_slice(&self.seq.to_le_bytes());
        b[3..5].copy_from_slice(&self.ack.to_le_bytes());
        b[5..7].copy_from_slice(&self.win.to_le_bytes());
        b[7..9].copy_from_slice(&self.rt_ack.to_le_bytes());
        b[9] = self.rt_win;
    }

    fn read(b: &[u8; HEADER_LEN]) -> Option<Self> {
        let kind = Kind::from_u8(b[0] & 0x0F)?;
        let flags = b[0] & 0xF0;
        if flags & !FLAGS_KNOWN != 0 {
            return None;
        }
        Some(Self {
            kind,
            flags,
            seq: u16::from_le_bytes([b[1], b[2]]),
            ack: u16::from_le_bytes([b[3], b[4]]),
            win: u16::from_le_bytes([b[5], b[6]]),
            rt_ack: u16::from_le_bytes([b[7], b[8]]),
            rt_win: b[9],
        })
    }
}

/// Why a frame could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The payload does not fit in [`MAX_PAYLOAD`].
    PayloadTooLarge,
    /// `out` is shorter than the encoded frame.
    OutputTooSmall,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            EncodeError::PayloadTooLarge => "payload larger than a frame allows",
            EncodeError::OutputTooSmall => "output buffer shorter than the frame",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

/// Encodes `header` and the postcard form of `payload` (if any) as one
/// complete wire frame (delimiter included) into `out`; returns its length.
pub fn encode_frame<P: serde::Serialize>(
    header: &Header,
    payload: Option<&P>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let mut raw = [0u8; MAX_RAW];
    let plen = match payload {
        Some(p) => codec::encode(p, &mut raw[HEADER_LEN..MAX_RAW - CRC_LEN])
            .ok_or(EncodeError::PayloadTooLarge)?,
        None => 0,
    };
    finish_frame(header, &mut raw, plen, out)
}

/// The part of [`encode_frame`] that does not depend on the payload's type (one copy in flash
/// instead of one per payload type): the header before the `plen` payload bytes already in
/// `raw`, the CRC after them, and the COBS encoding with its terminating zero into `out`.
fn finish_frame(
    header: &Header,
    raw: &mut [u8; MAX_RAW],
    plen: usize,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    header.write(&mut raw[..HEADER_LEN]);
    // `plen` never exceeds the room it was given; the `min` lets the compiler see that the slices
    // below are in range (no bounds-check panic paths).
    let body = (HEADER_LEN + plen).min(MAX_RAW - CRC_LEN);
    let (msg, tail) = raw.split_at_mut(body);
    let crc = crc32(msg);
    tail[..CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    let raw_len = body + CRC_LEN;
    let n = cobs::try_encode(raw.get(..raw_len).unwrap_or_default(), out)
        .map_err(|_| EncodeError::OutputTooSmall)?;
    if n >= out.len() {
        return Err(EncodeError::OutputTooSmall);
    }
    out[n] = 0;
    Ok(n + 1)
}

/// A valid frame handed out by the decoder; `payload` borrows its buffer.
#[derive(Debug)]
pub struct Frame<'a> {
    pub header: Header,
    pub payload: &'a [u8],
}

/// COBS decoding as the bytes arrive, a block at a time: a code byte, then the bytes it vouches
/// for, copied to the output in one block, then (for a code below 0xFF that is not the frame's
/// last) a zero. The `cobs` crate (whose encoder [`encode_frame`] uses) decodes a byte at a time
/// after the whole frame is in: 19 Cortex-M4 instructions per byte, on every byte the host sends
/// (target-tests `bench_link`). A test holds the two decoders equal on every input and chunking.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct CobsRun {
    /// Bytes of the current code's block still to come (0: the next byte is a code).
    block_left: u8,
    /// The last code was below 0xFF: a zero goes out before the next block's bytes.
    zero_owed: bool,
}

impl CobsRun {
    /// Decodes `run` (no delimiter in it) onto `out` from `*len` on; false when the decoded
    /// bytes do not fit (`*len` then stands at the end of `out`).
    fn decode(&mut self, mut run: &[u8], out: &mut [u8], len: &mut usize) -> bool {
        while let Some((&first, rest)) = run.split_first() {
            if self.block_left == 0 {
                if core::mem::replace(&mut self.zero_owed, first != 0xFF) {
                    let Some(z) = out.get_mut(*len) else {
                        return false;
                    };
                    *z = 0;
                    *len += 1;
                }
                self.block_left = first.wrapping_sub(1);
                run = rest;
                continue;
            }
            let n = run.len().min(self.block_left as usize);
            let (block, rest) = run.split_at(n);
            let Some(to) = out.get_mut(*len..*len + n) else {
                return false;
            };
            to.copy_from_slice(block);
            *len += n;
            self.block_left -= n as u8;
            run = rest;
        }
        true
    }

    /// The frame's delimiter came: whether every code's block was complete; ready for the next
    /// frame either way.
    fn finish(&mut self) -> bool {
        core::mem::take(self).block_left == 0
    }
}

/// Counters of what the decoder saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Frames that passed every check.
    pub frames: u32,
    /// Frames whose COBS structure was broken.
    pub bad_cobs: u32,
    /// Frames shorter than a header plus CRC.
    pub runts: u32,
    /// Frames with a CRC mismatch.
    pub bad_crc: u32,
    /// Frames with a valid CRC but an unknown kind or flag.
    pub bad_header: u32,
    /// Frames longer than [`MAX_FRAME_LEN`] (discarded up to the next 0x00).
    pub oversize: u32,
}

/// Streaming decoder: feed it bytes in any chunking; it yields each valid
/// frame once and silently drops (and counts) everything else. Memory is one
/// fixed buffer of [`MAX_FRAME_LEN`] bytes.
pub struct FrameDecoder {
    /// The frame in progress, decoded as it arrives.
    buf: [u8; MAX_FRAME_LEN],
    /// Bytes of it decoded so far.
    decoded: usize,
    /// Wire bytes of it received so far.
    len: usize,
    cobs: CobsRun,
    overflow: bool,
    stats: DecoderStats,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME_LEN],
            decoded: 0,
            len: 0,
            cobs: CobsRun {
                block_left: 0,
                zero_owed: false,
            },
            overflow: false,
            stats: DecoderStats {
                frames: 0,
                bad_cobs: 0,
                runts: 0,
                bad_crc: 0,
                bad_header: 0,
                oversize: 0,
            },
        }
    }

    /// What the decoder has seen so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes of the frame in progress (always ≤ [`MAX_FRAME_LEN`]).
    pub fn buffered(&self) -> usize {
        self.len
    }

    /// Feeds one byte; returns a frame when this byte completes a valid one.
    /// The frame borrows the decoder until the next call.
    pub fn push_byte(&mut self, b: u8) -> Option<Frame<'_>> {
        self.push_run(core::slice::from_ref(&b)).1
    }

    /// Feeds `bytes` up to and including the first frame delimiter (0x00) among them: returns
    /// how many bytes it took (all of them when there is no delimiter) and the frame that
    /// delimiter completed, when it is valid. The bytes before the delimiter are found with one
    /// scan and decoded into the frame buffer a COBS block at a time (a call per byte would cost
    /// more than the decoding). The frame borrows the decoder until the next call.
    pub fn push_run(&mut self, bytes: &[u8]) -> (usize, Option<Frame<'_>>) {
        let end = bytes.iter().position(|&b| b == 0);
        let run = bytes.get(..end.unwrap_or(bytes.len())).unwrap_or_default();
        if !self.overflow {
            // Longer than a frame on the wire: dropped up to its end, counted oversize there.
            self.overflow = self.len + run.len() > MAX_FRAME_LEN
                || !self.cobs.decode(run, &mut self.buf, &mut self.decoded);
        }
        self.len = (self.len + run.len()).min(MAX_FRAME_LEN);
        match end {
            Some(i) => (i + 1, self.end_frame()),
            None => (bytes.len(), None),
        }
    }

    /// A delimiter ended the bytes received since the last one: the frame they encode, when it
    /// is valid (each kind of invalid frame is counted).
    fn end_frame(&mut self) -> Option<Frame<'_>> {
        let len = core::mem::replace(&mut self.len, 0);
        let n = core::mem::replace(&mut self.decoded, 0);
        let whole = self.cobs.finish();
        if core::mem::replace(&mut self.overflow, false) {
            self.stats.oversize = self.stats.oversize.wrapping_add(1);
            return None;
        }
        if len == 0 {
            return None; // back-to-back delimiters: idle fill, not an error
        }
        if !whole {
            self.stats.bad_cobs = self.stats.bad_cobs.wrapping_add(1);
            return None;
        }
        // Header, payload, CRC (decoding never grows the frame: `n <= len`); shorter is a runt.
        let split = self
            .buf
            .get(..n)
            .and_then(|f| f.split_last_chunk::<CRC_LEN>())
            .and_then(|(body, crc)| Some((body, body.split_first_chunk::<HEADER_LEN>()?, crc)));
        let Some((body, (head, payload), crc)) = split else {
            self.stats.runts = self.stats.runts.wrapping_add(1);
            return None;
        };
        if crc32(body) != u32::from_le_bytes(*crc) {
            self.stats.bad_crc = self.stats.bad_crc.wrapping_add(1);
            return None;
        }
        let Some(header) = Header::read(head) else {
            self.stats.bad_header = self.stats.bad_header.wrapping_add(1);
            return None;
        };
        self.stats.frames = self.stats.frames.wrapping_add(1);
        Some(Frame { header, payload })
    }

    /// Feeds a chunk and calls `f` for every valid frame it completes.
    pub fn feed(&mut self, mut bytes: &[u8], mut f: impl FnMut(Frame<'_>)) {
        while !bytes.is_empty() {
            let (used, frame) = self.push_run(bytes);
            if let Some(frame) = frame {
                f(frame);
            }
            bytes = bytes.get(used..).unwrap_or_default();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Our block decoder and the `cobs` crate's agree on every frame body, whatever chunks it
    /// arrives in: valid encodings of random data (decoded back to the data), and random bytes
    /// without a delimiter (the same result, or both refuse).
    #[test]
    fn cobs_decoder_equals_the_crates() {
        let mut seed = 0x2545_F491_u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed
        };
        let ours = |wire: &[u8], cuts: u32| -> Option<Vec<u8>> {
            let mut run = CobsRun::default();
            let mut out = vec![0u8; wire.len()];
            let mut len = 0;
            let mut rest = wire;
            while !rest.is_empty() {
                let n = (1 + cuts as usize % 300).min(rest.len());
                let (chunk, after) = rest.split_at(n);
                assert!(
                    run.decode(chunk, &mut out, &mut len),
                    "decoding never grows"
                );
                rest = after;
            }
            run.finish().then(|| out[..len].to_vec())
        };
        for round in 0..20_000 {
            let len = 1 + (next() % 600) as usize;
            // Runs of zeros and 254-byte stretches without one are both likely.
            let zeros = [2, 16, 1000][round % 3];
            let data: Vec<u8> = (0..len)
                .map(|_| {
                    if next() % zeros == 0 {
                        0
                    } else {
                        next() as u8 | 1
                    }
                })
                .collect();
            let mut enc = vec![0u8; cobs::max_encoding_length(len)];
            let n = cobs::encode(&data, &mut enc);
            let got = ours(&enc[..n], next()).expect("a valid encoding decodes");
            assert_eq!(got, data, "round {round}");

            let junk: Vec<u8> = (0..len).map(|_| (next() as u8).max(1)).collect();
            let mut theirs = junk.clone();
            match (ours(&junk, next()), cobs::decode_in_place(&mut theirs)) {
                (Some(a), Ok(b)) => assert_eq!(a[..], theirs[..b], "round {round}"),
                (None, Err(_)) => {}
                (a, b) => panic!("round {round}: ours {a:?}, the crate's {b:?} for {junk:?}"),
            }
        }
    }

    #[test]
    fn header_round_trip_and_sizes() {
        let h = Header {
            kind: Kind::Data,
            flags: FLAG_NAK | FLAG_POLL,
            seq: 0xBEEF,
            ack: 0x1234,
            win: 7,
            rt_ack: 0xFFFF,
            rt_win: 3,
        };
        let mut out = [0u8; MAX_FRAME_LEN];
        let hello = crate::Hello {
            version: 0x0201,
            nonce: 0xDEAD_BEEF,
            window: 16,
            rt_window: 8,
        };
        let n = encode_frame(&h, Some(&hello), &mut out).unwrap();
        assert_eq!(out[n - 1], 0);
        assert!(out[..n - 1].iter().all(|&b| b != 0));
        let mut d = FrameDecoder::new();
        let mut got = None;
        d.feed(&out[..n], |f| got = Some((f.header, f.payload.to_vec())));
        let (gh, gp) = got.unwrap();
        assert_eq!(gh, h);
        assert_eq!(gp, [0x81, 0x04, 0xEF, 0xFD, 0xB6, 0xF5, 0x0D, 16, 8]);
        assert_eq!(crate::codec::decode::<crate::Hello>(&gp), Some(hello));
        assert_eq!(MAX_FRAME_LEN, 323);
    }

    #[test]
    fn each_kind_has_its_wire_nibble_and_no_other_nibble_decodes() {
        use Kind::*;
        let kinds = [Ack, Data, Realtime, Hello, HelloAck, Desync];
        for (nibble, kind) in kinds.iter().enumerate() {
            assert_eq!(*kind as u8, nibble as u8);
            assert_eq!(Kind::from_u8(nibble as u8), Some(*kind));
        }
        for nibble in kinds.len() as u8..16 {
            assert_eq!(Kind::from_u8(nibble), None);
        }
    }

    #[test]
    fn too_small_output_is_an_error() {
        let mut out = [0u8; 8];
        assert_eq!(
            encode_frame::<()>(&Header::new(Kind::Ack), None, &mut out),
            Err(EncodeError::OutputTooSmall)
        );
    }
}
