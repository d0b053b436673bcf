//! The probing workflows of the session (host-sender/src/session/probe.rs, docs/probing.md
//! "Workflows") in process, on the emulated board with its probe targets: each sets the work
//! offset (or the tool length) to the exact latched contacts, read back from the board's setup
//! and status, and ends where its plan says. The page's run of them is scripts/console_drive.js.

use gantry_emulator::{EmulatedBoard, ProbeTarget};
use gantry_machine::setup::Setup;
use gantry_machine::units::NM_PER_MM;
use host_sender::session::probe::{Approach, Corner, Side};
use host_sender::session::{Flow, Session};

const MM: i64 = NM_PER_MM;

/// A session with the emulated board: a block X 200-250 Y 100-150 (top Z 0), a 60 mm round boss
/// at X -100 Y 100, a 30 mm bore at X -100 Y -100, the tool setter (top Z 10) under G30.
fn session() -> Session {
    let mut s = Setup::default();
    s.program.g30_home[..3].copy_from_slice(&[275 * MM, -175 * MM, 20 * MM]);
    let mut b = EmulatedBoard::new(s.clone());
    for t in [
        "boss:200,100,250,150,0",
        "cylinder:-100,100,60,0",
        "ring:-100,-100,30,60,0",
        "boss:270,-180,280,-170,10",
    ] {
        b.add_probe_target(ProbeTarget::parse(t).unwrap());
    }
    Session::emulated(b, s).unwrap()
}

fn go(s: &mut Session, blocks: &[&str]) {
    let blocks: Vec<String> = blocks.iter().map(|b| b.to_string()).collect();
    let (_, report) = s.mdi(&blocks, &mut |_| Flow::Continue).unwrap();
    assert!(report.completed && report.errors.is_empty(), "{report:?}");
}

fn g54(s: &mut Session) -> [i64; 3] {
    let o = s.reload_setup().unwrap().program.work_offsets[0];
    [o[0], o[1], o[2]]
}

fn machine(s: &mut Session) -> [i64; 3] {
    let m = s.status().unwrap().machine_pos;
    [m[0], m[1], m[2]]
}

const A: Approach = Approach {
    clearance: 12.0,
    depth: 8.0,
    diameter: 0.0,
};

#[test]
fn edge_and_corners_set_the_offset_at_the_faces() {
    let mut s = session();
    go(&mut s, &["G21 G90 G53 G0 Z5", "G53 G0 X206 Y106"]);
    let r = s.probe_corner(Corner::FrontLeft, A, 300.0, 2.0).unwrap();
    assert!(
        r.contains("X 200.000 (left face) and Y 100.000 (front face)"),
        "{r}"
    );
    assert_eq!(g54(&mut s), [200 * MM, 100 * MM, 0]);
    assert_eq!(
        machine(&mut s),
        [206 * MM, 106 * MM, 5 * MM],
        "above the start"
    );
    // A 3 mm tool: the corner is the radius beyond each contact.
    go(&mut s, &["G53 G0 X244 Y144"]);
    let a3 = Approach { diameter: 3.0, ..A };
    let r = s.probe_corner(Corner::BackRight, a3, 300.0, 2.0).unwrap();
    assert!(
        r.contains("X 250.000 (right face) and Y 150.000 (back face)"),
        "{r}"
    );
    assert_eq!(g54(&mut s), [248_500_000, 148_500_000, 0]);
    // One edge changes its axis alone.
    go(&mut s, &["G53 G0 X206 Y125"]);
    let r = s.probe_edge(Side::XPlus, A, 300.0, 2.0).unwrap();
    assert!(
        r.contains("contact at machine X 200.000 (left face)"),
        "{r}"
    );
    assert_eq!(g54(&mut s), [200 * MM, 148_500_000, 0]);
    assert_eq!(machine(&mut s), [206 * MM, 125 * MM, 5 * MM]);
    // Without a part beside it: alarm 5, and nothing set.
    go(&mut s, &["G53 G0 X100 Y0"]);
    let e = s.probe_edge(Side::YMinus, A, 300.0, 2.0).unwrap_err();
    assert!(e.contains("alarm 5"), "{e}");
    assert_eq!(g54(&mut s), [200 * MM, 148_500_000, 0]);
}

#[test]
fn boss_and_bore_centres_and_the_tool_length() {
    let mut s = session();
    go(&mut s, &["G21 G90 G53 G0 Z5", "G53 G0 X-98 Y100"]);
    let r = s.probe_boss(60.0, A, 300.0, 2.0).unwrap();
    assert!(
        r.contains("X -130.000 and -70.000, Y 70.000 and 130.000") && r.contains("diameter 60.000"),
        "{r}"
    );
    assert_eq!(g54(&mut s), [-100 * MM, 100 * MM, 0]);
    assert_eq!(machine(&mut s), [-100 * MM, 100 * MM, 5 * MM]);
    // Off the centre line in the bore: the X contacts are a chord, its middle the centre.
    go(&mut s, &["G53 G0 X-97 Y-101", "G53 G0 Z-3"]);
    let r = s.probe_bore(30.0, 0.0, 300.0, 1.0).unwrap();
    assert!(
        r.contains("Y -115.000 and -85.000") && r.contains("diameter 30.000"),
        "{r}"
    );
    assert_eq!(g54(&mut s), [-100 * MM, -100 * MM, 0]);
    assert_eq!(machine(&mut s), [-100 * MM, -100 * MM, -3 * MM]);
    // The tool setter: contact at Z 10, a tool of length 0 at Z -20: 30 mm, applied.
    go(&mut s, &["G53 G0 Z5"]);
    let r = s.probe_tool_length(2, -20.0, 15.0, 100.0, 2.0).unwrap();
    assert!(
        r.contains("machine Z 10.000") && r.contains("T2 length set to 30.000"),
        "{r}"
    );
    let st = s.status().unwrap();
    assert_eq!(&st.machine_pos[..3], &[275 * MM, -175 * MM, 20 * MM]);
    assert_eq!(st.machine_pos[2] - st.work_pos[2], 30 * MM, "G43 H2: 30 mm");
}
