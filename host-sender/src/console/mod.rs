//! The operator's console: `gantry serve --port P --http 127.0.0.1:8080` serves one page (its
//! HTML, script and style compiled into the binary, nothing fetched from elsewhere) from which an
//! operator reads the machine and drives it.
//!
//! The page is a client of the same session layer as the CLI (`crate::session`): the console
//! opens its sessions through serve's own socket, exactly as `gantry status` or `gantry stream`
//! in another terminal do, so a click and a command act on the same job and see the same state.
//! - the *control* session (one thread, [`worker`]) reads the status the board pushes (every
//!   100 ms) and broadcasts it to every page as Server-Sent Events, and carries the page's
//!   realtime requests (hold, resume, abort, overrides, jog, home, unlock, zero, setup push);
//! - a *job* session (a thread per job, [`job`]) streams a program or an MDI block, as
//!   `gantry stream` would, and broadcasts its progress with the planner's ETA.
//!
//! The job belongs to the serve process, not to the page: closing the page never stops it.
//! Locked ([`lock`]): every request carries the token serve printed; the console listens on
//! loopback unless `--allow-remote` (docs/console.md).

mod args;
mod http;
mod library;
mod loaded;
pub(crate) mod lock;
mod probing;
pub(crate) mod program;

use crate::commands::stream::Eta;
use crate::link::OnClose;
use crate::present::{
    alarm_text, limit_text, outputs_text, refusal_text, state_name, state_words, work_system_name,
};
use crate::program::Program;
use crate::program_stops;
use crate::resume::resume_preamble;
use crate::session::probe::Probe;
use crate::session::{Flow, JobStart, Overrides, Session, Target};
use anyhow::Context;
use args::{num_in, percent, text, whole_in};
use gantry_machine::setup::Setup;
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{BoardMsg, MachineState, Status};
use loaded::Loaded;
use serde_json::{json, Value};
use std::collections::{BTreeMap, VecDeque};
use std::io::{BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

const PAGE: &str = include_str!("page.html");
const SCRIPT: &str = include_str!("console.js");
const STYLE: &str = include_str!("console.css");

/// How long the page's request waits for the board's answer.
const ANSWER_MS: u32 = 2000;

/// Where the console listens.
#[derive(Clone, Debug)]
pub struct Options {
    pub addr: SocketAddr,
    pub allow_remote: bool,
    /// Make a new token even if the one kept from the last start is usable (`lock.rs`).
    pub new_token: bool,
}

/// Refuses an address other hosts can reach unless `allow_remote`; warns when allowed.
pub(crate) fn check_address(addr: &SocketAddr, allow_remote: bool) -> anyhow::Result<()> {
    if addr.ip().is_loopback() {
        return Ok(());
    }
    anyhow::ensure!(
        allow_remote,
        "--http {addr}: not a loopback address; the console speaks plain HTTP, so its token \
         crosses the network readable by anyone on it, who can then move the machine. Use \
         127.0.0.1 (and an SSH tunnel for a tablet, docs/console.md), or add --allow-remote if \
         you mean it"
    );
    eprintln!(
        "serve: WARNING: the console listens on {addr}, reachable from other hosts over plain \
         HTTP: anyone who can read the traffic learns the token and can move the machine"
    );
    Ok(())
}

/// The events every page receives: a ring of the recent ones and the newest of each kind (a page
/// that connects gets those first).
#[derive(Default)]
struct Hub {
    state: Mutex<HubState>,
    cv: Condvar,
}

#[derive(Default)]
struct HubState {
    seq: u64,
    ring: VecDeque<(u64, String)>,
    latest: BTreeMap<&'static str, String>,
}

impl Hub {
    fn publish(&self, kind: &'static str, data: Value) {
        let text = http::event_text(kind, &data.to_string());
        let mut s = self.state.lock().expect("hub");
        s.seq += 1;
        let seq = s.seq;
        s.ring.push_back((seq, text.clone()));
        if s.ring.len() > 256 {
            s.ring.pop_front();
        }
        if kind != "notice" {
            s.latest.insert(kind, text);
        }
        self.cv.notify_all();
    }

    /// The newest event of each kind, and the sequence number they bring a page up to.
    fn snapshot(&self) -> (u64, Vec<String>) {
        let s = self.state.lock().expect("hub");
        (s.seq, s.latest.values().cloned().collect())
    }

    /// The events after `seq` (waiting at most `limit` for one).
    fn after(&self, seq: u64, limit: Duration) -> (u64, Vec<String>) {
        let s = self.state.lock().expect("hub");
        let (s, _) = self
            .cv
            .wait_timeout_while(s, limit, |s| s.seq <= seq)
            .expect("hub");
        let events = s
            .ring
            .iter()
            .filter(|(n, _)| *n > seq)
            .map(|(_, t)| t.clone())
            .collect();
        (s.seq, events)
    }
}

/// A request for the control session.
enum Cmd {
    Hold,
    Resume,
    Abort,
    Overrides(Overrides),
    /// Jog `axis` towards `dir` (±1) by `step_nm` (0: continuous, to the end of the travel).
    Jog {
        axis: u8,
        dir: i8,
        step_nm: u64,
        feed_um_min: i32,
    },
    JogStop,
    /// The page still holds its continuous jog button: passed on to the board as a keepalive
    /// (only what the page sends: a page gone offline stops the jog, docs/console.md).
    JogKeepalive,
    Home(u8),
    Unlock,
    /// Work zero of `axis` here (G10 L20 P0).
    Zero(u8),
    /// Sets work offsets: `G10 L2 P<p>` with these axis values, mm.
    Offsets(String),
    /// Reads the board's setup (and the work offsets in it) again.
    ReadBack,
    /// The editor's setup text, pushed through the session's one push path.
    PushSetup(String),
}

type Reply = Result<String, String>;

struct Console {
    port: String,
    lock: lock::Lock,
    hub: Hub,
    setup: Mutex<Option<Setup>>,
    /// The program every page shows (`loaded.rs`), and its last revision number.
    program: Mutex<Option<Arc<Loaded>>>,
    /// The program library and the macros (`library.rs`), when a data directory is usable.
    library: Option<library::Library>,
    rev: AtomicU64,
    /// Where the tool stands (machine nm) and the active work system, from the newest status.
    here: Mutex<[i64; 6]>,
    system: Mutex<u8>,
    /// The tool in the spindle (0 = none), from the newest status.
    tool: AtomicU64,
    /// A console job thread runs.
    job: AtomicBool,
    /// A request to hold, resume, abort, or continue from the job thread.
    control: Mutex<mpsc::Sender<(Cmd, mpsc::Sender<Reply>)>>,
}

impl Console {
    /// The tool in the spindle now (0 = none).
    fn tool_now(&self) -> u32 {
        u32::try_from(self.tool.load(Ordering::SeqCst)).unwrap_or(0)
    }

    /// The program library serve keeps, or why there is none.
    fn library(&self) -> Result<&library::Library, String> {
        self.library
            .as_ref()
            .ok_or_else(|| "serve keeps no library (no data directory)".to_owned())
    }

    fn ask(&self, cmd: Cmd) -> Reply {
        let (tx, rx) = mpsc::channel();
        self.control
            .lock()
            .expect("control")
            .send((cmd, tx))
            .map_err(|_| "the console's session has ended".to_owned())?;
        rx.recv_timeout(Duration::from_secs(15))
            .map_err(|_| "no answer from the console's session".to_owned())?
    }

    fn notice(&self, text: impl Into<String>) {
        self.hub
            .publish("notice", json!({ "text": text.into(), "at": now_s() }));
    }
}

fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Starts the console for the board `gantry serve` serves on `port` (serve's socket must be bound
/// already in its private directory `dir`, and [`check_address`] passed); returns once it
/// listens, with the file that holds the console's token (kept when serve ends: `lock.rs`).
pub(crate) fn start(port: &str, opts: &Options, dir: &std::path::Path) -> anyhow::Result<PathBuf> {
    let listener = TcpListener::bind(opts.addr)
        .with_context(|| format!("--http {}: cannot listen", opts.addr))?;
    let addr = listener.local_addr()?;
    let lock = lock::Lock::open(
        &dir.join(lock::token_name(port)),
        addr.port(),
        opts.new_token,
    )?;
    let library = match library::default_dir().map(|d| library::Library::open(&d)) {
        Some(Ok(l)) => Some(l),
        Some(Err(e)) => {
            eprintln!("serve: the console keeps no program library or macros: {e:#}");
            None
        }
        None => {
            eprintln!(
                "serve: the console keeps no program library or macros: no XDG_DATA_HOME or HOME"
            );
            None
        }
    };
    if let Some(l) = &library {
        eprintln!(
            "serve: the console's program library and macros are in {}",
            l.dir().display()
        );
    }
    let (tx, rx) = mpsc::channel();
    let console = Arc::new(Console {
        port: port.to_owned(),
        lock,
        hub: Hub::default(),
        setup: Mutex::new(None),
        program: Mutex::new(None),
        library,
        rev: AtomicU64::new(0),
        here: Mutex::new([0; 6]),
        system: Mutex::new(0),
        tool: AtomicU64::new(0),
        job: AtomicBool::new(false),
        control: Mutex::new(tx),
    });
    let c = console.clone();
    std::thread::Builder::new()
        .name("console-session".into())
        .spawn(move || worker(c, rx))?;
    if let Some(l) = &console.library {
        console
            .hub
            .publish("library", json!({ "programs": l.list() }));
        console
            .hub
            .publish("macros", json!({ "macros": l.macros() }));
    }
    let url = format!("http://{addr}/?token={}", console.lock.token());
    let file = console.lock.file().to_owned();
    let c = console;
    std::thread::Builder::new()
        .name("console-http".into())
        .spawn(move || {
            for stream in listener.incoming().flatten() {
                let c = c.clone();
                let _ = std::thread::Builder::new()
                    .name("console-client".into())
                    .spawn(move || serve_client(&c, stream, addr));
            }
        })?;
    // Printed once: the URL is the key (a notebook server's way); scripts read the file.
    eprintln!("serve: the console is on {url}");
    eprintln!("serve: (its token is also in {})", file.display());
    Ok(file)
}

/// The control session: the board's pushed status to every page, the page's requests to the
/// board. Reconnects when its link ends (serve closes every command's link when the board
/// restarts).
fn worker(c: Arc<Console>, rx: mpsc::Receiver<(Cmd, mpsc::Sender<Reply>)>) {
    loop {
        let mut session = match Session::connect(Target::Port(c.port.clone()), OnClose::KeepDtr) {
            Ok(s) => s,
            Err(e) => {
                c.notice(format!("cannot reach the board: {e:#}"));
                std::thread::sleep(Duration::from_secs(1));
                continue;
            }
        };
        *c.setup.lock().expect("setup") = Some(session.setup().clone());
        c.hub.publish("setup", setup_json(session.setup()));
        let mut heard = Instant::now();
        loop {
            match rx.recv_timeout(Duration::from_millis(5)) {
                Ok((cmd, reply)) => {
                    let r = carry_out(&mut session, &c, cmd);
                    let _ = reply.send(r);
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            match session.pushed_status() {
                Ok(got) => {
                    if let Some(s) = got.statuses.last() {
                        heard = Instant::now();
                        *c.here.lock().expect("here") = s.machine_pos;
                        *c.system.lock().expect("system") = s.work_system;
                        c.tool.store(u64::from(s.outputs.tool), Ordering::SeqCst);
                        c.hub.publish("status", status_json(s, session.axes()));
                    }
                    // A job (any client's: a program, an MDI block) may have set work offsets,
                    // which the board keeps in its setup: read them back once it is over.
                    if got.jobs_ended > 0 {
                        read_back(&mut session, &c);
                    }
                }
                Err(e) => {
                    c.notice(format!("the link to serve ended: {e:#}"));
                    break;
                }
            }
            for n in session.take_notices() {
                match n {
                    BoardMsg::Alarm { code, line } => {
                        c.notice(format!("line {line}: {}", alarm_text(code)))
                    }
                    BoardMsg::Limit { axis, max } => c.notice(limit_text(axis, max)),
                    _ => {}
                }
            }
            if heard.elapsed() > Duration::from_secs(3) {
                c.notice("no status from the board for 3 s: connecting again");
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn answer(a: anyhow::Result<Option<u16>>, done: &str) -> Reply {
    match a {
        Ok(Some(0)) => Ok(done.to_owned()),
        Ok(Some(code)) => Err(format!("refused: {}", refusal_text(code))),
        Ok(None) => Err(format!(
            "the board did not answer within {} s",
            ANSWER_MS / 1000
        )),
        Err(e) => Err(format!("{e:#}")),
    }
}

fn carry_out(s: &mut Session, c: &Arc<Console>, cmd: Cmd) -> Reply {
    let e = |r: anyhow::Result<()>, done: &str| {
        r.map(|()| done.to_owned()).map_err(|e| format!("{e:#}"))
    };
    match cmd {
        Cmd::Hold => e(s.hold(), "feed hold sent"),
        Cmd::Resume => e(s.resume(), "resume sent"),
        Cmd::Abort => e(s.abort(), "abort sent"),
        Cmd::Overrides(o) => e(s.set_overrides(o), "override sent"),
        Cmd::JogStop => e(s.jog_stop(), "jog stopped"),
        Cmd::JogKeepalive => e(s.jog_keepalive(), "jog kept alive"),
        Cmd::Jog {
            axis,
            dir,
            step_nm,
            feed_um_min,
        } => {
            let axes = s.axes();
            if axis as usize >= axes {
                return Err(format!("the machine has {axes} axes"));
            }
            let here = match s.last_status() {
                Some(st) => st.machine_pos[axis as usize],
                None => s.status().map_err(|e| format!("{e:#}"))?.machine_pos[axis as usize],
            };
            let a = &s.setup().axes[axis as usize];
            // Never beyond the travel: a step stops at its end, a continuous jog (the board's,
            // kept alive by the page) goes at most to it.
            let room = if dir > 0 {
                a.travel_max - here
            } else {
                here - a.travel_min
            };
            if room <= 0 {
                return Err(format!(
                    "{} is at the end of its travel",
                    AXIS_LETTERS[axis as usize]
                ));
            }
            let distance = if step_nm == 0 {
                0
            } else {
                step_nm.min(room as u64)
            };
            let feed = feed_um_min.abs() * if dir > 0 { 1 } else { -1 };
            answer(s.jog(axis, feed, distance, ANSWER_MS), "jogging")
        }
        Cmd::Home(axes) => answer(s.home(axes, ANSWER_MS), "homing"),
        Cmd::Unlock => answer(s.unlock(ANSWER_MS), "unlocked"),
        Cmd::Zero(axis) => {
            let letter = AXIS_LETTERS[axis as usize];
            let r = mdi_here(s, &format!("G10 L20 P0 {letter}0"))
                .map(|()| format!("work {letter} is 0 here"));
            read_back(s, c);
            r
        }
        Cmd::Offsets(block) => {
            // The block is in mm (G21); a program in inches gets its G20 back.
            let inch = s.last_status().is_some_and(|st| st.inch);
            let r = if inch {
                mdi_lines(s, &[block.clone(), "G20".into()])
            } else {
                mdi_here(s, &block)
            }
            .map(|()| format!("{block}: done"));
            read_back(s, c);
            r
        }
        Cmd::ReadBack => {
            read_back(s, c);
            Ok("the board's setup and work offsets read back".into())
        }
        Cmd::PushSetup(text) => match s.push_setup_text(&text) {
            Ok(setup) => {
                c.hub.publish("setup", setup_json(&setup));
                *c.setup.lock().expect("setup") = Some(setup);
                Ok("setup pushed, saved by the board".into())
            }
            Err(e) => Err(format!("nothing was pushed: {e:#}")),
        },
    }
}

/// Reads the board's setup again (the work offsets a job or a zero changed, which the board keeps
/// in it) and shows it to every page.
fn read_back(s: &mut Session, c: &Arc<Console>) {
    match s.reload_setup() {
        Ok(setup) => {
            let setup = setup.clone();
            c.hub.publish("setup", setup_json(&setup));
            *c.setup.lock().expect("setup") = Some(setup);
            // The work offsets may have changed: the program's path in machine coordinates too.
            refresh(c);
        }
        Err(e) => c.notice(format!("cannot read the board's setup back: {e:#}")),
    }
}

/// Runs one block that does not move (offsets) on the control session.
fn mdi_here(s: &mut Session, block: &str) -> Result<(), String> {
    mdi_lines(s, &[block.to_owned()])
}

/// Runs blocks that do not move on the control session.
fn mdi_lines(s: &mut Session, blocks: &[String]) -> Result<(), String> {
    let (program, report) = s
        .mdi(blocks, &mut |_| Flow::Continue)
        .map_err(|e| format!("{e:#}"))?;
    if let Some(e) = report.errors.first() {
        return Err(e.describe("mdi", &program));
    }
    Ok(())
}

/// Millimetres to the µm, rounded as `gantry status` rounds (`crate::present::um_of_nm`).
fn nm_to_mm(nm: i64) -> f64 {
    crate::present::um_of_nm(nm) as f64 / 1000.0
}

/// A length in the program's units: mm to the µm, or inches to 0.0001 in.
fn in_units(nm: i64, inch: bool) -> f64 {
    if inch {
        (nm as f64 / 2540.0).round() / 10_000.0
    } else {
        nm_to_mm(nm)
    }
}

/// A speed (µm/min) in the program's units per minute, to 0.1 mm/min or 0.01 in/min.
fn speed_in_units(um_min: u32, inch: bool) -> f64 {
    if inch {
        (f64::from(um_min) / 254.0).round() / 100.0
    } else {
        (f64::from(um_min) / 100.0).round() / 10.0
    }
}

/// The status as the page reads it.
fn status_json(s: &Status, axes: usize) -> Value {
    let homed: String = (0..axes)
        .filter(|i| s.homed >> i & 1 == 1)
        .map(|i| AXIS_LETTERS[i])
        .collect();
    let inputs = crate::present::input_names(s.inputs);
    let alarm = match s.state {
        MachineState::Alarm { code } => Some(alarm_text(code)),
        _ => None,
    };
    let tool_change = match s.state {
        MachineState::ToolChange { tool } => Some(tool),
        _ => None,
    };
    json!({
        "state": state_name(s.state),
        "words": state_words(s.state),
        "alarm": alarm,
        "tool_change": tool_change,
        "axes": axes,
        "letters": AXIS_LETTERS[..axes].iter().map(|c| c.to_string()).collect::<Vec<_>>(),
        "machine": s.machine_pos[..axes].iter().map(|&p| nm_to_mm(p)).collect::<Vec<_>>(),
        "work": s.work_pos[..axes].iter().map(|&p| nm_to_mm(p)).collect::<Vec<_>>(),
        // The move being executed, in its program's units (G20/G21).
        "units": if s.inch { "in" } else { "mm" },
        "work_units": s.work_pos[..axes].iter().map(|&p| in_units(p, s.inch)).collect::<Vec<_>>(),
        "work_system": work_system_name(s.work_system),
        "work_system_index": s.work_system,
        "feed": s.feed_um_min as f64 / 1000.0,
        "feed_units": speed_in_units(s.feed_um_min, s.inch),
        "programmed_feed_units": speed_in_units(s.programmed_feed_um_min, s.inch),
        "feed_override": s.feed_override,
        "rapid_override": s.rapid_override,
        "spindle_override": s.spindle_override,
        // The speed commanded to the spindle: the programmed S scaled by the override.
        "rpm_actual": u64::from(s.outputs.rpm) * u64::from(s.spindle_override) / 100,
        "line": s.line,
        "tool": s.outputs.tool,
        "rpm": s.outputs.rpm,
        // Laser mode: the beam's power now, % (null: not a laser machine).
        "laser_power": s.outputs.laser_permille.map(|p| f64::from(p) / 10.0),
        "outputs": outputs_text(&s.outputs),
        "homed": homed,
        "inputs": inputs,
        "planner": s.planner_fill,
        "queue": s.queue_fill,
        "probe": s.probe.map(|p| json!({"machine": p.machine_pos[..axes].iter().map(|&v| nm_to_mm(v)).collect::<Vec<_>>(), "contact": p.success})),
    })
}

/// The setup as the page shows it (the setup file's TOML, the travel box).
fn setup_json(s: &Setup) -> Value {
    let axes = s.axis_count as usize;
    json!({
        "toml": crate::setup_file::to_toml(s),
        "axes": axes,
        "travel_min": s.axes[..axes].iter().map(|a| nm_to_mm(a.travel_min)).collect::<Vec<_>>(),
        "travel_max": s.axes[..axes].iter().map(|a| nm_to_mm(a.travel_max)).collect::<Vec<_>>(),
        // G54..G59.3 as the board keeps them (machine mm), read back with the setup.
        "offsets": s.program.work_offsets.iter().enumerate().map(|(i, o)| json!({
            "name": work_system_name(i as u8),
            "values": o[..axes].iter().map(|&v| nm_to_mm(v)).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

/// Streams `program` (a file from the page, or an MDI block) on a session of its own, once it
/// passed the start check (`cleared`).
fn job(
    c: Arc<Console>,
    name: String,
    text: String,
    from: Option<u32>,
    cleared: crate::session::Cleared,
) {
    let program = Program::from_text(&text);
    // The job is over for the console before any page hears of it: a page that starts the next
    // one at once must not be refused as "still running".
    let publish_end = |v: Value| {
        c.job.store(false, Ordering::SeqCst);
        c.hub.publish("job", v)
    };
    let result = (|| -> anyhow::Result<()> {
        let mut s = Session::connect(Target::Port(c.port.clone()), OnClose::KeepDtr)?;
        let setup = s.setup().clone();
        let eta = Eta::plan(&text, &setup);
        let mut preamble = Vec::new();
        let start = match from {
            Some(n) if n > 1 => {
                let here = s.status()?.machine_pos;
                preamble = resume_preamble(&program, &text, n, &setup, &here)?;
                if let Some(e) = &eta {
                    e.start_at(n);
                }
                JobStart::FromLine(n, preamble.clone())
            }
            _ => JobStart::Beginning,
        };
        let total = program.len();
        let mut last = 0u32;
        let mut stop_line = 0u32;
        let mut stop: Option<String> = None;
        let report = s.start_job(&program, start, cleared, &mut |p| {
            let state = p.status.as_ref().map(|s| s.state);
            let stopped = matches!(
                state,
                Some(MachineState::Hold { stopped: true } | MachineState::ToolChange { .. })
            );
            if stopped && p.line != stop_line {
                if let Some(f) = program_stops::stop_at(state, &program, p.line) {
                    stop_line = p.line;
                    let source = program.line(p.line).unwrap_or("").trim().to_owned();
                    stop = Some(format!(
                        "{}\n{source}",
                        program_stops::message(f, p.line)
                            .replace("press Enter (or cycle start)", "press Continue")
                    ));
                    last = 0;
                }
            }
            if !stopped {
                stop = None;
            }
            if p.elapsed_ms.wrapping_sub(last) >= 100 || last == 0 {
                last = p.elapsed_ms.max(1);
                let elapsed = p.elapsed_ms as f64 / 1000.0;
                let left = eta.as_ref().map(|e| e.left_at(p.line.max(1), elapsed));
                c.hub.publish(
                    "job",
                    json!({
                        "running": true, "name": name, "line": p.line, "total": total,
                        "elapsed_s": elapsed, "left_s": left,
                        "planned_s": eta.as_ref().map(|e| e.total()),
                        "preamble": preamble, "from_line": from, "stop": stop,
                    }),
                );
            }
            Flow::Continue
        })?;
        let errors: Vec<String> = report
            .errors
            .iter()
            .map(|e| e.describe(&name, &program))
            .collect();
        let alarms: Vec<String> = report.alarms.iter().map(|a| a.describe(&program)).collect();
        publish_end(json!({
            "running": false, "name": name, "line": report.last_line, "total": total,
            "completed": report.completed, "aborted": report.aborted,
            "resume_line": resume_line(&report, from.unwrap_or(1)),
            "errors": errors, "alarms": alarms,
            "elapsed_s": report.elapsed_ms as f64 / 1000.0,
            "link": format!("{:?}", report.link),
        }));
        Ok(())
    })();
    if let Err(e) = result {
        publish_end(json!({ "running": false, "name": name, "errors": [format!("{e:#}")] }));
    }
}

/// Makes `text` the program every page shows: checked with the board's setup and drawn from
/// where the tool stands; returns all of it for the page that opened it.
fn open_program(c: &Arc<Console>, name: &str, text: &str) -> Result<Value, String> {
    let setup = c
        .setup
        .lock()
        .expect("setup")
        .clone()
        .ok_or("the board's setup is not read yet")?;
    let here = *c.here.lock().expect("here");
    let rev = c.rev.fetch_add(1, Ordering::SeqCst) + 1;
    let loaded = Arc::new(Loaded::build(name, text, &setup, &here, rev));
    *c.program.lock().expect("program") = Some(loaded.clone());
    c.hub.publish("program", loaded.summary.clone());
    Ok(loaded.whole())
}

/// Checks and draws the program again (the setup, its offsets or the tool's position changed),
/// on a thread of its own: a long program's check does not hold up the status. The result
/// replaces the program only if no other was opened meanwhile.
fn refresh(c: &Arc<Console>) {
    let Some(old) = c.program.lock().expect("program").clone() else {
        return;
    };
    let Some(setup) = c.setup.lock().expect("setup").clone() else {
        return;
    };
    let here = *c.here.lock().expect("here");
    let c = c.clone();
    let _ = std::thread::Builder::new()
        .name("console-check".into())
        .spawn(move || {
            let rev = c.rev.fetch_add(1, Ordering::SeqCst) + 1;
            let new = Arc::new(Loaded::build(&old.name, &old.text, &setup, &here, rev));
            let mut p = c.program.lock().expect("program");
            if p.as_ref().is_some_and(|p| p.rev == old.rev) {
                *p = Some(new.clone());
                drop(p);
                c.hub.publish("program", new.summary.clone());
            }
        });
}

/// The line to run from after a job that did not complete, as `gantry stream` offers it
/// (commands/stream.rs, its report's `resume:` line): after an abort, an alarm on the path or a
/// lost link the line the board stood at (not before the run's first line), after an error its
/// line; `None` after a completed job or one that cannot be resumed by line.
fn resume_line(report: &crate::session::StreamReport, first_line: u32) -> Option<u32> {
    use gantry_machine::board::AlarmCode;
    let on_path = report
        .alarms
        .iter()
        .any(|a| a.code == AlarmCode::SoftLimit as u16 || a.code == AlarmCode::HostLost as u16);
    let link_lost = matches!(
        report.link,
        crate::session::LinkEnd::Closed | crate::session::LinkEnd::BoardReset
    );
    if report.completed {
        None
    } else if report.aborted || on_path || link_lost {
        Some(report.last_line.max(first_line))
    } else {
        report.errors.iter().find(|e| e.line != 0).map(|e| e.line)
    }
}

/// Runs a probing workflow on a job session of its own (unless a console job runs); its report
/// goes to every page as a `probe` event.
fn start_probe(c: &Arc<Console>, probe: Probe) -> Reply {
    if c.job.swap(true, Ordering::SeqCst) {
        return Err("a job started from the console is still running".into());
    }
    let c2 = c.clone();
    let run = move || {
        let result = Session::connect(Target::Port(c2.port.clone()), OnClose::KeepDtr)
            .map_err(|e| format!("{e:#}"))
            .and_then(|mut s| s.probe(&probe));
        let (ok, text) = match result {
            Ok(t) => (true, t),
            Err(e) => (false, format!("probing stopped: {e}")),
        };
        c2.job.store(false, Ordering::SeqCst);
        c2.notice(text.clone());
        c2.hub
            .publish("probe", json!({ "ok": ok, "text": text, "at": now_s() }));
    };
    std::thread::Builder::new()
        .name("console-probe".into())
        .spawn(run)
        .map_err(|e| {
            c.job.store(false, Ordering::SeqCst);
            e.to_string()
        })?;
    Ok("probing started".into())
}

/// Starts a job thread unless one runs, once the program passed the start check
/// (`crate::session::start`) with the board's setup: a program with an error is refused with
/// the check's report, and nothing moves.
fn start_job(c: &Arc<Console>, name: String, text: String, from: Option<u32>) -> Reply {
    let setup = c
        .setup
        .lock()
        .expect("setup")
        .clone()
        .ok_or("the board's setup is not read yet")?;
    let cleared = crate::session::check_text(&name, &text, &setup).map_err(|refused| {
        format!(
            "{}nothing was run: the program has an error (fix it and open it again)",
            refused.report
        )
    })?;
    if c.job.swap(true, Ordering::SeqCst) {
        return Err("a job started from the console is still running".into());
    }
    let c2 = c.clone();
    let _ = std::thread::Builder::new()
        .name("console-job".into())
        .spawn(move || job(c2, name, text, from, cleared))
        .map_err(|e| {
            c.job.store(false, Ordering::SeqCst);
            e.to_string()
        })?;
    Ok("started".into())
}

fn serve_client(c: &Arc<Console>, stream: TcpStream, addr: SocketAddr) {
    let Ok(read_half) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(read_half);
    let mut out = stream;
    loop {
        let head = match http::read_head(&mut reader) {
            Ok(h) => h,
            Err(http::ReadError::Closed) => return,
            Err(http::ReadError::Malformed) => {
                http::refuse_and_close(&mut out, "400 Bad Request", "not an HTTP request\n");
                return;
            }
            Err(http::ReadError::HeaderTooLarge) => {
                http::refuse_and_close(
                    &mut out,
                    "431 Request Header Fields Too Large",
                    &format!(
                        "a header line is at most {} bytes, at most {} header lines\n",
                        http::LINE_MAX,
                        http::HEADERS_MAX
                    ),
                );
                return;
            }
        };
        // A page from elsewhere must not drive the machine through the operator's browser: the
        // Host must be this console's (no DNS rebinding), and a command must be JSON (a
        // cross-site form cannot send that without a CORS preflight, which is never granted).
        if !head.host_ok(addr) {
            http::refuse_and_close(&mut out, "403 Forbidden", "wrong Host\n");
            return;
        }
        // The lock (`lock.rs`): nothing is read, shown or done without the token.
        if !c.lock.admits(&head) {
            http::refuse_and_close(
                &mut out,
                "401 Unauthorized",
                "the console needs its token: open the URL gantry serve printed \
                 (the token is also in its runtime directory)\n",
            );
            return;
        }
        let limit = if head.method == "POST" && head.path == "/api/program" {
            http::UPLOAD_MAX
        } else {
            http::BODY_MAX
        };
        if head.content_length > limit {
            http::refuse_and_close(
                &mut out,
                "413 Content Too Large",
                &format!("a request body is at most {limit} bytes here\n"),
            );
            return;
        }
        let Some(body) = http::read_body(&mut reader, head.content_length) else {
            return;
        };
        // The first visit (the printed URL with its token) gets the cookie; later ones send it.
        let cookie = if c.lock.in_query(&head) {
            c.lock.set_cookie()
        } else {
            String::new()
        };
        let asset = |out: &mut TcpStream, kind: &str, text: &str| {
            http::respond_with(out, "200 OK", kind, &cookie, text.as_bytes())
        };
        let ok = match (head.method.as_str(), head.path.as_str()) {
            ("GET", "/") | ("GET", "/index.html") => {
                asset(&mut out, "text/html; charset=utf-8", PAGE)
            }
            ("GET", "/console.js") => asset(&mut out, "text/javascript; charset=utf-8", SCRIPT),
            ("GET", "/console.css") => asset(&mut out, "text/css; charset=utf-8", STYLE),
            ("GET", "/events") => {
                events(c, out);
                return;
            }
            ("POST", path) if path.starts_with("/api/") => {
                if !head.json {
                    http::respond(
                        &mut out,
                        "415 Unsupported Media Type",
                        "text/plain",
                        b"commands are application/json\n",
                    );
                    return;
                }
                // A body that is not a JSON object is refused, never taken as an empty command;
                // an empty body is a command without arguments.
                let parsed = if body.iter().all(u8::is_ascii_whitespace) {
                    Ok(json!({}))
                } else {
                    match serde_json::from_slice::<Value>(&body) {
                        Ok(v) if v.is_object() => Ok(v),
                        Ok(_) => Err("the body must be a JSON object: nothing was done".to_owned()),
                        Err(e) => Err(format!(
                            "the request is not valid JSON ({e}): nothing was done"
                        )),
                    }
                };
                let (code, v) = match parsed {
                    Ok(body) => match api(c, &path[5..], &body) {
                        Ok(v) => ("200 OK", v),
                        Err(e) => ("200 OK", json!({ "ok": false, "error": e })),
                    },
                    Err(e) => ("400 Bad Request", json!({ "ok": false, "error": e })),
                };
                http::respond(&mut out, code, "application/json", v.to_string().as_bytes())
            }
            _ => http::respond(&mut out, "404 Not Found", "text/plain", b"not found\n"),
        };
        if !ok {
            return;
        }
    }
}

/// The Server-Sent Events stream of one page: the newest event of each kind, then every event
/// as it comes; a comment every second finds a page that went away.
fn events(c: &Console, mut out: TcpStream) {
    if !http::start_events(&mut out) {
        return;
    }
    let (mut seq, first) = c.hub.snapshot();
    for e in first {
        if out.write_all(e.as_bytes()).is_err() {
            return;
        }
    }
    loop {
        let (n, events) = c.hub.after(seq, Duration::from_secs(1));
        let text = if events.is_empty() {
            ": ping\n\n".to_owned()
        } else {
            events.concat()
        };
        if out.write_all(text.as_bytes()).is_err() || out.flush().is_err() {
            return;
        }
        seq = n;
    }
}

fn ok(message: String) -> Value {
    json!({ "ok": true, "message": message })
}

fn axis_of(v: &Value) -> Result<u8, String> {
    match v.get("axis") {
        Some(Value::String(s)) => AXIS_LETTERS
            .iter()
            .position(|a| s.eq_ignore_ascii_case(&a.to_string()))
            .map(|i| i as u8)
            .ok_or_else(|| format!("no axis {s}")),
        Some(Value::Number(n)) => n
            .as_u64()
            .filter(|&n| n < 6)
            .map(|n| n as u8)
            .ok_or_else(|| "no such axis".into()),
        _ => Err("which axis?".into()),
    }
}

fn api(c: &Arc<Console>, what: &str, body: &Value) -> Result<Value, String> {
    let m = match what {
        "hold" => c.ask(Cmd::Hold)?,
        "resume" | "continue" => c.ask(Cmd::Resume)?,
        "abort" => c.ask(Cmd::Abort)?,
        "override" => {
            let o = Overrides {
                feed: percent(body, "feed", 10, 200)?,
                rapid: percent(body, "rapid", 1, 100)?,
                spindle: percent(body, "spindle", 10, 200)?,
            };
            if o.feed.is_none() && o.rapid.is_none() && o.spindle.is_none() {
                return Err("which override? give feed, rapid or spindle".into());
            }
            c.ask(Cmd::Overrides(o))?
        }
        "jog" => {
            let step = num_in(body, "step", 0.0, 1000.0, " mm")?.unwrap_or(0.0);
            let feed = num_in(body, "feed", 1.0, 100_000.0, " mm/min")?.unwrap_or(1000.0);
            let dir = match args::num(body, "dir")? {
                None => 1,
                Some(d) if d == 1.0 || d == -1.0 => d as i8,
                Some(d) => return Err(format!("dir {d}: give 1 or -1")),
            };
            c.ask(Cmd::Jog {
                axis: axis_of(body)?,
                dir,
                step_nm: (step * 1e6).round() as u64,
                feed_um_min: (feed * 1000.0).round() as i32,
            })?
        }
        "jog_stop" => c.ask(Cmd::JogStop)?,
        "jog_alive" => c.ask(Cmd::JogKeepalive)?,
        "home" => {
            let axes = match body.get("axis") {
                None | Some(Value::Null) => 0,
                Some(_) => 1u8 << axis_of(body)?,
            };
            c.ask(Cmd::Home(axes))?
        }
        "unlock" => c.ask(Cmd::Unlock)?,
        "zero" => c.ask(Cmd::Zero(axis_of(body)?))?,
        "read_back" => c.ask(Cmd::ReadBack)?,
        "offset" => {
            // G10 L2 P1..P9 (G54..G59.3) with the values given, mm.
            let p = whole_in(body, "p", 1, 9)?.ok_or("P 1 (G54) to 9 (G59.3)")?;
            let mut block = format!("G21 G10 L2 P{p}");
            for l in AXIS_LETTERS {
                // Machine mm, as G10 L2 takes them: within any machine's reach.
                if let Some(v) = num_in(body, &l.to_string(), -1e6, 1e6, " mm")? {
                    block.push_str(&format!(" {l}{v:.4}"));
                }
            }
            c.ask(Cmd::Offsets(block))?
        }
        "mdi" => {
            let line = text(body, "line")?.unwrap_or("").trim();
            if line.is_empty() {
                return Err("an empty MDI block".into());
            }
            start_job(c, "mdi".into(), line.to_owned(), None)?
        }
        "program" => {
            let name = text(body, "name")?.unwrap_or("program.nc");
            let name = library::file_name(name).unwrap_or_else(|_| "program.nc".into());
            let text = text(body, "text")?.ok_or("no program text")?;
            let v = open_program(c, &name, text)?;
            // Kept in the library (a program chosen there again is stored again: its date).
            if let Some(lib) = &c.library {
                if let Err(e) = lib.store(&name, text, &v) {
                    c.notice(format!("the library did not keep {name}: {e}"));
                }
                c.hub.publish("library", json!({ "programs": lib.list() }));
            }
            return Ok(v);
        }
        "library" => {
            let lib = c.library()?;
            return Ok(json!({ "ok": true, "programs": lib.list(), "dir": lib.dir() }));
        }
        "library_open" => {
            let lib = c.library()?;
            let name = text(body, "name")?.ok_or("which program?")?;
            let text = lib.read(name)?;
            let name = library::file_name(name)?;
            let v = open_program(c, &name, &text)?;
            lib.store(&name, &text, &v)?;
            c.hub.publish("library", json!({ "programs": lib.list() }));
            return Ok(v);
        }
        "library_delete" => {
            let lib = c.library()?;
            let name = text(body, "name")?.ok_or("which program?")?;
            lib.remove(name)?;
            c.hub.publish("library", json!({ "programs": lib.list() }));
            format!("{name} removed from the library")
        }
        "macros" => {
            let lib = c
                .library
                .as_ref()
                .ok_or("serve keeps no macros (no data directory)")?;
            return Ok(json!({ "ok": true, "macros": lib.macros() }));
        }
        "macro_save" | "macro_delete" => {
            let lib = c
                .library
                .as_ref()
                .ok_or("serve keeps no macros (no data directory)")?;
            let name = text(body, "name")?.ok_or("which macro?")?;
            let blocks = if what == "macro_save" {
                Some(text(body, "text")?.ok_or("the macro's blocks?")?)
            } else {
                None
            };
            lib.set_macro(name, blocks)?;
            c.hub.publish("macros", json!({ "macros": lib.macros() }));
            format!(
                "macro {name} {}",
                if blocks.is_some() { "kept" } else { "removed" }
            )
        }
        "probe_plan" => {
            let p = probing::from_json(body, c.tool_now())?;
            let system = work_system_name(*c.system.lock().expect("system"));
            let g30 = c
                .setup
                .lock()
                .expect("setup")
                .as_ref()
                .map_or([0.0; 3], |s| {
                    let g = s.program.g30_home;
                    [0, 1, 2].map(|i| g[i] as f64 / 1e6)
                });
            return Ok(json!({ "ok": true, "plan": p.plan(system, g30) }));
        }
        "probe" => start_probe(c, probing::from_json(body, c.tool_now())?)?,
        "macro_run" => {
            let lib = c
                .library
                .as_ref()
                .ok_or("serve keeps no macros (no data directory)")?;
            let name = text(body, "name")?.ok_or("which macro?")?;
            let blocks = lib.macro_text(name)?;
            start_job(c, format!("macro {name}"), blocks, None)?
        }
        "loaded" => {
            let p = c.program.lock().expect("program").clone();
            return Ok(p.ok_or("no program is open")?.whole());
        }
        "run" => {
            let (name, text) = {
                let p = c.program.lock().expect("program");
                let p = p.as_ref().ok_or("open a program first")?;
                (p.name.clone(), p.text.clone())
            };
            let lines = Program::from_text(&text).len().max(1) as u64;
            let from = whole_in(body, "from_line", 1, lines)?.map(|n| n as u32);
            let m = start_job(c, name, text, from)?;
            // The path from where the tool stands now.
            refresh(c);
            m
        }
        "preamble" => {
            let p = c.program.lock().expect("program");
            let p = p.as_ref().ok_or("open a program first")?;
            let lines = Program::from_text(&p.text).len().max(1) as u64;
            let from = whole_in(body, "from_line", 1, lines)?.unwrap_or(1) as u32;
            let setup = c
                .setup
                .lock()
                .expect("setup")
                .clone()
                .ok_or("no setup yet")?;
            let program = Program::from_text(&p.text);
            // Shown before the run; the job computes it again where the machine stands then.
            let here = *c.here.lock().expect("here");
            let pre = resume_preamble(&program, &p.text, from, &setup, &here)
                .map_err(|e| format!("{e:#}"))?;
            return Ok(json!({ "ok": true, "preamble": pre }));
        }
        "setup_check" | "setup_push" => {
            let Some(text) = body.get("toml").and_then(Value::as_str) else {
                return Err(
                    "expected {\"toml\": \"<the setup file's text>\"}: nothing was changed".into(),
                );
            };
            if what == "setup_check" {
                let board = c.setup.lock().expect("setup").clone().unwrap_or_default();
                crate::setup_file::SetupFile::parse_for_push(text, &board)
                    .map_err(|e| format!("{e:#}"))?;
                "the setup is valid".into()
            } else {
                c.ask(Cmd::PushSetup(text.to_owned()))?
            }
        }
        _ => return Err(format!("no command {what}")),
    };
    Ok(ok(m))
}
