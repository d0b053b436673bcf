//! Message payload encoding: postcard's wire format, written by hand.
//!
//! The bytes are exactly those of `postcard` 1.x for the same types (the tests compare both on
//! every message kind and on random input): unsigned integers wider than a byte as LEB128
//! varints, signed ones zigzag-encoded first, `u8` and `bool` as one byte, an enum as its variant
//! index (varint) followed by its fields, structs and arrays field by field, strings and byte
//! vectors as a varint length and the bytes. `docs/protocol.md` describes the format.
//!
//! Why by hand: the serde-derived code for the messages, inlined into the firmware's main loop,
//! cost several KiB of the F411's 128 KiB of flash. Here one visitor per type ([`Visit`]) serves
//! both directions, so encoder and decoder cannot disagree, and each field costs one call into
//! [`Codec`].

use heapless::{String, Vec};

/// The buffer a [`Codec`] reads from or writes to.
enum Buf<'a> {
    Read(&'a [u8]),
    Write(&'a mut [u8]),
}

/// Reads or writes one value at a time. Every method takes the field by `&mut`: writing encodes
/// it, reading overwrites it. After the first error (end of the buffer, a value out of range,
/// an unknown variant) nothing more is read or written and [`Codec::ok`] stays false.
pub struct Codec<'a> {
    buf: Buf<'a>,
    pos: usize,
    ok: bool,
}

/// A type with a wire form: `visit` walks its fields through a [`Codec`] in wire order.
pub trait Visit: Sized + Clone {
    /// Any value, to decode into (enums: any variant; `visit` replaces it when reading).
    fn blank() -> Self;
    fn visit(&mut self, c: &mut Codec<'_>);
}

/// Encodes `value` into `out`; its length, or `None` when it does not fit.
pub fn encode<T: Visit>(value: &T, out: &mut [u8]) -> Option<usize> {
    // The visitor takes fields by `&mut` for both directions: encode a copy (messages are small).
    let mut copy = value.clone();
    let mut c = Codec {
        buf: Buf::Write(out),
        pos: 0,
        ok: true,
    };
    copy.visit(&mut c);
    c.ok.then_some(c.pos)
}

/// Decodes a `T` that takes exactly all of `bytes`.
pub fn decode<T: Visit>(bytes: &[u8]) -> Option<T> {
    let mut v = T::blank();
    let mut c = Codec {
        buf: Buf::Read(bytes),
        pos: 0,
        ok: true,
    };
    v.visit(&mut c);
    (c.ok && c.pos == bytes.len()).then_some(v)
}

impl Codec<'_> {
    /// True while decoding (enum visitors then replace the value by the variant read).
    pub fn reading(&self) -> bool {
        matches!(self.buf, Buf::Read(_))
    }

    /// Marks the input as invalid (an unknown variant index).
    pub fn fail(&mut self) {
        self.ok = false;
    }

    /// One raw byte.
    #[inline(never)]
    fn byte(&mut self, b: u8) -> u8 {
        if !self.ok {
            return 0;
        }
        let pos = self.pos;
        let got = match &mut self.buf {
            Buf::Write(out) => out.get_mut(pos).map(|slot| {
                *slot = b;
                b
            }),
            Buf::Read(bytes) => bytes.get(pos).copied(),
        };
        match got {
            Some(v) => {
                self.pos += 1;
                v
            }
            None => {
                self.ok = false;
                0
            }
        }
    }

    /// An unsigned value of `bits` bits as a LEB128 varint (as postcard: at most
    /// ⌈bits / 7⌉ bytes, the value within the type).
    #[inline(never)]
    fn varint(&mut self, value: u64, bits: u32) -> u64 {
        if !self.reading() {
            let mut v = value;
            while v >= 0x80 {
                self.byte(v as u8 | 0x80);
                v >>= 7;
            }
            self.byte(v as u8);
            return value;
        }
        let mut v = 0u64;
        for i in 0..bits.div_ceil(7) {
            let b = self.byte(0);
            v |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                if bits < 64 && v >> bits != 0 || bits == 64 && i == 9 && b > 1 {
                    break;
                }
                return v;
            }
        }
        self.ok = false;
        0
    }

    pub fn u8(&mut self, v: &mut u8) {
        *v = self.byte(*v);
    }

    pub fn bool(&mut self, v: &mut bool) {
        match self.byte(u8::from(*v)) {
            0 => *v = false,
            1 => *v = true,
            _ => self.ok = false,
        }
    }

    pub fn u16(&mut self, v: &mut u16) {
        *v = self.varint(u64::from(*v), 16) as u16;
    }

    pub fn u32(&mut self, v: &mut u32) {
        *v = self.varint(u64::from(*v), 32) as u32;
    }

    pub fn u64(&mut self, v: &mut u64) {
        *v = self.varint(*v, 64);
    }

    pub fn i32(&mut self, v: &mut i32) {
        let z = self.varint(u64::from(((*v << 1) ^ (*v >> 31)) as u32), 32) as u32;
        *v = (z >> 1) as i32 ^ -((z & 1) as i32);
    }

    pub fn i64(&mut self, v: &mut i64) {
        let z = self.varint(((*v << 1) ^ (*v >> 63)) as u64, 64);
        *v = (z >> 1) as i64 ^ -((z & 1) as i64);
    }

    /// An enum's variant index.
    pub fn variant(&mut self, index: &mut u32) {
        self.u32(index);
    }

    /// A byte vector: its length, then the bytes.
    pub fn bytes<const N: usize>(&mut self, v: &mut Vec<u8, N>) {
        let mut len = v.len() as u64;
        len = self.varint(len, usize::BITS);
        if self.reading() {
            v.clear();
            if v.resize(len as usize, 0).is_err() {
                self.ok = false;
            }
        }
        for b in v.iter_mut() {
            self.u8(b);
        }
    }

    /// A string: its length, then its UTF-8 bytes.
    pub fn str<const N: usize>(&mut self, s: &mut String<N>) {
        if !self.reading() {
            self.varint(s.len() as u64, usize::BITS);
            for &b in s.as_bytes() {
                self.byte(b);
            }
            return;
        }
        let len = self.varint(0, usize::BITS) as usize;
        let text = match &self.buf {
            Buf::Read(bytes) if self.ok => bytes.get(self.pos..self.pos.saturating_add(len)),
            _ => None,
        };
        s.clear();
        match text
            .and_then(|t| core::str::from_utf8(t).ok())
            .map(|t| s.push_str(t))
        {
            Some(Ok(())) => self.pos += len,
            _ => self.ok = false,
        }
    }
}

impl Visit for () {
    fn blank() -> Self {}
    fn visit(&mut self, _c: &mut Codec<'_>) {}
}

impl<const N: usize> Visit for Vec<u8, N> {
    fn blank() -> Self {
        Vec::new()
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        c.bytes(self);
    }
}
