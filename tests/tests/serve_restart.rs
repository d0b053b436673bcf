//! Issue 25 item 14: a board restart mid-job under `gantry serve`. The stream ends with a report
//! that says what happened and the commands to resume (not "Connection reset by peer"), and
//! serve keeps the port for the next command.

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
    // serve is still there for the next command.
    let status = gantry(&["--port", emu.port(), "status"], 10 * S);
    assert_eq!(status.code, Some(0), "{status:?}");
}
