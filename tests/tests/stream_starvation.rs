//! The stream report's time lost to starvation (machine/src/board/starvation.rs, carried in
//! the board's status), through the `gantry` binary: very short lines, long on the wire, streamed
//! over a pty to `gantry emulate --cpu-model f411` lose time, the example job streamed to the
//! emulated board loses none.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

/// 500 mm/s axes with 10 m/s², 160 steps/mm: the planner, not the axes, bounds the speed.
const FAST_AXES: &str = "[axis.X]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n\
[axis.Y]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n\
[axis.Z]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n";

/// A parameter of a long name (0) each line adds to its X: 143 bytes a line, so the link, which
/// the board takes at most 512 B a millisecond of (`RX_BYTES_PER_PASS`), delivers ~3,500 lines a
/// second, fewer than the moves need.
const NAME: &str =
    "_a_parameter_whose_long_name_makes_each_line_of_this_program_take_more_bytes_on_the_wire";

/// `n` lines of 0.02 mm at F30000 along X (Y and Z drifting): ~11,000 lines/s, each long on the
/// wire.
fn short_lines(n: i64) -> String {
    let mut p = format!("G21 G90\n#<{NAME}>=0\nG0 X-100 Y0 Z0\nG1 F30000\n");
    for i in 1..=n {
        let x = -100_000 + i * 20;
        let sign = if x < 0 { "-" } else { "" };
        p.push_str(&format!(
            "X[{sign}{}.{:03}+#<{NAME}>] Y0.{:05} Z-0.{:05}\n",
            x.abs() / 1000,
            x.abs() % 1000,
            2 * i,
            2 * i
        ));
    }
    p.push_str("M30\n");
    p
}

/// The seconds on the report's `starved:` line.
fn starved_seconds(stdout: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("starved:"))
        .unwrap_or_else(|| panic!("no starved line in {stdout}"));
    line["starved:".len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn short_lines_over_a_pty_to_the_f411_model_lose_time() {
    let dir = Dir::new("starved-pty");
    let setup = dir.file("setup.toml", FAST_AXES);
    let emu = Emulator::start_with(&dir, Some(&setup), &["--cpu-model", "f411"]);
    let file = dir.file("short.ngc", &short_lines(5_000));
    let port = emu.pty.to_str().unwrap();
    let out = gantry(&["--port", port, "stream", file.to_str().unwrap()], 60 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    let starved = starved_seconds(&out.stdout);
    // 100 mm planned in 0.715 s (`gantry simulate`); fed at the F411's pace it takes longer.
    assert!(starved > 0.1, "starved {starved} s:\n{}", out.stdout);
}

#[test]
fn the_example_job_loses_no_time() {
    let bracket = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/bracket.ngc");
    let out = gantry(&["stream", "--emulated", bracket], 60 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert_eq!(starved_seconds(&out.stdout), 0.0, "{}", out.stdout);
}
