//! Sustained streaming throughput: lines per second of wall time through the real protocol into
//! the emulated board (interpreter + planner + step kernel all running), on a 0.1 mm CAM program.
//! The last line printed is the figure: `stream_lines_per_s: N`.

use criterion::{criterion_group, Criterion};
use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{stream_program, Flow};
use std::fmt::Write as _;
use std::time::Instant;

const LINES: usize = 10_000;

fn program() -> Program {
    let mut p = String::from("G21 G90 G94 F6000\n");
    for i in 0..LINES {
        let _ = writeln!(
            p,
            "G1 X{:.1} Y{:.1}",
            (i % 500) as f64 * 0.1,
            (i / 500) as f64 * 0.1
        );
    }
    p.push_str("M30\n");
    Program::from_text(&p)
}

fn fast_setup() -> Setup {
    let mut s = Setup::default();
    for a in s.axes.iter_mut() {
        a.max_rate = 10_000_000_000;
        a.accel = 2_000_000_000;
    }
    s
}

fn run_once(p: &Program) {
    let mut client = Client::connect(EmulatedBoard::new(fast_setup()), 2000).unwrap();
    let report = stream_program(&mut client, p, &mut |_| Flow::Continue).unwrap();
    assert!(report.completed);
}

fn bench(c: &mut Criterion) {
    let p = program();
    let mut g = c.benchmark_group("stream");
    g.sample_size(10);
    g.throughput(criterion::Throughput::Elements(LINES as u64));
    g.bench_function("emulated_10k_lines", |b| b.iter(|| run_once(&p)));
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    // One more timed run for the figure scripts read.
    let p = program();
    let t = Instant::now();
    run_once(&p);
    println!(
        "stream_lines_per_s: {:.0}",
        LINES as f64 / t.elapsed().as_secs_f64()
    );
}
