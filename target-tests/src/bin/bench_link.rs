//! MCU cost of the board's side of the host link per streamed line, apart from the G-code work:
//! a host endpoint (untimed) streams short G1 lines (`G1 Y-6.789 F3000`,
//! `gantry_target_tests::program`) the way `gantry stream` does (host-sender/src/session/job.rs
//! `send_lines`): blanks stripped (`G1X-99.893Y-6.789F3000`, as `Program::wire_text` sends it),
//! packed with `gantry_proto::lines::push_record` into `HostMsg::Lines` batches, a new batch
//! whenever the queued lane has a free place. The board takes them the way its main loop does
//! (machine/src/device/main_loop.rs, one pass per virtual millisecond) through the public API
//! only: `BoardLink::on_bytes` in 64-byte reads (frame decoder, COBS, CRC, the batch read in
//! place and copied into the line ring, the receive window), `BoardLink::service` twice (status
//! reports, credit) and `BoardLink::poll_transmit` (acks, status frames); those are the link.
//! `Board::poll` and `Board::next_segment` (interpret, plan, prepare) are timed apart.
//!
//! The steady-state run packs each batch up to `gantry_proto::lines::BATCH_MAX` record bytes:
//! the limit the host's `BatchSize` grows to while nothing is retransmitted (10 short lines a
//! frame). A run of passes with nothing received gives the link's cost of a pass; two runs of
//! 4-line batches, the lines bare and padded with a 40-byte comment (same frames and lines, more
//! bytes), give its cost per received wire byte; the steady-state run and the bare 4-line run
//! then split the rest into a cost per frame and per line. The CPU model's frame figure is the
//! cost of a steady-state batch less its bytes (per frame plus ten lines' share). Run with the
//! `-icount shift=0,sleep=off` runner (target-tests/README.md); the last line (`figures ...`) is
//! what scripts/bench-mcu.sh reads.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use gantry_machine::board::Board;
use gantry_machine::device::link::{BoardLink, KernelView};
use gantry_machine::setup::Setup;
use gantry_proto::lines::{push_record, record_len, BATCH_MAX};
use gantry_proto::{Config, HostEndpoint, HostMsg, Lane, LineBatch, MAX_FRAME_LEN};
use gantry_target_tests::clock::{self, now, timer_overhead};
use gantry_target_tests::program::{padded_line, TextLine};
use gantry_target_tests::{exit, println};

/// Instructions per SysTick count (25 MHz SysTick, one instruction per ns: 40).
const INSTR_PER_COUNT: u64 = 40;
/// Lines streamed before the measured ones (window and planner in steady state).
const WARM_UP: u32 = 300;
/// Lines measured per run (a multiple of every run's lines per batch).
const LINES: u32 = 2_000;
/// Lines per batch of the runs that split the cost per byte from the rest (a padded line's
/// record is 68 bytes: four fill a frame's [`BATCH_MAX`]).
const SPLIT_BATCH: usize = 4;

/// Planner blocks kept queued ahead of segment preparation (of the board's 128).
const LOOK_AHEAD: usize = 96;

/// Batches the host can have unacknowledged at once, at most (its queued lane holds fewer).
const IN_FLIGHT: usize = 64;

/// How the host packs lines: at most `lines` a batch, and `BATCH_MAX` bytes.
#[derive(Clone, Copy)]
struct Packing {
    /// Bytes of comment padding each line.
    pad: usize,
    lines: usize,
}

impl Packing {
    /// What `gantry stream` sends in steady state: bare lines, each batch filled to its limit.
    const STEADY: Packing = Packing {
        pad: 0,
        lines: usize::MAX,
    };
}

/// Counts spent per stage, and what went through the link.
#[derive(Default, Clone, Copy)]
struct Tally {
    /// SysTick counts in `on_bytes`, `service` and `poll_transmit` (the link).
    link: u64,
    /// SysTick counts in `Board::poll` and `next_segment` (interpret, plan, prepare).
    motion: u64,
    /// Bytes and frames the board received.
    rx_bytes: u64,
    rx_frames: u64,
    /// Segments the board prepared.
    segments: u64,
    passes: u64,
}

/// A host endpoint wired to a board and its link, with a virtual millisecond clock.
struct Rig {
    host: HostEndpoint,
    link: BoardLink,
    board: Board,
    now_ms: u32,
    /// The next line number the host sends.
    next_line: u32,
    packing: Packing,
    /// The last line of each batch sent and not known acknowledged, oldest first (a ring).
    batch_ends: [u32; IN_FLIGHT],
    first_batch: usize,
    batches: usize,
    /// The last line of the newest batch the board acknowledged.
    delivered: u32,
}

/// Line `i` as the host sends it: blanks stripped (`host-sender/src/program.rs` `strip`), the
/// padding comment kept (the board's interpreter skips it; it only lengthens the record).
fn wire_line(i: u32, pad: usize) -> TextLine {
    padded_line(i, pad).without_blanks()
}

impl Rig {
    /// Connected, with a job started, nothing streamed yet.
    fn new(packing: Packing) -> Rig {
        let mut rig = Rig {
            host: HostEndpoint::new_host(Config::USB_MS, 7),
            link: BoardLink::new(1),
            board: Board::new(Setup::default()),
            now_ms: 0,
            next_line: 1,
            packing,
            batch_ends: [0; IN_FLIGHT],
            first_batch: 0,
            batches: 0,
            delivered: 0,
        };
        let mut t = Tally::default();
        while !rig.host.is_up() {
            rig.pass(&mut t, 0);
        }
        if rig.host.send(HostMsg::Start { id: 1 }).is_err() {
            fail("the host could not send Start");
        }
        for _ in 0..5 {
            rig.pass(&mut t, 0);
        }
        rig
    }

    /// Forgets the batches the board acknowledged, noting the last line they carried.
    fn note_acks(&mut self) {
        let unacked = self.host.unacked(Lane::Queued);
        while self.batches > unacked {
            self.delivered = self.batch_ends[self.first_batch];
            self.first_batch = (self.first_batch + 1) % IN_FLIGHT;
            self.batches -= 1;
        }
    }

    /// The host packs and queues batches of lines up to `last` while its queued lane has a
    /// free place (as `send_lines` does).
    fn send_lines(&mut self, last: u32) {
        while self.next_line <= last && self.host.send_capacity(Lane::Queued) > 0 {
            if self.batches == IN_FLIGHT {
                fail("more batches in flight than the rig keeps");
            }
            let mut records = LineBatch::new();
            let mut lines = 0;
            while self.next_line <= last && lines < self.packing.lines {
                let text = wire_line(self.next_line, self.packing.pad);
                if records.len() + record_len(text.as_bytes().len()) > BATCH_MAX
                    || !push_record(&mut records, self.next_line, text.as_bytes())
                {
                    break;
                }
                self.next_line += 1;
                lines += 1;
            }
            if lines == 0 {
                fail("a line too long for a batch");
            }
            if self.host.send(HostMsg::Lines { id: 0, records }).is_err() {
                fail("the host could not send a batch");
            }
            self.batch_ends[(self.first_batch + self.batches) % IN_FLIGHT] = self.next_line - 1;
            self.batches += 1;
        }
    }

    /// One main-loop pass at the next millisecond; the host sends lines up to `last`.
    fn pass(&mut self, t: &mut Tally, last: u32) {
        // The host side (untimed): batches while the lane has room, then its frames.
        self.send_lines(last);
        let mut wire = [0u8; 16 * MAX_FRAME_LEN];
        let mut len = 0;
        while let Some(n) = self.host.poll_transmit(self.now_ms, &mut wire[len..]) {
            len += n;
            t.rx_frames += 1;
            if wire.len() - len < MAX_FRAME_LEN {
                break;
            }
        }
        t.rx_bytes += len as u64;
        let view = KernelView::default();
        // Out of the timed part: the board transmits through one frame-sized buffer a pass
        // (machine/src/device/main_loop.rs); zeroing this 16-frame one took ~1,950 instructions.
        let mut out = [0u8; 16 * MAX_FRAME_LEN];
        // The board's pass: receive, service, motion, service, transmit.
        let t0 = now();
        for chunk in wire[..len].chunks(64) {
            self.link
                .on_bytes(&mut self.board, self.now_ms, black_box(chunk));
        }
        self.link.service(&mut self.board, self.now_ms, &view);
        let t1 = now();
        self.board.poll(false);
        // Segments are taken only behind a full look-ahead, as a kernel running in real time
        // would (draining the planner each pass would prepare every block's ramp to rest).
        while self.board.motion().planner().len() > LOOK_AHEAD {
            let Some(seg) = self.board.next_segment() else {
                break;
            };
            black_box(seg);
            t.segments += 1;
        }
        let t2 = now();
        self.link.service(&mut self.board, self.now_ms, &view);
        let mut out_len = 0;
        while out.len() - out_len >= MAX_FRAME_LEN {
            let Some(n) = self.link.poll_transmit(self.now_ms, &mut out[out_len..]) else {
                break;
            };
            out_len += n;
        }
        let t3 = now();
        t.link += (t1 - t0) + (t3 - t2);
        t.motion += t2 - t1;
        t.passes += 1;
        // The host hears the acks and status (untimed).
        self.host.on_bytes(self.now_ms, &out[..out_len]);
        while black_box(self.host.recv()).is_some() {}
        while black_box(self.host.poll_event()).is_some() {}
        self.note_acks();
        self.now_ms += 1;
    }

    /// Streams `count` more lines and passes until the board has acknowledged every one: what
    /// the board's side spent on them.
    fn stream(&mut self, count: u32) -> Tally {
        let last = self.next_line - 1 + count;
        let mut t = Tally::default();
        while self.delivered < last {
            self.pass(&mut t, last);
            if t.passes > 100 * count as u64 {
                fail("the board stopped taking lines");
            }
        }
        t
    }
}

/// Ends the run with failure, saying why.
fn fail(why: &str) -> ! {
    println!("bench_link: {}", why);
    exit(false)
}

/// Instructions × 1000 of the stage counts `counts` over `calls` timed calls.
fn instr_milli(counts: u64, calls: u64, overhead: u64) -> u64 {
    (counts * 1000).saturating_sub(calls * overhead) * INSTR_PER_COUNT
}

/// What one run of [`LINES`] lines measured: link and motion instructions × 1000 in total,
/// passes, and the bytes and frames the board received.
struct Run {
    link: u64,
    passes: u64,
    bytes: u64,
    frames: u64,
}

fn run(packing: Packing, overhead: u64) -> Run {
    let mut rig = Rig::new(packing);
    rig.stream(WARM_UP);
    let t = rig.stream(LINES);
    // Each pass times the link in two stages and motion in one, one `now()` pair each.
    let r = Run {
        link: instr_milli(t.link, 2 * t.passes, overhead),
        passes: t.passes,
        bytes: t.rx_bytes,
        frames: t.rx_frames,
    };
    let motion = instr_milli(t.motion, t.passes, overhead);
    let n = LINES as u64;
    println!(
        "lines padded by {} bytes, {} a frame: {} wire bytes in {} frames for {} lines ({} segments) in {} passes; per line: link {} instructions, interpret + plan + prepare {}",
        packing.pad,
        (n + r.frames / 2) / r.frames,
        r.bytes,
        r.frames,
        n,
        t.segments,
        r.passes,
        r.link / 1000 / n,
        motion / 1000 / n
    );
    r
}

/// Link instructions × 1000 of a pass that received nothing (service, status every 100 ms).
fn idle_pass(overhead: u64) -> u64 {
    let mut rig = Rig::new(Packing::STEADY);
    rig.stream(50);
    let mut t = Tally::default();
    const PASSES: u32 = 1000;
    let last = rig.next_line - 1;
    for _ in 0..PASSES {
        rig.pass(&mut t, last);
    }
    instr_milli(t.link, 2 * t.passes, overhead) / PASSES as u64
}

/// Instructions per byte × 1000 of `gantry_proto::crc::crc32` over a 48-byte frame body.
fn crc_per_byte() -> u64 {
    const N: u64 = 1000;
    let body = [0xA5u8; 48];
    let t0 = now();
    let mut acc = 0u32;
    for _ in 0..N {
        acc ^= gantry_proto::crc::crc32(black_box(&body));
    }
    black_box(acc);
    (now() - t0) * INSTR_PER_COUNT * 1000 / N / body.len() as u64
}

/// `a.b` with three places of a value × 1000.
struct Milli(u64);

impl core::fmt::Display for Milli {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}.{:03}", self.0 / 1000, self.0 % 1000)
    }
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap();
    clock::start(&mut cp.SYST);

    let overhead = timer_overhead();
    let crc = crc_per_byte();
    println!("crc32: {} instructions per byte", Milli(crc));
    let idle = idle_pass(overhead);
    let steady = run(Packing::STEADY, overhead);
    let bare = run(
        Packing {
            pad: 0,
            lines: SPLIT_BATCH,
        },
        overhead,
    );
    let padded = run(
        Packing {
            pad: 40,
            lines: SPLIT_BATCH,
        },
        overhead,
    );
    if padded.bytes <= bare.bytes || padded.frames != bare.frames {
        fail("the padded run must differ in bytes only");
    }
    if steady.frames >= bare.frames {
        fail("the steady-state batches must carry more lines than the split runs'");
    }
    // link = passes · idle + frames · per_frame + lines · per_line + bytes · per_byte (× 1000);
    // `rest` is what is left after the passes and the bytes, per frame and line.
    let net = |r: &Run| r.link.saturating_sub(r.passes * idle);
    let per_byte = net(&padded).saturating_sub(net(&bare)) / (padded.bytes - bare.bytes);
    let rest = |r: &Run| net(r).saturating_sub(per_byte * r.bytes);
    // Both runs carry LINES lines: the difference of the rests is the difference of frames.
    let per_frame = rest(&bare).saturating_sub(rest(&steady)) / (bare.frames - steady.frames);
    let n = LINES as u64;
    let per_line = rest(&steady).saturating_sub(per_frame * steady.frames) / n;
    // The CPU model charges frames and bytes: a steady-state frame carries its lines' share.
    let steady_frame = rest(&steady) / steady.frames;
    println!(
        "link: {} instructions per pass + {} per frame + {} per line + {} per wire byte; a steady-state frame ({} lines) {} + bytes",
        idle / 1000,
        per_frame / 1000,
        per_line / 1000,
        Milli(per_byte),
        (n + steady.frames / 2) / steady.frames,
        steady_frame / 1000
    );
    // For scripts/bench-mcu.sh (emulator/src/cpu_model_f411.rs, firmware/README.md).
    println!(
        "figures link_line={} link_pass={} link_frame={} link_byte={} line_bytes={} lines_per_frame={} lines_per_pass={}",
        steady.link / 1000 / n,
        (idle + 500) / 1000,
        (steady_frame + 500) / 1000,
        (per_byte + 500) / 1000,
        (steady.bytes + n / 2) / n,
        (n + steady.frames / 2) / steady.frames,
        (n + steady.passes / 2) / steady.passes
    );
    exit(true)
}
