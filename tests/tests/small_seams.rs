//! Small seams, through the binary against `gantry emulate --pty`: `resume` with nothing to
//! resume says so and fails; a jog shorter than one step says why nothing moved; `setup show`
//! shows the board's setup; `simulate`/`check --canon` into `head` end quietly; the emulator's
//! ready line says where its setup came from; the progress bar never draws over the Ctrl-C
//! question.

mod serial_support;

use serial_support::*;
use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const T: Duration = Duration::from_secs(20);
const S: Duration = Duration::from_secs(1);

#[test]
fn resume_with_nothing_to_resume_fails_and_says_why() {
    let dir = Dir::new("resume-nothing");
    let emu = Emulator::start(&dir, None);
    let out = gantry(&["--port", emu.port(), "resume"], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    assert!(
        out.stdout.contains("nothing to resume: the board is Idle"),
        "{out:?}"
    );
}

#[test]
fn a_jog_shorter_than_one_step_says_nothing_moved() {
    let dir = Dir::new("jog-one-nm");
    let emu = Emulator::start(&dir, None);
    // The default X: 0.0025 mm per step.
    let out = gantry(&["--port", emu.port(), "jog", "X", "0.000001"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout
            .contains("no motion: 0.000001 mm is less than one step of X (0.0015625 mm)"),
        "{out:?}"
    );
    assert!(!out.stdout.contains("did not start"), "{out:?}");
    // One step's worth moves and says nothing of it.
    let out = gantry(&["--port", emu.port(), "jog", "X", "0.0025"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("machine:   X 0.003"), "{out:?}");
    assert!(!out.stdout.contains("no motion"), "{out:?}");
}

#[test]
fn setup_show_shows_the_boards_setup() {
    let dir = Dir::new("setup-show-board");
    let setup = dir.file("s.toml", "[axis.X]\nmax_rate = 4321.0\n");
    let emu = Emulator::start(&dir, Some(&setup));
    assert!(emu.log().contains(&format!(
        "setup from {}, stored in {}",
        setup.display(),
        dir.0.join("state.toml").display()
    )));
    let out = gantry(&["--port", emu.port(), "setup", "show"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.starts_with(&format!(
            "# Effective values of the board's setup on {}",
            emu.port()
        )),
        "{out:?}"
    );
    assert!(out.stdout.contains("max_rate = 4321.0"), "{out:?}");
    let out = gantry(&["--port", emu.port(), "setup", "show", "--defaults"], T);
    assert!(!out.stdout.contains("max_rate = 4321.0"), "{out:?}");
    let out = gantry(&["setup", "show"], T);
    assert!(
        out.stdout
            .starts_with("# Effective values of the built-in defaults (no board"),
        "{out:?}"
    );
}

#[test]
fn output_into_head_ends_quietly() {
    let dir = Dir::new("into-head");
    let mut text = String::from("G21 G90 G1 F1000\n");
    for i in 0..20_000 {
        text.push_str(&format!("G1 X{} Y{}\n", i % 100, i % 7));
    }
    let prog = dir.file("long.ngc", &text);
    for args in [
        vec!["simulate", prog.to_str().unwrap()],
        vec!["check", "--canon", prog.to_str().unwrap()],
    ] {
        let mut child = Command::new(GANTRY)
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Read one line, then close the pipe, as `head -1` does.
        let mut stdout = child.stdout.take().unwrap();
        let mut first = [0u8; 64];
        stdout.read_exact(&mut first).unwrap();
        drop(stdout);
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(141), "{args:?}");
        // Only the line that says which machine the program is measured against (no panic,
        // no "Broken pipe" report).
        let stderr = String::from_utf8_lossy(&out.stderr);
        let said: Vec<&str> = stderr.lines().collect();
        assert_eq!(said.len(), 1, "{args:?}: {stderr}");
        assert!(
            said[0].starts_with(&format!("gantry {}: built-in defaults", args[0])),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn the_progress_bar_never_draws_over_the_ctrl_c_question() {
    let dir = Dir::new("ctrl-c-question");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let job = dir.file("job.ngc", &zigzag(3000));
    // `script` gives the sender a terminal: the progress bar draws, and Ctrl-C typed on it is
    // a SIGINT.
    let cmd = format!("{GANTRY} --port {} stream {}", emu.port(), job.display());
    let mut child = Command::new("script")
        .args(["-qfec", &cmd, "/dev/null"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::<u8>::new()));
    let reader = {
        let seen = seen.clone();
        let mut out = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = out.read(&mut buf) {
                if n == 0 {
                    break;
                }
                seen.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        })
    };
    let text = || String::from_utf8_lossy(&seen.lock().unwrap()).into_owned();
    assert!(
        wait_for(T, || text().contains(" line ") && text().contains("Run")),
        "no progress bar: {}",
        text()
    );
    stdin.write_all(b"\x03").unwrap();
    const QUESTION: &str = "feed hold: abort the job? [y/N]";
    assert!(wait_for(T, || text().contains(QUESTION)), "{}", text());
    // The bar keeps being updated while the machine decelerates and stands; none of it may
    // reach the terminal until the question is answered.
    std::thread::sleep(Duration::from_millis(1500));
    let asked = text();
    let after = &asked[asked.find(QUESTION).unwrap() + QUESTION.len()..];
    assert!(
        !after.contains(" line "),
        "the bar drew over the question: {after:?}"
    );
    stdin.write_all(b"y\n").unwrap();
    let start = Instant::now();
    assert!(wait_for(T, || text().contains("job aborted")), "{}", text());
    assert!(start.elapsed() < T);
    drop(stdin);
    let _ = child.wait();
    let _ = reader.join();
}

#[test]
fn check_and_the_board_give_the_same_recursion_error() {
    let dir = Dir::new("recursion");
    let emu = Emulator::start(&dir, None);
    for (name, text, line) in [
        (
            "oword.ngc",
            "G21 G90\nO1 sub\nG0 X1\nO1 call\nO1 endsub\nO1 call\nM30\n",
            4,
        ),
        (
            "m98.ngc",
            "G21 G90\nM98 P100\nM30\nO100\nG0 X1\nM98 P100\nM99\n",
            6,
        ),
    ] {
        let prog = dir.file(name, text);
        let p = prog.to_str().unwrap();
        let want = format!("{name}:{line}: error E603: subprogram calls nested too deeply");
        let check = gantry(&["check", p], T);
        assert_eq!(check.code, Some(1), "{check:?}");
        assert!(check.stdout.contains(&want), "{check:?}");
        let stream = gantry(&["--port", emu.port(), "stream", "--no-check", p], T);
        assert_ne!(stream.code, Some(0), "{stream:?}");
        assert!(
            (stream.stdout.clone() + &stream.stderr).contains(&want),
            "{stream:?}"
        );
    }
}

#[test]
fn continue_at_a_tool_change_with_stdin_closed_waits_for_cycle_start_and_ends() {
    use nix::sys::signal::Signal;
    let dir = Dir::new("continue-at-m6");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let job = dir.file("m6.ngc", "G21 G90 G1 F3000\nX5\nT2 M6\nG1 X10\nY4\nM30\n");
    let job = job.to_str().unwrap();
    // Other terminals reach the board while a job runs through `gantry serve`.
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    // The first sender stops at the tool change (its standard input stays open), then dies.
    let sender = spawn(&["stream", "--port", port, job]);
    assert!(
        emu.wait_log(10 * S, |l| l.contains("ToolChange T2")),
        "{}",
        emu.log()
    );
    sender.signal(Signal::SIGKILL);
    drop(sender);
    assert!(
        wait_for(5 * S, || server.stderr().contains("went away")),
        "{}",
        server.stderr()
    );
    // Taken over with standard input closed: it says what it waits for and does not hang.
    let mut taker = spawn(&["stream", "--port", port, job, "--continue"]);
    drop(taker.stdin.take());
    let waiting =
        "standard input is closed: waiting for cycle start on the machine, or `gantry resume`";
    assert!(
        wait_for(10 * S, || taker.stderr().contains(waiting)),
        "{}",
        taker.stderr()
    );
    // It waits: the take-over does not answer the tool change itself (it did: the job went on
    // with the old tool in the spindle).
    std::thread::sleep(Duration::from_millis(500));
    let (state, _) = status_line(port);
    assert_eq!(state, "state:     ToolChange", "{}", emu.log());
    // Cycle start from another terminal: the job goes on to its end.
    let out = gantry(&["--port", port, "resume"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let out = taker.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("job done: last line 6 of 6"), "{out:?}");
    assert!(emu.wait_log(5 * S, |l| l.contains("Idle line 6")));
    // 10 mm of X and 4 mm of Y at 640 steps/mm.
    assert_eq!(emu.last_counts().0, "X 6400 Y 2560 Z 0");
    drop(server);
}

/// The first line of `gantry status` and the whole output.
fn status_line(port: &str) -> (String, String) {
    let out = gantry(&["--port", port, "status"], T);
    (
        out.stdout.lines().next().unwrap_or("").to_owned(),
        out.stdout,
    )
}
