//! Jerk-limited motion on the emulated board (docs/motion.md), measured on its step pins: the
//! per-axis acceleration and jerk recomputed from the step timestamps stay within 1.1× the
//! limits over a CAM-like contour, where the trapezoid's jerk is far over them, and the end
//! positions are exact to the step. A feed hold in the middle of a ramp decelerates within the
//! jerk limit and the job resumes on its path.
//!
//! The pulse train is a staircase: each axis's position is interpolated linearly between its
//! step events, sampled every [`W`], and acceleration and jerk are its second and third
//! differences. The window keeps the half-step staircase error under a tenth of the jerk limit;
//! the trapezoid's acceleration jump (within one 2 ms segment) reads as `A/W` there, and more at
//! a finer window.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, PinEvent};
use gantry_machine::board::State;
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use std::cell::RefCell;
use std::rc::Rc;

/// Sampling window, kernel timer counts (20 ms).
const W: u64 = KERNEL_TIMER_HZ as u64 / 50;
/// Limits of the default axes: 200 mm/s²; the jerk set here: 5,000 mm/s³.
const ACCEL: f64 = 200.0;
const JERK: f64 = 5_000.0;

fn jerk_setup(s: &mut Setup) {
    for a in s.axes.iter_mut() {
        a.jerk = 5_000 * 1_000_000;
    }
}

fn record(eb: &mut EmulatedBoard) -> Rc<RefCell<Vec<PinEvent>>> {
    let events = Rc::new(RefCell::new(Vec::new()));
    let sink = events.clone();
    eb.observe(move |p| sink.borrow_mut().push(p));
    events
}

/// A CAM-like finishing pass: a plunge, a wavy contour in 0.05 mm chords (the curve's own
/// per-axis jerk well under the limit at these feeds) with a feed change half way, a retract
/// and a rapid home, ending at X0 Y0 Z0. The moves meet tangentially or after a dwell: a
/// corner is a junction-deviation speed jump in both modes (docs/motion.md).
fn contour() -> String {
    let mut p = String::from("G21 G90 G94\nG1 Z-0.5 F600\nG4 P0.1\nF3000\n");
    for k in 1..=2400 {
        let x = 0.05 * k as f64;
        let y = 2.0 * (x / 8.0).sin() + (x / 5.0).sin();
        if k == 1200 {
            p += "F1800\n";
        }
        p += &format!("G1 X{x:.4} Y{y:.4}\n");
    }
    p + "G4 P0.1\nG0 Z0\nG4 P0.1\nG0 X0 Y0\nM2\n"
}

/// Per-axis position (steps) of every axis at each step event of `events`.
fn tracks(events: &[PinEvent]) -> [Vec<(u64, i64)>; 3] {
    let mut pos = [0i64; 3];
    let mut out: [Vec<(u64, i64)>; 3] = Default::default();
    for e in events {
        for i in 0..3 {
            if e.step >> i & 1 != 0 {
                pos[i] += if e.dir >> i & 1 != 0 { -1 } else { 1 };
                out[i].push((e.time, pos[i]));
            }
        }
    }
    out
}

/// Largest |acceleration| (mm/s²) and |jerk| (mm/s³) of one axis's track, sampled every `W`
/// from `from` to `to`.
fn peaks(track: &[(u64, i64)], from: u64, to: u64) -> (f64, f64) {
    let at = |t: u64| -> f64 {
        let k = track.partition_point(|&(ts, _)| ts <= t);
        match (k.checked_sub(1).map(|j| track[j]), track.get(k)) {
            (None, _) => 0.0,
            (Some((_, p)), None) => p as f64,
            (Some((t0, p0)), Some(&(t1, p1))) => {
                p0 as f64 + (p1 - p0) as f64 * (t - t0) as f64 / (t1 - t0) as f64
            }
        }
    };
    let dt = W as f64 / KERNEL_TIMER_HZ as f64;
    let mm = 1.0 / STEPS_PER_MM as f64;
    let samples: Vec<f64> = (from / W..=to / W + 4).map(|m| at(m * W) * mm).collect();
    let (mut a_max, mut j_max) = (0.0f64, 0.0f64);
    for w in samples.windows(4) {
        let a = (w[2] - 2.0 * w[1] + w[0]) / (dt * dt);
        let j = (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]) / (dt * dt * dt);
        a_max = a_max.max(a.abs());
        j_max = j_max.max(j.abs());
    }
    (a_max, j_max)
}

/// Runs `program` on a board with setup `edit`; the recorded pin events and the step position.
fn run(edit: impl FnOnce(&mut Setup), program: &str) -> (Vec<PinEvent>, [i64; 6]) {
    let mut eb = board(edit);
    let events = record(&mut eb);
    job(&mut eb, program);
    until_state(&mut eb, State::Idle, 120_000);
    until_at_rest(&mut eb, 1000);
    let ev = events.borrow().clone();
    (ev, steps(&eb))
}

fn axis_peaks(events: &[PinEvent]) -> [(f64, f64); 3] {
    let t = tracks(events);
    let end = events.last().map_or(0, |e| e.time);
    [0, 1, 2].map(|i| peaks(&t[i], 0, end))
}

#[test]
fn a_cam_contour_keeps_every_axis_within_its_acceleration_and_jerk() {
    let program = contour();
    let (jerk_ev, jerk_end) = run(jerk_setup, &program);
    let (trap_ev, trap_end) = run(|_| {}, &program);
    // Both end where the program does, to the step.
    assert_eq!(jerk_end, [0; 6]);
    assert_eq!(trap_end, [0; 6]);
    let jerk = axis_peaks(&jerk_ev);
    let trap = axis_peaks(&trap_ev);
    println!("jerk-limited: {jerk:?}\ntrapezoid: {trap:?}");
    for (i, (a, j)) in jerk.iter().enumerate() {
        assert!(*a <= 1.1 * ACCEL, "axis {i}: acceleration {a:.0} mm/s²");
        assert!(*j <= 1.1 * JERK, "axis {i}: jerk {j:.0} mm/s³");
    }
    // The trapezoid switches its acceleration on at once: at this window already about twice
    // the limit on the axes that ramp.
    let worst = trap.iter().map(|p| p.1).fold(0.0, f64::max);
    assert!(worst > 1.8 * JERK, "trapezoid jerk {worst:.0} mm/s³");
}

#[test]
fn a_hold_mid_ramp_decelerates_within_the_jerk_limit_and_resumes_on_the_path() {
    // A diagonal 40 × 30 mm move: its ramp up takes A/J = 40 ms to reach full acceleration;
    // the hold comes 25 ms in, with the acceleration still rising.
    let mut eb = board(jerk_setup);
    let events = record(&mut eb);
    job(&mut eb, "G21 G90 G1 X40 Y30 F3000\nM2\n");
    assert!(eb.run_until(2_000, |b| steps(b)[0] > 0));
    let started = eb.now();
    eb.run_for(25 * (KERNEL_TIMER_HZ as u64 / 1000));
    eb.board.feed_hold();
    assert!(
        eb.run_until(2_000, |b| b.board.motion().state() == MotionState::Held
            && b.kernel_drained())
    );
    let held = steps(&eb);
    assert!(
        held[0] > 0 && held[0] < 40 * STEPS_PER_MM,
        "held at {held:?}"
    );
    eb.run_ms(200);
    eb.board.resume();
    until_state(&mut eb, State::Idle, 30_000);
    until_at_rest(&mut eb, 1000);
    assert_eq!(steps(&eb)[..3], [40 * STEPS_PER_MM, 30 * STEPS_PER_MM, 0]);
    let ev = events.borrow();
    let t = tracks(&ev);
    let end = ev.last().unwrap().time;
    for (i, track) in t.iter().enumerate().take(2) {
        let (a, j) = peaks(track, started, end);
        // Each axis's share of the path limits (4/5 and 3/5): within the axis limits.
        assert!(a <= 1.1 * ACCEL, "axis {i}: acceleration {a:.0}");
        assert!(j <= 1.1 * JERK, "axis {i}: jerk {j:.0}");
    }
    // On the path: every step position within a step of the line 3x = 4y.
    let (mut x, mut y) = (0i64, 0i64);
    for e in ev.iter() {
        x += i64::from(e.step & 1);
        y += i64::from(e.step >> 1 & 1);
        assert!((3 * x - 4 * y).abs() <= 4 + 1, "off the path at {x}, {y}");
    }
}
