//! A board restart mid-job under `gantry serve`. The stream ends with a report
//! that says what happened and the commands to resume (not "Connection reset by peer").

mod serial_support;

use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

#[test]
fn a_board_restart_under_serve_ends_the_stream_with_the_resume_command() {
    let dir = Dir::new("serve-restart");
    let mut emu = Emulator::start(&dir, None);
    let job = dir.file("job.nc", &zigzag(400));
    let server = spawn(&["serve", "--port", emu.port()]);
    assert!(
        wait_for(10 * S, || (server.stderr() + &server.stdout())
            .contains("served on")),
        "{} {}",
        server.stdout(),
        server.stderr()
    );
    let sender = spawn(&["stream", job.to_str().unwrap(), "--port", emu.port()]);
    assert!(emu.wait_log(10 * S, |l| l.contains(" Run line")));
    std::thread::sleep(S);
    // A power cut and the board comes back at the same port.
    emu.kill();
    let emu = Emulator::start(&dir, None);
    let out = sender.wait(30 * S);
    assert_eq!(out.code, Some(1), "{out:?}");
    let text = out.stdout.clone() + &out.stderr;
    assert!(!text.contains("Connection reset"), "{out:?}");
    assert!(
        text.contains("--from-line")
            && (text.contains("board reset") || text.contains("link closed")),
        "{out:?}"
    );
    // The restarted board may have another pty name behind the same link: serve follows it, and
    // commands given the link reach the board through serve.
    assert!(
        wait_for(10 * S, || {
            let out = gantry(&["--port", emu.port(), "status"], 10 * S);
            out.code == Some(0) && out.stdout.starts_with("state:     Idle")
        }),
        "serve: {}",
        server.stderr()
    );
    assert!(
        emu.log().matches("host opened the port").count() == 1,
        "one host, serve: {}",
        emu.log()
    );
    drop(emu);
    drop(server);
}

/// A `gantry serve` whose board went away (the emulator killed) ends at once on
/// SIGTERM instead of waiting up to a minute for the port to come back.
#[test]
fn serve_whose_board_is_gone_ends_at_once_on_sigterm() {
    let dir = Dir::new("serve-sigterm");
    let mut emu = Emulator::start(&dir, None);
    let server = spawn(&["serve", "--port", emu.port()]);
    assert!(wait_for(10 * S, || (server.stderr() + &server.stdout())
        .contains("served on")));
    emu.kill();
    assert!(
        wait_for(10 * S, || server.stderr().contains("went away")),
        "{}",
        server.stderr()
    );
    let t0 = std::time::Instant::now();
    server.signal(nix::sys::signal::Signal::SIGTERM);
    let out = server.wait(10 * S);
    assert!(
        t0.elapsed() < 3 * S,
        "{:?} after SIGTERM: {out:?}",
        t0.elapsed()
    );
}
