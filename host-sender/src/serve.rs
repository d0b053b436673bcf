//! `gantry serve --port P`: one process owns the board's port for as long as it runs, and other
//! `gantry` commands reach the board through it while a job runs.
//!
//! Transport: a Unix stream socket named after the port ([`socket_path`]). Each command that
//! connects to it speaks the ordinary link protocol (`docs/protocol.md`) to a board endpoint the
//! server keeps for it, exactly as it would over the USB port; the server passes every message
//! a command sends on to the board (queued ones as the board's credit allows) and every message
//! the board sends to every command (each takes what concerns it: status reports, errors,
//! program requests, setup chunks).
//!
//! Discovery: a command given `--port P` (or `GANTRY_PORT`, or the one plugged-in board) first
//! tries the socket of P; when no server answers there it opens P itself.
//!
//! The job belongs to the command that started it (or took it over with `stream --continue`):
//! when that command goes away mid-job (killed, terminal closed), the server holds the job, as
//! the board does when the port is closed, and a later `stream --continue` through the server
//! takes it over. When the server itself ends, its port closes with DTR dropped: the board holds.

use crate::link::{Client, OnClose, SerialTransport, Transport};
use anyhow::Context;
use gantry_proto::{BoardEndpoint, BoardMsg, Config, HostMsg, MachineState};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The socket of the server for `port`: `gantry-<port path, '/' as '_'>.sock` in the private
/// directory [`socket_dir`]; the port path is resolved first, so a link to a port and the port
/// itself find the same server.
pub fn socket_name(port: &str) -> String {
    let resolved = std::fs::canonicalize(port).unwrap_or_else(|_| PathBuf::from(port));
    let name: String = resolved
        .to_string_lossy()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("gantry-{name}.sock")
}

/// The user this process runs as.
fn my_uid() -> u32 {
    nix::unistd::geteuid().as_raw()
}

/// Refuses a path another user owns: it may have been planted there to pose as this user's
/// `gantry serve` (a fake board that answers `gantry abort` while the real job runs).
fn check_owner(path: &Path, meta: &std::fs::Metadata) -> anyhow::Result<()> {
    use std::os::unix::fs::MetadataExt;
    let me = my_uid();
    if meta.uid() != me {
        anyhow::bail!(
            "{}: not owned by you (owner uid {}, you are uid {me}): refusing it, another user may have put it there to pose as your `gantry serve`; remove it (as its owner or root) if it is stale",
            path.display(),
            meta.uid()
        );
    }
    Ok(())
}

/// The private directory of the servers' sockets: `$XDG_RUNTIME_DIR` (the user's own, 0700),
/// else `gantry-<uid>` in the temporary directory, created with mode 0700 when `create`. It must
/// be a directory owned by this user and closed to everyone else (no group or other
/// permission bit), else it is refused with the reason. `None`: it does not exist (and was not
/// to be created), so no server runs.
pub fn socket_dir(create: bool) -> anyhow::Result<Option<PathBuf>> {
    use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
    let xdg = std::env::var_os("XDG_RUNTIME_DIR")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from);
    let (dir, meta) = match xdg {
        // Set up by the login session; may be a link to /run/user/<uid>.
        Some(d) => match std::fs::metadata(&d) {
            Ok(m) => (d, m),
            Err(e) => anyhow::bail!("XDG_RUNTIME_DIR {}: {e}", d.display()),
        },
        None => {
            let d = std::env::temp_dir().join(format!("gantry-{}", my_uid()));
            if create {
                match std::fs::DirBuilder::new().mode(0o700).create(&d) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                    Err(e) => {
                        return Err(e).with_context(|| format!("cannot create {}", d.display()))
                    }
                }
            }
            // Not followed: a link planted in the shared temporary directory is refused.
            match std::fs::symlink_metadata(&d) {
                Ok(m) => (d, m),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
                Err(e) => return Err(e).with_context(|| format!("cannot read {}", d.display())),
            }
        }
    };
    check_owner(&dir, &meta)?;
    if !meta.is_dir() {
        anyhow::bail!(
            "{}: not a directory (refused as the socket directory of `gantry serve`)",
            dir.display()
        );
    }
    let mode = meta.permissions().mode() & 0o777;
    if mode & 0o077 != 0 {
        anyhow::bail!(
            "{}: open to other users (mode {mode:04o}): the socket directory of `gantry serve` must be private (chmod 700 it)",
            dir.display()
        );
    }
    Ok(Some(dir))
}

/// The socket of the server for `port` (see [`socket_name`], [`socket_dir`]); `None` when the
/// directory does not exist.
pub fn socket_path(port: &str) -> anyhow::Result<Option<PathBuf>> {
    Ok(socket_dir(false)?.map(|d| d.join(socket_name(port))))
}

/// Refuses an existing `path` that is not this user's socket; false when nothing is there.
fn check_socket(path: &Path) -> anyhow::Result<bool> {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::symlink_metadata(path) {
        Ok(m) => {
            check_owner(path, &m)?;
            if !m.file_type().is_socket() {
                anyhow::bail!("{}: not a socket (refused)", path.display());
            }
            Ok(true)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", path.display())),
    }
}

/// A command's link to the board through a running server.
pub struct SocketTransport {
    stream: UnixStream,
    start: Instant,
}

impl SocketTransport {
    /// Connects to the server of `port`, if one runs (`None`: no socket, or nobody listens).
    /// A socket or socket directory of another user is refused (an error), never used.
    pub fn connect(port: &str) -> anyhow::Result<Option<Self>> {
        let Some(path) = socket_path(port)? else {
            return Ok(None);
        };
        if !check_socket(&path)? {
            return Ok(None);
        }
        let Ok(stream) = UnixStream::connect(&path) else {
            return Ok(None);
        };
        if stream.set_nonblocking(true).is_err() {
            return Ok(None);
        }
        Ok(Some(SocketTransport {
            stream,
            start: Instant::now(),
        }))
    }
}

impl Transport for SocketTransport {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        let mut rest = bytes;
        let since = Instant::now();
        while !rest.is_empty() {
            match self.stream.write(rest) {
                Ok(0) => anyhow::bail!("gantry serve closed the link"),
                Ok(n) => rest = &rest[n..],
                // A server that does not read (its board is stuck) loses these bytes, as a
                // serial line would; the protocol sends them again, and the sender's silence
                // bound ends the wait.
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if since.elapsed() > Duration::from_millis(50) {
                        return Ok(());
                    }
                    std::thread::sleep(Duration::from_millis(1))
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e).context("gantry serve closed the link"),
            }
        }
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        let mut buf = [0u8; 4096];
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => anyhow::bail!(
                    "gantry serve closed the link (the server ended, or the board restarted)"
                ),
                Ok(n) => into.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => return Ok(()),
                Err(e) => return Err(e).context("gantry serve closed the link"),
            }
        }
    }

    fn wait(&mut self, ms: u32) {
        std::thread::sleep(Duration::from_millis(ms as u64));
    }

    fn now_ms(&self) -> u32 {
        self.start.elapsed().as_millis() as u32
    }
}

/// One command connected to the server.
struct Session {
    stream: UnixStream,
    endpoint: BoardEndpoint,
    /// Board messages not yet taken by the endpoint (its send queue was full).
    outbox: VecDeque<BoardMsg>,
    /// This command started the running job (or took it over).
    owns_job: bool,
    alive: bool,
}

impl Session {
    fn new(stream: UnixStream, id: u32) -> Self {
        Session {
            stream,
            endpoint: BoardEndpoint::new_board(Config::USB_MS, 0x5e7e_0000 ^ id),
            outbox: VecDeque::new(),
            owns_job: false,
            alive: true,
        }
    }

    fn read(&mut self, now: u32) {
        let mut buf = [0u8; 4096];
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => {
                    self.alive = false;
                    return;
                }
                Ok(n) => self.endpoint.on_bytes(now, &buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(_) => {
                    self.alive = false;
                    return;
                }
            }
        }
    }

    fn flush(&mut self, now: u32) {
        while let Some(m) = self.outbox.pop_front() {
            if let Err(gantry_proto::SendError::Full(m)) = self.endpoint.send(m) {
                self.outbox.push_front(m);
                break;
            }
        }
        let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
        while let Some(n) = self.endpoint.poll_transmit(now, &mut frame) {
            let mut rest = &frame[..n];
            while !rest.is_empty() && self.alive {
                match self.stream.write(rest) {
                    Ok(n) => rest = &rest[n..],
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                        // A command that does not read loses frames; the protocol resends.
                        break;
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(_) => self.alive = false,
                }
            }
        }
    }
}

/// Runs the server for `port` until SIGINT or SIGTERM.
pub fn run(port: &str) -> anyhow::Result<ExitCode> {
    let dir = socket_dir(true)?.expect("created");
    let path = dir.join(socket_name(port));
    if check_socket(&path)? {
        if UnixStream::connect(&path).is_ok() {
            anyhow::bail!(
                "a gantry serve already owns {port} (socket {})",
                path.display()
            );
        }
        // This user's socket that nobody listens on: left by a server that was killed.
        let _ = std::fs::remove_file(&path);
    }
    let t: Box<dyn Transport> = Box::new(SerialTransport::open_with(port, OnClose::DropDtr)?);
    let mut board = Client::connect(t, 3000)?;
    let listener =
        UnixListener::bind(&path).with_context(|| format!("cannot bind {}", path.display()))?;
    // Read and write for this user only, whatever the umask (the directory is private too).
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600))
            .with_context(|| format!("cannot make {} private", path.display()))?;
    }
    listener.set_nonblocking(true)?;
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::SeqCst))
        .context("cannot install the SIGINT/SIGTERM handler")?;
    eprintln!("serve: {port} is served on {}", path.display());
    let start = Instant::now();
    let mut sessions: Vec<Session> = Vec::new();
    let mut next_id = 0u32;
    let mut state = MachineState::Idle;
    let mut to_board: VecDeque<HostMsg> = VecDeque::new();
    let result = (|| -> anyhow::Result<()> {
        while !stop.load(Ordering::SeqCst) {
            let now = start.elapsed().as_millis() as u32;
            while let Ok((stream, _)) = listener.accept() {
                if stream.set_nonblocking(true).is_ok() {
                    next_id += 1;
                    sessions.push(Session::new(stream, next_id));
                }
            }
            let job_owned = sessions.iter().any(|s| s.owns_job && s.alive);
            for s in sessions.iter_mut() {
                s.read(now);
                // The session's handshake is the endpoint's own business.
                while s.endpoint.poll_event().is_some() {}
                while let Some(msg) = s.endpoint.recv_realtime() {
                    if matches!(msg, HostMsg::Resume)
                        && matches!(
                            state,
                            MachineState::Run
                                | MachineState::Hold { .. }
                                | MachineState::ToolChange { .. }
                        )
                        && !job_owned
                    {
                        // `stream --continue` taking over a job no command owns: a new hello
                        // makes the board ask for the lines it is missing.
                        board.reconnect();
                        s.owns_job = true;
                        eprintln!("serve: a command takes over the job");
                    }
                    to_board.push_back(msg);
                }
                while board.queued_room() > 0 {
                    let Some(msg) = s.endpoint.recv_queued() else {
                        break;
                    };
                    if matches!(msg, HostMsg::Start { .. } | HostMsg::StartFromLine { .. }) {
                        s.owns_job = true;
                    }
                    board.send(msg)?;
                }
            }
            // Realtime messages wait here while the board's lane is full (a silent board):
            // the server keeps serving its commands meanwhile.
            while let Some(msg) = to_board.pop_front() {
                if let Err(m) = board.try_send(msg) {
                    to_board.push_front(*m);
                    break;
                }
            }
            board.pump(1)?;
            if board.take_board_reset() {
                eprintln!("serve: the board restarted: every command's link is closed");
                sessions.clear();
            }
            while let Some(msg) = board.recv() {
                if let BoardMsg::Status(st) = &msg {
                    if st.state != state {
                        eprintln!("serve: board {} line {}", state_words(st.state), st.line);
                        let job_ended =
                            matches!(st.state, MachineState::Idle | MachineState::Alarm { .. });
                        if job_ended {
                            for s in sessions.iter_mut() {
                                s.owns_job = false;
                            }
                        }
                    }
                    state = st.state;
                }
                for s in sessions.iter_mut() {
                    if let BoardMsg::Status(_) = msg {
                        // Status reports: the newest replaces an unsent older one.
                        s.outbox.retain(|m| !matches!(m, BoardMsg::Status(_)));
                    }
                    s.outbox.push_back(msg.clone());
                }
            }
            for s in sessions.iter_mut() {
                s.flush(now);
            }
            let gone_owner = sessions.iter().any(|s| !s.alive && s.owns_job);
            if gone_owner
                && matches!(
                    state,
                    MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. }
                )
            {
                eprintln!("serve: the command that owned the job went away: feed hold");
                if board.try_send(HostMsg::FeedHold).is_err() {
                    eprintln!("serve: the board takes no message now (its link is stuck)");
                }
                board.pump(1)?;
                // Its lines still waiting here would block every later queued message (a
                // setup request, a new start): a fresh link to the board drops them, and the
                // board asks for what it misses when a command takes the job over.
                // The handshake completes in later passes, so a board that is silent now (the
                // reason its owner gave up) does not end the server: it answers when it is back.
                let t = std::mem::replace(&mut board, placeholder()).into_transport();
                board = Client::unconnected(t);
                board.reconnect();
            }
            sessions.retain(|s| s.alive);
        }
        Ok(())
    })();
    let _ = std::fs::remove_file(&path);
    eprintln!("serve: stopped");
    result.map(|()| ExitCode::SUCCESS)
}

/// A link that is never used, while the real one is being replaced.
fn placeholder() -> Client<Box<dyn Transport>> {
    struct Nothing;
    impl Transport for Nothing {
        fn write(&mut self, _: &[u8]) -> anyhow::Result<()> {
            Ok(())
        }
        fn read(&mut self, _: &mut Vec<u8>) -> anyhow::Result<()> {
            Ok(())
        }
        fn wait(&mut self, _: u32) {}
        fn now_ms(&self) -> u32 {
            0
        }
    }
    Client::unconnected(Box::new(Nothing))
}

/// True when a server for `port` answers on its socket (of this user).
pub fn running(port: &str) -> bool {
    matches!(SocketTransport::connect(port), Ok(Some(_)))
}

/// The board's state as the server's log names it: each state the status tells apart has its own
/// words, so a change is logged once and reads as one (a hold coming to rest goes from "holding"
/// to "held"; an alarm and a tool change name their code and tool).
fn state_words(s: MachineState) -> String {
    match s {
        MachineState::Hold { stopped: false } => "holding (stopping)".into(),
        MachineState::Hold { stopped: true } => "held".into(),
        MachineState::Alarm { code } => format!("Alarm {code}"),
        MachineState::ToolChange { tool } => format!("ToolChange T{tool}"),
        other => crate::stream::state_name(other).into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_state_change_has_its_own_words() {
        let states = [
            MachineState::Idle,
            MachineState::Run,
            MachineState::Hold { stopped: false },
            MachineState::Hold { stopped: true },
            MachineState::Jog,
            MachineState::Alarm { code: 1 },
            MachineState::Alarm { code: 9 },
            MachineState::Homing,
            MachineState::Check,
            MachineState::ToolChange { tool: 2 },
            MachineState::ToolChange { tool: 3 },
        ];
        let words: Vec<String> = states.iter().map(|&s| state_words(s)).collect();
        for (i, w) in words.iter().enumerate() {
            assert_eq!(words.iter().filter(|o| *o == w).count(), 1, "{w}");
            assert_eq!(state_words(states[i]), *w);
        }
        assert_eq!(words[2], "holding (stopping)");
        assert_eq!(words[3], "held");
        assert_eq!(words[1], "Run");
    }
}
