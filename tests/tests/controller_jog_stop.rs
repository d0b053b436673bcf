//! Jog stops and the analog stick on the emulated board: a stop (host jog stop, stick release,
//! stick to centre) takes back the segments queued to the kernel and decelerates from the end of
//! the kernel's running segment, so the machine stops within v²/2a plus the travel of that
//! segment and of at most one main-loop millisecond; the analog stick's speed follows the
//! deflection without stopping; continuous jogs stop on the soft limit.
//!
//! Bounds are computed from the setup: `v` is the jog speed, `a` the axis acceleration,
//! `running_left` the time the kernel's running segment still had when the queue was taken back
//! (recorded by the emulator) and `delay` the time from the stop request to that main-loop pass.
//! Positions are whole steps, so one step (1/640 mm) covers where inside a step the request came.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::inputs::Signal;
use gantry_machine::board::{AdcReadings, State};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::{Segment, KERNEL_TIMER_HZ};

/// Default axis acceleration, mm/s².
const ACCEL: f64 = 200.0;
/// One step, mm.
const STEP_MM: f64 = 1.0 / STEPS_PER_MM as f64;

/// What a stop did, measured on axis X.
struct Stop {
    /// Travel from the stop request to rest, mm.
    travelled: f64,
    /// v²/2a, mm.
    ideal: f64,
    /// Running segment's remaining time and the request's wait for the main loop, ms.
    running_left: f64,
    delay: f64,
    /// Kernel queue (ms) and segments taken back.
    queued: f64,
    dropped: usize,
}

impl Stop {
    /// v²/2a + v·(running segment left + delay) + one step.
    fn bound(&self, v: f64) -> f64 {
        self.ideal + v * (self.running_left + self.delay) / 1000.0 + STEP_MM
    }

    fn report(&self, what: &str, v: f64) -> String {
        format!(
            "{what} at {:.0} mm/min: stopped in {:.4} mm, ideal v²/2a {:.4} mm, excess {:.4} mm \
             = {:.2} ms of travel (running segment had {:.2} ms left, request waited {:.2} ms for \
             the main loop, {} queued segments = {:.1} ms taken back)",
            v * 60.0,
            self.travelled,
            self.ideal,
            self.travelled - self.ideal,
            (self.travelled - self.ideal) / v * 1000.0,
            self.running_left,
            self.delay,
            self.dropped,
            self.queued,
        )
    }
}

/// Runs until the machine is at rest after a stop requested now (at step position `from`,
/// virtual time `t0`, kernel queue `queued` ms) from `v` mm/s.
fn measure_stop(eb: &mut EmulatedBoard, t0: u64, from: i64, queued: f64, v: f64) -> Stop {
    until_at_rest(eb, 10_000);
    let drop = eb.last_drop.expect("the stop took the kernel's queue back");
    assert!(drop.time >= t0, "no queue drop since the stop");
    let ms = |counts: u64| counts as f64 / COUNTS_PER_MS as f64;
    let stop = Stop {
        travelled: (eb.isr.kernel.position()[0] - from).abs() as f64 * STEP_MM,
        ideal: v * v / (2.0 * ACCEL),
        running_left: ms(drop.running_left),
        delay: ms(drop.time - t0),
        queued,
        dropped: drop.dropped,
    };
    assert!(stop.delay <= 1.0, "the stop waited {} ms", stop.delay);
    // Nothing lost: the board's position is the kernel's.
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
    let cfg = *eb.board.motion_config();
    assert_eq!(
        eb.board.motion().queued_position(),
        cfg.to_nm(&eb.isr.kernel.position())
    );
    stop
}

fn check_stop(stop: &Stop, what: &str, v: f64) {
    let text = stop.report(what, v);
    println!("{text}");
    assert!(
        stop.travelled <= stop.bound(v),
        "{text}: bound {}",
        stop.bound(v)
    );
    // The brief's bound: the running segment plus one 1 ms main-loop period.
    assert!(stop.travelled <= stop.ideal + v * (stop.running_left + 1.0) / 1000.0 + STEP_MM);
    // It did decelerate (not an instant stop) and the queue was really taken back.
    assert!(stop.travelled >= stop.ideal - STEP_MM, "{text}");
    assert!(stop.dropped > 0 && stop.queued > 5.0, "{text}");
}

/// Setup with X's max rate (rapid) in mm/min.
fn with_x_rate(mm_min: i64) -> impl FnOnce(&mut Setup) {
    move |s: &mut Setup| s.axes[0].max_rate = mm_min * MM
}

#[test]
fn a_host_jog_stop_decelerates_from_the_running_segment_at_every_speed() {
    // 600 and 3000 mm/min, and the max rapid of a faster machine (10 000 mm/min).
    for (rate, jog, offset_ms) in [(3000, 600, 0.0), (3000, 3000, 0.0), (10_000, 10_000, 0.4)] {
        let mut eb = board(with_x_rate(rate));
        assert!(eb.board.jog(0, jog * 1000, 0));
        let v = jog as f64 / 60.0;
        run_held(&mut eb, (v / ACCEL * 1000.0) as u64 + 300);
        eb.run_for((offset_ms * COUNTS_PER_MS as f64) as u64);
        let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
        eb.board.jog_stop();
        let stop = measure_stop(&mut eb, t0, from, queued, v);
        check_stop(&stop, "host jog stop", v);
        until_state(&mut eb, State::Idle, 100);
        // The next jog starts from where the kernel stopped.
        let at = eb.isr.kernel.position()[0];
        assert!(eb.board.jog(0, 600_000, 1_000_000));
        until_state(&mut eb, State::Idle, 5_000);
        assert_eq!(eb.isr.kernel.position()[0], at + STEPS_PER_MM);
    }
}

#[test]
fn a_stick_release_decelerates_from_the_running_segment_at_every_speed() {
    // Accelerated mode jogs at the rapid rate: 600, 3000 and 10 000 mm/min machines. The release
    // comes inside a main-loop millisecond, so it waits for the next pass.
    for (rate, offset_ms) in [(600, 0.37), (3000, 0.0), (10_000, 0.81)] {
        let mut eb = board(with_x_rate(rate));
        enter_joystick(&mut eb);
        set(&mut eb, Signal::Accelerated, true);
        set(&mut eb, Signal::JogS3, true);
        let v = rate as f64 / 60.0;
        eb.run_ms((v / ACCEL * 1000.0) as u64 + 300);
        eb.run_for((offset_ms * COUNTS_PER_MS as f64) as u64);
        let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
        set(&mut eb, Signal::JogS3, false);
        let stop = measure_stop(&mut eb, t0, from, queued, v);
        check_stop(&stop, "stick release", v);
        assert_eq!(eb.board.state(), State::Jog);
    }
}

#[test]
fn the_old_queued_overrun_is_gone() {
    // Before, at 3000 mm/min the stop overran v²/2a = 6.25 mm by 0.136 mm (the kernel queue the
    // board kept while jogging). Now only the running segment (≤ 2 ms) runs before the ramp.
    let mut eb = board(|_| {});
    assert!(eb.board.jog(0, 3_000_000, 0));
    run_held(&mut eb, 1000);
    let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
    eb.board.jog_stop();
    let stop = measure_stop(&mut eb, t0, from, queued, 50.0);
    check_stop(&stop, "jog stop", 50.0);
    assert!(stop.running_left <= 2.1, "{} ms", stop.running_left);
    assert!(
        stop.travelled - stop.ideal < 0.136,
        "{}",
        stop.report("jog stop", 50.0)
    );
}

/// Leaving joystick mode (Mark + Release) and the abort input, each in the same instant of the
/// same joystick jog, stop it identically: the same queue drop at the same time, the same last
/// step, and both leave jog mode for Idle.
#[test]
fn leaving_jog_mode_and_abort_stop_the_same_way() {
    let mut stops = Vec::new();
    for leave in [true, false] {
        let mut eb = board(|s| s.inputs.abort = true);
        enter_joystick(&mut eb);
        set(&mut eb, Signal::Accelerated, true);
        set(&mut eb, Signal::JogS3, true);
        eb.run_ms(1000);
        let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
        if leave {
            set(&mut eb, Signal::Mark, true);
            set(&mut eb, Signal::Release, true);
        } else {
            set(&mut eb, Signal::Abort, true);
        }
        let stop = measure_stop(&mut eb, t0, from, queued, 50.0);
        check_stop(&stop, if leave { "leave jog" } else { "abort" }, 50.0);
        let drop = eb.last_drop.unwrap();
        let rest = (
            eb.isr.kernel.position(),
            eb.last_step_at,
            drop,
            stop.travelled,
        );
        set(&mut eb, Signal::JogS3, false);
        set(&mut eb, Signal::Mark, false);
        set(&mut eb, Signal::Release, false);
        set(&mut eb, Signal::Abort, false);
        until_state(&mut eb, State::Idle, 100);
        // Out of joystick mode: the switches no longer jog.
        set(&mut eb, Signal::JogS3, true);
        eb.run_ms(50);
        assert_eq!(eb.board.state(), State::Idle);
        assert_eq!(eb.isr.kernel.position(), rest.0);
        stops.push(rest);
    }
    let (leave, abort) = (stops[0], stops[1]);
    assert!(leave.3 > 0.0, "the jog moved before the stop");
    assert_eq!(leave.2, abort.2, "the same queue drop at the same time");
    assert_eq!(leave.1, abort.1, "the last step at the same time");
    assert_eq!(leave.0, abort.0, "at rest on the same step");
}

#[test]
fn a_host_feed_hold_during_a_jog_stops_it_the_same_way() {
    let mut eb = board(|_| {});
    assert!(eb.board.jog(0, -3_000_000, 0));
    run_held(&mut eb, 1000);
    let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
    eb.board.feed_hold();
    let stop = measure_stop(&mut eb, t0, from, queued, 50.0);
    check_stop(&stop, "feed hold while jogging", 50.0);
    until_state(&mut eb, State::Idle, 100);
}

/// ADC reading of a deflection in eighths of the stick's range (0 = centre, ±8 = full).
fn stick(eighths: i64) -> u16 {
    // Default setup: adc_max 4095 (centre 2047), deadband 100: range 1947 counts.
    let range = 2047 - 100;
    (2047 + eighths.signum() * 100 + eighths * range / 8) as u16
}

/// Path speed (mm/min) of a started X segment, and its direction.
fn segment_speed(s: &Segment) -> (f64, bool) {
    let mm = s.steps[0] as f64 * STEP_MM;
    let secs = s.duration() as f64 / KERNEL_TIMER_HZ as f64;
    (mm / secs * 60.0, s.dir & 1 != 0)
}

/// The speeds of the segments the kernel started in `[from, to)` (virtual time).
fn speeds(eb: &EmulatedBoard, from: u64, to: u64) -> Vec<(u64, f64, bool)> {
    eb.started_segments
        .as_ref()
        .unwrap()
        .iter()
        .filter(|(t, _)| (from..to).contains(t))
        .map(|(t, s)| {
            let (v, neg) = segment_speed(s);
            (*t, v, neg)
        })
        .collect()
}

/// Segment speeds round their duration to the 83 ns timer count once per tick: at these rates
/// that is below 0.2 %.
const ROUNDING: f64 = 0.002;

fn assert_monotonic(v: &[(u64, f64, bool)], rising: bool, what: &str) {
    for w in v.windows(2) {
        let (a, b) = (w[0].1, w[1].1);
        let ok = if rising {
            b >= a * (1.0 - ROUNDING)
        } else {
            b <= a * (1.0 + ROUNDING)
        };
        assert!(ok, "{what}: {a:.2} then {b:.2} mm/min at {}", w[1].0);
    }
}

/// Largest speed change per second (mm/s²) between segments 5 apart (about 10 ms, so the
/// timer-count rounding of single segments stays below 3 %), from their mid times.
fn peak_accel(v: &[(u64, f64, bool)], eb: &EmulatedBoard) -> f64 {
    let segs: Vec<_> = eb
        .started_segments
        .as_ref()
        .unwrap()
        .iter()
        .filter(|(t, _)| v.iter().any(|x| x.0 == *t))
        .map(|(t, s)| (*t as f64 + s.duration() as f64 / 2.0, segment_speed(s).0))
        .collect();
    segs.windows(6)
        .map(|w| (w[5].1 - w[0].1).abs() / 60.0 / ((w[5].0 - w[0].0) / KERNEL_TIMER_HZ as f64))
        .fold(0.0, f64::max)
}

#[test]
fn the_analog_stick_speed_follows_the_deflection_without_stopping() {
    let mut eb = board(|s| s.jog.analog_max_speed = 1200 * MM);
    enter_joystick(&mut eb);
    eb.started_segments = Some(Vec::new());
    let mut speed_samples = Vec::new();
    let mut run = |eb: &mut EmulatedBoard, ms: u64| {
        for _ in 0..ms {
            eb.run_ms(1);
            speed_samples.push(eb.kernel_view().feed_um_min);
        }
    };
    // 50 % right.
    eb.adc = AdcReadings {
        fro: None,
        stick: Some([stick(4), 2047]),
    };
    run(&mut eb, 600);
    let t1 = eb.now();
    eb.adc.stick = Some([stick(8), 2047]);
    run(&mut eb, 600);
    let t2 = eb.now();
    eb.adc.stick = Some([stick(4), 2047]);
    run(&mut eb, 600);
    let t3 = eb.now();

    let cruise = speeds(&eb, t1 - 100 * COUNTS_PER_MS, t1);
    assert!(cruise
        .iter()
        .all(|s| (s.1 - 600.0).abs() < 600.0 * ROUNDING));
    let up = speeds(&eb, t1, t2);
    let down = speeds(&eb, t2, t3);
    assert_monotonic(&up, true, "50 % → 100 %");
    assert_monotonic(&down, false, "100 % → 50 %");
    for (what, v, target) in [("up", &up, 1200.0), ("down", &down, 600.0)] {
        let last = v.last().unwrap().1;
        assert!(
            (last - target).abs() < target * ROUNDING,
            "{what}: ends at {last}"
        );
        assert!(v.iter().all(|s| !s.2), "{what}: X kept its direction");
        // The ramp takes Δv/a (10 mm/s at 200 mm/s²: 50 ms) after the running segment.
        let start = v[0].0;
        let reached = v
            .iter()
            .find(|s| (s.1 - target).abs() < target * ROUNDING)
            .unwrap()
            .0;
        let ramp_ms = (reached - start) as f64 / COUNTS_PER_MS as f64;
        let accel = peak_accel(v, &eb);
        println!("analog {what}: ramp {ramp_ms:.1} ms to {target} mm/min, peak {accel:.1} mm/s²");
        assert!(
            (45.0..=55.0).contains(&ramp_ms),
            "{what}: ramp {ramp_ms} ms"
        );
        assert!(accel <= ACCEL * 1.03, "{what}: {accel} mm/s²");
    }
    // The per-millisecond speed never dropped to zero once moving.
    let moving = speed_samples.iter().position(|&v| v > 0).unwrap();
    let slowest = speed_samples[moving + 100..].iter().min().unwrap();
    println!("slowest 1 ms sample after the start: {slowest} µm/min");
    assert!(*slowest >= 500_000, "{slowest} µm/min");
    assert_eq!(eb.isr.kernel.position()[1], 0);

    // Centre: stops within v²/2a from 600 mm/min.
    let (t0, from, queued) = (eb.now(), eb.isr.kernel.position()[0], eb.queued_ms());
    eb.adc.stick = Some([2047, 2047]);
    let stop = measure_stop(&mut eb, t0, from, queued, 10.0);
    check_stop(&stop, "analog stick to centre", 10.0);
    assert_eq!(eb.board.state(), State::Jog);
}

#[test]
fn reversing_the_analog_stick_passes_through_zero() {
    let mut eb = board(|s| s.jog.analog_max_speed = 1200 * MM);
    enter_joystick(&mut eb);
    eb.started_segments = Some(Vec::new());
    eb.adc = AdcReadings {
        fro: None,
        stick: Some([stick(8), 2047]),
    };
    eb.run_ms(600);
    let t1 = eb.now();
    eb.adc.stick = Some([stick(-8), 2047]);
    eb.run_ms(600);
    let v = speeds(&eb, t1, eb.now());
    let flip = v.iter().position(|s| s.2).expect("X reversed");
    assert_monotonic(&v[..flip], false, "slowing down");
    assert_monotonic(&v[flip..], true, "speeding up the other way");
    // The ramp comes down to the start speed (60 mm/min: reachable at once from rest) before X
    // reverses, and the other way starts from it: a segment's mean speed is at most 2 ms of
    // acceleration above it.
    println!(
        "reversal: last speed forward {:.1} mm/min, first backward {:.1} mm/min",
        v[flip - 1].1,
        v[flip].1
    );
    let start_speed = 60.0 + ACCEL * 0.002 * 60.0;
    assert!(v[flip - 1].1 <= start_speed && v[flip].1 <= start_speed);
    assert!((v.last().unwrap().1 - 1200.0).abs() < 1200.0 * ROUNDING);
    eb.adc.stick = Some([2047, 2047]);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
}

#[test]
fn continuous_jogs_stop_on_the_soft_limit_without_an_error() {
    // Accelerated (rapid) joystick jog, a full analog deflection sped up near the edge, and a
    // host jog: each ends exactly on X = 20 mm, no alarm, the joystick still in jog mode.
    for how in 0..3 {
        let mut eb = board(|s| {
            s.axes[0].travel_max = 20 * MM;
            s.jog.analog_max_speed = 3000 * MM;
        });
        if how < 2 {
            enter_joystick(&mut eb);
        }
        match how {
            0 => {
                set(&mut eb, Signal::Accelerated, true);
                set(&mut eb, Signal::JogS3, true);
            }
            1 => {
                eb.adc.stick = Some([stick(2), 2047]);
                eb.run_until(10_000, |b| b.isr.kernel.position()[0] >= 15 * STEPS_PER_MM);
                // 3000 mm/min needs 6.25 mm to stop: the speed-up is bounded by the edge.
                eb.adc.stick = Some([stick(8), 2047]);
            }
            _ => assert!(eb.board.jog(0, 3_000_000, 0)),
        }
        run_held(&mut eb, 3000);
        assert_eq!(eb.isr.kernel.position()[0], 20 * STEPS_PER_MM, "case {how}");
        assert_eq!(eb.board.motion().state(), MotionState::Idle);
        assert_eq!(eb.board.alarm(), None, "case {how}");
        let state = if how < 2 { State::Jog } else { State::Idle };
        assert_eq!(eb.board.state(), state);
    }
}

/// Path speed (mm/min) and per-axis speeds (mm/s, signed) of a started segment on X and Y.
fn segment_velocity(s: &Segment) -> (f64, [f64; 2]) {
    let secs = s.duration() as f64 / KERNEL_TIMER_HZ as f64;
    let axis = |i: usize| {
        let mm = s.steps[i] as f64 * STEP_MM / secs;
        if s.dir & (1 << i) != 0 {
            -mm
        } else {
            mm
        }
    };
    let v = [axis(0), axis(1)];
    ((v[0] * v[0] + v[1] * v[1]).sqrt() * 60.0, v)
}

#[test]
fn turning_the_analog_stick_bends_the_path_without_stopping() {
    let mut eb = board(|s| s.jog.analog_max_speed = 1200 * MM);
    enter_joystick(&mut eb);
    eb.started_segments = Some(Vec::new());
    eb.adc = AdcReadings {
        fro: None,
        stick: Some([stick(8), 2047]),
    };
    eb.run_ms(600);
    let t1 = eb.now();
    // Up a little: X at 1200, Y at 600 mm/min (26.6° to the left).
    eb.adc.stick = Some([stick(8), stick(4)]);
    eb.run_ms(600);
    let t2 = eb.now();
    // Back to X alone.
    eb.adc.stick = Some([stick(8), 2047]);
    eb.run_ms(600);
    let log: Vec<(u64, Segment)> = eb.started_segments.clone().unwrap();
    let after: Vec<(u64, f64, [f64; 2])> = log
        .iter()
        .filter(|(t, _)| *t >= t1)
        .map(|(t, s)| {
            let (v, axes) = segment_velocity(s);
            (*t, v, axes)
        })
        .collect();
    // Never at rest: every segment moves, at a corner speed the planner allows (junction
    // deviation's, higher than Feed Shift 60 mm/min over the direction jump: ≈ 130 mm/min for 26.6°).
    let slowest = after.iter().map(|s| s.1).fold(f64::MAX, f64::min);
    println!("bend: slowest segment {slowest:.1} mm/min");
    assert!(slowest > 100.0, "{slowest} mm/min");
    // X never reversed; Y moved up and stopped again.
    assert!(after.iter().all(|s| s.2[0] > 0.0 && s.2[1] >= 0.0));
    // Axis speeds (mm/s) over the last 20 segments before `until` (single segments of the minor
    // axis round to whole steps).
    let mean = |until: u64| {
        let segs: Vec<&(u64, Segment)> = log.iter().filter(|(t, _)| *t < until).collect();
        let tail = &segs[segs.len() - 20..];
        let secs =
            tail.iter().map(|(_, s)| s.duration()).sum::<u64>() as f64 / KERNEL_TIMER_HZ as f64;
        let mm = |i: usize| tail.iter().map(|(_, s)| s.steps[i]).sum::<u32>() as f64 * STEP_MM;
        [mm(0) / secs, mm(1) / secs]
    };
    let in_turn = mean(t2);
    let end = mean(eb.now());
    println!("bend: axis speeds {in_turn:?} mm/s after the turn, {end:?} mm/s after turning back");
    assert!((in_turn[0] - 20.0).abs() < 0.05 && (in_turn[1] - 10.0).abs() < 0.05);
    assert!((end[0] - 20.0).abs() < 0.05 && end[1] == 0.0);
    // Per axis, speed changes stay within 200 mm/s² plus the corner's jump, over windows of 5
    // segments: junction deviation (0.01 mm) changes an axis's speed by at most √(8·a·δ) = 4 mm/s
    // at a corner (the Feed Shift's 1 mm/s allows less, so it does not raise these corners).
    let jump = (8.0 * ACCEL * 0.01f64).sqrt();
    for axis in 0..2 {
        let peak = after
            .windows(6)
            .map(|w| {
                let dv = (w[5].2[axis] - w[0].2[axis]).abs();
                let dt = (w[5].0 - w[0].0) as f64 / KERNEL_TIMER_HZ as f64;
                (dv - jump).max(0.0) / dt
            })
            .fold(0.0, f64::max);
        println!("bend: axis {axis} peak acceleration beyond the corner jump {peak:.1} mm/s²");
        assert!(peak <= ACCEL * 1.05, "axis {axis}: {peak}");
    }
    let y = eb.isr.kernel.position()[1];
    assert!(y > 0);
    eb.adc.stick = Some([2047, 2047]);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.isr.kernel.position()[1], y);
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
    assert_eq!(eb.board.state(), State::Jog);
}

#[test]
fn an_analog_bend_toward_a_near_edge_stops_and_restarts_instead() {
    // A 7° turn would keep ≈ 480 mm/min through the corner (Feed Shift), which needs 0.16 mm to
    // stop; Y's travel ends 0.01 mm away, so the jog stops instead and starts the new direction
    // from rest, and still ends on the soft limit.
    let mut eb = board(|s| {
        s.jog.analog_max_speed = 1200 * MM;
        s.axes[1].travel_max = MM / 100;
    });
    enter_joystick(&mut eb);
    eb.started_segments = Some(Vec::new());
    eb.adc = AdcReadings {
        fro: None,
        stick: Some([stick(8), 2047]),
    };
    eb.run_ms(600);
    let t1 = eb.now();
    eb.adc.stick = Some([stick(8), stick(1)]);
    eb.run_ms(1000);
    assert_eq!(eb.isr.kernel.position()[1], 6); // 0.01 mm = 6.4 steps
                                                // The slowest X segment before Y starts: at rest (a bend would pass the corner at speed).
    let log = eb.started_segments.as_ref().unwrap();
    let before_y: Vec<f64> = log
        .iter()
        .filter(|(t, _)| *t >= t1)
        .take_while(|(_, s)| s.steps[1] == 0)
        .map(|(_, s)| segment_velocity(s).0)
        .collect();
    let slowest = before_y.iter().copied().fold(f64::MAX, f64::min);
    println!("near-edge turn: slowest segment {slowest:.1} mm/min");
    assert!(
        slowest <= 60.0 + ACCEL * 0.002 * 60.0,
        "it stopped: {slowest}"
    );
    eb.adc.stick = Some([2047, 2047]);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.board.motion().prepared_steps(), eb.isr.kernel.position());
    assert_eq!(eb.board.alarm(), None);
}
