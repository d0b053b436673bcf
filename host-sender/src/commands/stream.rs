//! `gantry stream`: a job on a session (`crate::session`) with a progress bar or progress lines,
//! the operator's answers at stops (Ctrl-C hold then "abort?", Enter at M0/M1/M6), an ETA from the
//! planner, and the final report.

use super::{check_can_start, ctrl_c_flag};
use crate::link::OnClose;
use crate::present::{axes_line, hms, limit_text, starved_line, state_name, underrun_line};
use crate::program::Program;
use crate::program_stops;
use crate::resume::resume_preamble;
use crate::session::{Flow, JobStart, LinkEnd, Progress, Session, StreamReport, Target};
use gantry_emulator::EmulatedBoard;
use gantry_proto::MachineState;

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

/// The start check's refusal as `gantry stream` prints it: `gantry check`'s report, then why
/// nothing moved.
fn refusal_text(refused: &crate::session::Refused) -> String {
    let mut text = refused.report.clone();
    text.push_str(
        "gantry: nothing was run: the program was checked before the first move (fix it, or \
         stream it with --no-check to let the board stop at the error)\n",
    );
    text
}

/// Runs `gantry stream FILE [--from-line N | --continue]`: progress while it runs, a final
/// report, exit code 1 on errors. `setup` describes the machine for the run-from-line preamble
/// (the emulated board runs with it too); `cpu`, a CPU model for the emulated board
/// (`--cpu-model`, [`gantry_emulator::cpu_model`]): its main loop then takes the time the MCU
/// would, and the report's underruns show whether that MCU keeps up with the program. The whole
/// program is checked first unless `check` is false (`--no-check`,
/// for programs too long to check before they start). `through_stops` (`--through-stops`, the
/// emulated board in this process only): every M0/M1 and M6 stop is answered at once, for
/// unattended runs; without it a stop waits for the operator, and one nobody can answer (standard
/// input closed, no machine behind the emulated board) aborts the job instead of hanging.
pub fn run_checked(
    file: &std::path::Path,
    target: Target,
    setup: gantry_machine::setup::Setup,
    start: Start,
    cpu: Option<gantry_emulator::cpu_model::CpuModel>,
    check: bool,
    through_stops: bool,
) -> anyhow::Result<std::process::ExitCode> {
    // The file read once (its line lengths checked first: crate::program::check_line_lengths).
    crate::program::check_line_lengths(file)?;
    let text = std::fs::read_to_string(file)?;
    let program = Program::from_text(&text);
    let wall = std::time::Instant::now();
    let from_board = matches!(target, Target::Port(_));
    anyhow::ensure!(
        !(through_stops && from_board),
        "--through-stops answers the stops of the emulated board in this process only: on a \
         machine, only the operator continues a stop (Enter, cycle start, `gantry resume`)"
    );
    // The command that runs this program again on the same board, for the resume hints.
    let again = match &target {
        Target::Port(p) => format!("gantry --port {p} stream {}", file.display()),
        Target::Emulated(_) => format!("gantry stream {}", file.display()),
    };
    if matches!(target, Target::Emulated(_)) {
        println!(
            "gantry: no --port given: streaming {} to the emulated board",
            file.display()
        );
    }
    let mut session = match (target, cpu) {
        (Target::Emulated(setup), Some(model)) => {
            let mut board = EmulatedBoard::new((*setup).clone());
            board.set_cpu_model(Some(model));
            Session::emulated(board, *setup)?
        }
        // The sender that owns the job: if it dies, closing the port holds the job.
        (target, _) => Session::connect(target, OnClose::DropDtr)?,
    };
    // The machine is what the board says it is.
    let setup = if from_board {
        session.setup().clone()
    } else {
        setup
    };
    let axes = setup.axis_count as usize;
    // The one start check (`crate::session::start`), in constant memory.
    let cleared = if start == Start::TakeOver {
        None
    } else if check {
        let src = crate::preview::source::FileSource::open(file)
            .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
        match session.check_start(&file.display().to_string(), src)? {
            Ok(c) => {
                eprint!("{}", c.warnings());
                Some(c)
            }
            Err(refused) => {
                print!("{}", refusal_text(&refused));
                return Ok(std::process::ExitCode::from(1));
            }
        }
    } else {
        Some(crate::session::Cleared::unchecked())
    };
    let eta = Eta::plan(&text, &setup);
    let answers = if !from_board {
        StopAnswers::Itself {
            at_once: through_stops,
        }
    } else if session.served() {
        StopAnswers::MachineOrCommand
    } else {
        StopAnswers::Machine
    };
    let (report, stopped_ms) = match start {
        Start::Beginning => {
            check_can_start(&mut session)?;
            stream_with_progress(
                &mut session,
                &program,
                JobStart::Beginning,
                cleared,
                &eta,
                answers,
            )?
        }
        Start::TakeOver => {
            let state = session.status()?.state;
            if !matches!(
                state,
                MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. }
            ) {
                anyhow::bail!(
                    "--continue: the board runs no job (it is {})",
                    state_name(state)
                );
            }
            stream_with_progress(
                &mut session,
                &program,
                JobStart::TakeOver,
                None,
                &eta,
                answers,
            )?
        }
        Start::FromLine(n) => {
            check_can_start(&mut session)?;
            let here = session.status()?.machine_pos;
            let pre = resume_preamble(&program, &text, n, &setup, &here)?;
            println!("resuming at line {n} after {} preamble blocks:", pre.len());
            for b in &pre {
                println!("    {b}");
            }
            stream_with_progress(
                &mut session,
                &program,
                JobStart::FromLine(n, pre),
                cleared,
                &eta,
                answers,
            )?
        }
    };
    // The first line of the program this run was to run: a stop in a run-from-line preamble
    // (its blocks count as line 0) resumes there, not at line 1.
    let first_line = match start {
        Start::FromLine(n) => n,
        _ => 1,
    };
    print_report(
        &report,
        &program,
        &Again {
            file,
            command: &again,
            text: &text,
        },
        axes,
        wall.elapsed(),
        first_line,
        stopped_ms,
    );
    if let Some(n) = session.underruns() {
        println!("{}", underrun_line(n, cpu));
    }
    if let Some(s) = &report.final_status {
        println!("{}", starved_line(s.starved_ms));
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

/// Asks a question on the progress bar's line: the bar is cleared and stays hidden until
/// [`answered`], so that its updates never draw over the question or the answer being typed.
fn ask(bar: Option<&indicatif::ProgressBar>, question: &str) {
    use std::io::Write;
    match bar {
        Some(b) => {
            b.set_draw_target(indicatif::ProgressDrawTarget::hidden());
            // Carriage return and erase the line: the bar's last drawing goes.
            eprint!("\r\x1b[2K{question}");
        }
        None => eprint!("{question}"),
    }
    let _ = std::io::stderr().flush();
}

/// The question [`ask`] asked has its answer: the bar shows again.
fn answered(bar: Option<&indicatif::ProgressBar>) {
    if let Some(b) = bar {
        b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
    }
}

/// Prints a question or message above the progress bar.
fn say(bar: Option<&indicatif::ProgressBar>, text: &str) {
    use std::io::Write;
    let print = || {
        eprintln!("{text}");
        let _ = std::io::stderr().flush();
    };
    match bar {
        Some(b) => b.suspend(print),
        None => print(),
    }
}

/// Who else can answer a stop when this sender's standard input is closed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StopAnswers {
    /// Nobody: the emulated board in this process has no cycle start and no other command
    /// reaches it. `at_once` (`--through-stops`, the operator's choice on the command line):
    /// every program stop is answered as it comes; else a stop standard input cannot answer
    /// aborts the job.
    Itself { at_once: bool },
    /// The machine's cycle-start input (this sender owns the port).
    Machine,
    /// The machine's cycle start, or `gantry resume` from another terminal (through `gantry
    /// serve`).
    MachineOrCommand,
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
    /// The job is held and this sender did not ask for it (the board held it when its host went
    /// silent or away, the machine's hold input, another command's hold, or the hold a lost
    /// sender left to a take-over): Enter resumes (so do cycle start and `gantry resume`).
    Held,
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
pub(crate) struct Eta {
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
    pub(crate) fn plan(text: &str, setup: &gantry_machine::setup::Setup) -> Option<Eta> {
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
    pub(crate) fn start_at(&self, line: u32) {
        if let Some(i) = self.timeline.iter().position(|s| s.line >= line) {
            self.cursor.set(i);
            self.offset.set(self.timeline[i].start);
        }
    }

    /// Machine seconds left when the board executes `line`, `elapsed_s` seconds into the job.
    pub(crate) fn left_at(&self, line: u32, elapsed_s: f64) -> f64 {
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
    pub(crate) fn total(&self) -> f64 {
        self.total
    }
}

/// How far a job is, as the progress bar and lines show it: a fraction that never goes back.
/// With a plan ([`Eta`]) it is the planned machine time done, which follows every pass of a
/// loop or a repeated subprogram (the line the board reports goes back there, its file line
/// number is no measure); without one (a program the planner refuses), the furthest line reached
/// over the file's lines.
#[derive(Default)]
struct Advance {
    done: f64,
    furthest: u32,
}

impl Advance {
    /// The fraction done (0..=1) and the machine seconds left (with a plan) when the board
    /// reports `line`, `machine_s` into the job; `lines`: the file's lines.
    fn at(
        &mut self,
        eta: Option<&Eta>,
        line: u32,
        lines: u64,
        machine_s: f64,
    ) -> (f64, Option<f64>) {
        self.furthest = self.furthest.max(line);
        let (now, left) = match eta {
            Some(e) if e.total() > 0.0 => {
                let left = e.left_at(line.max(1), machine_s);
                (1.0 - left / e.total(), Some(left))
            }
            Some(e) => (
                self.furthest as f64 / lines.max(1) as f64,
                Some(e.left_at(line.max(1), machine_s)),
            ),
            None => (self.furthest as f64 / lines.max(1) as f64, None),
        };
        self.done = self.done.max(now.clamp(0.0, 1.0));
        (self.done, left)
    }
}

/// Streams with a live progress bar on a terminal, or a progress line every 10 % otherwise.
fn stream_with_progress(
    session: &mut Session,
    program: &Program,
    resume: JobStart,
    cleared: Option<crate::session::Cleared>,
    eta: &Option<Eta>,
    answers: StopAnswers,
) -> anyhow::Result<(StreamReport, u32)> {
    let emulated = matches!(answers, StopAnswers::Itself { .. });
    let at_once = answers == StopAnswers::Itself { at_once: true };
    use std::io::IsTerminal;
    let total = program.len().max(1) as u64;
    let bar = std::io::stderr().is_terminal().then(|| {
        // Position in per mille of the job ([`Advance`]), the line the board is at in the message.
        let b = indicatif::ProgressBar::new(1000);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:30} {percent}%  {msg}")
                .expect("valid template"),
        );
        b
    });
    let mut advance = Advance::default();
    let mut last_decile = 0;
    let interrupted = ctrl_c_flag();
    let mut asking = Asking::Nothing;
    // A hold this sender asked for (Ctrl-C), as opposed to a program stop.
    let mut hold_requested = false;
    // The line of the last stop the operator was asked about (a run-from-line preamble's stop,
    // an M6 there, is line 0).
    let mut last_stop_line = None;
    let mut told_closed = false;
    let taking_over = resume == JobStart::TakeOver;
    // When this sender last sent a resume (machine ms): the board's next reports may still show
    // the hold it ended, which is not a new hold to announce.
    let resumed_at: std::cell::Cell<Option<u32>> = std::cell::Cell::new(None);
    let mut told_take_over = false;
    // Machine time spent standing at holds and stops (M0/M1, M6), for the report, on the link
    // clock the report's machine time is taken on (`Progress::elapsed_ms`): each interval
    // between two progress calls counts as standing when the machine stood at rest at its start.
    // Counted first, before any answer returns early, so a wait at a prompt is never dropped.
    let mut stopped_ms = 0u32;
    let mut last_elapsed_ms = 0u32;
    let mut stood = false;
    // The in-process emulated board's clock runs only as the link is serviced, flat out while the
    // job moves; while the operator is asked something it is held to the wall clock's pace from
    // when the question came (`pace`), so the time standing there is the time the operator took.
    let mut paced_from = (std::time::Instant::now(), 0u32);
    let pace = |from: &(std::time::Instant, u32), now_ms: u32| {
        let board = u64::from(now_ms.saturating_sub(from.1));
        let wall = from.0.elapsed().as_millis() as u64;
        if board > wall {
            std::thread::sleep(std::time::Duration::from_millis(board - wall));
        }
    };
    let mut answer = |p: &Progress| {
        if emulated && asking == Asking::Nothing {
            paced_from = (std::time::Instant::now(), p.elapsed_ms);
        }
        let ctrl_c = interrupted.swap(false, std::sync::atomic::Ordering::SeqCst);
        let state = p.status.as_ref().map(|s| s.state);
        if stood {
            stopped_ms += p.elapsed_ms.saturating_sub(last_elapsed_ms);
        }
        last_elapsed_ms = p.elapsed_ms;
        stood = matches!(
            state,
            Some(MachineState::Hold { stopped: true } | MachineState::ToolChange { .. })
        );
        let standing = matches!(
            state,
            Some(MachineState::Hold { .. } | MachineState::ToolChange { .. })
        );
        if resumed_at
            .get()
            .is_some_and(|t| !standing || p.elapsed_ms.wrapping_sub(t) > 1000)
        {
            resumed_at.set(None);
        }
        match asking {
            Asking::AbortAfterHold => {
                // The link keeps running while the operator answers.
                let flow = match (ctrl_c, typed()) {
                    (true, _) => Some(Flow::Abort),
                    (false, Some(Typed::Closed)) => {
                        say(bar.as_ref(), "(no answer: standard input is closed)");
                        Some(Flow::Abort)
                    }
                    (false, Some(Typed::Line(l))) if l.trim().eq_ignore_ascii_case("y") => {
                        Some(Flow::Abort)
                    }
                    (false, Some(Typed::Line(_))) => Some(Flow::Resume),
                    (false, None) => {
                        if emulated {
                            pace(&paced_from, p.elapsed_ms);
                        }
                        None
                    }
                };
                if let Some(f) = flow {
                    answered(bar.as_ref());
                    asking = Asking::Nothing;
                    hold_requested = false;
                    let text = if f == Flow::Abort {
                        "aborting the job"
                    } else {
                        "resuming the job"
                    };
                    say(bar.as_ref(), text);
                    return f;
                }
                return Flow::Continue;
            }
            Asking::Stop(_) | Asking::Held
                if !matches!(
                    state,
                    Some(MachineState::Hold { .. } | MachineState::ToolChange { .. })
                ) =>
            {
                // Cycle start on the machine (or `gantry resume`) answered it.
                asking = Asking::Nothing;
                told_closed = false;
            }
            Asking::Stop(_) | Asking::Held => {
                match typed() {
                    Some(Typed::Line(_)) => {
                        asking = Asking::Nothing;
                        told_closed = false;
                        say(bar.as_ref(), "resuming the job");
                        return Flow::Resume;
                    }
                    // Nobody can answer on the emulated board in this process: the job ends
                    // rather than wait for ever (only the operator releases a stop; the
                    // operator's `--through-stops` answers them as they come).
                    Some(Typed::Closed) if emulated => {
                        say(
                            bar.as_ref(),
                            "(standard input is closed and nothing else can continue a stop on \
                             the emulated board in this process: aborting the job; run it from \
                             a terminal, or give --through-stops to answer its stops at once)",
                        );
                        asking = Asking::Nothing;
                        return Flow::Abort;
                    }
                    Some(Typed::Closed) if !told_closed => {
                        told_closed = true;
                        let who = if answers == StopAnswers::MachineOrCommand {
                            "cycle start on the machine, or `gantry resume` from another terminal"
                        } else {
                            "cycle start on the machine (`gantry resume` from another terminal \
                             reaches the board only through `gantry serve`)"
                        };
                        say(
                            bar.as_ref(),
                            &format!("(standard input is closed: waiting for {who})"),
                        );
                    }
                    _ => {
                        if emulated {
                            pace(&paced_from, p.elapsed_ms);
                        }
                    }
                }
            }
            Asking::Nothing => {}
        }
        if ctrl_c {
            // Ctrl-C: hold first (decelerate on the path), then ask what to do.
            forget_typed();
            ask(
                bar.as_ref(),
                "feed hold: abort the job? [y/N] (Ctrl-C again aborts) ",
            );
            asking = Asking::AbortAfterHold;
            hold_requested = true;
            return Flow::Hold;
        }
        if asking == Asking::Nothing
            && !hold_requested
            && resumed_at.get().is_none()
            && matches!(
                state,
                Some(MachineState::Hold { stopped: true } | MachineState::ToolChange { .. })
            )
            && last_stop_line != Some(p.line)
        {
            last_stop_line = Some(p.line);
            if let Some(stop) = program_stops::stop_at(state, program, p.line) {
                let source = program.line(p.line);
                say(
                    bar.as_ref(),
                    &program_stops::message_with(stop, p.line, source),
                );
                if at_once {
                    say(bar.as_ref(), "(--through-stops: continuing)");
                    return Flow::Resume;
                }
                forget_typed();
                asking = Asking::Stop(p.line);
            } else {
                // A hold this sender did not ask for: say what stopped the job and how it goes
                // on, and wait like at a program stop (never resumed from here on its own).
                let why = if taking_over && !told_take_over {
                    "the job this sender takes over is held (the sender that ran it was lost, \
                     or the job was held before)"
                        .to_owned()
                } else if p
                    .status
                    .as_ref()
                    .and_then(|st| st.outputs.torch)
                    .is_some_and(|t| t.arc_lost)
                {
                    "the plasma torch lost its arc: the job holds on its path with the torch off \
                     (going on re-fires the torch and waits for arc-OK before moving)"
                        .to_owned()
                } else if p.link_gap_ms > 0 {
                    format!(
                        "the board held the job while its link was silent for {:.1} s (host lost: \
                         spindle and coolant go off at rest)",
                        p.link_gap_ms as f64 / 1000.0
                    )
                } else {
                    "the job is held (the machine's hold input, another command's `gantry hold` \
                     or the console's Hold, or the host was lost)"
                        .to_owned()
                };
                told_take_over = true;
                let how = match answers {
                    StopAnswers::MachineOrCommand => {
                        "press Enter, cycle start on the machine, or `gantry resume` (or the \
                         console's Continue) to go on"
                    }
                    _ => "press Enter or cycle start on the machine to go on",
                };
                say(
                    bar.as_ref(),
                    &format!("line {}: {why}; {how}; Ctrl-C aborts", p.line),
                );
                forget_typed();
                asking = Asking::Held;
            }
        }
        if !matches!(
            state,
            Some(MachineState::Hold { .. } | MachineState::ToolChange { .. })
        ) && asking == Asking::Nothing
        {
            // Running again: the next stop (even on the same line) is announced again.
            last_stop_line = None;
        }
        let machine_s = p.elapsed_ms as f64 / 1000.0;
        let (done, left) = advance.at(eta.as_ref(), p.line, total, machine_s);
        let pct = (done * 100.0) as u64;
        let left = match left {
            Some(l) => format!("ETA {}", hms(l)),
            None => "ETA -".to_owned(),
        };
        let state = state.map_or("-", state_name);
        match &bar {
            Some(b) => {
                b.set_position((done * 1000.0) as u64);
                b.set_message(format!(
                    "line {}/{total}  {state}  {}  {left}",
                    p.line.min(total as u32),
                    hms(machine_s)
                ));
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
    let mut on_progress = |p: &Progress| {
        let flow = answer(p);
        if flow == Flow::Resume {
            resumed_at.set(Some(p.elapsed_ms));
        }
        flow
    };
    if let (JobStart::FromLine(n, _), Some(e)) = (&resume, eta) {
        e.start_at(*n);
    }
    let report = match cleared {
        Some(c) => session.start_job(program, resume, c, &mut on_progress),
        None => session.take_over_job(program, &mut on_progress),
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok((report?, stopped_ms))
}

/// How the report's resume hints run the program again: the command (`gantry --port P stream
/// FILE`, the port repeated) and the program's text (a line inside O-word control flow resumes
/// at the block's start, `crate::resume_blocks`).
struct Again<'a> {
    file: &'a std::path::Path,
    command: &'a str,
    text: &'a str,
}

impl Again<'_> {
    /// `COMMAND --from-line N` for a run meant to start at `line`, and why another line when it
    /// is inside a block.
    fn run_from(&self, line: u32) -> String {
        let at = crate::resume_blocks::resumable_line(self.text, line);
        if at == line {
            format!("{} --from-line {line}", self.command)
        } else {
            format!(
                "{} --from-line {at}   (line {line} is inside the O-word block that starts at line {at}: it runs again from there)",
                self.command
            )
        }
    }
}

fn print_report(
    report: &StreamReport,
    program: &Program,
    again: &Again,
    axes: usize,
    wall: std::time::Duration,
    first_line: u32,
    stopped_ms: u32,
) {
    let resume_line = report.last_line.max(first_line);
    for e in &report.errors {
        print!("{}", e.describe(&again.file.display().to_string(), program));
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
                "resume:   (when the board answers again) {} --continue",
                again.command
            );
            return;
        }
        LinkEnd::Closed => {
            println!(
                "link closed: gantry serve closed this sender's link mid-job (the board restarted, or the server ended)"
            );
            println!(
                "resume:   if the board restarted (the job is gone): {}",
                again.run_from(resume_line)
            );
            println!(
                "          if it still holds the job (serve ended): {} --continue",
                again.command
            );
            return;
        }
        LinkEnd::BoardReset => {
            println!(
                "board reset: the board restarted during the job (power, reset button or watchdog): the job is gone, the spindle stopped"
            );
            println!(
                "resume:   (after gantry home, or gantry unlock) {}",
                again.run_from(resume_line)
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
    let stopped_ms = stopped_ms.min(report.elapsed_ms);
    if stopped_ms > 0 {
        println!(
            "time:     {:.3} s machine time: {:.3} s running, {:.3} s standing at holds and stops ({:.2} s wall)",
            report.elapsed_ms as f64 / 1000.0,
            (report.elapsed_ms - stopped_ms) as f64 / 1000.0,
            stopped_ms as f64 / 1000.0,
            wall.as_secs_f64()
        );
    } else {
        println!(
            "time:     {:.3} s machine time ({:.2} s wall)",
            report.elapsed_ms as f64 / 1000.0,
            wall.as_secs_f64()
        );
    }
    // Abort, alarm 2 and alarm 20 stop the job on its path with the position kept.
    let stopped_on_path = report.alarms.iter().any(|a| {
        a.code == gantry_machine::board::AlarmCode::SoftLimit as u16
            || a.code == gantry_machine::board::AlarmCode::HostLost as u16
    });
    if report.aborted || stopped_on_path {
        println!(
            "resume:   {}{}",
            if stopped_on_path {
                "(after gantry unlock) "
            } else {
                ""
            },
            again.run_from(resume_line)
        );
    } else if let Some(e) = report.errors.iter().find(|e| e.line != 0) {
        // An error ended the job: everything before its line ran, nothing from it on.
        println!(
            "resume:   (after fixing line {}) {}",
            e.line,
            again.run_from(e.line)
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
    fn progress_never_goes_back_in_a_loop() {
        use gantry_machine::setup::Setup;
        // Lines 4-5 run three times, then line 7: the board reports 4 5 4 5 4 5 7, and the
        // line over the file's 8 lines (the old measure) went back from 62 % to 50 % twice.
        let program = "G21 G90 F600\nO101 repeat [3]\nG91\nG1 X10\nG1 Y10\nO101 endrepeat\n\
                       G1 X-20\nM30\n";
        let eta = Eta::plan(program, &Setup::default()).unwrap();
        let starts: Vec<(u32, f64)> = eta.timeline.iter().map(|s| (s.line, s.start)).collect();
        let mut advance = Advance::default();
        let mut last = 0.0;
        let mut seen = Vec::new();
        for (line, start) in starts {
            // Twice per pass: as it starts and half a second in.
            for t in [start, start + 0.5] {
                let (done, left) = advance.at(Some(&eta), line, 8, t);
                assert!(done >= last, "line {line} at {t} s: {done} after {last}");
                assert!((done - (1.0 - left.unwrap() / eta.total())).abs() < 1e-9);
                last = done;
                seen.push(done);
            }
        }
        // It advances through every pass (not stuck at the loop's first one), up to the end
        // of line 7's start.
        assert!(
            seen.windows(2).filter(|w| w[1] > w[0]).count() >= 12,
            "{seen:?}"
        );
        assert!(last > 0.7, "{last}");
        // Without a plan: the furthest line, held.
        let mut advance = Advance::default();
        assert_eq!(advance.at(None, 5, 8, 0.0), (5.0 / 8.0, None));
        assert_eq!(advance.at(None, 4, 8, 1.0), (5.0 / 8.0, None));
        assert_eq!(advance.at(None, 7, 8, 2.0), (7.0 / 8.0, None));
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
}
