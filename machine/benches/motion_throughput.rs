//! Host throughput of the motion core on a generated 100 000-block program of 0.1 mm segments:
//! plan + segment prep (canon in), and interpret + plan + segment prep (G-code text in).
//!
//! `cargo bench -p gantry-machine --bench motion_throughput`; the last line prints blocks/s.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput};
use gantry_machine::arith::{polar, TURN};
use gantry_machine::canon::{Action, Canon};
use gantry_machine::gcode::{InterpConfig, Interpreter, MemorySource};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::{Motion, PushError};

const BLOCKS: u32 = 100_000;

/// 0.1 mm chords around a 20 mm circle at F3000, as machine positions (nm).
fn points() -> Vec<(i64, i64)> {
    let r = 20_000_000i64;
    let step = (TURN as i128 * 5 / 1000 * 1_000_000 / 6_283_185) as i64;
    (1..=BLOCKS as i64)
        .map(|i| {
            let (x, y) = polar(r, step * i);
            (x - r, y)
        })
        .collect()
}

fn canon_program() -> Vec<Canon> {
    points()
        .into_iter()
        .enumerate()
        .map(|(i, (x, y))| Canon {
            line: i as u32 + 1,
            action: Action::Feed {
                to: [x, y, 0, 0, 0, 0],
                feed: 3_000_000_000,
            },
        })
        .collect()
}

fn gcode_program() -> Vec<u8> {
    let mut text = String::from("G21 G90 G17 F3000\n");
    for (x, y) in points() {
        text.push_str(&format!(
            "G1 X{:.6} Y{:.6}\n",
            x as f64 / 1e6,
            y as f64 / 1e6
        ));
    }
    text.push_str("M2\n");
    text.into_bytes()
}

/// Pushes every action and prepares every segment; returns the segment count.
fn plan_and_prep(program: impl Iterator<Item = Canon>) -> u64 {
    let mut motion: Box<Motion<128>> = Box::new(Motion::new(MotionConfig::default()));
    let mut segments = 0u64;
    for c in program {
        loop {
            match motion.push(&c) {
                Ok(()) => break,
                Err(PushError::Full) => {
                    if motion.next_segment().is_some() {
                        segments += 1;
                    } else if motion.sync_point().is_some() {
                        motion.release_sync();
                    }
                }
                Err(e) => panic!("{e:?}"),
            }
        }
    }
    loop {
        if motion.next_segment().is_some() {
            segments += 1;
        } else if motion.sync_point().is_some() {
            motion.release_sync();
        } else {
            break;
        }
    }
    segments
}

fn interpreted(text: &[u8]) -> impl Iterator<Item = Canon> + '_ {
    let mut interp = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(text);
    std::iter::from_fn(move || interp.next(&mut src).map(|r| r.expect("program is valid")))
}

/// Median of five wall-clock runs, blocks per second.
fn blocks_per_second(mut run: impl FnMut() -> u64) -> f64 {
    let mut rates: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            black_box(run());
            BLOCKS as f64 / t.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    rates[2]
}

fn main() {
    let canon = canon_program();
    let text = gcode_program();
    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let mut group = c.benchmark_group("motion_100k_blocks_0.1mm");
    group.throughput(Throughput::Elements(BLOCKS as u64));
    group.bench_function("plan+prep", |b| {
        b.iter(|| plan_and_prep(black_box(&canon).iter().copied()))
    });
    group.bench_function("interpret+plan+prep", |b| {
        b.iter(|| plan_and_prep(interpreted(black_box(&text))))
    });
    group.finish();
    c.final_summary();
    let plan = blocks_per_second(|| plan_and_prep(canon.iter().copied()));
    let all = blocks_per_second(|| plan_and_prep(interpreted(&text)));
    println!(
        "motion throughput (100k x 0.1 mm blocks): plan+prep {:.0} blocks/s, interpret+plan+prep {:.0} blocks/s",
        plan, all
    );
}
