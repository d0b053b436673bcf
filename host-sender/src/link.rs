//! The host's side of the board link: a byte transport (USB serial port or the emulated board) and
//! the protocol endpoint on top of it.

use crate::emulator::{EmulatedBoard, COUNTS_PER_MS};
use anyhow::{bail, Context};
use gantry_proto::{BoardMsg, Config, HostEndpoint, HostMsg, Lane, LinkEvent, SendError};
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
}

/// The emulated board as a transport: waiting runs it on virtual time.
impl Transport for EmulatedBoard {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.receive(bytes);
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        into.extend(self.take_output());
        Ok(())
    }

    fn wait(&mut self, ms: u32) {
        self.run_for(ms as u64 * COUNTS_PER_MS);
    }

    fn now_ms(&self) -> u32 {
        EmulatedBoard::now_ms(self)
    }
}

/// How long the sender keeps trying to reopen a port that went away (USB cable pulled, board
/// re-enumerating) before it gives up.
pub const REOPEN_FOR: Duration = Duration::from_secs(60);

/// A real board on a USB serial port (CDC-ACM). When the port fails (the cable was pulled) it is
/// reopened by path until [`REOPEN_FOR`] has passed; the protocol then resynchronises, and the board,
/// which held the job meanwhile, continues it without losing or repeating a block.
pub struct SerialTransport {
    path: String,
    port: Option<Box<dyn serialport::SerialPort>>,
    start: Instant,
}

fn open_port(path: &str) -> serialport::Result<Box<dyn serialport::SerialPort>> {
    serialport::new(path, 115_200)
        .timeout(Duration::from_millis(1))
        .open()
}

impl SerialTransport {
    pub fn open(path: &str) -> anyhow::Result<Self> {
        let port = open_port(path).with_context(|| format!("cannot open serial port {path}"))?;
        Ok(SerialTransport {
            path: path.to_owned(),
            port: Some(port),
            start: Instant::now(),
        })
    }

    /// The open port, reopening it after a failure.
    fn port(&mut self) -> anyhow::Result<&mut Box<dyn serialport::SerialPort>> {
        if self.port.is_none() {
            let since = Instant::now();
            eprintln!("gantry: {} went away; reopening it", self.path);
            loop {
                match open_port(&self.path) {
                    Ok(p) => {
                        eprintln!("gantry: {} is back", self.path);
                        self.port = Some(p);
                        break;
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

impl Transport for SerialTransport {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        if self.port()?.write_all(bytes).is_err() {
            // Lost frames are retransmitted by the protocol once the port is back.
            self.port = None;
        }
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        let mut buf = [0u8; 512];
        loop {
            match self.port()?.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => into.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => return Ok(()),
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

/// A connected link: endpoint + transport.
pub struct Client<T: Transport> {
    pub transport: T,
    endpoint: HostEndpoint,
    rx: Vec<u8>,
    /// Alarm and limit reports received so far (kept even when a caller skips messages).
    notices: Vec<BoardMsg>,
}

impl<T: Transport> Client<T> {
    /// Opens the link and completes the version handshake (within `timeout_ms` of link time).
    pub fn connect(transport: T, timeout_ms: u32) -> anyhow::Result<Self> {
        let nonce = std::process::id() ^ 0x5eed_0000;
        let mut c = Client {
            transport,
            endpoint: HostEndpoint::new_host(Config::USB_MS, nonce),
            rx: Vec::new(),
            notices: Vec::new(),
        };
        let start = c.transport.now_ms();
        loop {
            c.pump(1)?;
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
                bail!("no answer from the board within {timeout_ms} ms");
            }
        }
    }

    /// Exchanges bytes, then lets `ms` milliseconds pass.
    pub fn pump(&mut self, ms: u32) -> anyhow::Result<()> {
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
    pub fn try_send(&mut self, msg: HostMsg) -> Result<(), Box<HostMsg>> {
        self.endpoint
            .send(msg)
            .map_err(|SendError::Full(m)| Box::new(m))
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

    /// Room in the queued lane (lines that can be sent now).
    pub fn queued_room(&self) -> usize {
        self.endpoint.send_capacity(Lane::Queued)
    }

    /// The next message from the board.
    pub fn recv(&mut self) -> Option<BoardMsg> {
        let msg = self.endpoint.recv()?;
        if matches!(msg, BoardMsg::Alarm { .. } | BoardMsg::Limit { .. }) {
            self.notices.push(msg.clone());
        }
        Some(msg)
    }

    /// The alarm and limit reports received since the last call, oldest first.
    pub fn take_notices(&mut self) -> Vec<BoardMsg> {
        std::mem::take(&mut self.notices)
    }

    /// Closes the link and gives the transport back (the board keeps its state).
    pub fn into_transport(self) -> T {
        self.transport
    }

    pub fn stats(&self) -> gantry_proto::LinkStats {
        self.endpoint.stats()
    }
}
