//! `gantry emulate --tcp ADDR`: the emulated board behind a TCP listener, as grblHAL's network
//! builds offer, for senders that connect by address (docs/grbl.md). One client at a time; a
//! client connecting is the port opening (DTR up), its disconnect is the port closing (DTR
//! drop: the next connection chooses its protocol again). The board runs in the same loop as
//! behind the pty (`crate::emulate::run_board`), so grbl and the framed protocol both work, and the
//! log is the same.

use crate::emulate::{load_state, new_board, run_board, wait_on, HostSide, Polled};
use anyhow::Context;
use nix::poll::{PollFd, PollFlags};
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Refuses an address other hosts can reach unless `allow_remote` (a CNC machine must not take
/// commands from the network by accident); warns when allowed.
pub(crate) fn check_address(addr: &SocketAddr, allow_remote: bool) -> anyhow::Result<()> {
    if addr.ip().is_loopback() {
        return Ok(());
    }
    anyhow::ensure!(
        allow_remote,
        "--tcp {addr}: not a loopback address; anyone who reaches it can move the machine. \
         Use 127.0.0.1, or add --allow-remote if you mean it"
    );
    eprintln!("emulate: WARNING: listening on {addr}, reachable from other hosts; anyone who reaches it can move the machine");
    Ok(())
}

/// Bytes read from the client's socket ahead of the board, at most: a pty's buffer.
const SOCKET_BUFFER: usize = 4096;

/// The listener and its one client.
struct TcpHost {
    listener: TcpListener,
    client: Option<TcpStream>,
    /// Read from the socket, not yet taken by the board.
    pending: Vec<u8>,
}

impl HostSide for TcpHost {
    fn poll(&mut self, wait: Duration, buf: &mut [u8]) -> anyhow::Result<Polled> {
        if self.client.is_none() {
            match self.listener.accept() {
                Ok((c, peer)) => {
                    // Blocking, read only when poll says so; a stuck client cannot stall the
                    // board for longer than the write timeout.
                    c.set_nonblocking(false)?;
                    c.set_write_timeout(Some(Duration::from_millis(100)))?;
                    let _ = c.set_nodelay(true);
                    eprintln!("emulate: {peer} connected");
                    self.client = Some(c);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                Err(e) => return Err(e.into()),
            }
        }
        let Some(c) = self.client.as_mut() else {
            return Ok(Polled {
                open: false,
                read: 0,
            });
        };
        // The socket is read into `pending` up to a pty's buffer (`SOCKET_BUFFER`); the board
        // is handed only what it has room for (`buf`). Beyond that nothing is read: the bytes
        // wait in the socket and the sender's writes block, as behind a USB board's endpoint.
        let room = SOCKET_BUFFER.saturating_sub(self.pending.len());
        let events = if room > 0 {
            PollFlags::POLLIN
        } else {
            PollFlags::empty()
        };
        let wait = if self.pending.is_empty() || room == 0 {
            wait
        } else {
            Duration::ZERO
        };
        let mut fds = [PollFd::new(c.as_raw_fd(), events)];
        let _ = wait_on(&mut fds, wait);
        let ev = fds[0].revents().unwrap_or(PollFlags::empty());
        if room > 0 && ev.intersects(PollFlags::POLLIN | PollFlags::POLLHUP | PollFlags::POLLERR) {
            let mut chunk = [0u8; SOCKET_BUFFER];
            match c.read(&mut chunk[..room]) {
                Ok(n) if n > 0 => self.pending.extend_from_slice(&chunk[..n]),
                _ => {
                    // Gone: what it sent and the board did not take goes with it.
                    eprintln!("emulate: client disconnected");
                    self.client = None;
                    self.pending.clear();
                    return Ok(Polled {
                        open: false,
                        read: 0,
                    });
                }
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(Polled {
            open: true,
            read: n,
        })
    }

    fn close_drops_dtr(&self) -> bool {
        true
    }

    fn send(&mut self, bytes: &[u8]) {
        if let Some(c) = self.client.as_mut() {
            if c.write_all(bytes).is_err() {
                // Seen as closed at the next poll.
                let _ = c.shutdown(std::net::Shutdown::Both);
            }
        }
    }
}

/// Runs the board behind `addr` until SIGINT or SIGTERM.
pub fn run(
    addr: SocketAddr,
    allow_remote: bool,
    setup: Option<PathBuf>,
    state: Option<PathBuf>,
    opts: &crate::emulate::BoardOptions,
) -> anyhow::Result<ExitCode> {
    check_address(&addr, allow_remote)?;
    let (setup, origin) = load_state(state.as_deref(), setup)?;
    let axes = setup.axis_count;
    let mut board = new_board(setup, state.as_deref(), opts)?;
    let listener = TcpListener::bind(addr).with_context(|| format!("cannot listen on {addr}"))?;
    listener.set_nonblocking(true)?;
    // No host until a client connects.
    board.set_dtr(false);
    let ready = format!(
        "emulate: board ready on tcp {}, {axes} axes; {origin}",
        listener.local_addr().map_or(addr, |a| a)
    );
    let mut host = TcpHost {
        listener,
        client: None,
        pending: Vec::new(),
    };
    run_board(board, &mut host, state.as_deref(), &ready)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_loopback_unless_allowed() {
        assert!(check_address(&"127.0.0.1:2323".parse().unwrap(), false).is_ok());
        assert!(check_address(&"[::1]:2323".parse().unwrap(), false).is_ok());
        assert!(check_address(&"0.0.0.0:2323".parse().unwrap(), false).is_err());
        assert!(check_address(&"0.0.0.0:2323".parse().unwrap(), true).is_ok());
    }
}
