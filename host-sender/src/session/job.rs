//! A job on the board, over a connected link: the program is streamed line by line through the
//! link's credit window (no round trip per line), one *place* at a time: the main stream from
//! line 1 (id 0), then whatever the board asks for after an M98/M99 jump (a new id each time).
//! Progress goes to a callback, which can hold, resume, abort or detach; the end is a
//! [`StreamReport`] (data only: `crate::present` words it).

use crate::link::{Client, Transport};
use crate::program::{Program, ProgramTarget};
use anyhow::bail;
use gantry_proto::lines::{push_record, record_len};
use gantry_proto::{BoardMsg, HostMsg, LineBatch, MachineState, Status};

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
    pub(crate) column: u16,
}

/// An alarm the board raised, as it reported it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardAlarm {
    pub code: u16,
    /// Program line concerned (0 = none).
    pub line: u32,
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
    /// The last gap in the board's messages long enough for the board to count its host as lost
    /// (more than `HOST_TIMEOUT_MS`: this process stalled, the cable was out), ms; 0 if none. A
    /// job the board held then stays held: the caller tells the operator why.
    pub link_gap_ms: u32,
}

/// How a streamed job ended.
#[derive(Clone, Debug)]
pub struct StreamReport {
    pub completed: bool,
    /// The job was aborted: from this sender (Ctrl-C), another command, or the board's stop input.
    pub(crate) aborted: bool,
    pub errors: Vec<BoardError>,
    pub alarms: Vec<BoardAlarm>,
    /// Limit switches that stopped motion (axis, max side), in the order reported.
    pub limits: Vec<(u8, bool)>,
    pub(crate) last_line: u32,
    /// Lines sent (main stream and subprogram serving).
    pub lines_sent: u32,
    pub jumps_served: u32,
    /// Link clock at the end, ms.
    pub elapsed_ms: u32,
    pub final_status: Option<Status>,
    /// How the link to the board ended.
    pub(crate) link: LinkEnd,
}

/// How the link ended for a stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LinkEnd {
    /// The board stayed with the sender to the end of the job.
    Kept,
    /// The board said nothing for this long (ms): the sender gave up (the board, if alive, holds
    /// the job by itself when the host is gone).
    Silent(u32),
    /// The board restarted during the job (its boot id changed): the job is gone.
    BoardReset,
    /// The link itself closed mid-job (`gantry serve` ended, or closed the link because the board
    /// restarted): the sender cannot tell which.
    Closed,
}

/// Board silence (ms) after which the sender warns (the board reports its status every 100 ms).
pub(crate) const SILENT_WARN_MS: u32 = 2_000;

/// Board silence (ms) after which the sender gives up on the job.
pub(crate) const SILENT_GIVE_UP_MS: u32 = 10_000;

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
    run(client, program, JobStart::Beginning, on_progress)
}

/// How a job begins ([`run`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum JobStart {
    /// From line 1.
    Beginning,
    /// From this line, after the preamble blocks that rebuild the program's state there
    /// ([`crate::resume`]).
    FromLine(u32, Vec<String>),
    /// Take over the job the board runs (the board asks for the lines it is missing).
    TakeOver,
}

/// Runs a job over a connected link to its end (see [`stream_program`], [`stream_from_line`],
/// [`continue_job`]). Nothing here ever releases a stop (a feed hold, a hold for a lost host, an
/// M0/M1, a tool change): only the operator does (docs/controller.md "Only the operator releases
/// a stop"), through the caller's [`Flow::Resume`] (its answer to the operator's Enter or
/// Continue), the machine's cycle start or another command's `resume`. A job standing at a stop
/// is waited on for as long as it stands.
pub(crate) fn run<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    start: JobStart,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    match start {
        JobStart::Beginning => begin(client, program, on_progress),
        JobStart::FromLine(n, pre) => from_line(client, program, n, pre, on_progress),
        JobStart::TakeOver => take_over(client, program, on_progress),
    }
}

fn begin<T: Transport>(
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
/// `gantry` process): the board asks for exactly the lines it is missing. A job the board holds
/// stays held until the operator resumes it (the caller's [`Flow::Resume`], cycle start or
/// `gantry resume`): a take-over releases no stop.
pub fn continue_job<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    run(client, program, JobStart::TakeOver, on_progress)
}

fn take_over<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    on_progress: &mut dyn FnMut(&Progress) -> Flow,
) -> anyhow::Result<StreamReport> {
    // `gantry serve` makes this command the job's owner on it (protocol 5.0), and the board
    // counts its host as back. Whatever stop the job stands at (the hold the lost sender left,
    // an M0/M1, a tool change) stays: the operator releases it, not the take-over.
    client.send(HostMsg::TakeOver)?;
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
    run(
        client,
        program,
        JobStart::FromLine(from, preamble),
        on_progress,
    )
}

fn from_line<T: Transport>(
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
    let mut batch = BatchSize::new();
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
    let mut awaiting = start;
    let mut done = false;
    let mut warned_silent = false;
    while !done {
        let pumped = send_lines(client, program, &mut serving, &mut batch, &mut report)
            .and_then(|()| client.pump(1));
        if pumped.is_err() && client.transport.closed() {
            report.link = LinkEnd::Closed;
            report.elapsed_ms = client.transport.now_ms().wrapping_sub(start_ms);
            report.last_line = progress.line;
            return Ok(report);
        }
        pumped?;
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
        // A gap in the board's messages (this process stalled, the cable came back) changes
        // nothing here: a job the board held meanwhile (host lost) stays held until the operator
        // resumes it; the gap is reported with the progress.
        if silent > gantry_machine::device::link::HOST_TIMEOUT_MS {
            progress.link_gap_ms = silent;
        }
        while let Some(msg) = client.recv() {
            match msg {
                BoardMsg::Status(s) => {
                    progress.line = s.line;
                    if s.state == MachineState::Run {
                        // Running again: a later hold is not the gap's.
                        progress.link_gap_ms = 0;
                    }
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

/// How many bytes of records the sender packs into one batch: it starts small and grows by an
/// eighth for every message the board acknowledged while the link retransmitted nothing, up to a
/// whole frame's worth;
/// every retransmission halves it. On a noisy line a long frame is likely damaged (at 3 % of bytes
/// damaged, a frame of 300 bytes almost never arrives whole, one of 40 bytes a third of the time),
/// and a frame once queued keeps its size until it arrives. Never less than one line.
pub(crate) struct BatchSize {
    limit: usize,
    retransmits: u32,
    /// Queued messages acknowledged when last asked.
    acked: u64,
}

impl BatchSize {
    /// The smallest limit: one short line with its record header.
    const MIN: usize = 32;

    pub(crate) fn new() -> Self {
        BatchSize {
            limit: Self::MIN,
            retransmits: 0,
            acked: 0,
        }
    }

    /// The limit for the next batch, given the link's retransmissions and the queued messages
    /// the board acknowledged so far.
    pub(crate) fn next(&mut self, retransmits: u32, acked: u64) -> usize {
        let newly_acked = acked.saturating_sub(self.acked);
        self.acked = acked;
        if retransmits != self.retransmits {
            self.retransmits = retransmits;
            self.limit = (self.limit / 2).max(Self::MIN);
        } else {
            for _ in 0..newly_acked.min(32) {
                self.limit = (self.limit + self.limit / 8 + 1).min(gantry_proto::lines::BATCH_MAX);
            }
        }
        self.limit
    }
}

impl Default for BatchSize {
    fn default() -> Self {
        Self::new()
    }
}

/// Sends lines of the current place while the link's send queue has room, packed into batches
/// (`gantry_proto::lines`: as many lines as a frame carries, docs/protocol.md "Line batches"); the
/// link sends each batch once the board's credit (bytes of its line ring) covers it.
fn send_lines<T: Transport>(
    client: &mut Client<T>,
    program: &Program,
    serving: &mut Serving,
    batch: &mut BatchSize,
    report: &mut StreamReport,
) -> anyhow::Result<()> {
    while !serving.ended && client.queued_room() > 0 {
        if serving.preamble.is_empty() && serving.next_line > program.len() {
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
        let mut records = LineBatch::new();
        let mut lines = 0;
        let acked = client.queued_sent() - client.unacked_queued() as u64;
        let limit = batch.next(client.stats().retransmits, acked);
        let fits = |records: &LineBatch, text: &str| {
            records.is_empty() || records.len() + record_len(text.len()) <= limit
        };
        while let Some(text) = serving.preamble.front() {
            if !fits(&records, text) || !push_record(&mut records, 0, text.as_bytes()) {
                if records.is_empty() {
                    bail!("resume preamble block too long: {text}");
                }
                break;
            }
            serving.preamble.pop_front();
        }
        while serving.preamble.is_empty() && serving.next_line <= program.len() {
            let n = serving.next_line;
            let text = match program.wire_text(n) {
                Ok(Some(t)) => t,
                Ok(None) => {
                    serving.next_line += 1;
                    continue;
                }
                Err(e) => bail!("{e}"),
            };
            // wire_text checked the length: only a full batch refuses the line.
            if !fits(&records, &text) || !push_record(&mut records, n, text.as_bytes()) {
                break;
            }
            serving.next_line += 1;
            lines += 1;
        }
        if !records.is_empty() {
            client.send(HostMsg::Lines {
                id: serving.id,
                records,
            })?;
            report.lines_sent += lines;
        }
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

/// A progress callback for an emulated board that stands for no machine (a simulation's trace,
/// tests): it answers every program stop (M0/M1, M6) once it stands, as an operator pressing
/// cycle start at once would. Never used for a board that drives a machine: there only the
/// operator releases a stop (`gantry stream --through-stops` is refused with `--port`).
pub struct ThroughStops {
    /// The line of the stop answered last, while the job still stands there.
    answered: Option<u32>,
}

impl ThroughStops {
    pub fn new() -> Self {
        ThroughStops { answered: None }
    }

    /// What to do at this progress: resume a program stop the job stands at, else go on.
    pub fn flow(&mut self, program: &Program, p: &Progress) -> Flow {
        let state = p.status.as_ref().map(|s| s.state);
        let standing = matches!(
            state,
            Some(
                gantry_proto::MachineState::Hold { stopped: true }
                    | gantry_proto::MachineState::ToolChange { .. }
            )
        );
        if !standing {
            self.answered = None;
            return Flow::Continue;
        }
        if self.answered != Some(p.line)
            && crate::program_stops::stop_at(state, program, p.line).is_some()
        {
            self.answered = Some(p.line);
            return Flow::Resume;
        }
        Flow::Continue
    }
}

impl Default for ThroughStops {
    fn default() -> Self {
        Self::new()
    }
}
