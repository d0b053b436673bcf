//! `gantry stream`: send a program to the board line by line, serve its subprogram jumps, show
//! progress and report how the job ended.
//!
//! The sender keeps the board's line buffer full through the link's credit window (no round trip
//! per line). It serves one *place* at a time: the main stream from line 1 (id 0), then whatever
//! the board asks for after an M98/M99 jump (a new id each time).

use crate::link::{Client, Transport};
use crate::program::{Program, ProgramTarget};
use anyhow::bail;
use gantry_machine::gcode::ErrorCode;
use gantry_proto::{BoardMsg, HostMsg, Line, MachineState, Status};

/// What the sender is serving now.
struct Serving {
    /// 0 = the main stream, else the id of the board's jump request.
    id: u16,
    next_line: u32,
    ended: bool,
    /// Blocks sent before `next_line` (a run-from-line preamble), as line 0.
    preamble: std::collections::VecDeque<String>,
}

impl Serving {
    fn at(id: u16, next_line: u32) -> Self {
        Serving {
            id,
            next_line,
            ended: false,
            preamble: Default::default(),
        }
    }
}

/// A rejected block, as the board reported it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BoardError {
    pub line: u32,
    pub code: u16,
    pub column: u16,
}

impl BoardError {
    /// The error as `gantry check` prints it ([`crate::check::format_error`]: `place:line: N.. error
    /// E231: …`, the source line, a caret under the word the board blamed).
    pub fn describe(&self, place: &str, program: &Program) -> String {
        let message = ErrorCode::ALL
            .iter()
            .find(|c| c.number() == self.code)
            .map(|c| c.message())
            .unwrap_or(match self.code {
                gantry_machine::board::ERROR_SOFT_LIMIT => {
                    "move exceeds the machine travel (soft limit)"
                }
                gantry_machine::board::ERROR_HOMING_REQUIRED => {
                    "the machine must be homed first (gantry home)"
                }
                gantry_machine::board::ERROR_BUSY => {
                    "the board is busy (a job, a homing cycle or a jog still moving): wait until it is Idle"
                }
                gantry_machine::board::ERROR_INVALID_REQUEST => {
                    "the board cannot carry this out (no such axis, no feed, or no axis to home)"
                }
                _ => "unknown error",
            });
        if self.line == 0 {
            return format!("resume preamble: error {}: {message}", self.code);
        }
        crate::check::format_error(&crate::check::ErrorReport {
            place,
            line: self.line,
            n_word: crate::program::n_word(program, self.line),
            code: Some(self.code),
            message,
            source: program.line(self.line),
            columns: program.source_columns(self.line, self.column),
        })
    }
}

/// An alarm the board raised, as it reported it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardAlarm {
    pub code: u16,
    /// Program line concerned (0 = none).
    pub line: u32,
}

/// Program text made safe for a terminal: control characters (an escape sequence in a comment
/// would otherwise reach the terminal raw) are shown as `\u{1b}`-style escapes.
pub fn printable(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_unicode().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// "alarm 2 (soft limit): a block would leave …" for an alarm number.
pub fn alarm_text(code: u16) -> String {
    match gantry_machine::controller::AlarmCode::from_number(code) {
        Some(a) => format!("alarm {code} ({}): {}", a.name(), a.message()),
        None => format!("alarm {code} (unknown to this gantry)"),
    }
}

impl BoardAlarm {
    /// The alarm's name and text, with the program line it concerns and that line's text.
    pub fn describe(&self, program: &Program) -> String {
        let text = alarm_text(self.code);
        if self.line == 0 {
            return text;
        }
        let source = printable(program.line(self.line).unwrap_or("").trim());
        format!(
            "line {}: {text}
    {source}",
            self.line
        )
    }
}

/// "X max switch" for a limit report.
pub fn limit_text(axis: u8, max: bool) -> String {
    let letter = gantry_machine::units::AXIS_LETTERS
        .get(axis as usize)
        .copied()
        .unwrap_or('?');
    format!(
        "limit switch {letter} {} stopped the motion",
        if max { "max" } else { "min" }
    )
}

/// Progress as the sender sees it.
#[derive(Clone, Debug, Default)]
pub struct Progress {
    /// Line the board is executing.
    pub line: u32,
    /// Lines in the file.
    pub total_lines: u32,
    /// Link clock, ms since the link opened.
    pub elapsed_ms: u32,
    pub status: Option<Status>,
}

/// How a streamed job ended.
#[derive(Clone, Debug)]
pub struct StreamReport {
    pub completed: bool,
    /// The job was aborted: from this sender (Ctrl-C), another command, or the board's stop input.
    pub aborted: bool,
    pub errors: Vec<BoardError>,
    pub alarms: Vec<BoardAlarm>,
    /// Limit switches that stopped motion (axis, max side), in the order reported.
    pub limits: Vec<(u8, bool)>,
    pub last_line: u32,
    /// Lines sent (main stream and subprogram serving).
    pub lines_sent: u32,
    pub jumps_served: u32,
    /// Link clock at the end, ms.
    pub elapsed_ms: u32,
    pub final_status: Option<Status>,
    /// How the link to the board ended.
    pub link: LinkEnd,
}

/// How the link ended for a stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkEnd {
    /// The board stayed with the sender to the end of the job.
    Kept,
    /// The board said nothing for this long (ms): the sender gave up (the board, if alive, holds
    /// the job by itself when the host is gone).
    Silent(u32),
    /// The board restarted during the job (its boot id changed): the job is gone.
    BoardReset,
}

/// Board silence (ms) after which the sender warns (the board reports its status every 100 ms).
pub const SILENT_WARN_MS: u32 = 2_000;
/// Board silence (ms) after which the sender gives up on the job.
pub const SILENT_GIVE_UP_MS: u32 = 10_000;

/// What the progress callback wants next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Continue,
    /// Stop streaming now and return (the board keeps the job; see [`continue_job`]).
    Detach,
    /// Send a feed hold, a resume or an abort, and go on.
    Hold,
    Resume,
    Abort,
}

/// Streams `program` over a connected link until the board reports the job done.
pub fn stream_program<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    let id = client.request_id();
    client.send(HostMsg::Start { id })?;
    run_job(
        client,
        program,
        Some(id),
        Some(Serving::at(0, 1)),
        None,
        on_progress,
    )
}

/// Takes over a job the board is already running (after the link was lost, or from a new
/// `gantry` process): the board asks for exactly the lines it is missing, and the job resumes
/// from where the board holds.
pub fn continue_job<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    client.send(HostMsg::Resume)?;
    // The job's messages from before (its errors, its end) are this command's to report.
    run_job(client, program, None, None, None, on_progress)
}

/// Streams `program` from line `from` after `preamble` (see [`crate::resume`]): the blocks that
/// rebuild the program's state there are sent first, as line 0.
pub fn stream_from_line<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    from: u32,
    preamble: Vec<String>,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    let id = client.request_id();
    client.send(HostMsg::StartFromLine { id, line_no: from })?;
    let mut serving = Serving::at(0, from);
    serving.preamble = preamble.iter().cloned().collect();
    run_job(
        client,
        program,
        Some(id),
        Some(serving),
        Some((from, preamble)),
        on_progress,
    )
}

/// Runs the job to its end. `start`: the id of the `Start` / `StartFromLine` request that began
/// it; queued messages before the board's answer to it are not about this job (an earlier
/// command's, or another command's through `gantry serve`) and are passed over.
fn run_job<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    start: Option<u32>,
    serving: Option<Serving>,
    resume: Option<(u32, Vec<String>)>,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    let start_ms = client.transport.now_ms();
    // Until the board says where to serve from, nothing is sent.
    let mut serving = serving.unwrap_or(Serving {
        ended: true,
        ..Serving::at(0, 1)
    });
    let mut report = StreamReport {
        completed: false,
        aborted: false,
        errors: Vec::new(),
        alarms: Vec::new(),
        limits: Vec::new(),
        last_line: 0,
        lines_sent: 0,
        jumps_served: 0,
        elapsed_ms: 0,
        final_status: None,
        link: LinkEnd::Kept,
    };
    let mut progress = Progress {
        total_lines: program.len(),
        ..Progress::default()
    };
    let mut last_heard = client.transport.now_ms();
    let mut awaiting = start;
    let mut done = false;
    let mut warned_silent = false;
    let operator = MANUAL_TOOL_CHANGE.load(std::sync::atomic::Ordering::Relaxed);
    let mut tool_change_answered = false;
    while !done {
        serve(client, program, &mut serving, &mut report)?;
        client.pump(1)?;
        if client.take_board_reset() {
            report.link = LinkEnd::BoardReset;
            report.elapsed_ms = client.transport.now_ms().wrapping_sub(start_ms);
            report.last_line = progress.line;
            return Ok(report);
        }
        let silent = client.silent_for_ms();
        if silent >= SILENT_GIVE_UP_MS {
            report.link = LinkEnd::Silent(silent);
            report.elapsed_ms = client.transport.now_ms().wrapping_sub(start_ms);
            report.last_line = progress.line;
            return Ok(report);
        }
        if silent >= SILENT_WARN_MS && !warned_silent {
            warned_silent = true;
            eprintln!(
                "gantry: no word from the board for {:.1} s (expected a status every 0.1 s); giving up after {} s",
                silent as f64 / 1000.0,
                SILENT_GIVE_UP_MS / 1000
            );
        } else if silent < SILENT_WARN_MS && warned_silent {
            warned_silent = false;
            eprintln!("gantry: the board is back");
        }
        let now = client.transport.now_ms();
        while let Some(msg) = client.recv() {
            if now.wrapping_sub(last_heard) > gantry_machine::board::link::HOST_TIMEOUT_MS {
                // The link was down long enough for the board to hold the job: resume it.
                client.send(HostMsg::Resume)?;
            }
            last_heard = now;
            match msg {
                BoardMsg::Status(s) => {
                    progress.line = s.line;
                    let at_tool_change = matches!(s.state, MachineState::ToolChange { .. });
                    if at_tool_change && !operator && !tool_change_answered {
                        // Nobody to change the tool: go on with the one in the spindle.
                        client.send(HostMsg::Resume)?;
                    }
                    tool_change_answered = at_tool_change && !operator;
                    progress.status = Some(s);
                }
                BoardMsg::Alarm { code, line } => report.alarms.push(BoardAlarm { code, line }),
                BoardMsg::Limit { axis, max } => report.limits.push((axis, max)),
                BoardMsg::Answer { id, code } if Some(id) == awaiting => {
                    awaiting = None;
                    if code != 0 {
                        // The board refused the start: no job runs, nothing more will come.
                        report.errors.push(BoardError {
                            line: 0,
                            code,
                            column: 0,
                        });
                        done = true;
                    }
                }
                // Queued before the answer to this job's start: not about this job.
                _ if awaiting.is_some() => {}
                BoardMsg::Error { line, code, column } => {
                    report.errors.push(BoardError { line, code, column });
                }
                BoardMsg::ProgramRequest { .. } if report.aborted => {}
                BoardMsg::ProgramRequest { id, target } => {
                    report.jumps_served += 1;
                    match (program.resolve(target), &resume) {
                        // A board that resynchronises before it ran the first resumed line asks
                        // for line 1 (it has taken only preamble blocks, numbered 0): serve the
                        // preamble again, then the resume line.
                        (_, Some((from, pre))) if matches!(target, ProgramTarget::Line(n) if n <= 1) =>
                        {
                            serving = Serving::at(id, *from);
                            serving.preamble = pre.iter().cloned().collect();
                        }
                        (Some(line), _) => serving = Serving::at(id, line),
                        (None, _) => {
                            client.send(HostMsg::ProgramEnd { id, found: false })?;
                            serving = Serving {
                                ended: true,
                                ..Serving::at(id, program.len() + 1)
                            };
                            if let ProgramTarget::Program(p) = target {
                                eprintln!(
                                    "gantry: the program calls O{p}, which is not in the file"
                                );
                            }
                        }
                    }
                }
                BoardMsg::JobDone { line, end } => {
                    report.last_line = line;
                    // Aborted elsewhere (another command, the board's stop input): not done.
                    report.aborted |= end == gantry_proto::JobEnd::Aborted;
                    done = true;
                }
                BoardMsg::Mark { .. }
                | BoardMsg::SetupChunk { .. }
                | BoardMsg::SetupEnd { .. }
                | BoardMsg::Answer { .. } => {}
            }
        }
        progress.elapsed_ms = client.transport.now_ms().wrapping_sub(start_ms);
        match on_progress(&progress) {
            Flow::Continue => {}
            Flow::Detach => {
                report.elapsed_ms = progress.elapsed_ms;
                return Ok(report);
            }
            Flow::Hold => client.send(HostMsg::FeedHold)?,
            Flow::Resume => client.send(HostMsg::Resume)?,
            Flow::Abort => {
                report.aborted = true;
                client.send(HostMsg::Abort)?;
                // Nothing more goes to an ending job: a line arriving while the abort
                // decelerates would stay in the board's line buffer after the job ended.
                serving.ended = true;
                serving.preamble.clear();
            }
        }
    }
    report.final_status = Some(fresh_status(client)?);
    report.elapsed_ms = client.transport.now_ms().wrapping_sub(start_ms);
    report.completed = report.errors.is_empty() && report.alarms.is_empty() && !report.aborted;
    Ok(report)
}

/// Whether an operator answers the board's tool-change stops (its M6 holds the job at rest,
/// [`MachineState::ToolChange`]). Set by the interactive `gantry stream` ([`run`]), which asks
/// the operator; otherwise (library callers: tests, `mdi`; a script feeding the emulated board)
/// the stream resumes such a stop at once, as if the tool were already in the spindle.
static MANUAL_TOOL_CHANGE: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Sends lines of the current place while the link has credit.
fn serve<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    serving: &mut Serving,
    report: &mut StreamReport,
) -> anyhow::Result<()> {
    while !serving.ended && client.queued_room() > 0 {
        if let Some(text) = serving.preamble.pop_front() {
            let line = Line::new(0, &text)
                .ok_or_else(|| anyhow::anyhow!("resume preamble block too long: {text}"))?;
            client.send(if serving.id == 0 {
                HostMsg::Line(line)
            } else {
                HostMsg::ProgramLine {
                    id: serving.id,
                    line,
                }
            })?;
            continue;
        }
        let n = serving.next_line;
        if n > program.len() {
            let end = if serving.id == 0 {
                HostMsg::EndOfJob
            } else {
                HostMsg::ProgramEnd {
                    id: serving.id,
                    found: true,
                }
            };
            client.send(end)?;
            serving.ended = true;
            break;
        }
        serving.next_line += 1;
        let text = match program.wire_text(n) {
            Ok(Some(t)) => t,
            Ok(None) => continue,
            Err(e) => bail!("{e}"),
        };
        let line = Line::new(n, &text).expect("wire_text checked the length");
        let msg = if serving.id == 0 {
            HostMsg::Line(line)
        } else {
            HostMsg::ProgramLine {
                id: serving.id,
                line,
            }
        };
        client.send(msg)?;
        report.lines_sent += 1;
    }
    Ok(())
}

/// Asks for a status report and waits for it (2 s of link time at most). Status reports already
/// received predate the request and are dropped; every other message (errors, alarms, program
/// requests, job ends) is kept for the next [`Client::recv`].
pub fn fresh_status<T: Transport>(client: &mut Client<T>) -> anyhow::Result<Status> {
    let mut kept = Vec::new();
    while let Some(m) = client.recv() {
        if !matches!(m, BoardMsg::Status(_)) {
            kept.push(m);
        }
    }
    let result = (|| {
        client.send(HostMsg::StatusRequest)?;
        for _ in 0..2000 {
            client.pump(1)?;
            while let Some(msg) = client.recv() {
                match msg {
                    BoardMsg::Status(s) => return Ok(s),
                    other => kept.push(other),
                }
            }
        }
        bail!("the board sent no status within 2 s (expected its answer to a status request)")
    })();
    client.put_back(kept);
    result
}

/// `Idle`, `Run`, … as users read it.
pub fn state_name(s: MachineState) -> &'static str {
    match s {
        MachineState::Idle => "Idle",
        MachineState::Run => "Run",
        MachineState::Hold { .. } => "Hold",
        MachineState::Jog => "Jog",
        MachineState::Alarm { .. } => "Alarm",
        MachineState::Homing => "Homing",
        MachineState::Check => "Check",
        MachineState::ToolChange { .. } => "ToolChange",
    }
}

/// Where `gantry` sends its commands.
pub enum Target {
    /// The built-in emulated board, with this setup.
    Emulated(Box<gantry_machine::setup::Setup>),
    /// A board on this serial port.
    Port(String),
}

fn mm(nm: i64) -> String {
    format!("{:.3}", nm as f64 / 1e6)
}

/// A position as `X 1.000  Y 2.000  Z 3.000` (mm, 3 decimals) for the first `axes` axes.
pub fn axes_line(p: &[i64], axes: usize) -> String {
    let names = gantry_machine::units::AXIS_LETTERS;
    (0..axes)
        .map(|i| format!("{} {}", names[i], mm(p[i])))
        .collect::<Vec<_>>()
        .join("  ")
}

/// Where `gantry stream` starts the job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// From line 1.
    Beginning,
    /// From a line, after the preamble that rebuilds the state there (`--from-line`).
    FromLine(u32),
    /// Take over the job the board is running (`--continue`).
    TakeOver,
}

/// Runs `gantry stream FILE [--from-line N | --continue]`: progress while it runs, a final
/// report, exit code 1 on errors. `setup` describes the machine for the run-from-line preamble
/// (the emulated board runs with it too).
pub fn run(
    file: &std::path::Path,
    target: Target,
    setup: gantry_machine::setup::Setup,
    start: Start,
) -> anyhow::Result<std::process::ExitCode> {
    run_with_cpu(file, target, setup, start, None)
}

/// [`run`] with a CPU model for the emulated board (`--cpu-model`, [`crate::cpu_model`]): its
/// main loop then takes the time the MCU would, and the report's underruns show whether that
/// MCU keeps up with the program.
pub fn run_with_cpu(
    file: &std::path::Path,
    target: Target,
    setup: gantry_machine::setup::Setup,
    start: Start,
    cpu: Option<crate::cpu_model::CpuModel>,
) -> anyhow::Result<std::process::ExitCode> {
    let program = Program::load(file)?;
    let text = std::fs::read_to_string(file)?;
    let wall = std::time::Instant::now();
    let from_board = matches!(target, Target::Port(_));
    // Someone must be able to continue a tool-change stop: the operator at a terminal (Enter) or
    // a board's cycle-start input. The emulated board fed from a script has neither, so there
    // the program runs through its M6 as the library streams do (no stop that nobody can end).
    let can_continue = from_board || std::io::IsTerminal::is_terminal(&std::io::stdin());
    MANUAL_TOOL_CHANGE.store(can_continue, std::sync::atomic::Ordering::Relaxed);
    if matches!(target, Target::Emulated(_)) {
        println!(
            "gantry: no --port given: streaming {} to the emulated board",
            file.display()
        );
    }
    let (mut client, board_setup) = match (target, cpu) {
        (Target::Emulated(setup), Some(model)) => {
            let mut board = crate::emulator::EmulatedBoard::new((*setup).clone());
            board.set_cpu_model(Some(model));
            let t: Box<dyn crate::link::Transport> = Box::new(board);
            (crate::link::Client::connect(t, 2000)?, *setup)
        }
        (target, _) => crate::commands::connect_with(target, crate::link::OnClose::DropDtr)?,
    };
    // The machine is what the board says it is.
    let setup = if from_board { board_setup } else { setup };
    let axes = setup.axis_count as usize;
    let eta = Eta::plan(&text, &setup);
    let report = match start {
        Start::Beginning => {
            check_can_start(&mut client)?;
            stream_with_progress(&mut client, &program, Resume::No, &eta)?
        }
        Start::TakeOver => {
            let state = fresh_status(&mut client)?.state;
            if !matches!(
                state,
                MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. }
            ) {
                anyhow::bail!(
                    "--continue: the board runs no job (it is {})",
                    state_name(state)
                );
            }
            stream_with_progress(&mut client, &program, Resume::TakeOver, &eta)?
        }
        Start::FromLine(n) => {
            check_can_start(&mut client)?;
            let here = fresh_status(&mut client)?.machine_pos;
            let pre = crate::resume::resume_preamble(&program, &text, n, &setup, &here)?;
            println!("resuming at line {n} after {} preamble blocks:", pre.len());
            for b in &pre {
                println!("    {b}");
            }
            stream_with_progress(&mut client, &program, Resume::FromLine(n, pre), &eta)?
        }
    };
    print_report(&report, &program, file, axes, wall.elapsed());
    if let Some(n) = client.transport.underruns() {
        println!("{}", underrun_line(n, cpu));
    }
    if let Some(s) = &report.final_status {
        let cfg = gantry_machine::motion::config::MotionConfig::from_setup(&setup);
        let steps = cfg.to_steps(&s.machine_pos);
        println!(
            "steps:    {}",
            (0..axes)
                .map(|i| format!("{} {}", gantry_machine::units::AXIS_LETTERS[i], steps[i]))
                .collect::<Vec<_>>()
                .join("  ")
        );
    }
    Ok(exit_code(&report))
}

fn exit_code(report: &StreamReport) -> std::process::ExitCode {
    if report.completed {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::from(1)
    }
}

/// A flag set by Ctrl-C (installed once per process).
pub fn ctrl_c_flag() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, OnceLock};
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        // If no handler can be installed, Ctrl-C keeps its default meaning (the board then holds
        // by itself when the link goes silent).
        let _ = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst));
        flag
    })
    .clone()
}

/// What standard input has said, read on a thread so the link keeps being serviced (the board
/// would otherwise count the host as gone) while the operator thinks.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Typed {
    Line(String),
    /// Standard input is closed (nobody to ask).
    Closed,
}

/// The next line typed since the last call, if any.
fn typed() -> Option<Typed> {
    use std::io::BufRead;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::mpsc::{channel, Receiver};
    use std::sync::{Mutex, OnceLock};
    static LINES: OnceLock<Mutex<Receiver<String>>> = OnceLock::new();
    static CLOSED: AtomicBool = AtomicBool::new(false);
    let rx = LINES.get_or_init(|| {
        let (tx, rx) = channel();
        std::thread::spawn(move || loop {
            let mut line = String::new();
            match std::io::stdin().lock().read_line(&mut line) {
                Ok(0) | Err(_) => {
                    CLOSED.store(true, Ordering::SeqCst);
                    break;
                }
                Ok(_) => {
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            }
        });
        Mutex::new(rx)
    });
    match rx.lock().expect("stdin lock").try_recv() {
        Ok(l) => Some(Typed::Line(l)),
        Err(_) if CLOSED.load(Ordering::SeqCst) => Some(Typed::Closed),
        Err(_) => None,
    }
}

/// Drops lines typed before a question was asked.
fn forget_typed() {
    while let Some(Typed::Line(_)) = typed() {}
}

/// Prints a question or message above the progress bar.
fn say(bar: Option<&indicatif::ProgressBar>, text: &str, newline: bool) {
    use std::io::Write;
    let print = || {
        if newline {
            eprintln!("{text}");
        } else {
            eprint!("{text}");
        }
        let _ = std::io::stderr().flush();
    };
    match bar {
        Some(b) => b.suspend(print),
        None => print(),
    }
}

/// What the operator is being asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Asking {
    Nothing,
    /// After a Ctrl-C hold: "abort the job?"; `y` aborts, anything else resumes, a closed
    /// standard input aborts.
    AbortAfterHold,
    /// At an M0/M1/M6 stop on this line: Enter resumes (so does cycle start on the machine).
    Stop(u32),
}

/// The job's remaining machine time, from the planner (the same motion core as the board, each
/// block's time in closed form: the exact time at 100 % override, dwells included); `None` when
/// the program cannot be planned.
///
/// The plan is kept as a timeline in the order the board runs it: one span per run of blocks of
/// one source line, so a subprogram called or repeated several times (M98 L, O-word repeat,
/// while) has a span per pass. The board reports only the line it executes; the span is the
/// next one of that line from the last match whose start the job's machine time has reached
/// (each pass of a repeated line in turn), and within a span (an arc, or passes of one line
/// back to back) the machine time places the job.
pub struct Eta {
    timeline: Vec<Span>,
    total: f64,
    /// Index of the span matched last (never goes back).
    cursor: std::cell::Cell<usize>,
    /// Planned time at which the streamed job starts (`--from-line`: the start of that line).
    offset: std::cell::Cell<f64>,
}

/// Consecutive blocks of one source line in the plan, machine seconds from the program's start.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    line: u32,
    start: f64,
    end: f64,
}

impl Eta {
    pub fn plan(text: &str, setup: &gantry_machine::setup::Setup) -> Option<Eta> {
        let src = gantry_machine::gcode::MemorySource::new(text.as_bytes());
        let mut actions = crate::preview::source::Actions::new(src, &setup.interp_config());
        let mut timeline: Vec<Span> = Vec::new();
        let seconds = crate::preview::plan::seconds;
        let counts = crate::preview::plan::plan_stream(actions.by_ref(), setup, &mut |r, end| {
            let (start, end) = (seconds(end.saturating_sub(r.counts)), seconds(end));
            match timeline.last_mut() {
                Some(s) if s.line == r.line => s.end = end,
                _ => timeline.push(Span {
                    line: r.line,
                    start,
                    end,
                }),
            }
        })
        .ok()?;
        if actions.ended != crate::preview::source::Ended::No {
            return None;
        }
        Some(Eta {
            timeline,
            total: seconds(counts),
            cursor: std::cell::Cell::new(0),
            offset: std::cell::Cell::new(0.0),
        })
    }

    /// The job starts at the first pass of `line` (`--from-line`: nothing before it runs).
    pub fn start_at(&self, line: u32) {
        if let Some(i) = self.timeline.iter().position(|s| s.line >= line) {
            self.cursor.set(i);
            self.offset.set(self.timeline[i].start);
        }
    }

    /// Machine seconds left when the board executes `line`, `elapsed_s` seconds into the job.
    pub fn left_at(&self, line: u32, elapsed_s: f64) -> f64 {
        let now = self.offset.get() + elapsed_s.max(0.0);
        let from = self.cursor.get();
        let mut pick = None;
        for (i, s) in self.timeline.iter().enumerate().skip(from) {
            if s.start > now && (pick.is_some() || s.start > 2.0 * now + 60.0) {
                break;
            }
            if s.line == line {
                pick = Some(i);
                if s.start > now {
                    break;
                }
            }
        }
        if let Some(i) = pick {
            self.cursor.set(i);
        }
        let done = self
            .timeline
            .get(self.cursor.get())
            .map_or(0.0, |s| now.clamp(s.start, s.end.max(s.start)));
        (self.total - done).max(0.0)
    }

    /// Total machine time of the program (seconds).
    pub fn total(&self) -> f64 {
        self.total
    }
}

/// The report line on the emulated board's underruns (gaps where its step kernel ran dry mid-job).
pub fn underrun_line(gaps: u64, cpu: Option<crate::cpu_model::CpuModel>) -> String {
    let model = match cpu {
        Some(m) => format!("CPU model {} at {} MHz", m.name, m.hz / 1_000_000),
        None => "no CPU model: main loop in no time, --cpu-model f411 charges it".to_owned(),
    };
    format!("underruns: {gaps} (the step kernel ran dry mid-job; {model})")
}

/// Seconds as h:mm:ss.
pub fn hms(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Refuses a start the board would refuse, with its reason: in alarm (with what clears it), or
/// busy with another job, jog or homing cycle.
pub fn check_can_start<T: Transport>(client: &mut Client<T>) -> anyhow::Result<()> {
    let status = fresh_status(client)?;
    match status.state {
        MachineState::Idle => Ok(()),
        MachineState::Alarm { code } => bail!(
            "the board is in {}\n  clear it first: gantry unlock (gantry home when homing is required)",
            alarm_text(code)
        ),
        MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. } => bail!(
            "the board is running a job (state {}, line {}): take it over with `gantry stream FILE --continue`, or `gantry abort` it",
            state_name(status.state),
            status.line
        ),
        other => bail!(
            "the board is busy ({}): wait until it is Idle",
            state_name(other)
        ),
    }
}

/// Streams with a live progress bar on a terminal, or a progress line every 10 % otherwise.
/// How [`stream_with_progress`] begins.
enum Resume {
    No,
    FromLine(u32, Vec<String>),
    TakeOver,
}

fn stream_with_progress<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    resume: Resume,
    eta: &Option<Eta>,
) -> anyhow::Result<StreamReport> {
    use std::io::IsTerminal;
    let total = program.len().max(1) as u64;
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:30} line {pos}/{len} {percent}%  {msg}")
                .expect("valid template"),
        );
        b
    });
    let mut last_decile = 0;
    let interrupted = ctrl_c_flag();
    let mut asking = Asking::Nothing;
    // A hold this sender asked for (Ctrl-C), as opposed to a program stop.
    let mut hold_requested = false;
    let mut last_stop_line = 0;
    let mut on_progress = |p: &Progress| {
        let ctrl_c = interrupted.swap(false, std::sync::atomic::Ordering::SeqCst);
        let state = p.status.as_ref().map(|s| s.state);
        match asking {
            Asking::AbortAfterHold => {
                // The link keeps running while the operator answers.
                let flow = match (ctrl_c, typed()) {
                    (true, _) => Some(Flow::Abort),
                    (false, Some(Typed::Closed)) => {
                        say(bar.as_ref(), "(no answer: standard input is closed)", true);
                        Some(Flow::Abort)
                    }
                    (false, Some(Typed::Line(l))) if l.trim().eq_ignore_ascii_case("y") => {
                        Some(Flow::Abort)
                    }
                    (false, Some(Typed::Line(_))) => Some(Flow::Resume),
                    (false, None) => None,
                };
                if let Some(f) = flow {
                    asking = Asking::Nothing;
                    hold_requested = false;
                    let text = if f == Flow::Abort {
                        "aborting the job"
                    } else {
                        "resuming the job"
                    };
                    say(bar.as_ref(), text, true);
                    return f;
                }
                return Flow::Continue;
            }
            Asking::Stop(_)
                if !matches!(
                    state,
                    Some(MachineState::Hold { .. } | MachineState::ToolChange { .. })
                ) =>
            {
                // Cycle start on the machine answered it.
                asking = Asking::Nothing;
            }
            Asking::Stop(_) => {
                if let Some(Typed::Line(_)) = typed() {
                    asking = Asking::Nothing;
                    return Flow::Resume;
                }
            }
            Asking::Nothing => {}
        }
        if ctrl_c {
            // Ctrl-C: hold first (decelerate on the path), then ask what to do.
            forget_typed();
            say(
                bar.as_ref(),
                "feed hold: abort the job? [y/N] (Ctrl-C again aborts) ",
                false,
            );
            asking = Asking::AbortAfterHold;
            hold_requested = true;
            return Flow::Hold;
        }
        if asking == Asking::Nothing
            && !hold_requested
            && matches!(
                state,
                Some(MachineState::Hold { stopped: true } | MachineState::ToolChange { .. })
            )
            && p.line != last_stop_line
        {
            let stop = match state {
                // The board names the tool it waits for.
                Some(MachineState::ToolChange { tool }) => {
                    Some(crate::program_stops::Stop::ToolChange { tool: Some(tool) })
                }
                _ => program
                    .wire_text(p.line)
                    .ok()
                    .flatten()
                    .and_then(|t| crate::program_stops::stop_in(&t))
                    .filter(|s| matches!(s, crate::program_stops::Stop::Program { .. })),
            };
            if let Some(stop) = stop {
                last_stop_line = p.line;
                forget_typed();
                say(
                    bar.as_ref(),
                    &crate::program_stops::message(stop, p.line),
                    true,
                );
                asking = Asking::Stop(p.line);
            }
        }
        let pct = (p.line as u64 * 100 / total).min(100);
        let machine_s = p.elapsed_ms as f64 / 1000.0;
        let left = match eta {
            Some(e) => format!("ETA {}", hms(e.left_at(p.line.max(1), machine_s))),
            None => "ETA -".to_owned(),
        };
        let state = state.map_or("-", state_name);
        match &bar {
            Some(b) => {
                b.set_position((p.line as u64).min(total));
                b.set_message(format!("{state}  {}  {left}", hms(machine_s)));
            }
            None => {
                if pct / 10 > last_decile {
                    last_decile = pct / 10;
                    println!(
                        "progress: line {}/{} ({pct}%)  {state}  {}  {left}",
                        p.line.min(total as u32),
                        total,
                        hms(machine_s)
                    );
                }
            }
        }
        Flow::Continue
    };
    if let (Resume::FromLine(n, _), Some(e)) = (&resume, eta) {
        e.start_at(*n);
    }
    let report = match resume {
        Resume::No => stream_program(client, program, &mut on_progress),
        Resume::FromLine(from, pre) => {
            stream_from_line(client, program, from, pre, &mut on_progress)
        }
        Resume::TakeOver => continue_job(client, program, &mut on_progress),
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    report
}

fn print_report(
    report: &StreamReport,
    program: &Program,
    file: &std::path::Path,
    axes: usize,
    wall: std::time::Duration,
) {
    for e in &report.errors {
        print!("{}", e.describe(&file.display().to_string(), program));
    }
    for &(axis, max) in &report.limits {
        println!("{}", limit_text(axis, max));
    }
    for a in &report.alarms {
        println!("{}", a.describe(program));
    }
    match report.link {
        LinkEnd::Kept => {}
        LinkEnd::Silent(ms) => {
            println!(
                "board silent: no word from the board for {:.1} s (expected a status every 0.1 s): the sender gave up",
                ms as f64 / 1000.0
            );
            println!("the board, if it is alive, holds the job by itself (host lost) and ends it after link.host_lost_stop_s");
            println!(
                "resume:   (when the board answers again) gantry stream {} --continue",
                file.display()
            );
            return;
        }
        LinkEnd::BoardReset => {
            println!(
                "board reset: the board restarted during the job (power, reset button or watchdog): the job is gone, the spindle stopped"
            );
            println!(
                "resume:   (after gantry home, or gantry unlock) gantry stream {} --from-line {}",
                file.display(),
                report.last_line.max(1)
            );
            return;
        }
    }
    let verdict = if report.completed {
        "job done"
    } else if report.aborted {
        "job aborted"
    } else {
        "job stopped"
    };
    println!(
        "{verdict}: last line {} of {}, {} lines sent, {} subprogram jumps served",
        report.last_line,
        program.len(),
        report.lines_sent,
        report.jumps_served
    );
    println!(
        "time:     {:.3} s machine time ({:.2} s wall)",
        report.elapsed_ms as f64 / 1000.0,
        wall.as_secs_f64()
    );
    // Abort, alarm 2 and alarm 20 stop the job on its path with the position kept.
    let stopped_on_path = report.alarms.iter().any(|a| {
        a.code == gantry_machine::controller::AlarmCode::SoftLimit as u16
            || a.code == gantry_machine::controller::AlarmCode::HostLost as u16
    });
    if report.aborted || stopped_on_path {
        println!(
            "resume:   {}gantry stream {} --from-line {}",
            if stopped_on_path {
                "(after gantry unlock) "
            } else {
                ""
            },
            file.display(),
            report.last_line.max(1)
        );
    } else if let Some(e) = report.errors.iter().find(|e| e.line != 0) {
        // An error ended the job: everything before its line ran, nothing from it on.
        println!(
            "resume:   (after fixing line {0}) gantry stream {1} --from-line {0}",
            e.line,
            file.display()
        );
    }
    if let Some(s) = &report.final_status {
        println!("machine:  {}", axes_line(&s.machine_pos, axes));
        println!("work:     {}", axes_line(&s.work_pos, axes));
        println!("state:    {}", state_name(s.state));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eta_follows_subprogram_repeats_in_execution_order() {
        use gantry_machine::setup::Setup;
        // The body (lines 4-5) runs three times: 10 mm in X, then 10 mm in Y, at F600 (1 s
        // each, plus ramps), then line 7 moves 20 mm back in X.
        let program = "G21 G90 F600\nO101 repeat [3]\nG91\nG1 X10\nG1 Y10\nO101 endrepeat\n\
                       G1 X-20\nM30\n";
        let eta = Eta::plan(program, &Setup::default()).unwrap();
        let lines: Vec<u32> = eta.timeline.iter().map(|s| s.line).collect();
        assert_eq!(lines, [4, 5, 4, 5, 4, 5, 7]);
        let total = eta.total();
        assert!((8.0..8.5).contains(&total), "{total}");
        let pass = |k: usize| eta.timeline[k].start;
        // First pass of line 4 at the start.
        assert_eq!(eta.left_at(4, 0.0), total);
        // The board reports line 4 again later on: the second pass (the line-ratio or
        // per-line lookup would still say the first).
        let t = pass(2) + 0.1;
        assert!((eta.left_at(4, t) - (total - t)).abs() < 1e-9);
        // Line 7 after the three passes: only its own move is left.
        let t = pass(6);
        assert!((eta.left_at(7, t) - (total - pass(6))).abs() < 1e-9);
        assert!(eta.left_at(7, t) < 2.2);
        // Never back: line 4 reported late (a stale status) keeps the estimate.
        assert!((eta.left_at(4, t) - (total - t)).abs() < 1e-9);
    }

    #[test]
    fn the_eta_from_a_line_counts_from_there() {
        let program = "G21 G90 F600\nG1 X10\nG1 X20\nG1 X30\nM30\n";
        let eta = Eta::plan(program, &gantry_machine::setup::Setup::default()).unwrap();
        eta.start_at(4);
        let left = eta.left_at(4, 0.0);
        // Line 4's 10 mm at F600 (~1 s) is what is left, not the whole program.
        assert!((0.9..1.2).contains(&left), "{left} of {}", eta.total());
        // The preamble runs first (reported as line 0): the estimate stays.
        assert_eq!(eta.left_at(0, 0.0), left);
    }

    #[test]
    fn program_text_never_reaches_the_terminal_with_control_characters() {
        let program = Program::from_text("G1 X1 (\u{1b}[2J\u{7}cleared)\n");
        let e = BoardError {
            line: 1,
            code: 900,
            column: 0,
        };
        let text = e.describe("p.nc", &program);
        assert!(
            !text.chars().any(|c| c.is_control() && c != '\n'),
            "{text:?}"
        );
        assert!(
            text.trim_end().ends_with("G1 X1 (\\u{1b}[2J\\u{7}cleared)"),
            "{text}"
        );
    }

    #[test]
    fn board_errors_print_as_check_does() {
        let program = Program::from_text("G0 X1\nN20 G1 (cut) Q2 X3 F1\n");
        // The board blames column 6 of the text it got, "N20G1Q2X3F1": the Q.
        let e = BoardError {
            line: 2,
            code: 211,
            column: 6,
        };
        let (check, _) = crate::check::human_report(
            "p.nc",
            b"G0 X1\nN20 G1 (cut) Q2 X3 F1\n",
            &Default::default(),
        );
        let text = e.describe("p.nc", &program);
        assert!(check.starts_with(&text), "{check}\n{text}");
        assert!(
            text.ends_with("    N20 G1 (cut) Q2 X3 F1\n                 ^^\n"),
            "{text}"
        );
    }

    #[test]
    fn eta_is_hours_minutes_seconds() {
        assert_eq!(hms(0.4), "0:00:00");
        assert_eq!(hms(3725.6), "1:02:06");
    }
}
