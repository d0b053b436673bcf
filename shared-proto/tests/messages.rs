//! Round trip of every message through the codec (postcard) and a frame, the exact wire bytes of
//! every message kind (`wire_bytes.txt`), damaged and random payloads, and worst-case sizes.

use gantry_proto::codec;
use gantry_proto::frame::{encode_frame, FrameDecoder, Header, Kind, MAX_FRAME_LEN, MAX_PAYLOAD};
use gantry_proto::lines::{push_record, BATCH_MAX};
use gantry_proto::messages::SETUP_CHUNK_MAX;
use gantry_proto::{
    BoardMsg, Hello, HelloAck, HostMsg, JobEnd, Jog, Lane, LineBatch, MachineState, OutputsStatus,
    ProbeStatus, ProgramTarget, SpindleStatus, Status, TorchStatus, Wire, AXES, LINE_MAX,
};
use serde::{de::DeserializeOwned, Serialize};
use std::fmt::Debug;

/// A batch of `lines` as (number, text).
fn lines(id: u16, lines: &[(u32, &str)]) -> HostMsg {
    let mut records = LineBatch::new();
    for (n, t) in lines {
        assert!(push_record(&mut records, *n, t.as_bytes()));
    }
    HostMsg::Lines { id, records }
}

/// The longest line, numbered `u32::MAX`.
fn worst_line(id: u16) -> HostMsg {
    lines(id, &[(u32::MAX, &"X".repeat(LINE_MAX))])
}

/// A batch as full as a frame allows.
fn full_batch() -> HostMsg {
    let mut records = LineBatch::new();
    let mut n = 1;
    while push_record(&mut records, n, b"G1 X1.234 Y5.678") {
        n += 1;
    }
    HostMsg::Lines { id: 0, records }
}

fn all_host() -> Vec<HostMsg> {
    vec![
        lines(0, &[(1, "G1 X10 Y-2.5 F1200")]),
        worst_line(0),
        lines(0, &[(7, "")]),
        lines(9001, &[(3, "G91 G0 Z1"), (4, "G0 X1")]),
        worst_line(u16::MAX),
        full_batch(),
        HostMsg::ProgramEnd {
            id: 12,
            found: true,
        },
        HostMsg::SetupChunk {
            offset: 128,
            bytes: heapless::Vec::from_slice(&[0, 1, 2, 0xFF]).unwrap(),
        },
        HostMsg::SetupChunk {
            offset: u32::MAX,
            bytes: heapless::Vec::from_slice(&[0xFF; SETUP_CHUNK_MAX]).unwrap(),
        },
        HostMsg::SetupCommit {
            id: u32::MAX,
            len: 1000,
            crc32: 0xDEAD_BEEF,
        },
        HostMsg::SetupRequest { id: u32::MAX },
        HostMsg::Start { id: 7 },
        HostMsg::StartFromLine {
            id: 8,
            line_no: 1234,
        },
        HostMsg::EndOfJob,
        HostMsg::FeedHold,
        HostMsg::Resume,
        HostMsg::Abort,
        HostMsg::FeedOverride(150),
        HostMsg::RapidOverride(25),
        HostMsg::Jog(Jog {
            id: 1,
            axis: 2,
            feed_um_min: -500_000,
            distance_nm: 0,
        }),
        HostMsg::Jog(Jog {
            id: u32::MAX,
            axis: 5,
            feed_um_min: i32::MIN,
            distance_nm: u64::MAX,
        }),
        HostMsg::JogStop,
        HostMsg::StatusRequest,
        HostMsg::Unlock { id: 3 },
        HostMsg::Home { id: 4, axes: 0b111 },
        HostMsg::TakeOver,
        HostMsg::SpindleOverride(120),
        HostMsg::OwnerLost,
    ]
}

fn worst_status() -> Status {
    Status {
        state: MachineState::Hold { stopped: true },
        machine_pos: [i64::MIN; AXES],
        work_pos: [i64::MAX; AXES],
        feed_um_min: u32::MAX,
        feed_override: u16::MAX,
        rapid_override: u16::MAX,
        spindle_override: u8::MAX,
        programmed_feed_um_min: u32::MAX,
        work_system: u8::MAX,
        inch: true,
        planner_fill: u16::MAX,
        queue_fill: u16::MAX,
        line: u32::MAX,
        inputs: u32::MAX,
        homed: u8::MAX,
        outputs: OutputsStatus {
            spindle: SpindleStatus::Ccw,
            rpm: u32::MAX,
            mist: true,
            flood: true,
            tool: u32::MAX,
            laser_permille: Some(u16::MAX),
            torch: Some(TorchStatus {
                on: true,
                waiting: true,
                arc_lost: true,
                thc_nm: i32::MIN,
            }),
        },
        starved_ms: u32::MAX,
        probe: Some(ProbeStatus {
            machine_pos: [i64::MIN; AXES],
            success: true,
        }),
    }
}

fn all_board() -> Vec<BoardMsg> {
    let states = [
        MachineState::Idle,
        MachineState::Run,
        MachineState::Hold { stopped: false },
        MachineState::Jog,
        MachineState::Alarm { code: u16::MAX },
        MachineState::Homing,
        MachineState::Check,
    ];
    let mut v: Vec<BoardMsg> = states
        .iter()
        .map(|&state| {
            BoardMsg::Status(Status {
                state,
                machine_pos: [10_000_000_000, -1, 0, 5, 6, 7],
                work_pos: [-10_000_000_000, 1, 2, 3, 4, 5],
                feed_um_min: 1_200_000,
                feed_override: 100,
                rapid_override: 50,
                spindle_override: 100,
                programmed_feed_um_min: 0,
                work_system: 0,
                inch: false,
                planner_fill: 127,
                queue_fill: 16,
                line: 99,
                inputs: 0b1010,
                homed: 0b111,
                outputs: OutputsStatus {
                    spindle: SpindleStatus::Cw,
                    rpm: 12_000,
                    mist: false,
                    flood: true,
                    tool: 3,
                    laser_permille: None,
                    torch: None,
                },
                starved_ms: 1_234,
                probe: (state == MachineState::Check).then_some(ProbeStatus {
                    machine_pos: [0, 0, -5_000_000, 0, 0, 0],
                    success: true,
                }),
            })
        })
        .collect();
    v.extend([
        BoardMsg::Status(worst_status()),
        BoardMsg::Alarm {
            code: 3,
            line: u32::MAX,
        },
        BoardMsg::Limit { axis: 1, max: true },
        BoardMsg::Error {
            line: 17,
            code: 33,
            column: 5,
        },
        BoardMsg::Mark { line: 200, id: 7 },
        BoardMsg::ProgramRequest {
            id: 1,
            target: ProgramTarget::Program(100),
        },
        BoardMsg::ProgramRequest {
            id: u16::MAX,
            target: ProgramTarget::Line(u32::MAX),
        },
        BoardMsg::SetupChunk {
            offset: u32::MAX,
            bytes: heapless::Vec::from_slice(&[0xff; SETUP_CHUNK_MAX]).unwrap(),
        },
        BoardMsg::SetupEnd {
            len: u32::MAX,
            crc32: u32::MAX,
        },
        BoardMsg::Answer {
            id: u32::MAX,
            code: 3,
        },
        BoardMsg::JobDone {
            line: u32::MAX,
            end: JobEnd::Alarm,
        },
    ]);
    v
}

fn round_trip<M: Serialize + DeserializeOwned + PartialEq + Debug>(m: &M) -> usize {
    let mut buf = [0u8; 512];
    let bytes = postcard::to_slice(m, &mut buf).unwrap();
    let n = bytes.len();
    let back: M = postcard::from_bytes(bytes).unwrap();
    assert_eq!(&back, m);
    // The codec writes exactly postcard's bytes and reads them back.
    let mut mine = [0u8; 512];
    let k = codec::encode(m, &mut mine).unwrap();
    assert_eq!(&mine[..k], &*bytes, "{m:?}");
    assert_eq!(codec::decode::<M>(bytes).as_ref(), Some(m));
    // Too little room is refused, not truncated.
    assert_eq!(codec::encode(m, &mut mine[..n - 1]), None);
    // And inside a frame.
    let mut out = [0u8; MAX_FRAME_LEN];
    let len = encode_frame(&Header::new(Kind::Data), Some(m), &mut out)
        .unwrap_or_else(|e| panic!("{m:?} does not fit a frame: {e:?}"));
    let mut d = FrameDecoder::new();
    let mut got = None;
    d.feed(&out[..len], |f| {
        got = Some(postcard::from_bytes::<M>(f.payload).unwrap())
    });
    assert_eq!(got.as_ref(), Some(m));
    n
}

#[test]
fn every_host_message_round_trips() {
    for m in all_host() {
        let n = round_trip(&m);
        assert!(n <= MAX_PAYLOAD);
    }
}

#[test]
fn every_board_message_round_trips() {
    for m in all_board() {
        let n = round_trip(&m);
        assert!(n <= MAX_PAYLOAD);
    }
}

#[test]
fn handshake_messages_round_trip() {
    round_trip(&Hello {
        version: gantry_proto::PROTOCOL_VERSION,
        nonce: u32::MAX,
        window: 32,
        rt_window: 8,
    });
    round_trip(&HelloAck {
        version: 0x0200,
        nonce: u32::MAX,
        boot_id: u32::MAX,
        rx_capacity: u16::MAX,
        rt_capacity: u16::MAX,
        next_expected: u16::MAX,
        rt_next_expected: u16::MAX,
        window: u16::MAX,
        rt_window: u8::MAX,
        tx_base: u16::MAX,
        rt_tx_base: u16::MAX,
        last_line: u32::MAX,
    });
}

#[test]
fn worst_case_line_frames_fit_a_frame() {
    let mut out = [0u8; MAX_FRAME_LEN];
    let h = Header {
        kind: Kind::Data,
        flags: 0x70,
        seq: u16::MAX,
        ack: u16::MAX,
        win: 255,
        rt_ack: u16::MAX,
        rt_win: 255,
    };
    let n = encode_frame(&h, Some(&worst_line(u16::MAX)), &mut out).unwrap();
    assert!(n <= MAX_FRAME_LEN, "worst line frame is {n} bytes");
    // The fullest batch fits a frame too; one byte more does not fit the batch.
    let full = HostMsg::Lines {
        id: u16::MAX,
        records: LineBatch::from_slice(&[0u8; BATCH_MAX]).unwrap(),
    };
    assert!(encode_frame(&h, Some(&full), &mut out).is_ok());
    let mut b = LineBatch::new();
    assert!(!push_record(&mut b, 1, "X".repeat(LINE_MAX + 1).as_bytes()));
}

#[test]
fn lanes() {
    for m in all_host() {
        let rt = matches!(
            m,
            HostMsg::FeedHold
                | HostMsg::Resume
                | HostMsg::Abort
                | HostMsg::FeedOverride(_)
                | HostMsg::RapidOverride(_)
                | HostMsg::Jog(_)
                | HostMsg::JogStop
                | HostMsg::StatusRequest
                | HostMsg::Unlock { .. }
                | HostMsg::Home { .. }
                | HostMsg::TakeOver
                | HostMsg::SpindleOverride(_)
                | HostMsg::OwnerLost
        );
        assert_eq!(m.lane() == Lane::Realtime, rt, "{m:?}");
    }
    assert_eq!(BoardMsg::Alarm { code: 1, line: 0 }.lane(), Lane::Realtime);
    assert_eq!(
        BoardMsg::JobDone {
            line: 1,
            end: JobEnd::Completed
        }
        .lane(),
        Lane::Queued
    );
    assert_eq!(worst_line(0).stream_token(), Some(u32::MAX));
    assert_eq!(
        worst_line(1).stream_token(),
        None,
        "a served place marks no stream position"
    );
    assert_eq!(lines(0, &[(3, "G0"), (9, "M2")]).stream_token(), Some(9));
    assert_eq!(lines(0, &[(3, "G0"), (9, "M2")]).charge(), 2 * 6 + 4);
    assert_eq!(HostMsg::EndOfJob.charge(), 0);
    assert_eq!(HostMsg::FeedHold.charge(), 1);
}

/// The bytes of every message of `all_host` and `all_board`, one hex line each, as
/// `tests/wire_bytes.txt` has them: written by the hand-made codec this crate had before it used
/// postcard's serde derive, so the wire format did not change with the switch.
#[test]
fn wire_bytes_of_every_message_kind_are_unchanged() {
    fn hex<M: Serialize>(m: &M) -> String {
        let mut buf = [0u8; 512];
        let n = codec::encode(m, &mut buf).unwrap();
        buf[..n].iter().map(|b| format!("{b:02x}")).collect()
    }
    let want: Vec<&str> = include_str!("wire_bytes.txt").lines().collect();
    let got: Vec<String> = all_host()
        .iter()
        .map(hex)
        .chain(all_board().iter().map(hex))
        .collect();
    // A deliberate wire change (with its protocol version bump, docs/protocol.md "Version
    // policy") rewrites the golden file: `GANTRY_BLESS_WIRE=1 cargo test -p gantry-proto`.
    if std::env::var_os("GANTRY_BLESS_WIRE").is_some() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/wire_bytes.txt");
        std::fs::write(path, got.join("\n") + "\n").unwrap();
        return;
    }
    assert_eq!(got.len(), want.len());
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w, "message {i}");
    }
    // A few by hand, against docs/protocol.md: Start{id 7} is variant 5 and varint 7; Jog(id 1,
    // axis 2, -500 000 µm/min, 0 nm) is variant 13, varint 1, the axis byte, zigzag varint
    // 999 999, varint 0; Lines{id 0, one record: line 1 "G0"} is variant 0, varint 0, varint 8
    // (the records' length), then the record: line 1 (u32 LE), length 2 (u16 LE), the text.
    assert_eq!(hex(&HostMsg::Start { id: 7 }), "0507");
    assert_eq!(hex(&lines(0, &[(1, "G0")])), "0000080100000002004730");
    assert_eq!(
        hex(&HostMsg::Jog(Jog {
            id: 1,
            axis: 2,
            feed_um_min: -500_000,
            distance_nm: 0,
        })),
        "0d0102bf843d00"
    );
}

/// Damaged encodings (a byte changed, cut short, one byte longer) and random bytes either fail
/// or decode to a message that encodes and decodes to itself; a message followed by a stray
/// byte is refused (the link takes a payload as one whole message).
#[test]
fn damaged_and_random_payloads_fail_or_decode_to_a_valid_message() {
    fn check<M: Serialize + DeserializeOwned + PartialEq + Debug>(msgs: &[M], seed: u64) {
        let mut r = seed;
        let mut next = move || {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            r
        };
        let (mut agree_some, mut agree_none) = (0, 0);
        for m in msgs {
            let mut buf = [0u8; 512];
            let good = postcard::to_slice(m, &mut buf).unwrap().to_vec();
            let mut longer = good.clone();
            longer.push(0);
            assert_eq!(
                codec::decode::<M>(&longer),
                None,
                "{m:?} with a trailing byte"
            );
            for _ in 0..2000 {
                let mut b = good.clone();
                match next() % 4 {
                    0 => {
                        let i = next() as usize % b.len();
                        b[i] = next() as u8;
                    }
                    1 => b.truncate(next() as usize % b.len()),
                    2 => b.push(next() as u8),
                    _ => {
                        let len = next() as usize % 40;
                        b = (0..len).map(|_| next() as u8).collect();
                    }
                }
                if let Some(m) = codec::decode::<M>(&b) {
                    let mut again = [0u8; 512];
                    let n = codec::encode(&m, &mut again).unwrap();
                    assert_eq!(
                        codec::decode::<M>(&again[..n]).as_ref(),
                        Some(&m),
                        "{b:02x?}"
                    );
                    agree_some += 1;
                } else {
                    agree_none += 1;
                }
            }
        }
        // Both outcomes were exercised.
        assert!(
            agree_some > 100 && agree_none > 100,
            "{agree_some} {agree_none}"
        );
    }
    check(&all_host(), 0x9E37_79B9_7F4A_7C15);
    check(&all_board(), 0xD1B5_4A32_D192_ED03);
}
