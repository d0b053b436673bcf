//! The setup's byte encoding for flash and the link: one format byte ([`FORMAT`]), then the
//! [`Setup`] in postcard's format (fields in declaration order, `u8` as one byte, other integers
//! as varints (zigzag for the signed ones), bools as 0/1, lists and strings as their length and
//! elements, fixed arrays as their elements, enums as their variant index and fields).
//!
//! Hand-written rather than through serde and postcard: the same bytes (the tests compare them
//! with postcard's), in a fifth of the flash. Each type's fields are listed once, in
//! `code_struct!`, which destructures without `..`: a new field does not compile until it is
//! listed there.
//!
//! Decoding is strict, as postcard's: a wrong format byte (a setup stored by older firmware), a
//! value beyond its field's range, an unknown enum variant, a list longer than its capacity, a
//! truncated blob or trailing bytes all fail, and the board then runs with the defaults.
//! Errors are sticky (`Reader::bad`): a failed read gives 0 and the whole decode fails at the
//! end, so the field code has no error branches. The setup is decoded in place into a default
//! one, one field at a time: no frame holds a second setup (firmware/README.md, "Stack").
//!
//! [`Writer`] is the one output for both uses: the whole blob into a buffer, or only the bytes
//! `from .. from + out.len()` of it (a chunk for the link, with no buffer for the whole blob).

use super::{
    AxisSetup, DriverSetup, GrblSetup, HomingAxis, HomingSetup, InputSetup, JogSetup, LinkSetup,
    ListCommand, McodeList, OperatorSetup, OrientSetup, OutputSetup, PathSetup, ProgramSetup,
    Setup, TorchSetup,
};
use crate::gcode::{Dialect, DwellUnits, RetractMode, Tool, ToolChangePosition};

/// First byte of every blob: the encoding's version. 1 was the first serde/postcard encoding
/// (without this byte), 2 the hand-written one; 3 is postcard through serde again; 4 adds
/// `program.tool_change_position`, `path.blend_tolerance` and the grbl front end's section; 5
/// adds `grbl.door_spin_up_ms`. Format 5 is written by hand again, byte for byte as postcard; 6
/// adds `grbl.m6_stop`; 7 `outputs.laser`; 8 `homing.axes[].locate_rate`; 9 `outputs.orient`; 10
/// `outputs.torch`; 11 `axes[].jerk`. Change it whenever the layout changes.
pub(crate) const FORMAT: u8 = 11;

/// Writes blob bytes `skip ..` into `out`. With `clip`, bytes beyond `out` are counted and
/// dropped (a window of the blob); without, they make the encoding fail (`full`).
struct Writer<'a> {
    out: &'a mut [u8],
    skip: usize,
    clip: bool,
    pos: usize,
    full: bool,
}

impl Writer<'_> {
    #[inline(never)]
    fn byte(&mut self, byte: u8) {
        if let Some(i) = self.pos.checked_sub(self.skip) {
            match self.out.get_mut(i) {
                Some(slot) => *slot = byte,
                None => self.full |= !self.clip,
            }
        }
        self.pos += 1;
    }

    /// An unsigned varint: 7 bits a byte, low first, the top bit set on all but the last.
    #[inline(never)]
    fn varint(&mut self, mut v: u64) {
        while v >= 0x80 {
            self.byte(v as u8 | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    /// A signed varint: zigzag (0, -1, 1, -2 ... as 0, 1, 2, 3 ...), then as unsigned.
    #[inline(never)]
    fn signed(&mut self, v: i64) {
        self.varint(((v << 1) ^ (v >> 63)) as u64);
    }
}

/// Reads the blob's bytes; a failed read sets `bad` and gives 0.
struct Reader<'a> {
    bytes: &'a [u8],
    bad: bool,
}

impl Reader<'_> {
    /// The next byte (0 and `bad` at the end).
    #[inline(never)]
    fn byte(&mut self) -> u8 {
        match self.bytes.split_first() {
            Some((&b, rest)) => {
                self.bytes = rest;
                b
            }
            None => {
                self.bad = true;
                0
            }
        }
    }

    /// Marks the blob bad; gives 0.
    fn fail(&mut self) -> u64 {
        self.bad = true;
        0
    }

    /// An unsigned varint of a `bits`-bit integer, as postcard reads it: at most
    /// `ceil(bits / 7)` bytes, the last of them within the bits left.
    #[inline(never)]
    fn varint(&mut self, bits: u32) -> u64 {
        let max = bits.div_ceil(7);
        let mut out = 0;
        for i in 0..max {
            let b = self.byte();
            out |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                if i == max - 1 && u32::from(b) >= 1 << (bits % 7) {
                    return self.fail();
                }
                return out;
            }
        }
        self.fail()
    }

    /// A zigzag varint of a `bits`-bit signed integer.
    #[inline(never)]
    fn signed(&mut self, bits: u32) -> i64 {
        let n = self.varint(bits);
        (n >> 1) as i64 ^ -((n & 1) as i64)
    }

    /// An enum's variant index, below `count` (else 0 and `bad`).
    #[inline(never)]
    fn variant(&mut self, count: usize) -> usize {
        let i = self.varint(32) as usize;
        if i < count {
            i
        } else {
            self.fail() as usize
        }
    }

    /// A list's length, at most `cap` (else 0 and `bad`).
    #[inline(never)]
    fn len(&mut self, cap: usize) -> usize {
        let n = self.varint(usize::BITS);
        if n <= cap as u64 {
            n as usize
        } else {
            self.fail() as usize
        }
    }
}

/// A value of the blob: written, and read in place.
trait Code {
    fn enc(&self, w: &mut Writer);
    fn dec(&mut self, r: &mut Reader);
}

/// A list element: the value a read starts from.
trait Elem: Code + Sized {
    fn blank() -> Self;
}

impl Code for u8 {
    fn enc(&self, w: &mut Writer) {
        w.byte(*self);
    }
    fn dec(&mut self, r: &mut Reader) {
        *self = r.byte();
    }
}

impl Code for bool {
    fn enc(&self, w: &mut Writer) {
        w.byte(u8::from(*self));
    }
    fn dec(&mut self, r: &mut Reader) {
        *self = match r.byte() {
            0 => false,
            1 => true,
            _ => r.fail() != 0,
        };
    }
}

macro_rules! code_unsigned {
    ($($t:ty),*) => {$(
        impl Code for $t {
            fn enc(&self, w: &mut Writer) {
                w.varint(u64::from(*self));
            }
            fn dec(&mut self, r: &mut Reader) {
                *self = r.varint(<$t>::BITS) as $t;
            }
        }
    )*};
}
code_unsigned!(u16, u32);

impl Code for i64 {
    fn enc(&self, w: &mut Writer) {
        w.signed(*self);
    }
    fn dec(&mut self, r: &mut Reader) {
        *self = r.signed(64);
    }
}

impl Elem for u16 {
    fn blank() -> Self {
        0
    }
}

impl<T: Code, const N: usize> Code for [T; N] {
    fn enc(&self, w: &mut Writer) {
        for v in self {
            v.enc(w);
        }
    }
    fn dec(&mut self, r: &mut Reader) {
        for v in self {
            v.dec(r);
        }
    }
}

impl<T: Elem, const N: usize> Code for heapless::Vec<T, N> {
    fn enc(&self, w: &mut Writer) {
        w.varint(self.len() as u64);
        for v in self {
            v.enc(w);
        }
    }
    fn dec(&mut self, r: &mut Reader) {
        self.clear();
        for _ in 0..r.len(N) {
            let mut v = T::blank();
            v.dec(r);
            // Within capacity: `len` checked it.
            let _ = self.push(v);
        }
    }
}

impl<const N: usize> Code for heapless::String<N> {
    fn enc(&self, w: &mut Writer) {
        w.varint(self.len() as u64);
        for &b in self.as_bytes() {
            w.byte(b);
        }
    }
    fn dec(&mut self, r: &mut Reader) {
        // postcard reads the length as a usize and the bytes, then the string must be UTF-8 and
        // fit: all failures alike here.
        let n = r.varint(usize::BITS);
        let mut bytes = heapless::Vec::<u8, N>::new();
        for _ in 0..n {
            if r.bad {
                break;
            }
            let b = r.byte();
            if bytes.push(b).is_err() {
                r.fail();
            }
        }
        *self = heapless::String::from_utf8(bytes).unwrap_or_else(|_| {
            r.fail();
            heapless::String::new()
        });
    }
}

/// A struct: its fields in order (all of them, the destructuring has no `..`).
macro_rules! code_struct {
    ($($t:ty { $($f:ident),* $(,)? })*) => {$(
        impl Code for $t {
            fn enc(&self, w: &mut Writer) {
                let Self { $($f),* } = self;
                $($f.enc(w);)*
            }
            fn dec(&mut self, r: &mut Reader) {
                let Self { $($f),* } = self;
                $($f.dec(r);)*
            }
        }
    )*};
}

code_struct! {
    Setup { axis_count, axes, path, program, operator, inputs, homing, jog, outputs, link, drivers, grbl }
    AxisSetup { steps, units_nm, max_rate, accel, jerk, start_speed, travel_min, travel_max, invert_dir }
    PathSetup { junction_deviation, feed_shift, chord_tolerance, arc_segment_angle_mdeg, arc_max_segments, blend_tolerance }
    ProgramSetup { dialect, dwell_units, peck_clearance, chip_break_retract, default_retract, tools, work_offsets, g28_home, g30_home, user_mcodes, tool_change_position }
    Tool { number, length, diameter }
    ToolChangePosition { axes, at }
    OperatorSetup { resume_needs_cycle_start, two_hand_start, fro_low, fro_high, dry_run_feed }
    InputSetup { invert, debounce_ms, limit_min, limit_max, hard_limits, feed_hold, abort, fro_pot, adc_max }
    HomingSetup { axes, required, before_seek, before_retract, after_retract }
    HomingAxis { priority, seek_low, seek_rate, locate_rate, retract, set_home, home_position }
    JogSetup { pairs, instant_speed, nudge_distance, nudge_interval_ms, analog_axes, analog_deadband, analog_max_speed }
    OutputSetup { spindle_min_rpm, spindle_max_rpm, pwm_max, pwm_min, laser, torch, mcode_lists, orient }
    OrientSetup { output, done_input, dwell_ms }
    TorchSetup { on, arc_ok_timeout_ms, thc, thc_rate, thc_travel, thc_anti_dive, thc_delay_ms }
    McodeList { code, dry_run_disabled, commands }
    LinkSetup { host_lost_stop_s }
    DriverSetup { step_pulse_ns, dir_setup_ns }
    GrblSetup { status_mask, inches, startup, door_spin_up_ms, m6_stop }
}

impl Elem for Tool {
    fn blank() -> Self {
        Tool::default()
    }
}

impl Elem for McodeList {
    fn blank() -> Self {
        McodeList {
            code: 0,
            dry_run_disabled: false,
            commands: heapless::Vec::new(),
        }
    }
}

/// An enum without fields: its variant index.
macro_rules! code_unit_enum {
    ($($t:ident [$($v:ident),*])*) => {$(
        impl Code for $t {
            fn enc(&self, w: &mut Writer) {
                w.varint(*self as u64);
            }
            fn dec(&mut self, r: &mut Reader) {
                const ALL: &[$t] = &[$($t::$v),*];
                // `variant` is below `ALL.len()`; `get` leaves no bounds-check panic path.
                *self = ALL.get(r.variant(ALL.len())).copied().unwrap_or(ALL[0]);
            }
        }
    )*};
}

code_unit_enum! {
    Dialect [Rs274, Gixa]
    DwellUnits [Seconds, FanucIntegerMillis]
    RetractMode [InitialLevel, RPlane]
}

impl Code for ListCommand {
    fn enc(&self, w: &mut Writer) {
        match *self {
            ListCommand::Set(n) => {
                w.varint(0);
                n.enc(w);
            }
            ListCommand::Clear(n) => {
                w.varint(1);
                n.enc(w);
            }
            ListCommand::DwellMs(ms) => {
                w.varint(2);
                ms.enc(w);
            }
            ListCommand::WaitInput {
                bit,
                level,
                timeout_ms,
            } => {
                w.varint(3);
                bit.enc(w);
                level.enc(w);
                timeout_ms.enc(w);
            }
            ListCommand::DisableLimitReport => w.varint(4),
            ListCommand::Seek => w.varint(5),
        }
    }
    fn dec(&mut self, r: &mut Reader) {
        *self = match r.variant(6) {
            0 => ListCommand::Set(r.byte()),
            1 => ListCommand::Clear(r.byte()),
            2 => ListCommand::DwellMs(r.varint(16) as u16),
            3 => {
                let mut bit = 0;
                let mut level = false;
                let mut timeout_ms = 0;
                bit.dec(r);
                level.dec(r);
                timeout_ms.dec(r);
                ListCommand::WaitInput {
                    bit,
                    level,
                    timeout_ms,
                }
            }
            4 => ListCommand::DisableLimitReport,
            _ => ListCommand::Seek,
        };
    }
}

impl Elem for ListCommand {
    fn blank() -> Self {
        ListCommand::Seek
    }
}

/// Encodes the blob into `out` from blob byte `skip` on; the blob's length, or `None` when it
/// does not fit and `clip` is false.
pub(super) fn encode(setup: &Setup, out: &mut [u8], skip: usize, clip: bool) -> Option<usize> {
    let mut w = Writer {
        out,
        skip,
        clip,
        pos: 0,
        full: false,
    };
    w.byte(FORMAT);
    setup.enc(&mut w);
    (!w.full).then_some(w.pos)
}

/// Decodes a blob that is exactly one setup in this [`FORMAT`] (validity is checked by the
/// caller).
pub(super) fn decode(bytes: &[u8]) -> Option<Setup> {
    let (&FORMAT, rest) = bytes.split_first()? else {
        return None;
    };
    let mut r = Reader {
        bytes: rest,
        bad: false,
    };
    let mut setup = Setup::default();
    setup.dec(&mut r);
    (!r.bad && r.bytes.is_empty()).then_some(setup)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::super::{HomingAxis, ListCommand, MAX_HOMING_COMMANDS};
    use super::*;
    use crate::units::MAX_AXES;
    use heapless::Vec;

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
                locate_rate: 500 + i,
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

    /// postcard's decoding of a blob, the oracle of [`decode`]: the format byte, then exactly
    /// one setup.
    fn postcard_decode(bytes: &[u8]) -> Option<Setup> {
        let ((format, setup), rest): ((u8, Setup), _) = postcard::take_from_bytes(bytes).ok()?;
        (format == FORMAT && rest.is_empty()).then_some(setup)
    }

    /// Every field away from its default, every list full, every list command kind, the
    /// extremes of the integers and multi-byte characters in the startup lines.
    fn full() -> Setup {
        use super::super::{McodeList, MAX_MCODE_COMMANDS, MAX_MCODE_LISTS, MAX_USER_MCODES};
        use crate::gcode::{Dialect, DwellUnits, RetractMode, Tool, MAX_TOOLS};
        let mut s = distinct();
        s.axis_count = 6;
        for (i, a) in s.axes.iter_mut().enumerate() {
            a.steps = u32::MAX - i as u32;
            a.units_nm = i64::MIN + i as i64;
            a.max_rate = i64::MAX - i as i64;
            a.accel = -1 - i as i64;
            a.jerk = 1 << (9 * i);
            a.start_speed = 63 + i as i64;
            a.travel_min = -64 - i as i64;
            a.travel_max = 1 << (7 * i);
            a.invert_dir = i % 2 == 1;
        }
        s.path.junction_deviation = -1;
        s.path.feed_shift = 1;
        s.path.chord_tolerance = 127;
        s.path.arc_segment_angle_mdeg = 128;
        s.path.arc_max_segments = u32::MAX;
        s.path.blend_tolerance = 16_384;
        let p = &mut s.program;
        p.dialect = Dialect::Gixa;
        p.dwell_units = DwellUnits::FanucIntegerMillis;
        p.peck_clearance = 1;
        p.chip_break_retract = 2;
        p.default_retract = RetractMode::RPlane;
        for i in 0..MAX_TOOLS {
            p.tools
                .push(Tool {
                    number: u32::MAX - i as u32,
                    length: -(1 << (2 * i)),
                    diameter: i64::MAX >> i,
                })
                .unwrap();
        }
        for i in 0..MAX_USER_MCODES {
            p.user_mcodes.push(u16::MAX - i as u16).unwrap();
        }
        p.tool_change_position.axes = 0xff;
        p.tool_change_position.at = [i64::MIN, i64::MAX, -1, 1, 0, 300];
        s.operator.resume_needs_cycle_start = true;
        s.operator.two_hand_start = true;
        s.operator.fro_low = u16::MAX;
        s.operator.fro_high = 128;
        s.operator.dry_run_feed = -5;
        s.inputs.invert = u32::MAX;
        s.inputs.debounce_ms = 255;
        s.inputs.limit_min = 0x80;
        s.inputs.limit_max = 0x7f;
        s.inputs.hard_limits = false;
        s.inputs.feed_hold = false;
        s.inputs.abort = false;
        s.inputs.fro_pot = true;
        s.inputs.adc_max = 65_535;
        let kinds = [
            ListCommand::Set(255),
            ListCommand::Clear(128),
            ListCommand::DwellMs(65_535),
            ListCommand::WaitInput {
                bit: 200,
                level: true,
                timeout_ms: 60_000,
            },
            ListCommand::WaitInput {
                bit: 0,
                level: false,
                timeout_ms: 0,
            },
            ListCommand::DisableLimitReport,
            ListCommand::Seek,
            ListCommand::DwellMs(127),
        ];
        s.homing.before_retract = Vec::from_slice(&kinds).unwrap();
        s.jog.pairs = [[0, 255], [128, 7]];
        s.jog.instant_speed = 1_000_000_007;
        s.jog.nudge_distance = -10;
        s.jog.nudge_interval_ms = 1;
        s.jog.analog_axes = [255, 254];
        s.jog.analog_deadband = 300;
        s.jog.analog_max_speed = -1_000_000;
        s.outputs.spindle_min_rpm = 1;
        s.outputs.spindle_max_rpm = u32::MAX;
        s.outputs.pwm_max = u16::MAX;
        s.outputs.pwm_min = 1;
        s.outputs.orient = OrientSetup {
            output: 15,
            done_input: 31,
            dwell_ms: u16::MAX,
        };
        for i in 0..MAX_MCODE_LISTS {
            let mut l = McodeList {
                code: 100 + 1000 * i as u16,
                dry_run_disabled: i % 2 == 0,
                commands: Vec::new(),
            };
            for c in kinds.iter().cycle().skip(i).take(MAX_MCODE_COMMANDS) {
                l.commands.push(*c).unwrap();
            }
            s.outputs.mcode_lists.push(l).unwrap();
        }
        s.link.host_lost_stop_s = u16::MAX;
        s.drivers.step_pulse_ns = u32::MAX;
        s.drivers.dir_setup_ns = 129;
        s.grbl.status_mask = 0xff;
        s.grbl.inches = true;
        s.grbl.door_spin_up_ms = u16::MAX;
        while s.grbl.startup[0].push('G').is_ok() {}
        while s.grbl.startup[1].push('\u{e9}').is_ok() {}
        s
    }

    /// The hand-written encoder writes postcard's bytes, and the decoder reads them back.
    #[test]
    fn the_blob_is_postcards_bytes() {
        let mut empty_lists = full();
        empty_lists.outputs.mcode_lists[3].commands.clear();
        empty_lists.grbl.startup[0].clear();
        for s in [Setup::default(), distinct(), full(), empty_lists] {
            let mut ours = [0u8; crate::setup::SETUP_BLOB_MAX];
            let len = encode(&s, &mut ours, 0, false).unwrap();
            let mut theirs = [0u8; crate::setup::SETUP_BLOB_MAX];
            let expected = postcard::to_slice(&(FORMAT, &s), &mut theirs).unwrap();
            assert_eq!(&ours[..len], &expected[..]);
            assert_eq!(decode(&ours[..len]), Some(s.clone()));
            // Too little room fails; a window of any part is the same bytes.
            assert_eq!(encode(&s, &mut ours[..len - 1], 0, false), None);
            let mut window = [0u8; 37];
            for from in (0..len).step_by(37) {
                assert_eq!(encode(&s, &mut window, from, true), Some(len));
                let n = (len - from).min(37);
                assert_eq!(&window[..n], &expected[from..from + n]);
            }
        }
    }

    /// The decoder accepts and refuses what postcard does: every truncation, trailing bytes,
    /// another format byte, and every byte of the blob replaced by values that make a varint
    /// longer, a bool or an enum out of range, a list longer or a string not UTF-8; and at every
    /// position, a byte replaced by overlong and too long varints.
    #[test]
    fn decoding_refuses_what_postcard_refuses() {
        let mut buf = [0u8; crate::setup::SETUP_BLOB_MAX];
        let varints: [&[u8]; 7] = [
            &[0x80, 0x00],
            &[0x80, 0x80, 0x00],
            &[0xff, 0xff, 0x03],
            &[0xff, 0xff, 0x04],
            &[0xff; 10],
            &[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01],
            &[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02],
        ];
        for s in [Setup::default(), full()] {
            let len = encode(&s, &mut buf, 0, false).unwrap();
            let blob = buf[..len].to_vec();
            let same = |bytes: &[u8]| {
                assert_eq!(decode(bytes), postcard_decode(bytes), "{bytes:x?}");
            };
            same(&blob);
            for n in 0..len {
                same(&blob[..n]);
            }
            let mut longer = blob.clone();
            longer.push(0);
            same(&longer);
            for format in [0, 4, 6, 255] {
                let mut other = blob.clone();
                other[0] = format;
                same(&other);
            }
            for i in 1..len {
                for v in [
                    0, 1, 2, 3, 4, 5, 6, 7, 0x10, 0x21, 0x40, 0x7f, 0x80, 0x81, 0xc3, 0xff,
                ] {
                    let mut other = blob.clone();
                    other[i] = v;
                    same(&other);
                }
                for extra in varints {
                    let mut other = blob[..i].to_vec();
                    other.extend_from_slice(extra);
                    other.extend_from_slice(&blob[i + 1..]);
                    same(&other);
                }
            }
        }
    }
}
