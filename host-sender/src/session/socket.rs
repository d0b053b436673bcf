//! The link to a board through a running `gantry serve` (`crate::commands::serve`): a Unix stream
//! socket named after the port in a private directory, refused when another user owns it.
//!
//! Discovery: a command given `--port P` (or `GANTRY_PORT`, or the one plugged-in board) first
//! tries the socket of P; when no server answers there it opens P itself.

use crate::link::Transport;
use anyhow::Context;
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The socket of the server for `port`: `gantry-<port path, '/' as '_'>.sock` in the private
/// directory [`socket_dir`]; the port path is resolved first, so a link to a port and the port
/// itself find the same server.
pub(crate) fn socket_name(port: &str) -> String {
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
pub(crate) fn socket_dir(create: bool) -> anyhow::Result<Option<PathBuf>> {
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
pub(crate) fn socket_path(port: &str) -> anyhow::Result<Option<PathBuf>> {
    Ok(socket_dir(false)?.map(|d| d.join(socket_name(port))))
}

/// Refuses an existing `path` that is not this user's socket; false when nothing is there.
pub(crate) fn check_socket(path: &Path) -> anyhow::Result<bool> {
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
    /// The server closed the link.
    closed: bool,
}

impl SocketTransport {
    /// Connects to the server of `port`, if one runs (`None`: no socket, or nobody listens).
    /// A socket of another user is refused (an error), never used. A socket directory that is
    /// not this user's private one is never used either, but it cannot hold this user's server
    /// (serve refuses to start there): the command is told why and opens the port itself.
    pub fn connect(port: &str) -> anyhow::Result<Option<Self>> {
        let path = match socket_path(port) {
            Ok(Some(path)) => path,
            Ok(None) => return Ok(None),
            Err(e) => {
                eprintln!(
                    "gantry: {e:#}\n  no gantry serve of yours can be there: opening {port} directly"
                );
                return Ok(None);
            }
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
            closed: false,
        }))
    }
}

impl Transport for SocketTransport {
    fn closed(&self) -> bool {
        self.closed
    }

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
                Err(e) => {
                    self.closed = true;
                    return Err(e).context("gantry serve closed the link");
                }
            }
        }
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        let mut buf = [0u8; 4096];
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => {
                    self.closed = true;
                    anyhow::bail!(
                        "gantry serve closed the link (the server ended, or the board restarted)"
                    )
                }
                Ok(n) => into.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => return Ok(()),
                Err(e) => {
                    self.closed = true;
                    return Err(e).context("gantry serve closed the link");
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
