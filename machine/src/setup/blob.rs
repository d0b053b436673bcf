//! The setup's byte encoding for flash and the link: one format byte, then every field in
//! declaration order as a LEB128 varint (signed values zigzag-encoded first), variable-length
//! lists as their length and then their elements.
//!
//! One visitor ([`visit_setup`]) walks every field for both directions, so writing and reading
//! cannot drift apart, and each struct is destructured without `..`: a new field does not compile
//! until it is added here. A hand-written codec instead of serde + postcard: the derived
//! deserializer cost ~10 KiB of the F411's flash and a 13 KiB stack frame (every nested `Result`
//! moved the partly built `Setup`); this one is a few hundred bytes of calls into [`Codec`].
//!
//! Decoding is strict: a wrong format byte, a value beyond its field's range, an unknown enum
//! tag, a list longer than its capacity, a truncated blob or trailing bytes all fail.

use super::{
    AxisSetup, Dialect, DriverSetup, DwellUnits, HomingAxis, HomingSetup, InputSetup, JogSetup,
    LinkSetup, ListCommand, McodeList, OperatorSetup, OutputSetup, PathSetup, ProgramSetup, Setup,
    Tool,
};
use crate::gcode::RetractMode;
use heapless::Vec;

/// First byte of every blob: the encoding's version (1 was the serde/postcard encoding, which
/// had no such byte). Change it whenever the layout changes.
pub const FORMAT: u8 = 2;

/// The buffer a [`Codec`] reads from or writes to.
enum Buf<'a> {
    Read(&'a [u8]),
    /// Blob bytes `skip ..` go to `out`; with `clip`, bytes beyond `out` are dropped (a window
    /// of the blob), else they are an error.
    Write {
        out: &'a mut [u8],
        skip: usize,
        clip: bool,
    },
}

/// Reads or writes one value at a time. Every method takes the field by `&mut`: when writing it
/// encodes the value, when reading it overwrites it. After the first error (end of buffer, a
/// value out of range) it stops touching the buffer and [`Codec::ok`] stays false.
pub(super) struct Codec<'a> {
    buf: Buf<'a>,
    pos: usize,
    ok: bool,
}

impl<'a> Codec<'a> {
    pub(super) fn reader(bytes: &'a [u8]) -> Self {
        Codec {
            buf: Buf::Read(bytes),
            pos: 0,
            ok: true,
        }
    }

    pub(super) fn writer(out: &'a mut [u8]) -> Self {
        Codec {
            buf: Buf::Write {
                out,
                skip: 0,
                clip: false,
            },
            pos: 0,
            ok: true,
        }
    }

    /// A writer that keeps only blob bytes `from .. from + out.len()` (in `out`) and counts the
    /// rest.
    pub(super) fn window(out: &'a mut [u8], from: usize) -> Self {
        Codec {
            buf: Buf::Write {
                out,
                skip: from,
                clip: true,
            },
            pos: 0,
            ok: true,
        }
    }

    /// Bytes read, or the blob's length so far when writing.
    pub(super) fn len(&self) -> usize {
        self.pos
    }

    /// No error so far (and, when reading, every byte consumed if `finish` is true).
    pub(super) fn ok(&self, finish: bool) -> bool {
        self.ok
            && match &self.buf {
                Buf::Read(b) => !finish || self.pos == b.len(),
                Buf::Write { .. } => true,
            }
    }

    fn reading(&self) -> bool {
        matches!(self.buf, Buf::Read(_))
    }

    fn fail(&mut self) {
        self.ok = false;
    }

    /// The core of every field: an unsigned value up to `max` as a LEB128 varint.
    #[inline(never)]
    fn uint(&mut self, value: u64, max: u64) -> u64 {
        if !self.ok {
            return 0;
        }
        match &mut self.buf {
            Buf::Write { out, skip, clip } => {
                let mut v = value;
                loop {
                    let byte = if v < 0x80 { v as u8 } else { (v as u8) | 0x80 };
                    if self.pos >= *skip {
                        match out.get_mut(self.pos - *skip) {
                            Some(slot) => *slot = byte,
                            None if *clip => {}
                            None => {
                                self.ok = false;
                                return 0;
                            }
                        }
                    }
                    self.pos += 1;
                    if v < 0x80 {
                        return value;
                    }
                    v >>= 7;
                }
            }
            Buf::Read(bytes) => {
                let mut v = 0u64;
                let mut shift = 0;
                loop {
                    let Some(&b) = bytes.get(self.pos) else {
                        self.ok = false;
                        return 0;
                    };
                    self.pos += 1;
                    let bits = u64::from(b & 0x7f);
                    // 10 bytes at most, and the 10th may only hold the top bit.
                    if shift == 63 && bits > 1 {
                        self.ok = false;
                        return 0;
                    }
                    v |= bits << shift;
                    if b & 0x80 == 0 {
                        break;
                    }
                    shift += 7;
                    if shift > 63 {
                        self.ok = false;
                        return 0;
                    }
                }
                if v > max {
                    self.ok = false;
                    return 0;
                }
                v
            }
        }
    }

    fn u8(&mut self, v: &mut u8) {
        *v = self.uint(u64::from(*v), u64::from(u8::MAX)) as u8;
    }

    fn u16(&mut self, v: &mut u16) {
        *v = self.uint(u64::from(*v), u64::from(u16::MAX)) as u16;
    }

    fn u32(&mut self, v: &mut u32) {
        *v = self.uint(u64::from(*v), u64::from(u32::MAX)) as u32;
    }

    fn i64(&mut self, v: &mut i64) {
        let zigzag = ((*v << 1) ^ (*v >> 63)) as u64;
        let z = self.uint(zigzag, u64::MAX);
        *v = ((z >> 1) as i64) ^ -((z & 1) as i64);
    }

    fn bool(&mut self, v: &mut bool) {
        *v = self.uint(u64::from(*v), 1) != 0;
    }

    fn i64s(&mut self, v: &mut [i64]) {
        for x in v {
            self.i64(x);
        }
    }

    /// A list: its length (at most `N`), then each element through `f`. Reading fills it with
    /// `fill` first, so `f` always has an element to overwrite.
    fn vec<T: Clone, const N: usize>(
        &mut self,
        v: &mut Vec<T, N>,
        fill: T,
        mut f: impl FnMut(&mut Self, &mut T),
    ) {
        let n = self.uint(v.len() as u64, N as u64) as usize;
        if self.reading() {
            v.clear();
            // Cannot fail: n ≤ N was checked by `uint`.
            let _ = v.resize(n, fill);
        }
        for x in v.iter_mut() {
            f(self, x);
        }
    }
}

/// Writes or reads the whole setup (after the format byte).
pub(super) fn visit_setup(c: &mut Codec, s: &mut Setup) {
    let mut format = FORMAT;
    c.u8(&mut format);
    if format != FORMAT {
        c.fail();
    }
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
    } = s;
    c.u8(axis_count);
    for a in axes.iter_mut() {
        axis(c, a);
    }
    path_setup(c, path);
    program_setup(c, program);
    operator_setup(c, operator);
    input_setup(c, inputs);
    homing_setup(c, homing);
    jog_setup(c, jog);
    output_setup(c, outputs);
    let LinkSetup { host_lost_stop_s } = link;
    c.u16(host_lost_stop_s);
    let DriverSetup {
        step_pulse_ns,
        dir_setup_ns,
    } = drivers;
    c.u32(step_pulse_ns);
    c.u32(dir_setup_ns);
}

fn axis(c: &mut Codec, a: &mut AxisSetup) {
    let AxisSetup {
        steps,
        units_nm,
        max_rate,
        accel,
        start_speed,
        travel_min,
        travel_max,
        invert_dir,
    } = a;
    c.u32(steps);
    for v in [
        units_nm,
        max_rate,
        accel,
        start_speed,
        travel_min,
        travel_max,
    ] {
        c.i64(v);
    }
    c.bool(invert_dir);
}

fn path_setup(c: &mut Codec, p: &mut PathSetup) {
    let PathSetup {
        junction_deviation,
        feed_shift,
        chord_tolerance,
        arc_segment_angle_mdeg,
        arc_max_segments,
    } = p;
    c.i64(junction_deviation);
    c.i64(feed_shift);
    c.i64(chord_tolerance);
    c.u32(arc_segment_angle_mdeg);
    c.u32(arc_max_segments);
}

fn program_setup(c: &mut Codec, p: &mut ProgramSetup) {
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
    } = p;
    let mut d = match dialect {
        Dialect::Ngc => 0,
        Dialect::Gixa => 1,
    };
    c.u8(&mut d);
    *dialect = match d {
        0 => Dialect::Ngc,
        1 => Dialect::Gixa,
        _ => {
            c.fail();
            Dialect::Ngc
        }
    };
    let mut u = match dwell_units {
        DwellUnits::Seconds => 0,
        DwellUnits::Milliseconds => 1,
    };
    c.u8(&mut u);
    *dwell_units = match u {
        0 => DwellUnits::Seconds,
        1 => DwellUnits::Milliseconds,
        _ => {
            c.fail();
            DwellUnits::Seconds
        }
    };
    c.i64(peck_clearance);
    c.i64(chip_break_retract);
    let mut r = u8::from(*default_retract == RetractMode::RPlane);
    c.u8(&mut r);
    *default_retract = match r {
        0 => RetractMode::InitialLevel,
        1 => RetractMode::RPlane,
        _ => {
            c.fail();
            RetractMode::InitialLevel
        }
    };
    let blank = Tool {
        number: 0,
        length: 0,
        diameter: 0,
    };
    c.vec(tools, blank, |c, t| {
        let Tool {
            number,
            length,
            diameter,
        } = t;
        c.u32(number);
        c.i64(length);
        c.i64(diameter);
    });
    for o in work_offsets.iter_mut() {
        c.i64s(o);
    }
    c.i64s(g28_home);
    c.i64s(g30_home);
    c.vec(user_mcodes, 0, |c, m| c.u16(m));
}

fn operator_setup(c: &mut Codec, o: &mut OperatorSetup) {
    let OperatorSetup {
        resume_needs_cycle_start,
        two_hand_start,
        fro_low,
        fro_high,
        dry_run_feed,
    } = o;
    c.bool(resume_needs_cycle_start);
    c.bool(two_hand_start);
    c.u16(fro_low);
    c.u16(fro_high);
    c.i64(dry_run_feed);
}

fn input_setup(c: &mut Codec, i: &mut InputSetup) {
    let InputSetup {
        invert,
        debounce_ms,
        limit_min,
        limit_max,
        hard_limits,
        feed_hold,
        abort,
        fro_pot,
        adc_max,
    } = i;
    c.u32(invert);
    c.u8(debounce_ms);
    c.u8(limit_min);
    c.u8(limit_max);
    c.bool(hard_limits);
    c.bool(feed_hold);
    c.bool(abort);
    c.bool(fro_pot);
    c.u16(adc_max);
}

fn homing_setup(c: &mut Codec, h: &mut HomingSetup) {
    let HomingSetup {
        axes,
        required,
        before_seek,
        before_retract,
        after_retract,
    } = h;
    for a in axes.iter_mut() {
        let HomingAxis {
            priority,
            seek_low,
            seek_rate,
            retract,
            set_home,
            home_position,
        } = a;
        c.u8(priority);
        c.bool(seek_low);
        c.i64(seek_rate);
        c.i64(retract);
        c.bool(set_home);
        c.i64(home_position);
    }
    c.bool(required);
    for list in [before_seek, before_retract, after_retract] {
        c.vec(list, ListCommand::Seek, list_command);
    }
}

/// A list command as a tag and its three possible operands (unused ones are 0).
fn list_command(c: &mut Codec, cmd: &mut ListCommand) {
    let (mut tag, mut n, mut level, mut ms) = match *cmd {
        ListCommand::Set(n) => (0, n, false, 0),
        ListCommand::Clear(n) => (1, n, false, 0),
        ListCommand::DwellMs(ms) => (2, 0, false, ms),
        ListCommand::WaitInput {
            bit,
            level,
            timeout_ms,
        } => (3, bit, level, timeout_ms),
        ListCommand::DisableLimitReport => (4, 0, false, 0),
        ListCommand::Seek => (5, 0, false, 0),
    };
    c.u8(&mut tag);
    c.u8(&mut n);
    c.bool(&mut level);
    c.u16(&mut ms);
    *cmd = match tag {
        0 => ListCommand::Set(n),
        1 => ListCommand::Clear(n),
        2 => ListCommand::DwellMs(ms),
        3 => ListCommand::WaitInput {
            bit: n,
            level,
            timeout_ms: ms,
        },
        4 => ListCommand::DisableLimitReport,
        5 => ListCommand::Seek,
        _ => {
            c.fail();
            ListCommand::Seek
        }
    };
}

fn jog_setup(c: &mut Codec, j: &mut JogSetup) {
    let JogSetup {
        pairs,
        instant_speed,
        nudge_distance,
        nudge_interval_ms,
        analog_axes,
        analog_deadband,
        analog_max_speed,
    } = j;
    for p in pairs.iter_mut().flatten() {
        c.u8(p);
    }
    c.i64(instant_speed);
    c.i64(nudge_distance);
    c.u16(nudge_interval_ms);
    for a in analog_axes.iter_mut() {
        c.u8(a);
    }
    c.u16(analog_deadband);
    c.i64(analog_max_speed);
}

fn output_setup(c: &mut Codec, o: &mut OutputSetup) {
    let OutputSetup {
        spindle_min_rpm,
        spindle_max_rpm,
        pwm_max,
        pwm_min,
        mcode_lists,
    } = o;
    c.u32(spindle_min_rpm);
    c.u32(spindle_max_rpm);
    c.u16(pwm_max);
    c.u16(pwm_min);
    let blank = McodeList {
        code: 0,
        dry_run_disabled: false,
        commands: Vec::new(),
    };
    c.vec(mcode_lists, blank, |c, l| {
        let McodeList {
            code,
            dry_run_disabled,
            commands,
        } = l;
        c.u16(code);
        c.bool(dry_run_disabled);
        c.vec(commands, ListCommand::Seek, list_command);
    });
}
