//! Test harness: a host and a board endpoint joined by two fault pipes, plus
//! wire spies that check the credit rule on every frame actually written.
#![allow(dead_code)]

use gantry_proto::fault::{Faults, FaultyPipe, Rng};
use gantry_proto::frame::{FrameDecoder, Kind, MAX_FRAME_LEN};
use gantry_proto::{BoardEndpoint, Config, HelloAck, HostEndpoint, Line};

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
    pub h2b: Box<FaultyPipe<PIPE>>,
    pub b2h: Box<FaultyPipe<PIPE>>,
    rng: Rng,
    spy_h2b: FrameDecoder,
    spy_b2h: FrameDecoder,
    /// Largest queued-lane limit the board has advertised on the wire.
    pub board_limit: Option<u16>,
    /// Data frames the host wrote at or beyond `board_limit`.
    pub credit_violations: u32,
    /// Largest number of data frames in flight beyond the board's last ack.
    pub max_in_flight: u16,
    board_ack: u16,
}

impl Sim {
    pub fn new(seed: u64, faults: Faults, cfg: Config) -> Self {
        Self {
            now: 1000,
            host: HostEndpoint::new_host(cfg, seed as u32 ^ 0xA5A5_0001),
            board: BoardEndpoint::new_board(cfg, seed as u32 ^ 0x5A5A_0002),
            h2b: Box::new(FaultyPipe::new(seed.wrapping_mul(3), faults)),
            b2h: Box::new(FaultyPipe::new(
                seed.wrapping_mul(5).wrapping_add(1),
                faults,
            )),
            rng: Rng::new(seed.wrapping_mul(7).wrapping_add(2)),
            spy_h2b: FrameDecoder::new(),
            spy_b2h: FrameDecoder::new(),
            board_limit: None,
            credit_violations: 0,
            max_in_flight: 0,
            board_ack: 0,
        }
    }

    pub fn set_faults(&mut self, f: Faults) {
        self.h2b.set_faults(f);
        self.b2h.set_faults(f);
    }

    /// Forgets the board's advertisements (after a board reset).
    pub fn reset_spies(&mut self) {
        self.board_limit = None;
    }

    fn spy_board_frame(&mut self, bytes: &[u8]) {
        let mut lim = self.board_limit;
        let mut ack = self.board_ack;
        self.spy_b2h.feed(bytes, |f| {
            let l = match f.header.kind {
                Kind::Ack | Kind::Data | Kind::Realtime => {
                    ack = f.header.ack;
                    Some(f.header.ack.wrapping_add(f.header.win as u16))
                }
                Kind::HelloAck => {
                    let a: HelloAck = postcard::from_bytes(f.payload).unwrap();
                    ack = a.next_expected;
                    Some(a.next_expected.wrapping_add(a.window as u16))
                }
                _ => None,
            };
            if let Some(l) = l {
                lim = Some(match lim {
                    Some(old) if wrapping_before(l, old) => old,
                    _ => l,
                });
            }
        });
        self.board_limit = lim;
        self.board_ack = ack;
    }

    fn spy_host_frame(&mut self, bytes: &[u8]) {
        let lim = self.board_limit;
        let ack = self.board_ack;
        let mut bad = 0;
        let mut inflight = self.max_in_flight;
        self.spy_h2b.feed(bytes, |f| {
            if f.header.kind == Kind::Data {
                match lim {
                    Some(l) if wrapping_before(f.header.seq, l) => {}
                    _ => bad += 1,
                }
                let d = f.header.seq.wrapping_sub(ack).wrapping_add(1);
                if (d as i16) > 0 {
                    inflight = inflight.max(d);
                }
            }
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
            self.board.on_bytes(now, &chunk[..n]);
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
pub fn line(n: u32) -> Line {
    let text = match n % 4 {
        0 => format!("G1X{}Y{}", n % 1000, n % 777),
        1 => format!("G1 X{}.{} F1200", n % 300, n % 10),
        2 => format!("G2X{}Y{}I1J-2", n % 50, n % 60),
        _ => format!("N{n} G0 Z5"),
    };
    Line::new(n, &text).unwrap()
}
