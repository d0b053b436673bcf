//! Streaming: a 100 000-block program of 0.1 mm segments keeps the planner fed and at speed.

use gantry_machine::arith::{polar, TURN};
use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::sim::{Sim, SimEvent};
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;

/// 100 000 chords of 0.1 mm around a 20 mm circle at F3000 (generated canon, as a CAM post would).
fn circle_program(blocks: u32) -> impl Iterator<Item = Canon> {
    let r = 20_000_000i64;
    // 0.1 mm chord on r = 20 mm: 0.005 rad = TURN · 0.005 / 2π.
    let step = (TURN as i128 * 5 / 1000 * 1_000_000 / 6_283_185) as i64;
    (1..=blocks).map(move |i| {
        let (x, y) = polar(r, step * i as i64);
        Canon {
            line: i,
            action: Action::Feed {
                to: [x - r, y, 0, 0, 0, 0],
                feed: 3000 * 1_000_000,
            },
        }
    })
}

#[test]
fn hundred_thousand_short_segments_never_starve() {
    let cfg = MotionConfig::default();
    let mut sim: Box<Sim<128>> = Box::new(Sim::new(cfg));
    let mut slow_blocks = 0u32;
    let mut blocks = 0u32;
    let mut steps = 0u64;
    sim.run(circle_program(100_000), &mut |e| match e {
        SimEvent::Block { report, .. } => {
            blocks += 1;
            // After the first ramp (≤ 6.25 mm = 63 blocks) and before the final one, every block
            // runs at the programmed 50 mm/s.
            if (100..99_900).contains(&report.line) && report.entry < 49_900_000 {
                slow_blocks += 1;
            }
        }
        SimEvent::Step(_) => steps += 1,
        _ => {}
    })
    .unwrap();
    let seconds = sim.now as f64 / KERNEL_TIMER_HZ as f64;
    // 10 000 mm at 50 mm/s = 200 s, plus one ramp up and one down (0.25 s each, half lost).
    println!(
        "{blocks} blocks, {steps} step ticks, {seconds:.3} s, underruns {}",
        sim.underruns
    );
    assert_eq!(blocks, 100_000);
    assert_eq!(slow_blocks, 0);
    assert_eq!(sim.underruns, 0);
    assert!(seconds < 200.0 + 0.3, "{seconds}");
    let end = circle_program(100_000).last().unwrap();
    let Action::Feed { to, .. } = end.action else {
        unreachable!()
    };
    assert_eq!(sim.kernel.position(), cfg.to_steps(&to));
}
