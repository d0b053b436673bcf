//! On-the-fly outputs through the motion core (docs/controller.md, "On-the-fly outputs"): an output event
//! queued between two moves rides on the second move's first segment and is reported by the
//! kernel tick that starts it, exactly at the junction step, at full speed.

use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::{Motion, MotionState};
use gantry_machine::motion::planner::BlockKind;
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::motion::sim::{Sim, SimEvent};
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::units::Pos;

const UM: i64 = 1_000;
/// Default axes: 3200 steps per 5 mm.
const STEPS_PER_MM: i64 = 640;
/// 1125 mm/min = 18.75 mm/s = 12 000 steps/s: exactly 1000 timer counts per step.
const FEED_MM_MIN: i64 = 1125;
const CRUISE_PERIOD: u32 = KERNEL_TIMER_HZ / 12_000;
/// The GIXA controller manual's on-the-fly example (docs/controller.md, on-the-fly M codes) in mm:
/// 1.0 in, 6.0 in and 7.0 in along X.
const INCH_UM: i64 = 25_400;

fn x(um: i64) -> Pos {
    [um * UM, 0, 0, 0, 0, 0]
}

fn feed(line: u32, to_um: i64) -> Step {
    Step::Push(Canon {
        line,
        action: Action::Feed {
            to: x(to_um),
            feed: FEED_MM_MIN * 1_000_000,
        },
    })
}

fn on(n: u8) -> OutputEvent {
    OutputEvent::new(n, true).unwrap()
}

fn off(n: u8) -> OutputEvent {
    OutputEvent::new(n, false).unwrap()
}

/// One thing the test program does to the pipeline.
#[derive(Clone, Copy)]
enum Step {
    Push(Canon),
    /// An on-the-fly user M code: line, code, event.
    Output(u32, u16, OutputEvent),
    /// No more motion: [`Motion::flush_output`].
    End,
}

/// What a run recorded.
#[derive(Default, Debug)]
struct Run {
    /// Each output the kernel fired: X steps made before it, the event, the period of its tick.
    outputs: Vec<(i64, OutputEvent, u32)>,
    /// Each sync point reached: X steps made, its line.
    syncs: Vec<(i64, u32)>,
    blocks: Vec<BlockReport>,
    /// Times a hold came to rest, with the X position then.
    holds: Vec<i64>,
    x: i64,
}

/// Runs `program` on a 32-block pipeline; `hold_at`: feed hold once X has made that many steps,
/// resumed as soon as the hold is at rest.
fn run(program: &[Step], hold_at: Option<i64>) -> Run {
    let mut sim: Sim<32> = Sim::new(MotionConfig::default());
    let mut r = Run::default();
    let mut x = 0i64;
    let mut pending_output: Option<(u64, OutputEvent)> = None;
    let mut next = 0;
    let mut idle = 0;
    let mut held = false;
    loop {
        while next < program.len() {
            let ok = match program[next] {
                Step::Push(c) => sim.motion.push(&c).is_ok(),
                Step::Output(l, c, e) => sim.motion.push_output(l, c, e).is_ok(),
                Step::End => sim.motion.flush_output().is_ok(),
            };
            if !ok {
                break;
            }
            next += 1;
        }
        if let Some(at) = hold_at {
            if !held && r.holds.is_empty() && x >= at {
                sim.motion.feed_hold();
                held = true;
            }
        }
        if held && sim.motion.state() == MotionState::Held && !sim.kernel.is_busy() {
            r.holds.push(x);
            held = false;
            sim.motion.resume();
        }
        let mut tick_steps = 0;
        let mut events = Vec::new();
        let out = sim.tick(&mut |e| events.push(e));
        for e in events {
            match e {
                SimEvent::Output { time, output, .. } => pending_output = Some((time, output)),
                SimEvent::Step(s) => tick_steps += i64::from(s.step & 1),
                SimEvent::Sync { canon, .. } => r.syncs.push((x, canon.line)),
                SimEvent::Block { report, .. } => r.blocks.push(report),
            }
        }
        if let Some((_, output)) = pending_output.take() {
            // Reported by the tick that starts its block's first segment, before that tick's step
            // (at low rates AMASS over-drives the tick, so the first step may come a tick later).
            r.outputs.push((x, output, out.period));
        }
        x += tick_steps;
        if out.period == 0 {
            idle += 1;
            if idle > 3 && next >= program.len() {
                break;
            }
        } else {
            idle = 0;
        }
    }
    assert_eq!(sim.kernel.position()[0], x);
    r.x = x;
    r
}

/// `G1 X1in` / `M14` / `X6in` / `M15` / `X7in` with M14 = set 1, M15 = clear 1.
fn gixa_example() -> Vec<Step> {
    vec![
        feed(1, INCH_UM),
        Step::Output(2, 14, on(1)),
        feed(3, 6 * INCH_UM),
        Step::Output(4, 15, off(1)),
        feed(5, 7 * INCH_UM),
        Step::End,
    ]
}

const STEPS_1IN: i64 = 16_256;

#[test]
fn outputs_between_moves_fire_at_the_junction_step_at_cruise_speed() {
    let r = run(&gixa_example(), None);
    assert_eq!(
        r.outputs,
        vec![
            (STEPS_1IN, on(1), CRUISE_PERIOD),
            (6 * STEPS_1IN, off(1), CRUISE_PERIOD)
        ]
    );
    assert!(r.syncs.is_empty(), "{:?}", r.syncs);
    assert_eq!(r.x, 7 * STEPS_1IN);
    // No slowdown at either junction: the blocks meet at the programmed 18.75 mm/s.
    let cruise = (FEED_MM_MIN * 1_000_000 / 60) as u64;
    assert_eq!(r.blocks.len(), 3);
    for b in &r.blocks[..2] {
        assert_eq!(b.exit, cruise, "{b:?}");
    }
    assert_eq!(r.blocks[1].entry, cruise);
    assert_eq!(r.blocks[2].entry, cruise);
}

#[test]
fn the_event_rides_on_the_next_line_block_and_its_first_segment_only() {
    let mut m: Motion<8> = Motion::new(MotionConfig::default());
    for s in &gixa_example()[..3] {
        match *s {
            Step::Push(c) => m.push(&c).unwrap(),
            Step::Output(l, c, e) => m.push_output(l, c, e).unwrap(),
            Step::End => m.flush_output().unwrap(),
        }
    }
    let p = m.planner();
    assert_eq!(p.len(), 2);
    assert_eq!(
        p.get(0).unwrap().kind(),
        BlockKind::Line {
            output: OutputEvent::NONE
        }
    );
    let b = p.get(1).unwrap();
    assert_eq!(
        (b.kind(), b.stop_before),
        (BlockKind::Line { output: on(1) }, false)
    );
    assert!(!m.output_pending());
    let mut x = 0i64;
    let mut carried = Vec::new();
    while let Some(s) = m.next_segment() {
        if s.output.is_some() {
            carried.push((x, s.output));
        }
        x += i64::from(s.steps[0]);
    }
    assert_eq!(carried, vec![(STEPS_1IN, on(1))]);
    assert_eq!(x, 6 * STEPS_1IN);
}

#[test]
fn an_output_before_the_first_move_fires_before_its_first_step() {
    let r = run(
        &[Step::Output(1, 14, on(3)), feed(1, 10_000), Step::End],
        None,
    );
    assert_eq!(r.outputs.len(), 1);
    assert_eq!(r.outputs[0].0, 0);
    assert_eq!(r.outputs[0].1, on(3));
    assert!(r.syncs.is_empty());
}

#[test]
fn two_outputs_between_the_same_moves_break_the_contour_and_run_at_rest() {
    let r = run(
        &[
            feed(1, 10_000),
            Step::Output(2, 14, on(1)),
            Step::Output(3, 15, off(1)),
            feed(4, 20_000),
            Step::End,
        ],
        None,
    );
    assert!(r.outputs.is_empty(), "{:?}", r.outputs);
    // Both became sync points, in order, with X at rest on the junction.
    assert_eq!(
        r.syncs,
        vec![(10 * STEPS_PER_MM, 2), (10 * STEPS_PER_MM, 3)]
    );
    // The first move ends at the start speed (1 mm/s): it stops there.
    assert_eq!(r.blocks[0].exit, 1_000_000);
    assert_eq!(r.blocks[1].entry, 1_000_000);
    assert_eq!(r.x, 20 * STEPS_PER_MM);
}

#[test]
fn an_output_with_no_move_after_it_runs_once_the_motion_before_it_has_ended() {
    // Followed by a dwell.
    let dwell = Step::Push(Canon {
        line: 3,
        action: Action::Dwell { micros: 10_000 },
    });
    let r = run(
        &[
            feed(1, 10_000),
            Step::Output(2, 14, on(1)),
            dwell,
            feed(4, 20_000),
        ],
        None,
    );
    assert!(r.outputs.is_empty());
    assert_eq!(r.syncs, vec![(10 * STEPS_PER_MM, 2)]);
    // Followed by the end of the program.
    let r = run(
        &[feed(1, 10_000), Step::Output(2, 14, on(1)), Step::End],
        None,
    );
    assert!(r.outputs.is_empty());
    assert_eq!(r.syncs, vec![(10 * STEPS_PER_MM, 2)]);
}

#[test]
fn a_move_without_steps_leaves_the_output_for_the_next_move() {
    let r = run(
        &[
            feed(1, 10_000),
            Step::Output(2, 14, on(1)),
            feed(2, 10_000),
            feed(3, 20_000),
            Step::End,
        ],
        None,
    );
    assert_eq!(r.outputs, vec![(10 * STEPS_PER_MM, on(1), CRUISE_PERIOD)]);
}

#[test]
fn a_hold_across_the_point_fires_the_output_once_at_the_same_step() {
    // The deceleration from 18.75 mm/s takes 0.88 mm plus the queued segments (≈ 0.3 mm): a hold
    // at 20 mm or 24 mm comes to rest before the 1 in (25.4 mm) junction, one at 25 mm passes it
    // while slowing down.
    let mut passed = Vec::new();
    for hold_mm in [20, 24, 25] {
        let r = run(&gixa_example(), Some(hold_mm * STEPS_PER_MM));
        assert_eq!(r.holds.len(), 1, "hold at {hold_mm} mm");
        assert_eq!(r.outputs.len(), 2, "hold at {hold_mm} mm: {:?}", r.outputs);
        assert_eq!((r.outputs[0].0, r.outputs[0].1), (STEPS_1IN, on(1)));
        assert_eq!((r.outputs[1].0, r.outputs[1].1), (6 * STEPS_1IN, off(1)));
        assert_eq!(r.outputs[1].2, CRUISE_PERIOD);
        assert_eq!(r.x, 7 * STEPS_1IN);
        let beyond = r.holds[0] > STEPS_1IN;
        if beyond {
            // Fired on the way down, before the stop.
            assert!(r.outputs[0].2 > CRUISE_PERIOD, "{:?}", r.outputs);
        }
        passed.push(beyond);
    }
    assert_eq!(passed, [false, false, true]);
}
