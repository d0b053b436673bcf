//! The stream report's time lost to starvation (machine/src/device/starvation.rs, carried in
//! the board's status), through the `gantry` binary: very short lines, long on the wire, streamed
//! over a pty to `gantry emulate --cpu-model f411` lose time, the example job streamed to the
//! emulated board loses none.

mod fine_lines;
mod serial_support;

use fine_lines::{fine_lines, Wording};
use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

/// 500 mm/s axes with 10 m/s², 160 steps/mm: the planner, not the axes, bounds the speed.
const FAST_AXES: &str = "[axis.X]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n\
[axis.Y]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n\
[axis.Z]\nsteps_per = [800, 5]\nmax_rate = 30000.0\naccel = 10000.0\n";

/// `n` lines of 0.02 mm at F30000 along X from −100 mm (Y and Z drifting): ~11,000 lines/s,
/// each 143 bytes on the wire (the link, not the CPU, cannot keep up).
fn short_lines(n: i64) -> String {
    fine_lines(-100, n, 20, 30_000, Wording::Wordy)
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
    // Its M6 answered at once: an unattended run (`--through-stops`).
    let out = gantry(
        &["stream", "--emulated", "--through-stops", bracket],
        60 * S,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert_eq!(starved_seconds(&out.stdout), 0.0, "{}", out.stdout);
}
