//! The `gixa` dialect (`gcode::Dialect::Gixa`, docs/settings.md): two-digit G words, `;` comments, I/J centre modes, J as the Z
//! centre in G18/G19, G04 as a stored dwell, GIXA canned cycles, M98 P<N>.
#![allow(clippy::field_reassign_with_default, clippy::type_complexity)]

use gantry_machine::canon::{Action, ArcDir, Canon, Plane, Spindle, StopKind};
use gantry_machine::gcode::{
    ArcCenterMode, ErrorCode, GcodeError, InterpConfig, Interpreter, MemorySource,
};

const MM: i64 = 1_000_000;

fn run_with(program: &str, cfg: &InterpConfig) -> Vec<Result<Canon, GcodeError>> {
    let mut it = Interpreter::new(cfg);
    let mut src = MemorySource::new(program.as_bytes());
    let mut out = Vec::new();
    while let Some(x) = it.next(&mut src) {
        out.push(x);
        assert!(out.len() < 100_000, "runaway");
    }
    out
}

fn ok(program: &str) -> Vec<Action> {
    ok_with(program, &InterpConfig::gixa())
}

fn ok_with(program: &str, cfg: &InterpConfig) -> Vec<Action> {
    run_with(program, cfg)
        .into_iter()
        .map(|r| {
            r.unwrap_or_else(|e| panic!("unexpected error {e:?} in\n{program}"))
                .action
        })
        .collect()
}

fn err(program: &str) -> GcodeError {
    run_with(program, &InterpConfig::gixa())
        .into_iter()
        .find_map(|r| r.err())
        .expect("an error")
}

fn at(x: f64, y: f64, z: f64) -> [i64; 6] {
    [
        (x * 1e6).round() as i64,
        (y * 1e6).round() as i64,
        (z * 1e6).round() as i64,
        0,
        0,
        0,
    ]
}

fn rapid(x: f64, y: f64, z: f64) -> Action {
    Action::Rapid { to: at(x, y, z) }
}

fn feed(x: f64, y: f64, z: f64, f: i64) -> Action {
    Action::Feed {
        to: at(x, y, z),
        feed: f * MM,
    }
}

#[test]
fn word_format_rules() {
    assert_eq!(err("G1 X1 F10\n").code, ErrorCode::BadWordFormat);
    assert_eq!(err("M0\n").code, ErrorCode::BadWordFormat);
    assert_eq!(err("M1\n").code, ErrorCode::BadWordFormat);
    let a = ok("G01 X1 F10 ; comment G00 X9\nM3\nM00\n");
    assert_eq!(a[0], feed(1.0, 0.0, 0.0, 10));
    assert_eq!(a.last(), Some(&Action::Stop(StopKind::Pause)));
}

#[test]
fn manual_g81_example() {
    // N200 G81 X1.5 Y2.0 R.5 Z2 F20 M3 G99 G91 / N201 X1 G98 / N202 G80 M05
    let a = ok("N200 G81 X1.5 Y2.0 R.5 Z2 F20 M3 G99 G91\nN201 X1 G98\nN202 G80 M05\n");
    assert_eq!(
        a,
        vec![
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 0
            },
            rapid(1.5, 2.0, 0.0),
            rapid(1.5, 2.0, -0.5),
            feed(1.5, 2.0, -2.5, 20),
            rapid(1.5, 2.0, -0.5),
            rapid(2.5, 2.0, -0.5),
            feed(2.5, 2.0, -2.5, 20),
            rapid(2.5, 2.0, 0.0),
            Action::Spindle {
                state: Spindle::Off,
                rpm: 0
            },
        ]
    );
}

#[test]
fn manual_g83_example_pecks_without_clearance() {
    let a = ok("G83 X1 Y1 R1.0 Q0.5 Z1.062 F20 G91\n");
    assert_eq!(
        a,
        vec![
            rapid(1.0, 1.0, 0.0),
            rapid(1.0, 1.0, -1.0),
            feed(1.0, 1.0, -1.5, 20),
            rapid(1.0, 1.0, -1.0),
            rapid(1.0, 1.0, -1.5),
            feed(1.0, 1.0, -2.0, 20),
            rapid(1.0, 1.0, -1.0),
            rapid(1.0, 1.0, -2.0),
            feed(1.0, 1.0, -2.062, 20),
            rapid(1.0, 1.0, 0.0),
        ]
    );
}

#[test]
fn g04_stores_the_dwell_for_g82_g84_g89() {
    let a = ok("G00 Z5\nG04 P25\nG82 X1 R1 Z-1 F60\nG80\nM03 S100\nG84 X2 R1 Z-1 F60\nG80\nG89 X3 R1 Z-1 F60 G99\n");
    let dwells: Vec<u64> = a
        .iter()
        .filter_map(|x| match x {
            Action::Dwell { micros } => Some(*micros),
            _ => None,
        })
        .collect();
    assert_eq!(dwells, vec![250_000, 250_000, 250_000]);
    // G84: feed in, reverse, dwell, feed out to R, restore, rapid to the initial level (G98).
    let tap: Vec<Action> = a
        .iter()
        .copied()
        .skip_while(|x| {
            *x != Action::Spindle {
                state: Spindle::Cw,
                rpm: 100,
            }
        })
        .skip(1)
        .take(7)
        .collect();
    assert_eq!(
        tap,
        vec![
            rapid(2.0, 0.0, 5.0),
            rapid(2.0, 0.0, 1.0),
            feed(2.0, 0.0, -1.0, 60),
            Action::Spindle {
                state: Spindle::Ccw,
                rpm: 100
            },
            Action::Dwell { micros: 250_000 },
            feed(2.0, 0.0, 1.0, 60),
            Action::Spindle {
                state: Spindle::Cw,
                rpm: 100
            },
        ]
    );
    // G04 itself never dwells.
    assert!(ok("G04 P100\n").is_empty());
}

#[test]
fn g87_chip_break_partial_retract() {
    let a = ok("G00 Z5\nG87 X0 Y0 R0 Z-2 Q1 F50\n");
    assert_eq!(
        a[1..],
        [
            rapid(0.0, 0.0, 5.0),
            rapid(0.0, 0.0, 0.0),
            feed(0.0, 0.0, -1.0, 50),
            rapid(0.0, 0.0, -0.746),
            feed(0.0, 0.0, -2.0, 50),
            rapid(0.0, 0.0, 5.0),
        ]
    );
    assert_eq!(
        err("G87 X0 Y0 R0 Z-2 Q0.2 F50\n").code,
        ErrorCode::CyclePeckNotAboveRetract
    );
}

#[test]
fn g88_punch_runs_the_m10_list_at_each_position() {
    let a = ok("G88 X1 Y1\nX2\nG80\nG00 X0\n");
    assert_eq!(
        a,
        vec![
            rapid(1.0, 1.0, 0.0),
            Action::UserMCode {
                code: 10,
                at_rest: true
            },
            rapid(2.0, 1.0, 0.0),
            Action::UserMCode {
                code: 10,
                at_rest: true
            },
            rapid(0.0, 1.0, 0.0),
        ]
    );
}

#[test]
fn g86_waits_for_cycle_start_and_g85_feeds_out() {
    let a = ok("G00 Z2\nG86 X1 R1 Z-1 F30\nG80\nG85 X2 R1 Z-1 F30\n");
    assert_eq!(
        a[1..],
        [
            rapid(1.0, 0.0, 2.0),
            rapid(1.0, 0.0, 1.0),
            feed(1.0, 0.0, -1.0, 30),
            Action::Stop(StopKind::Pause),
            rapid(1.0, 0.0, 2.0),
            rapid(2.0, 0.0, 2.0),
            rapid(2.0, 0.0, 1.0),
            feed(2.0, 0.0, -1.0, 30),
            feed(2.0, 0.0, 1.0, 30),
            rapid(2.0, 0.0, 2.0),
        ]
    );
}

#[test]
fn g80_restores_the_previous_motion_mode() {
    let a = ok("G01 X1 F100\nG81 X2 R0 Z-1\nG80\nX3\n");
    assert_eq!(a.last(), Some(&feed(3.0, 0.0, 0.0, 100)));
}

#[test]
fn j_is_the_z_centre_in_g18_and_g19() {
    let a = ok("G18\nG00 X10 Y0 Z0\nG02 X0 Z10 I-10 J0 F100\n");
    match a[1] {
        Action::Arc {
            to,
            center,
            plane,
            dir,
            ..
        } => {
            assert_eq!(
                (to, center, plane, dir),
                (at(0.0, 0.0, 10.0), [0, 0, 0], Plane::ZX, ArcDir::Cw)
            );
        }
        ref x => panic!("{x:?}"),
    }
    let a = ok("G19\nG00 Y10 Z0\nG03 Y0 Z10 I-10 J0 F100\n");
    match a[1] {
        Action::Arc { center, plane, .. } => assert_eq!((center, plane), ([0, 0, 0], Plane::YZ)),
        ref x => panic!("{x:?}"),
    }
    assert_eq!(err("G02 X1 K1 F10\n").code, ErrorCode::ArcOffsetWrongPlane);
    assert_eq!(err("G02 X1 R1 F10\n").code, ErrorCode::NotSupported);
}

#[test]
fn arc_centre_modes() {
    // Absolute centres.
    let mut cfg = InterpConfig::gixa();
    cfg.gixa.arc_centers = ArcCenterMode::Absolute;
    let a = ok_with("G00 X10 Y10\nG02 X20 Y0 I10 J0 F100\n", &cfg);
    match a[1] {
        Action::Arc { center, .. } => assert_eq!(center, [10 * MM, 0, 0]),
        ref x => panic!("{x:?}"),
    }
    // Follows G90/G91.
    cfg.gixa.arc_centers = ArcCenterMode::FollowsDistanceMode;
    let a = ok_with("G00 X10 Y10\nG91\nG02 X10 Y-10 I0 J-10 F100\n", &cfg);
    match a[1] {
        Action::Arc { center, to, .. } => {
            assert_eq!((center, to), ([10 * MM, 0, 0], at(20.0, 0.0, 0.0)))
        }
        ref x => panic!("{x:?}"),
    }
}

#[test]
fn m98_addresses_subroutines_by_n() {
    let a = ok("G00 X0\nM98 P100 L2\nM30\nN100 G91 G00 X1\nM99\n");
    assert_eq!(
        a,
        vec![
            rapid(0.0, 0.0, 0.0),
            rapid(1.0, 0.0, 0.0),
            rapid(2.0, 0.0, 0.0),
            Action::Stop(StopKind::EndRewind),
        ]
    );
    assert_eq!(err("M98 P100 O3\n").code, ErrorCode::NotSupported);
    assert_eq!(err("M98 P7\n").code, ErrorCode::UnknownProgram);
}

#[test]
fn job_defaults_feed_plane_and_distance_mode() {
    let mut cfg = InterpConfig::gixa();
    cfg.gixa.default_feed = 250 * MM;
    cfg.gixa.absolute = false;
    let a = ok_with("G01 X1\nX1\nM30\n", &cfg);
    assert_eq!(a[..2], [feed(1.0, 0.0, 0.0, 250), feed(2.0, 0.0, 0.0, 250)]);
}
