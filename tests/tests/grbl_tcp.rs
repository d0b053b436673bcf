//! `gantry emulate --tcp` as its own process, driven as a grbl sender on a TCP connection:
//! character counting against the advertised RX buffer, every line `ok`, the final position and
//! step counts equal to `gantry stream`'s over the pty on the same program and setup; a second
//! connection after the first closed gets a new banner.

mod serial_support;

use gantry_machine::device::grbl::{BANNER, RX_SIZE};
use serial_support::*;
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::Command;
use std::time::{Duration, Instant};

const S: Duration = Duration::from_secs(1);

/// A program of our own: absolute moves, an arc each way, a dwell, ending at X12 Y-3.5.
fn program() -> String {
    let mut p = String::from("G21 G90 G17 G64\nG0 X1 Y1\n");
    for i in 0..40 {
        let x = 1.0 + 0.25 * f64::from(i);
        let y = if i % 2 == 0 { 1.3 } else { 0.7 };
        p.push_str(&format!("G1 X{x:.2} Y{y} F4000\n"));
    }
    p.push_str("G1 X10 Y1\nG2 X15 Y1 I2.5 J0 F3000\nG3 X10 Y1 I-2.5 J0\nG4 P0.1\nG1 X12 Y-3.5\n");
    p
}

/// Reads what the connection has (bounded by the socket's read timeout) into `seen`.
fn read_some(c: &mut TcpStream, seen: &mut String) {
    let mut buf = [0u8; 4096];
    match c.read(&mut buf) {
        Ok(0) => panic!("the emulator closed the connection; saw {seen:?}"),
        Ok(n) => seen.push_str(&String::from_utf8_lossy(&buf[..n])),
        Err(_) => {}
    }
}

fn read_until(c: &mut TcpStream, what: &str, limit: Duration) -> String {
    let mut seen = String::new();
    let start = Instant::now();
    while !seen.contains(what) {
        assert!(start.elapsed() < limit, "no {what:?}; saw {seen:?}");
        read_some(c, &mut seen);
    }
    seen
}

/// The emulator log's last state line.
fn last_state(log: &str) -> String {
    log.lines()
        .rev()
        .find(|l| l.contains(" pulses "))
        .unwrap_or("")
        .to_owned()
}

fn connect(port: u16) -> TcpStream {
    let c = TcpStream::connect(("127.0.0.1", port)).unwrap();
    c.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    c
}

#[test]
fn a_grbl_sender_streams_over_tcp_by_character_counting_like_gantry_stream() {
    let dir = Dir::new("grbl-tcp");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let job = dir.file("job.nc", &program());

    // Reference: `gantry stream` over the pty.
    let reference = {
        let emu = Emulator::start(&dir, Some(&setup));
        let out = gantry(
            &["stream", job.to_str().unwrap(), "--port", emu.port()],
            30 * S,
        );
        assert_eq!(out.code, Some(0), "{out:?}");
        assert!(emu.wait_log(5 * S, |l| last_state(l).contains(" Idle ")));
        emu.last_counts()
    };

    let (mut child, log) = spawn_logged(
        Command::new(GANTRY)
            .args(["emulate", "--tcp", "127.0.0.1:0", "--setup"])
            .arg(&setup),
    );
    let log_text = || log.lock().unwrap().clone();
    assert!(wait_for(10 * S, || log_text().contains("board ready on tcp")));
    let port: u16 = {
        let text = log_text();
        let rest = text.split("board ready on tcp 127.0.0.1:").nth(1).unwrap();
        rest.split(',').next().unwrap().parse().unwrap()
    };

    let mut c = connect(port);
    // grbl is chosen by the first line (an empty one: `ok`).
    c.write_all(b"\n").unwrap();
    let seen = read_until(&mut c, "ok\r\n", 5 * S);
    assert!(seen.starts_with(&format!("\r\n{BANNER}\r\n")), "{seen:?}");

    // Character counting: at most RX_SIZE unanswered bytes.
    let text = program();
    let lines: Vec<&str> = text.lines().collect();
    let mut in_flight: VecDeque<usize> = VecDeque::new();
    let mut sent = 0;
    let mut answers = String::new();
    let (mut oks, mut most) = (0, 0);
    let start = Instant::now();
    while oks < lines.len() {
        assert!(start.elapsed() < 60 * S, "stuck: {answers:?}");
        while sent < lines.len() {
            let len = lines[sent].len() + 1;
            if in_flight.iter().sum::<usize>() + len > RX_SIZE {
                break;
            }
            c.write_all(format!("{}\n", lines[sent]).as_bytes())
                .unwrap();
            in_flight.push_back(len);
            sent += 1;
        }
        most = most.max(in_flight.iter().sum::<usize>());
        let before = answers.len();
        read_some(&mut c, &mut answers);
        for line in answers[before..].lines() {
            assert!(!line.starts_with("error"), "{answers:?}");
        }
        let now = answers.matches("ok\r\n").count();
        for _ in oks..now {
            in_flight.pop_front().expect("an ok for a line sent");
        }
        oks = now;
    }
    assert_eq!(oks, lines.len(), "every line answered ok: {answers:?}");
    assert!(most > RX_SIZE / 2, "the RX buffer was kept full ({most} B)");

    // At rest: the exact end and the same steps as `gantry stream`.
    let mut status = String::new();
    for _ in 0..500 {
        c.write_all(b"?").unwrap();
        status = read_until(&mut c, ">\r\n", 5 * S);
        if status.contains("<Idle|") {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        status.contains("<Idle|MPos:12.000,-3.500,0.000|"),
        "{status:?}"
    );
    let steps = |log: &str| {
        let line = last_state(log);
        let steps = line.split(" steps ").nth(1).unwrap();
        let (s, p) = steps.split_once(" pulses ").unwrap();
        (s.to_owned(), p.to_owned())
    };
    assert!(wait_for(5 * S, || steps(&log_text()) == reference));

    // The first connection closes; a second one gets a new banner and a status.
    drop(c);
    assert!(wait_for(5 * S, || log_text().contains("client disconnected")));
    let mut c = connect(port);
    c.write_all(b"?").unwrap();
    let seen = read_until(&mut c, ">\r\n", 5 * S);
    assert!(seen.contains(BANNER), "{seen:?}");
    assert!(seen.contains("<Idle|MPos:12.000,-3.500,0.000|"), "{seen:?}");
    drop(c);
    let _ = child.kill();
    let _ = child.wait();
}

/// Starts `gantry emulate --tcp 127.0.0.1:0`; the child, its log and its port.
fn emulate_tcp(
    setup: &std::path::Path,
) -> (
    std::process::Child,
    std::sync::Arc<std::sync::Mutex<String>>,
    u16,
) {
    let (child, log) = spawn_logged(
        Command::new(GANTRY)
            .args(["emulate", "--tcp", "127.0.0.1:0", "--setup"])
            .arg(setup),
    );
    assert!(wait_for(10 * S, || log
        .lock()
        .unwrap()
        .contains("board ready on tcp")));
    let port = {
        let text = log.lock().unwrap().clone();
        let rest = text.split("board ready on tcp 127.0.0.1:").nth(1).unwrap();
        rest.split(',').next().unwrap().parse().unwrap()
    };
    (child, log, port)
}

/// The status report once it starts with `state` (bounded).
fn status_when(c: &mut TcpStream, state: &str) -> String {
    let start = Instant::now();
    loop {
        c.write_all(b"?").unwrap();
        let s = read_until(c, ">\r\n", 5 * S);
        let report = &s[s.rfind('<').unwrap()..];
        if report.starts_with(state) {
            return report.to_owned();
        }
        assert!(start.elapsed() < 30 * S, "no {state:?}: {report:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Over TCP, bytes the board cannot take yet wait in the socket: nothing is dropped. A client
/// that connects and says nothing is greeted with the banner. Then, as CNCjs does: a feed hold
/// in Idle, 144 bytes of lines in one write (every line answered `ok` in the hold, nothing
/// moving), cycle start (each line runs once: the end is the last line's); eight jog clicks in
/// one write of 160 bytes (eight `ok`, X exactly +8 mm), and the next line is read whole.
#[test]
fn over_tcp_a_hold_and_a_jog_burst_lose_nothing_and_a_silent_client_is_greeted() {
    let dir = Dir::new("grbl-tcp-bursts");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let (mut child, _log, port) = emulate_tcp(&setup);
    let mut c = connect(port);
    let seen = read_until(&mut c, BANNER, 10 * S);
    assert_eq!(seen, format!("\r\n{BANNER}\r\n"), "greeted, nothing else");

    c.write_all(b"!").unwrap();
    status_when(&mut c, "<Hold:0");
    let xs = [1, 2, 3, 4, 5, 6, 7, 8, 9, 8, 7, 6];
    let burst: String = xs.iter().map(|x| format!("G1 X{x} F9000\n")).collect();
    assert_eq!(burst.len(), 144);
    c.write_all(burst.as_bytes()).unwrap();
    c.write_all(b"$G\n").unwrap();
    let mut seen = String::new();
    let start = Instant::now();
    while seen.matches("ok\r\n").count() < 13 {
        assert!(start.elapsed() < 20 * S, "answers in the hold: {seen:?}");
        read_some(&mut c, &mut seen);
    }
    assert!(!seen.contains("error"), "{seen:?}");
    assert!(status_when(&mut c, "<Hold:0").contains("MPos:0.000,0.000,0.000"));
    c.write_all(b"~").unwrap();
    let end = status_when(&mut c, "<Idle");
    assert!(end.contains("MPos:6.000,0.000,0.000"), "{end:?}");

    let jogs = "$J=G91 G21 X1 F2000\n".repeat(8);
    assert_eq!(jogs.len(), 160);
    c.write_all(jogs.as_bytes()).unwrap();
    let mut seen = String::new();
    let start = Instant::now();
    while seen.matches("ok\r\n").count() < 8 {
        assert!(start.elapsed() < 20 * S, "jog answers: {seen:?}");
        read_some(&mut c, &mut seen);
    }
    assert!(!seen.contains("error"), "{seen:?}");
    c.write_all(b"G90 G0 Y5\n").unwrap();
    let answer = read_until(&mut c, "\r\n", 10 * S);
    assert!(answer.starts_with("ok"), "{answer:?}");
    let end = status_when(&mut c, "<Idle");
    assert!(end.contains("MPos:14.000,5.000,0.000"), "{end:?}");
    drop(c);
    let _ = child.kill();
    let _ = child.wait();
}

/// A grbl sender that opens the port after a `gantry` command reads grbl's banner first, not
/// frames meant for the command that left: once the host is gone the board sends nothing
/// until a new connection speaks (or is greeted), and the emulator drops what the departed host
/// left unread.
#[test]
fn after_a_gantry_command_a_grbl_client_first_reads_the_banner() {
    let dir = Dir::new("grbl-after-gantry");
    let emu = Emulator::start(&dir, None);
    let out = gantry(&["status", "--port", emu.port()], 30 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(emu.wait_log(10 * S, |l| l.contains("host closed the port")));
    // Long enough for the board's status frames (every 100 ms) to pile up, were any sent.
    std::thread::sleep(Duration::from_millis(500));
    let mut port = serialport::new(emu.port(), 115_200)
        .timeout(Duration::from_millis(20))
        .open()
        .unwrap();
    let mut seen = Vec::new();
    let start = Instant::now();
    while !String::from_utf8_lossy(&seen).contains(BANNER) {
        assert!(
            start.elapsed() < 10 * S,
            "no banner: {:?}",
            String::from_utf8_lossy(&seen)
        );
        let mut buf = [0u8; 4096];
        if let Ok(n) = port.read(&mut buf) {
            seen.extend_from_slice(&buf[..n]);
        }
    }
    assert_eq!(
        String::from_utf8_lossy(&seen),
        format!("\r\n{BANNER}\r\n"),
        "the first bytes are the banner"
    );
    port.write_all(b"?").unwrap();
    let mut seen = String::new();
    let start = Instant::now();
    while !seen.contains(">\r\n") {
        assert!(start.elapsed() < 10 * S, "no status: {seen:?}");
        let mut buf = [0u8; 256];
        if let Ok(n) = port.read(&mut buf) {
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }
    assert!(seen.starts_with("<Idle|"), "{seen:?}");
}
