//! A newcomer's smaller seams, through the `gantry` binary against `gantry emulate --pty`: a hold
//! with nothing to hold says so; the status names the active inputs as the console does; a
//! spindle speed beyond `spindle.rpm_range` is warned with its line; the emulator says its
//! underrun count only when there is one; `setup check` lists every error; the board options
//! (`--port`, `--emulated`) appear only on the commands that use a board, and still work before
//! or after the subcommand and from GANTRY_PORT.

mod serial_support;

use serial_support::*;
use std::process::Command;
use std::time::Duration;

const T: Duration = Duration::from_secs(30);

#[test]
fn a_hold_on_an_idle_board_says_there_was_nothing_to_hold() {
    let dir = Dir::new("hold-nothing");
    let emu = Emulator::start(&dir, None);
    let out = gantry(&["--port", emu.port(), "hold"], T);
    // Exit 0 as `gantry unlock` without an alarm: the machine stands, as asked.
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    assert!(
        out.stderr
            .contains("gantry: nothing to hold: the board is Idle, nothing moves"),
        "{out:?}"
    );
}

#[test]
fn the_status_names_the_active_inputs() {
    let dir = Dir::new("inputs-named");
    let emu = Emulator::start(&dir, None);
    let out = gantry(&["--port", emu.port(), "status"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("\ninputs:    none active\n"), "{out:?}");
    // The names are the setup's and the console's (one table; bit 31 is the plasma torch
    // height controller's down input).
    let names = host_sender::present::input_names(1 << 16 | 1 << 28 | 1 << 31);
    assert_eq!(names, ["x_min", "probe", "thc_down"]);
}

#[test]
fn a_spindle_speed_beyond_the_range_is_warned_and_underruns_are_logged_only_when_there_are_any() {
    let dir = Dir::new("rpm-underruns");
    let emu = Emulator::start(&dir, None);
    // One long move: nothing can run dry mid-job.
    let job = dir.file("s.ngc", "G21 G91\nM3 S30000\nG1 X2 F600\nM5\nM30\n");
    let out = gantry(&["--port", emu.port(), "stream", job.to_str().unwrap()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains(&format!(
            "{}:2: warning: S30000 is above the spindle's rpm_range [0, 24000]: the board clamps it to 24000 rpm",
            job.display()
        )),
        "{out:?}"
    );
    let check = gantry(&["--port", emu.port(), "check", job.to_str().unwrap()], T);
    assert_eq!(check.code, Some(0), "{check:?}");
    assert!(
        check.stdout.contains(":2: warning: S30000 is above"),
        "{check:?}"
    );
    assert!(
        emu.wait_log(T, |l| l.contains(" Idle line 5")),
        "{}",
        emu.log()
    );
    // Before: `emulate: underruns 0` after every state line.
    assert!(!emu.log().contains("emulate: underruns"), "{}", emu.log());
}

#[test]
fn setup_check_lists_every_error_with_its_line() {
    let dir = Dir::new("setup-check-all");
    let file = dir.file(
        "bad.toml",
        "[axis.X]\nmax_rate = -5.0\nsteps_per_mm = 640.0\n\n[spindle]\nrpm_range = [5000, 100]\n\n[jog]\nno_such_key = 1\n",
    );
    let out = gantry(&["setup", "check", file.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    let f = file.display();
    // A bad value, an unknown key, a rule between settings (low above high) and an unknown key
    // in another section: all four, each with its line.
    for (line, key) in [
        (2, "max_rate"),
        (3, "steps_per_mm"),
        (6, "rpm_range"),
        (9, "no_such_key"),
    ] {
        assert!(
            out.stderr.contains(&format!("{f}:{line}: error: ")) && out.stderr.contains(key),
            "line {line} ({key}): {out:?}"
        );
    }
    assert!(out.stderr.contains(&format!("{f}: 4 errors")), "{out:?}");
    let good = dir.file("good.toml", "[axis.X]\nmax_rate = 5000.0\n");
    let out = gantry(&["setup", "check", good.to_str().unwrap()], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("setup is valid"), "{out:?}");
}

#[test]
fn board_options_show_only_on_commands_that_use_a_board() {
    let help = |args: &[&str]| {
        let out = gantry(args, T);
        assert_eq!(out.code, Some(0), "{args:?}: {out:?}");
        out.stdout
    };
    for offline in [
        &["emulate", "--help"][..],
        &["setup", "check", "--help"],
        &["setup", "docs", "--help"],
    ] {
        let text = help(offline);
        assert!(
            !text.contains("--port <") && !text.contains("--emulated"),
            "{offline:?}:\n{text}"
        );
    }
    for online in [
        &["status", "--help"][..],
        &["stream", "--help"],
        &["check", "--help"],
        &["setup", "push", "--help"],
    ] {
        assert!(help(online).contains("--port"), "{online:?}");
    }
    assert!(help(&["serve", "--help"]).contains("--port"));
    // Before the subcommand, after it, and from GANTRY_PORT: the same board.
    let dir = Dir::new("port-places");
    let emu = Emulator::start(&dir, None);
    for args in [
        &["--port", emu.port(), "status"][..],
        &["status", "--port", emu.port()],
    ] {
        let out = gantry(args, T);
        assert_eq!(out.code, Some(0), "{args:?}: {out:?}");
        assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    }
    let mut cmd = Command::new(GANTRY);
    cmd.arg("status").env("GANTRY_PORT", emu.port());
    let mut r = spawn_cmd(&mut cmd);
    drop(r.stdin.take());
    let out = r.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
}
