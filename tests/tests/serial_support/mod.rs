//! Running `gantry` as users do: the emulated board as its own process behind a pty
//! (`gantry emulate --pty`), and `gantry` commands as separate processes talking to it. Every wait
//! is bounded, so a failing test ends instead of hanging.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The `gantry` binary (built from host-sender's main.rs, see tests/Cargo.toml).
pub const GANTRY: &str = env!("CARGO_BIN_EXE_gantry-under-test");

/// A fresh directory for one test, removed at the end. It holds the test's own runtime
/// directory (`run/`, mode 0700), the `XDG_RUNTIME_DIR` of every `gantry` the test starts on
/// this thread ([`spawn_cmd`]).
pub struct Dir(pub PathBuf);

thread_local! {
    /// The runtime directory of the newest [`Dir`] of this thread.
    static RUNTIME_DIR: std::cell::RefCell<Option<PathBuf>> = const { std::cell::RefCell::new(None) };
}

impl Dir {
    pub fn new(name: &str) -> Dir {
        use std::os::unix::fs::DirBuilderExt;
        let d = std::env::temp_dir().join(format!("gantry-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let run = d.join("run");
        std::fs::DirBuilder::new().mode(0o700).create(&run).unwrap();
        RUNTIME_DIR.with(|r| *r.borrow_mut() = Some(run));
        Dir(d)
    }

    /// Writes `text` to `name` in the directory and returns its path.
    pub fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Collects a pipe's text on a thread.
fn collect(mut r: impl Read + Send + 'static) -> Arc<Mutex<String>> {
    let text = Arc::new(Mutex::new(String::new()));
    let t = text.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = r.read(&mut buf) {
            if n == 0 {
                break;
            }
            t.lock()
                .unwrap()
                .push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    });
    text
}

/// Polls `done` every 20 ms for at most `limit`.
pub fn wait_for(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    done()
}

/// Starts `cmd` with no stdin or stdout, its stderr collected line by line into the returned
/// log (the emulator's state lines and messages).
pub fn spawn_logged(cmd: &mut Command) -> (Child, Arc<Mutex<String>>) {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = Arc::new(Mutex::new(String::new()));
    let l = log.clone();
    let err = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let mut l = l.lock().unwrap();
            l.push_str(&line);
            l.push('\n');
        }
    });
    (child, log)
}

/// A `gantry emulate --pty` process (killed at the end of the test).
pub struct Emulator {
    child: Child,
    log: Arc<Mutex<String>>,
    pub pty: PathBuf,
}

impl Emulator {
    /// Starts the emulated board at `dir/board`, its flash in `dir/state.toml`, with `setup`
    /// stored first when given; waits (≤ 10 s) until it is ready.
    pub fn start(dir: &Dir, setup: Option<&Path>) -> Emulator {
        Self::start_with(dir, setup, &[])
    }

    /// [`Emulator::start`] with more arguments for `gantry emulate` (probe targets...).
    pub fn start_with(dir: &Dir, setup: Option<&Path>, args: &[&str]) -> Emulator {
        let pty = dir.0.join("board");
        let mut cmd = Command::new(GANTRY);
        cmd.arg("emulate")
            .arg("--pty")
            .arg(&pty)
            .arg("--state")
            .arg(dir.0.join("state.toml"));
        if let Some(s) = setup {
            cmd.arg("--setup").arg(s);
        }
        cmd.args(args);
        let (child, log) = spawn_logged(&mut cmd);
        let e = Emulator { child, log, pty };
        assert!(
            e.wait_log(Duration::from_secs(10), |l| l.contains("board ready")),
            "the emulator did not start: {}",
            e.log()
        );
        e
    }

    pub fn pid(&self) -> nix::unistd::Pid {
        nix::unistd::Pid::from_raw(self.child.id() as i32)
    }

    pub fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }

    /// Waits (bounded) until the log satisfies `pred`.
    pub fn wait_log(&self, limit: Duration, pred: impl Fn(&str) -> bool) -> bool {
        wait_for(limit, || pred(&self.log()))
    }

    /// The port path as a string for `--port`.
    pub fn port(&self) -> &str {
        self.pty.to_str().unwrap()
    }

    /// `(steps, pulses)` per axis from the last state-change line of the log.
    pub fn last_counts(&self) -> (String, String) {
        let log = self.log();
        let line = log
            .lines()
            .rev()
            .find(|l| l.contains(" pulses "))
            .expect("a state line")
            .to_owned();
        let steps = line.split(" steps ").nth(1).unwrap();
        let (steps, pulses) = steps.split_once(" pulses ").unwrap();
        (steps.to_owned(), pulses.to_owned())
    }

    /// [`Emulator::last_counts`] once the last state line is `Idle` (waited for, bounded): a job
    /// that has ended logs its counts, but its line may still be on its way through the pipe.
    #[allow(dead_code)]
    pub fn idle_counts(&self, limit: Duration) -> (String, String) {
        let idle = |log: &str| {
            let last = log.lines().rev().find(|l| l.contains(" pulses "));
            last.is_some_and(|l| l.contains("Idle"))
        };
        self.wait_log(limit, idle);
        self.last_counts()
    }

    /// Stops the process as Ctrl-C does (it writes its state first) and waits for it.
    #[allow(dead_code)]
    pub fn kill_gently(&mut self) {
        let _ = nix::sys::signal::kill(self.pid(), nix::sys::signal::Signal::SIGINT);
        let _ = self.child.wait();
    }

    /// Kills the process at once (a power cut).
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = nix::sys::signal::kill(self.pid(), nix::sys::signal::Signal::SIGCONT);
        self.kill();
    }
}

/// A finished `gantry` run.
#[derive(Debug)]
pub struct Out {
    /// Exit code (`None`: killed by a signal).
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    pub took: Duration,
}

/// A running `gantry` process.
pub struct Running {
    child: Child,
    pub stdin: Option<ChildStdin>,
    stdout: Arc<Mutex<String>>,
    stderr: Arc<Mutex<String>>,
    started: Instant,
}

impl Running {
    pub fn pid(&self) -> nix::unistd::Pid {
        nix::unistd::Pid::from_raw(self.child.id() as i32)
    }

    pub fn stdout(&self) -> String {
        self.stdout.lock().unwrap().clone()
    }

    pub fn stderr(&self) -> String {
        self.stderr.lock().unwrap().clone()
    }

    pub fn signal(&self, sig: nix::sys::signal::Signal) {
        nix::sys::signal::kill(self.pid(), sig).unwrap();
    }

    /// Writes a line to its standard input.
    pub fn answer(&mut self, line: &str) {
        let s = self.stdin.as_mut().expect("stdin piped");
        writeln!(s, "{line}").unwrap();
        s.flush().unwrap();
    }

    /// Waits for the exit (killing it and failing after `limit`).
    pub fn wait(mut self, limit: Duration) -> Out {
        let exited = wait_for(limit, || self.child.try_wait().unwrap().is_some());
        if !exited {
            let _ = self.child.kill();
            let _ = self.child.wait();
            panic!(
                "gantry did not exit within {limit:?}\nstdout:\n{}\nstderr:\n{}",
                self.stdout(),
                self.stderr()
            );
        }
        let status = self.child.wait().unwrap();
        // Let the reader threads take the last bytes.
        std::thread::sleep(Duration::from_millis(50));
        Out {
            code: status.code(),
            stdout: self.stdout(),
            stderr: self.stderr(),
            took: self.started.elapsed(),
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `gantry ARGS` with standard input piped (for answers) and its output collected.
pub fn spawn(args: &[&str]) -> Running {
    spawn_cmd(Command::new(GANTRY).args(args))
}

/// Starts the prepared `cmd` (`gantry` with its arguments and environment) as [`spawn`] does.
///
/// Unless `cmd` sets `XDG_RUNTIME_DIR` itself, it gets the test's own ([`Dir`]): `gantry serve`
/// names its socket after the device the port resolves to (`/dev/pts/N`,
/// host-sender/src/session/socket.rs), and ptys are reused, so with one shared runtime
/// directory a command of one test could reach the server of another test running at the same
/// time, whose board had that pty a moment before.
pub fn spawn_cmd(cmd: &mut Command) -> Running {
    let own_runtime = cmd.get_envs().any(|(k, _)| k == "XDG_RUNTIME_DIR");
    if !own_runtime {
        cmd.env("XDG_RUNTIME_DIR", runtime_dir());
    }
    // The port is the test's to give (an operator's GANTRY_PORT must not leak in).
    if !cmd.get_envs().any(|(k, _)| k == "GANTRY_PORT") {
        cmd.env_remove("GANTRY_PORT");
    }
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = collect(child.stdout.take().unwrap());
    let stderr = collect(child.stderr.take().unwrap());
    Running {
        stdin: child.stdin.take(),
        child,
        stdout,
        stderr,
        started: Instant::now(),
    }
}

/// The runtime directory of this thread's newest [`Dir`], else one of this process (mode 0700).
pub fn runtime_dir() -> PathBuf {
    use std::os::unix::fs::DirBuilderExt;
    if let Some(d) = RUNTIME_DIR.with(|r| r.borrow().clone()) {
        if d.is_dir() {
            return d;
        }
    }
    let d = std::env::temp_dir().join(format!("gantry-run-{}", std::process::id()));
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&d);
    d
}

/// Runs `gantry ARGS` to its end (at most `limit`), standard input closed.
pub fn gantry(args: &[&str], limit: Duration) -> Out {
    let mut r = spawn(args);
    drop(r.stdin.take());
    r.wait(limit)
}

/// A setup for short real-time jobs: fast X and Y, and the host-loss stop after 1 s.
pub const FAST_SETUP: &str = "[axis.X]\nmax_rate = 6000.0\naccel = 5000.0\n[axis.Y]\nmax_rate = 6000.0\naccel = 5000.0\n[link]\nhost_lost_stop_s = 1\n";

/// A zigzag of `n` short moves (more lines than the board buffers, a few seconds long with
/// [`FAST_SETUP`]), ending with M30.
pub fn zigzag(n: usize) -> String {
    let mut s = String::from("G21 G91 G64\n");
    for i in 0..n {
        let x = if i % 2 == 0 { "0.15" } else { "-0.15" };
        s.push_str(&format!("G1 X{x} Y0.02 F6000\n"));
    }
    s.push_str("G90 M30\n");
    s
}

/// The board's setup as `gantry setup pull FILE` writes it (to `dir/pulled.toml`), checked to
/// succeed.
pub fn pulled_setup(dir: &Dir, port: &str) -> String {
    let pulled = dir.0.join("pulled.toml");
    let out = gantry(
        &["--port", port, "setup", "pull", pulled.to_str().unwrap()],
        Duration::from_secs(20),
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    std::fs::read_to_string(&pulled).unwrap()
}
