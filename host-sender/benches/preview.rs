//! `gantry preview` of a generated program of short moves (rows of 0.2 mm G1 zig-zags over a
//! wavy Z, an arc pair every 50 lines, a rapid between rows), to PNG and to SVG: the whole
//! command (two passes of interpreter and planner, drawing, encoding). The last line printed is
//! the figure: `preview_png_lines_per_cpu_s: N` (process CPU time, user + sys, of one more run).
//! The comparison with LinuxCNC's `rs274 -g` is scripts/bench-preview.sh,
//! which needs rs274 and so is not run in CI.

use criterion::{criterion_group, Criterion};
use gantry_machine::setup::Setup;
use host_sender::preview;
use std::io::Write as _;
use std::path::{Path, PathBuf};

const LINES: usize = 100_000;

/// Writes the program; returns its line count.
fn write_program(path: &Path, lines: usize) -> usize {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(f, "G21 G90 G17 G94\nG0 Z5\nG0 X0 Y0\nG1 Z-1 F3000").unwrap();
    let (mut n, mut row) = (4, 0);
    while n < lines - 2 {
        let y = (row % 400) as f64 * 0.25;
        writeln!(f, "G0 Z2\nG0 X0 Y{y:.3}\nG1 Z-1").unwrap();
        n += 3;
        let mut x = 0.0;
        for i in 1..500 {
            if n >= lines - 2 {
                break;
            }
            if i % 50 == 0 {
                writeln!(
                    f,
                    "G2 X{:.3} Y{y:.3} I0.2 J0\nG3 X{:.3} Y{y:.3} I0.2 J0",
                    x + 0.4,
                    x + 0.8
                )
                .unwrap();
                x += 0.8;
                n += 2;
                continue;
            }
            x += 0.2;
            let z = -1.0 + 0.4 * (((i % 200) as f64 - 100.0).abs() / 50.0 - 1.0);
            writeln!(f, "G1 X{x:.3} Y{y:.3} Z{z:.3}").unwrap();
            n += 1;
        }
        row += 1;
    }
    writeln!(f, "G0 Z5\nM30").unwrap();
    n + 2
}

struct Files {
    dir: PathBuf,
    program: PathBuf,
}

impl Files {
    fn new() -> Files {
        let dir = std::env::temp_dir().join(format!("gantry-bench-preview-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let program = dir.join("raster.ngc");
        write_program(&program, LINES);
        Files { dir, program }
    }

    fn run(&self, out: &str) {
        preview::run(
            &self.program,
            &self.dir.join(out),
            &Setup::default(),
            &[0; 6],
        )
        .unwrap();
    }
}

impl Drop for Files {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// CPU time of this process so far (user + sys), s: /proc/self/stat fields 14 and 15.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .skip(11)
        .take(2)
        .map(|v| v.parse().unwrap_or(0.0))
        .collect();
    // Clock ticks: 100 per second on Linux.
    f.iter().sum::<f64>() / 100.0
}

fn bench(c: &mut Criterion) {
    let files = Files::new();
    let mut g = c.benchmark_group("preview");
    g.sample_size(10);
    g.throughput(criterion::Throughput::Elements(LINES as u64));
    g.bench_function("png_100k_lines", |b| b.iter(|| files.run("out.png")));
    g.bench_function("svg_100k_lines", |b| b.iter(|| files.run("out.svg")));
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    // One more run for the figure scripts read.
    let files = Files::new();
    let t = cpu_s();
    files.run("out.png");
    let spent = (cpu_s() - t).max(0.01);
    println!("preview_png_lines_per_cpu_s: {:.0}", LINES as f64 / spent);
}
