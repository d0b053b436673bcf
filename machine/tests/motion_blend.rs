//! Path-tolerance blending (`G64 P`, machine/src/motion/blend.rs): chains of short moves run as
//! chords within the tolerance, corners at the tolerance's junction speed, exact end positions,
//! exact stop under G61, holds inside a merged chord.

use gantry_machine::arith::isqrt_u64;
use gantry_machine::canon::{Action, Canon, PathMode};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::motion::planner::{junction_limit_sq, UNIT};
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::motion::sim::{Sim, SimEvent, StepEvent};
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use gantry_machine::units::{Pos, MAX_AXES};

const MM: i64 = 1_000_000;

fn feed(line: u32, to: Pos, mm_min: i64) -> Canon {
    Canon {
        line,
        action: Action::Feed {
            to,
            feed: mm_min * MM,
        },
    }
}

fn path(line: u32, mode: PathMode) -> Canon {
    Canon {
        line,
        action: Action::PathMode(mode),
    }
}

fn xy(x: i64, y: i64) -> Pos {
    [x, y, 0, 0, 0, 0]
}

/// 3000 moves of 20 µm along X (60 mm) at 3000 mm/min, every other end point 1 µm off the line
/// (as a CAM post rounds them), from line 2 on.
fn fine_line() -> Vec<Canon> {
    (1..=3000)
        .map(|k| feed(k as u32 + 1, xy(k * 20_000, (k % 2) * 1_000), 3000))
        .collect()
}

struct Run {
    reports: Vec<BlockReport>,
    steps: Vec<StepEvent>,
    sim: Sim<128>,
}

fn run(cfg: MotionConfig, program: Vec<Canon>) -> Run {
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut reports = Vec::new();
    let mut steps = Vec::new();
    sim.run(program, &mut |e| match e {
        SimEvent::Block { report, .. } => reports.push(report),
        SimEvent::Step(s) => steps.push(s),
        _ => {}
    })
    .unwrap();
    Run {
        reports,
        steps,
        sim,
    }
}

/// `program` with a feed hold once `hold_when` holds (checked before every tick); once held and
/// at rest the machine must stand still for 1000 ticks; then it resumes and runs to its end.
/// The run's step trace and simulator (no block reports), and where it held.
fn hold_and_resume(
    cfg: MotionConfig,
    program: Vec<Canon>,
    hold_when: impl Fn(&Sim<128>) -> bool,
) -> (Run, [i64; MAX_AXES]) {
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut steps = Vec::new();
    let mut feeder = gantry_machine::motion::sim::Feeder::new(program.into_iter());
    let mut on = |e: SimEvent| {
        if let SimEvent::Step(s) = e {
            steps.push(s)
        }
    };
    while !hold_when(&sim) {
        feeder.feed(&mut sim).unwrap();
        sim.tick(&mut on);
    }
    sim.motion.feed_hold();
    while sim.motion.state() != MotionState::Held {
        feeder.feed(&mut sim).unwrap();
        sim.tick(&mut on);
    }
    sim.run_until_idle(&mut on);
    let held = sim.kernel.position();
    for _ in 0..1000 {
        sim.tick(&mut on);
    }
    assert_eq!(sim.kernel.position(), held, "stands still while held");
    sim.motion.resume();
    loop {
        feeder.feed(&mut sim).unwrap();
        sim.tick(&mut on);
        if feeder.exhausted() && sim.motion.state() == MotionState::Idle && sim.fifo.0.is_empty() {
            break;
        }
    }
    sim.run_until_idle(&mut on);
    let run = Run {
        reports: Vec::new(),
        steps,
        sim,
    };
    (run, held)
}

fn blend(tolerance: i64) -> Canon {
    path(1, PathMode::Blend { tolerance })
}

/// Largest distance (nm) of any step position of the trace from the polyline through `points`.
fn deviation(cfg: &MotionConfig, steps: &[StepEvent], points: &[Pos]) -> f64 {
    let nm = |a: usize| cfg.axes[a].units as f64 / cfg.axes[a].steps as f64;
    let mut p = [0i64; 2];
    let mut worst = 0f64;
    let mut seg = 0;
    for e in steps {
        for (a, v) in p.iter_mut().enumerate() {
            if e.step & (1 << a) != 0 {
                *v += if e.dir & (1 << a) != 0 { -1 } else { 1 };
            }
        }
        let q = [p[0] as f64 * nm(0), p[1] as f64 * nm(1)];
        // The nearest of the segments around the last one that was nearest (the path advances).
        let dist = |i: usize| {
            let (a, b) = (points[i], points[i + 1]);
            let (ax, ay, bx, by) = (a[0] as f64, a[1] as f64, b[0] as f64, b[1] as f64);
            let (dx, dy) = (bx - ax, by - ay);
            let t = (((q[0] - ax) * dx + (q[1] - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            ((q[0] - ax - t * dx).powi(2) + (q[1] - ay - t * dy).powi(2)).sqrt()
        };
        let lo = seg.max(1) - 1;
        let hi = (seg + 64).min(points.len() - 1);
        let (best, d) = (lo..hi)
            .map(|i| (i, dist(i)))
            .fold((seg, f64::MAX), |m, x| if x.1 < m.1 { x } else { m });
        seg = best;
        worst = worst.max(d);
    }
    worst
}

#[test]
fn a_chain_of_short_moves_runs_at_constant_feed_within_the_tolerance() {
    let cfg = MotionConfig::default();
    // Junction deviation alone: 128 blocks of 20 µm are 2.56 mm of look-ahead, so the machine
    // never reaches 50 mm/s (it must be able to stop within them: √(2·200·2.56) = 32 mm/s).
    let plain = run(cfg, fine_line());
    let plain_peak = plain.reports.iter().map(|r| r.peak).max().unwrap();
    let plain_time: u64 = plain.reports.iter().map(|r| r.counts).sum();
    assert_eq!(plain.reports.len(), 3000);
    assert!(plain_peak < 33_000_000, "{plain_peak}");
    // G64 P0.01: 32 moves per block (0.64 mm chords), the whole chain at 50 mm/s.
    let mut program = vec![blend(10_000)];
    program.extend(fine_line());
    let blended = run(cfg, program);
    let r = &blended.reports;
    assert_eq!(r.len(), 3000 / 32 + 1);
    assert_eq!(r[0].line, 33);
    assert_eq!(r[0].length, 640_000);
    let cruise: Vec<&BlockReport> = r.iter().filter(|b| b.peak == 50_000_000).collect();
    // Every block between the ramps cruises: entry, peak and exit all 50 mm/s.
    let steady = r
        .iter()
        .filter(|b| b.entry == 50_000_000 && b.exit == 50_000_000)
        .count();
    let time: u64 = r.iter().map(|b| b.counts).sum();
    println!(
        "fine line: {} blocks, peak {plain_peak} nm/s, {:.4} s; blended {} blocks, {} at 50 mm/s ({steady} from entry to exit), {:.4} s",
        plain.reports.len(),
        plain_time as f64 / KERNEL_TIMER_HZ as f64,
        r.len(),
        cruise.len(),
        time as f64 / KERNEL_TIMER_HZ as f64
    );
    // 72 (73 before corners were rounded): the last leg is held back until the queue runs low,
    // and this program has no end (M2) to flush it.
    assert_eq!(steady, 72);
    // End positions stay exact: 60 mm of X and the last point's Y (0).
    let end = cfg.to_steps(&xy(60 * MM, 0));
    assert_eq!(blended.sim.kernel.position(), end);
    assert_eq!(plain.sim.kernel.position(), end);
    // The path stays within the tolerance (plus a step's quantisation, 1.5625 µm).
    let mut points = vec![xy(0, 0)];
    points.extend((1..=3000).map(|k| xy(k * 20_000, (k % 2) * 1_000)));
    let dev = deviation(&cfg, &blended.steps, &points);
    println!("fine line: largest deviation {dev:.0} nm");
    assert!(dev <= 10_000.0 + 1_563.0, "{dev}");
}

/// Two chains of 50 µm moves meeting at a right angle at (10 mm, 0).
fn right_angle() -> Vec<Canon> {
    let mut program = Vec::new();
    for k in 1..=200 {
        program.push(feed(k as u32 + 1, xy(k * 50_000, 0), 3000));
    }
    for k in 1..=200 {
        program.push(feed(k as u32 + 201, xy(10 * MM, k * 50_000), 3000));
    }
    program
}

/// Closest approach (nm) of the step trace to the point `p` (X, Y).
fn closest(cfg: &MotionConfig, steps: &[StepEvent], p: Pos) -> f64 {
    let nm = |a: usize| cfg.axes[a].units as f64 / cfg.axes[a].steps as f64;
    let mut q = [0i64; 2];
    let mut best = f64::MAX;
    for e in steps {
        for (a, v) in q.iter_mut().enumerate() {
            if e.step & (1 << a) != 0 {
                *v += if e.dir & (1 << a) != 0 { -1 } else { 1 };
            }
        }
        let (dx, dy) = (
            q[0] as f64 * nm(0) - p[0] as f64,
            q[1] as f64 * nm(1) - p[1] as f64,
        );
        best = best.min((dx * dx + dy * dy).sqrt());
    }
    best
}

#[test]
fn a_rounded_corner_runs_at_the_arc_speed_within_the_tolerance() {
    let cfg = MotionConfig::default();
    let mut program = vec![blend(10_000)];
    program.extend(right_angle());
    let r = run(cfg, program);
    // The corner's arc: r = 10 µm·cos45°/(1 − cos45°) = 24.142 µm, run as 2 vertices 22.5° and
    // 67.5° round it (each within the 2 µm chord tolerance of the arc), at the speed whose
    // centripetal acceleration every axis allows at both: a = 200 mm/s² / cos 22.5° =
    // 216.478 mm/s², v = √(a·r) = 2.286093 mm/s (junction deviation at 10 µm allowed 2.613 mm/s
    // with the path turning on the corner point).
    let x = [UNIT, 0, 0, 0, 0, 0];
    let y = [0, UNIT, 0, 0, 0, 0];
    assert_eq!(
        isqrt_u64(junction_limit_sq(&cfg, &x, &y, 10_000)),
        2_613_125
    );
    let corner = gantry_machine::motion::corner::round(
        &cfg,
        &xy(0, 0),
        &xy(10 * MM, 0),
        &xy(10 * MM, 10 * MM),
        (10 * MM as u64, 10 * MM as u64),
        10_000,
    )
    .unwrap();
    let v = isqrt_u64(corner.speed_sq);
    assert_eq!(v, 2_286_093);
    let a = 200e6 / (22.5f64).to_radians().cos();
    let r_arc = 10_000.0 * (45f64).to_radians().cos() / (1.0 - (45f64).to_radians().cos());
    assert_eq!(corner.radius, r_arc as u64);
    assert_eq!(v, (a * corner.radius as f64).sqrt() as u64);
    // Blocks: the X chain up to the first vertex, the vertex-to-vertex segment (both report
    // line 201, the move whose end point the corner rounds), then the Y chain from the second.
    let at = r.reports.iter().position(|b| b.line == 201).unwrap();
    let (before, arc, after) = (&r.reports[at], &r.reports[at + 1], &r.reports[at + 2]);
    println!(
        "corner: exit {} | arc {} nm: entry {} peak {} exit {} | entry {} (line {})",
        before.exit, arc.length, arc.entry, arc.peak, arc.exit, after.entry, after.line
    );
    assert_eq!(arc.line, 201);
    assert_eq!(after.line, 233);
    // 2·r·tan(22.5°) = 20 µm between the vertices.
    assert!((19_999..=20_001).contains(&arc.length), "{}", arc.length);
    // The profiles, from whole steps, land within 0.01 % of the planned speed, constant
    // through the corner.
    for s in [before.exit, arc.entry, arc.peak, arc.exit, after.entry] {
        assert!(s.abs_diff(v) < 300, "{s}");
    }
    // 200 = 6·32 + 8 moves per side, and the corner's segment.
    assert_eq!(r.reports.len(), 15);
    assert_eq!(r.sim.kernel.position(), cfg.to_steps(&xy(10 * MM, 10 * MM)));
    // The path stays within the tolerance of the programmed moves, and passes the corner point
    // at the tolerance (the middle of the vertex-to-vertex segment is 10 µm from it), give or
    // take a step (1.5625 µm).
    let dev = deviation(
        &cfg,
        &r.steps,
        &[xy(0, 0), xy(10 * MM, 0), xy(10 * MM, 10 * MM)],
    );
    let near = closest(&cfg, &r.steps, xy(10 * MM, 0));
    println!("corner: largest deviation {dev:.0} nm, closest to the corner point {near:.0} nm");
    assert!(dev <= 10_000.0 + 1_563.0, "{dev}");
    assert!(
        (10_000.0 - 1_563.0..=10_000.0 + 1_563.0).contains(&near),
        "{near}"
    );
}

#[test]
fn the_setup_tolerance_is_the_g64_default_and_p_overrides_it() {
    let setup_default = MotionConfig {
        blend_tolerance: 10_000,
        ..MotionConfig::default()
    };
    let explicit = run(MotionConfig::default(), {
        let mut p = vec![blend(10_000)];
        p.extend(right_angle());
        p
    });
    // At power-up, and after `G64` without P, the setup's tolerance blends.
    let power_up = run(setup_default, right_angle());
    let mut p = vec![path(1, PathMode::ExactStop), blend(0)];
    p.extend(right_angle());
    let g64 = run(setup_default, p);
    assert_eq!(power_up.reports, explicit.reports);
    assert_eq!(g64.reports, explicit.reports);
    // `G64 P` overrides it: P0.03 rounds with a larger arc (3·24.142 µm, 3 vertices), faster.
    let mut p = vec![blend(30_000)];
    p.extend(right_angle());
    let wider = run(setup_default, p);
    let arc = |r: &Run| {
        let at = r.reports.iter().position(|b| b.line == 201).unwrap();
        r.reports[at + 1]
    };
    println!(
        "P0.03 corner: {} nm at {} nm/s",
        arc(&wider).length,
        arc(&wider).peak
    );
    assert!(arc(&wider).peak > arc(&explicit).peak * 3 / 2);
    // Off by default: `G64` alone keeps junction deviation (one block per move).
    let plain = run(MotionConfig::default(), right_angle());
    assert_eq!(plain.reports.len(), 400);
}

#[test]
fn a_hold_inside_a_rounded_corner_stops_on_the_arc_and_resumes_exactly() {
    let cfg = MotionConfig::default();
    // Two 10 mm moves at a right angle with P1: r = 2.414 mm, the corner is 6 vertices (the
    // most) round a 3.8 mm arc, run at √(200 mm/s²·r/cos 7.5°)-ish ≈ 22 mm/s.
    let program = vec![
        blend(MM),
        feed(2, xy(10 * MM, 0), 3000),
        feed(3, xy(10 * MM, 10 * MM), 3000),
        Canon {
            line: 4,
            action: Action::Stop(gantry_machine::canon::StopKind::End),
        },
    ];
    let reference = run(cfg, program.clone());
    let corner_blocks = reference.reports.iter().filter(|b| b.line == 2).count();
    assert_eq!(corner_blocks, 6);
    // Hold as soon as Y moves (the first vertex-to-vertex segment), then resume once held.
    let (Run { steps, sim, .. }, held) =
        hold_and_resume(cfg, program, |sim| sim.kernel.position()[1] != 0);
    println!("corner hold: stopped at {held:?} steps");
    // At rest inside the corner: off both programmed moves.
    let corner = cfg.to_steps(&xy(10 * MM, 0));
    assert!(held[0] < corner[0] && held[1] > 0, "{held:?}");
    assert_eq!(sim.kernel.position(), reference.sim.kernel.position());
    assert_eq!(sim.kernel.position(), cfg.to_steps(&xy(10 * MM, 10 * MM)));
    let dev = deviation(
        &cfg,
        &steps,
        &[xy(0, 0), xy(10 * MM, 0), xy(10 * MM, 10 * MM)],
    );
    let near = closest(&cfg, &steps, xy(10 * MM, 0));
    println!("corner hold: largest deviation {dev:.0} nm, closest to the corner {near:.0} nm");
    assert!(dev <= 1_000_000.0 + 1_563.0, "{dev}");
    assert!(near >= 900_000.0, "{near}");
}

#[test]
fn exact_stop_under_g61_stops_at_every_programmed_point() {
    let cfg = MotionConfig::default();
    let mut program = vec![blend(10_000), path(1, PathMode::ExactStop)];
    program.extend(fine_line().into_iter().take(100));
    let r = run(cfg, program);
    println!("exact stop: {} blocks", r.reports.len());
    assert_eq!(r.reports.len(), 100);
    // Every move starts and ends at rest (within the start speed, 1 mm/s; the profile from whole
    // steps lands within 0.2 % of it).
    let fastest = r.reports.iter().map(|b| b.entry.max(b.exit)).max().unwrap();
    println!("exact stop: fastest entry or exit {fastest} nm/s");
    assert!(fastest <= 1_002_000, "{fastest}");
    assert_eq!(r.sim.kernel.position(), cfg.to_steps(&xy(2 * MM, 0)));
}

#[test]
fn a_dwell_inside_a_chain_stands_exactly_on_its_programmed_point() {
    let cfg = MotionConfig::default();
    let mut program = vec![blend(10_000)];
    let line = fine_line();
    program.extend(line[..50].iter().copied());
    program.push(Canon {
        line: 60,
        action: Action::Dwell { micros: 100_000 },
    });
    program.extend(line[50..100].iter().copied());
    let mut sim: Sim<128> = Sim::new(cfg);
    let mut at_dwell = None;
    let mut reports = Vec::new();
    let mut feeder = gantry_machine::motion::sim::Feeder::new(program.into_iter());
    loop {
        feeder.feed(&mut sim).unwrap();
        let mut on = |e: SimEvent| {
            if let SimEvent::Block { report, .. } = e {
                reports.push(report)
            }
        };
        sim.tick(&mut on);
        if at_dwell.is_none() && reports.last().is_some_and(|b| b.line == 51) {
            // The block up to line 51 is prepared: prep stands on its end.
            at_dwell = Some(sim.motion.prepared_steps());
        }
        if feeder.exhausted() && sim.motion.state() == MotionState::Idle && sim.fifo.0.is_empty() {
            break;
        }
    }
    sim.run_until_idle(&mut |_| {});
    // Line 51 ends at (1 mm, 0): 640 steps of X.
    assert_eq!(at_dwell.unwrap(), cfg.to_steps(&xy(MM, 0)));
    assert_eq!(at_dwell.unwrap()[..2], [640, 0]);
    // 50 moves: one 32-move chord, then the 18 left before the dwell; after it 32 + 18 again.
    let lines: Vec<u32> = reports.iter().map(|b| b.line).collect();
    assert_eq!(lines, [33, 51, 83, 101]);
    assert_eq!(sim.kernel.position(), cfg.to_steps(&xy(2 * MM, 0)));
}

#[test]
fn a_hold_inside_a_merged_chord_stops_on_it_and_resumes_to_the_same_end() {
    let cfg = MotionConfig::default();
    let mut program = vec![blend(10_000)];
    program.extend(fine_line());
    let reference = run(cfg, program.clone());
    // Hold at 0.5 s (cruising through the chords), then resume once held.
    let (Run { steps, sim, .. }, held) =
        hold_and_resume(cfg, program, |sim| sim.now >= KERNEL_TIMER_HZ as u64 / 2);
    // Stopped inside a block, off its programmed points' step grid but on the chord: X moved
    // 20 mm at most, and Y within the tolerance of the line (0 or 1 µm programmed).
    println!("hold: stopped at {held:?}");
    assert!(held[0] > 0 && held[0] < cfg.to_steps(&xy(60 * MM, 0))[0]);
    assert!(held[1].abs() <= 7, "{held:?}"); // 7 steps = 10.9 µm
    assert_eq!(sim.kernel.position(), reference.sim.kernel.position());
    let mut points = vec![xy(0, 0)];
    points.extend((1..=3000).map(|k| xy(k * 20_000, (k % 2) * 1_000)));
    let dev = deviation(&cfg, &steps, &points);
    println!("hold: largest deviation {dev:.0} nm");
    assert!(dev <= 10_000.0 + 1_563.0, "{dev}");
    let _ = MAX_AXES;
}

#[test]
fn a_fine_curved_contour_stays_near_its_programmed_points() {
    // A circle of 8 mm radius with a 3-lobe wave, programmed every ~30 µm (as CAM posts it,
    // rounded to the µm), at F3000 under G64 P0.01: chords merge the points within 10 µm and
    // the corners between chords are rounded within 10 µm of the chord ends.
    let cfg = MotionConfig::default();
    let point = |k: i64| {
        let t = k as f64 * std::f64::consts::TAU / 1_800.0;
        let r = 8.0e6 + 0.6e6 * (3.0 * t).sin();
        xy(
            ((r * t.cos()) / 1_000.0).round() as i64 * 1_000,
            ((r * t.sin()) / 1_000.0).round() as i64 * 1_000,
        )
    };
    let mut points = vec![xy(0, 0), point(0)];
    let mut program = vec![blend(10_000), feed(2, point(0), 3000)];
    for k in 1..=1_800 {
        points.push(point(k));
        program.push(feed(k as u32 + 2, point(k), 3000));
    }
    program.push(Canon {
        line: 2_000,
        action: Action::Stop(gantry_machine::canon::StopKind::End),
    });
    let r = run(cfg, program);
    let rounded = r.reports.len();
    let dev = deviation(&cfg, &r.steps, &points);
    let time: u64 = r.reports.iter().map(|b| b.counts).sum();
    println!(
        "contour: {rounded} blocks, {:.4} s, largest deviation {dev:.0} nm",
        time as f64 / KERNEL_TIMER_HZ as f64
    );
    // Within the tolerance plus a step; the documented bound where chords meet rounded corners
    // is twice the tolerance.
    assert!(dev <= 10_000.0 + 1_563.0, "{dev}");
    assert_eq!(r.sim.kernel.position(), cfg.to_steps(&point(1_800)));
}
