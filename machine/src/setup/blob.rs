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

use super::{HomingSetup, ProgramSetup, Setup};
use postcard::ser_flavors::Flavor;
use serde::de::DeserializeOwned;

/// postcard's reader over the blob's bytes.
type Reader<'a> = postcard::Deserializer<'a, postcard::de_flavors::Slice<'a>>;

/// First byte of every blob: the encoding's version. 1 was the first serde/postcard encoding
/// (without this byte), 2 the hand-written one; 3 is postcard through serde again; 4 adds
/// `program.tool_change_position`, `path.blend_tolerance` and the grbl front end's section; 5
/// adds `grbl.door_spin_up_ms` (read with the rest of the grbl section in [`decode`]).
/// Change it whenever the layout changes.
pub const FORMAT: u8 = 5;

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
///
/// Fixed-size arrays (positions, the homing axes) are read element by element: postcard writes
/// an array as its elements in order with no length, and serde's array decoder repeats the
/// element's whole decoder once per element (the homing part alone was 1.9 KiB of F411 flash).
pub(super) fn decode(bytes: &[u8]) -> Option<Setup> {
    let (&FORMAT, rest) = bytes.split_first()? else {
        return None;
    };
    let mut reader = postcard::Deserializer::from_bytes(rest);
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
        grbl,
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
        tool_change_position,
    } = program;
    let r = &mut reader;
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
    for o in work_offsets.iter_mut().chain([g28_home, g30_home]) {
        for v in o {
            part(r, v)?;
        }
    }
    part(r, user_mcodes)?;
    // Field by field (postcard writes a struct as its fields): the u8 and Pos readers exist
    // already, a reader of the whole struct would be new flash.
    part(r, &mut tool_change_position.axes)?;
    part(r, &mut tool_change_position.at)?;
    part(r, operator)?;
    part(r, inputs)?;
    let HomingSetup {
        axes: homing_axes,
        required,
        before_seek,
        before_retract,
        after_retract,
    } = homing;
    for h in homing_axes {
        part(r, h)?;
    }
    part(r, required)?;
    for list in [before_seek, before_retract, after_retract] {
        part(r, list)?;
    }
    part(r, jog)?;
    part(r, outputs)?;
    part(r, link)?;
    part(r, drivers)?;
    part(r, grbl)?;
    reader.finalize().ok()?.is_empty().then_some(setup)
}

/// Reads the next value of the blob into `into`. One reader for all parts: a
/// `take_from_bytes` per part repeated its set-up and remainder code in each of the ~18
/// instances of this function.
#[inline(never)]
fn part<T: DeserializeOwned>(reader: &mut Reader<'_>, into: &mut T) -> Option<()> {
    *into = T::deserialize(reader).ok()?;
    Some(())
}

#[cfg(test)]
mod tests {
    use super::super::{HomingAxis, ListCommand, MAX_HOMING_COMMANDS};
    use super::*;
    use crate::units::MAX_AXES;

    /// A setup whose arrays hold a different value in every element: a part read out of order
    /// or an element read into the wrong slot shows.
    fn distinct() -> Setup {
        let mut s = Setup::default();
        for (i, h) in s.homing.axes.iter_mut().enumerate() {
            let i = i as i64;
            *h = HomingAxis {
                priority: i as u8 + 1,
                seek_low: i % 2 == 0,
                seek_rate: 1_000 + i,
                retract: 2_000 + i,
                set_home: i % 3 == 0,
                home_position: -3_000 - i,
            };
        }
        s.homing.required = true;
        for n in 0..MAX_HOMING_COMMANDS as u8 {
            s.homing.before_seek.push(ListCommand::Set(n)).unwrap();
            s.homing.after_retract.push(ListCommand::Clear(n)).unwrap();
        }
        for (w, o) in s.program.work_offsets.iter_mut().enumerate() {
            for (a, v) in o.iter_mut().enumerate() {
                *v = (w * MAX_AXES + a) as i64 * -1_000_003;
            }
        }
        for a in 0..MAX_AXES {
            s.program.g28_home[a] = 7_000 + a as i64;
            s.program.g30_home[a] = -9_000 - a as i64;
        }
        s
    }

    #[test]
    fn part_by_part_decoding_equals_decoding_the_whole_setup() {
        let s = distinct();
        let mut buf = [0u8; crate::setup::SETUP_BLOB_MAX];
        let len = encode(&s, &mut buf, 0, false).unwrap();
        let (format, whole): (u8, Setup) = postcard::from_bytes(&buf[..len]).unwrap();
        assert_eq!(format, FORMAT);
        assert_eq!(whole, s);
        assert_eq!(decode(&buf[..len]), Some(whole));
        // A blob cut inside the homing axes or the positions is refused.
        for cut in 1..len {
            assert_eq!(decode(&buf[..cut]), None, "{cut} bytes");
        }
    }

    #[test]
    fn the_door_spin_up_round_trips_and_is_range_checked_and_format_4_is_refused() {
        let mut s = Setup::default();
        let mut buf = [0u8; crate::setup::SETUP_BLOB_MAX];
        let default_len = encode(&s, &mut buf, 0, false).unwrap();
        s.grbl.door_spin_up_ms = 60_000;
        let len = encode(&s, &mut buf, 0, false).unwrap();
        assert_eq!(
            len,
            default_len + 1,
            "the field is a varint: 4000 in 2 bytes, 60000 in 3"
        );
        assert_eq!(Setup::from_blob(&buf[..len]), Some(s.clone()));
        s.grbl.door_spin_up_ms = 60_001;
        let len = encode(&s, &mut buf, 0, false).unwrap();
        assert_eq!(decode(&buf[..len]), Some(s.clone()));
        assert_eq!(Setup::from_blob(&buf[..len]), None, "beyond 60 s");
        // A blob stored by the firmware before the field (format 4) gives the defaults.
        buf[0] = 4;
        assert_eq!(Setup::from_blob(&buf[..len]), None);
    }
}
