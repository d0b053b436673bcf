//! Fuzz-equivalent property test: arbitrary and mutated bytes into the frame
//! decoder and both endpoints, driven by a deterministic PRNG. Properties: no
//! panic, memory bounded (fixed-size state, decoder buffer ≤ MAX_FRAME_LEN,
//! queues ≤ capacity), every frame an endpoint emits is well formed, and a
//! transmit burst always ends.
//!
//! Default suite: `FUZZ_DEFAULT` executions. The long run:
//! `GANTRY_FUZZ_EXECS=1000000 cargo test --release -p gantry-proto --test fuzz -- --ignored --nocapture`

use gantry_proto::channel::{QueuedSink, Refusal, HOST_RX_QUEUE};
use gantry_proto::fault::Rng;
use gantry_proto::frame::{encode_frame, FrameDecoder, Header, Kind, MAX_FRAME_LEN};
use gantry_proto::{
    BoardEndpoint, BoardMsg, Config, Hello, HelloAck, HostEndpoint, HostMsg, Jog, Lane, LineBatch,
    MachineState, Status, Wire, PROTOCOL_VERSION,
};

/// The board application's store: decoded queued messages within a byte budget (as the board's
/// line ring); it refuses what does not fit.
const BOARD_BYTES: u16 = 1024;

#[derive(Default)]
struct Store {
    q: Vec<HostMsg>,
    used: u32,
}

impl QueuedSink for Store {
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
        let m: HostMsg = gantry_proto::codec::decode(payload).ok_or(Refusal::Undecodable)?;
        if m.charge() > self.room() {
            return Err(Refusal::NoRoom);
        }
        self.used += u32::from(m.charge());
        let t = m.stream_token();
        self.q.push(m);
        Ok(t)
    }
    fn room(&self) -> u16 {
        (u32::from(BOARD_BYTES) - self.used) as u16
    }
}
use std::time::Instant;

const FUZZ_DEFAULT: u64 = 20_000;
const CFG: Config = Config {
    rto: 10,
    hello_interval: 10,
    keepalive: 50,
};

fn random_host(r: &mut Rng) -> HostMsg {
    match r.below(10) {
        0 => HostMsg::FeedHold,
        1 => HostMsg::FeedOverride(r.next_u32() as u16),
        2 => HostMsg::Jog(Jog {
            id: r.next_u32(),
            axis: r.next_u32() as u8,
            feed_um_min: r.next_u32() as i32,
            distance_nm: r.next_u64(),
        }),
        3 => HostMsg::StartFromLine {
            id: r.next_u32(),
            line_no: r.next_u32(),
        },
        4 => HostMsg::SetupChunk {
            offset: r.next_u32(),
            bytes: heapless::Vec::from_slice(&[r.next_u32() as u8; 40]).unwrap(),
        },
        _ => {
            let mut records = LineBatch::new();
            for _ in 0..1 + r.below(5) {
                let text = "G1X1Y2".repeat(r.below(17) as usize);
                let _ =
                    gantry_proto::lines::push_record(&mut records, r.next_u32(), text.as_bytes());
            }
            HostMsg::Lines {
                id: r.next_u32() as u16,
                records,
            }
        }
    }
}

fn random_board(r: &mut Rng) -> BoardMsg {
    match r.below(5) {
        0 => BoardMsg::Status(Status {
            state: MachineState::Hold {
                stopped: r.chance(500_000),
            },
            machine_pos: [r.next_u64() as i64; 6],
            work_pos: [r.next_u64() as i64 >> 20; 6],
            feed_um_min: r.next_u32(),
            feed_override: 100,
            rapid_override: 100,
            spindle_override: 100,
            programmed_feed_um_min: 0,
            work_system: 0,
            inch: false,
            planner_fill: 3,
            queue_fill: 2,
            line: r.next_u32(),
            inputs: r.next_u32(),
            homed: 1,
            outputs: Default::default(),
            starved_ms: r.next_u32(),
            probe: None,
        }),
        1 => BoardMsg::Alarm {
            code: r.next_u32() as u16,
            line: r.next_u32(),
        },
        2 => BoardMsg::Error {
            line: r.next_u32(),
            code: 1,
            column: 2,
        },
        _ => BoardMsg::Mark {
            line: r.next_u32(),
            id: r.next_u32(),
        },
    }
}

struct Fuzzer {
    r: Rng,
    now: u32,
    board: Box<BoardEndpoint>,
    store: Store,
    host: Box<HostEndpoint>,
    dec: FrameDecoder,
    check: FrameDecoder,
    input: Vec<u8>,
    frames_out: u64,
}

impl Fuzzer {
    fn new(seed: u64) -> Self {
        Self {
            r: Rng::new(seed),
            now: 0,
            board: Box::new(BoardEndpoint::new_board(CFG, seed as u32, BOARD_BYTES)),
            store: Store::default(),
            host: Box::new(HostEndpoint::new_host(CFG, (seed >> 7) as u32)),
            dec: FrameDecoder::new(),
            check: FrameDecoder::new(),
            input: Vec::new(),
            frames_out: 0,
        }
    }

    fn header(&mut self, kind: Kind, seq: u16) -> Header {
        let r = &mut self.r;
        Header {
            kind,
            flags: (r.next_u32() as u8) & 0x70,
            seq,
            ack: r.next_u32() as u16 % 64,
            win: r.below(1200) as u16,
            rt_ack: r.next_u32() as u16 % 64,
            rt_win: r.below(12) as u8,
        }
    }

    fn push_frame<P: serde::Serialize>(&mut self, h: &Header, p: Option<&P>) {
        let mut out = [0u8; MAX_FRAME_LEN];
        if let Ok(n) = encode_frame(h, p, &mut out) {
            self.input.extend_from_slice(&out[..n]);
        }
    }

    /// One plausible frame for the board (`to_board`) or the host.
    fn valid_frame(&mut self, to_board: bool) {
        let pick = self.r.below(12);
        let jitter = self.r.below(8) as u16;
        match (to_board, pick) {
            (true, 0) => {
                let h = Hello {
                    version: if self.r.chance(900_000) {
                        PROTOCOL_VERSION
                    } else {
                        self.r.next_u32() as u16
                    },
                    nonce: self.r.next_u32(),
                    window: self.r.below(1200) as u16,
                    rt_window: self.r.below(9) as u8,
                };
                self.push_frame(&Header::new(Kind::Hello), Some(&h));
            }
            (false, 0) => {
                let a = HelloAck {
                    version: PROTOCOL_VERSION,
                    nonce: if self.r.chance(800_000) {
                        self.host.nonce()
                    } else {
                        self.r.next_u32()
                    },
                    boot_id: self.r.below(3),
                    rx_capacity: 16,
                    rt_capacity: 8,
                    next_expected: self.r.next_u32() as u16 % 64,
                    rt_next_expected: self.r.next_u32() as u16 % 64,
                    window: self.r.below(1200) as u16,
                    rt_window: self.r.below(12) as u8,
                    tx_base: self.r.next_u32() as u16 % 64,
                    rt_tx_base: 0,
                    last_line: self.r.next_u32(),
                };
                self.push_frame(&Header::new(Kind::HelloAck), Some(&a));
            }
            (_, 1) => {
                let h = self.header(Kind::Desync, 0);
                self.push_frame::<()>(&h, None);
            }
            (_, 2 | 3) => {
                let h = self.header(Kind::Ack, 0);
                self.push_frame::<()>(&h, None);
            }
            (true, _) => {
                let m = random_host(&mut self.r);
                let rt = pick == 4;
                let lane = if rt { Lane::Realtime } else { Lane::Queued };
                // Mostly near what the board expects: duplicates, in order, gaps.
                let base = if self.r.chance(900_000) {
                    self.board.next_expected(lane)
                } else {
                    self.r.next_u32() as u16
                };
                let seq = base.wrapping_add(jitter).wrapping_sub(2);
                let h = self.header(if rt { Kind::Realtime } else { Kind::Data }, seq);
                self.push_frame(&h, Some(&m));
            }
            (false, _) => {
                let m = random_board(&mut self.r);
                let rt = pick == 4;
                let lane = if rt { Lane::Realtime } else { Lane::Queued };
                let base = if self.r.chance(900_000) {
                    self.host.next_expected(lane)
                } else {
                    self.r.next_u32() as u16
                };
                let seq = base.wrapping_add(jitter).wrapping_sub(2);
                let h = self.header(if rt { Kind::Realtime } else { Kind::Data }, seq);
                self.push_frame(&h, Some(&m));
            }
        }
    }

    fn make_input(&mut self, to_board: bool) {
        self.input.clear();
        match self.r.below(4) {
            0 => {
                // Arbitrary bytes, zeros over-represented.
                let n = self.r.below(400) as usize;
                for _ in 0..n {
                    let b = if self.r.chance(100_000) {
                        0
                    } else {
                        self.r.next_u32() as u8
                    };
                    self.input.push(b);
                }
            }
            1 => {
                for _ in 0..1 + self.r.below(6) {
                    self.valid_frame(to_board);
                }
            }
            _ => {
                for _ in 0..1 + self.r.below(4) {
                    self.valid_frame(to_board);
                }
                // Mutations: flips, inserts, deletes, truncation, splices.
                for _ in 0..self.r.below(4) {
                    if self.input.is_empty() {
                        break;
                    }
                    let len = self.input.len() as u32;
                    let i = self.r.below(len) as usize;
                    match self.r.below(5) {
                        0 => self.input[i] ^= 1 << self.r.below(8),
                        1 => self.input.insert(i, self.r.next_u32() as u8),
                        2 => {
                            self.input.remove(i);
                        }
                        3 => self.input.truncate(i),
                        _ => {
                            let j = self.r.below(len) as usize;
                            let (a, b) = (i.min(j), i.max(j));
                            let seg: Vec<u8> = self.input[a..b].to_vec();
                            self.input.extend_from_slice(&seg);
                        }
                    }
                }
            }
        }
    }

    fn drain_output(&mut self) {
        let mut out = [0u8; MAX_FRAME_LEN];
        for (who, n_max) in [(0, 100), (1, 100)] {
            let mut count = 0;
            loop {
                let n = if who == 0 {
                    self.board.poll_transmit(self.now, &mut out)
                } else {
                    self.host.poll_transmit(self.now, &mut out)
                };
                let Some(n) = n else { break };
                assert!(n <= MAX_FRAME_LEN);
                let mut ok = 0;
                self.check.feed(&out[..n], |_| ok += 1);
                assert_eq!(ok, 1, "endpoint emitted a malformed frame");
                count += 1;
                self.frames_out += 1;
                assert!(count < n_max, "transmit burst does not end");
            }
        }
    }

    fn exec(&mut self) {
        let to_board = self.r.chance(500_000);
        self.make_input(to_board);
        // Feed in random chunks.
        let mut i = 0;
        let input = std::mem::take(&mut self.input);
        while i < input.len() {
            let n = (1 + self.r.below(80) as usize).min(input.len() - i);
            let c = &input[i..i + n];
            self.dec.feed(c, |_| {});
            if to_board {
                self.board.on_bytes(self.now, c, &mut self.store);
            } else {
                self.host.on_bytes(self.now, c);
            }
            i += n;
        }
        self.input = input;
        assert!(self.dec.buffered() <= MAX_FRAME_LEN);
        assert!(self.board.decoder_buffered() <= MAX_FRAME_LEN);
        assert!(self.host.decoder_buffered() <= MAX_FRAME_LEN);
        // Applications.
        if self.r.chance(300_000) {
            let _ = self.board.send(random_board(&mut self.r));
        }
        if self.r.chance(300_000) {
            let _ = self.host.send(random_host(&mut self.r));
        }
        if self.r.chance(500_000) {
            while self.board.recv_realtime().is_some() {}
            self.store = Store::default();
            self.board.set_window(self.store.room());
            while self.host.recv().is_some() {}
        }
        if self.r.chance(5_000) {
            self.host.connect();
        }
        assert!(self.store.used <= u32::from(BOARD_BYTES));
        assert!(self.host.queued_len() <= HOST_RX_QUEUE);
        self.now = self.now.wrapping_add(self.r.below(30));
        self.drain_output();
    }
}

/// (frames emitted, messages delivered by either endpoint, frames of the fuzz input the reference
/// decoder accepted, and rejected for broken COBS, a bad CRC or header, shortness or length)
fn run(execs: u64, seed: u64) -> (u64, u64, u64, u64) {
    let mut done = 0;
    let mut frames = 0;
    let mut delivered = 0;
    let (mut accepted, mut rejected) = (0, 0);
    let mut s = seed;
    while done < execs {
        // A fresh pair of endpoints every 2 000 executions; state carries over
        // in between so deep states are reached.
        let mut f = Fuzzer::new(s);
        let n = (execs - done).min(2_000);
        for _ in 0..n {
            f.exec();
        }
        done += n;
        frames += f.frames_out;
        delivered += (f.board.stats().delivered + f.host.stats().delivered) as u64;
        let d = f.dec.stats();
        accepted += u64::from(d.frames);
        rejected += u64::from(d.bad_cobs + d.runts + d.bad_crc + d.bad_header + d.oversize);
        s = s.wrapping_add(0x9E37_79B9);
    }
    (frames, delivered, accepted, rejected)
}

#[test]
fn fuzz_decoder_and_endpoints() {
    let (frames, delivered, accepted, rejected) = run(FUZZ_DEFAULT, 1);
    println!(
        "fuzz: {FUZZ_DEFAULT} executions, {frames} frames emitted, {delivered} messages \
         delivered, input frames {accepted} accepted / {rejected} rejected"
    );
    // The endpoints kept their invariants (checked in every execution) through both kinds of
    // input: valid frames (the generator reaches the connected states and messages are
    // delivered) and damaged ones (every rejection path of the decoder is fed).
    assert!(
        frames > FUZZ_DEFAULT && delivered > 1_000,
        "{frames} {delivered}"
    );
    assert!(
        accepted > 1_000 && rejected > 1_000,
        "{accepted} {rejected}"
    );
}

#[test]
#[ignore = "long run: GANTRY_FUZZ_EXECS=1000000, use --release"]
fn fuzz_long() {
    let execs: u64 = std::env::var("GANTRY_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let t = Instant::now();
    let (frames, delivered, accepted, rejected) = run(execs, 0x5EED);
    let n = execs;
    let dt = t.elapsed();
    println!(
        "board endpoint {} B, host endpoint {} B",
        std::mem::size_of::<BoardEndpoint>(),
        std::mem::size_of::<HostEndpoint>()
    );
    println!(
        "fuzz: {n} executions, {frames} frames emitted, {delivered} messages delivered, \
         input frames {accepted} accepted / {rejected} rejected, {:.1} s, {:.0} exec/s",
        dt.as_secs_f64(),
        n as f64 / dt.as_secs_f64()
    );
}
