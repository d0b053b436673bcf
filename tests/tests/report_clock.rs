//! The stream report's times, through the binary against `gantry emulate --pty` (the real-time
//! board): machine time = running + standing, standing covers the wait at a stop's prompt, and
//! machine time is never above the wall time.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(60);

/// The four figures of `time:     M s machine time: R s running, S s standing … (W s wall)`.
fn times(stdout: &str) -> (f64, f64, f64, f64) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("time:"))
        .unwrap_or_else(|| panic!("no time line: {stdout}"));
    let nums: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|w| w.parse().ok())
        .collect();
    assert_eq!(nums.len(), 4, "{line}");
    (nums[0], nums[1], nums[2], nums[3])
}

#[test]
fn the_reports_times_add_up_and_stay_within_the_wall_time() {
    let dir = Dir::new("report-clock");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let job = dir.file(
        "m0.ngc",
        "G21 G90\nG1 X5 F3000\nM0 (check the part)\nG1 X0\nM30\n",
    );
    let emu = Emulator::start(&dir, Some(&setup));
    let mut sender = spawn(&["--port", emu.port(), "stream", job.to_str().unwrap()]);
    assert!(
        emu.wait_log(T, |l| l.contains("Hold (at rest)")),
        "{}",
        emu.log()
    );
    // The operator looks at the part for a while before pressing Enter.
    let think = Duration::from_millis(1500);
    std::thread::sleep(think);
    sender.answer("");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let (machine, running, standing, wall) = times(&out.stdout);
    assert!(
        (running + standing - machine).abs() <= 0.0015,
        "{machine} != {running} + {standing}: {}",
        out.stdout
    );
    // The sender sees the stop in the board's next status (every 0.1 s), later under load: the
    // standing time may start a little after the log line the wait was timed from.
    assert!(standing >= think.as_secs_f64() - 0.5, "{}", out.stdout);
    // The wall time is printed to 10 ms.
    assert!(machine <= wall + 0.005, "{}", out.stdout);
}

/// The in-process emulated board (no `--port`) runs its clock flat out while the job moves, but
/// at the wall clock's pace while the operator is asked: the standing time is the wait.
#[test]
fn on_the_emulated_board_the_standing_time_is_the_operators_wait() {
    let dir = Dir::new("report-clock-emulated");
    let job = dir.file(
        "m0.ngc",
        "G21 G90\nG1 X5 F3000\nM0 (check the part)\nG1 X0\nM30\n",
    );
    let mut sender = spawn(&["stream", job.to_str().unwrap()]);
    assert!(
        wait_for(T, || sender.stdout().contains("check the part")
            || sender.stderr().contains("check the part")),
        "{} {}",
        sender.stdout(),
        sender.stderr()
    );
    let think = Duration::from_millis(1500);
    std::thread::sleep(think);
    sender.answer("");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let (machine, running, standing, _wall) = times(&out.stdout);
    assert!(
        (running + standing - machine).abs() <= 0.0015,
        "{}",
        out.stdout
    );
    // At least the wait; not a fraction of it (it was a fifth: one board ms per 5 ms slept).
    assert!(standing >= think.as_secs_f64() - 0.5, "{}", out.stdout);
}
