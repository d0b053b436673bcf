//! The reliable link endpoint: a sans-IO state machine run unchanged by the
//! firmware (role `Board`) and by the host sender (role `Host`).
//!
//! The caller owns the byte pipe and the clock. It feeds received bytes to
//! [`Endpoint::on_bytes`], asks [`Endpoint::poll_transmit`] for frames to
//! write until it returns `None` (calling it again whenever time passes or
//! bytes arrive), queues outgoing messages with [`Endpoint::send`] and takes
//! incoming ones with [`Endpoint::recv`]. Time is a free-running `u32`
//! (milliseconds recommended) passed into every call; it may wrap.
//!
//! Two lanes share the frames (see [`crate::window`]): the queued lane
//! (credit = free slots of the host's queue, or free bytes of the board's line
//! ring: the board takes each queued message as it arrives, through a
//! [`QueuedSink`]) and the realtime lane (its own sequence space and a small
//! window; never waits behind queued data, transmitted first, handed out first
//! by `recv`). Handshake, reconnect and
//! the boot-id reset detection are described in `docs/protocol.md`.

use crate::frame::{
    encode_frame, DecoderStats, FrameDecoder, Header, Kind, FLAG_NAK, FLAG_POLL, FLAG_RT_NAK,
    MAX_FRAME_LEN, MAX_PAYLOAD,
};
use crate::messages::{BoardInbound, BoardMsg, Hello, HelloAck, HostMsg, Lane, Wire};
use crate::window::{seq_before, DirectLane, QueuedRecv, RecvLane, RxOutcome, SendLane};
use crate::{versions_compatible, PROTOCOL_VERSION};
use heapless::Deque;

/// Timing parameters, in the caller's time unit (milliseconds recommended).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Retransmission timeout for an unacknowledged frame; also the interval
    /// of window probes while blocked.
    pub rto: u32,
    /// Interval between `Hello` attempts while connecting.
    pub hello_interval: u32,
    /// Idle interval after which a keepalive probe is sent (0 = never).
    pub keepalive: u32,
}

impl Config {
    /// Values for USB full speed in milliseconds: USB round trips are 1-3 ms,
    /// so a 50 ms timeout retransmits quickly without spurious resends.
    pub const USB_MS: Config = Config {
        rto: 50,
        hello_interval: 100,
        keepalive: 250,
    };
}

impl Default for Config {
    fn default() -> Self {
        Self::USB_MS
    }
}

/// Which end of the link this endpoint is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Initiates the handshake (the host sender).
    Host,
    /// Answers it and keeps its state across host sessions (the board).
    Board,
}

/// Connection state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkState {
    /// Board: no host has said `Hello` since power-up.
    Unsynced,
    /// Host: sending `Hello` and waiting for the answer.
    Connecting,
    /// Sequenced traffic flows.
    Up,
    /// Host: the board speaks an incompatible protocol version.
    Incompatible { peer_version: u16 },
}

/// Things the application may want to know about the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkEvent {
    /// Host: the handshake completed. `board_reset` is true when the board's
    /// boot id changed since the last handshake: it restarted, and messages
    /// still queued here were renumbered and will be sent to it again.
    Connected { ack: HelloAck, board_reset: bool },
    /// Board: a host said `Hello` (first connection or reconnection).
    HostAttached { nonce: u32 },
    /// Host: the board has no session with us (it restarted); reconnecting.
    Desynced,
    /// Host: the board's protocol version is incompatible.
    VersionMismatch { peer_version: u16 },
}

/// Why [`Endpoint::send`] refused a message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SendError<T> {
    /// The lane's send queue is full; try again after acks arrive.
    Full(T),
}

impl<T> core::fmt::Display for SendError<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("link send queue full")
    }
}

#[cfg(feature = "std")]
impl<T: core::fmt::Debug> std::error::Error for SendError<T> {}

/// Counters for diagnostics and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    pub frames_tx: u32,
    pub frames_rx: u32,
    /// Retransmitted frames (both lanes).
    pub retransmits: u32,
    /// CRC-valid frames whose payload did not decode (version skew or bug).
    pub undecodable: u32,
    /// Frames the encoder could not build (a message over `MAX_PAYLOAD`).
    pub encode_errors: u32,
    /// Messages delivered (both lanes).
    pub delivered: u32,
    /// Duplicate frames dropped (both lanes).
    pub duplicates: u32,
    /// Frames beyond the advertised window (both lanes); 0 between two
    /// correct endpoints.
    pub window_violations: u32,
    /// Frame decoder counters.
    pub decoder: DecoderStats,
}

const EVENTS: usize = 4;

/// Why a [`QueuedSink`] did not take a message (it is not acknowledged; the peer sends it again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// It does not fit in the room the sink has (the peer exceeded the credit).
    NoRoom,
    /// Its bytes are not a message (version skew or a bug).
    Undecodable,
}

/// Where an endpoint with a [`DirectLane`] (the board's) hands each queued message, in order, as
/// its payload bytes: the application decodes it in place and keeps what it needs.
pub trait QueuedSink {
    /// Takes the next queued message; `Ok` with its stream token ([`Wire::stream_token`]).
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal>;
    /// The room the sink has now (the credit advertised to the peer).
    fn room(&self) -> u16;
}

/// What the queued lane made of a Data frame.
enum DataOutcome {
    Undecodable,
    Taken(RxOutcome, Option<u32>),
}

/// A link endpoint sending `T` and receiving `R`.
///
/// `TQ`: queued-lane send queue; `Q`: the queued lane's receiving half (a
/// [`RecvLane`] queue whose free slots are the credit, or a [`DirectLane`]);
/// `TRT`/`RRT`: send and receive queues of the realtime lane. Queue sizes in
/// 1..=255 (checked at compile time).
pub struct Endpoint<T, R, const TQ: usize, Q, const TRT: usize, const RRT: usize> {
    role: Role,
    cfg: Config,
    state: LinkState,
    nonce: u32,
    last_hello: Option<u32>,
    boot_id: u32,
    peer_boot: Option<u32>,
    peer_version: Option<u16>,
    tx: SendLane<T, TQ>,
    rt_tx: SendLane<T, TRT>,
    rx: Q,
    rt_rx: RecvLane<R, RRT>,
    decoder: FrameDecoder,
    ack_owed: bool,
    nak_owed: bool,
    rt_nak_owed: bool,
    hello_ack_owed: Option<u32>,
    desync_owed: bool,
    last_desync: Option<u32>,
    last_tx: u32,
    last_rx: Option<u32>,
    events: Deque<LinkEvent, EVENTS>,
    last_token: u32,
    frames_tx: u32,
    frames_rx: u32,
    undecodable: u32,
    encode_errors: u32,
}

impl<T: Wire, R: Wire, const TQ: usize, Q: QueuedRecv, const TRT: usize, const RRT: usize>
    Endpoint<T, R, TQ, Q, TRT, RRT>
{
    const CAPS_OK: () = assert!(
        TQ > 0 && TRT > 0 && RRT > 0 && TQ <= 255 && TRT <= 255 && RRT <= 255,
        "lane capacities must be 1..=255"
    );

    fn new(role: Role, cfg: Config, id: u32, rx: Q) -> Self {
        #[allow(clippy::let_unit_value)]
        let _ = Self::CAPS_OK;
        Self {
            role,
            cfg,
            state: match role {
                Role::Host => LinkState::Connecting,
                Role::Board => LinkState::Unsynced,
            },
            nonce: id,
            last_hello: None,
            boot_id: id,
            peer_boot: None,
            peer_version: None,
            tx: SendLane::new(),
            rt_tx: SendLane::new(),
            rx,
            rt_rx: RecvLane::new(),
            decoder: FrameDecoder::new(),
            ack_owed: false,
            nak_owed: false,
            rt_nak_owed: false,
            hello_ack_owed: None,
            desync_owed: false,
            last_desync: None,
            last_tx: 0,
            last_rx: None,
            events: Deque::new(),
            last_token: 0,
            frames_tx: 0,
            frames_rx: 0,
            undecodable: 0,
            encode_errors: 0,
        }
    }

    pub fn role(&self) -> Role {
        self.role
    }

    pub fn state(&self) -> LinkState {
        self.state
    }

    pub fn is_up(&self) -> bool {
        self.state == LinkState::Up
    }

    /// Stream token ([`Wire::stream_token`]) of the last queued message
    /// delivered by this endpoint (0 = none yet).
    pub fn last_delivered_token(&self) -> u32 {
        self.last_token
    }

    /// Host: the nonce of the current handshake attempt.
    pub fn nonce(&self) -> u32 {
        self.nonce
    }

    /// The peer's protocol version once known.
    pub fn peer_version(&self) -> Option<u16> {
        self.peer_version
    }

    /// Host: (re)starts the handshake, e.g. after reopening the port. Queued
    /// messages are kept; the board's answer tells which were delivered.
    pub fn connect(&mut self) {
        if self.role == Role::Host {
            self.nonce = self
                .nonce
                .wrapping_mul(0x9E37_79B9)
                .wrapping_add(0x7F4A_7C15);
            self.state = LinkState::Connecting;
            self.last_hello = None;
        }
    }

    /// True when a frame arrived from the peer within `window` time units.
    pub fn peer_alive(&self, now: u32, window: u32) -> bool {
        self.last_rx.is_some_and(|t| now.wrapping_sub(t) <= window)
    }

    // ------------------------------------------------------------ sending

    /// Queues `msg` on its lane ([`Wire::lane`]). Queued messages are sent
    /// as the peer's credit allows; realtime ones go out before any queued
    /// frame. Accepted before the link is up too (sent after the handshake).
    pub fn send(&mut self, msg: T) -> Result<(), SendError<T>> {
        let charge = msg.charge();
        match msg.lane() {
            Lane::Queued => self.tx.push(msg, charge),
            Lane::Realtime => self.rt_tx.push(msg, charge),
        }
        .map_err(SendError::Full)
    }

    /// Free places in the send queue of `lane`.
    pub fn send_capacity(&self, lane: Lane) -> usize {
        match lane {
            Lane::Queued => self.tx.free(),
            Lane::Realtime => self.rt_tx.free(),
        }
    }

    /// Messages of `lane` not yet acknowledged by the peer.
    pub fn unacked(&self, lane: Lane) -> usize {
        match lane {
            Lane::Queued => self.tx.len(),
            Lane::Realtime => self.rt_tx.len(),
        }
    }

    /// The credit the peer granted on the queued lane, as (oldest unacknowledged sequence
    /// number, what the messages from it on may cost).
    pub fn send_window(&self) -> (u16, u16) {
        (self.tx.base(), self.tx.credit())
    }

    // ---------------------------------------------------------- receiving

    /// Takes the next realtime message.
    pub fn recv_realtime(&mut self) -> Option<R> {
        let m = self.rt_rx.pop();
        if m.is_some() {
            self.ack_owed = true; // window update
        }
        m
    }

    /// Next sequence number this endpoint will deliver on `lane` (its
    /// cumulative ack), for diagnostics.
    pub fn next_expected(&self, lane: Lane) -> u16 {
        match lane {
            Lane::Queued => self.rx.expected(),
            Lane::Realtime => self.rt_rx.expected(),
        }
    }

    /// Next link event, if any.
    pub fn poll_event(&mut self) -> Option<LinkEvent> {
        self.events.pop_front()
    }

    fn event(&mut self, e: LinkEvent) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    /// Counters.
    pub fn stats(&self) -> LinkStats {
        let (d1, u1, v1) = self.rx.counters();
        let (d2, u2, v2) = self.rt_rx.counters();
        LinkStats {
            frames_tx: self.frames_tx,
            frames_rx: self.frames_rx,
            retransmits: self.tx.retransmits().wrapping_add(self.rt_tx.retransmits()),
            undecodable: self.undecodable,
            encode_errors: self.encode_errors,
            delivered: d1.wrapping_add(d2),
            duplicates: u1.wrapping_add(u2),
            window_violations: v1.wrapping_add(v2),
            decoder: self.decoder.stats(),
        }
    }

    /// Bytes buffered in the frame decoder (bounded by `MAX_FRAME_LEN`).
    pub fn decoder_buffered(&self) -> usize {
        self.decoder.buffered()
    }

    // ------------------------------------------------------------- input

    /// Feeds received bytes to the decoder; each complete frame goes to [`Self::on_frame`],
    /// with `data` taking a Data frame's message into the queued lane. The payload is copied once
    /// out of the decoder's buffer (a block copy per frame), so the endpoint may change while the
    /// message is handled.
    fn on_bytes_with(
        &mut self,
        now: u32,
        bytes: &[u8],
        data: &mut impl FnMut(&mut Q, u16, &[u8]) -> DataOutcome,
    ) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (used, frame) = self.decoder.push_run(rest);
            rest = rest.get(used..).unwrap_or_default();
            let Some(frame) = frame else {
                continue;
            };
            // Per frame, not per call: a call per 64-byte USB chunk zeroed it for nothing.
            let mut payload = [0u8; MAX_PAYLOAD];
            let header = frame.header;
            let n = frame.payload.len().min(MAX_PAYLOAD);
            if let (Some(to), Some(from)) = (payload.get_mut(..n), frame.payload.get(..n)) {
                to.copy_from_slice(from);
            }
            self.on_frame(now, header, payload.get(..n).unwrap_or_default(), data);
        }
    }

    fn on_frame(
        &mut self,
        now: u32,
        h: Header,
        payload: &[u8],
        data: &mut impl FnMut(&mut Q, u16, &[u8]) -> DataOutcome,
    ) {
        self.frames_rx = self.frames_rx.wrapping_add(1);
        self.last_rx = Some(now);
        match h.kind {
            Kind::Hello => {
                if self.role == Role::Board {
                    match decode_exact::<Hello>(payload) {
                        Some(hello) => self.on_hello(hello),
                        None => self.undecodable = self.undecodable.wrapping_add(1),
                    }
                }
            }
            Kind::HelloAck => {
                if self.role == Role::Host && self.state == LinkState::Connecting {
                    match decode_exact::<HelloAck>(payload) {
                        Some(a) if a.nonce == self.nonce => self.on_hello_ack(now, a),
                        Some(_) => {} // stale answer to an earlier attempt
                        None => self.undecodable = self.undecodable.wrapping_add(1),
                    }
                }
            }
            Kind::Desync => {
                if self.role == Role::Host && self.state == LinkState::Up {
                    self.connect();
                    self.event(LinkEvent::Desynced);
                }
            }
            Kind::Ack | Kind::Data | Kind::Realtime => {
                if self.state != LinkState::Up {
                    if self.role == Role::Board {
                        self.desync_owed = true;
                    }
                    return;
                }
                if h.flags & FLAG_POLL != 0 {
                    self.ack_owed = true;
                }
                self.tx.on_ack(h.ack, h.win);
                self.rt_tx.on_ack(h.rt_ack, u16::from(h.rt_win));
                if h.flags & FLAG_NAK != 0 {
                    // The board parks nothing on its queued lane: the host goes back to the gap.
                    let go_back = self.role == Role::Host;
                    self.tx.on_nak(h.ack, now, self.cfg.rto, go_back);
                }
                if h.flags & FLAG_RT_NAK != 0 {
                    self.rt_tx.on_nak(h.rt_ack, now, self.cfg.rto, false);
                }
                if h.kind == Kind::Ack {
                    return;
                }
                if h.kind == Kind::Data {
                    match data(&mut self.rx, h.seq, payload) {
                        // Not acknowledged: the peer will retransmit; a persistent failure means
                        // version skew and shows in the counter.
                        DataOutcome::Undecodable => {
                            self.undecodable = self.undecodable.wrapping_add(1);
                        }
                        DataOutcome::Taken(r, token) => {
                            self.ack_owed = true;
                            if let Some(t) = token {
                                self.last_token = t;
                            }
                            if matches!(r, RxOutcome::Parked | RxOutcome::Skipped) {
                                self.nak_owed = true;
                            }
                        }
                    }
                    return;
                }
                let Some(msg) = decode_exact::<R>(payload) else {
                    self.undecodable = self.undecodable.wrapping_add(1);
                    return;
                };
                self.ack_owed = true;
                if self.rt_rx.on_frame(h.seq, msg) == RxOutcome::Parked {
                    self.rt_nak_owed = true;
                }
            }
        }
    }

    fn on_hello(&mut self, hello: Hello) {
        self.peer_version = Some(hello.version);
        if versions_compatible(hello.version, PROTOCOL_VERSION) {
            self.state = LinkState::Up;
            // Frames parked from an earlier host session may not match what the
            // new host sends under the same numbers: drop them. Delivered
            // messages and `expected` stay, so nothing is lost or repeated.
            self.rx.reset(self.rx.expected());
            self.rt_rx.reset(self.rt_rx.expected());
            // The new host accepts from our base with its own window; resend
            // everything unacknowledged at once.
            self.tx.renumber(self.tx.base(), hello.window);
            self.rt_tx
                .renumber(self.rt_tx.base(), u16::from(hello.rt_window));
            self.event(LinkEvent::HostAttached { nonce: hello.nonce });
        }
        self.hello_ack_owed = Some(hello.nonce);
    }

    fn on_hello_ack(&mut self, now: u32, a: HelloAck) {
        self.peer_version = Some(a.version);
        if !versions_compatible(a.version, PROTOCOL_VERSION) {
            self.state = LinkState::Incompatible {
                peer_version: a.version,
            };
            self.event(LinkEvent::VersionMismatch {
                peer_version: a.version,
            });
            return;
        }
        let first = self.peer_boot.is_none();
        let board_reset = self.peer_boot.is_some_and(|b| b != a.boot_id);
        self.peer_boot = Some(a.boot_id);
        let fresh = first || board_reset;
        // Host → board: drop what the board already delivered, resend the rest.
        sync_send(
            &mut self.tx,
            fresh,
            a.next_expected,
            a.window,
            now,
            self.cfg.rto,
        );
        sync_send(
            &mut self.rt_tx,
            fresh,
            a.rt_next_expected,
            u16::from(a.rt_window),
            now,
            self.cfg.rto,
        );
        // Board → host: start at the board's oldest unacknowledged frame, or
        // keep our position when we already delivered past it.
        sync_recv(&mut self.rx, fresh, a.tx_base);
        sync_recv(&mut self.rt_rx, fresh, a.rt_tx_base);
        self.state = LinkState::Up;
        self.ack_owed = true;
        self.event(LinkEvent::Connected {
            ack: a,
            board_reset,
        });
    }

    // ------------------------------------------------------------ output

    fn ack_header(&self, kind: Kind) -> Header {
        let mut flags = 0;
        if self.nak_owed {
            flags |= FLAG_NAK;
        }
        if self.rt_nak_owed {
            flags |= FLAG_RT_NAK;
        }
        Header {
            kind,
            flags,
            seq: 0,
            ack: self.rx.expected(),
            win: self.rx.window(),
            rt_ack: self.rt_rx.expected(),
            rt_win: self.rt_rx.window().min(255) as u8,
        }
    }

    fn sent(&mut self, now: u32, n: usize) -> Option<usize> {
        self.frames_tx = self.frames_tx.wrapping_add(1);
        self.last_tx = now;
        Some(n)
    }

    fn sent_sequenced(
        &mut self,
        now: u32,
        r: Result<usize, crate::frame::EncodeError>,
    ) -> Option<usize> {
        match r {
            Ok(n) => {
                self.ack_owed = false;
                self.nak_owed = false;
                self.rt_nak_owed = false;
                self.sent(now, n)
            }
            Err(_) => {
                self.encode_errors = self.encode_errors.wrapping_add(1);
                None
            }
        }
    }

    /// Writes the next frame due at `now` into `out` and returns its length,
    /// or `None` when nothing is due. Call repeatedly until `None`. `out`
    /// must hold at least [`MAX_FRAME_LEN`] bytes.
    pub fn poll_transmit(&mut self, now: u32, out: &mut [u8]) -> Option<usize> {
        if out.len() < MAX_FRAME_LEN {
            return None;
        }
        if let Some(nonce) = self.hello_ack_owed.take() {
            return self.send_hello_ack(now, nonce, out);
        }
        match self.state {
            LinkState::Connecting => {
                if self
                    .last_hello
                    .is_some_and(|t| now.wrapping_sub(t) < self.cfg.hello_interval)
                {
                    return None;
                }
                self.last_hello = Some(now);
                let hello = Hello {
                    version: PROTOCOL_VERSION,
                    nonce: self.nonce,
                    window: self.rx.window(),
                    rt_window: self.rt_rx.window().min(255) as u8,
                };
                let r = encode_frame(&Header::new(Kind::Hello), Some(&hello), out);
                let n = r.ok()?;
                self.sent(now, n)
            }
            LinkState::Unsynced => {
                if !self.desync_owed
                    || self
                        .last_desync
                        .is_some_and(|t| now.wrapping_sub(t) < self.cfg.rto)
                {
                    return None;
                }
                self.desync_owed = false;
                self.last_desync = Some(now);
                let n = encode_frame::<()>(&Header::new(Kind::Desync), None, out).ok()?;
                self.sent(now, n)
            }
            LinkState::Incompatible { .. } => None,
            LinkState::Up => self.poll_up(now, out),
        }
    }

    fn send_hello_ack(&mut self, now: u32, nonce: u32, out: &mut [u8]) -> Option<usize> {
        let a = HelloAck {
            version: PROTOCOL_VERSION,
            nonce,
            boot_id: self.boot_id,
            rx_capacity: self.rx.capacity(),
            rt_capacity: RRT as u16,
            next_expected: self.rx.expected(),
            rt_next_expected: self.rt_rx.expected(),
            window: self.rx.window(),
            rt_window: self.rt_rx.window().min(255) as u8,
            tx_base: self.tx.base(),
            rt_tx_base: self.rt_tx.base(),
            last_line: self.last_token,
        };
        let n = encode_frame(&Header::new(Kind::HelloAck), Some(&a), out).ok()?;
        self.sent(now, n)
    }

    fn poll_up(&mut self, now: u32, out: &mut [u8]) -> Option<usize> {
        let rto = self.cfg.rto;
        let mut h = self.ack_header(Kind::Realtime);
        if let Some((seq, msg)) = self.rt_tx.next_transmit(now, rto) {
            h.seq = seq;
            let r = encode_frame(&h, Some(msg), out);
            return self.sent_sequenced(now, r);
        }
        h.kind = Kind::Data;
        if let Some((seq, msg)) = self.tx.next_transmit(now, rto) {
            h.seq = seq;
            let r = encode_frame(&h, Some(msg), out);
            return self.sent_sequenced(now, r);
        }
        h.kind = Kind::Ack;
        let idle = now.wrapping_sub(self.last_tx);
        let probe = ((self.tx.blocked() || self.rt_tx.blocked()) && idle >= rto)
            || (self.cfg.keepalive != 0 && idle >= self.cfg.keepalive);
        if !(self.ack_owed || self.nak_owed || self.rt_nak_owed || probe) {
            return None;
        }
        if probe {
            h.flags |= FLAG_POLL;
        }
        let r = encode_frame::<()>(&h, None, out);
        self.sent_sequenced(now, r)
    }

    /// Earliest time at which `poll_transmit` may have something new to send
    /// without any input (a retransmission, probe or keepalive), for callers
    /// that sleep. `None` when only input can create work.
    pub fn next_deadline(&self) -> Option<u32> {
        let rto = self.cfg.rto;
        match self.state {
            LinkState::Connecting => Some(
                self.last_hello
                    .map_or(self.last_tx, |t| t.wrapping_add(self.cfg.hello_interval)),
            ),
            LinkState::Up => {
                let mut d = [
                    self.rt_tx.next_timeout(rto),
                    self.tx.next_timeout(rto),
                    (self.tx.blocked() || self.rt_tx.blocked())
                        .then(|| self.last_tx.wrapping_add(rto)),
                    (self.cfg.keepalive != 0)
                        .then(|| self.last_tx.wrapping_add(self.cfg.keepalive)),
                ]
                .into_iter()
                .flatten();
                let first = d.next()?;
                Some(d.fold(first, |a, b| if seq_before32(b, a) { b } else { a }))
            }
            _ => None,
        }
    }
}

fn seq_before32(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

fn decode_exact<M: serde::de::DeserializeOwned>(payload: &[u8]) -> Option<M> {
    crate::codec::decode(payload)
}

fn sync_send<T, const N: usize>(
    lane: &mut SendLane<T, N>,
    fresh: bool,
    next_expected: u16,
    win: u16,
    now: u32,
    rto: u32,
) {
    let in_range = next_expected.wrapping_sub(lane.base()) as usize <= lane.in_flight();
    if fresh || !in_range {
        lane.renumber(next_expected, win);
    } else {
        lane.on_ack(next_expected, win);
        lane.rewind(now, rto);
    }
}

fn sync_recv(lane: &mut impl QueuedRecv, fresh: bool, tx_base: u16) {
    if fresh || seq_before(lane.expected(), tx_base) {
        lane.reset(tx_base);
    } else {
        lane.reset(lane.expected());
    }
}

impl<T: Wire, R: Wire, const TQ: usize, const RQ: usize, const TRT: usize, const RRT: usize>
    Endpoint<T, R, TQ, RecvLane<R, RQ>, TRT, RRT>
{
    /// A host endpoint; it starts connecting at once. `nonce` should differ
    /// between host sessions (e.g. from the process id and clock).
    pub fn new_host(cfg: Config, nonce: u32) -> Self {
        Self::new(Role::Host, cfg, nonce, RecvLane::new())
    }

    /// Feeds bytes received from the pipe at time `now` (any chunking).
    pub fn on_bytes(&mut self, now: u32, bytes: &[u8]) {
        self.on_bytes_with(now, bytes, &mut |rx, seq, payload| {
            let Some(msg) = decode_exact::<R>(payload) else {
                return DataOutcome::Undecodable;
            };
            let mut token = None;
            let r = rx.on_frame_with(seq, msg, |m| {
                if let Some(t) = m.stream_token() {
                    token = Some(t);
                }
            });
            DataOutcome::Taken(r, token)
        });
    }

    /// Takes the next incoming message: realtime first, then queued.
    pub fn recv(&mut self) -> Option<R> {
        self.recv_realtime().or_else(|| self.recv_queued())
    }

    /// Takes the next queued message; its slot becomes credit for the peer.
    pub fn recv_queued(&mut self) -> Option<R> {
        let m = self.rx.pop();
        if m.is_some() {
            self.ack_owed = true; // window update
        }
        m
    }

    /// Looks at the next queued message without taking it (e.g. to wait for
    /// planner room before consuming a line).
    pub fn peek_queued(&self) -> Option<&R> {
        self.rx.peek()
    }

    /// Queued messages delivered and not yet taken.
    pub fn queued_len(&self) -> usize {
        self.rx.ready_len()
    }
}

impl<T: Wire, R: Wire, const TQ: usize, const TRT: usize, const RRT: usize>
    Endpoint<T, R, TQ, DirectLane, TRT, RRT>
{
    /// A board endpoint whose application holds `capacity` units of queued messages (its line
    /// ring's bytes). `boot_id` must differ between power-ups (e.g. a boot counter in flash, or a
    /// hardware RNG value) so a host can tell a reset board from a reconnection.
    pub fn new_board(cfg: Config, boot_id: u32, capacity: u16) -> Self {
        Self::new(Role::Board, cfg, boot_id, DirectLane::new(capacity))
    }

    /// Feeds bytes received from the pipe at time `now` (any chunking); each queued message
    /// goes to `sink` as it arrives, in order.
    pub fn on_bytes(&mut self, now: u32, bytes: &[u8], sink: &mut impl QueuedSink) {
        self.on_bytes_with(now, bytes, &mut |rx, seq, payload| {
            let mut token = None;
            let mut undecodable = false;
            let r = rx.on_frame(seq, || match sink.deliver(payload) {
                Ok(t) => {
                    token = t;
                    true
                }
                Err(e) => {
                    undecodable = e == Refusal::Undecodable;
                    false
                }
            });
            rx.set_window(sink.room());
            if undecodable {
                return DataOutcome::Undecodable;
            }
            DataOutcome::Taken(r, token)
        });
    }

    /// The application's room changed (it took lines out of its ring): the credit advertised
    /// from now on. A grown credit is announced at once.
    pub fn set_window(&mut self, room: u16) {
        if self.rx.set_window(room) {
            self.ack_owed = true;
        }
    }
}

/// Host queued-lane send queue: up to this many messages (line batches) queued or in flight.
pub const HOST_TX_QUEUE: usize = 32;
/// Host receive queue for board messages.
pub const HOST_RX_QUEUE: usize = 32;
/// Board send queue for events.
pub const BOARD_TX_QUEUE: usize = 16;
/// Realtime lane queues (both directions).
pub const RT_QUEUE: usize = 8;

/// The host sender's endpoint.
pub type HostEndpoint = Endpoint<
    HostMsg,
    BoardMsg,
    HOST_TX_QUEUE,
    RecvLane<BoardMsg, HOST_RX_QUEUE>,
    RT_QUEUE,
    RT_QUEUE,
>;
/// The firmware's endpoint: queued messages go to the board's [`QueuedSink`] as they arrive.
pub type BoardEndpoint =
    Endpoint<BoardMsg, BoardInbound, BOARD_TX_QUEUE, DirectLane, RT_QUEUE, RT_QUEUE>;
