//! Application messages carried by the link, in both directions.
//!
//! Every type here has a fixed maximum size (heapless strings and vectors, no
//! allocation) and is serialised in postcard's format (by [`crate::codec`]; the serde
//! derives serve host tools and tests). Each message belongs to a
//! [`Lane`]: `Queued` messages are delivered in order and consume the
//! receiver's credit (its free queue slots); `Realtime` messages travel on a
//! separate sequence space that bypasses the queue (see `docs/protocol.md`).
//!
//! Units: lengths in nanometres (`i64`, exact to 1 nm over ±10 m), feeds in
//! micrometres per minute, overrides in percent.

use crate::codec::{Codec, Visit};
use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

/// Longest G-code line (bytes) a [`Line`] carries.
///
/// 104 bytes is the largest text for which the worst-case `Line` frame
/// (9-byte header, 1-byte tag, 5-byte varint line number, 1-byte length,
/// text, 4-byte CRC, 1 byte of COBS overhead and the 0x00 delimiter = 126 B)
/// still fits in two 64-byte USB full-speed bulk packets. It is longer than
/// grbl's 80-byte line buffer; the host strips comments and blanks before
/// sending, so CAM output (typically < 60 bytes) fits with room to spare. A
/// longer line is an error reported by the host against that line.
pub const LINE_MAX: usize = 104;

/// Bytes per setup chunk (one USB packet of payload).
pub const SETUP_CHUNK_MAX: usize = 64;

/// Number of axes the wire format carries (X Y Z A B C).
pub const AXES: usize = 6;

/// Text of one G-code line.
pub type LineText = String<LINE_MAX>;

/// Which path a message takes through the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    /// Ordered, credit-limited, delivered through the receiver's queue.
    Queued,
    /// Ordered among realtime messages only; delivered at once, no credit needed
    /// from the application queue.
    Realtime,
}

/// A message type the link can carry.
pub trait Wire: Visit {
    /// The lane this message travels on.
    fn lane(&self) -> Lane;

    /// A position in the stream this message marks (the job line number for
    /// [`HostMsg::Line`]). The receiving endpoint remembers the token of the
    /// last message it delivered and reports it in [`HelloAck::last_line`],
    /// so a restarted host knows where to continue.
    fn stream_token(&self) -> Option<u32> {
        None
    }
}

/// One G-code line of the streamed job.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
pub struct Line {
    /// Line number in the host's file (1-based), used in errors and status.
    pub line_no: u32,
    /// The text, comments and blanks stripped by the host.
    pub text: LineText,
}

impl Line {
    /// Builds a line; `None` when `text` is longer than [`LINE_MAX`].
    pub fn new(line_no: u32, text: &str) -> Option<Self> {
        Some(Self {
            line_no,
            text: LineText::try_from(text).ok()?,
        })
    }
}

/// A jog command (realtime).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Jog {
    /// Axis index 0..AXES (X=0).
    pub axis: u8,
    /// Signed velocity in µm/min; the sign gives the direction.
    pub feed_um_min: i32,
    /// Distance to travel in nm; 0 = continuous until `JogStop`.
    pub distance_nm: u64,
}

/// Messages from the host to the board.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
pub enum HostMsg {
    // ---- queued ----
    /// A line of the streamed job.
    Line(Line),
    /// Program server answer to the [`BoardMsg::ProgramRequest`] with the same `id`: the
    /// next line from the requested place on (lines are sent in file order).
    ProgramLine { id: u16, line: Line },
    /// Program server answer: no more lines follow for request `id` (end of the file), or the
    /// requested place does not exist (`found` false).
    ProgramEnd { id: u16, found: bool },
    /// A chunk of the opaque setup blob at byte `offset`.
    SetupChunk {
        offset: u32,
        bytes: Vec<u8, SETUP_CHUNK_MAX>,
    },
    /// The setup blob is complete: `len` bytes with CRC-32/ISO-HDLC `crc32`.
    /// The board validates and applies it (and writes flash only when idle).
    SetupCommit { len: u32, crc32: u32 },
    /// Ask the board to send its setup blob (as [`BoardMsg::SetupChunk`]s and a
    /// [`BoardMsg::SetupEnd`]).
    SetupRequest,
    /// Start executing the streamed job from its first line.
    Start,
    /// Start (resume) the job from line `line_no`; the host replays the modal
    /// preamble as ordinary lines before it.
    StartFromLine { line_no: u32 },
    /// No more lines follow for this job (lets the board tell "done" from "starved").
    EndOfJob,
    // ---- realtime ----
    /// Decelerate on the path and hold.
    FeedHold,
    /// Resume from hold.
    Resume,
    /// Stop now, run the program-stop sequence, remember the resume point.
    Abort,
    /// Feed override in percent (10..=200).
    FeedOverride(u16),
    /// Rapid override in percent (e.g. 25, 50, 100).
    RapidOverride(u16),
    /// Jog one axis.
    Jog(Jog),
    /// Stop jogging and flush jog motion.
    JogStop,
    /// Ask for a [`BoardMsg::Status`].
    StatusRequest,
    /// Clear an alarm lock.
    Unlock,
    /// Run the homing cycle for the axes in the bit mask (bit 0 = X; 0 = all).
    Home { axes: u8 },
}

impl Wire for HostMsg {
    fn lane(&self) -> Lane {
        use HostMsg::*;
        match self {
            Line(_)
            | ProgramLine { .. }
            | ProgramEnd { .. }
            | SetupChunk { .. }
            | SetupCommit { .. }
            | SetupRequest
            | Start
            | StartFromLine { .. }
            | EndOfJob => Lane::Queued,
            FeedHold
            | Resume
            | Abort
            | FeedOverride(_)
            | RapidOverride(_)
            | Jog(_)
            | JogStop
            | StatusRequest
            | Unlock
            | Home { .. } => Lane::Realtime,
        }
    }

    fn stream_token(&self) -> Option<u32> {
        match self {
            HostMsg::Line(l) => Some(l.line_no),
            _ => None,
        }
    }
}

/// Controller state as reported in [`Status`].
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MachineState {
    Idle,
    Run,
    /// Feed hold; `stopped` once motion has come to rest.
    Hold {
        stopped: bool,
    },
    Jog,
    /// Motion refused until unlock (and homing where required); `code` is the alarm number
    /// (`gantry_machine::controller::AlarmCode`, grbl's numbering where the meaning is the same).
    Alarm {
        code: u16,
    },
    Homing,
    Check,
}

/// Periodic or requested status report.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
pub struct Status {
    pub state: MachineState,
    /// Machine position, nm.
    pub machine_pos: [i64; AXES],
    /// Work position (machine minus active offsets), nm.
    pub work_pos: [i64; AXES],
    /// Current feed, µm/min.
    pub feed_um_min: u32,
    /// Feed override, %.
    pub feed_override: u16,
    /// Rapid override, %.
    pub rapid_override: u16,
    /// Planner blocks in use.
    pub planner_fill: u16,
    /// Link queue slots in use (lines received but not yet interpreted).
    pub queue_fill: u16,
    /// Line number of the block being executed.
    pub line: u32,
    /// Input pins (bit per input: limits, probe, hold, start, ...).
    pub inputs: u32,
    /// Homed axes (bit 0 = X).
    pub homed: u8,
}

/// Where a [`BoardMsg::ProgramRequest`] asks the host to continue serving lines.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgramTarget {
    /// The `O<program>` line of a subprogram (RS274NGC/Fanuc `M98 P<program>`).
    Program(u32),
    /// The first block with N word `n` (gixa subroutines are addressed by N).
    Sequence(u32),
    /// Line `n` of the file (1-based): the return from `M99`, or `1` for a restart.
    Line(u32),
}

/// Messages from the board to the host.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
pub enum BoardMsg {
    // ---- realtime ----
    /// Status report.
    Status(Status),
    /// Alarm raised (machine locked until unlock/home): `code` says why, `line` is the program
    /// line it concerns (0 = none; for alarm 2 the block that would have left the travel).
    Alarm { code: u16, line: u32 },
    /// A limit switch stopped motion: `axis` (0 = X), on its max side (`max`) or min side. Sent
    /// with alarm 1 for a hard limit, alone for a commanded switch hit inside a homing list.
    Limit { axis: u8, max: bool },
    // ---- queued ----
    /// The block of `line` was rejected: `code` says why, `column` where (0 = unknown).
    Error { line: u32, code: u16, column: u16 },
    /// Execution reached `line` (a resume point the host may record); `id` is
    /// a board-chosen tag (e.g. an M-code mark).
    Mark { line: u32, id: u32 },
    /// The interpreter jumped (M98/M99): stop serving the previous place and serve lines from
    /// `target` on as `ProgramLine { id, .. }`. Lines for older ids are dropped by the board.
    ProgramRequest { id: u16, target: ProgramTarget },
    /// A chunk of the board's setup blob at byte `offset` (answer to `SetupRequest`).
    SetupChunk {
        offset: u32,
        bytes: Vec<u8, SETUP_CHUNK_MAX>,
    },
    /// The setup blob is complete: `len` bytes with CRC-32/ISO-HDLC `crc32`.
    SetupEnd { len: u32, crc32: u32 },
    /// Answer to `SetupCommit`: 0 = applied (and saved), else why not (1 = bad length or CRC,
    /// 2 = not a valid setup, 3 = not idle).
    SetupResult { code: u16 },
    /// The job finished; `line` is the last executed line.
    JobDone { line: u32 },
}

impl Wire for BoardMsg {
    fn lane(&self) -> Lane {
        match self {
            BoardMsg::Status(_) | BoardMsg::Alarm { .. } | BoardMsg::Limit { .. } => Lane::Realtime,
            _ => Lane::Queued,
        }
    }
}

/// Handshake request (host → board), sent in a `Hello` control frame.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hello {
    /// The host's [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Random per-attempt value echoed in the answer, so stale answers are ignored.
    pub nonce: u32,
    /// Free slots of the host's queued-lane receive queue.
    pub window: u8,
    /// Free slots of the host's realtime-lane receive queue.
    pub rt_window: u8,
}

/// Handshake answer (board → host), sent in a `HelloAck` control frame. It
/// tells the host where both sequence spaces stand so it can continue
/// without loss or repetition.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct HelloAck {
    /// The board's [`crate::PROTOCOL_VERSION`].
    pub version: u16,
    /// Echo of [`Hello::nonce`].
    pub nonce: u32,
    /// Identifies this power-up of the board; a change means the board reset.
    pub boot_id: u32,
    /// Queued-lane receive queue size (slots) of the board.
    pub rx_capacity: u16,
    /// Realtime-lane receive queue size of the board.
    pub rt_capacity: u16,
    /// Next host→board queued sequence number the board will deliver
    /// (= last delivered + 1).
    pub next_expected: u16,
    /// Same for the realtime lane.
    pub rt_next_expected: u16,
    /// Current free slots (credit) of the queued lane.
    pub window: u8,
    /// Current free slots of the realtime lane.
    pub rt_window: u8,
    /// Oldest board→host queued sequence number not yet acknowledged.
    pub tx_base: u16,
    /// Same for the realtime lane.
    pub rt_tx_base: u16,
    /// `line_no` of the last job [`Line`] the board delivered (0 = none): a
    /// restarted host continues the job with the line after it.
    pub last_line: u32,
}

// ---- wire form (postcard's layout: fields in declaration order, variants by index) ----

impl Visit for Line {
    fn blank() -> Self {
        Line {
            line_no: 0,
            text: LineText::new(),
        }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        let Line { line_no, text } = self;
        c.u32(line_no);
        c.str(text);
    }
}

impl Visit for Jog {
    fn blank() -> Self {
        Jog {
            axis: 0,
            feed_um_min: 0,
            distance_nm: 0,
        }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        let Jog {
            axis,
            feed_um_min,
            distance_nm,
        } = self;
        c.u8(axis);
        c.i32(feed_um_min);
        c.u64(distance_nm);
    }
}

impl HostMsg {
    /// A value of variant `i` (declaration order) with blank fields.
    fn variant(i: u32) -> Option<Self> {
        use HostMsg::*;
        Some(match i {
            0 => Line(crate::Line::blank()),
            1 => ProgramLine {
                id: 0,
                line: crate::Line::blank(),
            },
            2 => ProgramEnd {
                id: 0,
                found: false,
            },
            3 => SetupChunk {
                offset: 0,
                bytes: Vec::new(),
            },
            4 => SetupCommit { len: 0, crc32: 0 },
            5 => SetupRequest,
            6 => Start,
            7 => StartFromLine { line_no: 0 },
            8 => EndOfJob,
            9 => FeedHold,
            10 => Resume,
            11 => Abort,
            12 => FeedOverride(0),
            13 => RapidOverride(0),
            14 => Jog(crate::Jog::blank()),
            15 => JogStop,
            16 => StatusRequest,
            17 => Unlock,
            18 => Home { axes: 0 },
            _ => return None,
        })
    }

    fn index(&self) -> u32 {
        use HostMsg::*;
        match self {
            Line(_) => 0,
            ProgramLine { .. } => 1,
            ProgramEnd { .. } => 2,
            SetupChunk { .. } => 3,
            SetupCommit { .. } => 4,
            SetupRequest => 5,
            Start => 6,
            StartFromLine { .. } => 7,
            EndOfJob => 8,
            FeedHold => 9,
            Resume => 10,
            Abort => 11,
            FeedOverride(_) => 12,
            RapidOverride(_) => 13,
            Jog(_) => 14,
            JogStop => 15,
            StatusRequest => 16,
            Unlock => 17,
            Home { .. } => 18,
        }
    }
}

impl Visit for HostMsg {
    fn blank() -> Self {
        HostMsg::SetupRequest
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        use HostMsg::*;
        let mut i = self.index();
        c.variant(&mut i);
        if c.reading() {
            match Self::variant(i) {
                Some(v) => *self = v,
                None => return c.fail(),
            }
        }
        match self {
            Line(l) => l.visit(c),
            ProgramLine { id, line } => {
                c.u16(id);
                line.visit(c);
            }
            ProgramEnd { id, found } => {
                c.u16(id);
                c.bool(found);
            }
            SetupChunk { offset, bytes } => {
                c.u32(offset);
                c.bytes(bytes);
            }
            SetupCommit { len, crc32 } => {
                c.u32(len);
                c.u32(crc32);
            }
            StartFromLine { line_no } => c.u32(line_no),
            FeedOverride(p) | RapidOverride(p) => c.u16(p),
            Jog(j) => j.visit(c),
            Home { axes } => c.u8(axes),
            SetupRequest | Start | EndOfJob | FeedHold | Resume | Abort | JogStop
            | StatusRequest | Unlock => {}
        }
    }
}

impl Visit for MachineState {
    fn blank() -> Self {
        MachineState::Idle
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        use MachineState::*;
        let mut i = match self {
            Idle => 0,
            Run => 1,
            Hold { .. } => 2,
            Jog => 3,
            Alarm { .. } => 4,
            Homing => 5,
            Check => 6,
        };
        c.variant(&mut i);
        if c.reading() {
            *self = match i {
                0 => Idle,
                1 => Run,
                2 => Hold { stopped: false },
                3 => Jog,
                4 => Alarm { code: 0 },
                5 => Homing,
                6 => Check,
                _ => return c.fail(),
            };
        }
        match self {
            Hold { stopped } => c.bool(stopped),
            Alarm { code } => c.u16(code),
            Idle | Run | Jog | Homing | Check => {}
        }
    }
}

impl Visit for Status {
    fn blank() -> Self {
        Status {
            state: MachineState::Idle,
            machine_pos: [0; AXES],
            work_pos: [0; AXES],
            feed_um_min: 0,
            feed_override: 0,
            rapid_override: 0,
            planner_fill: 0,
            queue_fill: 0,
            line: 0,
            inputs: 0,
            homed: 0,
        }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        let Status {
            state,
            machine_pos,
            work_pos,
            feed_um_min,
            feed_override,
            rapid_override,
            planner_fill,
            queue_fill,
            line,
            inputs,
            homed,
        } = self;
        state.visit(c);
        for p in machine_pos.iter_mut().chain(work_pos.iter_mut()) {
            c.i64(p);
        }
        c.u32(feed_um_min);
        c.u16(feed_override);
        c.u16(rapid_override);
        c.u16(planner_fill);
        c.u16(queue_fill);
        c.u32(line);
        c.u32(inputs);
        c.u8(homed);
    }
}

impl Visit for ProgramTarget {
    fn blank() -> Self {
        ProgramTarget::Line(0)
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        use ProgramTarget::*;
        let (mut i, mut n) = match *self {
            Program(n) => (0, n),
            Sequence(n) => (1, n),
            Line(n) => (2, n),
        };
        c.variant(&mut i);
        c.u32(&mut n);
        *self = match i {
            0 => Program(n),
            1 => Sequence(n),
            2 => Line(n),
            _ => return c.fail(),
        };
    }
}

impl Visit for BoardMsg {
    fn blank() -> Self {
        BoardMsg::JobDone { line: 0 }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        use BoardMsg::*;
        let mut i = match self {
            Status(_) => 0,
            Alarm { .. } => 1,
            Limit { .. } => 2,
            Error { .. } => 3,
            Mark { .. } => 4,
            ProgramRequest { .. } => 5,
            SetupChunk { .. } => 6,
            SetupEnd { .. } => 7,
            SetupResult { .. } => 8,
            JobDone { .. } => 9,
        };
        c.variant(&mut i);
        if c.reading() {
            *self = match i {
                0 => Status(crate::Status::blank()),
                1 => Alarm { code: 0, line: 0 },
                2 => Limit {
                    axis: 0,
                    max: false,
                },
                3 => Error {
                    line: 0,
                    code: 0,
                    column: 0,
                },
                4 => Mark { line: 0, id: 0 },
                5 => ProgramRequest {
                    id: 0,
                    target: ProgramTarget::blank(),
                },
                6 => SetupChunk {
                    offset: 0,
                    bytes: Vec::new(),
                },
                7 => SetupEnd { len: 0, crc32: 0 },
                8 => SetupResult { code: 0 },
                9 => JobDone { line: 0 },
                _ => return c.fail(),
            };
        }
        match self {
            Status(s) => s.visit(c),
            Alarm { code, line } => {
                c.u16(code);
                c.u32(line);
            }
            Limit { axis, max } => {
                c.u8(axis);
                c.bool(max);
            }
            Error { line, code, column } => {
                c.u32(line);
                c.u16(code);
                c.u16(column);
            }
            Mark { line, id } => {
                c.u32(line);
                c.u32(id);
            }
            ProgramRequest { id, target } => {
                c.u16(id);
                target.visit(c);
            }
            SetupChunk { offset, bytes } => {
                c.u32(offset);
                c.bytes(bytes);
            }
            SetupEnd { len, crc32 } => {
                c.u32(len);
                c.u32(crc32);
            }
            SetupResult { code } => c.u16(code),
            JobDone { line } => c.u32(line),
        }
    }
}

impl Visit for Hello {
    fn blank() -> Self {
        Hello {
            version: 0,
            nonce: 0,
            window: 0,
            rt_window: 0,
        }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        let Hello {
            version,
            nonce,
            window,
            rt_window,
        } = self;
        c.u16(version);
        c.u32(nonce);
        c.u8(window);
        c.u8(rt_window);
    }
}

impl Visit for HelloAck {
    fn blank() -> Self {
        HelloAck {
            version: 0,
            nonce: 0,
            boot_id: 0,
            rx_capacity: 0,
            rt_capacity: 0,
            next_expected: 0,
            rt_next_expected: 0,
            window: 0,
            rt_window: 0,
            tx_base: 0,
            rt_tx_base: 0,
            last_line: 0,
        }
    }
    fn visit(&mut self, c: &mut Codec<'_>) {
        let HelloAck {
            version,
            nonce,
            boot_id,
            rx_capacity,
            rt_capacity,
            next_expected,
            rt_next_expected,
            window,
            rt_window,
            tx_base,
            rt_tx_base,
            last_line,
        } = self;
        c.u16(version);
        c.u32(nonce);
        c.u32(boot_id);
        c.u16(rx_capacity);
        c.u16(rt_capacity);
        c.u16(next_expected);
        c.u16(rt_next_expected);
        c.u8(window);
        c.u8(rt_window);
        c.u16(tx_base);
        c.u16(rt_tx_base);
        c.u32(last_line);
    }
}
