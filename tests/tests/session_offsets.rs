//! The board keeps what the operator set. Through the `gantry` binary against
//! `gantry emulate --pty --state F` (its flash): a zero set with `G10 L20` survives a power cut
//! of the board and is shown by `setup pull`; a setup pushed to it is in its flash afterwards.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(20);

#[test]
fn a_zero_set_with_g10_survives_a_restart_and_setup_pull_shows_it() {
    let dir = Dir::new("offsets-restart");
    let mut emu = Emulator::start(&dir, None);
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "mdi",
            "G21 G90 G0 X10 Y5",
            "G10 L20 P1 X0 Y0",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(Duration::from_secs(5), |l| l.contains("setup saved")),
        "{}",
        emu.log()
    );
    // A power cut, then the board starts again from its flash.
    emu.kill();
    let emu = Emulator::start(&dir, None);
    let out = gantry(&["--port", emu.port(), "mdi", "G90 G54 G0 X1 Y1"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(emu.wait_log(Duration::from_secs(5), |l| l.contains("Idle line")));
    let (steps, _) = emu.idle_counts(Duration::from_secs(5));
    // Default 640 steps/mm; the emulated board powers up at 0.
    assert_eq!(steps.trim(), "X 7040 Y 3840 Z 0", "{}", emu.log());
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [10.0, 5.0, 0.0]"), "{text}");
}

/// A setup pushed to `gantry emulate --state F` is in its flash: the board
/// restarted from F has it.
#[test]
fn a_pushed_setup_is_saved_and_a_restarted_emulator_comes_back_with_it() {
    let dir = Dir::new("push-saved");
    let mut emu = Emulator::start(&dir, None);
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("max_rate = 3000.0"), "{text}");
    let edited = dir.file(
        "edited.toml",
        &text.replacen("max_rate = 3000.0", "max_rate = 2500.0", 1),
    );
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "setup",
            "push",
            edited.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(Duration::from_secs(5), |l| l.contains("setup saved")),
        "{}",
        emu.log()
    );
    emu.kill();
    let emu = Emulator::start(&dir, None);
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("max_rate = 2500.0"), "{text}");
}

/// `setup push` of a file that does not name the work offsets keeps the ones the
/// operator set on the board; a file that names them sets them.
#[test]
fn a_setup_push_keeps_the_boards_offsets_unless_the_file_names_them() {
    let dir = Dir::new("push-keeps-offsets");
    let emu = Emulator::start(&dir, None);
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "mdi",
            "G21 G90 G0 X10 Y5",
            "G10 L20 P1 X0 Y0",
            "G28.1",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let plain = dir.file("plain.toml", "[axis.X]\nmax_rate = 2500.0\n");
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "setup",
            "push",
            plain.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("max_rate = 2500.0"), "{text}");
    assert!(text.contains("\"G54\" = [10.0, 5.0, 0.0]"), "{text}");
    assert!(text.contains("g28_home = [10.0, 5.0, 0.0]"), "{text}");
    // Named in the file: set.
    let named = dir.file("named.toml", "[work_offsets]\n\"G54\" = [1.0, 2.0, 3.0]\n");
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "setup",
            "push",
            named.to_str().unwrap(),
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [1.0, 2.0, 3.0]"), "{text}");
    assert!(text.contains("g28_home = [10.0, 5.0, 0.0]"), "{text}");
}

/// Under `gantry serve`, which answers setup requests from its copy of the board's setup, a zero
/// set by a job is in the setup the next command reads (serve read it again after the job).
#[test]
fn setup_pull_through_serve_shows_a_zero_set_by_a_job() {
    let dir = Dir::new("offsets-serve");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(T, || server.stderr().contains("is served on")));
    // serve has read the setup before this job.
    let out = gantry(&["--port", port, "setup", "pull"], T);
    assert!(out.stdout.contains("\"G54\" = [0.0, 0.0, 0.0]"), "{out:?}");
    let out = gantry(
        &[
            "--port",
            port,
            "mdi",
            "G21 G90 G0 X10 Y5",
            "G10 L20 P1 X0 Y0",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let out = gantry(&["--port", port, "setup", "pull"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("\"G54\" = [10.0, 5.0, 0.0]"), "{out:?}");
}

/// `gantry emulate --setup F --state S` started again with the same command line: F's machine
/// settings apply (an edit of F between the runs is taken), the work offsets and G28 position the
/// operator set stay, as `setup push F` keeps them, and the ready line names what it kept. A fresh
/// S takes everything from F; an offset F names is F's.
#[test]
fn a_restart_with_the_same_setup_file_keeps_the_work_zero() {
    let dir = Dir::new("restart-keeps-zero");
    let setup = dir.file("router.toml", "[axis.X]\nmax_rate = 2800.0\n");
    let mut emu = Emulator::start(&dir, Some(&setup));
    assert!(emu.log().contains("(new)"), "{}", emu.log());
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "mdi",
            "G21 G90 G0 X10 Y5",
            "G10 L20 P1 X0 Y0",
            "G28.1",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(Duration::from_secs(10), |l| l.contains("setup saved")),
        "{}",
        emu.log()
    );
    // Ctrl-C, the file edited, the same command line again.
    emu.kill_gently();
    std::fs::write(&setup, "[axis.X]\nmax_rate = 2700.0\n").unwrap();
    let mut emu = Emulator::start(&dir, Some(&setup));
    let log = emu.log();
    assert!(
        log.contains(&format!(
            "machine settings from {}, stored in {} (kept from there: work offsets G54, G28 position)",
            setup.display(),
            dir.0.join("state.toml").display()
        )),
        "{log}"
    );
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [10.0, 5.0, 0.0]"), "{text}");
    assert!(text.contains("g28_home = [10.0, 5.0, 0.0]"), "{text}");
    assert!(text.contains("max_rate = 2700.0"), "{text}");
    // Work X1 Y1 is machine X11 Y6: 7040 and 3840 steps at the default 640 steps/mm (the
    // emulated board's machine position powers up at 0, as in the test above).
    let out = gantry(&["--port", emu.port(), "mdi", "G90 G54 G0 X1 Y1"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(T, |l| l.contains("Idle line 1 steps X 7040 Y 3840 Z 0")),
        "{}",
        emu.log()
    );
    emu.kill_gently();
    // A file that names G54 sets it over the stored one.
    std::fs::write(
        &setup,
        "[axis.X]\nmax_rate = 2700.0\n[work_offsets]\n\"G54\" = [1.0, 2.0, 3.0]\n",
    )
    .unwrap();
    let mut emu = Emulator::start(&dir, Some(&setup));
    assert!(
        emu.log().contains("(kept from there: G28 position)"),
        "{}",
        emu.log()
    );
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [1.0, 2.0, 3.0]"), "{text}");
    emu.kill_gently();
    // A fresh state file takes everything from the file.
    std::fs::remove_file(dir.0.join("state.toml")).unwrap();
    std::fs::write(&setup, "[axis.X]\nmax_rate = 2700.0\n").unwrap();
    let emu = Emulator::start(&dir, Some(&setup));
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [0.0, 0.0, 0.0]"), "{text}");
    assert!(text.contains("g28_home = [0.0, 0.0, 0.0]"), "{text}");
}
