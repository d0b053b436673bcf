//! The setup's byte encoding for flash and the link: one format byte ([`FORMAT`]), then the
//! [`Setup`] in postcard's format through its serde derive (fields in declaration order, integers
//! as varints, lists as their length and elements, enums as their variant index).
//!
//! Decoding is strict: a wrong format byte (a setup stored by older firmware), a value beyond its
//! field's range, an unknown enum variant, a list longer than its capacity, a truncated blob or
//! trailing bytes all fail, and the board then runs with the defaults.
//!
//! [`Window`] is the one output flavor for both uses: the whole blob into a buffer, or only the
//! bytes `from .. from + out.len()` of it (a chunk for the link, with no buffer for the whole
//! blob).

use super::{ProgramSetup, Setup};
use postcard::ser_flavors::Flavor;
use serde::de::DeserializeOwned;

/// First byte of every blob: the encoding's version. 1 was the first serde/postcard encoding
/// (without this byte), 2 the hand-written one; 3 is postcard through serde again. Change it
/// whenever the layout changes.
pub const FORMAT: u8 = 4;

/// Writes blob bytes `skip ..` into `out`. With `clip`, bytes beyond `out` are counted and
/// dropped (a window of the blob); without, they are an error.
struct Window<'a> {
    out: &'a mut [u8],
    skip: usize,
    clip: bool,
    pos: usize,
}

impl Flavor for Window<'_> {
    /// The blob's length (all of it, also the bytes a window dropped).
    type Output = usize;

    fn try_push(&mut self, byte: u8) -> postcard::Result<()> {
        if let Some(i) = self.pos.checked_sub(self.skip) {
            match self.out.get_mut(i) {
                Some(slot) => *slot = byte,
                None if self.clip => {}
                None => return Err(postcard::Error::SerializeBufferFull),
            }
        }
        self.pos += 1;
        Ok(())
    }

    fn finalize(self) -> postcard::Result<usize> {
        Ok(self.pos)
    }
}

/// Encodes the blob into `out` from blob byte `skip` on; the blob's length, or `None` when it
/// does not fit and `clip` is false.
pub(super) fn encode(setup: &Setup, out: &mut [u8], skip: usize, clip: bool) -> Option<usize> {
    let window = Window {
        out,
        skip,
        clip,
        pos: 0,
    };
    postcard::serialize_with_flavor(&(FORMAT, setup), window).ok()
}

/// Decodes a blob that is exactly one setup in this [`FORMAT`] (validity is checked by the
/// caller).
///
/// Part by part, into the fields of a default setup: the bytes are the same as for the whole
/// [`Setup`] (postcard writes a struct as its fields in order), but deserializing the whole
/// struct at once moved the partly built 2 KiB setup through every nested `Result` and took a
/// 13.6 KiB stack frame on the F411 (firmware/README.md, "Stack"); one part at a time, each
/// frame holds only that part. The destructuring has no `..`: a new field does not compile
/// until it is read here.
pub(super) fn decode(bytes: &[u8]) -> Option<Setup> {
    let (&FORMAT, mut rest) = bytes.split_first()? else {
        return None;
    };
    let mut setup = Setup::default();
    let Setup {
        axis_count,
        axes,
        path,
        program,
        operator,
        inputs,
        homing,
        jog,
        outputs,
        link,
        drivers,
    } = &mut setup;
    let ProgramSetup {
        dialect,
        dwell_units,
        peck_clearance,
        chip_break_retract,
        default_retract,
        tools,
        work_offsets,
        g28_home,
        g30_home,
        user_mcodes,
    } = program;
    let r = &mut rest;
    part(r, axis_count)?;
    for a in axes {
        part(r, a)?;
    }
    part(r, path)?;
    part(r, dialect)?;
    part(r, dwell_units)?;
    part(r, peck_clearance)?;
    part(r, chip_break_retract)?;
    part(r, default_retract)?;
    part(r, tools)?;
    for o in work_offsets {
        part(r, o)?;
    }
    part(r, g28_home)?;
    part(r, g30_home)?;
    part(r, user_mcodes)?;
    part(r, operator)?;
    part(r, inputs)?;
    part(r, homing)?;
    part(r, jog)?;
    part(r, outputs)?;
    part(r, link)?;
    part(r, drivers)?;
    rest.is_empty().then_some(setup)
}

/// Reads one value from the front of `rest` into `into`.
#[inline(never)]
fn part<T: DeserializeOwned>(rest: &mut &[u8], into: &mut T) -> Option<()> {
    let (value, tail) = postcard::take_from_bytes(rest).ok()?;
    *into = value;
    *rest = tail;
    Some(())
}
