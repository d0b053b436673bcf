//! The board's side of the host link: moves protocol messages between a [`BoardEndpoint`] and the
//! [`Board`], and reports status and events back. Sans-IO: the owner feeds received bytes in,
//! drains frames out, and calls [`BoardLink::service`] from its main loop.

use crate::board::State;
use crate::board::{line_ring, Pushed};
use crate::board::{Board, BoardEvent, JobEnd, JumpTarget};
use crate::setup::{Setup, SETUP_BLOB_MAX};
use gantry_proto::channel::{QueuedSink, Refusal};
use gantry_proto::setup_commit::SetupRefusal;
use gantry_proto::{
    BoardEndpoint, BoardInbound, BoardMsg, Config, HostMessage, Lane, LinkEvent, MachineState,
    OutputsStatus, ProbeStatus, ProgramTarget, SpindleStatus, Status, TorchStatus,
};

// The line ring's free bytes are the link's credit, a `u16`.
const _: () = assert!(crate::board::LINE_RING <= u16::MAX as usize);

/// The protocol a connection speaks, told from its first byte and forgotten when the host
/// disconnects (DTR drop, port closed): Gantry's framed protocol or grbl 1.1's text
/// (`machine/src/device/grbl/`, docs/grbl.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkProtocol {
    /// Nothing received yet on this connection (the framed link runs meanwhile).
    Undecided,
    /// COBS frames (docs/protocol.md).
    Framed,
    /// grbl 1.1 text.
    Grbl,
}

impl LinkProtocol {
    /// The protocol the first bytes of a connection belong to, or `None` while they do not tell
    /// yet. A grbl sender sends printable text, TAB, CR/LF and realtime bytes (`?`, `!`, `~`,
    /// Ctrl-X, 0x80 and up), nothing else; a framed host sends COBS frames ending in 0x00. So:
    /// framed when the first byte is 0x00-0x09 (the delimiter, or the COBS code of a new
    /// endpoint's first frame, whose header has a zero byte among its first three), at a 0x00, or
    /// at any other control byte; grbl at a line end (CR/LF) or Ctrl-X after text only, or when
    /// more bytes than a frame holds came without a decision. A host that reconnects with its
    /// endpoint running on (any first byte) is told apart by its header's control bytes or its
    /// frame's 0x00.
    pub fn decide(bytes: &[u8]) -> Option<LinkProtocol> {
        if *bytes.first()? < 0x0A {
            return Some(LinkProtocol::Framed);
        }
        for &b in bytes {
            match b {
                b'\n' | b'\r' | 0x18 => return Some(LinkProtocol::Grbl),
                b'\t' | 0x20..=0x7E | 0x80..=0xFF => {}
                _ => return Some(LinkProtocol::Framed),
            }
        }
        (bytes.len() >= gantry_proto::MAX_FRAME_LEN).then_some(LinkProtocol::Grbl)
    }

    /// Undecided bytes that waited [`UNDECIDED_MS`]: a sender polling with realtime bytes alone
    /// (`?`, `!`, `~`, 0x80 and up) speaks grbl (a frame arrives whole, in one USB transfer).
    pub fn decide_after_wait(bytes: &[u8]) -> Option<LinkProtocol> {
        (!bytes.is_empty()
            && bytes
                .iter()
                .all(|&b| matches!(b, b'?' | b'!' | b'~' | 0x80..)))
        .then_some(LinkProtocol::Grbl)
    }
}

/// A USB full-speed bulk packet: what the board takes at once while a connection's protocol is
/// undecided ([`BoardLink::rx_room`]).
pub(crate) const RX_PACKET: usize = 64;

/// How long undecided realtime bytes wait for more before they count as grbl, ms.
pub(crate) const UNDECIDED_MS: u32 = 50;

/// Interval between unsolicited status reports, ms.
pub(crate) const STATUS_INTERVAL_MS: u32 = 100;

/// Silence after which the host counts as gone (four keepalive intervals), ms: the board then
/// holds a running job on its path (docs/controller.md "Host lost (alarm 20)") until a host reconnects and resumes it, or until
/// `link.host_lost_stop_s` (setup) have passed, when it ends the job with alarm 20 (also when
/// the operator resumed it locally and it then waits for lines the host cannot send).
pub const HOST_TIMEOUT_MS: u32 = 4 * Config::USB_MS.keepalive;

pub use super::kernel_view::KernelView;

/// The board's setup being sent to the host: each chunk is encoded from the live setup as it
/// goes out (no copy of the blob is kept); length and CRC are those of the blob at the request,
/// so a setup changed in the middle of the transfer fails the host's check instead of arriving
/// as a mixture.
struct SetupOut {
    len: usize,
    crc32: u32,
    /// Bytes already sent.
    sent: usize,
}

/// The setup blobs in transfer.
struct SetupTransfer {
    /// The setup blob being received from the host.
    incoming: heapless::Vec<u8, SETUP_BLOB_MAX>,
    outgoing: Option<SetupOut>,
    /// A new setup was applied: the firmware saves it to flash (when idle).
    changed: bool,
}

/// The framed link's host, as the board knows it during this power-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Host {
    /// No host has attached yet.
    Never,
    /// A host attached and has not gone silent since.
    Attached,
    /// The host went silent (its job is held; `link.host_lost_stop_s` counts).
    Lost,
    /// The host stays (`gantry serve`) but the job's owner behind it is gone
    /// (`HostMsg::OwnerLost`): the job is held as for a lost host and `link.host_lost_stop_s`
    /// counts, through the server's reconnections, until a sender takes the job over
    /// (`HostMsg::TakeOver`).
    OwnerLost,
}

/// Link endpoint + the glue to the board.
pub struct BoardLink {
    endpoint: BoardEndpoint,
    /// Messages for the host the send queue had no room for yet, oldest first.
    outbox: heapless::Deque<BoardMsg, 4>,
    /// When (ms) the last status report went out; `None` when one is due now whatever the
    /// interval: none sent yet, or the host asked (or attached) since the last one.
    last_status: Option<u32>,
    host: Host,
    /// Since when (ms) the job has been held, or waited for lines, with the host gone (alarm 20
    /// timer).
    unattended_since: Option<u32>,
    /// Setup blobs to and from the host.
    setup: SetupTransfer,
    /// The protocol of the current connection.
    protocol: LinkProtocol,
    /// The grbl front end (used while `protocol` is [`LinkProtocol::Grbl`]).
    grbl: super::grbl::Grbl,
    /// The first bytes of a connection while they do not tell its protocol, and since when.
    undecided: heapless::Vec<u8, { gantry_proto::MAX_FRAME_LEN }>,
    undecided_since: u32,
    /// Where the current connection stands before its first bytes.
    opening: Opening,
}

/// A connection before it has spoken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Opening {
    /// The board talks (power-up, or the connection has chosen its protocol).
    Talking,
    /// The host left (port closed, DTR dropped): the board sends nothing until a new
    /// connection has chosen its protocol by its first bytes, so a grbl client that opens the
    /// port next reads no frames meant for the host that left.
    Quiet,
    /// The port opened at `since` (DTR rose, a TCP client connected) and nothing came yet: the
    /// grbl banner goes out after [`GREET_MS`] of silence.
    Opened { since: u32 },
    /// The banner went out; still nothing received.
    Greeted,
}

/// Silence after the port opened before the board greets with grbl's banner, ms: a `gantry`
/// command speaks at once (its first frame within a few ms), a grbl sender that waits for the
/// banner gets it well within its own wait.
pub(crate) const GREET_MS: u32 = 250;

impl BoardLink {
    /// `boot_id` must differ at every power-up (the host detects board resets by it).
    pub fn new(boot_id: u32) -> Self {
        BoardLink {
            endpoint: BoardEndpoint::new_board(
                Config::USB_MS,
                boot_id,
                crate::board::LINE_RING as u16,
            ),
            outbox: heapless::Deque::new(),
            last_status: None,
            host: Host::Never,
            unattended_since: None,
            setup: SetupTransfer {
                incoming: heapless::Vec::new(),
                outgoing: None,
                changed: false,
            },
            protocol: LinkProtocol::Undecided,
            grbl: super::grbl::Grbl::new(),
            undecided: heapless::Vec::new(),
            undecided_since: 0,
            opening: Opening::Talking,
        }
    }

    /// The protocol of the current connection.
    pub fn protocol(&self) -> LinkProtocol {
        self.protocol
    }

    /// Bytes received from the host. The first bytes of a connection choose its protocol
    /// ([`LinkProtocol::decide`]); until they do, they wait here. Queued messages reach the
    /// board as they arrive (program lines into its line ring).
    pub fn on_bytes(&mut self, board: &mut Board, now_ms: u32, bytes: &[u8]) {
        if self.protocol == LinkProtocol::Undecided {
            if self.undecided.is_empty() {
                self.undecided_since = now_ms;
            }
            let mut rest = bytes;
            while let Some((&b, after)) = rest.split_first() {
                rest = after;
                let _ = self.undecided.push(b);
                if let Some(p) = LinkProtocol::decide(&self.undecided) {
                    self.choose(board, now_ms, p);
                    self.deliver(board, now_ms, rest);
                    return;
                }
            }
            return;
        }
        self.deliver(board, now_ms, bytes);
    }

    /// The connection speaks `p`: the bytes that waited go to it.
    fn choose(&mut self, board: &mut Board, now_ms: u32, p: LinkProtocol) {
        self.protocol = p;
        let greeted = core::mem::replace(&mut self.opening, Opening::Talking) == Opening::Greeted;
        if p == LinkProtocol::Grbl {
            self.grbl.connect(greeted);
        } else {
            // A greeting not yet sent is not for this host.
            self.grbl.forget_output();
        }
        let held = core::mem::take(&mut self.undecided);
        self.deliver(board, now_ms, &held);
    }

    fn deliver(&mut self, board: &mut Board, now_ms: u32, bytes: &[u8]) {
        match self.protocol {
            LinkProtocol::Grbl => self.grbl.on_bytes(bytes),
            _ => {
                let mut inbox = Inbox {
                    board,
                    setup: &mut self.setup,
                };
                self.endpoint.on_bytes(now_ms, bytes, &mut inbox);
            }
        }
    }

    /// Bytes the board can take from the port now without dropping any (the main loop reads no
    /// more: on the USB board the rest waits in the receive pipe, then in the endpoint, which the
    /// host's NAKs pace). grbl: the receive buffer's room (`device/grbl/rx.rs`); undecided: a packet,
    /// so that bytes a grbl decision hands to that buffer fit it; framed: no limit (the link's
    /// window paces the host).
    pub fn rx_room(&self) -> usize {
        match self.protocol {
            LinkProtocol::Grbl => self.grbl.rx_room(),
            LinkProtocol::Undecided => RX_PACKET,
            LinkProtocol::Framed => usize::MAX,
        }
    }

    /// The host closed the port (`dtr_dropped`: and dropped DTR; docs/controller.md "Host
    /// lost"). The next connection chooses its protocol again (a grbl client is greeted with the
    /// banner, a `gantry` command gets its handshake). A grbl sender is gone whichever way it
    /// closed (grbl has no job to take over): its job stops on its path and ends at rest with
    /// spindle and coolant off, an idle machine's spindle and coolant go off at once. A framed
    /// host that dropped DTR is lost: [`Board::host_lost`] (hold, outputs off at rest, the job
    /// kept for `gantry stream --continue`); one that kept DTR up (a one-shot command) leaves
    /// the machine as it is.
    pub(crate) fn port_closed(&mut self, board: &mut Board, dtr_dropped: bool) {
        match self.protocol {
            LinkProtocol::Grbl => {
                board.host_lost();
                self.grbl.disconnect(board);
            }
            _ if dtr_dropped => board.host_lost(),
            _ => {}
        }
        self.protocol = LinkProtocol::Undecided;
        self.undecided.clear();
        self.grbl.forget_output();
        self.opening = Opening::Quiet;
    }

    /// A host opened the port (DTR rose, a TCP client connected): with nothing received for
    /// [`GREET_MS`], the board greets with grbl's banner (docs/grbl.md "How a connection
    /// chooses").
    pub(crate) fn port_opened(&mut self, now_ms: u32) {
        if self.protocol == LinkProtocol::Undecided && self.undecided.is_empty() {
            self.opening = Opening::Opened { since: now_ms };
        }
    }

    /// The next bytes to send (call until `None`); `out` must hold `gantry_proto::MAX_FRAME_LEN`.
    pub fn poll_transmit(&mut self, now_ms: u32, out: &mut [u8]) -> Option<usize> {
        match self.protocol {
            LinkProtocol::Grbl => self.grbl.poll_transmit(out),
            LinkProtocol::Undecided => {
                // The greeting, if one is due; frames only for a host that has not left.
                if let Some(n) = self.grbl.poll_transmit(out) {
                    return Some(n);
                }
                match self.opening {
                    Opening::Talking => self.endpoint.poll_transmit(now_ms, out),
                    _ => None,
                }
            }
            LinkProtocol::Framed => self.endpoint.poll_transmit(now_ms, out),
        }
    }

    /// True while a host is attached and has been heard from recently.
    pub fn host_alive(&self, now_ms: u32) -> bool {
        self.host == Host::Attached
            && self
                .endpoint
                .peer_alive(now_ms, 4 * gantry_proto::Config::USB_MS.keepalive)
    }

    pub fn endpoint(&self) -> &BoardEndpoint {
        &self.endpoint
    }

    /// Delivers what the host sent to the board and sends what the board has to say.
    pub fn service(&mut self, board: &mut Board, now_ms: u32, view: &KernelView) {
        if self.protocol == LinkProtocol::Undecided
            && now_ms.wrapping_sub(self.undecided_since) >= UNDECIDED_MS
        {
            if let Some(p) = LinkProtocol::decide_after_wait(&self.undecided) {
                self.choose(board, now_ms, p);
            }
        }
        if let Opening::Opened { since } = self.opening {
            if self.protocol == LinkProtocol::Undecided
                && self.undecided.is_empty()
                && now_ms.wrapping_sub(since) >= GREET_MS
            {
                self.grbl.greet(board);
                self.opening = Opening::Greeted;
            }
        }
        if self.protocol == LinkProtocol::Grbl {
            self.grbl.service(board, view);
            return;
        }
        while let Some(ev) = self.endpoint.poll_event() {
            if let LinkEvent::HostAttached { .. } = ev {
                if self.host != Host::Never {
                    // A host came back (or a new one took over): it serves the job again from
                    // the line after the last one interpreted.
                    board.resync_stream();
                }
                // A server reconnecting for an ownerless job is still no owner.
                if self.host != Host::OwnerLost {
                    self.host = Host::Attached;
                }
                self.last_status = None;
            }
        }
        // The ownerless job ended (alarm 20, an abort, its end): the next job has its owner.
        if self.host == Host::OwnerLost
            && !matches!(board.state(), State::Run | State::Hold | State::ToolChange)
        {
            self.host = Host::Attached;
        }
        if self.host == Host::Attached && !self.endpoint.peer_alive(now_ms, HOST_TIMEOUT_MS) {
            self.host = Host::Lost;
            board.host_lost();
        }
        self.watch_unattended_job(board, now_ms);
        while let Some(msg) = self.endpoint.recv_realtime() {
            self.realtime(board, msg);
        }
        // Queued messages were taken as they arrived (`Inbox`); the credit is the line ring's
        // room now that the interpreter has taken lines out of it.
        self.endpoint
            .set_window(board.line_ring_free().min(u16::MAX as usize) as u16);
        self.send_events(board);
        self.send_setup(board);
        let due = self
            .last_status
            .is_none_or(|t| now_ms.wrapping_sub(t) >= STATUS_INTERVAL_MS);
        if due && self.endpoint.send_capacity(Lane::Realtime) > 0 {
            let status = status_of(board, view);
            if self.endpoint.send(BoardMsg::Status(status)).is_ok() {
                self.last_status = Some(now_ms);
            }
        }
    }

    /// Alarm 20: a job that stands still with the host gone — in a feed hold, or in Run at rest
    /// waiting for program lines only the host could send (the operator resumed it locally and
    /// it ran out of lines) — is ended once `link.host_lost_stop_s` have passed (counted from the
    /// later of the host loss and the start of the hold or wait). A returning host stops the
    /// count (it serves the job again); so does a local resume, until the job stands still
    /// again. An M0 / M1 stop (spindle and coolant already off) waits for its cycle start as
    /// programmed.
    fn watch_unattended_job(&mut self, board: &mut Board, now_ms: u32) {
        let limit_s = board.setup().link.host_lost_stop_s;
        let standing = board.feed_held() || board.waiting_for_lines();
        let unattended = matches!(self.host, Host::Lost | Host::OwnerLost);
        if !unattended || limit_s == 0 || !standing {
            self.unattended_since = None;
            return;
        }
        let since = *self.unattended_since.get_or_insert(now_ms);
        if now_ms.wrapping_sub(since) >= u32::from(limit_s) * 1000 {
            self.unattended_since = None;
            board.host_lost_stop();
        }
    }

    fn realtime(&mut self, board: &mut Board, msg: BoardInbound) {
        match msg {
            HostMessage::FeedHold => board.feed_hold(),
            HostMessage::Resume => board.resume(),
            HostMessage::Abort => board.abort(),
            HostMessage::FeedOverride(p) => board.set_feed_override(p),
            HostMessage::RapidOverride(p) => board.set_rapid_override(p),
            HostMessage::SpindleOverride(p) => board.set_spindle_override(p),
            HostMessage::StatusRequest => self.last_status = None,
            // Requests with an id are answered (`BoardMsg::Answer`), accepted or refused.
            HostMessage::Unlock { id } => {
                let r = board.try_unlock();
                answer(board, id, r);
            }
            HostMessage::Jog(j) => {
                let r = board.try_jog(j.axis, j.feed_um_min, j.distance_nm);
                answer(board, j.id, r);
            }
            HostMessage::JogStop => board.jog_stop(),
            HostMessage::JogKeepalive => board.jog_keepalive(),
            HostMessage::Home { id, axes } => {
                let r = board.try_home(axes);
                answer(board, id, r);
            }
            // The job's owner behind a server is gone: what a dropped DTR does.
            HostMessage::OwnerLost => {
                if self.host == Host::Attached {
                    self.host = Host::OwnerLost;
                }
                board.host_lost();
            }
            HostMessage::TakeOver if self.host == Host::OwnerLost => self.host = Host::Attached,
            _ => {}
        }
    }

    /// True once after a setup from the host was applied: the owner persists `board.setup()`.
    pub(crate) fn take_setup_changed(&mut self) -> bool {
        core::mem::take(&mut self.setup.changed) | self.grbl.take_setup_changed()
    }

    /// Sends the next chunks of an outgoing setup blob as the queue allows.
    fn send_setup(&mut self, board: &Board) {
        let Some(out) = self.setup.outgoing.as_mut() else {
            return;
        };
        while self.endpoint.send_capacity(Lane::Queued) > 0 {
            if out.sent >= out.len {
                let end = BoardMsg::SetupEnd {
                    len: out.len as u32,
                    crc32: out.crc32,
                };
                if self.endpoint.send(end).is_ok() {
                    self.setup.outgoing = None;
                }
                return;
            }
            let n = (out.len - out.sent).min(gantry_proto::messages::SETUP_CHUNK_MAX);
            let mut bytes = heapless::Vec::new();
            // Cannot fail: n ≤ SETUP_CHUNK_MAX, the Vec's capacity.
            let _ = bytes.resize(n, 0);
            // Fewer bytes only if the setup changed (shrank) meanwhile: the offsets keep counting
            // the requested blob, so the host's length or CRC check fails.
            let got = board.setup().blob_window(out.sent, &mut bytes);
            bytes.truncate(got);
            let chunk = BoardMsg::SetupChunk {
                offset: out.sent as u32,
                bytes,
            };
            if self.endpoint.send(chunk).is_err() {
                return;
            }
            out.sent += n;
        }
    }

    fn send_events(&mut self, board: &mut Board) {
        loop {
            let msg = match self.outbox.pop_front() {
                Some(m) => m,
                None => match board.take_event() {
                    Some(e) => event_message(e),
                    // Joystick Mark presses, for teach-in on the host (kept on the board, in
                    // its small queue, while no host listens).
                    None if self.host != Host::Attached => return,
                    None => match board.take_mark() {
                        Some(m) => BoardMsg::Mark {
                            line: board.line(),
                            id: m.id,
                        },
                        None => return,
                    },
                },
            };
            if let Err(gantry_proto::SendError::Full(m)) = self.endpoint.send(msg) {
                let _ = self.outbox.push_front(m);
                return;
            }
        }
    }
}

/// The board as the link's queued lane sees it while bytes arrive: each queued message is taken
/// at once, in order (docs/protocol.md "Flow control"): a line batch's records are checked and
/// copied into the board's line ring as they are, everything else is handled on the spot.
struct Inbox<'a> {
    board: &'a mut Board,
    setup: &'a mut SetupTransfer,
}

impl QueuedSink for Inbox<'_> {
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
        // Batches are read in place; anything else with the realtime lane's decoder (one
        // deserializer for the message enum in flash).
        let Some((id, records)) = gantry_proto::lines::batch_in_place(payload) else {
            let msg =
                gantry_proto::codec::decode::<BoardInbound>(payload).ok_or(Refusal::Undecodable)?;
            self.queued(msg);
            return Ok(None);
        };
        let (lines, last) = line_ring::check_run(records).ok_or(Refusal::Undecodable)?;
        match self.board.push_lines(id, records, lines) {
            Pushed::Full => Err(Refusal::NoRoom),
            Pushed::Stored | Pushed::Stale => Ok(if id == 0 { last } else { None }),
        }
    }

    fn room(&self) -> u16 {
        self.board.line_ring_free().min(u16::MAX as usize) as u16
    }
}

impl Inbox<'_> {
    fn queued(&mut self, msg: BoardInbound) {
        match msg {
            HostMessage::SetupChunk { offset, bytes } => {
                let rx = &mut self.setup.incoming;
                if offset == 0 {
                    rx.clear();
                }
                // Chunks arrive in order (queued lane); a gap or overflow fails at commit.
                if offset as usize == rx.len() && rx.extend_from_slice(&bytes).is_err() {
                    rx.clear();
                }
            }
            HostMessage::SetupCommit { id, len, crc32 } => {
                let blob = &self.setup.incoming;
                let result =
                    if blob.len() != len as usize || gantry_proto::crc::crc32(blob) != crc32 {
                        Err(SetupRefusal::Damaged)
                    } else {
                        match Setup::from_blob(blob) {
                            None => Err(SetupRefusal::Invalid),
                            Some(setup) => {
                                if self.board.set_setup(setup) {
                                    self.setup.changed = true;
                                    Ok(())
                                } else {
                                    Err(SetupRefusal::NotIdle)
                                }
                            }
                        }
                    };
                self.setup.incoming.clear();
                answer(self.board, id, result.map_err(SetupRefusal::code));
            }
            HostMessage::SetupRequest { id } => {
                let mut buf = [0u8; SETUP_BLOB_MAX];
                let result = match self.board.setup().to_blob(&mut buf) {
                    Some(blob) => {
                        self.setup.outgoing = Some(SetupOut {
                            len: blob.len(),
                            crc32: gantry_proto::crc::crc32(blob),
                            sent: 0,
                        });
                        Ok(())
                    }
                    None => Err(SetupRefusal::Invalid),
                };
                // Before the chunks (`BoardLink::service` sends the events, this answer among
                // them, before the transfer): what the host receives before it is no part of
                // this transfer (messages.rs `SetupRequest`).
                answer(self.board, id, result.map_err(SetupRefusal::code));
            }
            HostMessage::Start { id } | HostMessage::StartFromLine { id, .. } => {
                let r = self.board.try_start_job();
                answer(self.board, id, r);
            }
            HostMessage::ProgramEnd { id, .. } => self.board.end_of_lines(id),
            HostMessage::EndOfJob => self.board.end_of_lines(0),
            _ => {}
        }
    }
}

/// Answers the host request `id`: after every event emitted before (so the host can tell what
/// came before its request from what came after).
fn answer(board: &mut Board, id: u32, result: Result<(), u16>) {
    let code = match result {
        Ok(()) => 0,
        Err(code) => code,
    };
    board.emit(BoardEvent::Answer { id, code });
}

fn event_message(e: BoardEvent) -> BoardMsg {
    match e {
        BoardEvent::Answer { id, code } => BoardMsg::Answer { id, code },
        BoardEvent::Error { line, code, column } => BoardMsg::Error { line, code, column },
        BoardEvent::Alarm { code, line } => BoardMsg::Alarm {
            code: code as u16,
            line,
        },
        BoardEvent::Limit { axis, max } => BoardMsg::Limit { axis, max },
        BoardEvent::JobDone { line, end } => BoardMsg::JobDone {
            line,
            end: match end {
                JobEnd::Completed => gantry_proto::JobEnd::Completed,
                JobEnd::Failed => gantry_proto::JobEnd::Failed,
                JobEnd::Aborted => gantry_proto::JobEnd::Aborted,
                JobEnd::Alarm => gantry_proto::JobEnd::Alarm,
            },
        },
        BoardEvent::Jump(req) => BoardMsg::ProgramRequest {
            id: req.id,
            target: match req.target {
                JumpTarget::Program(p) => ProgramTarget::Program(p),
                JumpTarget::Sequence(n) => ProgramTarget::Sequence(n),
                JumpTarget::Line(n) => ProgramTarget::Line(n),
            },
        },
    }
}

/// The status report of the board as the kernel sees it now.
pub fn status_of(board: &Board, view: &KernelView) -> Status {
    // Z as the program put it: a torch's height correction is shown on its own.
    let machine = board.reported_position(&view.steps);
    let torch = board
        .torch_status()
        .map(|(on, waiting, arc_lost)| TorchStatus {
            on,
            waiting,
            arc_lost,
            thc_nm: board.thc_correction_nm(),
        });
    let modes = board.executing_modes();
    let work = modes.work_position(&machine);
    let state = match board.state() {
        State::Idle => MachineState::Idle,
        State::Run => MachineState::Run,
        State::Hold => MachineState::Hold {
            stopped: view.feed_um_min == 0,
        },
        State::Alarm => MachineState::Alarm {
            code: board.alarm().map_or(0, |a| a as u16),
        },
        State::Homing => MachineState::Homing,
        State::Jog => MachineState::Jog,
        State::Check => MachineState::Check,
        State::ToolChange => MachineState::ToolChange {
            tool: board.tool_change().unwrap_or(0),
        },
    };
    Status {
        state,
        machine_pos: machine,
        work_pos: work,
        feed_um_min: view.feed_um_min,
        feed_override: board.motion().planner().feed_override(),
        rapid_override: board.motion().planner().rapid_override(),
        spindle_override: board.spindle_override() as u8,
        programmed_feed_um_min: board.programmed_feed_um_min(),
        work_system: modes.work_system,
        inch: modes.inch,
        planner_fill: board.motion().planner().len() as u16,
        queue_fill: board.lines_buffered() as u16,
        line: board.line(),
        inputs: view.inputs,
        homed: board.homed(),
        outputs: OutputsStatus {
            torch,
            ..outputs_status(board.outputs(), laser_permille(board, view))
        },
        starved_ms: view.starved_ms,
        probe: board.probe_result().map(|p| ProbeStatus {
            machine_pos: p.position,
            success: p.success,
        }),
    }
}

/// Laser mode's beam power now, per mille of full power (`None`: not a laser machine).
pub(crate) fn laser_permille(board: &Board, view: &KernelView) -> Option<u16> {
    let o = &board.setup().outputs;
    o.laser.then(|| {
        let max = u32::from(o.pwm_max.max(1));
        ((u32::from(view.laser_duty).min(max) * 1000 + max / 2) / max) as u16
    })
}

/// The outputs part of a status report.
fn outputs_status(o: crate::board::Outputs, laser_permille: Option<u16>) -> OutputsStatus {
    use crate::canon::Spindle;
    OutputsStatus {
        spindle: match o.spindle {
            Spindle::Off => SpindleStatus::Off,
            Spindle::Cw => SpindleStatus::Cw,
            Spindle::Ccw => SpindleStatus::Ccw,
        },
        rpm: if o.spindle == Spindle::Off { 0 } else { o.rpm },
        mist: o.mist,
        flood: o.flood,
        tool: o.tool,
        laser_permille,
        torch: None,
    }
}
