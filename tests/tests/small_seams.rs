//! Issue 25 item 16, through the binary against `gantry emulate --pty`: `resume` with nothing to
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
        assert_eq!(String::from_utf8_lossy(&out.stderr), "", "{args:?}");
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
