//! Test harness: a host and a board endpoint joined by two fault pipes, plus
//! wire spies that check the credit rule on every frame actually written.
#![allow(dead_code)]

use gantry_proto::channel::{QueuedSink, Refusal};
use gantry_proto::fault::{Faults, FaultyPipe, Rng};
use gantry_proto::frame::{FrameDecoder, Kind, MAX_FRAME_LEN};
use gantry_proto::lines::push_record;
use gantry_proto::{BoardEndpoint, Config, HelloAck, HostEndpoint, HostMsg, LineBatch, Wire};
use std::collections::{HashMap, VecDeque};

/// The board's line store in these tests: bytes of credit (small, so flow control bites).
pub const INBOX_BYTES: u16 = 256;

/// The board application's queued messages as a byte-budgeted queue: a message costs its charge
/// (a batch its record bytes, as in the board's line ring) until the application takes it.
#[derive(Default)]
pub struct Inbox {
    q: VecDeque<HostMsg>,
    used: u32,
}

impl Inbox {
    pub fn used(&self) -> u32 {
        self.used
    }
    pub fn len(&self) -> usize {
        self.q.len()
    }
    pub fn pop(&mut self) -> Option<HostMsg> {
        let m = self.q.pop_front()?;
        self.used -= u32::from(m.charge());
        Some(m)
    }
}

impl QueuedSink for Inbox {
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
        let m: HostMsg = gantry_proto::codec::decode(payload).ok_or(Refusal::Undecodable)?;
        if m.charge() > self.room() {
            return Err(Refusal::NoRoom);
        }
        self.used += u32::from(m.charge());
        let token = m.stream_token();
        self.q.push_back(m);
        Ok(token)
    }
    fn room(&self) -> u16 {
        (u32::from(INBOX_BYTES) - self.used) as u16
    }
}

pub const PIPE: usize = 16 * 1024;

/// Fast timing for simulated links (1 tick = 1 ms of virtual time).
pub const SIM: Config = Config {
    rto: 10,
    hello_interval: 10,
    keepalive: 50,
};

pub fn wrapping_before(a: u16, b: u16) -> bool {
    (a.wrapping_sub(b) as i16) < 0
}

pub struct Sim {
    pub now: u32,
    pub host: HostEndpoint,
    pub board: BoardEndpoint,
    pub inbox: Inbox,
    pub h2b: Box<FaultyPipe<PIPE>>,
    pub b2h: Box<FaultyPipe<PIPE>>,
    rng: Rng,
    spy_h2b: FrameDecoder,
    spy_b2h: FrameDecoder,
    /// The board's newest queued-lane advertisement on the wire: (ack, credit in bytes).
    pub board_credit: Option<(u16, u16)>,
    /// Data frames the host wrote beyond the board's credit.
    pub credit_violations: u32,
    /// Largest charge (bytes) of the data frames in flight beyond the board's last ack.
    pub max_in_flight: u32,
    /// The charge of each data frame the host wrote, by sequence number (the newest content).
    charges: HashMap<u16, u16>,
}

impl Sim {
    pub fn new(seed: u64, faults: Faults, cfg: Config) -> Self {
        Self {
            now: 1000,
            host: HostEndpoint::new_host(cfg, seed as u32 ^ 0xA5A5_0001),
            board: BoardEndpoint::new_board(cfg, seed as u32 ^ 0x5A5A_0002, INBOX_BYTES),
            inbox: Inbox::default(),
            h2b: Box::new(FaultyPipe::new(seed.wrapping_mul(3), faults)),
            b2h: Box::new(FaultyPipe::new(
                seed.wrapping_mul(5).wrapping_add(1),
                faults,
            )),
            rng: Rng::new(seed.wrapping_mul(7).wrapping_add(2)),
            spy_h2b: FrameDecoder::new(),
            spy_b2h: FrameDecoder::new(),
            board_credit: None,
            credit_violations: 0,
            max_in_flight: 0,
            charges: HashMap::new(),
        }
    }

    /// A new board (power cycled): new endpoint, empty line store.
    pub fn reset_board(&mut self, boot_id: u32) {
        self.board = BoardEndpoint::new_board(SIM, boot_id, INBOX_BYTES);
        self.inbox = Inbox::default();
        self.board_credit = None;
    }

    /// The board application takes its next queued message; the room it frees is credit.
    pub fn board_recv_queued(&mut self) -> Option<HostMsg> {
        let m = self.inbox.pop();
        self.board.set_window(self.inbox.room());
        m
    }

    pub fn set_faults(&mut self, f: Faults) {
        self.h2b.set_faults(f);
        self.b2h.set_faults(f);
    }

    fn spy_board_frame(&mut self, bytes: &[u8]) {
        let mut adv = self.board_credit;
        self.spy_b2h.feed(bytes, |f| {
            let a = match f.header.kind {
                Kind::Ack | Kind::Data | Kind::Realtime => Some((f.header.ack, f.header.win)),
                Kind::HelloAck => {
                    let a: HelloAck = postcard::from_bytes(f.payload).unwrap();
                    Some((a.next_expected, a.window))
                }
                _ => None,
            };
            if let Some((ack, win)) = a {
                adv = Some(match adv {
                    // An older ack (reordered), or the same with less credit: the sender keeps
                    // the better one, and so does the spy.
                    Some((old, w)) if wrapping_before(ack, old) || (ack == old && win < w) => {
                        (old, w)
                    }
                    _ => (ack, win),
                });
            }
        });
        self.board_credit = adv;
    }

    fn spy_host_frame(&mut self, bytes: &[u8]) {
        let adv = self.board_credit;
        let mut bad = 0;
        let mut inflight = self.max_in_flight;
        let charges = &mut self.charges;
        self.spy_h2b.feed(bytes, |f| {
            if f.header.kind != Kind::Data {
                return;
            }
            let m: HostMsg = gantry_proto::codec::decode(f.payload).unwrap();
            charges.insert(f.header.seq, m.charge());
            let Some((ack, win)) = adv else {
                bad += 1;
                return;
            };
            if wrapping_before(f.header.seq, ack) {
                return; // a retransmission of a frame the board has
            }
            let mut seq = ack;
            let mut cost = 0u32;
            loop {
                cost += u32::from(charges.get(&seq).copied().unwrap_or(0));
                if seq == f.header.seq {
                    break;
                }
                seq = seq.wrapping_add(1);
            }
            if cost > u32::from(win) {
                bad += 1;
            }
            inflight = inflight.max(cost);
        });
        self.credit_violations += bad;
        self.max_in_flight = inflight;
    }

    /// Both endpoints transmit what is due; nothing is delivered.
    pub fn transmit(&mut self) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let now = self.now;
        while let Some(n) = self.host.poll_transmit(now, &mut buf) {
            assert!(n <= MAX_FRAME_LEN);
            self.spy_host_frame(&buf[..n]);
            self.h2b.write(now, &buf[..n]);
        }
        while let Some(n) = self.board.poll_transmit(now, &mut buf) {
            assert!(n <= MAX_FRAME_LEN);
            self.spy_board_frame(&buf[..n]);
            self.b2h.write(now, &buf[..n]);
        }
    }

    /// Delivers due bytes in random chunk sizes.
    pub fn deliver(&mut self) {
        let now = self.now;
        let mut chunk = [0u8; 96];
        loop {
            let want = 1 + self.rng.below(chunk.len() as u32) as usize;
            let n = self.h2b.read(now, &mut chunk[..want]);
            if n == 0 {
                break;
            }
            self.board.on_bytes(now, &chunk[..n], &mut self.inbox);
        }
        loop {
            let want = 1 + self.rng.below(chunk.len() as u32) as usize;
            let n = self.b2h.read(now, &mut chunk[..want]);
            if n == 0 {
                break;
            }
            self.host.on_bytes(now, &chunk[..n]);
        }
    }

    /// One tick: transmit, deliver, advance time.
    pub fn pump(&mut self) {
        self.transmit();
        self.deliver();
        self.now = self.now.wrapping_add(1);
    }

    pub fn rng(&mut self) -> &mut Rng {
        &mut self.rng
    }

    /// Pumps until both endpoints are up (panics after `max` ticks).
    pub fn connect(&mut self, max: u32) {
        for _ in 0..max {
            if self.host.is_up() && self.board.is_up() {
                return;
            }
            self.pump();
        }
        panic!("no connection after {max} ticks");
    }
}

/// A G-code-like line for number `n`.
pub fn line(n: u32) -> String {
    match n % 4 {
        0 => format!("G1X{}Y{}", n % 1000, n % 777),
        1 => format!("G1 X{}.{} F1200", n % 300, n % 10),
        2 => format!("G2X{}Y{}I1J-2", n % 50, n % 60),
        _ => format!("N{n} G0 Z5"),
    }
}

/// Lines `first..first + count` of the main stream in one batch.
pub fn batch(first: u32, count: u32) -> HostMsg {
    let mut records = LineBatch::new();
    for n in first..first + count {
        assert!(push_record(&mut records, n, line(n).as_bytes()));
    }
    HostMsg::Lines { id: 0, records }
}

/// The lines of a batch, as (number, text).
pub fn lines_of(m: &HostMsg) -> Vec<(u32, String)> {
    let HostMsg::Lines { id: 0, records } = m else {
        panic!("not a main-stream batch: {m:?}")
    };
    gantry_proto::lines::records(records)
        .map(|(n, t)| (n, String::from_utf8(t.to_vec()).unwrap()))
        .collect()
}
