//! Issue 25 item 6: `gantry emulate` models the machine's switches at the ends of the travel with
//! the setup's polarity, and powers up where its state file says the machine stood. Through the
//! binary: normally-closed switches read open until reached (no alarm 1 on the first move),
//! `gantry home --port P` returns when homing has ended with the axis homed (item 1), and a
//! restarted emulator stands where the last one stopped.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

/// X and Y with normally-closed switches at both ends (inputs active low), X homed to its min
/// switch at 3000 mm/min.
fn setup(dir: &Dir) -> std::path::PathBuf {
    let base = gantry(&["setup", "show"], T).stdout;
    let text = base
        .replacen(
            "active_low = []",
            r#"active_low = ["x_min", "x_max", "y_min", "y_max"]"#,
            1,
        )
        .replacen("limits_min = []", r#"limits_min = ["X", "Y"]"#, 1)
        .replacen("limits_max = []", r#"limits_max = ["X", "Y"]"#, 1)
        .replacen(
            "[homing.axis.X]\npriority = 0   # 0 = not homed\nseek = \"low\"\nseek_rate = 60.0",
            "[homing.axis.X]\npriority = 1\nseek = \"low\"\nseek_rate = 3000.0",
            1,
        );
    assert!(text.contains("seek_rate = 3000.0"), "{text}");
    dir.file("machine.toml", &text)
}

#[test]
fn normally_closed_switches_homing_and_the_power_up_position() {
    let dir = Dir::new("emulated-switches");
    let machine = setup(&dir);
    // The machine stands 10 mm inside the X min end (travel ±300 mm, switch 1 mm beyond).
    std::fs::write(dir.0.join("state.toml.position"), "-290000000 0 0\n").unwrap();
    let mut emu = Emulator::start(&dir, Some(&machine));
    // Normally closed, not reached: a move runs (was: alarm 1 at once).
    let out = gantry(
        &["--port", emu.port(), "jog", "X", "5", "--feed", "3000"],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", emu.port(), "status"], T);
    assert!(status.stdout.contains("Idle"), "{status:?}");
    // Homing: seeks to the switch 16 mm away at 3000 mm/min, pulls off, sets home; the command
    // returns once it has ended, the axis homed.
    let out = gantry(&["--port", emu.port(), "home", "X"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.took > Duration::from_millis(300),
        "returned at once: {out:?}"
    );
    let status = gantry(&["--port", emu.port(), "status"], T);
    assert!(status.stdout.contains("Idle"), "{status:?}");
    assert!(emu.log().contains(" Homing line"), "{}", emu.log());
    // Stop the board where it stands; the next power-up is there (X 5 mm from the min end after
    // homing to home_position 0 with a 2 mm pull-off: machine X 2 is 3 mm inside the switch).
    let out = gantry(
        &["--port", emu.port(), "jog", "X", "10", "--feed", "3000"],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    emu.kill_gently();
    let stood: Vec<i64> = std::fs::read_to_string(dir.0.join("state.toml.position"))
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    // Switch at -301 mm, home_position 0 there... the frame: after homing X 0 is the switch +
    // pull-off; 10 mm further on. The seek's limit stop let the step interrupt's two prepared
    // steps out past the switch (machine/src/step/isr.rs `TICKS_AHEAD`; 1 562.5 nm each): home
    // sits two steps further out, as on the board.
    assert_eq!(
        stood[0],
        -301_000_000 + 2_000_000 + 10_000_000 - 3_125,
        "{stood:?}"
    );
    let emu = Emulator::start(&dir, None);
    // 12 mm from the min switch: a 13 mm jog toward it trips it (hard limit, alarm 1).
    let out = gantry(
        &["--port", emu.port(), "jog", "X", "-13", "--feed", "3000"],
        T,
    );
    let status = gantry(&["--port", emu.port(), "status"], T);
    assert!(status.stdout.contains("alarm 1"), "{out:?} {status:?}");
}
