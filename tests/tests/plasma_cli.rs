//! Plasma torch mode as users run it (docs/laser-plasma.md "Plasma"): the `gantry` binary
//! against `gantry emulate --pty` with its scripted power source and height controller
//! (`--no-arc`, `--arc-ok-delay`, `--arc-lost-at`, `--thc`).

mod serial_support;

use serial_support::*;
use std::time::{Duration, Instant};

const S: Duration = Duration::from_secs(1);
const T: Duration = Duration::from_secs(60);

/// A torch machine; the arc-OK wait short so the alarm comes soon.
const TORCH_SETUP: &str = "[spindle]\ntorch = true\narc_ok_timeout_ms = 500\nthc_rate = 120\n\
                           thc_travel = 1\nthc_delay_ms = 0\n";

#[test]
fn without_arc_ok_the_job_ends_in_alarm_22_with_the_torch_off() {
    let dir = Dir::new("plasma-no-arc");
    let setup = dir.file("torch.toml", TORCH_SETUP);
    let job = dir.file("cut.nc", "G21 G90\nM3 S1\nG1 X20 F1200\nM5\nM2\n");
    let emu = Emulator::start_with(&dir, Some(&setup), &["--no-arc"]);
    let out = gantry(&["stream", job.to_str().unwrap(), "--port", emu.port()], T);
    assert_ne!(out.code, Some(0), "{out:?}");
    let all = format!("{}{}", out.stdout, out.stderr);
    assert!(all.contains("alarm 22 (no arc)"), "{all}");
    let status = gantry(&["status", "--port", emu.port()], 20 * S);
    assert!(status.stdout.contains("alarm 22"), "{status:?}");
    assert!(status.stdout.contains("torch off"), "{status:?}");
    // Nothing moved.
    assert!(emu.last_counts().0.starts_with("X 0 "), "{}", emu.log());
}

#[test]
fn a_lost_arc_holds_the_job_until_the_operator_goes_on_and_the_torch_re_fires() {
    let dir = Dir::new("plasma-arc-lost");
    let setup = dir.file("torch.toml", TORCH_SETUP);
    // 40 mm at 1200 mm/min: 2 s of cut; the arc goes out 1 s after the torch fired.
    let job = dir.file("cut.nc", "G21 G90\nM3 S1\nG1 X40 F1200\nM5\nM2\n");
    let emu = Emulator::start_with(
        &dir,
        Some(&setup),
        &["--arc-ok-delay", "300ms", "--arc-lost-at", "1s"],
    );
    let mut sender = spawn(&["--port", emu.port(), "stream", job.to_str().unwrap()]);
    assert!(
        wait_for(20 * S, || sender.stderr().contains("lost its arc")),
        "{}\n{}",
        sender.stderr(),
        emu.log()
    );
    assert!(emu.wait_log(10 * S, |l| l.contains("Hold (at rest)")));
    let held = emu.last_counts();
    // It stays held (the stop rule): nothing moves for 2 s.
    let since = Instant::now();
    while since.elapsed() < 2 * S {
        assert_eq!(emu.last_counts(), held, "{}", emu.log());
        std::thread::sleep(Duration::from_millis(50));
    }
    // The operator goes on: the torch re-fires, arc-OK after 300 ms, and the cut finishes.
    sender.answer("");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}\n{}", emu.log());
    assert!(out.stdout.contains("job done"), "{out:?}");
    assert!(
        emu.wait_log(10 * S, |l| l.contains("Idle")),
        "{}",
        emu.log()
    );
    assert!(
        emu.last_counts().0.starts_with(&format!("X {} ", 40 * 640)),
        "{}",
        emu.log()
    );
}

#[test]
fn a_thc_pattern_moves_z_at_its_rate_and_the_correction_comes_out_at_the_end() {
    let dir = Dir::new("plasma-thc");
    let setup = dir.file("torch.toml", TORCH_SETUP);
    // Arc-OK 50 ms after firing, "up" from 500 to 1000 ms: 0.5 s at 2 mm/s = 1 mm = 640 Z steps,
    // inside the 2.5 s cruise of the 50 mm cut; M2 takes them back out.
    let job = dir.file("cut.nc", "G21 G90\nM3 S1\nG1 X50 F1200\nM5\nM2\n");
    let emu = Emulator::start_with(&dir, Some(&setup), &["--thc", "up:500-1000"]);
    let out = gantry(&["stream", job.to_str().unwrap(), "--port", emu.port()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(10 * S, |l| l.contains("Idle")),
        "{}",
        emu.log()
    );
    let (steps, pulses) = emu.last_counts();
    assert!(steps.contains(" Z 0"), "{steps}");
    let z_pulses: i64 = pulses
        .split(" Z ")
        .nth(1)
        .and_then(|z| z.split_whitespace().next())
        .and_then(|z| z.parse().ok())
        .unwrap_or_else(|| panic!("no Z pulses in {pulses}"));
    // Up 640 and back down 640, within one 2 ms segment (3 steps) each way.
    assert!((z_pulses - 1280).abs() <= 6, "Z made {z_pulses} pulses");
}
