//! Segment preparation (machine/src/motion/prep.rs) seen through the whole motion pipeline
//! (machine/src/motion/pipeline.rs): here rather than in prep.rs's own tests, which would make
//! prep.rs import the pipeline built on it (an import cycle, tests/tests/import_graph.rs).

use gantry_machine::canon::{Action, Canon};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::Motion;
use gantry_machine::motion::profile::Profile;
use gantry_machine::step::kernel::Segment;

const MM: i64 = 1_000_000;

fn feed(line: u32, x: i64) -> Canon {
    Canon {
        line,
        action: Action::Feed {
            to: [x, 0, 0, 0, 0, 0],
            feed: 3000 * MM,
        },
    }
}

/// X 10 mm, then 0.1015 mm (65 steps at 640 steps/mm), then 10 mm more, all at F3000
/// (50 mm/s, the default highest rate): the middle block runs at 50 mm/s throughout, where a
/// segment's nominal 2 ms is 100 µm = mul_div(100_000, 65, 101_500) = 64 steps. Its one step
/// left over is not a segment of its own: the block is one 65-step segment lasting the
/// profile's 101.5 µm / 50 mm/s = 2.03 ms = 24,360 counts at 12 MHz, as 65 ticks of
/// 24,360 / 65 = 374 counts (the 50 counts of rounding are paid in the next block's first segment).
#[test]
fn a_one_step_remainder_stays_in_the_segment() {
    let mut motion: Motion<16> = Motion::new(MotionConfig::default());
    for c in [feed(1, 10 * MM), feed(2, 10_101_500), feed(3, 20_101_500)] {
        motion.push(&c).unwrap();
    }
    let mut segments = Vec::new();
    while let Some(s) = motion.next_segment() {
        segments.push(s);
    }
    let mut x = 0;
    let middle: Vec<&Segment> = segments
        .iter()
        .filter(|s| {
            x += s.steps[0];
            x > 6400 && x <= 6465
        })
        .collect();
    assert_eq!(middle.len(), 1, "{middle:?}");
    let s = middle[0];
    assert_eq!(s.steps, [65, 0, 0, 0, 0, 0]);
    assert_eq!((s.ticks, s.period), (65, 374));
    let profile = Profile::plan(
        0,
        50 * MM as u64,
        101_500,
        50 * MM as u64,
        u64::MAX,
        200 * MM as u64,
    );
    assert_eq!(profile.duration(), 24_360);
    assert_eq!(
        u64::from(s.ticks) * u64::from(s.period),
        profile.duration() - profile.duration() % 65
    );
    assert_eq!(x, 12_865, "every step of the job");
}
