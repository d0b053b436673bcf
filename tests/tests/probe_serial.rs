//! Probing through the `gantry` binary: `gantry emulate --pty --probe-target plane:-5` as its own
//! process, `gantry stream --port` and `gantry status --port` as users run them
//! (docs/probing.md).

mod serial_support;

use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

#[test]
fn g38_2_finds_the_plane_and_the_program_uses_the_result() {
    let dir = Dir::new("probe-plane");
    let emu = Emulator::start_with(&dir, None, &["--probe-target", "plane:-5"]);
    let port = emu.port();
    // Probe down, then go 1 mm above the contact the program read from #5063: Z -4.000 mm is
    // step -2560 (640 steps per mm), exact because the latch is exactly on the plane.
    let job = dir.file(
        "probe.nc",
        "G21 G90\nG38.2 Z-20 F100\nG0 Z[#5063 + 1]\nM2\n",
    );
    let out = gantry(&["stream", job.to_str().unwrap(), "--port", port], 60 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.contains("job done: last line 4 of 4"),
        "{}",
        out.stdout
    );
    assert!(
        emu.wait_log(5 * S, |l| l.contains("Idle line 4 steps X 0 Y 0 Z -2560")),
        "{}",
        emu.log()
    );
    // The probe input is in the status (the tip stands 1 mm above the plane: not touching).
    let st = gantry(&["status", "--port", port], 10 * S);
    assert_eq!(st.code, Some(0), "{st:?}");
    assert!(st.stdout.starts_with("state:     Idle"), "{}", st.stdout);
}

#[test]
fn g38_2_without_contact_ends_the_stream_in_alarm_5_and_g38_3_does_not() {
    let dir = Dir::new("probe-miss");
    let emu = Emulator::start_with(&dir, None, &["--probe-target", "plane:-5"]);
    let port = emu.port();
    let ok = dir.file("miss3.nc", "G21 G90\nG38.3 Z-4 F300\nG0 Z0\nM2\n");
    let out = gantry(&["stream", ok.to_str().unwrap(), "--port", port], 60 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.contains("job done: last line 4 of 4"),
        "{}",
        out.stdout
    );
    let bad = dir.file("miss2.nc", "G21 G90\nG38.2 Z-4 F300\nG0 Z0\nM2\n");
    let out = gantry(&["stream", bad.to_str().unwrap(), "--port", port], 60 * S);
    assert_ne!(out.code, Some(0), "{out:?}");
    let text = format!("{}{}", out.stdout, out.stderr);
    assert!(text.contains("line 2: alarm 5"), "{text}");
    assert!(
        emu.wait_log(5 * S, |l| l.contains("Alarm 5 line 2")),
        "{}",
        emu.log()
    );
}
