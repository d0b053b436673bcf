//! Gantry wire protocol shared by the firmware and the host sender (no_std).
//!
//! * [`messages`]: what host and board say to each other ([`HostMsg`], [`BoardMsg`]).
//! * [`lines`]: the records that carry program lines, several per frame.
//! * [`codec`]: their bytes (postcard, serde derive).
//! * [`frame`]: COBS frames with a fixed header and CRC-32 ([`encode_frame`], [`FrameDecoder`]).
//! * [`crc`]: the frame check sequence.
//! * [`window`]: per-lane sliding windows (sequence numbers, acks, credit, retransmit).
//! * [`channel`]: the sans-IO [`Endpoint`] both sides run ([`HostEndpoint`], [`BoardEndpoint`]).
//! * [`fault`]: a deterministic lossy byte pipe for tests.
//!
//! The full specification is `docs/protocol.md`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]

pub mod channel;
pub mod codec;
pub mod crc;
pub mod fault;
pub mod frame;
pub mod lines;
pub mod messages;
pub mod setup_commit;
pub mod usb;
pub mod window;

pub use channel::{
    BoardEndpoint, Config, Endpoint, HostEndpoint, LinkEvent, LinkState, LinkStats, Role, SendError,
};
pub use frame::{encode_frame, Frame, FrameDecoder, Header, Kind, MAX_FRAME_LEN};
pub use messages::{
    BoardInbound, BoardMsg, Hello, HelloAck, HostMessage, HostMsg, JobEnd, Jog, Lane, LineBatch,
    MachineState, OutputsStatus, ProbeStatus, ProgramTarget, SpindleStatus, Status, TorchStatus,
    Wire, AXES, LINE_MAX,
};

/// Protocol version exchanged in the handshake: major in the high byte, minor
/// in the low byte. Endpoints connect only when the majors are equal (see
/// `docs/protocol.md`, version policy).
pub const PROTOCOL_VERSION: u16 = 0x0800;

/// The first version whose board takes [`HostMsg::JogKeepalive`] (a 5.0 board cannot decode it:
/// it would stand unacknowledged at the head of the realtime lane).
pub const JOG_KEEPALIVE_SINCE: u16 = 0x0501;

/// The first version whose board takes [`HostMsg::OwnerLost`] (a 5.0 board gets the feed hold
/// a server sent before).
pub const OWNER_LOST_SINCE: u16 = 0x0501;

/// True when two protocol versions can talk (same major).
pub const fn versions_compatible(a: u16, b: u16) -> bool {
    a >> 8 == b >> 8
}
