use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::sim::{Sim, SimEvent};

const MM: i64 = 1_000_000;

/// A 10 mm square at 1200 mm/min (default axes: 3200 steps per 5 mm = 640 steps/mm) runs every
/// side: 6400 steps out and 6400 back on X and on Y, nothing on the other axes, each side ends
/// where the next starts, the last at rest, and the whole takes the 2 s of 40 mm at 20 mm/s plus
/// the ramps.
#[test]
fn square_smoke() {
    let cfg = MotionConfig::default();
    let mut sim: Sim<128> = Sim::new(cfg);
    let prog = [
        Canon {
            line: 1,
            action: Action::Feed {
                to: [10 * MM, 0, 0, 0, 0, 0],
                feed: 1200 * MM,
            },
        },
        Canon {
            line: 2,
            action: Action::Feed {
                to: [10 * MM, 10 * MM, 0, 0, 0, 0],
                feed: 1200 * MM,
            },
        },
        Canon {
            line: 3,
            action: Action::Feed {
                to: [0, 10 * MM, 0, 0, 0, 0],
                feed: 1200 * MM,
            },
        },
        Canon {
            line: 4,
            action: Action::Feed {
                to: [0, 0, 0, 0, 0, 0],
                feed: 1200 * MM,
            },
        },
    ];
    let mut steps = [[0u64; 2]; 6]; // per axis: [positive, negative] steps
    let mut blocks = Vec::new();
    sim.run(prog, &mut |e| match e {
        SimEvent::Step(ev) => {
            for (axis, count) in steps.iter_mut().enumerate() {
                if ev.step & (1 << axis) != 0 {
                    count[usize::from(ev.dir & (1 << axis) != 0)] += 1;
                }
            }
        }
        SimEvent::Block { report, .. } => blocks.push(report),
        _ => {}
    })
    .unwrap();
    let mut want = [[0u64; 2]; 6];
    want[0] = [6400, 6400];
    want[1] = [6400, 6400];
    assert_eq!(steps, want);
    assert_eq!(sim.underruns, 0);
    assert_eq!(
        blocks.iter().map(|b| b.line).collect::<Vec<_>>(),
        [1, 2, 3, 4]
    );
    for b in &blocks {
        assert_eq!(b.length, 10 * MM as u64, "{b:?}");
        assert_eq!(
            b.peak,
            20 * MM as u64,
            "cruises at 1200 mm/min = 20 mm/s: {b:?}"
        );
    }
    assert_eq!(blocks[3].exit, 0, "ends at rest");
    let ms = sim.millis();
    assert!((2_000..2_400).contains(&ms), "{ms} ms");
    assert_eq!(sim.kernel.position(), [0; 6]);
}
