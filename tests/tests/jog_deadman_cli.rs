//! The board's dead-man for continuous jogs, through the binary as users run it: the emulated
//! board as its own process behind a pty (`gantry emulate --pty`), `gantry jog X --continuous +`
//! in another process, which is then killed (-9) or stopped (SIGSTOP), directly on the port and
//! through `gantry serve`. The board stops the jog by itself.
//!
//! Times are the board's: the emulator logs every state change with its clock ("emulate: 1.234 s
//! Jog line 0 steps …"). The board's clock never runs ahead of the wall clock, and it catches up
//! a lag of less than 0.5 s at most, so "the jog lasted on the board no longer than the wall time
//! from starting the command to killing it, plus 0.5 s" holds however loaded the machine is (the
//! command's own start-up, before its jog reaches the board, adds to the margin). Without the
//! dead-man a stopped command's jog ran until the host-loss timeout (1 s) or the travel's end.

mod serial_support;

use serial_support::*;
use std::time::{Duration, Instant};

const T: Duration = Duration::from_secs(20);
/// 600 mm/min = 10 mm/s: 50 ms and 0.25 mm to stop at the default 200 mm/s².
const FEED: &str = "600";
const STEPS_PER_MM: f64 = 640.0;

/// (board seconds, X steps) of the emulator's first state line for `state` after line `from`.
fn state_line(emu: &Emulator, state: &str, from: usize) -> Option<(usize, f64, i64)> {
    let log = emu.log();
    log.lines()
        .enumerate()
        .skip(from)
        .find(|(_, l)| l.starts_with("emulate: ") && l.contains(&format!(" s {state} line ")))
        .map(|(i, l)| {
            let secs: f64 = l["emulate: ".len()..]
                .split(' ')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            let steps = l.split(" steps ").nth(1).unwrap();
            // "steps X 123 Y 0 Z 0 pulses …"
            let x: i64 = steps.split(' ').nth(1).unwrap().parse().unwrap();
            (i, secs, x)
        })
}

/// Starts `gantry jog X --continuous + --port P` and waits (bounded) until the board jogs;
/// returns the command, when it was started and the Jog line (index, board s).
fn start_jog(emu: &Emulator, port: &str) -> (Running, Instant, usize, f64) {
    let started = Instant::now();
    let jog = spawn(&[
        "--port",
        port,
        "jog",
        "X",
        "--continuous",
        "+",
        "--feed",
        FEED,
    ]);
    assert!(
        emu.wait_log(T, |_| state_line(emu, "Jog", 0).is_some()),
        "the jog did not start: {}\n{}",
        jog.stderr(),
        emu.log()
    );
    let (i, t0, _) = state_line(emu, "Jog", 0).unwrap();
    // Let it run a while at speed, while it keeps its jog alive (a command starved of the CPU
    // for 250 ms on a loaded machine is stopped by the board already: the checks below hold
    // all the same).
    wait_for(Duration::from_millis(800), || {
        state_line(emu, "Idle", i + 1).is_some()
    });
    (jog, started, i, t0)
}

/// Waits for the board's Idle after the Jog line `from` and checks the jog's length on the
/// board against the wall time from the command's start to `stopped`; returns X at rest (steps).
fn stopped_in_time(
    emu: &Emulator,
    from: usize,
    t0: f64,
    started: Instant,
    stopped: Instant,
) -> i64 {
    assert!(
        emu.wait_log(T, |_| state_line(emu, "Idle", from + 1).is_some()),
        "the jog never stopped: {}",
        emu.log()
    );
    let (_, t1, x) = state_line(emu, "Idle", from + 1).unwrap();
    let wall = (stopped - started).as_secs_f64();
    println!(
        "jog on the board {:.3} s, command stopped {wall:.3} s after its start, X at rest {x} steps",
        t1 - t0
    );
    assert!(
        t1 - t0 <= wall + 0.5,
        "the jog ran {:.3} s on the board; the command was stopped {wall:.3} s after it started\n{}",
        t1 - t0,
        emu.log()
    );
    assert!(x > 0, "at X {x} steps");
    x
}

/// The board at rest where the Idle line says, and nothing moved since.
fn still_at(port: &str, x_steps: i64) {
    let out = gantry(&["--port", port, "status"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    let machine = out
        .stdout
        .lines()
        .find(|l| l.starts_with("machine:"))
        .unwrap()
        .to_owned();
    // "machine:   X 10.538  Y 0.000  Z 0.000" (to the µm, rounded)
    let x: f64 = machine.split_whitespace().nth(2).unwrap().parse().unwrap();
    let want = x_steps as f64 / STEPS_PER_MM;
    assert!((x - want).abs() < 0.000_6, "{machine} (expected X {want})");
}

#[test]
fn a_killed_continuous_jog_stops_on_the_board() {
    let dir = Dir::new("deadman-kill");
    let emu = Emulator::start(&dir, None);
    let (jog, started, i, t0) = start_jog(&emu, emu.port());
    jog.signal(nix::sys::signal::Signal::SIGKILL);
    let killed = Instant::now();
    let x = stopped_in_time(&emu, i, t0, started, killed);
    let _ = jog.wait(T);
    still_at(emu.port(), x);
}

#[test]
fn a_stopped_continuous_jog_stops_on_the_board() {
    let dir = Dir::new("deadman-stop");
    let emu = Emulator::start(&dir, None);
    let (jog, started, i, t0) = start_jog(&emu, emu.port());
    jog.signal(nix::sys::signal::Signal::SIGSTOP);
    let stopped = Instant::now();
    let x = stopped_in_time(&emu, i, t0, started, stopped);
    // Nothing moves while the command stays stopped (its link is silent: the board holds
    // nothing, it is idle).
    let (_, _, again) = state_line(&emu, "Idle", i + 1).unwrap();
    assert_eq!(again, x);
    jog.signal(nix::sys::signal::Signal::SIGCONT);
    let out = jog.wait(T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stdout
            .contains("the board stopped the jog: no keepalive from this command for 250 ms"),
        "{out:?}"
    );
    assert!(out.stdout.contains("state:     Idle"), "{out:?}");
    still_at(emu.port(), x);
}

#[test]
fn under_serve_a_killed_jog_client_stops() {
    let dir = Dir::new("deadman-serve");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(T, || server.stderr().contains("is served on")));
    let (jog, started, i, t0) = start_jog(&emu, port);
    jog.signal(nix::sys::signal::Signal::SIGKILL);
    let killed = Instant::now();
    let x = stopped_in_time(&emu, i, t0, started, killed);
    let _ = jog.wait(T);
    // serve stayed connected all along: the board alone stopped the jog.
    assert!(!emu.log().contains("host closed the port"), "{}", emu.log());
    still_at(port, x);
}

#[test]
fn a_timed_continuous_jog_and_a_stepped_jog_run_as_asked() {
    let dir = Dir::new("deadman-timed");
    let emu = Emulator::start(&dir, None);
    // 1.5 s at 10 mm/s (six times the dead-man's time): kept alive all along, stopped by --for.
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "jog",
            "X",
            "--continuous",
            "+",
            "--feed",
            FEED,
            "--for",
            "1.5",
        ],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(!out.stdout.contains("no keepalive"), "{out:?}");
    let (i, t0, _) = state_line(&emu, "Jog", 0).unwrap();
    let (_, t1, x) = state_line(&emu, "Idle", i + 1).unwrap();
    assert!(
        t1 - t0 >= 1.5,
        "the jog lasted {:.3} s on the board",
        t1 - t0
    );
    assert!(x as f64 / STEPS_PER_MM >= 14.0, "at X {x} steps");
    // A stepped jog of 12 mm (1.2 s, no keepalive) runs its whole distance, to the step.
    let before = emu.log().lines().count();
    let out = gantry(
        &["--port", emu.port(), "jog", "X", "-12", "--feed", FEED],
        T,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let (j, t2, _) = state_line(&emu, "Jog", before).expect("a Jog line");
    let (_, t3, back) = state_line(&emu, "Idle", j + 1).expect("an Idle line");
    println!(
        "stepped jog: {:.3} s on the board, X {x} -> {back} steps",
        t3 - t2
    );
    assert_eq!(back, x - 12 * 640);
    still_at(emu.port(), x - 12 * 640);
}
