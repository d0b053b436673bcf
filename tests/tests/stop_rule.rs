//! Only the operator releases a stop (docs/controller.md): a sender that stalls while its job is
//! held (a feed hold, an M0, an M6 tool change) finds it held when it runs again, says so and
//! waits; directly on the port and through `gantry serve`. The board is `gantry emulate --pty`
//! in its own process and the sender the `gantry` binary, stalled with SIGSTOP as a loaded laptop
//! stalls it.

mod serial_support;

use nix::sys::signal::Signal;
use serial_support::*;
use std::time::{Duration, Instant};

const S: Duration = Duration::from_secs(1);
const T: Duration = Duration::from_secs(60);

/// Fast axes; the host-loss stop (alarm 20) left at its 60 s so that a held job stays held.
const SETUP: &str =
    "[axis.X]\nmax_rate = 6000.0\naccel = 5000.0\n[axis.Y]\nmax_rate = 6000.0\naccel = 5000.0\n";

/// The emulator's last state line (its state and step counts), once it contains `what`.
fn state_line_with(emu: &Emulator, what: &str) -> String {
    assert!(
        emu.wait_log(20 * S, |l| l.lines().any(|l| l.contains(what))),
        "no `{what}` in the emulator's log:\n{}",
        emu.log()
    );
    last_state_line(emu)
}

fn last_state_line(emu: &Emulator) -> String {
    emu.log()
        .lines()
        .rev()
        .find(|l| l.contains(" steps "))
        .unwrap_or("")
        .to_owned()
}

/// Stalls `sender` for 2 s (SIGSTOP, SIGCONT), then watches the board for 3 s more: it must
/// still stand in the state line `held` (the same state and step counts, no other state line).
/// The gap is long enough for the board to count its host as lost (more than 1 s).
fn stall_and_watch(emu: &Emulator, sender: &Running, held: &str) {
    sender.signal(Signal::SIGSTOP);
    let stalled = Instant::now();
    while stalled.elapsed() < 2 * S {
        std::thread::sleep(Duration::from_millis(50));
    }
    sender.signal(Signal::SIGCONT);
    // A window in which nothing may happen: the old sender resumed within a few ms of waking.
    let woke = Instant::now();
    while woke.elapsed() < 3 * S {
        assert_eq!(
            last_state_line(emu),
            held,
            "the job left its stop after the sender's stall:\n{}\nsender: {}",
            emu.log(),
            sender.stderr()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// 100 mm of X at 600 mm/min (10 s) with spindle and flood: long enough to hold mid-cut.
const LONG_CUT: &str = "G21 G90\nM3 S12000\nM8\nG1 X100 F600\nM30\n";

#[test]
fn a_feed_hold_stays_held_when_the_sender_stalls_and_comes_back() {
    let dir = Dir::new("stop-rule-hold");
    let setup = dir.file("setup.toml", SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let job = dir.file("cut.ngc", LONG_CUT);
    let mut sender = spawn(&["--port", emu.port(), "stream", job.to_str().unwrap()]);
    // (The emulator logs state changes only: the sender's progress tells the line.)
    assert!(
        wait_for(20 * S, || sender.stdout().contains("progress: line 4/5")),
        "{}",
        sender.stdout()
    );
    // Ctrl-C: the sender holds, then asks whether to abort (its standard input stays open).
    sender.signal(Signal::SIGINT);
    let held = state_line_with(&emu, "Hold (at rest)");
    assert!(wait_for(10 * S, || sender
        .stderr()
        .contains("abort the job?")));
    stall_and_watch(&emu, &sender, &held);
    // The operator answers: abort. The job ends where it stood.
    sender.answer("y");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.contains("job aborted"), "{out:?}");
    let steps = held.split(" steps ").nth(1).unwrap();
    let steps = steps.split(" pulses ").next().unwrap();
    assert!(emu.wait_log(10 * S, |l| l.contains("Idle line 4")));
    assert_eq!(emu.last_counts().0, steps, "{}", emu.log());
}

#[test]
fn an_m0_and_an_m6_stay_stopped_when_the_sender_stalls_and_comes_back() {
    for (name, stop, at) in [
        ("m0", "M0 (look at the part)", "Hold (at rest) line 3"),
        ("m6", "T2 M6", "ToolChange T2 line 3"),
    ] {
        let dir = Dir::new(&format!("stop-rule-{name}"));
        let setup = dir.file("setup.toml", SETUP);
        let emu = Emulator::start(&dir, Some(&setup));
        let text = format!("G21 G90\nG1 X5 F3000\n{stop}\nG1 X10\nM30\n");
        let job = dir.file("stop.ngc", &text);
        let mut sender = spawn(&["--port", emu.port(), "stream", job.to_str().unwrap()]);
        let held = state_line_with(&emu, at);
        assert!(
            wait_for(10 * S, || sender.stderr().contains("line 3")),
            "{}",
            sender.stderr()
        );
        stall_and_watch(&emu, &sender, &held);
        // Enter continues it (the operator), and the job ends where an uninterrupted one does.
        sender.answer("");
        let out = sender.wait(T);
        assert_eq!(out.code, Some(0), "{name}: {out:?}");
        assert!(out.stdout.contains("job done: last line 5 of 5"), "{out:?}");
        assert!(emu.wait_log(10 * S, |l| l.contains("Idle line 5")));
        // 10 mm of X at 640 steps/mm.
        assert_eq!(
            emu.last_counts().0,
            "X 6400 Y 0 Z 0",
            "{name}: {}",
            emu.log()
        );
    }
}

#[test]
fn under_serve_a_hold_stays_held_when_the_sender_stalls_and_the_sender_says_why() {
    let dir = Dir::new("stop-rule-serve");
    let setup = dir.file("setup.toml", SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    let job = dir.file("cut.ngc", LONG_CUT);
    let sender = spawn(&["--port", port, "stream", job.to_str().unwrap()]);
    assert!(
        wait_for(20 * S, || sender.stdout().contains("progress: line 4/5")),
        "{}",
        sender.stdout()
    );
    // The hold comes from another terminal.
    let out = gantry(&["--port", port, "hold"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let held = state_line_with(&emu, "Hold (at rest)");
    assert!(
        wait_for(10 * S, || sender.stderr().contains("the job is held")),
        "{}",
        sender.stderr()
    );
    stall_and_watch(&emu, &sender, &held);
    // `gantry resume` (the operator) lets it go on to its end: 100 mm of X.
    let out = gantry(&["--port", port, "resume"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let out = sender.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("job done: last line 5 of 5"), "{out:?}");
    assert!(emu.wait_log(10 * S, |l| l.contains("Idle line 5")));
    assert_eq!(emu.last_counts().0, "X 64000 Y 0 Z 0", "{}", emu.log());
    drop(server);
}

#[test]
fn on_the_emulated_board_a_stop_nobody_can_answer_aborts_unless_through_stops() {
    let dir = Dir::new("stop-rule-emulated");
    let job = dir.file("m0.ngc", "G21 G90\nG1 X5 F3000\nM0\nG1 X10\nM30\n");
    let job = job.to_str().unwrap();
    // Standard input closed, no machine behind the emulated board: nobody can continue the M0.
    let out = gantry(&["stream", job], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stderr.contains("aborting the job"), "{out:?}");
    assert!(out.stdout.contains("job aborted: last line 3"), "{out:?}");
    assert!(out.stdout.contains("machine:  X 5.000"), "{out:?}");
    // The operator's explicit choice on the command line answers it.
    let out = gantry(&["stream", "--through-stops", job], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("job done: last line 5 of 5"), "{out:?}");
    assert!(out.stdout.contains("machine:  X 10.000"), "{out:?}");
    // Never on a machine.
    let dir2 = Dir::new("stop-rule-through-port");
    let emu = Emulator::start(&dir2, None);
    let out = gantry(&["--port", emu.port(), "stream", "--through-stops", job], T);
    assert_ne!(out.code, Some(0), "{out:?}");
    assert!(out.stderr.contains("--through-stops"), "{out:?}");
}
