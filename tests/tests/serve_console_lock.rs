//! The console's lock and bounds, through the binary (`gantry serve --http` in front of
//! `gantry emulate --pty`): a request without the token serve printed is answered 401 and changes
//! nothing; header lines, header count and bodies are bounded (431, 413) with serve's memory
//! flat under a 1 GiB header; the API's numbers are validated (`from_line` 1e20 is refused); and
//! `emulate --state` never writes through a link planted where its temporary file would be.

mod serial_support;

use serial_support::*;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

/// `gantry serve --http 127.0.0.1:0` for `emu`, with the URL, token and token file it printed.
struct Console {
    serve: Running,
    addr: SocketAddr,
    token: String,
    file: String,
}

fn console(emu: &Emulator, dir: &Dir) -> Console {
    // The console's library in the test's directory.
    let serve = spawn_cmd(
        std::process::Command::new(GANTRY)
            .args(["serve", "--port", emu.port(), "--http", "127.0.0.1:0"])
            .env("XDG_DATA_HOME", dir.0.join("data")),
    );
    assert!(
        wait_for(20 * S, || serve.stderr().contains("token is also in")),
        "serve did not start its console: {}",
        serve.stderr()
    );
    let log = serve.stderr();
    let url = log
        .lines()
        .find_map(|l| l.strip_prefix("serve: the console is on http://"))
        .expect("the URL")
        .to_owned();
    let (addr, token) = url.split_once("/?token=").expect("a token in the URL");
    let file = log
        .lines()
        .find_map(|l| l.strip_prefix("serve: (its token is also in "))
        .and_then(|l| l.strip_suffix(')'))
        .expect("the token file")
        .to_owned();
    Console {
        addr: addr.parse().unwrap(),
        token: token.to_owned(),
        file,
        serve,
    }
}

/// Sends `raw` and reads the answer to its end (the status code and the body).
fn exchange(addr: SocketAddr, raw: &[u8]) -> (u16, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(30 * S)).unwrap();
    s.write_all(raw).unwrap();
    let mut answer = Vec::new();
    let mut buf = [0u8; 4096];
    // One answer: up to its Content-Length.
    loop {
        match s.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => answer.extend_from_slice(&buf[..n]),
        }
        let text = String::from_utf8_lossy(&answer);
        if let Some((head, body)) = text.split_once("\r\n\r\n") {
            let len = head
                .lines()
                .find_map(|l| l.strip_prefix("Content-Length: "))
                .and_then(|n| n.trim().parse::<usize>().ok());
            if len.is_some_and(|n| body.len() >= n) {
                break;
            }
        }
    }
    let text = String::from_utf8_lossy(&answer).into_owned();
    let code = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (code, text)
}

/// A POST of `body` to `/api/what` with `auth` header lines.
fn post(addr: SocketAddr, what: &str, auth: &str, body: &str) -> (u16, String) {
    exchange(
        addr,
        format!(
            "POST /api/{what} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\n{auth}Content-Length: {}\r\n\r\n{body}",
            body.len()
        )
        .as_bytes(),
    )
}

fn status(emu: &Emulator) -> String {
    let out = gantry(&["status", "--port", emu.port()], 20 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    out.stdout
}

fn state_of(status: &str) -> String {
    status
        .lines()
        .find_map(|l| l.strip_prefix("state:"))
        .map(|l| l.trim().to_owned())
        .unwrap_or_default()
}

fn machine_x(emu: &Emulator) -> String {
    status(emu)
        .lines()
        .find_map(|l| l.strip_prefix("machine:"))
        .and_then(|l| l.split_whitespace().nth(1).map(str::to_owned))
        .expect("machine line")
}

fn is_root() -> bool {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self")
        .map(|m| m.uid())
        .unwrap_or(1)
        == 0
}

fn vm_hwm_kib(pid: nix::unistd::Pid) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmHWM")
}

#[test]
fn without_the_token_nothing_is_shown_or_done() {
    let dir = Dir::new("console-lock");
    let emu = Emulator::start(&dir, None);
    let c = console(&emu, &dir);
    let addr = c.addr;
    // The token: 256 bits, in a file only serve's user reads.
    assert_eq!(c.token.len(), 64, "{}", c.token);
    {
        use std::os::unix::fs::PermissionsExt;
        let meta = std::fs::metadata(&c.file).unwrap();
        assert_eq!(meta.permissions().mode() & 0o777, 0o600);
        assert_eq!(std::fs::read_to_string(&c.file).unwrap().trim(), c.token);
        let dir_mode = std::fs::metadata(std::path::Path::new(&c.file).parent().unwrap())
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(dir_mode & 0o077, 0, "the runtime directory is private");
    }
    if is_root() {
        // Another local user can reach the port but not the token.
        use std::os::unix::process::CommandExt;
        let out = std::process::Command::new("cat")
            .arg(&c.file)
            .uid(65534)
            .gid(65534)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{out:?}");
        assert!(out.stdout.is_empty());
    }
    assert_eq!(machine_x(&emu), "0.000");
    let jog5 = r#"{"axis":"X","step":5,"dir":1,"feed":3000}"#;
    let wrong = format!(
        "Cookie: gantry_console_{}={}\r\n",
        addr.port(),
        "0".repeat(64)
    );
    for auth in ["", &wrong, "Authorization: Bearer nope\r\n"] {
        let (code, text) = post(addr, "jog", auth, jog5);
        assert_eq!(code, 401, "{auth:?}: {text}");
        assert!(!text.contains("\"ok\""), "{text}");
    }
    for path in ["/", "/events", "/console.js"] {
        let (code, text) = exchange(
            addr,
            format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes(),
        );
        assert_eq!(code, 401, "{path}: {text}");
    }
    // With the token from its file (a script) the same request jogs: the refused ones did not,
    // or X would not end at exactly 1 mm (a jog 5 mm earlier, or this one refused as busy).
    let token = std::fs::read_to_string(&c.file).unwrap();
    let bearer = format!("Authorization: Bearer {}\r\n", token.trim());
    let (code, text) = post(addr, "jog", &bearer, r#"{"axis":"X","step":1,"dir":1}"#);
    assert_eq!(code, 200, "{text}");
    assert!(text.contains("\"ok\":true"), "{text}");
    assert!(
        wait_for(20 * S, || machine_x(&emu) == "1.000"
            && state_of(&status(&emu)) == "Idle"),
        "{}",
        status(&emu)
    );
    // The printed URL's first visit gives the page its cookie, which then lets it in.
    let (code, text) = exchange(
        addr,
        format!("GET /?token={} HTTP/1.1\r\nHost: {addr}\r\n\r\n", c.token).as_bytes(),
    );
    assert_eq!(code, 200, "{text}");
    let cookie = text
        .lines()
        .find_map(|l| l.strip_prefix("Set-Cookie: "))
        .and_then(|l| l.split(';').next())
        .expect("a cookie")
        .to_owned();
    assert!(
        text.contains("HttpOnly") && text.contains("SameSite=Strict"),
        "{text}"
    );
    let by_cookie = format!("Cookie: other=1; {cookie}\r\n");
    let (code, text) = post(addr, "read_back", &by_cookie, "{}");
    assert_eq!(code, 200, "{text}");
    assert!(text.contains("\"ok\":true"), "{text}");

    // Numbers are validated as the CLI validates them: nothing starts.
    let program = r#"{"name":"p.nc","text":"G21 G90\nG1 X2 F600\nM30\n"}"#;
    let (code, text) = post(addr, "program", &bearer, program);
    assert_eq!(code, 200, "{text}");
    for (what, body, word) in [
        ("run", r#"{"from_line":1e20}"#, "from_line"),
        ("run", r#"{"from_line":2.5}"#, "from_line"),
        ("run", r#"{"from_line":"2"}"#, "from_line"),
        ("run", r#"{"from_line":0}"#, "from_line"),
        ("override", r#"{"feed":5}"#, "feed"),
        ("override", r#"{"rapid":150}"#, "rapid"),
        ("override", r#"{"spindle":"fast"}"#, "spindle"),
        ("jog", r#"{"axis":"X","step":1,"dir":7}"#, "dir"),
        ("jog", r#"{"axis":"X","step":1e20,"dir":1}"#, "step"),
        ("offset", r#"{"p":1,"X":1e20}"#, "X"),
        ("offset", r#"{"p":1.5,"X":1}"#, "p"),
    ] {
        let (code, text) = post(addr, what, &bearer, body);
        assert_eq!(code, 200, "{what} {body}: {text}");
        assert!(
            text.contains("\"ok\":false") && text.contains(word),
            "{what} {body}: {text}"
        );
    }
    let (code, text) = post(addr, "run", &bearer, "[1]");
    assert_eq!(code, 400, "{text}");
    let st = status(&emu);
    assert_eq!(state_of(&st), "Idle", "{st}");
    assert!(st.contains("override feed 100 %"), "{st}");
    assert_eq!(machine_x(&emu), "1.000");
    drop(c);
}

#[test]
fn headers_and_bodies_are_bounded_and_memory_stays_flat() {
    let dir = Dir::new("console-bounds");
    let emu = Emulator::start(&dir, None);
    let c = console(&emu, &dir);
    let addr = c.addr;
    let bearer = format!("Authorization: Bearer {}\r\n", c.token);
    // Warm up (threads, the page) before the peak is read.
    let (code, _) = post(addr, "read_back", &bearer, "{}");
    assert_eq!(code, 200);
    let before = vm_hwm_kib(c.serve.pid());

    // A 1 GiB header line: refused at 8 KiB; the rest is never taken.
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_write_timeout(Some(60 * S)).unwrap();
    s.write_all(format!("GET / HTTP/1.1\r\nHost: {addr}\r\nX-Long: ").as_bytes())
        .unwrap();
    let chunk = vec![b'a'; 1 << 20];
    let mut sent = 0usize;
    while sent < 1 << 30 {
        match s.write(&chunk) {
            Ok(n) => sent += n,
            Err(_) => break,
        }
    }
    assert!(
        sent < 64 << 20,
        "serve took {sent} bytes of one header line"
    );
    drop(s);
    let after = vm_hwm_kib(c.serve.pid());
    assert!(
        after < before + 8 * 1024,
        "serve's peak memory grew from {before} KiB to {after} KiB"
    );

    // A header line just over 8 KiB, and 101 header lines: 431 with the reason.
    let long = format!(
        "GET / HTTP/1.1\r\nHost: {addr}\r\nX-Long: {}\r\n\r\n",
        "a".repeat(8 << 10)
    );
    let (code, text) = exchange(addr, long.as_bytes());
    assert_eq!(code, 431, "{text}");
    let many: String = (0..101).map(|i| format!("X-{i}: 1\r\n")).collect();
    let (code, text) = exchange(
        addr,
        format!("GET / HTTP/1.1\r\nHost: {addr}\r\n{many}\r\n").as_bytes(),
    );
    assert_eq!(code, 431, "{text}");
    // 100 are fine (with the token: the page).
    let hundred: String = (0..98).map(|i| format!("X-{i}: 1\r\n")).collect();
    let (code, text) = exchange(
        addr,
        format!("GET / HTTP/1.1\r\nHost: {addr}\r\n{bearer}{hundred}\r\n").as_bytes(),
    );
    assert_eq!(code, 200, "{text}");
    // A body over 1 MiB: 413 before a byte of it is read (401 first without the token).
    let big = format!(
        "POST /api/hold HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\n{bearer}Content-Length: {}\r\n\r\n",
        (1 << 20) + 1
    );
    let (code, text) = exchange(addr, big.as_bytes());
    assert_eq!(code, 413, "{text}");
    let big = format!(
        "POST /api/hold HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        1u64 << 40
    );
    let (code, text) = exchange(addr, big.as_bytes());
    assert_eq!(code, 401, "{text}");
    // serve still serves, and nothing moved.
    let (code, text) = post(addr, "read_back", &bearer, "{}");
    assert_eq!(code, 200, "{text}");
    let st = status(&emu);
    assert_eq!(state_of(&st), "Idle", "{st}");
    assert_eq!(machine_x(&emu), "0.000");
}

#[test]
fn emulate_state_never_writes_through_a_planted_link() {
    let dir = Dir::new("state-link");
    let victim = dir.file("victim", "keep\n");
    let victim2 = dir.file("victim2", "keep too\n");
    // Where the old code put its temporary file, and the position file beside the state.
    std::os::unix::fs::symlink(&victim, dir.0.join("state.tmp")).unwrap();
    std::os::unix::fs::symlink(&victim2, dir.0.join("state.toml.position")).unwrap();
    let mut emu = Emulator::start(&dir, None);
    let text = pulled_setup(&dir, emu.port());
    let edited = dir.file(
        "edited.toml",
        &text.replacen("max_rate = 3000.0", "max_rate = 2500.0", 1),
    );
    let out = gantry(
        &[
            "--port",
            emu.port(),
            "setup",
            "push",
            edited.to_str().unwrap(),
        ],
        20 * S,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(
        emu.wait_log(20 * S, |l| l.contains("setup saved")),
        "{}",
        emu.log()
    );
    emu.kill_gently();
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep\n");
    assert_eq!(std::fs::read_to_string(&victim2).unwrap(), "keep too\n");
    let state = std::fs::read_to_string(dir.0.join("state.toml")).unwrap();
    assert!(state.contains("max_rate = 2500.0"), "{state}");
    // The planted link is left as it was; the position file replaced it with a file of its own.
    assert!(std::fs::symlink_metadata(dir.0.join("state.tmp"))
        .unwrap()
        .file_type()
        .is_symlink());
    let pos = std::fs::symlink_metadata(dir.0.join("state.toml.position")).unwrap();
    assert!(pos.file_type().is_file(), "{pos:?}");
    // No temporary file is left behind.
    let left: Vec<_> = std::fs::read_dir(&dir.0)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp") && n != "state.tmp")
        .collect();
    assert!(left.is_empty(), "{left:?}");
}
