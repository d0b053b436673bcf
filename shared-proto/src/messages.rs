//! Application messages carried by the link, in both directions.
//!
//! Every type here has a fixed maximum size (heapless strings and vectors, no
//! allocation) and is serialised by postcard through its serde derive ([`crate::codec`]). Each
//! message kind is declared once, with its lane, in [`wire_messages!`]: the enum, its variant
//! indices on the wire (declaration order) and [`Wire::lane`] all come from that one list. Each
//! message belongs to a
//! [`Lane`]: `Queued` messages are delivered in order and consume the
//! receiver's credit ([`Wire::charge`]: free queue slots, or the board's free line-ring bytes); `Realtime` messages travel on a
//! separate sequence space that bypasses the queue (see `docs/protocol.md`).
//!
//! Units: lengths in nanometres (`i64`, exact to 1 nm over ±10 m), feeds in
//! micrometres per minute, overrides in percent.

use heapless::Vec;
use serde::{de::DeserializeOwned, Deserialize, Serialize};

pub use crate::lines::{LineBatch, LINE_MAX};

/// Bytes per setup chunk (one USB packet of payload).
pub const SETUP_CHUNK_MAX: usize = 64;

/// Number of axes the wire format carries (X Y Z A B C).
pub const AXES: usize = 6;

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
pub trait Wire: Serialize + DeserializeOwned {
    /// The lane this message travels on.
    fn lane(&self) -> Lane;

    /// A position in the stream this message marks (the number of the last job line of a
    /// main-stream [`HostMessage::Lines`]). The receiving endpoint remembers the token of the
    /// last message it delivered and reports it in [`HelloAck::last_line`],
    /// so a restarted host knows where to continue.
    fn stream_token(&self) -> Option<u32> {
        None
    }

    /// What this message costs of the receiver's credit on its lane: one slot, except where the
    /// receiver counts otherwise (the board counts line bytes, [`HostMessage`]).
    fn charge(&self) -> u16 {
        1
    }
}

/// A jog command (realtime).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Jog {
    /// Request id, echoed in the board's [`BoardMsg::Answer`].
    pub id: u32,
    /// Axis index 0..AXES (X=0).
    pub axis: u8,
    /// Signed velocity in µm/min; the sign gives the direction.
    pub feed_um_min: i32,
    /// Distance to travel in nm; 0 = continuous until `JogStop`, kept alive by
    /// [`HostMessage::JogKeepalive`].
    pub distance_nm: u64,
}

/// Declares a message enum once: each variant is written as `Lane Variant` (its fields as in an
/// ordinary enum). The macro emits the enum (serde derive: the wire index is the declaration
/// order) and its [`Wire::lane`], so the list of kinds exists in one place.
macro_rules! wire_messages {
    (
        $(#[$meta:meta])*
        pub enum $name:ident $(<$g:ident>)? {
            $(
                $(#[$vmeta:meta])* $lane:ident $variant:ident
                $( ( $($tuple:tt)* ) )? $( { $($named:tt)* } )?
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
        pub enum $name $(<$g>)? {
            $( $(#[$vmeta])* $variant $( ( $($tuple)* ) )? $( { $($named)* } )? ),*
        }

        impl $(<$g>)? $name $(<$g>)? {
            /// The lane of this kind of message, from its declaration.
            fn declared_lane(&self) -> Lane {
                match self {
                    $( $name::$variant { .. } => Lane::$lane, )*
                }
            }
        }
    };
}

wire_messages! {
    /// Messages from the host to the board; `B` holds a batch's records ([`HostMsg`] on the
    /// host, [`BoardInbound`] for the board's realtime lane, which never carries lines).
    pub enum HostMessage<B> {
        /// Lines of the program, in file order, as records (`crate::lines`). `id` 0: the streamed
        /// job; else the program server's answer to the [`BoardMsg::ProgramRequest`] with that
        /// `id` (lines from the requested place on).
        Queued Lines { id: u16, records: B },
        /// Program server answer: no more lines follow for request `id` (end of the file), or the
        /// requested place does not exist (`found` false).
        Queued ProgramEnd { id: u16, found: bool },
        /// A chunk of the opaque setup blob at byte `offset`.
        Queued SetupChunk {
            offset: u32,
            bytes: Vec<u8, SETUP_CHUNK_MAX>,
        },
        /// The setup blob is complete: `len` bytes with CRC-32/ISO-HDLC `crc32`.
        /// The board validates and applies it (and writes flash only when idle), and answers
        /// with [`BoardMsg::Answer`] `{ id, .. }`.
        Queued SetupCommit { id: u32, len: u32, crc32: u32 },
        /// Ask the board to send its setup blob: answered by [`BoardMsg::Answer`] `{ id, 0 }`,
        /// then [`BoardMsg::SetupChunk`]s and a [`BoardMsg::SetupEnd`]. The answer marks where
        /// this request's transfer begins: a board keeps its unacknowledged frames across host
        /// sessions and sends them to the next host, so a transfer an earlier host asked for (and
        /// left before it acknowledged) can arrive first, whole and with a valid CRC, holding
        /// the setup as it was then.
        Queued SetupRequest { id: u32 },
        /// Start executing the streamed job from its first line; answered by
        /// [`BoardMsg::Answer`] `{ id, .. }` before any message of the job.
        Queued Start { id: u32 },
        /// Start (resume) the job from line `line_no`; the host replays the modal
        /// preamble as ordinary lines before it. Answered as [`HostMsg::Start`].
        Queued StartFromLine { id: u32, line_no: u32 },
        /// No more lines follow for this job (lets the board tell "done" from "starved").
        Queued EndOfJob,
        /// Decelerate on the path and hold.
        Realtime FeedHold,
        /// Resume from hold.
        Realtime Resume,
        /// Stop now, run the program-stop sequence, remember the resume point.
        Realtime Abort,
        /// Feed override in percent (10..=200).
        Realtime FeedOverride(u16),
        /// Rapid override in percent (e.g. 25, 50, 100).
        Realtime RapidOverride(u16),
        /// Jog one axis; answered by [`BoardMsg::Answer`] with [`Jog::id`].
        Realtime Jog(Jog),
        /// Stop jogging and flush jog motion.
        Realtime JogStop,
        /// Ask for a [`BoardMsg::Status`].
        Realtime StatusRequest,
        /// Clear an alarm lock; answered by [`BoardMsg::Answer`] `{ id, .. }`.
        Realtime Unlock { id: u32 },
        /// Run the homing cycle for the axes in the bit mask (bit 0 = X; 0 = all); answered by
        /// [`BoardMsg::Answer`] `{ id, .. }`.
        Realtime Home { id: u32, axes: u8 },
        /// A sender takes over the running job (`gantry stream --continue`). `gantry serve`
        /// makes that command the job's owner; the board counts its host as back after a
        /// [`HostMsg::OwnerLost`] (a sender's new connection already makes it ask for the lines
        /// it misses). It resumes nothing: a held job stays held until the operator resumes it.
        Realtime TakeOver,
        /// Spindle speed override in percent (the board clamps it to 10..=200); it scales the
        /// spindle output, the programmed S stays as programmed.
        Realtime SpindleOverride(u16),
        /// The continuous jog goes on: a sender holding a jog (`distance_nm` 0) sends this at
        /// least every 100 ms; the board ends the jog with a controlled stop when none came for
        /// 250 ms (its dead-man, docs/controller.md "Jogging"). Ignored without such a jog.
        /// Protocol 5.1: never sent to a 5.0 peer.
        Realtime JogKeepalive,
        /// The job's owner is lost though the link stays (protocol 5.1): `gantry serve` says so
        /// when the command that started the job (or took it over) went away without finishing
        /// it (killed, crashed, terminal closed). The board treats it exactly as a lost direct
        /// host (a dropped DTR): hold on the path, spindle and coolant off at rest, the alarm-20
        /// count of `link.host_lost_stop_s`, until a sender takes the job over
        /// ([`HostMsg::TakeOver`]).
        Realtime OwnerLost,
    }
}

/// Messages from the host as the host holds them (each batch's records inline).
pub type HostMsg = HostMessage<LineBatch>;

/// Host messages as the board's realtime lane decodes them: no room for records (the board takes
/// line batches in place from the frame, `channel::QueuedSink`; a batch on the realtime lane does
/// not decode).
pub type BoardInbound = HostMessage<heapless::Vec<u8, 0>>;

impl<B> Wire for HostMessage<B>
where
    B: Serialize + DeserializeOwned + core::ops::Deref<Target = [u8]>,
{
    fn lane(&self) -> Lane {
        self.declared_lane()
    }

    fn stream_token(&self) -> Option<u32> {
        match self {
            HostMessage::Lines { id: 0, records } => {
                crate::lines::records(records).last().map(|(n, _)| n)
            }
            _ => None,
        }
    }

    /// The board takes queued messages as they arrive: a batch costs the bytes its records take
    /// in the board's line ring, anything else nothing (it is handled at once); a realtime
    /// message costs a slot of the board's realtime queue.
    fn charge(&self) -> u16 {
        match self {
            HostMessage::Lines { records, .. } => records.len() as u16,
            m if m.lane() == Lane::Queued => 0,
            _ => 1,
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
    /// (`gantry_machine::board::AlarmCode`, grbl's numbering where the meaning is the same).
    Alarm {
        code: u16,
    },
    Homing,
    Check,
    /// A job stands at rest at its M6 for a manual tool change: put `tool` in the spindle, then
    /// cycle start or resume (docs/probing.md "Tool change"). Spindle and coolant are off.
    ToolChange {
        tool: u32,
    },
}

/// How a job ended, in [`BoardMsg::JobDone`].
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    /// It ran to its end (M2/M30 or the end of the program).
    Completed,
    /// A block was rejected (the `Error` before it says which).
    Failed,
    /// An abort (from any host command or the board's stop input) stopped it on its path.
    Aborted,
    /// An alarm ended it (the `Alarm` before it says which).
    Alarm,
}

/// Spindle direction as the board drives it.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpindleStatus {
    #[default]
    Off,
    Cw,
    Ccw,
}

/// The spindle and coolant outputs as the board drives them, and the tool in the spindle: what an
/// operator checks before reaching into the machine.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputsStatus {
    pub spindle: SpindleStatus,
    /// Programmed spindle speed (S), rpm; 0 with the spindle off. The speed commanded to the
    /// spindle is this times [`Status::spindle_override`] / 100.
    pub rpm: u32,
    pub mist: bool,
    pub flood: bool,
    /// Tool in the spindle (after M6); 0 = none.
    pub tool: u32,
    /// Laser mode (docs/laser-plasma.md): the beam's power now in per mille of full power
    /// (the PWM duty over `spindle.pwm_range[1]`; 0 when off); `None`: not a laser machine.
    pub laser_permille: Option<u16>,
    /// Plasma torch mode (docs/laser-plasma.md "Plasma"); `None`: not a torch machine.
    pub torch: Option<TorchStatus>,
}

/// A plasma torch's state (docs/laser-plasma.md "Plasma").
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct TorchStatus {
    /// The torch is fired (M3).
    pub on: bool,
    /// Fired, and the motion waits for arc-OK.
    pub waiting: bool,
    /// The job is held because the arc was lost while cutting (cycle start re-fires the torch).
    pub arc_lost: bool,
    /// Torch height correction now, nm (+ = up). The Z positions of the status leave it out:
    /// they are where the program put Z.
    pub thc_nm: i32,
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
    /// Spindle speed override, % (10..=200: one byte keeps the status at 200 bytes in the
    /// board's queues).
    pub spindle_override: u8,
    /// Programmed path speed of the block being executed, µm/min (a rapid: the machine's limit
    /// for it; 0 with nothing queued). `feed_um_min` is the actual speed.
    pub programmed_feed_um_min: u32,
    /// Work system of the block being executed: 0..=8 = G54..G59.3.
    pub work_system: u8,
    /// The block being executed is in inches (G20); else millimetres (G21).
    pub inch: bool,
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
    /// Spindle, coolant and tool.
    pub outputs: OutputsStatus,
    /// Time lost to starvation in the current or last job, ms: how long its planner had nothing
    /// queued while the program had lines to come, from its first motion on (docs/ports.md
    /// "Starvation").
    pub starved_ms: u32,
    /// The last probe move's result since power-up (`None` before the first).
    pub probe: Option<ProbeStatus>,
}

/// The result of a G38 probe move (docs/probing.md).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeStatus {
    /// Machine position (nm) where the probe changed state, or where the move ended without.
    pub machine_pos: [i64; AXES],
    /// The probe changed state (contact for G38.2/G38.3, release for G38.4/G38.5).
    pub success: bool,
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

wire_messages! {
    /// Messages from the board to the host.
    pub enum BoardMsg {
        /// Status report.
        Realtime Status(Status),
        /// Alarm raised (machine locked until unlock/home): `code` says why, `line` is the program
        /// line it concerns (0 = none; for alarm 2 the block that would have left the travel).
        Realtime Alarm { code: u16, line: u32 },
        /// A limit switch stopped motion: `axis` (0 = X), on its max side (`max`) or min side.
        /// Sent with alarm 1 for a hard limit, alone for a commanded switch hit inside a homing
        /// list.
        Realtime Limit { axis: u8, max: bool },
        /// The block of `line` was rejected: `code` says why, `column` where (0 = unknown).
        Queued Error { line: u32, code: u16, column: u16 },
        /// Execution reached `line` (a resume point the host may record); `id` is
        /// a board-chosen tag (e.g. an M-code mark).
        Queued Mark { line: u32, id: u32 },
        /// The interpreter jumped (M98/M99): stop serving the previous place and serve lines from
        /// `target` on as `Lines { id, .. }`. Lines for older ids are dropped by the board.
        Queued ProgramRequest { id: u16, target: ProgramTarget },
        /// A chunk of the board's setup blob at byte `offset` (after the answer to `SetupRequest`).
        Queued SetupChunk {
            offset: u32,
            bytes: Vec<u8, SETUP_CHUNK_MAX>,
        },
        /// The setup blob is complete: `len` bytes with CRC-32/ISO-HDLC `crc32`.
        Queued SetupEnd { len: u32, crc32: u32 },
        /// The answer to the request with this `id` (`Jog`, `Home`, `Unlock`, `Start`,
        /// `StartFromLine`, `SetupCommit`, `SetupRequest`): 0 = accepted, else why not (error 900 beyond the
        /// travel, 901 homing required, 902 busy, 903 invalid; for `SetupCommit` 1 = bad length
        /// or CRC, 2 = not a valid setup, 3 = not idle). Queued, after every message the board
        /// queued before it took the request: whatever the host receives on the queued lane
        /// before it is not about this request (an older command's, or another command's through
        /// `gantry serve`).
        Queued Answer { id: u32, code: u16 },
        /// The job ended; `line` is the last executed line, `end` says how.
        Queued JobDone { line: u32, end: JobEnd },
    }
}

impl Wire for BoardMsg {
    fn lane(&self) -> Lane {
        self.declared_lane()
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
    pub window: u16,
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
    /// Queued-lane receive capacity of the board: bytes of its line ring.
    pub rx_capacity: u16,
    /// Realtime-lane receive queue size of the board.
    pub rt_capacity: u16,
    /// Next host→board queued sequence number the board will deliver
    /// (= last delivered + 1).
    pub next_expected: u16,
    /// Same for the realtime lane.
    pub rt_next_expected: u16,
    /// Current credit of the queued lane: free bytes of the board's line ring.
    pub window: u16,
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
