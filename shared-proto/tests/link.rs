//! End-to-end link tests: two endpoints through fault pipes.

mod support;

use gantry_proto::fault::Faults;
use gantry_proto::frame::{encode_frame, Header, Kind, MAX_FRAME_LEN};
use gantry_proto::Lane;
use gantry_proto::{
    BoardEndpoint, BoardInbound, BoardMsg, Config, HelloAck, HostEndpoint, HostMsg, LinkEvent,
    LinkState, MachineState, Status,
};
use support::{batch, line, lines_of, Sim, INBOX_BYTES, SIM};

/// The largest batch the tests send: 4 lines of at most 20 characters.
const MAX_BATCH_CHARGE: u32 = 4 * (6 + 20);

fn status(line: u32) -> BoardMsg {
    BoardMsg::Status(Status {
        state: MachineState::Run,
        machine_pos: [line as i64 * 1000, -7, 3, 0, 0, 0],
        work_pos: [0; 6],
        feed_um_min: 1_200_000,
        feed_override: 100,
        rapid_override: 100,
        spindle_override: 100,
        programmed_feed_um_min: 0,
        work_system: 0,
        inch: false,
        planner_fill: 3,
        queue_fill: 1,
        line,
        inputs: 0,
        homed: 0b111,
        outputs: Default::default(),
        starved_ms: 0,
        probe: None,
    })
}

/// Streams lines `1..=total` host → board with the board app consuming at a
/// random rate, the board sending a `Mark` every 100 lines and answering
/// status requests. Checks order, no loss, no repetition, credit.
struct Stream {
    total: u32,
    next_send: u32,
    next_recv: u32,
    next_mark: u32,
    marks_seen: u32,
    status_seen: u32,
}

impl Stream {
    fn new(total: u32) -> Self {
        Self {
            total,
            next_send: 1,
            next_recv: 1,
            next_mark: 100,
            marks_seen: 0,
            status_seen: 0,
        }
    }

    /// Batches of 1 to 4 lines.
    fn send_lines(&mut self, sim: &mut Sim) {
        while self.next_send <= self.total {
            let n = (1 + sim.rng().below(4)).min(self.total + 1 - self.next_send);
            match sim.host.send(batch(self.next_send, n)) {
                Ok(()) => self.next_send += n,
                Err(_) => break,
            }
        }
    }

    fn host_app(&mut self, sim: &mut Sim) {
        self.send_lines(sim);
        if sim.now.is_multiple_of(97) {
            let _ = sim.host.send(HostMsg::StatusRequest);
        }
        while let Some(m) = sim.host.recv() {
            match m {
                BoardMsg::Mark { line, .. } => {
                    assert_eq!(line, self.next_mark, "board→host mark order");
                    self.next_mark += 100;
                    self.marks_seen += 1;
                }
                BoardMsg::Status(_) => self.status_seen += 1,
                other => panic!("unexpected {other:?}"),
            }
        }
    }

    fn board_app(&mut self, sim: &mut Sim, max_per_tick: u32) {
        while let Some(m) = sim.board.recv_realtime() {
            assert_eq!(m, BoardInbound::StatusRequest);
            let _ = sim.board.send(status(self.next_recv));
        }
        let k = sim.rng().below(max_per_tick + 1);
        for _ in 0..k {
            let Some(m) = sim.board_recv_queued() else {
                break;
            };
            for (n, text) in lines_of(&m) {
                assert_eq!(
                    (n, text),
                    (self.next_recv, line(self.next_recv)),
                    "host→board order/content"
                );
                if n.is_multiple_of(100) {
                    sim.board
                        .send(BoardMsg::Mark { line: n, id: 0 })
                        .expect("board send queue");
                }
                self.next_recv += 1;
            }
        }
        assert!(sim.inbox.used() <= u32::from(INBOX_BYTES));
    }

    fn done(&self) -> bool {
        self.next_recv > self.total && self.next_mark > self.total
    }

    fn run(&mut self, sim: &mut Sim, max_ticks: u32, rate: u32) {
        for _ in 0..max_ticks {
            if self.done() {
                return;
            }
            self.host_app(sim);
            sim.pump();
            self.board_app(sim, rate);
        }
        panic!(
            "not done: received {} of {}, marks up to {}; host {:?} board {:?}",
            self.next_recv - 1,
            self.total,
            self.next_mark,
            sim.host.stats(),
            sim.board.stats()
        );
    }
}

fn assert_clean(sim: &Sim) {
    assert_eq!(
        sim.credit_violations, 0,
        "host wrote data beyond the board's credit"
    );
    assert!(sim.max_in_flight <= u32::from(INBOX_BYTES));
    assert_eq!(sim.board.stats().window_violations, 0);
    assert_eq!(sim.host.stats().window_violations, 0);
    assert_eq!(sim.board.stats().undecodable, 0);
    assert_eq!(sim.host.stats().undecodable, 0);
}

#[test]
fn perfect_link_streams_in_order() {
    let mut sim = Sim::new(1, Faults::NONE, SIM);
    sim.connect(100);
    let mut s = Stream::new(5_000);
    s.run(&mut sim, 20_000, 8);
    assert_clean(&sim);
    assert_eq!(sim.host.stats().retransmits, 0);
    assert!(s.status_seen > 0);
}

/// The acceptance test: 100 000 sequenced lines through 1 % byte drop, 1 %
/// corruption and 1 % duplication in both directions.
#[test]
fn hundred_thousand_lines_through_faults() {
    let f = Faults::uniform(10_000);
    let mut sim = Sim::new(42, f, SIM);
    sim.connect(1_000);
    let mut s = Stream::new(100_000);
    s.run(&mut sim, 3_000_000, 8);
    assert_clean(&sim);
    let (h, b) = (sim.host.stats(), sim.board.stats());
    let (p1, p2) = (sim.h2b.stats(), sim.b2h.stats());
    assert!(p1.dropped > 0 && p1.corrupted > 0 && p1.duplicated > 0);
    assert!(h.retransmits > 0 && b.decoder.bad_crc + b.decoder.bad_cobs > 0);
    assert_eq!(s.marks_seen, 1_000);
    eprintln!(
        "100k lines: {} ticks, host {h:?}, board {b:?}, h2b {p1:?}, b2h {p2:?}",
        sim.now
    );
}

#[test]
fn delays_and_faults_with_slow_consumer() {
    let f = Faults {
        delay_ppm: 2_000,
        max_delay: 30,
        ..Faults::uniform(5_000)
    };
    let mut sim = Sim::new(7, f, SIM);
    sim.connect(1_000);
    let mut s = Stream::new(5_000);
    s.run(&mut sim, 500_000, 1);
    assert_clean(&sim);
}

#[test]
fn flow_control_never_exceeds_window() {
    for seed in 0..4u64 {
        let f = if seed % 2 == 0 {
            Faults::NONE
        } else {
            Faults::uniform(10_000)
        };
        let mut sim = Sim::new(100 + seed, f, SIM);
        sim.connect(1_000);
        let mut s = Stream::new(3_000);
        // Stall the consumer for a while: the host must stop at the credit.
        for _ in 0..500 {
            s.host_app(&mut sim);
            sim.pump();
        }
        // The credit is spent: no further batch fits.
        assert!(sim.inbox.used() > u32::from(INBOX_BYTES) - MAX_BATCH_CHARGE);
        assert!(sim.host.unacked(Lane::Queued) > 0);
        assert_eq!(sim.board.stats().window_violations, 0);
        s.run(&mut sim, 500_000, 2);
        assert_clean(&sim);
    }
}

#[test]
fn realtime_bypasses_a_full_queue() {
    let mut sim = Sim::new(3, Faults::NONE, SIM);
    sim.connect(100);
    for n in 1..=30 {
        let _ = sim.host.send(batch(n, 1));
    }
    for _ in 0..50 {
        sim.pump();
    }
    // Credit exhausted: the board holds some lines, the host keeps the rest.
    assert!(sim.inbox.len() < 30 && sim.host.unacked(Lane::Queued) > 0);
    sim.host.send(HostMsg::FeedHold).unwrap();
    sim.host.send(HostMsg::FeedOverride(50)).unwrap();
    sim.pump();
    assert_eq!(sim.board.recv_realtime(), Some(BoardInbound::FeedHold));
    assert_eq!(
        sim.board.recv_realtime(),
        Some(BoardInbound::FeedOverride(50))
    );
    // Then the queued lines, in order.
    assert_eq!(sim.board_recv_queued(), Some(batch(1, 1)));
}

#[test]
fn realtime_lane_survives_faults_in_order() {
    let mut sim = Sim::new(9, Faults::uniform(20_000), SIM);
    sim.connect(1_000);
    let mut sent = 0u16;
    let mut got = 0u16;
    for _ in 0..200_000 {
        if sent < 3_000 && sim.host.send(HostMsg::FeedOverride(sent)).is_ok() {
            sent += 1;
        }
        sim.pump();
        while let Some(m) = sim.board.recv_realtime() {
            assert_eq!(m, BoardInbound::FeedOverride(got));
            got += 1;
        }
        if got == 3_000 {
            return;
        }
    }
    panic!("only {got} realtime messages");
}

/// The host process dies mid-job; a new one connects, learns the last
/// delivered line from the handshake and continues: the board sees every
/// line exactly once.
#[test]
fn host_restart_resumes_without_loss_or_repetition() {
    let mut sim = Sim::new(11, Faults::uniform(5_000), SIM);
    sim.connect(1_000);
    let mut s = Stream::new(12_000);
    while s.next_recv < 4_000 {
        s.host_app(&mut sim);
        sim.pump();
        s.board_app(&mut sim, 4);
    }
    // Crash: bytes in flight are lost, the board carries on alone a while.
    sim.h2b.clear();
    sim.b2h.clear();
    for _ in 0..200 {
        sim.transmit();
        sim.h2b.clear();
        sim.b2h.clear();
        s.board_app(&mut sim, 4);
        sim.now += 1;
    }
    sim.host = HostEndpoint::new_host(SIM, 0xDEAD_BEEF);
    let mut resumed = None;
    for _ in 0..10_000 {
        sim.pump();
        s.board_app(&mut sim, 4);
        while let Some(e) = sim.host.poll_event() {
            if let LinkEvent::Connected { ack, board_reset } = e {
                assert!(!board_reset);
                resumed = Some(ack.last_line);
            }
        }
        if resumed.is_some() {
            break;
        }
    }
    let last = resumed.expect("reconnected");
    // Every line the board's application took (4,000 before the crash, lines 0..=3,999, and
    // any it took alone after) was delivered, so the handshake reports at least the last of
    // them; lines beyond what the host sent cannot be.
    assert!(
        last + 1 >= s.next_recv && last < s.next_send,
        "last {last}, next_recv {}, next_send {}",
        s.next_recv,
        s.next_send
    );
    s.next_send = last + 1;
    // Marks the old host never acknowledged come again to the new host.
    s.next_mark = 0;
    s.run_after_restart(&mut sim);
    assert_clean(&sim);
}

impl Stream {
    /// Like `run`, but accepts board→host marks from any multiple of 100
    /// onward (a new host may get re-sent marks the old one already saw).
    fn run_after_restart(&mut self, sim: &mut Sim) {
        for _ in 0..2_000_000 {
            if self.next_recv > self.total {
                return;
            }
            self.send_lines(sim);
            while let Some(m) = sim.host.recv() {
                if let BoardMsg::Mark { line, .. } = m {
                    assert!(line > self.next_mark, "marks in order, no repeats");
                    self.next_mark = line;
                }
            }
            sim.pump();
            self.board_app(sim, 4);
        }
        panic!("stalled at {}", self.next_recv);
    }
}

/// The cable is pulled for a while and plugged back; the same host endpoint
/// reconnects and nothing is lost or repeated in either direction.
#[test]
fn cable_pull_and_reconnect_same_host() {
    let f = Faults::uniform(5_000);
    let mut sim = Sim::new(13, f, SIM);
    sim.connect(1_000);
    let mut s = Stream::new(10_000);
    for round in 0..3 {
        while s.next_recv < 2_500 * (round + 1) {
            s.host_app(&mut sim);
            sim.pump();
            s.board_app(&mut sim, 4);
        }
        let pulled = Faults {
            drop_ppm: 1_000_000,
            ..Faults::NONE
        };
        sim.set_faults(pulled);
        for _ in 0..300 {
            s.host_app(&mut sim);
            sim.pump();
            s.board_app(&mut sim, 4);
        }
        sim.set_faults(f);
        sim.host.connect();
    }
    s.run(&mut sim, 2_000_000, 4);
    assert_clean(&sim);
}

/// The board resets (new boot id): the host is told to say Hello again,
/// learns of the reset, and the link carries on in order.
#[test]
fn board_reset_is_detected() {
    let mut sim = Sim::new(17, Faults::NONE, SIM);
    sim.connect(100);
    for n in 1..=10 {
        sim.host.send(batch(n, 1)).unwrap();
    }
    for _ in 0..20 {
        sim.pump();
    }
    while sim.host.poll_event().is_some() {}
    sim.reset_board(0x1234_5678);
    assert_eq!(sim.board.state(), LinkState::Unsynced);
    // The host only notices when it sends something.
    for n in 11..=30 {
        sim.host.send(batch(n, 1)).unwrap();
    }
    let mut reset_seen = false;
    let mut got = Vec::new();
    for _ in 0..2_000 {
        sim.pump();
        while let Some(e) = sim.host.poll_event() {
            if let LinkEvent::Connected { board_reset, .. } = e {
                reset_seen |= board_reset;
            }
        }
        while let Some(m) = sim.board_recv_queued() {
            got.extend(lines_of(&m).into_iter().map(|(n, _)| n));
        }
    }
    assert!(reset_seen);
    assert!(!got.is_empty());
    assert_eq!(*got.last().unwrap(), 30);
    assert!(got.windows(2).all(|w| w[1] == w[0] + 1), "{got:?}");
}

#[test]
fn version_mismatch_is_refused() {
    let mut host = HostEndpoint::new_host(SIM, 5);
    let mut buf = [0u8; MAX_FRAME_LEN];
    assert!(host.poll_transmit(0, &mut buf).is_some()); // Hello
    let ack = HelloAck {
        version: 0x7F00,
        nonce: host.nonce(),
        boot_id: 1,
        rx_capacity: 16,
        rt_capacity: 8,
        next_expected: 0,
        rt_next_expected: 0,
        window: 16,
        rt_window: 8,
        tx_base: 0,
        rt_tx_base: 0,
        last_line: 0,
    };
    let n = encode_frame(&Header::new(Kind::HelloAck), Some(&ack), &mut buf).unwrap();
    host.on_bytes(1, &buf[..n]);
    assert_eq!(
        host.state(),
        LinkState::Incompatible {
            peer_version: 0x7F00
        }
    );
    assert_eq!(
        host.poll_event(),
        Some(LinkEvent::VersionMismatch {
            peer_version: 0x7F00
        })
    );

    let mut board = BoardEndpoint::new_board(Config::default(), 9, INBOX_BYTES);
    let hello = gantry_proto::Hello {
        version: 0x0100,
        nonce: 1,
        window: 8,
        rt_window: 8,
    };
    let n = encode_frame(&Header::new(Kind::Hello), Some(&hello), &mut buf).unwrap();
    board.on_bytes(0, &buf[..n], &mut support::Inbox::default());
    assert_eq!(board.state(), LinkState::Unsynced);
    // It still answers, so the host can report the board's version.
    let n = board.poll_transmit(0, &mut buf).unwrap();
    let mut dec = gantry_proto::FrameDecoder::new();
    let mut kind = None;
    dec.feed(&buf[..n], |f| kind = Some(f.header.kind));
    assert_eq!(kind, Some(Kind::HelloAck));
}

/// The window update that reopens a closed window is lost: the sender's
/// probe (Ack with POLL after `rto`) recovers, no deadlock.
#[test]
fn lost_window_update_is_recovered_by_probe() {
    let mut sim = Sim::new(21, Faults::NONE, SIM);
    sim.connect(100);
    for n in 1..=30 {
        let _ = sim.host.send(batch(n, 1));
    }
    for _ in 0..30 {
        sim.pump();
    }
    let first = sim.inbox.len();
    assert!(first < 30 && sim.host.unacked(Lane::Queued) > 0);
    let mut got = 0;
    while sim.board_recv_queued().is_some() {
        got += 1;
    }
    // The board's window update goes out, and is lost.
    sim.transmit();
    sim.b2h.clear();
    sim.h2b.clear();
    let t0 = sim.now;
    while sim.inbox.len() == 0 {
        sim.now += 1;
        sim.pump();
        assert!(sim.now - t0 < 3 * SIM.rto, "host never probed"); // keepalive is 50
    }
    while sim.board_recv_queued().is_some() {
        got += 1;
    }
    assert!(got > first);
}

#[test]
fn next_deadline_tracks_retransmission() {
    let mut sim = Sim::new(23, Faults::NONE, SIM);
    sim.connect(100);
    sim.pump();
    sim.host.send(HostMsg::Start { id: 1 }).unwrap();
    sim.transmit(); // sent, not delivered yet
    let sent_at = sim.now;
    sim.h2b.clear(); // lost
    let d = sim.host.next_deadline().unwrap();
    assert_eq!(d, sent_at + SIM.rto);
    while sim.inbox.len() == 0 {
        sim.pump();
        assert!(sim.now <= d + 2);
    }
}
