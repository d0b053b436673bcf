//! Cross-target vectors of the motion core: planner + prep + kernel runs digested step by step.
//!
//! Every step event (virtual tick time, step byte, direction byte) and the final step position
//! feed a [`Digest`], so any difference in integer arithmetic between targets shows up.

use super::{Digest, Vector};
use crate::canon::{Action, ArcDir, Canon, PathMode, Plane, Spindle, StopKind};
use crate::motion::config::MotionConfig;
use crate::motion::sim::{Sim, SimEvent};
use crate::step::kernel::{Segment, SegmentSource, StepKernel, KEEP_DUTY};
use crate::step::output_event::OutputEvent;
use crate::units::Pos;

const MM: i64 = 1_000_000;

const fn at(x: i64, y: i64, z: i64) -> Pos {
    [x, y, z, 0, 0, 0]
}

const fn feed(line: u32, to: Pos, mm_min: i64) -> Canon {
    Canon {
        line,
        action: Action::Feed {
            to,
            feed: mm_min * MM,
        },
    }
}

const fn rapid(line: u32, to: Pos) -> Canon {
    Canon {
        line,
        action: Action::Rapid { to },
    }
}

/// Runs `program` on a 48-block pipeline; `hold_at`: feed hold at that tick time, resumed once held.
fn digest_run(cfg: MotionConfig, program: &[Canon], hold_at: Option<u64>, fro: u16) -> u32 {
    let mut sim: Sim<48> = Sim::new(cfg);
    let mut d = Digest::new();
    let mut on = |e: SimEvent| {
        if let SimEvent::Step(s) = e {
            d.u64(s.time);
            d.bytes(&[s.step, s.dir]);
        }
    };
    let mut next = 0;
    let mut held = false;
    let mut idle = 0;
    loop {
        while next < program.len() && sim.motion.push(&program[next]).is_ok() {
            next += 1;
        }
        if let Some(t) = hold_at {
            if !held && sim.now >= t {
                sim.motion.feed_hold();
                sim.motion.set_feed_override(fro);
                held = true;
            }
        }
        if held && sim.motion.state() == crate::motion::pipeline::MotionState::Held {
            sim.motion.resume();
        }
        if sim.tick(&mut on).period == 0 {
            idle += 1;
            if idle > 3 && next >= program.len() {
                break;
            }
        } else {
            idle = 0;
        }
    }
    for p in sim.kernel.position() {
        d.i64(p);
    }
    d.finish()
}

struct Fixed<'a>(&'a [Segment], usize);

impl SegmentSource for Fixed<'_> {
    fn next_segment(&mut self) -> Option<Segment> {
        let s = self.0.get(self.1).copied();
        self.1 += 1;
        s
    }
}

fn kernel_bresenham() -> u32 {
    let segs = [
        Segment {
            steps: [10, 7, 3, 0, 0, 1],
            ticks: 10,
            period: 2400,
            dir: 0b10,
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        },
        Segment {
            steps: [4, 3, 1, 2, 0, 0],
            ticks: 32,
            period: 750,
            dir: 0b0101,
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        },
        Segment::idle(3, 1000),
        Segment {
            steps: [97, 96, 1, 50, 49, 2],
            ticks: 97,
            period: 300,
            dir: 0b11_1111,
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        },
    ];
    let mut src = Fixed(&segs, 0);
    let mut k = StepKernel::new();
    let mut d = Digest::new();
    loop {
        let out = k.tick(&mut src, false, false);
        if out.period == 0 {
            break;
        }
        d.bytes(&[out.step, out.dir]);
        d.u64(out.period as u64);
    }
    for p in k.position() {
        d.i64(p);
    }
    d.finish()
}

const SQUARE: [Canon; 6] = [
    feed(1, at(10 * MM, 0, 0), 1200),
    feed(2, at(10 * MM, 10 * MM, 0), 3000),
    feed(3, at(0, 10 * MM, MM), 600),
    feed(4, at(0, 0, 0), 2400),
    rapid(5, at(7 * MM, 3 * MM, 2 * MM)),
    rapid(6, at(0, 0, 0)),
];

fn planner_square() -> u32 {
    digest_run(MotionConfig::default(), &SQUARE, None, 100)
}

const ARCS: [Canon; 5] = [
    rapid(1, at(10 * MM, 0, 0)),
    Canon {
        line: 2,
        action: Action::Arc {
            to: at(0, 10 * MM, 0),
            center: [0, 0, 0],
            plane: Plane::XY,
            dir: ArcDir::Ccw,
            turns: 1,
            feed: 2000 * MM,
        },
    },
    Canon {
        line: 3,
        action: Action::Arc {
            to: at(0, 10 * MM, -2 * MM),
            center: [0, 5 * MM, 0],
            plane: Plane::XY,
            dir: ArcDir::Cw,
            turns: 2,
            feed: 1500 * MM,
        },
    },
    Canon {
        line: 4,
        action: Action::Arc {
            to: at(4 * MM, 10 * MM, -6 * MM),
            center: [2 * MM, 0, -4 * MM],
            plane: Plane::ZX,
            dir: ArcDir::Ccw,
            turns: 1,
            feed: 900 * MM,
        },
    },
    rapid(5, at(0, 0, 0)),
];

fn arcs_and_helix() -> u32 {
    digest_run(MotionConfig::default(), &ARCS, None, 100)
}

const HOLD_JOB: [Canon; 4] = [
    feed(1, at(30 * MM, 0, 0), 3000),
    feed(2, at(30 * MM, 20 * MM, 0), 3000),
    feed(3, at(0, 0, 0), 2000),
    Canon {
        line: 4,
        action: Action::Stop(StopKind::End),
    },
];

fn hold_resume_override() -> u32 {
    // Hold at 0.3 s, resume at 150 % feed override.
    digest_run(MotionConfig::default(), &HOLD_JOB, Some(7_200_000), 150)
}

const ODD_JOB: [Canon; 7] = [
    Canon {
        line: 1,
        action: Action::PathMode(PathMode::ExactStop),
    },
    feed(2, at(3_103_000, -1_234_567, 0), 800),
    Canon {
        line: 3,
        action: Action::Dwell { micros: 25_000 },
    },
    Canon {
        line: 4,
        action: Action::PathMode(PathMode::Blend { tolerance: 50_000 }),
    },
    feed(5, at(-2_000_001, 4_000_003, 777), 1700),
    feed(6, at(5_555_555, 1, -999), 2500),
    rapid(7, at(0, 0, 0)),
];

fn odd_ratios_dwell_exact_stop() -> u32 {
    let mut cfg = MotionConfig::default();
    cfg.axes[0].steps = 3000;
    cfg.axes[0].units = 78_816_200;
    cfg.axes[1].steps = 4000;
    cfg.axes[1].units = 7_000_001;
    cfg.axes[2].steps = 200;
    cfg.axes[2].units = 1_270_000;
    digest_run(cfg, &ODD_JOB, None, 100)
}

const fn spindle(line: u32, state: Spindle, rpm: u32) -> Canon {
    Canon {
        line,
        action: Action::Spindle { state, rpm },
    }
}

/// Laser mode (docs/laser-plasma.md): M4 with S changing between moves, a G0, an arc, M3 and a
/// dwell, pushed as the program's; held at 0.25 s and resumed.
const LASER_JOB: [Canon; 13] = [
    spindle(1, Spindle::Ccw, 300),
    feed(2, at(5 * MM, 0, 0), 1200),
    spindle(3, Spindle::Ccw, 900),
    feed(3, at(10 * MM, 0, 0), 1200),
    spindle(4, Spindle::Ccw, 550),
    feed(4, at(10 * MM, 7 * MM, 0), 2400),
    rapid(5, at(0, 0, 0)),
    Canon {
        line: 6,
        action: Action::Arc {
            to: at(0, 6 * MM, 0),
            center: [0, 3 * MM, 0],
            plane: Plane::XY,
            dir: ArcDir::Cw,
            turns: 1,
            feed: 900 * MM,
        },
    },
    spindle(7, Spindle::Cw, 700),
    feed(7, at(4 * MM, 6 * MM, 0), 600),
    Canon {
        line: 8,
        action: Action::Dwell { micros: 20_000 },
    },
    feed(9, at(0, 0, 0), 1500),
    Canon {
        line: 10,
        action: Action::Stop(StopKind::End),
    },
];

/// Steps, and each laser duty the kernel reports with its time.
fn laser_m4_power() -> u32 {
    let cfg = MotionConfig {
        laser: Some(crate::motion::laser::PwmMap {
            min_rpm: 100,
            max_rpm: 1000,
            pwm_min: 20,
            pwm_max: 999,
        }),
        ..MotionConfig::default()
    };
    let mut sim: Sim<48> = Sim::new(cfg);
    let mut d = Digest::new();
    let (mut next, mut held, mut idle) = (0, false, 0);
    loop {
        while next < LASER_JOB.len() && sim.push(&LASER_JOB[next]).is_ok() {
            next += 1;
        }
        if !held && sim.now >= 3_000_000 {
            sim.motion.feed_hold();
            held = true;
        }
        if held && sim.motion.state() == crate::motion::pipeline::MotionState::Held {
            sim.motion.resume();
        }
        let now = sim.now;
        let out = sim.tick(&mut |e| {
            if let SimEvent::Step(s) = e {
                d.u64(s.time);
                d.bytes(&[s.step, s.dir]);
            }
        });
        if out.power != KEEP_DUTY {
            d.u64(now);
            d.u64(u64::from(out.power));
        }
        if out.period == 0 {
            idle += 1;
            if idle > 3 && next >= LASER_JOB.len() {
                break;
            }
        } else {
            idle = 0;
        }
    }
    for p in sim.kernel.position() {
        d.i64(p);
    }
    d.finish()
}

/// One action of [`ONFLY_JOB`]: a canonical action, or an on-the-fly output (line, M code,
/// output number, level).
#[derive(Clone, Copy)]
enum Item {
    Canon(Canon),
    Output(u32, u16, u8, bool),
}

const ONFLY_JOB: [Item; 8] = [
    Item::Canon(feed(1, at(7 * MM, 0, 0), 1800)),
    Item::Output(2, 14, 1, true),
    Item::Canon(feed(3, at(12 * MM, 3 * MM, 0), 1800)),
    Item::Output(4, 15, 1, false),
    Item::Output(4, 16, 9, true),
    Item::Canon(ARCS[1]),
    Item::Output(6, 17, 9, false),
    Item::Canon(rapid(7, at(0, 0, 0))),
];

/// On-the-fly outputs between feeds, two at one junction (a stop) and one before an arc, with a
/// hold and a 70 % resume: every step and every output tick (time, event, output word).
fn onfly_outputs() -> u32 {
    let mut sim: Sim<48> = Sim::new(MotionConfig::default());
    let mut d = Digest::new();
    let mut on = |e: SimEvent| match e {
        SimEvent::Step(s) => {
            d.u64(s.time);
            d.bytes(&[s.step, s.dir]);
        }
        SimEvent::Output {
            time,
            output,
            outputs,
        } => {
            d.u64(time);
            d.bytes(&[output.code() as u8, b'o']);
            d.u64(outputs as u64);
        }
        SimEvent::Sync { time, canon } => {
            d.u64(time);
            d.u64(canon.line as u64);
        }
        SimEvent::Block { .. } => {}
    };
    let (mut next, mut idle, mut held) = (0, 0, false);
    loop {
        while next < ONFLY_JOB.len() {
            let ok = match ONFLY_JOB[next] {
                Item::Canon(c) => sim.motion.push(&c).is_ok(),
                Item::Output(line, code, n, level) => {
                    let e = OutputEvent::new(n, level).unwrap_or(OutputEvent::NONE);
                    sim.motion.push_output(line, code, e).is_ok()
                }
            };
            if !ok {
                break;
            }
            next += 1;
        }
        if next == ONFLY_JOB.len() {
            let _ = sim.motion.flush_output();
        }
        if !held && sim.now >= 3_000_000 {
            sim.motion.feed_hold();
            sim.motion.set_feed_override(70);
            held = true;
        }
        if held && sim.motion.state() == crate::motion::pipeline::MotionState::Held {
            sim.motion.resume();
        }
        if sim.tick(&mut on).period == 0 {
            idle += 1;
            if idle > 3 && next >= ONFLY_JOB.len() && !sim.motion.output_pending() {
                break;
            }
        } else {
            idle = 0;
        }
    }
    for p in sim.kernel.position() {
        d.i64(p);
    }
    d.u64(sim.kernel.outputs() as u64);
    d.finish()
}

/// `G64 P0.01` over 240 short moves (30 µm along X on a parabola with ±1 µm of CAM rounding
/// noise, then back along Y): the blend's chord tests ([`crate::motion::blend::chord_holds`]) decide which
/// moves merge; the digest takes every step and, first, the verdicts of a sweep of chord tests.
fn blend_chain() -> u32 {
    let mut d = Digest::new();
    let start = at(0, 0, 0);
    let mut points = [at(0, 0, 0); 8];
    for k in 0..400i64 {
        for (j, p) in points.iter_mut().enumerate() {
            let j = j as i64 + 1;
            *p = at(j * 100_000, (j * j * k * 37) % 9_001 - 4_500, (k * j) % 3);
        }
        let to = at(900_000, (k * 7_919) % 20_001 - 10_000, k % 5);
        d.bytes(&[crate::motion::blend::chord_holds(&start, &points, &to, 5_000, 3) as u8]);
    }
    let mut program = [rapid(0, at(0, 0, 0)); 241];
    program[0] = Canon {
        line: 1,
        action: Action::PathMode(PathMode::Blend { tolerance: 10_000 }),
    };
    for k in 1..=200i64 {
        let noise = (k * k * 7_919) % 2_001 - 1_000;
        program[k as usize] = feed(k as u32 + 1, at(k * 30_000, k * k * 50 + noise, 0), 3000);
    }
    for k in 1..=40i64 {
        program[200 + k as usize] = feed(
            k as u32 + 201,
            at(6_000_000, 2_000_000 - k * 25_000, 0),
            2400,
        );
    }
    d.u64(u64::from(digest_run(
        MotionConfig::default(),
        &program,
        None,
        100,
    )));
    d.finish()
}

const CORNER_JOB: [Canon; 9] = [
    Canon {
        line: 1,
        action: Action::PathMode(PathMode::Blend { tolerance: 50_000 }),
    },
    feed(2, at(12 * MM, 0, 0), 2400),
    feed(3, at(12 * MM, 9 * MM, 1_500_000), 2400),
    feed(4, at(3 * MM, 10 * MM, 0), 2400),
    feed(5, at(3_000_123, 11 * MM, 0), 2400),
    feed(6, at(-4 * MM, -2 * MM, -700_001), 1800),
    feed(7, at(-4_000_500, -7 * MM, 0), 1800),
    feed(8, at(0, 0, 0), 3000),
    Canon {
        line: 9,
        action: Action::Stop(StopKind::End),
    },
];

/// Rounded corners (machine/src/motion/corner.rs): the geometry of corners at many angles,
/// tolerances and lengths in 3D, then a job whose corners are rounded, held inside one and
/// resumed at 120 %.
fn corner_round() -> u32 {
    let cfg = MotionConfig::default();
    let mut d = Digest::new();
    for k in 1..=60i64 {
        let a = at(
            -(k * 97_531) % 7_000_000,
            (k * k * 4_321) % 900_000,
            k * 1_111,
        );
        let p = at(0, 0, 0);
        let b = at(
            (k * 7_919 * 13) % 5_000_000 - 2_500_000,
            (k * 3_571) % 4_000_000 + 10_000,
            -(k * 2_003) % 800_000,
        );
        let tol = (k as u64 * 3_733) % 200_000 + 1_000;
        let lengths = ((k as u64 * 999_983) % 9_000_000, 4_000_000);
        match crate::motion::corner::round(&cfg, &a, &p, &b, lengths, tol) {
            Some(c) => {
                d.u64(c.radius);
                d.u64(c.speed_sq);
                for v in &c.vertices {
                    for x in v {
                        d.i64(*x);
                    }
                }
            }
            None => d.bytes(&[0xee]),
        }
    }
    d.u64(u64::from(digest_run(
        cfg,
        &CORNER_JOB,
        Some(12_000_000),
        120,
    )));
    d.finish()
}

/// The default machine with a jerk limit of 5,000 mm/s³ on every axis (`motion/prep/jerk_line.rs`).
fn jerk_config() -> MotionConfig {
    let mut cfg = MotionConfig::default();
    for a in cfg.axes.iter_mut() {
        a.jerk = 5_000 * MM as u64;
    }
    cfg
}

fn jerk_square_arcs() -> u32 {
    let mut d = Digest::new();
    d.u64(u64::from(digest_run(jerk_config(), &SQUARE, None, 100)));
    d.u64(u64::from(digest_run(jerk_config(), &ARCS, None, 100)));
    d.finish()
}

fn jerk_hold_resume_override() -> u32 {
    // As `hold_resume_override`, jerk-limited: the hold brakes at the jerk limit.
    digest_run(jerk_config(), &HOLD_JOB, Some(7_200_000), 150)
}

pub(crate) const VECTORS: &[Vector] = &[
    Vector {
        name: "motion/kernel-bresenham",
        run: kernel_bresenham,
        expected: 0x1253_0f50,
    },
    Vector {
        name: "motion/planner-square",
        run: planner_square,
        expected: 0xc402_0d3e,
    },
    Vector {
        name: "motion/arcs-helix",
        run: arcs_and_helix,
        expected: 0xad98_cce4,
    },
    Vector {
        name: "motion/hold-resume-override",
        run: hold_resume_override,
        expected: 0x62fd_771f,
    },
    Vector {
        name: "motion/odd-ratios-dwell-exact-stop",
        run: odd_ratios_dwell_exact_stop,
        expected: 0xf82e_69d2,
    },
    Vector {
        name: "motion/onfly-outputs",
        run: onfly_outputs,
        expected: 0x56f6_e9de,
    },
    Vector {
        name: "motion/blend-chain",
        run: blend_chain,
        expected: 0x5cf0_2482,
    },
    Vector {
        name: "motion/corner-round",
        run: corner_round,
        expected: 0x8287_09c2,
    },
    Vector {
        name: "motion/laser-m4-power",
        run: laser_m4_power,
        expected: 0xbef1_9dee,
    },
    Vector {
        name: "motion/jerk-square-arcs",
        run: jerk_square_arcs,
        expected: 0x67aa_ca14,
    },
    Vector {
        name: "motion/jerk-hold-resume-override",
        run: jerk_hold_resume_override,
        expected: 0x2dc8_84d2,
    },
];

#[cfg(test)]
mod tests {
    extern crate std;

    /// Prints every motion vector's digest, to update the table above after an intended change:
    /// `cargo test -p gantry-machine --lib print_motion_digests -- --ignored --nocapture`. The
    /// digests are asserted by `vectors::tests::every_vector_matches_on_the_host` (and on the
    /// Cortex-M4 by `target-tests`).
    #[test]
    #[ignore = "generator, not a test: prints the digests (asserted by every_vector_matches_on_the_host)"]
    fn print_motion_digests() {
        for v in super::VECTORS {
            std::println!("{} {:#010x}", v.name, (v.run)());
        }
    }
}
