//! Throughput of program lines through the reliable channel, packed into
//! `Lines` batches as `gantry stream` packs them: the host endpoint encodes,
//! the board endpoint decodes, hands each batch to its sink and acknowledges,
//! the host decodes the acks (perfect in-memory pipe, both directions).
//!
//! `cargo bench -p gantry-proto --bench channel`; the last line is
//! `lines_per_s: N` (lines delivered to the board application per second of
//! CPU on this machine).

use criterion::{Criterion, Throughput};
use gantry_proto::channel::{QueuedSink, Refusal};
use gantry_proto::frame::{encode_frame, FrameDecoder, Header, Kind, MAX_FRAME_LEN};
use gantry_proto::lines::{check_records, push_record};
use gantry_proto::{BoardEndpoint, Config, HostEndpoint, HostMessage, HostMsg, LineBatch};
use std::hint::black_box;
use std::time::Instant;

const CFG: Config = Config {
    rto: 50,
    hello_interval: 10,
    keepalive: 0,
};

/// The board application: checks each batch's records and counts the lines (it takes them at once,
/// so its room is always the whole ring).
struct Counter(usize);

const RING: u16 = 4096;
const TEXT: &[u8] = b"G1 X123.456 Y-78.9 F1500";

impl QueuedSink for Counter {
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
        let m = gantry_proto::codec::decode_borrowed::<HostMessage<&[u8]>>(payload)
            .ok_or(Refusal::Undecodable)?;
        if let HostMessage::Lines { records, .. } = m {
            let run = check_records(records).ok_or(Refusal::Undecodable)?;
            self.0 += run.lines;
            return Ok(run.last_line);
        }
        Ok(None)
    }
    fn room(&self) -> u16 {
        RING
    }
}

struct Pair {
    host: HostEndpoint,
    board: BoardEndpoint,
    now: u32,
    next: u32,
    buf: [u8; MAX_FRAME_LEN],
    wire: Vec<u8>,
}

impl Pair {
    fn new() -> Self {
        let mut p = Self {
            host: HostEndpoint::new_host(CFG, 1),
            board: BoardEndpoint::new_board(CFG, 2, RING),
            now: 0,
            next: 1,
            buf: [0; MAX_FRAME_LEN],
            wire: Vec::with_capacity(8192),
        };
        while !(p.host.is_up() && p.board.is_up()) {
            p.step();
        }
        p
    }

    fn step(&mut self) -> usize {
        self.wire.clear();
        while let Some(n) = self.host.poll_transmit(self.now, &mut self.buf) {
            self.wire.extend_from_slice(&self.buf[..n]);
        }
        let mut counter = Counter(0);
        self.board.on_bytes(self.now, &self.wire, &mut counter);
        let got = black_box(counter.0);
        self.wire.clear();
        while let Some(n) = self.board.poll_transmit(self.now, &mut self.buf) {
            self.wire.extend_from_slice(&self.buf[..n]);
        }
        self.host.on_bytes(self.now, &self.wire);
        self.now = self.now.wrapping_add(1);
        got
    }

    /// Streams `count` lines; returns how many the board application got.
    fn stream(&mut self, count: u32) -> u32 {
        let end = self.next + count;
        let mut got = 0;
        while got < count {
            while self.next < end && self.host.send_capacity(gantry_proto::Lane::Queued) > 0 {
                let mut records = LineBatch::new();
                while self.next < end && push_record(&mut records, self.next, TEXT) {
                    self.next += 1;
                }
                let _ = self.host.send(HostMsg::Lines { id: 0, records });
            }
            got += self.step() as u32;
        }
        got
    }
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("proto");
    const BATCH: u32 = 1_000;
    g.throughput(Throughput::Elements(BATCH as u64));
    let mut pair = Pair::new();
    g.bench_function("lines_through_channel", |b| {
        b.iter(|| black_box(pair.stream(BATCH)))
    });

    g.throughput(Throughput::Elements(1));
    let mut records = LineBatch::new();
    push_record(&mut records, 4242, TEXT);
    let msg = HostMsg::Lines { id: 0, records };
    let mut out = [0u8; MAX_FRAME_LEN];
    let mut dec = FrameDecoder::new();
    g.bench_function("encode_decode_one_line_frame", |b| {
        b.iter(|| {
            let n =
                encode_frame(&Header::new(Kind::Data), Some(black_box(&msg)), &mut out).unwrap();
            let mut seen = 0;
            dec.feed(&out[..n], |f| seen += f.payload.len());
            black_box(seen)
        })
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    benches(&mut c);
    c.final_summary();
    // The figure scripts read: a fixed run timed once more.
    let mut pair = Pair::new();
    let n = 200_000;
    let t = Instant::now();
    let got = pair.stream(n);
    let dt = t.elapsed().as_secs_f64();
    println!("lines_per_s: {:.0}", got as f64 / dt);
}
