//! A limit switch still pressed, through the binary against `gantry emulate --pty` (its switches
//! sit 1 mm beyond each end of the travel, docs/ports.md): the machine stands on the X max switch
//! (its position file puts it 1.5 mm beyond the travel). `gantry unlock` and `gantry home` exit 1
//! with the board's reason and the jog that frees the switch, and the board stays in its alarm
//! instead of tripping again; a jog toward the switch is refused, the jog off it runs from the
//! alarm; then unlock and homing work.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

/// The default machine with X and Y switches at both ends (hard limits on), X homed to its min
/// switch at 3000 mm/min, homing required or not.
fn setup(dir: &Dir, homing_required: bool) -> std::path::PathBuf {
    let base = gantry(&["setup", "show"], T).stdout;
    let mut text = base
        .replacen("limits_min = []", r#"limits_min = ["X", "Y"]"#, 1)
        .replacen("limits_max = []", r#"limits_max = ["X", "Y"]"#, 1)
        .replacen(
            "[homing.axis.X]\npriority = 0   # 0 = not homed\nseek = \"low\"\nseek_rate = 2000.0",
            "[homing.axis.X]\npriority = 1\nseek = \"low\"\nseek_rate = 3000.0",
            1,
        );
    if homing_required {
        text = text.replacen("required = false", "required = true", 1);
    }
    assert!(text.contains("seek_rate = 3000.0"), "{text}");
    dir.file("machine.toml", &text)
}

/// An emulator whose machine stands on the X max switch.
fn on_the_switch(dir: &Dir, homing_required: bool) -> Emulator {
    let machine = setup(dir, homing_required);
    std::fs::write(dir.0.join("state.toml.position"), "301500000 0 0\n").unwrap();
    Emulator::start(dir, Some(&machine))
}

/// The state of the emulator's last state line ("emulate: 1.234 s Idle line 0 …").
fn last_state(emu: &Emulator) -> String {
    let log = emu.log();
    let line = log
        .lines()
        .rev()
        .find(|l| l.contains(" line ") && l.contains(" steps "))
        .unwrap();
    line.split(" s ")
        .nth(1)
        .unwrap()
        .split(" line ")
        .next()
        .unwrap()
        .to_owned()
}

fn alarm_lines(emu: &Emulator) -> usize {
    emu.log()
        .lines()
        .filter(|l| l.contains(" s Alarm "))
        .count()
}

#[test]
fn unlock_on_a_pressed_switch_fails_and_says_to_jog_off_it() {
    let dir = Dir::new("limit-pressed-unlock");
    let emu = on_the_switch(&dir, false);
    let port = emu.port();
    // Powered up on the switch: alarm 1.
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1"), "{status:?}");
    let alarms = alarm_lines(&emu);
    // The unlock is refused with the reason and what to do, and the board stays in alarm 1
    // (before: exit 0, then alarm 1 again a millisecond later).
    let out = gantry(&["--port", port, "unlock"], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stdout.contains(
            "unlock refused: error 905: a limit switch is still pressed: jog the axis off it (away from the switch) first"
        ),
        "{out:?}"
    );
    assert!(
        out.stdout.contains(
            "the X max limit switch is pressed: jog off it with gantry jog X -1, then gantry unlock"
        ),
        "{out:?}"
    );
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1"), "{status:?}");
    assert_eq!(alarm_lines(&emu), alarms, "{}", emu.log());
    // Toward the switch: refused, nothing moves.
    let out = gantry(&["--port", port, "jog", "X", "1"], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("error 905"), "{out:?}");
    // Off it: runs from the alarm, exactly 2 mm, and the alarm stays until the unlock.
    let out = gantry(&["--port", port, "jog", "X", "-2", "--feed", "600"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1"), "{status:?}");
    assert!(status.stdout.contains("X -2.000"), "{status:?}");
    let out = gantry(&["--port", port, "unlock"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    // And it stays unlocked: a move runs.
    let out = gantry(&["--port", port, "jog", "X", "-5", "--feed", "600"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.starts_with("state:     Idle"), "{status:?}");
    assert!(status.stdout.contains("X -7.000"), "{status:?}");
    assert_eq!(last_state(&emu), "Idle", "{}", emu.log());
}

#[test]
fn homing_on_a_pressed_switch_fails_and_says_to_jog_off_it() {
    let dir = Dir::new("limit-pressed-home");
    let emu = on_the_switch(&dir, true);
    let port = emu.port();
    // Powered up on the switch: alarm 1 (homing is required too).
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1 "), "{status:?}");
    let alarms = alarm_lines(&emu);
    // X homes to its min switch: the pressed max switch would trip the seek at once (before:
    // alarm 1 in 3 ms, every axis unhomed).
    let out = gantry(&["--port", port, "home"], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("home refused: error 905"), "{out:?}");
    assert!(
        out.stdout.contains(
            "the X max limit switch is pressed: jog off it with gantry jog X -1, then gantry unlock and gantry home"
        ),
        "{out:?}"
    );
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1 "), "{status:?}");
    assert_eq!(alarm_lines(&emu), alarms, "{}", emu.log());
    // The jog off it runs before homing; then the unlock leaves the homing lock (alarm 11).
    let out = gantry(&["--port", port, "jog", "X", "-2", "--feed", "600"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.contains("alarm 1 "), "{status:?}");
    let out = gantry(&["--port", port, "unlock"], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("alarm 11"), "{out:?}");
    let out = gantry(&["--port", port, "home"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", port, "status"], T);
    assert!(status.stdout.starts_with("state:     Idle"), "{status:?}");
    assert!(status.stdout.contains("homed:     X"), "{status:?}");
}
