//! `gantry serve`'s socket lives in a private runtime directory (mode 0700),
//! is itself mode 0600 whatever the umask, and a command refuses a socket or directory that
//! belongs to another user (it could be a fake board planted there) with a clear message.
//!
//! The planted socket is simulated by changing the owner of the real server's socket (or of
//! the directory) to another user, which needs root; run as another user, the tests say so and
//! skip (CI runs them as root).

mod serial_support;

use serial_support::*;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);
/// The user the planted socket belongs to (`nobody`).
const OTHER_UID: u32 = 65534;

fn is_root() -> bool {
    std::fs::metadata("/proc/self")
        .map(|m| m.uid())
        .unwrap_or(1)
        == 0
}

/// `gantry ARGS` with `env` set (`None`: removed), run to its end.
fn gantry_env(args: &[&str], env: &[(&str, Option<&Path>)], umask: Option<&str>) -> Running {
    let mut cmd = match umask {
        Some(m) => {
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("umask {m}; exec \"$0\" \"$@\""))
                .arg(GANTRY)
                .args(args);
            c
        }
        None => {
            let mut c = Command::new(GANTRY);
            c.args(args);
            c
        }
    };
    for (k, v) in env {
        match v {
            Some(v) => cmd.env(k, v),
            None => cmd.env_remove(k),
        };
    }
    spawn_cmd(&mut cmd)
}

/// The sockets under `dir` (recursively).
fn sockets_under(dir: &Path) -> Vec<PathBuf> {
    use std::os::unix::fs::FileTypeExt;
    let mut found = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return found;
    };
    for e in entries.flatten() {
        let Ok(t) = e.file_type() else { continue };
        if t.is_socket() {
            found.push(e.path());
        } else if t.is_dir() {
            found.extend(sockets_under(&e.path()));
        }
    }
    found
}

fn mode(p: &Path) -> u32 {
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

/// Starts `gantry serve` for `emu` with `env` and waits until it serves.
fn serve(emu: &Emulator, env: &[(&str, Option<&Path>)], umask: Option<&str>) -> Running {
    let server = gantry_env(&["serve", "--port", emu.port()], env, umask);
    assert!(
        wait_for(10 * S, || server.stderr().contains("is served on")),
        "serve did not start: {}",
        server.stderr()
    );
    server
}

#[test]
fn the_socket_is_0600_in_a_0700_directory_whatever_the_umask() {
    let dir = Dir::new("serve-mode");
    let emu = Emulator::start(&dir, None);
    // No XDG_RUNTIME_DIR: the directory of the user under the temporary directory.
    let tmp = dir.0.join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let env = [("XDG_RUNTIME_DIR", None), ("TMPDIR", Some(tmp.as_path()))];
    let server = serve(&emu, &env, Some("002"));
    let socks = sockets_under(&tmp);
    assert_eq!(
        socks.len(),
        1,
        "one socket under {}: {socks:?}",
        tmp.display()
    );
    let sock = &socks[0];
    assert_eq!(mode(sock), 0o600, "{}", sock.display());
    let parent = sock.parent().unwrap();
    assert_ne!(
        parent,
        tmp,
        "the socket is in a directory of its own, not in {}",
        tmp.display()
    );
    assert_eq!(mode(parent), 0o700, "{}", parent.display());
    // Commands find it (with the same environment) and reach the board through it.
    let out = gantry_env(&["status", "--port", emu.port()], &env, None).wait(10 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.starts_with("state:     Idle"), "{out:?}");
    drop(server);
}

#[test]
fn a_socket_planted_by_another_user_is_refused_with_a_clear_message() {
    if !is_root() {
        eprintln!("skipped: planting another user's socket needs root (chown)");
        return;
    }
    let dir = Dir::new("serve-planted");
    let emu = Emulator::start(&dir, None);
    let runtime = dir.0.join("runtime");
    std::fs::create_dir(&runtime).unwrap();
    std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700)).unwrap();
    let env = [("XDG_RUNTIME_DIR", Some(runtime.as_path()))];
    let server = serve(&emu, &env, None);
    let socks = sockets_under(&runtime);
    assert_eq!(socks.len(), 1, "{socks:?}");
    // Another user's socket where the server's would be: a command must not talk to it.
    std::os::unix::fs::chown(&socks[0], Some(OTHER_UID), Some(OTHER_UID)).unwrap();
    for cmd in ["abort", "status"] {
        let out = gantry_env(&[cmd, "--port", emu.port()], &env, None).wait(10 * S);
        assert_ne!(out.code, Some(0), "{cmd}: {out:?}");
        assert!(
            out.stderr.contains("not owned by you")
                && out.stderr.contains(&socks[0].display().to_string()),
            "{cmd}: {out:?}"
        );
        assert!(!out.stdout.contains("state:"), "{cmd}: {out:?}");
    }
    drop(server);
}

#[test]
fn a_runtime_directory_of_another_user_is_refused() {
    if !is_root() {
        eprintln!("skipped: planting another user's directory needs root (chown)");
        return;
    }
    let dir = Dir::new("serve-planted-dir");
    let emu = Emulator::start(&dir, None);
    // No XDG_RUNTIME_DIR: gantry's directory in the temporary directory is `gantry-<uid>`;
    // another user made it first.
    let tmp = dir.0.join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let planted = tmp.join("gantry-0");
    std::fs::create_dir(&planted).unwrap();
    std::fs::set_permissions(&planted, std::fs::Permissions::from_mode(0o777)).unwrap();
    std::os::unix::fs::chown(&planted, Some(OTHER_UID), Some(OTHER_UID)).unwrap();
    let env = [("XDG_RUNTIME_DIR", None), ("TMPDIR", Some(tmp.as_path()))];
    // serve refuses to put its socket there.
    let out = gantry_env(&["serve", "--port", emu.port()], &env, None).wait(10 * S);
    assert_ne!(out.code, Some(0), "{out:?}");
    assert!(
        out.stderr.contains("not owned by you")
            && out.stderr.contains(&planted.display().to_string()),
        "{out:?}"
    );
    // A direct-port command needs no server: it says why it ignores the directory and works.
    let out = gantry_env(&["status", "--port", emu.port()], &env, None).wait(10 * S);
    assert_eq!(out.code, Some(0), "{out:?}");
    assert!(out.stdout.contains("state:"), "{out:?}");
    assert!(
        out.stderr.contains("not owned by you")
            && out.stderr.contains("opening")
            && out.stderr.contains(&planted.display().to_string()),
        "{out:?}"
    );
    assert!(sockets_under(&tmp).is_empty());
}
