//! `gantry preview` streams the program: the same picture as when every move was held (a golden
//! SVG written by the in-memory renderer before the change, byte for byte; the PNG within a level
//! or two of rasterising that SVG whole), and a heap that does not grow with the program.

use gantry_machine::setup::Setup;
use host_sender::preview::{self, raster};
use std::path::{Path, PathBuf};

/// A directory of its own in the temp dir, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let p = std::env::temp_dir().join(format!("gantry-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// tests/golden/preview/bracket.svg: `gantry preview examples/bracket.ngc -o bracket.svg` at
/// 71263fc, when the preview held every move and built the document in memory.
const GOLDEN: &str = "tests/golden/preview/bracket.svg";

#[test]
fn streamed_svg_is_the_golden_byte_for_byte() {
    let dir = TempDir::new("preview-golden");
    // The title is the file name: the same one as when the golden was written.
    let program = dir.0.join("bracket.ngc");
    std::fs::copy(repo("examples/bracket.ngc"), &program).unwrap();
    let out = dir.0.join("bracket.svg");
    let code = preview::run(&program, &out, &Setup::default(), &[0; 6]).unwrap();
    assert_eq!(code, std::process::ExitCode::SUCCESS);
    let got = std::fs::read_to_string(&out).unwrap();
    let golden = std::fs::read_to_string(repo(GOLDEN)).unwrap();
    assert_eq!(got.len(), golden.len());
    for (n, (g, w)) in got.lines().zip(golden.lines()).enumerate() {
        assert_eq!(g, w, "line {}", n + 1);
    }
    assert_eq!(got, golden);
    // The in-memory job of the same program renders the same document.
    let text = std::fs::read(&program).unwrap();
    let p = preview::job_from_program(&text, false, &Setup::default(), "bracket.ngc").unwrap();
    let (svg, _) = preview::svg::render_svg(&p.job, &Default::default());
    assert_eq!(svg, golden);
}

#[test]
fn streamed_png_matches_the_golden_rasterised_whole() {
    let dir = TempDir::new("preview-png");
    let program = dir.0.join("bracket.ngc");
    std::fs::copy(repo("examples/bracket.ngc"), &program).unwrap();
    let out = dir.0.join("bracket.png");
    preview::run(&program, &out, &Setup::default(), &[0; 6]).unwrap();
    let got = resvg::tiny_skia::Pixmap::decode_png(&std::fs::read(&out).unwrap()).unwrap();
    let whole = raster::rasterise(&std::fs::read_to_string(repo(GOLDEN)).unwrap()).unwrap();
    assert_eq!((got.width(), got.height()), (whole.width(), whole.height()));
    let (mut differ, mut worst) = (0usize, 0u8);
    for (a, b) in got.pixels().iter().zip(whole.pixels()) {
        let d = [
            a.red().abs_diff(b.red()),
            a.green().abs_diff(b.green()),
            a.blue().abs_diff(b.blue()),
            a.alpha().abs_diff(b.alpha()),
        ];
        let d = d.into_iter().max().unwrap();
        if d > 0 {
            differ += 1;
            worst = worst.max(d);
        }
    }
    // Only compositing rounding: a few levels at a few anti-aliased pixels.
    let total = got.pixels().len();
    assert!(
        differ * 1000 < total && worst <= 8,
        "{differ} of {total} pixels differ, by up to {worst}"
    );
}

/// The peak resident memory of this process so far, KiB (Linux).
fn peak_rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// Writes a raster of short G1 moves to `path`: `rows` rows of 100 segments, a rapid between rows.
fn write_raster_program(path: &Path, rows: usize) {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(f, "G21 G90 G17 G94\nG0 Z5\nG1 Z-1 F3000").unwrap();
    for r in 0..rows {
        writeln!(f, "G0 Z2\nG0 X0 Y{}", r as f64 * 0.25).unwrap();
        for i in 1..=100 {
            let z = -1.0 + ((i % 20) as f64 - 10.0).abs() * 0.05;
            writeln!(f, "G1 X{:.1} Z{z:.2}", i as f64 * 0.2).unwrap();
        }
    }
    writeln!(f, "G0 Z5\nM30").unwrap();
}

/// Set in the child process that measures: the peak RSS is the whole process's, so the
/// measurement runs alone in a process of its own, never beside a sibling test that renders.
const MEASURE_ALONE: &str = "GANTRY_PREVIEW_MEMORY_ALONE";

#[cfg(target_os = "linux")]
#[test]
fn preview_memory_does_not_grow_with_the_program() {
    if std::env::var_os(MEASURE_ALONE).is_none() {
        // Re-run this test, and only it, in a fresh process of this test binary.
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "preview_memory_does_not_grow_with_the_program",
                "--exact",
                "--test-threads=1",
                "--nocapture",
            ])
            .env(MEASURE_ALONE, "1")
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "the measuring process failed:\n{text}"
        );
        assert!(
            text.contains("1 passed"),
            "the measuring process ran no test:\n{text}"
        );
        return;
    }
    let dir = TempDir::new("preview-memory");
    let run = |rows: usize, out: &str| {
        let program = dir.0.join(format!("raster{rows}.ngc"));
        write_raster_program(&program, rows);
        let out = dir.0.join(out);
        preview::run(&program, &out, &Setup::default(), &[0; 6]).unwrap();
        std::fs::remove_file(&program).unwrap();
        std::fs::remove_file(&out).unwrap();
        peak_rss_kib()
    };
    // The small program first: the peak then holds the code, the buffers and the planner.
    let small = run(20, "small.svg");
    // 10 times the moves: 20,000 G1 moves, 80,000 paths. Holding the moves alone would take
    // 20,000 × 88 B = 1.7 MiB, and the SVG document built in memory 7 MiB more. (PNG output is
    // bounded the same way, by a chunk of text and a pixmap per lane, but its plateau is only
    // reached with more than 2,500 moves per lane, too slow for a debug-build test.)
    let large = run(200, "large.svg");
    assert!(
        large <= small + 1024,
        "peak RSS: {small} KiB at 2,000 moves, {large} KiB at 20,000"
    );
}
