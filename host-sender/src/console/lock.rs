//! The console's lock: a secret serve makes at start (256 bits from the kernel's random source),
//! kept in a file only its user can read in serve's private runtime directory
//! (`crate::session::socket::socket_dir`, mode 0700) and printed once as the console's URL.
//! Every request must carry it: as the `token` query parameter (the printed URL; the page is then
//! given a cookie), the cookie, or an `Authorization: Bearer` header (scripts, reading the file).
//! Without it the answer is 401 and nothing is done, so another account on the same computer,
//! which can reach a loopback port but not the directory, cannot move the machine.
//!
//! The secret outlives serve ([`Lock::open`]): a serve started again takes the file's token when
//! the file is still exactly what serve wrote (a regular file, not a link, one name, this user's,
//! mode 0600, 64 hex digits), so a page left open comes back by itself after a restart. That
//! gives nothing away: whoever can read the file could read it while serve ran. Anything else
//! in its place, or `--new-token`, makes a new secret.

use super::http::Head;
use anyhow::Context;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The console's secret and where it is kept.
pub(crate) struct Lock {
    token: String,
    /// The cookie's name: one per console port (browsers share cookies across a host's ports).
    cookie: String,
    file: PathBuf,
}

impl Lock {
    /// The console's lock on `http_port`: the secret kept in `file` when it is one serve wrote
    /// and `renew` is false (see the module's doc), else a new one. Says which on stderr.
    pub(crate) fn open(file: &Path, http_port: u16, renew: bool) -> anyhow::Result<Lock> {
        if !renew {
            if let Some(token) = kept_token(file) {
                eprintln!("serve: the console keeps its token (--new-token makes a new one)");
                return Ok(Lock {
                    token,
                    cookie: format!("gantry_console_{http_port}"),
                    file: file.to_owned(),
                });
            }
        }
        Lock::create(file, http_port)
    }

    /// Makes a new secret for the console on `http_port` and writes it to `file` (replacing an
    /// earlier one of this user; created afresh, mode 0600, never through a link).
    pub(crate) fn create(file: &Path, http_port: u16) -> anyhow::Result<Lock> {
        let mut bytes = [0u8; 32];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| f.read_exact(&mut bytes))
            .context("cannot read /dev/urandom for the console's token")?;
        let token: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        match std::fs::symlink_metadata(file) {
            Ok(_) => std::fs::remove_file(file)
                .with_context(|| format!("cannot replace {}", file.display()))?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", file.display())),
        }
        {
            use std::os::unix::fs::OpenOptionsExt;
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .mode(0o600)
                .open(file)
                .with_context(|| format!("cannot create {}", file.display()))?;
            f.write_all(format!("{token}\n").as_bytes())
                .with_context(|| format!("cannot write {}", file.display()))?;
        }
        Ok(Lock {
            token,
            cookie: format!("gantry_console_{http_port}"),
            file: file.to_owned(),
        })
    }

    pub(crate) fn token(&self) -> &str {
        &self.token
    }

    pub(crate) fn file(&self) -> &Path {
        &self.file
    }

    /// The request carries the token (query, cookie or bearer header).
    pub(crate) fn admits(&self, head: &Head) -> bool {
        [
            head.query_param("token"),
            head.cookie(&self.cookie),
            head.bearer(),
        ]
        .into_iter()
        .flatten()
        .any(|t| same(t.as_bytes(), self.token.as_bytes()))
    }

    /// The token came in the query (the printed URL): the page is given the cookie.
    pub(crate) fn in_query(&self, head: &Head) -> bool {
        head.query_param("token")
            .is_some_and(|t| same(t.as_bytes(), self.token.as_bytes()))
    }

    /// The `Set-Cookie` header line that lets the page's later requests in.
    pub(crate) fn set_cookie(&self) -> String {
        format!(
            "Set-Cookie: {}={}; Path=/; HttpOnly; SameSite=Strict\r\n",
            self.cookie, self.token
        )
    }
}

/// The token in `file` if the file is exactly what [`Lock::create`] writes: a regular file (not
/// followed if a link), one link, owned by this user, mode 0600, a line of 64 hex digits.
fn kept_token(file: &Path) -> Option<String> {
    use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(nix::fcntl::OFlag::O_NOFOLLOW.bits())
        .open(file)
        .ok()?;
    let m = f.metadata().ok()?;
    let uid = nix::unistd::Uid::current().as_raw();
    if !m.is_file()
        || m.nlink() != 1
        || m.uid() != uid
        || m.mode() & 0o777 != 0o600
        || m.len() != 65
    {
        return None;
    }
    let mut text = String::new();
    f.take(65).read_to_string(&mut text).ok()?;
    let token = text.strip_suffix('\n')?;
    (token.len() == 64
        && token
            .bytes()
            .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase()))
    .then(|| token.to_owned())
}

/// Compares in a time that does not depend on where the first difference is.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

/// The token file's name for the serve of `port`, beside its socket.
pub(crate) fn token_name(port: &str) -> String {
    let sock = crate::session::socket::socket_name(port);
    format!("{}.console-token", sock.trim_end_matches(".sock"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_is_kept_only_in_the_file_serve_wrote() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("gantry-lock-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("t.console-token");
        let first = Lock::open(&file, 1, false).unwrap().token;
        assert_eq!(Lock::open(&file, 1, false).unwrap().token, first);
        // --new-token, a readable file, a link or other contents: a new secret.
        let renewed = Lock::open(&file, 1, true).unwrap().token;
        assert_ne!(renewed, first);
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o644)).unwrap();
        let after_chmod = Lock::open(&file, 1, false).unwrap().token;
        assert_ne!(after_chmod, renewed);
        let other = dir.join("planted");
        std::fs::write(&other, format!("{}\n", "a".repeat(64))).unwrap();
        std::fs::set_permissions(&other, std::fs::Permissions::from_mode(0o600)).unwrap();
        std::fs::remove_file(&file).unwrap();
        std::os::unix::fs::symlink(&other, &file).unwrap();
        let via_link = Lock::open(&file, 1, false).unwrap();
        assert_ne!(via_link.token, "a".repeat(64));
        assert!(!std::fs::symlink_metadata(&file)
            .unwrap()
            .file_type()
            .is_symlink());
        std::fs::write(&file, "not a token\n").unwrap();
        assert_eq!(kept_token(&file), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_comparison_needs_every_byte() {
        assert!(same(b"abcd", b"abcd"));
        assert!(!same(b"abcd", b"abce"));
        assert!(!same(b"abc", b"abcd"));
        assert!(!same(b"", b"a"));
    }
}
