//! `gantry serve --port P`: one session (`crate::session::Session`) owns the board's port for as
//! long as it runs and shares itself with other `gantry` commands through a Unix socket
//! (`crate::session::socket`), so anything a command can do, it can do while a job runs.
//!
//! Each command that connects speaks the ordinary link protocol (`docs/protocol.md`) to a board
//! endpoint the server keeps for it ([`Peer`]), exactly as it would over the USB port. The server
//! passes on every realtime message a command sends at once (hold, resume, abort, overrides,
//! status request, jog, home, unlock: they never wait behind a job's lines), every queued one as
//! the board's credit allows (taking turns between commands), and every board message to every
//! command (each takes what concerns it). A command's setup request is answered by the server
//! from the session's setup (read once when the server starts, read again after a setup was
//! committed or the board restarted): it never queues behind a job's lines, which fill the
//! board's buffers during short-segment jobs.
//!
//! The job belongs to the command that started it (or took it over with `stream --continue`):
//! when that command's connection ends mid-job (killed, crashed, terminal closed), the server
//! tells the board its job's owner is lost (`HostMsg::OwnerLost`), which the board takes exactly
//! as a lost direct host (hold on the path, spindle and coolant off at rest, the
//! `link.host_lost_stop_s` count: the policy is the core's, `machine/src/device/link.rs`); a later
//! `stream --continue` through the server takes the job over, and the operator resumes it. When
//! the server itself ends, its port closes with DTR dropped: the board holds.

use crate::link::{Client, OnClose, SerialTransport, Transport};
use crate::present::state_words;
use crate::session::socket::{check_socket, socket_dir, socket_name};
use crate::session::{Link, Session};
use anyhow::Context;
use gantry_machine::setup::{Setup, SETUP_BLOB_MAX};
use gantry_proto::channel::{QueuedSink, Refusal, BOARD_TX_QUEUE, RT_QUEUE};
use gantry_proto::messages::{Wire, SETUP_CHUNK_MAX};
use gantry_proto::window::DirectLane;
use gantry_proto::{BoardMsg, Config, Endpoint, HostMsg, Lane, MachineState};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Bytes of line records taken from a command ahead of the board's credit (its own order kept):
/// the credit the server grants each command, as the board grants the bytes of its line ring.
/// Other queued messages cost nothing (as on the board), so a setup request behind a job's lines
/// is seen at once; the command still feels the board's back-pressure through its lines.
const PENDING_BYTES: u16 = 4096;

/// The board's side of the link as the server plays it for one command: board messages out,
/// host messages in, each queued one taken as it arrives ([`Pending`]).
type PeerEndpoint = Endpoint<BoardMsg, HostMsg, BOARD_TX_QUEUE, DirectLane, RT_QUEUE, RT_QUEUE>;

/// A command's queued messages not yet passed to the board.
struct Pending<'a>(&'a mut VecDeque<HostMsg>);

impl Pending<'_> {
    fn room(queue: &VecDeque<HostMsg>) -> u16 {
        let used: u32 = queue.iter().map(|m| u32::from(m.charge())).sum();
        u32::from(PENDING_BYTES).saturating_sub(used) as u16
    }
}

impl QueuedSink for Pending<'_> {
    fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
        let msg: HostMsg = gantry_proto::codec::decode(payload).ok_or(Refusal::Undecodable)?;
        if msg.charge() > self.room() {
            return Err(Refusal::NoRoom);
        }
        let token = msg.stream_token();
        self.0.push_back(msg);
        Ok(token)
    }

    fn room(&self) -> u16 {
        Pending::room(self.0)
    }
}

/// One command connected to the server.
struct Peer {
    stream: UnixStream,
    endpoint: PeerEndpoint,
    /// Queued messages from the command, not yet passed to the board.
    pending: VecDeque<HostMsg>,
    /// Board messages not yet taken by the endpoint (its send queue was full).
    outbox: VecDeque<BoardMsg>,
    /// This command started the running job (or took it over).
    owns_job: bool,
    alive: bool,
}

impl Peer {
    fn new(stream: UnixStream, id: u32) -> Self {
        Peer {
            stream,
            endpoint: PeerEndpoint::new_board(Config::USB_MS, 0x5e7e_0000 ^ id, PENDING_BYTES),
            pending: VecDeque::new(),
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
                Ok(n) => self
                    .endpoint
                    .on_bytes(now, &buf[..n], &mut Pending(&mut self.pending)),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(_) => {
                    self.alive = false;
                    return;
                }
            }
        }
    }

    /// Gives the endpoint what it can take: realtime messages (status reports, alarms) pass
    /// queued ones that wait for the command's credit, as on the board's own link.
    fn flush(&mut self, now: u32) {
        let mut kept = VecDeque::new();
        let mut queued_full = false;
        while let Some(m) = self.outbox.pop_front() {
            let realtime = m.lane() == Lane::Realtime;
            if !realtime && queued_full {
                kept.push_back(m);
                continue;
            }
            if let Err(gantry_proto::SendError::Full(m)) = self.endpoint.send(m) {
                queued_full |= !realtime;
                kept.push_back(m);
            }
        }
        self.outbox = kept;
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

    /// Answers setup request `id` with `blob` as the board would (the answer, the chunks, then
    /// the end).
    fn send_setup(&mut self, id: u32, blob: &[u8]) {
        self.outbox.push_back(BoardMsg::Answer { id, code: 0 });
        for (i, chunk) in blob.chunks(SETUP_CHUNK_MAX).enumerate() {
            self.outbox.push_back(BoardMsg::SetupChunk {
                offset: (i * SETUP_CHUNK_MAX) as u32,
                bytes: heapless::Vec::from_slice(chunk).expect("chunk size"),
            });
        }
        self.outbox.push_back(BoardMsg::SetupEnd {
            len: blob.len() as u32,
            crc32: gantry_proto::crc::crc32(blob),
        });
    }
}

/// The setup as the board sends it.
fn blob_of(setup: &Setup) -> anyhow::Result<Vec<u8>> {
    let mut buf = [0u8; SETUP_BLOB_MAX];
    let blob = setup
        .to_blob(&mut buf)
        .ok_or_else(|| anyhow::anyhow!("the board's setup does not fit {SETUP_BLOB_MAX} bytes"))?;
    Ok(blob.to_vec())
}

/// Runs the server for `port` until SIGINT or SIGTERM, with the operator's console on `http`
/// (`crate::console`) when given.
pub fn run(port: &str, http: Option<&crate::console::Options>) -> anyhow::Result<ExitCode> {
    if let Some(o) = http {
        crate::console::check_address(&o.addr, o.allow_remote)?;
    }
    let dir = socket_dir(true)?.expect("created");
    let mut path = dir.join(socket_name(port));
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
    let link = Client::connect(t, 3000)?;
    let mut board = Session::over(link, Setup::default());
    board
        .reload_setup()
        .map_err(|e| anyhow::anyhow!("{port}: cannot read the board's setup: {e:#}"))?;
    let mut setup_blob = blob_of(board.setup())?;
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
    ctrlc::set_handler(move || {
        s.store(true, Ordering::SeqCst);
        crate::link::request_stop();
    })
    .context("cannot install the SIGINT/SIGTERM handler")?;
    eprintln!("serve: {port} is served on {}", path.display());
    // The console's token file stays when serve ends (console/lock.rs): the next serve takes
    // it again, so an open page comes back by itself.
    if let Some(o) = http {
        crate::console::start(port, o, &dir)?;
    }
    let start = Instant::now();
    let mut peers: Vec<Peer> = Vec::new();
    let mut next_id = 0u32;
    let mut turn = 0usize;
    let mut state = MachineState::Idle;
    let mut to_board: VecDeque<HostMsg> = VecDeque::new();
    // Ids of setup commits passed to the board: an accepting answer changes its setup.
    let mut commits: Vec<u32> = Vec::new();
    let mut setup_stale = false;
    let mut named_at = Instant::now();
    let result = (|| -> anyhow::Result<()> {
        while !stop.load(Ordering::SeqCst) {
            let now = start.elapsed().as_millis() as u32;
            if named_at.elapsed().as_millis() >= 250 {
                named_at = Instant::now();
                follow_port(port, &dir, &mut path);
            }
            while let Ok((stream, _)) = listener.accept() {
                if stream.set_nonblocking(true).is_ok() {
                    next_id += 1;
                    peers.push(Peer::new(stream, next_id));
                }
            }
            let job_owned = peers.iter().any(|p| p.owns_job && p.alive);
            for p in peers.iter_mut() {
                p.read(now);
                // The command's handshake is the endpoint's own business.
                while p.endpoint.poll_event().is_some() {}
                while let Some(msg) = p.endpoint.recv_realtime() {
                    if matches!(msg, HostMsg::TakeOver) {
                        if matches!(
                            state,
                            MachineState::Run
                                | MachineState::Hold { .. }
                                | MachineState::ToolChange { .. }
                        ) && !job_owned
                        {
                            // `stream --continue` taking over a job no command owns: a new
                            // hello makes the board ask for the lines it is missing, and the
                            // take-over tells it the job has an owner again.
                            board.link().reconnect();
                            p.owns_job = true;
                            eprintln!("serve: a command takes over the job");
                            to_board.push_back(HostMsg::TakeOver);
                        }
                        continue;
                    }
                    // A status request already waiting for the board answers this one too (the
                    // board's report goes to every command): a board that stops reading for a
                    // while does not pile them up here.
                    if matches!(msg, HostMsg::StatusRequest)
                        && to_board.iter().any(|m| matches!(m, HostMsg::StatusRequest))
                    {
                        continue;
                    }
                    to_board.push_back(msg);
                }
                // The session's setup answers a setup request at once (the command's earlier
                // queued messages have gone to the board).
                while let (Some(&HostMsg::SetupRequest { id }), false) =
                    (p.pending.front(), setup_stale)
                {
                    p.pending.pop_front();
                    p.send_setup(id, &setup_blob);
                }
            }
            // Realtime messages go first and never wait for queued ones; they wait here only
            // while the board's realtime lane is full (a silent board): the server keeps serving
            // its commands meanwhile.
            while let Some(msg) = to_board.pop_front() {
                let old_board = board
                    .link()
                    .peer_version()
                    .is_some_and(|v| v < gantry_proto::JOG_KEEPALIVE_SINCE);
                if old_board && msg == HostMsg::JogKeepalive {
                    // A 5.0 board cannot decode it (and has no dead-man).
                    continue;
                }
                if let Err(m) = board.link().try_send(msg) {
                    to_board.push_front(*m);
                    break;
                }
            }
            // Queued messages as the board's credit allows, one command's at a time in turn.
            let n = peers.len();
            let mut idle = 0;
            while n > 0 && idle < n && board.link().queued_room() > 0 {
                let p = &mut peers[turn % n];
                turn = turn.wrapping_add(1);
                match p.pending.front() {
                    None | Some(HostMsg::SetupRequest { .. }) => idle += 1,
                    Some(_) => {
                        idle = 0;
                        let msg = p.pending.pop_front().expect("front");
                        match msg {
                            HostMsg::Start { .. } | HostMsg::StartFromLine { .. } => {
                                p.owns_job = true
                            }
                            HostMsg::SetupCommit { id, .. } => commits.push(id),
                            _ => {}
                        }
                        board.link().send(msg)?;
                    }
                }
            }
            board.pump(1)?;
            if board.link().take_board_reset() {
                eprintln!("serve: the board restarted: every command's link is closed");
                peers.clear();
                setup_stale = true;
            }
            while let Some(msg) = board.link().recv() {
                match &msg {
                    BoardMsg::Status(st) => {
                        if st.state != state {
                            eprintln!("serve: board {} line {}", state_words(st.state), st.line);
                            let job_ended =
                                matches!(st.state, MachineState::Idle | MachineState::Alarm { .. });
                            if job_ended {
                                for p in peers.iter_mut() {
                                    p.owns_job = false;
                                }
                            }
                        }
                        state = st.state;
                    }
                    // Only the server asks the board for its setup.
                    BoardMsg::SetupChunk { .. } | BoardMsg::SetupEnd { .. } => continue,
                    // A job may have set work offsets (G10, G28.1, G30.1), which the board keeps
                    // in its setup (`Board::keep_stored_offsets`): read it again.
                    BoardMsg::JobDone { .. } => setup_stale = true,
                    BoardMsg::Answer { id, code } if commits.contains(id) => {
                        commits.retain(|c| c != id);
                        setup_stale |= *code == 0;
                    }
                    _ => {}
                }
                for p in peers.iter_mut() {
                    if let BoardMsg::Status(_) = msg {
                        // Status reports: the newest replaces an unsent older one.
                        p.outbox.retain(|m| !matches!(m, BoardMsg::Status(_)));
                    }
                    p.outbox.push_back(msg.clone());
                }
            }
            if setup_stale {
                // The board's setup changed (committed, or the board restarted): read it again.
                // Whatever else arrives meanwhile is kept for the commands.
                match board.reload_setup().and_then(blob_of) {
                    Ok(blob) => {
                        setup_blob = blob;
                        setup_stale = false;
                    }
                    Err(e) => eprintln!("serve: cannot read the board's setup again: {e:#}"),
                }
            }
            for p in peers.iter_mut() {
                p.endpoint.set_window(Pending::room(&p.pending));
                p.flush(now);
            }
            let gone_owner = peers.iter().any(|p| !p.alive && p.owns_job);
            if gone_owner
                && matches!(
                    state,
                    MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. }
                )
            {
                // A board of protocol 5.0 knows no `OwnerLost`: it gets the feed hold it got
                // before (its spindle then stays on at rest).
                let owner_lost = board
                    .link()
                    .peer_version()
                    .is_some_and(|v| v >= gantry_proto::OWNER_LOST_SINCE);
                eprintln!(
                    "serve: the command that owned the job went away: the board holds it (host lost)"
                );
                // Its lines still waiting here would block every later queued message (a
                // setup commit, a new start): a fresh link to the board drops them, and the
                // board asks for what it misses when a command takes the job over.
                // The handshake completes in later passes, so a board that is silent now (the
                // reason its owner gave up) does not end the server: it answers when it is back;
                // the owner's loss goes on the new link, after its handshake.
                let link = board.link();
                let t = std::mem::replace(link, placeholder()).into_transport();
                *link = Client::unconnected(t);
                link.reconnect();
                to_board.push_back(if owner_lost {
                    HostMsg::OwnerLost
                } else {
                    HostMsg::FeedHold
                });
            }
            peers.retain(|p| p.alive);
        }
        Ok(())
    })();
    let _ = std::fs::remove_file(&path);
    eprintln!("serve: stopped");
    result.map(|()| ExitCode::SUCCESS)
}

/// Keeps the socket named after the device `port` resolves to now: a board that restarts may
/// come back under another device name behind the same link (a new pty of `gantry emulate`, a
/// USB board re-enumerated), and commands find the server by the name their `--port` resolves to
/// ([`socket_name`]). A live socket of another server under the new name is left alone.
fn follow_port(port: &str, dir: &std::path::Path, path: &mut std::path::PathBuf) {
    let now = dir.join(socket_name(port));
    if now == *path || UnixStream::connect(&now).is_ok() {
        return;
    }
    if std::fs::rename(&*path, &now).is_ok() {
        eprintln!("serve: {port} is now served on {}", now.display());
        *path = now;
    }
}

/// A link that is never used, while the real one is being replaced.
fn placeholder() -> Link {
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
