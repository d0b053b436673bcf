//! `gantry serve` and the job's owner (docs/ports.md): a sender killed mid-job through the
//! server is a lost host for the board (hold, then spindle and coolant off at rest), another
//! command takes the job over and the operator resumes it; a board that stops reading for a
//! while is no lost port. And the console's Run and setup push go through the session's one
//! start check and one push path. The board is `gantry emulate --pty` in its own process.

mod serial_support;

use nix::sys::signal::Signal;
use serial_support::*;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

const S: Duration = Duration::from_secs(1);
const T: Duration = Duration::from_secs(90);

/// Fast axes; the host-loss stop (alarm 20) left at its 60 s.
const SETUP: &str =
    "[axis.X]\nmax_rate = 6000.0\naccel = 5000.0\n[axis.Y]\nmax_rate = 6000.0\naccel = 5000.0\n";

/// 30 moves of 20 mm in X at 3000 mm/min (0.4 s each) climbing 0.5 mm in Y, spindle and flood
/// on: 600 mm of X (384 000 pulses at 640 steps/mm) and 15 mm of Y (9 600), ending at X 0.
fn climb() -> String {
    let mut s = String::from("G21 G90\nM3 S12000\nM8\n");
    for i in 1..=30 {
        let x = if i % 2 == 1 { 20 } else { 0 };
        s.push_str(&format!("G1 X{x} Y{:.1} F3000\n", i as f64 * 0.5));
    }
    s.push_str("M30\n");
    s
}

fn serve(port: &str, extra: &[&str]) -> Running {
    let mut args = vec!["serve", "--port", port];
    args.extend_from_slice(extra);
    let server = spawn(&args);
    assert!(
        wait_for(10 * S, || server.stderr().contains("is served on")),
        "{}",
        server.stderr()
    );
    server
}

/// The line `gantry status` shows.
fn line_of(status: &str) -> u32 {
    status
        .lines()
        .find_map(|l| l.strip_prefix("line:"))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or(0)
}

/// `gantry status` through the server.
fn status(port: &str) -> String {
    let out = gantry(&["--port", port, "status"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    out.stdout
}

#[test]
fn a_sender_killed_under_serve_is_a_lost_host_and_a_take_over_finishes_the_job() {
    let dir = Dir::new("serve-owner-kill");
    let setup = dir.file("setup.toml", SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let server = serve(port, &[]);
    let job = dir.file("climb.ngc", &climb());
    let job = job.to_str().unwrap();
    let sender = spawn(&["--port", port, "stream", job]);
    assert!(
        wait_for(20 * S, || line_of(&status(port)) >= 10),
        "{}",
        emu.log()
    );
    assert!(status(port).contains("outputs:   spindle CW 12000 rpm, flood"));
    sender.signal(Signal::SIGKILL);
    let killed = Instant::now();
    drop(sender);
    // Within 5 s: held at rest, spindle and coolant off (before, they stayed on for minutes).
    let mut last = String::new();
    let at_rest = wait_for(5 * S, || {
        last = status(port);
        last.starts_with("state:     Hold") && last.contains("outputs:   spindle off, coolant off")
    });
    assert!(
        at_rest,
        "{:?} after the kill:\n{last}\nserve: {}",
        killed.elapsed(),
        server.stderr()
    );
    // It stays so: nothing resumes it.
    let held = emu.last_counts();
    // Another command takes the job over; the job stays held until the operator resumes it.
    let taker = spawn(&["--port", port, "stream", job, "--continue"]);
    assert!(
        wait_for(20 * S, || taker.stderr().contains("takes over is held")),
        "{}",
        taker.stderr()
    );
    assert!(status(port).starts_with("state:     Hold"));
    assert_eq!(emu.last_counts(), held);
    let out = gantry(&["--port", port, "resume"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    // Spindle and flood back with the motion.
    let out = taker.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.contains("job done: last line 34 of 34"),
        "{out:?}"
    );
    assert!(emu.wait_log(10 * S, |l| l.contains("Idle line 34")));
    // The uninterrupted run's counts: back at X 0, Y 15 mm; every pulse of the path once.
    let (steps, pulses) = emu.last_counts();
    assert_eq!(steps, "X 0 Y 9600 Z 0", "{}", emu.log());
    assert_eq!(pulses, "X 384000 Y 9600 Z 0", "{}", emu.log());
    drop(server);
}

#[test]
fn a_thousand_status_requests_while_the_board_is_stalled_cause_no_reopen_and_no_hold() {
    use host_sender::link::{Client, Transport};
    use host_sender::session::socket::SocketTransport;
    let dir = Dir::new("serve-owner-stall");
    let setup = dir.file("setup.toml", SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port().to_owned();
    let server = serve(&port, &[]);
    // Thousands of short lines: the server has lines in flight (and resends them) while the
    // board does not read.
    let job = dir.file("zigzag.ngc", &zigzag(1500));
    let sender = spawn(&["--port", &port, "stream", job.to_str().unwrap()]);
    assert!(
        wait_for(20 * S, || line_of(&status(&port)) >= 5),
        "{}",
        emu.log()
    );
    // A client of its own through the server, which listens in this test's runtime directory
    // (the one every `gantry` this test starts gets: serial_support's `spawn_cmd`).
    std::env::set_var("XDG_RUNTIME_DIR", runtime_dir());
    let t: Box<dyn Transport> = Box::new(SocketTransport::connect(&port).unwrap().unwrap());
    let mut client = Client::connect(t, 5000).unwrap();
    // The board stops reading for 3 s (its process stopped) while 1,000 status requests come.
    nix::sys::signal::kill(emu.pid(), Signal::SIGSTOP).unwrap();
    let stalled = Instant::now();
    let mut sent = 0;
    while sent < 1000 || stalled.elapsed() < 3 * S {
        if sent < 1000 {
            client
                .send(gantry_proto::HostMsg::StatusRequest)
                .expect("serve takes status requests while the board is stalled");
            sent += 1;
        }
        client.pump(2).unwrap();
        while client.recv().is_some() {}
    }
    nix::sys::signal::kill(emu.pid(), Signal::SIGCONT).unwrap();
    drop(client);
    let out = sender.wait(T);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        out.stdout.contains("job done: last line 1502 of 1502"),
        "{out:?}"
    );
    let log = emu.log();
    assert!(log.contains("this process was stopped for"), "{log}");
    // No reopen (before: "went away; reopening it" a thousand times, DTR dropped) and no hold.
    assert!(
        !server.stderr().contains("went away"),
        "{}",
        server.stderr()
    );
    assert!(!log.contains("host closed the port (DTR drop"), "{log}");
    assert!(!log.contains("Hold"), "{log}");
    let (steps, pulses) = emu.last_counts();
    // 1,500 moves of 0.15 mm in X (96 steps each) climbing 0.02 mm (12.8 steps) in Y.
    assert_eq!(steps, "X 0 Y 19200 Z 0", "{log}");
    assert_eq!(pulses, "X 144000 Y 19200 Z 0", "{log}");
    drop(server);
}

/// A free loopback port for the console.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// POSTs `body` (raw bytes, as JSON) to the console's `/api/{what}` and returns the answer's JSON.
fn post(console: &Http, what: &str, body: &str) -> serde_json::Value {
    let (http, token) = (console.port, &console.token);
    let mut c = std::net::TcpStream::connect(("127.0.0.1", http)).unwrap();
    c.set_read_timeout(Some(30 * S)).unwrap();
    write!(
        c,
        "POST /api/{what} HTTP/1.1\r\nHost: 127.0.0.1:{http}\r\nContent-Type: application/json\r\nAuthorization: Bearer {token}\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut text = Vec::new();
    let mut buf = [0u8; 4096];
    // One answer: headers, then Content-Length bytes.
    loop {
        let n = c.read(&mut buf).unwrap();
        assert!(n > 0, "the console closed the connection");
        text.extend_from_slice(&buf[..n]);
        let s = String::from_utf8_lossy(&text).into_owned();
        if let Some((head, rest)) = s.split_once("\r\n\r\n") {
            let len: usize = head
                .lines()
                .find_map(|l| l.strip_prefix("Content-Length: "))
                .unwrap()
                .parse()
                .unwrap();
            if rest.len() >= len {
                return serde_json::from_str(&rest[..len]).unwrap();
            }
        }
    }
}

/// The console of a `gantry serve --http`: its port and the token it printed in its URL.
struct Http {
    port: u16,
    token: String,
}

fn console(port: &str) -> (Running, Http) {
    let port_http = free_port();
    let addr = format!("127.0.0.1:{port_http}");
    let server = serve(port, &["--http", &addr]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("the console is on")));
    let log = server.stderr();
    let token = log
        .lines()
        .find_map(|l| l.split_once("/?token=").map(|(_, t)| t.trim().to_owned()))
        .expect("the console's URL with its token");
    let http = Http {
        port: port_http,
        token,
    };
    // The console's session has read the board's setup once `setup_check` knows it.
    assert!(wait_for(10 * S, || post(&http, "read_back", "{}")["ok"] == true));
    (server, http)
}

#[test]
fn the_console_refuses_to_run_a_program_whose_check_failed_and_nothing_moves() {
    let dir = Dir::new("serve-owner-typo");
    let emu = Emulator::start(&dir, None);
    let (server, http) = console(emu.port());
    let typo = "G21 G90 G54\nG0 X5 Y5 Z5\nG1 X10 Y10 Z-1 F300 G0\n";
    let body = serde_json::json!({ "name": "typo.ngc", "text": typo }).to_string();
    let v = post(&http, "program", &body);
    assert_eq!(v["ok"], true, "{v}");
    assert_eq!(v["errors"], 1, "{v}");
    assert!(
        v["check"]
            .as_str()
            .unwrap()
            .contains("typo.ngc:3: error E202"),
        "{v}"
    );
    // Run and run-from-line are refused with the check's report; the MDI of the bad block too.
    for (what, body) in [
        ("run", "{}".to_owned()),
        ("run", r#"{"from_line": 2}"#.to_owned()),
        (
            "mdi",
            serde_json::json!({ "line": "G1 X10 Y10 Z-1 F300 G0" }).to_string(),
        ),
    ] {
        let v = post(&http, what, &body);
        assert_eq!(v["ok"], false, "{what} {body}: {v}");
        let e = v["error"].as_str().unwrap();
        assert!(
            e.contains("error E202") && e.contains("nothing was run"),
            "{e}"
        );
    }
    // Nothing moved: the board never left Idle, no step.
    let st = status(emu.port());
    assert!(st.starts_with("state:     Idle"), "{st}");
    assert!(!emu.log().contains(" Run line"), "{}", emu.log());
    assert_eq!(emu.last_counts().0, "X 0 Y 0 Z 0");
    // Fixed and opened again, it runs.
    let fixed = "G21 G90 G54\nG0 X5 Y5 Z5\nG1 X10 Y10 Z-1 F300\nM30\n";
    let body = serde_json::json!({ "name": "fixed.ngc", "text": fixed }).to_string();
    assert_eq!(post(&http, "program", &body)["errors"], 0);
    assert_eq!(post(&http, "run", "{}")["ok"], true);
    assert!(
        emu.wait_log(T, |l| l.contains("Idle line 4")),
        "{}",
        emu.log()
    );
    drop(server);
}

#[test]
fn the_console_refuses_an_empty_or_unreadable_setup_push_and_keeps_the_offsets() {
    const G54: &str = "\"G54\" = [5";
    let dir = Dir::new("serve-owner-setup");
    let setup = dir.file("setup.toml", SETUP);
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let (server, http) = console(port);
    // A work offset the operator set.
    let out = gantry(&["--port", port, "mdi", "G10 L2 P1 X5 Y-3"], T);
    assert_eq!(out.code, Some(0), "{out:?}");
    let before = pulled_setup(&dir, port);
    assert!(before.contains(G54), "{before}");
    for body in [
        "{}",
        r#"{"toml": ""}"#,
        r#"{"toml": "  # only a comment\n"}"#,
        r#"{"toml": 5}"#,
        "{\"toml\": \"[axis.X]\\nmax_rate = ",
        "not json at all",
    ] {
        let v = post(&http, "setup_push", body);
        assert_eq!(v["ok"], false, "{body}: {v}");
        assert!(
            v["error"].as_str().unwrap().contains("nothing was"),
            "{body}: {v}"
        );
        assert_eq!(pulled_setup(&dir, port), before, "{body}");
    }
    // A setup that names no work offsets keeps the board's, as `gantry setup push` does.
    let toml = "[axis.X]\nmax_rate = 5000.0\n";
    let v = post(
        &http,
        "setup_push",
        &serde_json::json!({ "toml": toml }).to_string(),
    );
    assert_eq!(v["ok"], true, "{v}");
    let after = pulled_setup(&dir, port);
    assert!(after.contains(G54), "{after}");
    assert!(after.contains("max_rate = 5000.0"), "{after}");
    // And `gantry setup push` of an empty file is refused the same way.
    let empty = dir.file("empty.toml", "# nothing\n");
    let out = gantry(
        &["--port", port, "setup", "push", empty.to_str().unwrap()],
        T,
    );
    assert_ne!(out.code, Some(0), "{out:?}");
    assert!(out.stderr.contains("an empty setup"), "{out:?}");
    assert_eq!(pulled_setup(&dir, port), after);
    drop(server);
}
