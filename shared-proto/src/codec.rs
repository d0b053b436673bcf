//! Message payload encoding: postcard (serde derive on every message type).
//!
//! postcard's format: unsigned integers wider than a byte as LEB128 varints, signed ones
//! zigzag-encoded first, `u8` and `bool` as one byte, an enum as its variant index (varint)
//! followed by its fields, structs and arrays field by field, strings and byte vectors as a varint
//! length and the bytes. `docs/protocol.md` describes it; `tests/wire_bytes.txt` pins the bytes
//! of every message kind (the same bytes the earlier hand-written codec wrote).

use serde::{de::DeserializeOwned, Deserialize, Serialize};

/// Encodes `value` into `out`; its length, or `None` when it does not fit.
pub fn encode<T: Serialize>(value: &T, out: &mut [u8]) -> Option<usize> {
    postcard::to_slice(value, out).ok().map(|used| used.len())
}

/// Decodes a `T` that takes exactly all of `bytes` (trailing bytes are an error).
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Option<T> {
    match postcard::take_from_bytes(bytes) {
        Ok((value, [])) => Some(value),
        _ => None,
    }
}

/// Decodes a `T` that takes exactly all of `bytes`, borrowing from them (byte strings are read
/// where they lie: the board's line batches).
pub fn decode_borrowed<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Option<T> {
    match postcard::take_from_bytes(bytes) {
        Ok((value, [])) => Some(value),
        _ => None,
    }
}
