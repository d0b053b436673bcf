//! Run-from-line inside O-word control flow, through the binary against `gantry emulate --pty`:
//! a line inside a loop is refused with the loop's first line named, and the resume hint of a job
//! aborted inside the loop is a command (with the `--port` given) that runs.

mod serial_support;

use nix::sys::signal::Signal;
use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(60);

/// Two turns of a 20 mm there-and-back at F1200 (2 s a turn) inside `o100 while` (lines 4-8).
const SIGN: &str = "G21 G90 G94\nG0 X0 Y0\n#1 = 0\no100 while [#1 LT 2]\n  G1 X20 F1200\n  G1 X0\n  #1 = [#1 + 1]\no100 endwhile\nG0 Y5\nM30\n";

#[test]
fn a_line_inside_a_loop_names_the_loops_start_and_the_abort_hint_runs() {
    let dir = Dir::new("resume-oword");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let job = dir.file("sign.ngc", SIGN);
    let job = job.to_str().unwrap();
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();

    // The refusal names the line that works.
    let out = gantry(&["--port", port, "stream", job, "--from-line", "6"], T);
    assert_ne!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains("cannot resume from line 6: it is inside the O-word block that starts at line 4 (`o100 while [#1 LT 2]`)")
            && out.stderr.contains("(--from-line 4)"),
        "{out:?}"
    );
    assert!(
        !emu.log().contains(" Run line"),
        "nothing ran: {}",
        emu.log()
    );

    // Abort inside the loop (Ctrl-C, then "y").
    let mut sender = spawn(&["--port", port, "stream", job]);
    assert!(
        emu.wait_log(T, |l| l.contains(" Run line")),
        "{}",
        emu.log()
    );
    sender.signal(Signal::SIGINT);
    assert!(wait_for(T, || sender.stderr().contains("abort the job?")));
    sender.answer("y");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("job aborted"), "{out:?}");
    let hint = out
        .stdout
        .lines()
        .find_map(|l| l.strip_prefix("resume:   "))
        .unwrap_or_else(|| panic!("no resume hint: {out:?}"));
    let command = hint.split("   (").next().unwrap();
    assert_eq!(
        command,
        format!("gantry --port {port} stream {job} --from-line 4"),
        "{out:?}"
    );
    assert!(
        hint.contains("is inside the O-word block that starts at line 4"),
        "{hint}"
    );

    // The hint runs: the loop again from its start, to the end of the program.
    let args: Vec<&str> = command.split_whitespace().skip(1).collect();
    let out = gantry(&args, T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.contains("job done: last line 10 of 10"),
        "{out:?}"
    );
    // Y 5 at 640 steps/mm, X back at 0.
    assert!(
        emu.wait_log(T, |l| l.contains("Idle line 10 steps X 0 Y 3200 Z 0")),
        "{}",
        emu.log()
    );
}
