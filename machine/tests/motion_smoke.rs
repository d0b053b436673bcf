use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::sim::{Sim, SimEvent};

const MM: i64 = 1_000_000;

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
    let mut steps = 0u64;
    let mut blocks = Vec::new();
    sim.run(prog, &mut |e| match e {
        SimEvent::Step(_) => steps += 1,
        SimEvent::Block { report, .. } => blocks.push(report),
        _ => {}
    })
    .unwrap();
    for b in &blocks {
        println!("{b:?}");
    }
    println!(
        "time {} ms steps {steps} underruns {}",
        sim.millis(),
        sim.underruns
    );
    assert_eq!(sim.kernel.position(), [0; 6]);
}
