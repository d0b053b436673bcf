//! `gantry emulate --tcp ADDR`: the emulated board behind a TCP listener, as grblHAL's network
//! builds offer, for senders that connect by address (docs/grbl.md). One client at a time; a
//! client connecting is the port opening (DTR up), its disconnect is the port closing (DTR
//! drop: the next connection chooses its protocol again). Bytes go to and from the same board
//! the pty serves (`crate::emulate`), so grbl and the framed protocol both work.

use crate::emulate::{load_state, new_board, save_state};
use anyhow::Context;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Refuses an address other hosts can reach unless `allow_remote` (a CNC machine must not take
/// commands from the network by accident); warns when allowed.
pub fn check_address(addr: &SocketAddr, allow_remote: bool) -> anyhow::Result<()> {
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

/// Runs the board behind `addr` until SIGINT or SIGTERM.
pub fn run(
    addr: SocketAddr,
    allow_remote: bool,
    setup: Option<PathBuf>,
    state: Option<PathBuf>,
    probe_targets: &[String],
    cpu: Option<crate::cpu_model::CpuModel>,
) -> anyhow::Result<ExitCode> {
    check_address(&addr, allow_remote)?;
    let setup = load_state(state.as_deref(), setup)?;
    let mut board = new_board(setup, probe_targets, cpu)?;
    let listener = TcpListener::bind(addr).with_context(|| format!("cannot listen on {addr}"))?;
    listener.set_nonblocking(true)?;
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::SeqCst))
        .context("cannot install the SIGINT/SIGTERM handler")?;
    board.set_dtr(false);
    eprintln!(
        "emulate: board ready on tcp {}",
        listener.local_addr().map_or(addr, |a| a)
    );
    let start = Instant::now();
    let mut client: Option<TcpStream> = None;
    let mut buf = [0u8; 4096];
    while !stop.load(Ordering::SeqCst) {
        if client.is_none() {
            match listener.accept() {
                Ok((c, peer)) => {
                    c.set_nonblocking(true)?;
                    let _ = c.set_nodelay(true);
                    eprintln!("emulate: {peer} connected");
                    board.set_dtr(true);
                    client = Some(c);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                Err(e) => return Err(e.into()),
            }
        }
        let mut closed = false;
        if let Some(c) = client.as_mut() {
            match c.read(&mut buf) {
                Ok(0) => closed = true,
                Ok(n) => board.receive(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                Err(_) => closed = true,
            }
        }
        let behind = (start.elapsed().as_millis() as u64).saturating_sub(board.now_ms() as u64);
        if behind > 0 {
            board.run_ms(behind.min(50));
        }
        let out = board.take_output();
        if let (Some(c), false) = (client.as_mut(), out.is_empty()) {
            if c.write_all(&out).is_err() {
                closed = true;
            }
        }
        if closed {
            eprintln!("emulate: client disconnected (DTR drop)");
            client = None;
            board.set_dtr(false);
        }
        if board.link.take_setup_changed() {
            if let Some(st) = &state {
                save_state(st, board.board.setup())?;
                eprintln!("emulate: setup saved to {}", st.display());
            }
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    eprintln!("emulate: stopped");
    Ok(ExitCode::SUCCESS)
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
