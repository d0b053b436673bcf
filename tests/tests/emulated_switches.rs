//! `gantry emulate` models the machine's switches at the ends of the travel with
//! the setup's polarity, and powers up where its state file says the machine stood. Through the
//! binary: normally-closed switches read open until reached (no alarm 1 on the first move),
//! `gantry home --port P` returns when homing has ended with the axis homed (item 1), and a
//! restarted emulator stands where the last one stopped.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

/// X and Y with normally-closed switches at both ends (inputs active low), X homed to its min
/// switch, the seek at 3000 mm/min.
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
            "[homing.axis.X]\npriority = 0   # 0 = not homed\nseek = \"low\"\nseek_rate = 2000.0",
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
    // Homing: seeks to the switch 16 mm away at 3000 mm/min, pulls off, locates, sets home; the command
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
    // pull-off; 10 mm further on. The fast seek's limit stop lets the step interrupt's two
    // prepared steps out past the switch (machine/src/step/isr.rs `TICKS_AHEAD`), but it does
    // not set the position: the locate at 60 mm/min, one step per 1.5625 ms, stops on the step
    // the switch closed at, so home is exactly the switch + pull-off (docs/settings.md).
    assert_eq!(stood[0], -301_000_000 + 2_000_000 + 10_000_000, "{stood:?}");
    let emu = Emulator::start(&dir, None);
    // 12 mm from the min switch: a 13 mm jog toward it trips it (hard limit, alarm 1).
    let out = gantry(
        &["--port", emu.port(), "jog", "X", "-13", "--feed", "3000"],
        T,
    );
    let status = gantry(&["--port", emu.port(), "status"], T);
    assert!(status.stdout.contains("alarm 1"), "{out:?} {status:?}");
}

/// The board clock's seconds of the emulator's first log line containing `what`.
fn log_time(log: &str, what: &str) -> Option<f64> {
    let line = log.lines().find(|l| l.contains(what))?;
    line.strip_prefix("emulate: ")?
        .split(" s ")
        .next()?
        .parse()
        .ok()
}

/// Homing at the defaults (seek 2000 mm/min, pull-off 2 mm, locate 60 mm/min) from the far end of
/// X's 600 mm travel: seconds of machine time, not minutes, and home exactly the pull-off off the
/// switch step.
#[test]
fn homing_a_600_mm_axis_from_its_far_end_at_the_defaults_takes_seconds() {
    let dir = Dir::new("homing-far-end");
    let machine = dir.file(
        "router.toml",
        "[inputs]\nlimits_min = [\"X\"]\n[homing.axis.X]\npriority = 1\n",
    );
    // At the X max end of the travel (±300 mm); the min switch is 1 mm beyond -300.
    std::fs::write(dir.0.join("state.toml.position"), "300000000 0 0\n").unwrap();
    let mut emu = Emulator::start(&dir, Some(&machine));
    let out = gantry(
        &["--port", emu.port(), "home", "X"],
        Duration::from_secs(180),
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(T, |l| l.contains(" Idle line")),
        "{}",
        emu.log()
    );
    let log = emu.log();
    let started = log_time(&log, " Homing line").expect("a Homing line");
    let ended = log
        .lines()
        .filter(|l| l.contains(" Idle line"))
        .filter_map(|l| log_time(l, " Idle line"))
        .find(|&t| t > started)
        .expect("Idle after Homing");
    let took = ended - started;
    // 601 mm at 2000 mm/min is 18.03 s, the locate 2 mm at 60 mm/min 2 s, the pull-off and the
    // retract at rapid and the ramps a fraction of a second.
    assert!(
        (20.0..30.0).contains(&took),
        "homing took {took} s of machine time\n{log}"
    );
    emu.kill_gently();
    let stood: Vec<i64> = std::fs::read_to_string(dir.0.join("state.toml.position"))
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    // Exactly the 2 mm retract off the switch at -301 mm: the locate stopped on its step.
    assert_eq!(stood[0], -301_000_000 + 2_000_000, "{stood:?}");
}
