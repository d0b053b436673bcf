//! The host's side of the board link: a byte transport ([`Transport`]: a USB serial port here; the
//! emulated board's and `gantry serve`'s socket implement it where they are defined) and the
//! protocol endpoint on top of it ([`Client`]). It knows nothing of what is connected.

use anyhow::{bail, Context};
use gantry_proto::{BoardMsg, Config, HostEndpoint, HostMsg, Lane, LinkEvent, SendError, Wire};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// Moves bytes to and from a board and keeps its clock.
pub trait Transport {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()>;
    /// Appends whatever the board sent since the last call.
    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()>;
    /// Lets `ms` milliseconds pass (virtual time for the emulator, real time for a port).
    fn wait(&mut self, ms: u32);
    /// The link clock, ms.
    fn now_ms(&self) -> u32;
    /// Gaps in the motion where the step kernel ran dry mid-job: known for the emulated board
    /// only (`EmulatedBoard::starved`).
    fn underruns(&self) -> Option<u64> {
        None
    }
    /// The link has closed for good (the other end hung up): nothing more will come.
    fn closed(&self) -> bool {
        false
    }
}

impl Transport for Box<dyn Transport> {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        (**self).write(bytes)
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        (**self).read(into)
    }

    fn wait(&mut self, ms: u32) {
        (**self).wait(ms)
    }

    fn now_ms(&self) -> u32 {
        (**self).now_ms()
    }

    fn closed(&self) -> bool {
        (**self).closed()
    }

    fn underruns(&self) -> Option<u64> {
        (**self).underruns()
    }
}

/// Set once this process was asked to stop (SIGINT, SIGTERM: each command's handler calls
/// [`request_stop`]): a port that went away is then no longer waited for. A signal is state of the
/// whole process, so this is one flag for it.
static STOP_REQUESTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// This process was asked to stop: [`SerialTransport`] gives up reopening a port at once.
pub(crate) fn request_stop() {
    STOP_REQUESTED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// How long the sender keeps trying to reopen a port that went away (USB cable pulled, board
/// re-enumerating) before it gives up.
pub(crate) const REOPEN_FOR: Duration = Duration::from_secs(60);

/// What closing the port does to the board (the firmware takes a DTR drop as a feed hold, see
/// `firmware/src/control.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum OnClose {
    /// Closing drops DTR (the tty's HUPCL, the default): a running job holds at once. For the
    /// sender that owns a job (`stream`, `serve`): if it dies, the machine stops.
    DropDtr,
    /// Closing leaves DTR up (HUPCL cleared): for one-shot commands (`resume`, `abort`,
    /// `override`, `status` …), whose exit must not undo what they just did.
    KeepDtr,
}

/// A real board on a USB serial port (CDC-ACM). When the port fails (the cable was pulled, the
/// device is gone: ENXIO, EIO) it is reopened by path until [`REOPEN_FOR`] has passed; the
/// protocol then resynchronises, and the board, which held the job meanwhile, waits for the
/// operator to resume it. A board that only stops reading for a while (busy, stalled) is no lost
/// port: the bytes it does not take wait here ([`OUT_LIMIT`]) and the link's window holds the
/// rest back, so the port is never reopened (which would drop DTR and hold the job) for it.
pub struct SerialTransport {
    path: String,
    port: Option<serialport::TTYPort>,
    start: Instant,
    on_close: OnClose,
    /// Bytes written while the board did not read, sent before anything else.
    out: std::collections::VecDeque<u8>,
    /// How often the port was taken for gone and reopened (read by the tests: a board that only
    /// stops reading must never count here).
    #[cfg_attr(not(test), allow(dead_code))]
    went_away: u32,
}

/// Bytes kept for a board that does not read (a few dozen frames). Frames beyond it are dropped
/// whole, as a noisy line loses them: the protocol sends them again, and its windows bound what
/// waits (the link's queues are the back-pressure the commands feel).
pub(crate) const OUT_LIMIT: usize = 16 * 1024;

/// A write error that means the port is gone (the device was unplugged or closed under us), as
/// opposed to a board that is slow to read.
fn port_gone(e: &std::io::Error) -> bool {
    !matches!(
        e.kind(),
        std::io::ErrorKind::TimedOut
            | std::io::ErrorKind::WouldBlock
            | std::io::ErrorKind::Interrupted
    )
}

fn open_port(path: &str, on_close: OnClose) -> serialport::Result<serialport::TTYPort> {
    let port = serialport::new(path, 115_200)
        .timeout(Duration::from_millis(1))
        .open_native()?;
    set_hang_up_on_close(&port, on_close == OnClose::DropDtr);
    set_non_blocking(&port);
    Ok(port)
}

/// Makes writes return what the port took instead of waiting for all of it: the port's poll
/// says "writable" as soon as there is room for one byte, and a blocking write then waits until
/// the board has read the whole chunk — for as long as a stalled board does not read (the
/// caller, `gantry serve`, would stop serving every client meanwhile). Reads still wait at most
/// the port's timeout (poll first).
fn set_non_blocking(port: &serialport::TTYPort) {
    use nix::fcntl::{fcntl, FcntlArg, OFlag};
    use std::os::fd::AsRawFd;
    let fd = port.as_raw_fd();
    // Best effort, as HUPCL: without it a write waits for the board as before.
    if let Ok(flags) = fcntl(fd, FcntlArg::F_GETFL) {
        let flags = OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK;
        let _ = fcntl(fd, FcntlArg::F_SETFL(flags));
    }
}

/// Sets or clears HUPCL: whether closing the port drops DTR (and RTS). Set explicitly both ways:
/// USB serial ports have it set by default, pseudo-terminals not.
fn set_hang_up_on_close(port: &serialport::TTYPort, on: bool) {
    use nix::sys::termios::{tcgetattr, tcsetattr, ControlFlags, SetArg};
    use std::os::fd::AsRawFd;
    let fd = port.as_raw_fd();
    // Best effort: a port whose termios cannot be changed keeps its default.
    if let Ok(mut t) = tcgetattr(fd) {
        t.control_flags.set(ControlFlags::HUPCL, on);
        let _ = tcsetattr(fd, SetArg::TCSANOW, &t);
    }
}

impl SerialTransport {
    /// Opens `path` for the sender that owns a job (closing it holds the job, [`OnClose::DropDtr`]).
    pub fn open(path: &str) -> anyhow::Result<Self> {
        Self::open_with(path, OnClose::DropDtr)
    }

    pub(crate) fn open_with(path: &str, on_close: OnClose) -> anyhow::Result<Self> {
        let port = open_port(path, on_close).map_err(|e| port_error(path, e))?;
        Ok(SerialTransport {
            path: path.to_owned(),
            port: Some(port),
            start: Instant::now(),
            on_close,
            out: Default::default(),
            went_away: 0,
        })
    }

    /// Writes what waits in [`SerialTransport::out`] as far as the board takes it now (without
    /// waiting); the port counts as lost only on an error that says it is gone.
    fn flush_out(&mut self) -> anyhow::Result<()> {
        while !self.out.is_empty() {
            let (head, _) = self.out.as_slices();
            let n = head.len().min(4096);
            let chunk: Vec<u8> = head[..n].to_vec();
            match self.port()?.write(&chunk) {
                Ok(0) => return Ok(()),
                Ok(k) => {
                    self.out.drain(..k);
                }
                Err(e) if port_gone(&e) => {
                    // The device is gone: what waited is lost with it (the protocol resends).
                    self.port = None;
                    self.out.clear();
                    return Ok(());
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                // Not read yet: try again at the next pass.
                Err(_) => return Ok(()),
            }
        }
        Ok(())
    }

    /// The open port, reopening it after a failure.
    fn port(&mut self) -> anyhow::Result<&mut serialport::TTYPort> {
        if self.port.is_none() {
            self.went_away += 1;
            let since = Instant::now();
            eprintln!("gantry: {} went away; reopening it", self.path);
            loop {
                match open_port(&self.path, self.on_close) {
                    Ok(p) => {
                        eprintln!("gantry: {} is back", self.path);
                        self.port = Some(p);
                        break;
                    }
                    Err(e) if STOP_REQUESTED.load(std::sync::atomic::Ordering::SeqCst) => {
                        return Err(e).with_context(|| {
                            format!("{} went away and this process was asked to stop", self.path)
                        })
                    }
                    Err(e) if since.elapsed() > REOPEN_FOR => {
                        return Err(e).with_context(|| {
                            format!("{} did not come back within {REOPEN_FOR:?}", self.path)
                        })
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(200)),
                }
            }
        }
        Ok(self.port.as_mut().expect("opened above"))
    }
}

/// Why a port did not open, with what to do about it.
fn port_error(path: &str, e: serialport::Error) -> anyhow::Error {
    let hint = match e.kind() {
        serialport::ErrorKind::NoDevice => {
            " (in use by another program? a running `gantry serve` owns it: commands reach it through its socket)"
        }
        serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied) => {
            " (permission denied: add yourself to the `dialout` group, then log in again)"
        }
        serialport::ErrorKind::Io(std::io::ErrorKind::NotFound) => " (no such device)",
        _ => "",
    };
    anyhow::anyhow!("cannot open serial port {path}: {e}{hint}")
}

impl Transport for SerialTransport {
    /// Queues a whole frame behind what waits and writes as much as the board takes (at most the
    /// port's 1 ms timeout of waiting).
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        if self.out.len() + bytes.len() > OUT_LIMIT {
            // The board has not read for a while: this frame is lost as on a noisy line.
            return self.flush_out();
        }
        self.out.extend(bytes);
        self.flush_out()
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        self.flush_out()?;
        let mut buf = [0u8; 512];
        loop {
            match self.port()?.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => into.extend_from_slice(&buf[..n]),
                // Nothing (more) to read now (the port is non-blocking: `set_non_blocking`).
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                    ) =>
                {
                    return Ok(())
                }
                // A signal (Ctrl-C) interrupted the read: not a pulled cable.
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => return Ok(()),
                Err(_) => {
                    self.port = None;
                    return Ok(());
                }
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

/// The first request id of a link whose hello nonce is `nonce`: spread over the id space, so
/// links of different processes (through `gantry serve` they see each other's answers) do not
/// take the same ids.
fn first_request_id(nonce: u32) -> u32 {
    nonce.wrapping_mul(0x9E37_79B9)
        ^ (std::time::UNIX_EPOCH
            .elapsed()
            .map_or(0, |d| d.subsec_nanos()))
}

/// Makes every link of this process say hello with its own nonce.
static NONCES: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

/// A connected link: endpoint + transport.
pub struct Client<T: Transport> {
    pub transport: T,
    endpoint: HostEndpoint,
    rx: Vec<u8>,
    /// Alarm and limit reports received so far (kept even when a caller skips messages).
    notices: Vec<BoardMsg>,
    /// Messages put back by a caller that was waiting for another one ([`Client::put_back`]).
    stash: std::collections::VecDeque<BoardMsg>,
    /// Handshakes after the first one that found a restarted board (a new boot id).
    board_resets: u32,
    /// Queued-lane messages handed to the endpoint.
    queued_sent: u64,
    /// Link clock when the last message arrived from the board.
    last_heard_ms: u32,
    /// The id of the last request this link made ([`Client::request_id`]).
    request: u32,
}

impl<T: Transport> Client<T> {
    /// A link that has not said hello yet (see [`Client::connect`]).
    pub(crate) fn unconnected(transport: T) -> Self {
        let nonce = std::process::id()
            ^ 0x5eed_0000
            ^ NONCES.fetch_add(0x101, std::sync::atomic::Ordering::Relaxed);
        Client {
            transport,
            endpoint: HostEndpoint::new_host(Config::USB_MS, nonce),
            rx: Vec::new(),
            notices: Vec::new(),
            stash: Default::default(),
            board_resets: 0,
            queued_sent: 0,
            last_heard_ms: 0,
            request: first_request_id(nonce),
        }
    }

    /// Opens the link and completes the version handshake (within `timeout_ms` of link time).
    pub fn connect(transport: T, timeout_ms: u32) -> anyhow::Result<Self> {
        let mut c = Client::unconnected(transport);
        let start = c.transport.now_ms();
        c.last_heard_ms = start;
        loop {
            c.transport_pump(1)?;
            while let Some(ev) = c.endpoint.poll_event() {
                match ev {
                    LinkEvent::Connected { .. } => return Ok(c),
                    LinkEvent::VersionMismatch { peer_version } => bail!(
                        "the board speaks protocol version {peer_version:#06x}, this gantry {:#06x}: update one of them",
                        gantry_proto::PROTOCOL_VERSION
                    ),
                    _ => {}
                }
            }
            if c.transport.now_ms().wrapping_sub(start) > timeout_ms {
                bail!("no answer from the board within {timeout_ms} ms (expected its handshake: is it a Gantry board, powered, and on this port?)");
            }
        }
    }

    /// Exchanges bytes, then lets `ms` milliseconds pass; link events are noted (board resets).
    pub fn pump(&mut self, ms: u32) -> anyhow::Result<()> {
        self.transport_pump(ms)?;
        while let Some(ev) = self.endpoint.poll_event() {
            if let LinkEvent::Connected {
                board_reset: true, ..
            } = ev
            {
                self.board_resets += 1;
            }
        }
        Ok(())
    }

    /// Says hello again with a new nonce: the board takes it for a returning host and, when a
    /// job runs, asks for every line after the last one it interpreted (a `ProgramRequest`).
    pub fn reconnect(&mut self) {
        self.endpoint.connect();
    }

    /// True once for every restart of the board seen since the link opened (its boot id
    /// changed: whatever it was running is gone).
    pub(crate) fn take_board_reset(&mut self) -> bool {
        if self.board_resets > 0 {
            self.board_resets -= 1;
            return true;
        }
        false
    }

    /// Link time since the last message from the board, ms (it reports its status every
    /// 100 ms, so more than a second means the board or the cable is gone).
    pub(crate) fn silent_for_ms(&self) -> u32 {
        self.transport.now_ms().wrapping_sub(self.last_heard_ms)
    }

    fn transport_pump(&mut self, ms: u32) -> anyhow::Result<()> {
        let now = self.transport.now_ms();
        let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
        while let Some(n) = self.endpoint.poll_transmit(now, &mut frame) {
            self.transport.write(&frame[..n])?;
        }
        self.transport.wait(ms);
        self.rx.clear();
        self.transport.read(&mut self.rx)?;
        let now = self.transport.now_ms();
        self.endpoint.on_bytes(now, &self.rx);
        Ok(())
    }

    /// Queues a message; gives it back when its lane is full (pump and try again).
    pub(crate) fn try_send(&mut self, msg: HostMsg) -> Result<(), Box<HostMsg>> {
        let queued = msg.lane() == Lane::Queued;
        self.endpoint
            .send(msg)
            .map_err(|SendError::Full(m)| Box::new(m))?;
        self.queued_sent += u64::from(queued);
        Ok(())
    }

    /// Queues a message, pumping until there is room.
    pub fn send(&mut self, mut msg: HostMsg) -> anyhow::Result<()> {
        loop {
            match self.try_send(msg) {
                Ok(()) => return Ok(()),
                Err(m) => {
                    msg = *m;
                    self.pump(1)?;
                }
            }
        }
    }

    /// Queued-lane messages handed to the link since it opened.
    pub(crate) fn queued_sent(&self) -> u64 {
        self.queued_sent
    }

    /// Queued-lane messages not yet acknowledged by the board.
    pub(crate) fn unacked_queued(&self) -> usize {
        self.endpoint.unacked(Lane::Queued)
    }

    /// Room in the queued lane (messages that can be queued now).
    pub(crate) fn queued_room(&self) -> usize {
        self.endpoint.send_capacity(Lane::Queued)
    }

    /// The next message from the board (first those put back).
    pub fn recv(&mut self) -> Option<BoardMsg> {
        if let Some(m) = self.stash.pop_front() {
            return Some(m);
        }
        let msg = self.endpoint.recv()?;
        // A message, not just bytes: through `gantry serve` the server's own endpoint keeps
        // answering while the board behind it is silent.
        self.last_heard_ms = self.transport.now_ms();
        if matches!(msg, BoardMsg::Alarm { .. } | BoardMsg::Limit { .. }) {
            self.notices.push(msg.clone());
        }
        Some(msg)
    }

    /// Gives messages back to be received again, in order, before any new one (a caller waiting
    /// for one kind of message keeps the others, e.g. a `ProgramRequest` seen while waiting for a
    /// status).
    pub(crate) fn put_back(&mut self, msgs: impl IntoIterator<Item = BoardMsg>) {
        let mut msgs: Vec<_> = msgs.into_iter().collect();
        msgs.extend(self.stash.drain(..));
        self.stash = msgs.into();
    }

    /// A new id for a request the board answers (`Jog`, `Home`, `Unlock`, `Start`,
    /// `StartFromLine`, `SetupCommit`; docs/protocol.md "Answers"). Ids of different links (other
    /// processes through `gantry serve`) start far apart.
    pub(crate) fn request_id(&mut self) -> u32 {
        self.request = self.request.wrapping_add(1);
        self.request
    }

    /// Waits (at most `limit_ms` of link time) for the board's answer to request `id`: 0 =
    /// accepted, else the refusal's code; `None` when none came. Whatever the board queued
    /// before the answer is not about this request (an earlier command's answer or error, or
    /// another command's through `gantry serve`) and is passed over; what follows the answer
    /// stays for the caller, and alarm and limit reports are kept as notices.
    pub(crate) fn await_answer(&mut self, id: u32, limit_ms: u32) -> anyhow::Result<Option<u16>> {
        let start = self.transport.now_ms();
        loop {
            while let Some(msg) = self.recv() {
                if let BoardMsg::Answer { id: got, code } = msg {
                    if got == id {
                        return Ok(Some(code));
                    }
                }
            }
            if self.transport.now_ms().wrapping_sub(start) > limit_ms {
                return Ok(None);
            }
            self.pump(5)?;
        }
    }

    /// The alarm and limit reports received since the last call, oldest first.
    pub(crate) fn take_notices(&mut self) -> Vec<BoardMsg> {
        std::mem::take(&mut self.notices)
    }

    /// Closes the link and gives the transport back (the board keeps its state).
    pub fn into_transport(self) -> T {
        self.transport
    }

    pub(crate) fn stats(&self) -> gantry_proto::LinkStats {
        self.endpoint.stats()
    }

    /// The protocol version the board (or `gantry serve`) announced in the handshake: a message
    /// newer than its minor must not be sent to it (docs/protocol.md §8).
    pub(crate) fn peer_version(&self) -> Option<u16> {
        self.endpoint.peer_version()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serialport::SerialPort;

    /// Frame `seq` of the test: [`FRAME`] bytes, its number repeated (so a cut frame shows).
    fn frame(seq: u32) -> Vec<u8> {
        seq.to_le_bytes()
            .iter()
            .copied()
            .cycle()
            .take(FRAME)
            .collect()
    }

    /// Not a divisor of the 4 KiB chunks `flush_out` writes, nor of [`OUT_LIMIT`]: frames
    /// straddle the chunks the port takes in part.
    const FRAME: usize = 100;

    /// A board that stops reading (a pty whose master is never read) is no lost port: the
    /// transport keeps what the port does not take, up to [`OUT_LIMIT`], drops later frames whole,
    /// never reopens, and once the board reads again every kept frame arrives whole and in order.
    #[test]
    fn a_board_that_stops_reading_is_no_lost_port_and_kept_frames_arrive_whole_in_order() {
        let (mut master, slave) = serialport::TTYPort::pair().unwrap();
        let path = slave.name().unwrap();
        // The transport opens the slave by path, as it opens a board.
        drop(slave);
        let mut t = SerialTransport::open_with(&path, OnClose::KeepDtr).unwrap();
        // Far past what the pty holds (some 64 KiB) plus OUT_LIMIT, on a thread: a write that
        // waits for the board to read (a blocking port) would never return.
        let (done, finished) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut kept = Vec::new();
            for seq in 0..3000u32 {
                let f = frame(seq);
                if t.out.len() + f.len() <= OUT_LIMIT {
                    kept.push(seq);
                }
                t.write(&f).unwrap();
                assert_eq!(t.went_away, 0, "frame {seq}: the port was taken for gone");
                assert!(t.port.is_some());
            }
            let _ = done.send((t, kept));
        });
        let (mut t, kept) = finished
            .recv_timeout(Duration::from_secs(60))
            .expect("the writes ended (a write waited for the board to read, or failed)");
        assert!(
            t.out.len() + FRAME > OUT_LIMIT,
            "the port never filled: {} bytes wait",
            t.out.len()
        );
        assert!(kept.len() < 3000, "no frame was dropped");
        // The board reads again: everything kept arrives, the transport passing on what waits.
        master.set_timeout(Duration::from_millis(5)).unwrap();
        let want = kept.len() * FRAME;
        let mut got = Vec::new();
        let mut buf = [0u8; 8192];
        let deadline = Instant::now() + Duration::from_secs(30);
        while got.len() < want && Instant::now() < deadline {
            t.read(&mut Vec::new()).unwrap();
            match master.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => panic!("reading the master: {e}"),
            }
        }
        assert_eq!(got.len(), want, "not every kept frame arrived");
        assert!(t.out.is_empty());
        let arrived: Vec<u32> = got
            .chunks(FRAME)
            .map(|c| {
                let seq = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                assert_eq!(c, frame(seq).as_slice(), "frame {seq} arrived cut");
                seq
            })
            .collect();
        assert_eq!(arrived, kept);
        assert_eq!(t.went_away, 0);
    }
}
