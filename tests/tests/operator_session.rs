//! One whole session of a machinist, through the `gantry` binary against
//! `gantry emulate --pty` (its own process, with switches and a state file), as docs/ports.md
//! ("A session from power-up to shutdown") describes it: power up, home, zero with `G10 L20`,
//! restart the board (the offsets are kept), a program with a typo on line 5 (refused, no step
//! taken), a short-segment job under `serve` held, overridden, resumed and aborted from other
//! processes, a restart with `--from-line` past a tool change (XY before Z, the prompt answered),
//! ending with the same step counts as an uninterrupted run of the same program.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);
const T: Duration = Duration::from_secs(30);

/// A 600 × 400 × 100 mm router: X, Y, Z with normally-closed switches at both ends of each,
/// homed X then Y to their min switches, Z to its max switch, fast enough for a test.
fn router(dir: &Dir) -> std::path::PathBuf {
    let base = gantry(&["setup", "show"], T).stdout;
    let mut text = base
        .replacen(
            "active_low = []",
            r#"active_low = ["x_min", "x_max", "y_min", "y_max", "z_min", "z_max"]"#,
            1,
        )
        .replacen("limits_min = []", r#"limits_min = ["X", "Y", "Z"]"#, 1)
        .replacen("limits_max = []", r#"limits_max = ["X", "Y", "Z"]"#, 1);
    for (axis, prio, seek) in [("X", 2, "low"), ("Y", 3, "low"), ("Z", 1, "high")] {
        text = text.replacen(
            &format!("[homing.axis.{axis}]\npriority = 0   # 0 = not homed\nseek = \"low\"\nseek_rate = 2000.0"),
            &format!("[homing.axis.{axis}]\npriority = {prio}\nseek = \"{seek}\"\nseek_rate = 3000.0"),
            1,
        );
    }
    assert_eq!(text.matches("seek_rate = 3000.0").count(), 3, "{text}");
    dir.file("router.toml", &text)
}

/// The part: rapid over, plunge, a square of short segments, retract, a tool change, a second
/// square at another depth.
fn program() -> String {
    let mut p = String::from("G21 G90 G54\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F600\n");
    for i in 1..=20 {
        p.push_str(&format!("G1 X{}\n", 10 + i));
    }
    p.push_str("G1 Y20\nG1 X10\nG1 Y10\nG0 Z5\nT2 M6\nG0 X40 Y10\nG1 Z-2 F600\n");
    for i in 1..=20 {
        p.push_str(&format!("G1 X{}\n", 40 + i));
    }
    p.push_str("G1 Y20\nG1 X40\nG1 Y10\nG0 Z5\nM30\n");
    p
}

fn steps(emu: &Emulator) -> String {
    std::thread::sleep(Duration::from_millis(300));
    emu.last_counts().0.trim().to_owned()
}

#[test]
fn a_machinists_session_from_power_up_to_a_restart_from_a_line() {
    let dir = Dir::new("operator-session");
    let machine = router(&dir);
    // Power up where the machine was left: 20 mm inside every min end, Z 20 mm below the top.
    std::fs::write(
        dir.0.join("state.toml.position"),
        "-280000000 -180000000 80000000\n",
    )
    .unwrap();
    let mut emu = Emulator::start(&dir, Some(&machine));

    // Home: the command returns once homing has ended, every axis homed.
    let out = gantry(&["--port", emu.port(), "home"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let status = gantry(&["--port", emu.port(), "status"], T);
    assert!(status.stdout.contains("Idle"), "{status:?}");
    assert!(
        status.stdout.contains("XYZ") || status.stdout.contains("X Y Z"),
        "{status:?}"
    );

    // Zero G54 at machine X 100 Y 50 Z -20 (the top of the stock).
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "mdi",
            "G53 G0 X100 Y50",
            "G53 G0 Z-20",
            "G10 L20 P1 X0 Y0 Z0",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(5 * S, |l| l.contains("setup saved")),
        "{}",
        emu.log()
    );

    // The board restarts (power cut): the offsets are still there.
    emu.kill();
    let emu = Emulator::start(&dir, None);
    let text = pulled_setup(&dir, emu.port());
    assert!(text.contains("\"G54\" = [100.0, 50.0, -20.0]"), "{text}");
    // Homing again after the power cut (the position was lost).
    let out = gantry(&["--port", emu.port(), "home"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let homed = steps(&emu);

    // A typo on line 5: refused before the first move.
    let typo = dir.file(
        "typo.ngc",
        "G21 G90\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F600\nG1 X20 Q1\nM30\n",
    );
    let out = gantry(&["--port", emu.port(), "stream", typo.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("typo.ngc:5: error"), "{out:?}");
    assert_eq!(steps(&emu), homed, "a step was taken");

    // The reference: the program uninterrupted (Enter at its tool change).
    let part = dir.file("part.ngc", &program());
    let mut run = spawn(&["--port", emu.port(), "stream", part.to_str().unwrap()]);
    assert!(
        wait_for(20 * S, || (run.stdout() + &run.stderr())
            .contains("tool change: put tool 2")),
        "{} {}",
        run.stdout(),
        run.stderr()
    );
    run.answer("");
    let out = run.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let reference = steps(&emu);

    // Under serve: the job held, overridden, resumed and aborted from other processes.
    let server = spawn(&["serve", "--port", emu.port()]);
    assert!(wait_for(10 * S, || (server.stderr() + &server.stdout())
        .contains("served on")));
    // A short-segment job keeps the board's buffers full.
    let segments = dir.file(
        "segments.ngc",
        &format!("G21 G90 G54\nG0 Z5\n{}", zigzag(2000)),
    );
    let seen = emu.log().matches(" Run line").count();
    let job = spawn(&["--port", emu.port(), "stream", segments.to_str().unwrap()]);
    assert!(emu.wait_log(10 * S, |l| l.matches(" Run line").count() > seen));
    std::thread::sleep(S);
    for (args, state) in [
        (vec!["hold"], "Hold"),
        (vec!["override", "--feed", "150"], "Hold"),
        (vec!["resume"], "Run"),
        (vec!["abort"], "Idle"),
    ] {
        let mut a = vec!["--port", emu.port()];
        a.extend(args.iter().copied());
        let out = gantry(&a, 10 * S);
        assert_eq!(out.code, Some(0), "{args:?}: {out:?}");
        assert!(out.took < 3 * S, "{args:?} took {:?}", out.took);
        let status = gantry(&["--port", emu.port(), "status"], 10 * S);
        assert!(
            wait_for(3 * S, || gantry(&["--port", emu.port(), "status"], 10 * S)
                .stdout
                .contains(state)),
            "{args:?}: {status:?}"
        );
    }
    let out = job.wait(T);
    assert_eq!(out.code, Some(1), "{out:?}");
    let resume = out
        .stdout
        .lines()
        .find_map(|l| l.split("--from-line ").nth(1))
        .expect("the abort names the line to resume from")
        .trim()
        .to_owned();
    let line: u32 = resume.parse().unwrap();
    assert!(line > 1, "{out:?}");

    // Restart from a line past the tool change: the preamble's M6 prompts, XY at the clearance
    // before Z comes down, and the job ends where the uninterrupted run ended.
    let from = program().lines().position(|l| l == "G1 X45").unwrap() + 1;
    let mut run = spawn(&[
        "--port",
        emu.port(),
        "stream",
        part.to_str().unwrap(),
        "--from-line",
        &from.to_string(),
    ]);
    assert!(
        wait_for(20 * S, || (run.stdout() + &run.stderr())
            .contains("resume preamble: tool change: put tool 2")),
        "{} {}",
        run.stdout(),
        run.stderr()
    );
    run.answer("");
    let out = run.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let pre: Vec<&str> = out
        .stdout
        .lines()
        .skip_while(|l| !l.starts_with("resuming at line"))
        .skip(1)
        .take_while(|l| l.starts_with("    "))
        .map(str::trim)
        .collect();
    let up = pre
        .iter()
        .position(|l| *l == "G53 G0 Z-15")
        .expect("up to the clearance");
    let xy = pre
        .iter()
        .position(|l| l.starts_with("G53 G0 X144 Y60"))
        .unwrap();
    let down = pre
        .iter()
        .position(|l| l.starts_with("G53 G1 Z-22"))
        .unwrap();
    assert!(up < xy && xy < down, "{pre:?}");
    assert_eq!(steps(&emu), reference);
    drop(server);
}
