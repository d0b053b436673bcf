//! Laser mode on the emulated board (docs/laser-plasma.md), measured on its virtual pins: the
//! PWM duty the step interrupt writes (`laser_pwm` in `gantry simulate --vcd`) against the steps
//! around it. S changes never stop the motion; under M4 the duty of every segment is
//! S × speed ÷ F; under M3 it is S; the beam is off in G0, in a hold at rest and at the end.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, PinEvent};
use gantry_machine::board::State;
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use std::cell::RefCell;
use std::rc::Rc;

/// nm per step of the default axes (3200 steps per 5 mm).
const NM_PER_STEP: f64 = 5_000_000.0 / 3200.0;
/// X steps of the G0 before the raster (2 mm).
const G0_STEPS: i64 = 2 * STEPS_PER_MM;
/// Steps per 0.5 mm pixel.
const PIXEL: i64 = STEPS_PER_MM / 2;

/// S 0..1000 onto duty 0..1000, laser mode.
fn laser(s: &mut Setup) {
    s.outputs.laser = true;
    s.outputs.spindle_min_rpm = 0;
    s.outputs.spindle_max_rpm = 1000;
    s.outputs.pwm_min = 0;
    s.outputs.pwm_max = 1000;
}

/// The S of pixel `k`: 100-999, never the same twice in a row.
fn s_of(k: usize) -> u32 {
    100 + (k as u32 * 37) % 900
}

/// A raster with a corner: G0 to X2, 100 pixels of 0.5 mm along X and 100 along Y, each
/// `G1 … S…` under `mode` (M3 or M4) at F1200, then a G0 home and the end.
fn raster(mode: &str) -> String {
    let mut p = format!("G21 G90 G94\n{mode} S0\nG0 X2\nF1200\n");
    for k in 0..100 {
        p += &format!("G1 X{:.1} S{}\n", 2.0 + 0.5 * (k + 1) as f64, s_of(k));
    }
    for k in 100..200 {
        p += &format!("G1 Y{:.1} S{}\n", 0.5 * (k - 99) as f64, s_of(k));
    }
    p + "G0 X0 Y0\nM5\nM2\n"
}

fn record(eb: &mut EmulatedBoard) -> Rc<RefCell<Vec<PinEvent>>> {
    let events = Rc::new(RefCell::new(Vec::new()));
    let sink = events.clone();
    eb.observe(move |p| sink.borrow_mut().push(p));
    events
}

/// A stretch of constant laser duty on the pins: from the update that wrote it to the next
/// change (each segment of a powered block starts one, unless its duty equals the one before).
#[derive(Clone, Copy, Debug)]
struct Stretch {
    duty: u16,
    /// X and Y steps made before it.
    at: (i64, i64),
    /// Steps in it (one axis moves at a time in [`raster`]).
    steps: i64,
    /// Start and end, kernel timer counts.
    from: u64,
    to: u64,
}

impl Stretch {
    /// Average speed, nm/s.
    fn speed(&self) -> f64 {
        self.steps as f64 * NM_PER_STEP * KERNEL_TIMER_HZ as f64 / (self.to - self.from) as f64
    }
}

fn stretches(events: &[PinEvent]) -> Vec<Stretch> {
    let mut out: Vec<Stretch> = Vec::new();
    let (mut x, mut y) = (0i64, 0i64);
    let mut duty = 0u16;
    let mut cur = Stretch {
        duty: 0,
        at: (0, 0),
        steps: 0,
        from: 0,
        to: 0,
    };
    for e in events {
        if e.pwm != duty {
            cur.to = e.time;
            out.push(cur);
            duty = e.pwm;
            cur = Stretch {
                duty,
                at: (x, y),
                steps: 0,
                from: e.time,
                to: e.time,
            };
        }
        for (axis, pos) in [(0, &mut x), (1, &mut y)] {
            if e.step >> axis & 1 != 0 {
                *pos += if e.dir >> axis & 1 != 0 { -1 } else { 1 };
                cur.steps += 1;
            }
        }
        cur.to = e.time;
    }
    out.push(cur);
    out
}

/// What [`raster`] runs from position `at`: the G0 out (`None`), pixel `Some(k)`, or the G0 home
/// (`None` again).
fn pixel_at(at: (i64, i64)) -> Option<usize> {
    let (x, y) = at;
    if y == 0 && x < G0_STEPS {
        return None;
    }
    let k = if y == 0 {
        (x - G0_STEPS) / PIXEL
    } else {
        100 + y / PIXEL
    };
    (k < 200).then_some(k as usize)
}

/// F1200 in nm/s.
const F: f64 = 20_000_000.0;

#[test]
fn m4_duty_is_s_times_speed_over_f_at_every_segment_across_a_corner_and_a_hold() {
    let mut eb = board(laser);
    let events = record(&mut eb);
    job(&mut eb, &raster("M4"));
    // A hold half way up the Y leg, held at rest for 300 ms, then cycle start.
    assert!(eb.run_until(20_000, |b| steps(b)[1] >= 25 * STEPS_PER_MM));
    eb.board.feed_hold();
    assert!(
        eb.run_until(2_000, |b| b.board.motion().state() == MotionState::Held
            && b.isr.snapshot().drained)
    );
    let held_at = eb.now();
    eb.run_ms(300);
    assert_eq!(eb.laser_pwm(), 0, "the beam is off in a hold at rest");
    eb.board.resume();
    until_state(&mut eb, State::Idle, 30_000);
    until_at_rest(&mut eb, 1000);
    let ev = events.borrow();
    let st = stretches(&ev);
    let (mut powered, mut below_half, mut at_rest) = (0, 0, 0);
    for s in &st {
        let expected = match pixel_at(s.at) {
            None => 0.0,
            Some(k) => f64::from(s_of(k)) * (s.speed() / F).min(1.0),
        };
        if s.steps == 0 {
            // At rest (the start, the hold, the end): the beam is off.
            assert_eq!(s.duty, 0, "{s:?}");
            at_rest += 1;
            continue;
        }
        assert!(
            (f64::from(s.duty) - expected).abs() <= 1.0,
            "duty {} where S × speed ÷ F is {expected:.2}: {s:?}",
            s.duty
        );
        if let Some(k) = pixel_at(s.at) {
            powered += 1;
            if f64::from(s.duty) < f64::from(s_of(k)) / 2.0 {
                below_half += 1;
            }
        }
    }
    // Every pixel starts its own stretch (its S differs from the one before), the ramps at the
    // start, at the corner and around the hold add more, some of them at under half power.
    assert!(powered > 200, "{powered} powered stretches");
    assert!(below_half >= 6, "{below_half} stretches under half power");
    assert_eq!(at_rest, 1, "the hold is the one stretch at rest");
    // The hold stood still with the beam off.
    let hold = st
        .iter()
        .find(|s| s.from <= held_at && s.to > held_at)
        .unwrap();
    assert_eq!(hold.duty, 0, "{hold:?}");
    assert!(hold.to - hold.from >= 300 * (KERNEL_TIMER_HZ as u64 / 1000));
    assert_eq!(hold.steps, 0);
    assert_eq!(steps(&eb)[..2], [0, 0]);
    assert_eq!(eb.laser_pwm(), 0);
}

#[test]
fn m3_keeps_s_through_the_ramps_and_g0_never_fires() {
    let mut eb = board(laser);
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G90\nM3 S600\nG1 X10 F1200\nG0 X0\nG1 X5 S300\nG1 X6 S0\nG0 X0\nM2\n",
    );
    until_state(&mut eb, State::Idle, 20_000);
    until_at_rest(&mut eb, 1000);
    let ev = events.borrow();
    let st: Vec<(u16, i64)> = stretches(&ev)
        .iter()
        .map(|s| (s.duty, s.steps))
        .filter(|(_, n)| *n > 0)
        .collect();
    // The G1 at S600 (ramps included), the G0 back at 0, X5 at S300, then X6 at S0 and the G0
    // home at 0.
    assert_eq!(
        st,
        [
            (600, 10 * STEPS_PER_MM),
            (0, 10 * STEPS_PER_MM),
            (300, 5 * STEPS_PER_MM),
            (0, 7 * STEPS_PER_MM)
        ]
    );
    assert_eq!(eb.laser_pwm(), 0);
}

#[test]
fn s_changes_do_not_stop_the_motion_it_runs_in_its_planned_time() {
    // 200 × 0.5 mm at F1200 under M4 with S changing on every line (the measurement in the
    // issue: 18.7 s instead of 5.1 s when every S change stopped the motion).
    let mut p = String::from("G21 G90 G94\nM4 S0\nF1200\n");
    for k in 0..200 {
        p += &format!("G1 X{:.1} S{}\n", 0.5 * (k + 1) as f64, s_of(k));
    }
    p += "M5\nM2\n";
    let mut s = Setup::default();
    laser(&mut s);
    let (_, planned) = host_sender::simulate::simulate(p.as_bytes(), &s).unwrap();
    let mut eb = board(laser);
    job(&mut eb, &p);
    let start = eb.now();
    assert!(eb.run_until(60_000, |b| b.board.state() == State::Idle
        && !b.isr.kernel.is_busy()));
    let took = (eb.now() - start) as f64 / KERNEL_TIMER_HZ as f64;
    assert!(planned < 5.3, "planned {planned:.3} s");
    assert!(
        took <= planned * 1.02,
        "ran {took:.3} s, planned {planned:.3} s"
    );
    assert_eq!(steps(&eb)[0], 100 * STEPS_PER_MM);
    // Without laser mode the same program stops at every S (a milling spindle).
    let (_, milling) = host_sender::simulate::simulate(p.as_bytes(), &Setup::default()).unwrap();
    assert!(milling > 3.0 * planned, "{milling:.3} s");
}

#[test]
fn a_machine_without_laser_mode_never_touches_the_pwm_from_the_step_interrupt() {
    let mut eb = board(|_| {});
    let events = record(&mut eb);
    job(&mut eb, "G21 G90\nM4 S800\nG1 X5 F1200\nG0 X0\nM5\nM2\n");
    until_state(&mut eb, State::Idle, 20_000);
    assert!(events.borrow().iter().all(|e| e.pwm == 0));
    assert!(!eb.board.output_levels().laser);
}

#[test]
fn the_spindle_override_scales_the_laser_power_within_the_s_range() {
    for (pct, duty) in [(50, 250), (150, 750), (200, 1000)] {
        let mut eb = board(laser);
        let events = record(&mut eb);
        eb.board.set_spindle_override(pct);
        job(
            &mut eb,
            "G21 G90\nM3 S500\nG1 X5 F1200\nM3 S800\nG1 X10\nM2\n",
        );
        until_state(&mut eb, State::Idle, 20_000);
        let st: Vec<(u16, i64)> = stretches(&events.borrow())
            .iter()
            .map(|s| (s.duty, s.steps))
            .filter(|(_, n)| *n > 0)
            .collect();
        // S800 at 150 % and 200 %: the top of the S range.
        let second = (800 * u32::from(pct) / 100).min(1000) as u16;
        let expected = if second == duty {
            vec![(duty, 10 * STEPS_PER_MM)]
        } else {
            vec![(duty, 5 * STEPS_PER_MM), (second, 5 * STEPS_PER_MM)]
        };
        assert_eq!(st, expected, "{pct} %");
    }
}
