//! Physical checks on recorded step traces: rates, accelerations, corners, holds, exact counts.

use gantry_machine::canon::{Action, ArcDir, Canon, Plane};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::motion::sim::{Sim, SimEvent, StepEvent};
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use gantry_machine::units::{Pos, MAX_AXES};

const MM: i64 = 1_000_000;
const HZ: f64 = KERNEL_TIMER_HZ as f64;

fn feed(line: u32, to: Pos, mm_min: i64) -> Canon {
    Canon {
        line,
        action: Action::Feed {
            to,
            feed: mm_min * MM,
        },
    }
}

fn rapid(line: u32, to: Pos) -> Canon {
    Canon {
        line,
        action: Action::Rapid { to },
    }
}

fn xyz(x: f64, y: f64, z: f64) -> Pos {
    let mm = |v: f64| (v * MM as f64).round() as i64;
    [mm(x), mm(y), mm(z), 0, 0, 0]
}

/// A recorded trace with per-axis analysis (test-side floats only).
struct Trace {
    events: Vec<StepEvent>,
}

impl Trace {
    fn record(sim: &mut Sim<128>, program: Vec<Canon>) -> Trace {
        let mut events = Vec::new();
        sim.run(program, &mut |e| {
            if let SimEvent::Step(s) = e {
                events.push(s)
            }
        })
        .unwrap();
        Trace { events }
    }

    /// Signed step position of `axis` sampled every `window` seconds.
    fn sampled(&self, axis: usize, window: f64) -> Vec<i64> {
        let dt = (window * HZ) as u64;
        let end = self.events.last().map_or(0, |e| e.time) + 2 * dt;
        let mut out = Vec::new();
        let mut pos = 0i64;
        let mut i = 0;
        let mut t = 0;
        while t <= end {
            while i < self.events.len() && self.events[i].time < t {
                let e = self.events[i];
                if e.step & (1 << axis) != 0 {
                    pos += if e.dir & (1 << axis) != 0 { -1 } else { 1 };
                }
                i += 1;
            }
            out.push(pos);
            t += dt;
        }
        out
    }

    /// Highest speed (steps/s) and acceleration (steps/s²) of an axis over `window`-second samples.
    fn extremes(&self, axis: usize, window: f64) -> (f64, f64) {
        let p = self.sampled(axis, window);
        let v: Vec<f64> = p
            .windows(2)
            .map(|w| (w[1] - w[0]) as f64 / window)
            .collect();
        let vmax = v.iter().fold(0f64, |m, x| m.max(x.abs()));
        let amax = v
            .windows(2)
            .map(|w| ((w[1] - w[0]) / window).abs())
            .fold(0f64, f64::max);
        (vmax, amax)
    }

    fn final_position(&self) -> [i64; MAX_AXES] {
        let mut p = [0i64; MAX_AXES];
        for e in &self.events {
            for (a, v) in p.iter_mut().enumerate() {
                if e.step & (1 << a) != 0 {
                    *v += if e.dir & (1 << a) != 0 { -1 } else { 1 };
                }
            }
        }
        p
    }
}

fn steps_per_nm(cfg: &MotionConfig, axis: usize) -> f64 {
    cfg.axes[axis].steps as f64 / cfg.axes[axis].units as f64
}

/// A mixed job: rapids, feeds on 1-3 axes, a diagonal, arcs and a helix.
fn mixed_job() -> Vec<Canon> {
    let mut p = vec![
        rapid(1, xyz(5.0, 5.0, 2.0)),
        feed(2, xyz(5.0, 5.0, -1.0), 300),
        feed(3, xyz(40.0, 5.0, -1.0), 2400),
        feed(4, xyz(40.0, 30.0, -1.0), 2400),
        feed(5, xyz(10.0, 12.0, -1.5), 1800),
    ];
    p.push(Canon {
        line: 6,
        action: Action::Arc {
            to: xyz(30.0, 12.0, -1.5),
            center: [20 * MM, 12 * MM, -3 * MM / 2],
            plane: Plane::XY,
            dir: ArcDir::Cw,
            turns: 1,
            feed: 2000 * MM,
        },
    });
    p.push(Canon {
        line: 7,
        action: Action::Arc {
            to: xyz(30.0, 12.0, -3.0),
            center: [25 * MM, 12 * MM, -3 * MM / 2],
            plane: Plane::XY,
            dir: ArcDir::Ccw,
            turns: 2,
            feed: 1500 * MM,
        },
    });
    p.push(rapid(8, xyz(0.0, 0.0, 0.0)));
    p
}

fn check_limits(cfg: &MotionConfig, trace: &Trace, jump_per_axis_nm_s: f64) {
    let window = 0.010;
    for axis in 0..3 {
        let k = steps_per_nm(cfg, axis);
        let (v, a) = trace.extremes(axis, window);
        let vmax = cfg.axes[axis].max_rate as f64 * k + 1.0 / window;
        // One step of quantisation at each of three samples, plus any allowed instant speed jump.
        let amax = cfg.axes[axis].accel as f64 * k
            + 2.0 / (window * window)
            + jump_per_axis_nm_s * k / window;
        println!("axis {axis}: v {v:.0}/{vmax:.0} steps/s, a {a:.0}/{amax:.0} steps/s²");
        assert!(v <= vmax, "axis {axis} speed {v} > {vmax}");
        assert!(a <= amax, "axis {axis} accel {a} > {amax}");
    }
}

/// Largest instant speed change (nm/s) of one axis that the configuration allows: the start
/// speed from rest, the feed shift at a corner, or junction deviation's corner, whose per-axis
/// jump v·|Δu_i| is at most √(8·a_i·δ) (v² = a_j·δ·s/(1 − s) with a_j·|Δu_i|/|Δu| ≤ a_i and
/// |Δu|² = 4·(1 − s²), s the sine of half the corner's inner angle).
fn allowed_jump(cfg: &MotionConfig) -> f64 {
    let deviation = (8.0 * cfg.axes[0].accel as f64 * cfg.junction_deviation as f64).sqrt();
    (cfg.feed_shift.max(cfg.axes[0].start_speed) as f64).max(deviation)
}

#[test]
fn rates_and_accelerations_stay_within_limits() {
    // No instant jumps at all: start speed 0, corners at rest (no junction deviation, no feed
    // shift).
    let mut cfg = MotionConfig::default();
    for a in cfg.axes.iter_mut() {
        a.start_speed = 0;
    }
    cfg.feed_shift = 0;
    cfg.junction_deviation = 0;
    let mut sim: Sim<128> = Sim::new(cfg);
    let trace = Trace::record(&mut sim, mixed_job());
    check_limits(&cfg, &trace, 0.0);
    assert_eq!(trace.final_position(), [0; MAX_AXES]);
    assert_eq!(sim.kernel.position(), [0; MAX_AXES]);
    assert_eq!(sim.underruns, 0);
}

#[test]
fn default_machine_limits_allow_only_the_configured_jumps() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let trace = Trace::record(&mut sim, mixed_job());
    // Start speed (1 mm/s) from rest, junction deviation's 4 mm/s at most at corners.
    assert_eq!(allowed_jump(&cfg), 4e6);
    check_limits(&cfg, &trace, allowed_jump(&cfg));
    assert_eq!(trace.final_position(), [0; MAX_AXES]);
    // Feed shift alone (no junction deviation): its 1 mm/s at corners.
    let cfg = MotionConfig {
        junction_deviation: 0,
        ..cfg
    };
    let mut sim: Sim<128> = Sim::new(cfg);
    let trace = Trace::record(&mut sim, mixed_job());
    assert_eq!(allowed_jump(&cfg), 1e6);
    check_limits(&cfg, &trace, allowed_jump(&cfg));
    assert_eq!(trace.final_position(), [0; MAX_AXES]);
}

/// Speed through the corner of an L (steps/s): one step over the gap between the last X step and
/// the first Y step.
fn corner_speed(cfg: MotionConfig) -> f64 {
    let mut sim: Sim<128> = Sim::new(cfg);
    let trace = Trace::record(
        &mut sim,
        vec![
            feed(1, xyz(20.0, 0.0, 0.0), 3000),
            feed(2, xyz(20.0, 20.0, 0.0), 3000),
        ],
    );
    let last_x = trace.events.iter().rfind(|e| e.step & 1 != 0).unwrap().time;
    let first_y = trace.events.iter().find(|e| e.step & 2 != 0).unwrap().time;
    HZ / (first_y - last_x) as f64
}

#[test]
fn corners_respect_junction_deviation_and_feed_shift() {
    let k = steps_per_nm(&MotionConfig::default(), 0);
    // Junction deviation alone: v² = a_j·δ·sin(θ/2)/(1 − sin(θ/2)), a_j = 200·√2 mm/s² → 2.61 mm/s.
    let cfg = MotionConfig {
        feed_shift: 0,
        ..Default::default()
    };
    // The measured gap is the last step slot of a decelerating 2 ms segment: allow the speed one
    // segment of deceleration sheds (a·2 ms).
    let quantum = 200e6 * 0.002 * k;
    let limit = 2.613e6 * k;
    let v = corner_speed(cfg);
    println!("junction deviation corner: {v:.0} steps/s (limit {limit:.0} + {quantum:.0})");
    assert!(v <= limit + quantum && v >= limit * 0.5, "{v}");
    // Equivalent deviation from the corner: δ = v²·(1 − sin)/(a_j·sin) must stay ≤ 0.010 mm.
    let vm = (v - quantum) / k / 1e6; // mm/s
    let s = (0.5f64).sqrt();
    let dev = vm * vm * (1.0 - s) / (200.0 * 2f64.sqrt() * s);
    assert!(dev <= 0.0105, "deviation {dev} mm");
    // The default feed shift (1 mm/s) allows less than junction deviation at this corner, so it
    // changes nothing: the same corner speed to the step.
    assert_eq!(corner_speed(MotionConfig::default()), v);
    // Feed shift alone, 1 mm/s: the 90° corner's vector jump v·√2 ≤ 1 mm/s → 0.707 mm/s.
    let v = corner_speed(MotionConfig {
        junction_deviation: 0,
        ..Default::default()
    });
    let limit = 0.7072e6 * k;
    println!("feed shift corner: {v:.0} steps/s (limit {limit:.0} + {quantum:.0})");
    assert!(v <= limit + quantum && v >= limit * 0.5, "{v}");
    // A feed shift of 300 mm/min (5 mm/s) raises the corner above junction deviation's: 3.54 mm/s.
    let v = corner_speed(MotionConfig {
        feed_shift: 5_000_000,
        ..Default::default()
    });
    let limit = 3.5356e6 * k;
    println!("large feed shift corner: {v:.0} steps/s (limit {limit:.0} + {quantum:.0})");
    assert!(v <= limit + quantum && v >= limit * 0.8, "{v}");
}

#[test]
fn exact_counts_with_odd_ratios_over_many_moves() {
    let mut cfg = MotionConfig::default();
    cfg.axes[0].steps = 3000;
    cfg.axes[0].units = 78_816_200; // 3.103 in
    cfg.axes[1].steps = 4000;
    cfg.axes[1].units = 7_000_001;
    cfg.axes[2].steps = 200;
    cfg.axes[2].units = 1_270_000;
    let mut seed = 12345u64;
    let mut rnd = |span: i64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) as i64 % (2 * span + 1)) - span
    };
    let mut program = Vec::new();
    let mut to = [0i64; MAX_AXES];
    for line in 0..300 {
        for v in to.iter_mut().take(3) {
            *v = rnd(50 * MM);
        }
        program.push(if line % 7 == 0 {
            rapid(line, to)
        } else {
            feed(line, to, 2000)
        });
    }
    let mut sim: Sim<128> = Sim::new(cfg);
    let trace = Trace::record(&mut sim, program);
    let expect = cfg.to_steps(&to);
    assert_eq!(trace.final_position(), expect);
    assert_eq!(sim.kernel.position(), expect);
}

#[test]
fn hold_stops_within_computed_distance_and_resume_ends_identically() {
    let cfg = MotionConfig::default();
    let job = vec![
        feed(1, xyz(100.0, 0.0, 0.0), 3000),
        feed(2, xyz(100.0, 50.0, 0.0), 3000),
        feed(3, xyz(0.0, 0.0, 0.0), 3000),
    ];
    // Reference run without a hold.
    let mut reference: Sim<128> = Sim::new(cfg);
    let ref_trace = Trace::record(&mut reference, job.clone());

    let mut sim: Sim<128> = Sim::new(cfg);
    let mut events: Vec<StepEvent> = Vec::new();
    let mut on = |e: SimEvent| {
        if let SimEvent::Step(s) = e {
            events.push(s)
        }
    };
    for c in &job {
        sim.motion.push(c).unwrap();
    }
    // Cruise at 50 mm/s along X, then hold at t = 1 s.
    while sim.now < KERNEL_TIMER_HZ as u64 {
        sim.tick(&mut on);
    }
    let at_hold = sim.kernel.position();
    sim.motion.feed_hold();
    sim.run_until_idle(&mut on);
    assert_eq!(sim.motion.state(), MotionState::Held);
    let stopped = sim.kernel.position();
    let k = steps_per_nm(&cfg, 0);
    let v = 50.0e6; // nm/s
    let a = 200.0e6;
    // Segments already queued (≤ 9 × 2 ms) run at speed, then v²/2a on the path.
    let bound = (v * 9.0 * 0.002 + v * v / (2.0 * a)) * k + 2.0;
    let travelled = (stopped[0] - at_hold[0]) as f64;
    println!("hold: travelled {travelled} steps, bound {bound:.0}");
    assert!(travelled <= bound && travelled >= v * v / (2.0 * a) * k * 0.9);
    // Nothing moves while held.
    for _ in 0..1000 {
        sim.tick(&mut on);
    }
    assert_eq!(sim.kernel.position(), stopped);
    sim.motion.resume();
    sim.run_until_idle(&mut on);
    let trace = Trace { events };
    assert_eq!(sim.kernel.position(), reference.kernel.position());
    assert_eq!(trace.final_position(), ref_trace.final_position());
    assert_eq!(sim.kernel.position(), [0; MAX_AXES]);
    check_limits(&cfg, &trace, allowed_jump(&cfg));
}

/// Takes back up to `max` of the newest queued segments, as the kernel's owner does for a stop.
fn drop_queued(sim: &mut Sim<128>, pick: &mut impl FnMut(usize) -> usize) -> usize {
    let Some(max) = sim.motion.drop_request() else {
        return 0;
    };
    let k = pick(max.min(sim.fifo.0.len()));
    let keep = sim.fifo.0.len() - k;
    sim.fifo.0.truncate(keep);
    sim.motion.segments_dropped(k);
    k
}

#[test]
fn holds_that_take_back_queued_segments_stay_on_the_path_and_end_identically() {
    // The mixed job (lines, arcs cut into short chords, a helix) held every 97 ms; each hold
    // takes back a pseudo-random number of the queued segments (up to what prep allows), so the
    // rewinds land inside blocks and on block ends. Every stop must be where prep thinks it is,
    // the speeds and accelerations stay within the limits, and the job ends where an
    // uninterrupted run ends, with the same number of steps.
    let cfg = MotionConfig::default();
    let mut reference: Sim<128> = Sim::new(cfg);
    let ref_trace = Trace::record(&mut reference, mixed_job());

    let mut sim: Sim<128> = Sim::new(cfg);
    let mut events: Vec<StepEvent> = Vec::new();
    let mut on = |e: SimEvent| {
        if let SimEvent::Step(s) = e {
            events.push(s)
        }
    };
    let mut seed = 12345u64;
    let mut pick = |n: usize| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) % (n as u64 + 1)) as usize
    };
    let job = mixed_job();
    let mut next = 0;
    let mut next_hold = 0u64;
    let (mut holds, mut dropped) = (0, 0);
    loop {
        while next < job.len() && sim.motion.push(&job[next]).is_ok() {
            next += 1;
        }
        if sim.now >= next_hold && sim.motion.state() == MotionState::Running {
            next_hold = sim.now + KERNEL_TIMER_HZ as u64 * 97 / 1000;
            sim.motion.feed_hold();
            dropped += drop_queued(&mut sim, &mut pick);
            holds += 1;
            sim.run_until_idle(&mut on);
            assert_eq!(sim.motion.state(), MotionState::Held);
            assert_eq!(sim.kernel.position(), sim.motion.prepared_steps());
            sim.motion.resume();
        }
        let idle = sim.tick(&mut on).period == 0;
        if idle
            && next >= job.len()
            && sim.fifo.0.is_empty()
            && sim.motion.state() == MotionState::Idle
        {
            break;
        }
    }
    println!("{holds} holds took back {dropped} queued segments");
    assert!(holds > 40 && dropped > 100);
    let trace = Trace { events };
    assert_eq!(sim.kernel.position(), reference.kernel.position());
    assert_eq!(trace.final_position(), ref_trace.final_position());
    // The same path: every axis made the same number of steps (both ways).
    let pulses = |t: &Trace| {
        let mut n = [0usize; MAX_AXES];
        for e in &t.events {
            for (a, c) in n.iter_mut().enumerate() {
                *c += usize::from(e.step >> a & 1);
            }
        }
        n
    };
    assert_eq!(pulses(&trace), pulses(&ref_trace));
    check_limits(&cfg, &trace, allowed_jump(&cfg));
}

#[test]
fn feed_override_changes_speed_live() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut on = |_e: SimEvent| {};
    sim.motion
        .push(&feed(1, xyz(200.0, 0.0, 0.0), 1200))
        .unwrap();
    while sim.now < KERNEL_TIMER_HZ as u64 {
        sim.tick(&mut on);
    }
    let p0 = sim.kernel.position()[0];
    while sim.now < 2 * KERNEL_TIMER_HZ as u64 {
        sim.tick(&mut on);
    }
    let v100 = sim.kernel.position()[0] - p0;
    sim.motion.set_feed_override(200);
    while sim.now < 3 * KERNEL_TIMER_HZ as u64 {
        sim.tick(&mut on);
    }
    let p1 = sim.kernel.position()[0];
    while sim.now < 4 * KERNEL_TIMER_HZ as u64 {
        sim.tick(&mut on);
    }
    let v200 = sim.kernel.position()[0] - p1;
    // 20 mm/s → 40 mm/s, 640 steps/mm.
    assert!((v100 - 12_800).abs() <= 2, "{v100}");
    assert!((v200 - 25_600).abs() <= 2, "{v200}");
    sim.run_until_idle(&mut on);
    assert_eq!(sim.kernel.position()[0], 128_000);
}

#[test]
fn abort_stops_on_the_path_and_keeps_exact_position() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut on = |_e: SimEvent| {};
    sim.motion
        .push(&feed(1, xyz(100.0, 0.0, 0.0), 3000))
        .unwrap();
    sim.motion
        .push(&feed(2, xyz(100.0, 100.0, 0.0), 3000))
        .unwrap();
    while sim.now < KERNEL_TIMER_HZ as u64 / 2 {
        sim.tick(&mut on);
    }
    sim.motion.abort();
    sim.run_until_idle(&mut on);
    assert_eq!(sim.motion.state(), MotionState::Idle);
    let p = sim.kernel.position();
    assert_eq!(sim.motion.prepared_steps(), p);
    assert!(p[0] > 0 && p[0] < 64_000 && p[1] == 0);
    // The next move starts from where it stopped and lands exactly.
    sim.motion.push(&feed(3, xyz(0.0, 0.0, 0.0), 3000)).unwrap();
    sim.run_until_idle(&mut on);
    assert_eq!(sim.kernel.position(), [0; MAX_AXES]);
}

#[test]
fn dwell_and_stop_blocks_force_zero_speed() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut blocks = Vec::new();
    let mut syncs = Vec::new();
    let program = vec![
        feed(1, xyz(10.0, 0.0, 0.0), 3000),
        Canon {
            line: 2,
            action: Action::Dwell { micros: 500_000 },
        },
        feed(3, xyz(20.0, 0.0, 0.0), 3000),
        Canon {
            line: 4,
            action: Action::Stop(gantry_machine::canon::StopKind::Pause),
        },
        feed(5, xyz(30.0, 0.0, 0.0), 3000),
    ];
    sim.run(program, &mut |e| match e {
        SimEvent::Block { report, .. } => blocks.push(report),
        SimEvent::Sync { canon, .. } => syncs.push(canon.line),
        _ => {}
    })
    .unwrap();
    assert_eq!(syncs, vec![4]);
    assert_eq!(blocks.len(), 3);
    // Each stop is a jump from at most the start speed (1 mm/s) to rest, and back.
    for b in &blocks {
        assert!(b.entry <= 1_000_000 && b.exit <= 1_000_000, "{b:?}");
        assert!(b.peak > 40_000_000, "{b:?}");
    }
    assert_eq!(blocks[1].entry, 1_000_000);
    let total: u64 = blocks.iter().map(|b| b.counts).sum();
    assert!(sim.now >= total + KERNEL_TIMER_HZ as u64 / 2);
}

#[test]
fn exact_stop_mode_stops_at_every_block() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut blocks = Vec::new();
    let program = vec![
        Canon {
            line: 1,
            action: Action::PathMode(gantry_machine::canon::PathMode::ExactStop),
        },
        feed(2, xyz(10.0, 0.0, 0.0), 3000),
        feed(3, xyz(20.0, 0.0, 0.0), 3000),
        feed(4, xyz(30.0, 0.0, 0.0), 3000),
    ];
    sim.run(program, &mut |e| {
        if let SimEvent::Block { report, .. } = e {
            blocks.push(report)
        }
    })
    .unwrap();
    assert_eq!(blocks.len(), 3);
    for b in &blocks {
        assert!(b.exit <= 1_000_000, "{b:?}");
        assert!(b.entry <= 1_000_000, "{b:?}");
    }
}

#[test]
fn rapid_override_scales_rapids_only() {
    let cfg = MotionConfig::default();
    let run = |pct: u16| {
        let mut sim: Sim<128> = Sim::new(cfg);
        sim.motion.set_rapid_override(pct);
        let mut blocks = Vec::new();
        sim.run(
            vec![
                rapid(1, xyz(100.0, 0.0, 0.0)),
                feed(2, xyz(0.0, 0.0, 0.0), 1200),
            ],
            &mut |e| {
                if let SimEvent::Block { report, .. } = e {
                    blocks.push(report)
                }
            },
        )
        .unwrap();
        (blocks[0].peak, blocks[1].peak)
    };
    assert_eq!(run(100), (50_000_000, 20_000_000));
    assert_eq!(run(25), (12_500_000, 20_000_000));
}

#[test]
fn limit_stop_then_reset_keeps_exact_steps() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut on = |_e: SimEvent| {};
    sim.motion
        .push(&feed(1, xyz(50.0, 20.0, 0.0), 3000))
        .unwrap();
    while sim.now < KERNEL_TIMER_HZ as u64 / 3 {
        sim.tick(&mut on);
    }
    // Limit switch: the kernel stops stepping at this tick.
    sim.stop = true;
    let out = sim.tick(&mut on);
    assert_eq!((out.step, out.period), (0, 0));
    let at = sim.kernel.position();
    // Controller: flush the queue, resync motion to the kernel, clear the stop.
    sim.fifo.0.clear();
    sim.motion.reset(at);
    sim.kernel.clear_stop();
    sim.stop = false;
    assert_eq!(sim.motion.state(), MotionState::Idle);
    assert_eq!(sim.motion.prepared_steps(), at);
    sim.motion.push(&feed(2, xyz(0.0, 0.0, 0.0), 3000)).unwrap();
    sim.run_until_idle(&mut on);
    assert_eq!(sim.kernel.position(), [0; MAX_AXES]);
}
