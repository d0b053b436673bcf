//! `gantry emulate --pty PATH`: the emulated board (the firmware's core, `crate::emulator`) as a
//! serial device. It runs in real time behind the master side of a pseudo-terminal whose slave
//! side is linked at PATH, so `gantry … --port PATH` (or any program that opens serial ports)
//! talks to it exactly as to the USB board. Its stored setup (the board's flash) is kept in the
//! `--state` file. State changes, host connections and step counts are logged on stderr.
//!
//! The host closing the port is seen on the master side as a hang-up. A real USB port drops DTR
//! on close unless the host cleared HUPCL (`crate::link::OnClose`); the pty's termios carries
//! that flag, so the emulator passes a DTR drop to the board when HUPCL was set, as the firmware
//! sees it (`firmware/src/control.rs`), and a close that kept DTR up otherwise
//! (`HostPort::ClosedDtrKept` in machine/src/device/main_loop.rs): a grbl sender that closes
//! without HUPCL (pyserial, bCNC) or is killed is gone all the same, and the next client chooses
//! its protocol again.

use crate::setup_file::{to_toml, SetupFile};
use anyhow::Context;
use gantry_emulator::torch_script::{TorchModel, TorchScript};
use gantry_emulator::{EmulatedBoard, ProbeTarget};
use gantry_machine::device::link::status_of;
use gantry_machine::setup::Setup;
use gantry_machine::units::{Pos, AXIS_LETTERS, MAX_AXES};
use gantry_proto::MachineState;
use nix::poll::{ppoll, PollFd, PollFlags};
use nix::sys::termios::{tcgetattr, ControlFlags};
use nix::sys::time::TimeSpec;
use serialport::SerialPort;
use std::os::fd::{AsRawFd, RawFd};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The board's flash at power-up and what its ready line says about it. `--setup F` with a
/// `--state S` that exists applies F as `gantry setup push F` does: F's machine settings, and
/// S's work offsets, G28/G30 positions and tool table unless F names them
/// ([`SetupFile::load_keeping`]), so restarting with the first command line loses no zero. A
/// state file that does not exist yet takes everything from F.
pub(crate) fn load_state(
    state: Option<&Path>,
    setup: Option<PathBuf>,
) -> anyhow::Result<(Setup, String)> {
    let stored = |st: &Path| {
        SetupFile::load(st)
            .with_context(|| format!("{}: the emulated board's stored setup", st.display()))
    };
    match (setup, state) {
        (Some(f), Some(st)) if st.exists() => {
            let before = stored(st).with_context(|| {
                format!(
                    "--setup {} keeps the work offsets and tools stored there; delete {} to take everything from {}",
                    f.display(),
                    st.display(),
                    f.display()
                )
            })?;
            let (s, kept) = SetupFile::load_keeping(&f, &before)?;
            save_state(st, &s)?;
            let kept = if kept.is_empty() {
                "nothing else was stored there".to_owned()
            } else {
                format!("kept from there: {}", kept.join(", "))
            };
            Ok((
                s,
                format!(
                    "machine settings from {}, stored in {} ({kept})",
                    f.display(),
                    st.display()
                ),
            ))
        }
        (Some(f), Some(st)) => {
            let s = SetupFile::load(&f)?;
            save_state(st, &s)?;
            Ok((
                s,
                format!(
                    "setup from {}, stored in {} (new)",
                    f.display(),
                    st.display()
                ),
            ))
        }
        (Some(f), None) => Ok((
            SetupFile::load(&f)?,
            format!(
                "setup from {} (a pushed setup is forgotten at exit: no --state)",
                f.display()
            ),
        )),
        (None, Some(st)) if st.exists() => {
            Ok((stored(st)?, format!("stored setup: {}", st.display())))
        }
        (None, Some(st)) => Ok((
            Setup::default(),
            format!(
                "no stored setup yet, defaults (a pushed setup is stored in {})",
                st.display()
            ),
        )),
        (None, None) => Ok((
            Setup::default(),
            "defaults (a pushed setup is forgotten at exit: no --state)".into(),
        )),
    }
}

pub(crate) fn save_state(state: &Path, setup: &Setup) -> anyhow::Result<()> {
    replace_file(state, to_toml(setup).as_bytes())
}

/// Replaces `file` with `bytes` as one step: written to a new file of this process's own in the
/// same directory (created exclusively, mode 0600, so a link or file planted under its name is
/// never followed or overwritten), then renamed over `file` (a link at `file` itself is replaced,
/// not followed).
fn replace_file(file: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let dir = match file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = file
        .file_name()
        .map_or_else(|| std::ffi::OsString::from("state"), |n| n.to_owned());
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let mut last = None;
    for attempt in 0..16u32 {
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(&name);
        tmp_name.push(format!(".{}.{stamp:x}{attempt}.tmp", std::process::id()));
        let tmp = dir.join(tmp_name);
        let f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp);
        let mut f = match f {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                last = Some(e);
                continue;
            }
            Err(e) => return Err(e).with_context(|| format!("cannot create {}", tmp.display())),
        };
        let written = f.write_all(bytes).and_then(|()| f.sync_all());
        drop(f);
        if let Err(e) = written.and_then(|()| std::fs::rename(&tmp, file)) {
            let _ = std::fs::remove_file(&tmp);
            return Err(e).with_context(|| format!("cannot write {}", file.display()));
        }
        return Ok(());
    }
    Err(last.expect("an attempt failed"))
        .with_context(|| format!("cannot write {}: no free temporary name", file.display()))
}

/// Links `at` to the pty `target`, replacing an earlier link (never a regular file).
fn link_pty(at: &Path, target: &str) -> anyhow::Result<()> {
    if let Ok(meta) = std::fs::symlink_metadata(at) {
        anyhow::ensure!(
            meta.file_type().is_symlink(),
            "{}: exists and is not a link: choose another --pty path",
            at.display()
        );
        std::fs::remove_file(at)?;
    }
    std::os::unix::fs::symlink(target, at)
        .with_context(|| format!("cannot create the link {}", at.display()))
}

/// Steps and pulses per axis as one log field.
fn axes_field(values: &[i64], axes: usize) -> String {
    (0..axes)
        .map(|i| format!("{} {}", AXIS_LETTERS[i], values[i]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// What the log says about a state.
fn state_text(s: MachineState) -> String {
    match s {
        MachineState::Hold { stopped } => {
            format!("Hold ({})", if stopped { "at rest" } else { "stopping" })
        }
        MachineState::Alarm { code } => format!("Alarm {code}"),
        MachineState::ToolChange { tool } => format!("ToolChange T{tool}"),
        other => crate::present::state_name(other).to_owned(),
    }
}

/// Whether the slave side (the host's port) is open, from the master's poll flags, and (when
/// `read` asks) whether bytes wait. Without `read` the poll waits for a hang-up only: bytes the
/// board cannot take yet stay in the pty, and their arrival does not wake this loop.
fn host_side_open(fd: RawFd, wait: Duration, read: bool) -> (bool, bool) {
    let events = if read {
        PollFlags::POLLIN
    } else {
        PollFlags::empty()
    };
    let mut fds = [PollFd::new(fd, events)];
    let _ = wait_on(&mut fds, wait);
    let ev = fds[0].revents().unwrap_or(PollFlags::empty());
    (
        !ev.contains(PollFlags::POLLHUP),
        ev.contains(PollFlags::POLLIN),
    )
}

/// `poll` with a timeout to the microsecond (`ppoll`): poll(2)'s milliseconds round a wait for the
/// next main-loop pass up to a whole millisecond more, which a host's `ok` round trip would pay.
pub(crate) fn wait_on(fds: &mut [PollFd], wait: Duration) -> nix::Result<i32> {
    ppoll(fds, Some(TimeSpec::from(wait)), None)
}

/// What `gantry emulate` models around the board besides the setup.
#[derive(Clone, Debug, Default)]
pub struct BoardOptions {
    /// What the emulated touch probe touches (`--probe-target`, [`ProbeTarget::parse`]).
    pub probe_targets: Vec<String>,
    /// A CPU model (`--cpu-model`, [`gantry_emulator::cpu_model`]): each main-loop pass takes the time the
    /// MCU would take, and every gap in the motion is logged on stderr.
    pub cpu: Option<gantry_emulator::cpu_model::CpuModel>,
    /// The plasma power source and height controller (`--arc-ok-delay`, `--no-arc`,
    /// `--arc-lost-at`, `--thc`; [`gantry_emulator::torch_script`]). `None`: the default script when the
    /// setup has a torch, none otherwise.
    pub torch: Option<TorchScript>,
}

/// The emulated board of `gantry emulate` (behind a pty or TCP): `setup` and what `opts` model.
pub(crate) fn new_board(
    setup: Setup,
    state: Option<&Path>,
    opts: &BoardOptions,
) -> anyhow::Result<EmulatedBoard> {
    let cpu = opts.cpu;
    let targets = opts
        .probe_targets
        .iter()
        .map(|t| ProbeTarget::parse(t))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let stood_at = state.map(load_position).unwrap_or_default();
    let mut board = EmulatedBoard::new(setup.clone());
    add_travel_switches(&mut board, &setup, &stood_at);
    board.stood_at = stood_at;
    for t in targets {
        board.add_probe_target(t);
    }
    board.set_cpu_model(cpu);
    if let Some(m) = cpu {
        eprintln!("emulate: CPU model {} at {} MHz", m.name, m.hz / 1_000_000);
    }
    let torch = opts
        .torch
        .clone()
        .or_else(|| setup.outputs.torch.on.then(TorchScript::default));
    board.torch = torch.map(TorchModel::new);
    Ok(board)
}

/// How far beyond each end of the travel the emulated machine's switches sit, nm: a move to
/// the travel's end stays clear of them, a homing seek finds them.
pub(crate) const SWITCH_BEYOND_TRAVEL_NM: i64 = 1_000_000;

/// The switches of the emulated machine: one at each end of the travel of every axis whose limit
/// input the setup installs (`inputs.limit_min` / `limit_max`), with the setup's polarity (a
/// normally-closed switch reads closed until the machine reaches it). `stood_at`: where the
/// machine stands in the travel's frame as it powers up (its step count starts at 0 there, as a
/// real board's does).
fn add_travel_switches(board: &mut EmulatedBoard, setup: &Setup, stood_at: &Pos) {
    for (axis, (a, at)) in setup
        .axes
        .iter()
        .zip(stood_at)
        .take(usize::from(setup.axis_count))
        .enumerate()
    {
        if setup.inputs.limit_min >> axis & 1 != 0 {
            board.add_switch(axis, false, a.travel_min - SWITCH_BEYOND_TRAVEL_NM - at);
        }
        if setup.inputs.limit_max >> axis & 1 != 0 {
            board.add_switch(axis, true, a.travel_max + SWITCH_BEYOND_TRAVEL_NM - at);
        }
    }
}

/// Where the emulated machine stood when it last stopped (`STATE.position`, beside the state
/// file: one nm value per axis); at 0 when there is none.
fn load_position(state: &Path) -> Pos {
    let mut p = [0; MAX_AXES];
    if let Ok(text) = std::fs::read_to_string(position_file(state)) {
        for (v, word) in p.iter_mut().zip(text.split_whitespace()) {
            *v = word.parse().unwrap_or(0);
        }
    }
    p
}

fn position_file(state: &Path) -> PathBuf {
    let mut name = state.as_os_str().to_owned();
    name.push(".position");
    PathBuf::from(name)
}

/// Writes where the machine stands now (in the travel's frame) for the next power-up.
fn save_position(state: &Path, board: &EmulatedBoard) -> anyhow::Result<()> {
    let cfg = board.board.motion_config();
    let now = cfg.to_nm(&board.physical());
    let text: Vec<String> = now
        .iter()
        .zip(board.stood_at)
        .map(|(n, s)| (n + s).to_string())
        .collect();
    replace_file(&position_file(state), (text.join(" ") + "\n").as_bytes())
}

/// The longest lag behind the wall clock the board's clock catches up, ms (see [`run_board`]).
/// Shorter than the board's shortest wait on its host, the 250 ms jog dead-man
/// (`machine/src/board/jog/plan.rs`): a catch-up runs faster than the host writes, so a longer
/// one would be a silence the host never made.
const CATCH_UP_LIMIT_MS: u64 = 200;

/// Kernel timer counts per millisecond and per microsecond (the board's clock).
const COUNTS_PER_MS: u64 = gantry_emulator::COUNTS_PER_MS;
const COUNTS_PER_US: u64 = COUNTS_PER_MS / 1000;
const KERNEL_TIMER_HZ: u64 = COUNTS_PER_MS * 1000;

/// One pass's news from the host side of the emulated board's port.
pub(crate) struct Polled {
    /// A host has the port open (pty) or is connected (TCP).
    pub(crate) open: bool,
    /// Bytes read into the buffer.
    pub(crate) read: usize,
}

/// The host side of the emulated board: a pty (`--pty`) or a TCP listener (`--tcp`). One
/// [`run_board`] loop runs the board behind either.
pub(crate) trait HostSide {
    /// Waits at most `wait` for bytes; whether a host is there, and the bytes it sent, at
    /// most `buf.len()` (the board's room: the rest stays in the pty or socket; an empty `buf`
    /// reads nothing and waits only for the host to leave).
    fn poll(&mut self, wait: Duration, buf: &mut [u8]) -> anyhow::Result<Polled>;
    /// Whether the host's leaving drops DTR (a pty: its HUPCL flag; TCP: always).
    fn close_drops_dtr(&self) -> bool;
    /// Sends the board's bytes; a full buffer loses them, as a USB port would (the framed
    /// protocol retransmits).
    fn send(&mut self, bytes: &[u8]);
    /// The host left: what the board sent and it did not read is discarded, so the next client
    /// reads only what the board says to it (as a USB port's buffers go with the connection).
    fn discard_unread(&mut self) {}
}

/// The pty of `--pty`: its master side; the host opens the slave side linked at the path.
struct PtyHost {
    fd: RawFd,
    /// HUPCL of the host's port as last seen: whether its close drops DTR.
    hupcl: bool,
    last_termios_check: Instant,
}

impl HostSide for PtyHost {
    fn poll(&mut self, wait: Duration, buf: &mut [u8]) -> anyhow::Result<Polled> {
        let (open, readable) = host_side_open(self.fd, wait, !buf.is_empty());
        if open && self.last_termios_check.elapsed().as_millis() >= 5 {
            self.last_termios_check = Instant::now();
            // The master reads the slave's termios (one shared set for the pair).
            if let Ok(t) = tcgetattr(self.fd) {
                self.hupcl = t.control_flags.contains(ControlFlags::HUPCL);
            }
        }
        let mut read = 0;
        if readable && !buf.is_empty() {
            if let Ok(n) = nix::unistd::read(self.fd, buf) {
                read = n;
            }
        }
        Ok(Polled { open, read })
    }

    fn close_drops_dtr(&self) -> bool {
        self.hupcl
    }

    fn send(&mut self, bytes: &[u8]) {
        let _ = nix::unistd::write(self.fd, bytes);
    }

    fn discard_unread(&mut self) {
        // On the master, the output queue is the slave's unread input.
        // On the master, the output queue is the slave's unread input, and the input queue what
        // the departed host wrote that the board did not take.
        let _ = nix::sys::termios::tcflush(self.fd, nix::sys::termios::FlushArg::TCIOFLUSH);
    }
}

/// Runs the board until SIGINT or SIGTERM, with what `opts` models around it.
pub fn run(
    pty: &Path,
    setup: Option<PathBuf>,
    state: Option<PathBuf>,
    opts: &BoardOptions,
) -> anyhow::Result<ExitCode> {
    let (setup, origin) = load_state(state.as_deref(), setup)?;
    let axes = setup.axis_count as usize;
    let board = new_board(setup, state.as_deref(), opts)?;
    let (master, slave) = serialport::TTYPort::pair().context("cannot open a pseudo-terminal")?;
    let name = slave
        .name()
        .ok_or_else(|| anyhow::anyhow!("the pseudo-terminal has no name"))?;
    // The host opens the slave side itself; closing ours leaves the port "unplugged" until then.
    drop(slave);
    let fd = master.as_raw_fd();
    nix::fcntl::fcntl(
        fd,
        nix::fcntl::FcntlArg::F_SETFL(nix::fcntl::OFlag::O_NONBLOCK),
    )?;
    link_pty(pty, &name)?;
    let mut host = PtyHost {
        fd,
        hupcl: true,
        last_termios_check: Instant::now(),
    };
    let ready = format!(
        "emulate: board ready on {} ({name}), {axes} axes; {origin}",
        pty.display(),
    );
    // No host until one opens the port (its opening is a connection the board may greet).
    let mut board = board;
    board.set_dtr(false);
    let result = run_board(board, &mut host, state.as_deref(), &ready);
    // Remove the link only when it is still ours.
    if std::fs::read_link(pty).is_ok_and(|t| t == Path::new(&name)) {
        let _ = std::fs::remove_file(pty);
    }
    result
}

/// The run loop of `gantry emulate`, behind either host side, until SIGINT or SIGTERM: bytes in
/// and out, the board's clock following the wall clock, the stored setup saved when the board
/// writes its flash, and every state change logged on stderr with the step counts.
pub(crate) fn run_board(
    mut board: EmulatedBoard,
    host: &mut dyn HostSide,
    state: Option<&Path>,
    ready: &str,
) -> anyhow::Result<ExitCode> {
    let axes = board.board.setup().axis_count as usize;
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || s.store(true, Ordering::SeqCst))
        .context("cannot install the SIGINT/SIGTERM handler")?;
    let mut gaps = 0;
    // The underrun count the state lines last said (0: none said yet).
    let mut logged_gaps = 0;
    // Every start of the process is a power-up with its own boot id (the firmware counts boots
    // in flash), so a host sees a restarted board as one.
    let boot_id = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos() ^ d.as_secs() as u32)
        ^ std::process::id().rotate_left(16);
    board.link = gantry_machine::device::link::BoardLink::new(boot_id);
    eprintln!("{ready}");
    let start = Instant::now();
    // Wall time the board's clock skipped (see CATCH_UP_LIMIT_MS).
    let mut skipped_ms = 0u64;
    let mut host_open = false;
    let mut last_state: Option<MachineState> = None;
    let mut buf = [0u8; 4096];
    // What the board writes to its flash (the main loop's save, once idle: a pushed setup, a
    // grbl `$x=`, work offsets a job changed) goes to the state file.
    let saved: std::rc::Rc<std::cell::RefCell<Option<Setup>>> = Default::default();
    let to_save = saved.clone();
    board.on_setup_saved(move |s| *to_save.borrow_mut() = Some(s.clone()));
    while !stop.load(Ordering::SeqCst) {
        // The next tick's pass is due when the wall clock reaches it, as the firmware's 1 ms
        // ticker runs it (`firmware/src/control.rs`): the wait for the host's bytes ends then,
        // to the microsecond. Bytes that end it sooner get a pass of their own at once (below),
        // as the firmware's USB receive task wakes its main loop: a line is answered when it
        // arrives, not at the next tick.
        let due_us = board.next_tick() / COUNTS_PER_US + skipped_ms * 1000;
        let wait = Duration::from_micros(due_us.saturating_sub(start.elapsed().as_micros() as u64));
        let room = board.rx_room().min(buf.len());
        let polled = host.poll(
            if host_open { wait } else { Duration::ZERO },
            &mut buf[..room],
        )?;
        let open = polled.open;
        if !open {
            // Nothing to wait on while no host has the port open.
            std::thread::sleep(wait.min(Duration::from_millis(1)));
        }
        if open != host_open {
            host_open = open;
            if !open {
                host.discard_unread();
                board.discard_input();
            }
            if open {
                eprintln!("emulate: host opened the port");
                board.set_dtr(true);
            } else if host.close_drops_dtr() {
                eprintln!("emulate: host closed the port (DTR drop: the host is lost)");
                board.set_dtr(false);
            } else {
                eprintln!("emulate: host closed the port (DTR kept)");
                board.close_keeping_dtr();
            }
        }
        // Virtual time follows the wall clock to the kernel timer count (at most 50 ms at
        // once). A longer gap than CATCH_UP_LIMIT_MS means this process was stopped (SIGSTOP, a
        // suspended machine), which a real board never is: its clock skips the gap instead of
        // running it in a burst with no host word in it (which the board took for a lost host
        // and held the job).
        let wall_us = (start.elapsed().as_micros() as u64).saturating_sub(skipped_ms * 1000);
        let behind = (wall_us * COUNTS_PER_US).saturating_sub(board.now());
        // Within a millisecond of the wall clock (the usual wake: a tick or the host's bytes),
        // the bytes that ended the wait are given to the board once its clock has reached the
        // wall's, and their pass runs then (below). Further behind (this process was kept off
        // the CPU), when they came is not known: they go in first, ahead of what the catch-up
        // reads, and their pass runs at its start.
        let late = behind > COUNTS_PER_MS;
        if late && polled.read > 0 {
            board.receive(&buf[..polled.read]);
        }
        if behind > CATCH_UP_LIMIT_MS * COUNTS_PER_MS {
            skipped_ms += behind / COUNTS_PER_MS;
            eprintln!(
                "emulate: this process was stopped for {:.1} s: the board's clock skips it",
                behind as f64 / KERNEL_TIMER_HZ as f64
            );
        } else {
            // A millisecond at a time, with the port read and written in between: a real
            // board's bytes arrive while it runs, so a lag behind the wall clock must not turn
            // into a burst of virtual time with no host byte in it (and then a burst of bytes
            // one pass has to take).
            let mut left = behind.min(50 * COUNTS_PER_MS);
            let mut first = true;
            while left > 0 {
                if !first && open {
                    let room = board.rx_room().min(buf.len());
                    let polled = host.poll(Duration::ZERO, &mut buf[..room])?;
                    if polled.read > 0 {
                        board.receive(&buf[..polled.read]);
                    }
                }
                first = false;
                let step = left.min(COUNTS_PER_MS);
                board.run_for(step);
                left -= step;
                let out = board.take_output();
                if open && !out.is_empty() {
                    host.send(&out);
                }
            }
        }
        // The bytes that ended the wait, at the board's time now (the wall's): their pass runs
        // at once. (Not late, the catch-up above was one step and read nothing into `buf`.)
        if !late && polled.read > 0 {
            board.receive(&buf[..polled.read]);
            board.run_due();
        }
        let out = board.take_output();
        if open && !out.is_empty() {
            host.send(&out);
        }
        if let Some(setup) = saved.borrow_mut().take() {
            if let Some(st) = state {
                save_state(st, &setup)?;
                eprintln!("emulate: setup saved to {}", st.display());
            }
        }
        if board.starved.gaps != gaps {
            gaps = board.starved.gaps;
            eprintln!(
                "emulate: {:.3} s underrun: the step kernel ran dry mid-job ({gaps} so far)",
                board.seconds()
            );
        }
        let status = status_of(&board.board, &board.kernel_view());
        if last_state != Some(status.state) {
            last_state = Some(status.state);
            if let (Some(st), MachineState::Idle | MachineState::Alarm { .. }) =
                (state, status.state)
            {
                save_position(st, &board)?;
            }
            let pulses: Vec<i64> = board.pulses.iter().map(|&p| p as i64).collect();
            eprintln!(
                "emulate: {:.3} s {} line {} steps {} pulses {}",
                board.seconds(),
                state_text(status.state),
                status.line,
                axes_field(&board.isr.kernel.position(), axes),
                axes_field(&pulses, axes)
            );
            // Planner starvation so far (grbl streaming is judged by it, docs/grbl.md), when it
            // changed since the last state line that said it (none: nothing to say).
            if board.starved.gaps != logged_gaps {
                logged_gaps = board.starved.gaps;
                eprintln!("emulate: underruns {logged_gaps}");
            }
        }
    }
    if let Some(st) = state {
        save_position(st, &board)?;
    }
    eprintln!("emulate: stopped");
    Ok(ExitCode::SUCCESS)
}
