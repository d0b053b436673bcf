//! grbl 1.1 on the board's own port (docs/grbl.md): the text front end a grbl sender (UGS, CNCjs,
//! bCNC, Candle…) talks to when the first bytes of a connection are text rather than a framed
//! message (`device::link::LinkProtocol`). It feeds the same [`Board`] the framed link feeds: lines
//! go to the board's line buffer as the program source of a job, realtime bytes act as the
//! framed protocol's realtime messages do, and the answers come back as grbl's text.
//!
//! The pieces, one job each: [`rx`] line assembly and RX accounting, [`realtime`] the realtime
//! bytes, [`command`] and [`jog`] the `$` commands, [`settings`] the numbered settings over the
//! setup keys, [`report`] status and the other reports, [`codes`] the error numbers, [`text`]
//! the output bytes and number formats.
//!
//! Jobs: a line arriving with the board idle starts a job (a check job under `$C`); the job takes
//! the lines that follow; once every line is answered, none waits and the machine stands at rest
//! waiting for more, the front end ends the job (nothing is lost: the machine is at rest and the
//! modal state stays). A job the board ended early (an error, M2/M30) leaves the lines it did
//! not read unanswered; they are read again into a new job, as grbl runs the line after a bad
//! one. Each line is answered once the interpreter has taken it: `ok`, or `error:N` for its
//! error.

pub mod codes;
pub(crate) mod command;
pub(crate) mod door;
pub mod jog;
pub(crate) mod realtime;
pub mod report;
pub(crate) mod rx;
pub mod settings;
pub mod text;

use crate::board::{Board, BoardEvent, JogRefused, ProbeResult, Streamer};
use crate::device::kernel_view::KernelView;

/// Longest line (bytes, blanks and comments dropped) the grbl front end takes: more than grbl's
/// own 80, and with its line end well inside the 128-byte receive buffer grbl senders count on
/// (`rx.rs`). The framed link carries up to `board::LINE_CAPACITY` (256).
pub(crate) const LINE_CAPACITY: usize = 104;
use crate::board::{AlarmCode, State};
use crate::setup::STARTUP_LINE_LEN;
use command::{Command, Restore};
use door::Door;
use heapless::Deque;
use realtime::Realtime;
use report::Sparse;
use rx::Rx;
pub use rx::RX_SIZE;
use settings::Prefs;
use text::Out;

/// The welcome line, on connect and after a soft reset (senders look for "Grbl 1.1").
pub const BANNER: &str = "Grbl 1.1h ['$' for help]";

/// Lines in flight (on the board's line buffer or answered out of turn), at most.
const FLIGHTS: usize = 24;

/// Room the output must have before one more answer line is written.
const ANSWER_ROOM: usize = 48;

/// A line's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reply {
    Ok,
    Error(u16),
}

/// Where an unanswered line stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fate {
    /// In the board's line buffer or taken by its interpreter (`error`: the one it reported).
    OnBoard { error: Option<u16> },
    /// Answered as soon as the lines before it are.
    Decided(Reply),
}

/// A line read out of the RX ring (or a startup line) and not yet answered.
#[derive(Clone, Copy, Debug)]
struct Flight {
    line: u32,
    raw: usize,
    fate: Fate,
    /// A startup line (`$N0`/`$N1`, its index): answered as `>line:ok`.
    startup: Option<u8>,
    /// The line has `M2` or `M30`: grbl's `[MSG:Pgm End]` comes before its `ok`.
    program_end: bool,
}

/// The front end's session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Session {
    /// Lines are read and answered.
    Ready,
    /// A soft reset: the board is brought to rest, then the banner, then lines again.
    Resetting,
    /// A hard or soft limit alarm (grbl's critical event, `[MSG:Reset to continue]`): nothing
    /// but a soft reset is taken (a line answers `error:9`).
    ResetToContinue,
    /// `$SLP`: the job stopped, spindle and coolant off, status `Sleep`; only a soft reset wakes
    /// it.
    Sleeping,
}

/// A `$` command that runs across passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Busy {
    None,
    /// `$H` (its line's raw length): answered when homing ends.
    Homing {
        raw: usize,
    },
}

/// What a command did.
enum Step {
    Reply(Reply),
    /// Not now (the board must come to rest, or the output has no room): asked again next pass.
    Wait,
    Homing,
}

/// The grbl front end of one connection.
pub(crate) struct Grbl {
    rx: Rx,
    out: Out,
    realtime: Deque<Realtime, 16>,
    flights: Deque<Flight, FLIGHTS>,
    session: Session,
    busy: Busy,
    check_mode: bool,
    /// `!` came with the machine idle: grbl's `Hold:0` with nothing to hold; the next line's
    /// job starts held and waits for `~`.
    idle_hold: bool,
    door: Door,
    /// Startup lines still to run (bit i: `$Ni`), set with the banner.
    startup_due: u8,
    sparse: Sparse,
    status_due: bool,
    /// Line number of the next line given to the board.
    next_line: u32,
    /// The highest line the interpreter is known to have taken.
    taken_hint: u32,
    setup_changed: bool,
    /// The banner went out as the port opened: the connection's reset sends no second one.
    greeted: bool,
    /// The board's probe result last seen (`None` until the first service pass: a result from
    /// before the connection is not announced).
    probe_seen: Option<Option<ProbeResult>>,
}

impl Default for Grbl {
    fn default() -> Self {
        Self::new()
    }
}

impl Grbl {
    pub const fn new() -> Self {
        Grbl {
            rx: Rx::new(),
            out: Out::new(),
            realtime: Deque::new(),
            flights: Deque::new(),
            session: Session::Ready,
            busy: Busy::None,
            check_mode: false,
            idle_hold: false,
            door: Door::Closed,
            startup_due: 0,
            sparse: Sparse::new(),
            status_due: false,
            next_line: 1,
            taken_hint: 0,
            setup_changed: false,
            greeted: false,
            probe_seen: None,
        }
    }

    /// A new connection chose grbl: a fresh session that starts as grbl's power-up does, with
    /// the reset (overrides 100 %, the parser's defaults) and then one banner once the machine is
    /// at rest (a `0x18` among the first bytes joins this reset: no second banner).
    /// `greeted`: the banner went out already as the port opened ([`Grbl::greet`]): the reset
    /// runs without a second one.
    pub fn connect(&mut self, greeted: bool) {
        *self = Self::new();
        self.session = Session::Resetting;
        self.greeted = greeted;
    }

    /// The port opened and no byte came (`BoardLink`): grbl's power-up banner without waiting
    /// for the sender, as an Arduino grbl greets after the reset its DTR causes. Written while
    /// the connection's protocol is undecided; a framed host that speaks later gets the
    /// handshake after it (and discards the text as a broken frame).
    pub fn greet(&mut self, board: &Board) {
        self.out.clear();
        self.banner();
        if board.state() == State::Alarm {
            self.out.line("[MSG:'$H'|'$X' to unlock]");
        }
    }

    /// Drops output not yet sent (the connection chose the framed protocol).
    pub(crate) fn forget_output(&mut self) {
        self.out.clear();
    }

    /// The connection ended (DTR drop, port closed): grbl mode cannot resume a job later, so a
    /// running one is stopped on its path (it ends at rest with the program-stop sequence), and
    /// an idle machine's spindle and coolant go off at once (`Board::stop_outputs_at_rest`).
    pub fn disconnect(&mut self, board: &mut Board) {
        if matches!(
            board.state(),
            State::Run
                | State::Hold
                | State::ToolChange
                | State::Check
                | State::Jog
                | State::Homing
        ) {
            board.abort();
        }
        board.stop_outputs_at_rest();
        *self = Self::new();
    }

    /// The banner; the startup lines run next unless the machine is in alarm (as grbl's reset).
    fn banner(&mut self) {
        self.out.eol();
        self.out.line(BANNER);
        self.startup_due = 0b11;
    }

    /// Bytes from the host: realtime bytes are picked out, the rest is line text.
    pub fn on_bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match Realtime::of(b) {
                Some(Realtime::Reset) => {
                    // Everything received before the reset is gone at once.
                    self.rx.clear();
                    self.flights.clear();
                    self.realtime.clear();
                    let _ = self.realtime.push_back(Realtime::Reset);
                }
                Some(rt) => {
                    let _ = self.realtime.push_back(rt);
                }
                None => self.rx.push(b),
            }
        }
    }

    /// Bytes the link may take from the port now (`BoardLink::rx_room`): the receive buffer's
    /// room, so that a burst waits in the port (USB: the endpoint is not read, the host's NAKs
    /// pace the sender) instead of being dropped.
    pub fn rx_room(&self) -> usize {
        self.rx.free()
    }

    /// The next bytes for the host; returns how many were written to `out`.
    pub fn poll_transmit(&mut self, out: &mut [u8]) -> Option<usize> {
        match self.out.drain_into(out) {
            0 => None,
            n => Some(n),
        }
    }

    /// True once after `$x=` changed the setup: the owner persists `board.setup()`.
    pub(crate) fn take_setup_changed(&mut self) -> bool {
        core::mem::take(&mut self.setup_changed)
    }

    /// One service of the link (twice per main-loop pass, `device/main_loop.rs`).
    pub fn service(&mut self, board: &mut Board, view: &KernelView) {
        self.realtime_commands(board, view);
        self.door.poll(board, view);
        self.probe_message(board);
        self.board_events(board);
        if self.session == Session::Resetting {
            if !matches!(board.state(), State::Idle | State::Alarm) || self.out.room() < 128 {
                self.status(board, view);
                return;
            }
            self.session = Session::Ready;
            // grbl's reset puts the overrides back to 100 %.
            board.set_feed_override(100);
            board.set_rapid_override(100);
            board.set_spindle_override(100);
            if board.state() == State::Idle {
                // grbl's reset puts the parser back to its defaults (G0 G54 G17 G21 G90 G94 M5
                // M9, G92 cleared); rebuilding the board's setup in place does that, position and
                // homing kept.
                let setup = board.setup().clone();
                board.set_setup(setup);
            }
            if core::mem::take(&mut self.greeted) {
                // Greeted at the port's opening: the startup lines still follow the banner.
                self.startup_due = 0b11;
            } else {
                self.banner();
                if board.state() == State::Alarm {
                    self.out.line("[MSG:'$H'|'$X' to unlock]");
                }
            }
        }
        self.settle(board);
        if let Busy::Homing { raw } = self.busy {
            if board.state() != State::Homing && self.out.room() >= ANSWER_ROOM {
                self.busy = Busy::None;
                self.rx.answered(raw);
                self.emit(Reply::Ok);
                // grbl runs the startup lines after a homing cycle too.
                self.startup_due = 0b11;
            }
        }
        if self.busy == Busy::None && self.session == Session::Ready {
            self.run_startup_lines(board);
        }
        if self.busy == Busy::None {
            self.read_lines(board);
            self.end_idle_job(board);
        }
        self.status(board, view);
    }

    fn status(&mut self, board: &Board, view: &KernelView) {
        if self.status_due && self.out.room() >= report::STATUS_MAX {
            self.status_due = false;
            let rx_free = self.rx.free();
            report::status(
                &mut self.out,
                board,
                view,
                &Prefs::of(board.setup()),
                if self.session == Session::Sleeping {
                    "Sleep"
                } else if self.idle_hold && board.state() == State::Idle {
                    "Hold:0"
                } else {
                    self.door.state_name(board, view, self.check_mode)
                },
                rx_free,
                &mut self.sparse,
            );
        }
    }

    /// grbl's `[PRB:...]` once a probe move ends (before its alarm 5, if any, as grbl does).
    fn probe_message(&mut self, board: &Board) {
        let result = board.probe_result();
        if self.probe_seen == Some(result) || self.out.room() < report::STATUS_MAX {
            return;
        }
        if self.probe_seen.is_some() {
            report::probe(&mut self.out, board, &Prefs::of(board.setup()));
        }
        self.probe_seen = Some(result);
    }

    fn realtime_commands(&mut self, board: &mut Board, view: &KernelView) {
        while let Some(rt) = self.realtime.pop_front() {
            match rt {
                Realtime::Status => self.status_due = true,
                Realtime::FeedHold => {
                    if board.state() == State::Idle && !self.check_mode {
                        self.idle_hold = true;
                    }
                    board.feed_hold();
                }
                Realtime::CycleStart => {
                    // grbl resumes a feed hold only once it is complete (Hold:0), never
                    // during its deceleration (Hold:1).
                    let decelerating = board.state() == State::Hold && view.feed_um_min != 0;
                    self.idle_hold = false;
                    if !decelerating && self.door.resume(board) {
                        board.cycle_start();
                    }
                }
                Realtime::Reset => {
                    // Gantry's abort: decelerate on the path, the job ends at rest with the
                    // program-stop sequence (grbl cuts the steps and loses the position).
                    board.abort();
                    // A reset the sender asked for answers with its own banner.
                    self.greeted = false;
                    self.busy = Busy::None;
                    self.check_mode = false;
                    self.idle_hold = false;
                    self.door = Door::Closed;
                    self.session = Session::Resetting;
                }
                Realtime::JogCancel => board.jog_stop(),
                Realtime::Feed(step) => {
                    board.set_feed_override(realtime::feed_after(board.feed_override(), step))
                }
                Realtime::Rapid(pct) => board.set_rapid_override(pct),
                Realtime::SpindleSpeed(step) => {
                    board.set_spindle_override(realtime::feed_after(board.spindle_override(), step))
                }
                Realtime::SpindleStop => board.toggle_spindle_stop(),
                Realtime::Coolant { flood } => board.toggle_coolant(flood),
                Realtime::SafetyDoor => self.door.open(board),
                Realtime::Unknown => {}
            }
        }
    }

    fn board_events(&mut self, board: &mut Board) {
        while self.out.room() >= ANSWER_ROOM {
            let Some(e) = board.take_event() else {
                return;
            };
            match e {
                BoardEvent::Error { line, code, .. } if line != 0 => {
                    self.taken_hint = self.taken_hint.max(line);
                    for f in self.flights.iter_mut() {
                        if f.line == line {
                            if let Fate::OnBoard { error } = &mut f.fate {
                                error.get_or_insert(code);
                            }
                        }
                    }
                }
                BoardEvent::Error { .. } | BoardEvent::Limit { .. } | BoardEvent::Answer { .. } => {
                }
                BoardEvent::Alarm { code, .. } => {
                    self.out.str("ALARM:");
                    self.out.uint(code as u64);
                    self.out.eol();
                    if matches!(code, AlarmCode::HardLimit | AlarmCode::SoftLimit) {
                        // grbl's critical event: a soft reset before anything else.
                        self.out.line("[MSG:Reset to continue]");
                        self.session = Session::ResetToContinue;
                        self.busy = Busy::None;
                    }
                }
                BoardEvent::JobDone { line, .. } => self.taken_hint = self.taken_hint.max(line),
                // A line sender's job never jumps (`Streamer::LineSender`: M98 and O-word
                // loops are errors of their line).
                BoardEvent::Jump(_) => {}
            }
        }
    }

    /// The answer of `f`: a startup line's is echoed with it (`>G21G90:ok`); a program end's
    /// `ok` follows grbl's `[MSG:Pgm End]`.
    fn answer(&mut self, board: &Board, f: &Flight, r: Reply) {
        if f.program_end && r == Reply::Ok {
            self.out.line("[MSG:Pgm End]");
        }
        if let Some(i) = f.startup {
            self.out.byte(b'>');
            if let Some(line) = board.setup().grbl.startup.get(usize::from(i)) {
                self.out.str(line);
            }
            self.out.byte(b':');
        }
        self.emit(r);
    }

    fn emit(&mut self, r: Reply) {
        match r {
            Reply::Ok => self.out.line("ok"),
            Reply::Error(n) => {
                self.out.str("error:");
                self.out.uint(u64::from(n));
                self.out.eol();
            }
        }
    }

    /// Answers the lines the board has decided, oldest first.
    fn settle(&mut self, board: &Board) {
        let takes = board.line_room() != usize::MAX;
        let in_job = matches!(board.state(), State::Run | State::Hold | State::Check);
        let on_board = self
            .flights
            .iter()
            .filter(|f| matches!(f.fate, Fate::OnBoard { .. }))
            .count();
        let in_source = if takes {
            board.lines_buffered().min(on_board)
        } else {
            0
        };
        let mut taken = on_board - in_source;
        // grbl answers a probe line once the probe cycle has ended and its `[PRB:…]` is out:
        // while a probe move waits, runs or its result is not yet reported, the line the
        // interpreter took last (the probe's) waits.
        if board.probing() || self.probe_seen.is_some_and(|r| r != board.probe_result()) {
            taken = taken.saturating_sub(1);
        }
        while self.out.room() >= ANSWER_ROOM + STARTUP_LINE_LEN {
            let Some(f) = self.flights.front().copied() else {
                return;
            };
            let reply = match f.fate {
                Fate::Decided(r) => r,
                Fate::OnBoard { error } => {
                    let read = if takes {
                        taken > 0
                    } else if in_job {
                        // A stopping job: decided once it has ended.
                        return;
                    } else {
                        error.is_some() || f.line <= self.taken_hint
                    };
                    if read {
                        taken = taken.saturating_sub(1);
                        self.taken_hint = self.taken_hint.max(f.line);
                        error.map_or(Reply::Ok, |e| Reply::Error(codes::error_number(e)))
                    } else if takes {
                        return;
                    } else if board.state() == State::Alarm {
                        Reply::Error(codes::LOCKED)
                    } else {
                        // The job ended without reading it: read again into the next job.
                        self.flights.clear();
                        self.rx.rewind();
                        return;
                    }
                }
            };
            self.flights.pop_front();
            self.rx.answered(f.raw);
            self.answer(board, &f, reply);
        }
    }

    /// Runs the due startup lines (`$N0`, `$N1`) as a job of their own once the machine is idle
    /// with nothing in flight; in alarm they are dropped (grbl runs none then).
    fn run_startup_lines(&mut self, board: &mut Board) {
        match board.state() {
            _ if self.startup_due == 0 => return,
            State::Alarm => self.startup_due = 0,
            State::Idle if self.flights.is_empty() && !self.door.blocks_start() => {}
            _ => return,
        }
        for i in 0..2u8 {
            if self.startup_due & 1 << i == 0 {
                continue;
            }
            let mut buf = [0u8; STARTUP_LINE_LEN];
            let line = board.setup().grbl.startup[usize::from(i)].as_bytes();
            // (`min`: the string's capacity; copied byte by byte, no bounds-check panic paths.)
            let n = line.len().min(STARTUP_LINE_LEN);
            for (b, &c) in buf.iter_mut().zip(line) {
                *b = c;
            }
            if n == 0 {
                self.startup_due &= !(1 << i);
                continue;
            }
            let Ok(text) = core::str::from_utf8(buf.get(..n).unwrap_or_default()) else {
                return;
            };
            if board.state() == State::Idle && !board.start_job_from(Streamer::LineSender) {
                self.startup_due = 0;
                return;
            }
            if board.line_room() == 0 || !board.push_line(0, self.next_line, text) {
                return;
            }
            self.startup_due &= !(1 << i);
            let _ = self.flights.push_back(Flight {
                line: self.next_line,
                raw: 0,
                fate: Fate::OnBoard { error: None },
                startup: Some(i),
                program_end: false,
            });
            self.next_line = self.next_line.wrapping_add(1).max(1);
        }
    }

    /// Reads complete lines while the board and the output can take them.
    fn read_lines(&mut self, board: &mut Board) {
        while !self.flights.is_full() && self.out.room() >= 2 * ANSWER_ROOM {
            let mut buf = [0u8; LINE_CAPACITY];
            let Some(rx::Peeked { len: n, raw, cut }) = self.rx.peek_line(&mut buf) else {
                return;
            };
            let text = trim(buf.get(..n).unwrap_or_default());
            if cut || n > LINE_CAPACITY {
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::LINE_TOO_LONG));
                continue;
            }
            if matches!(self.session, Session::ResetToContinue | Session::Sleeping) {
                // Only a soft reset is taken (grbl ignores everything else; an answer keeps a
                // sender from waiting).
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::LOCKED));
                continue;
            }
            if text.is_empty() {
                self.rx.consume(raw);
                self.decided(raw, Reply::Ok);
                continue;
            }
            if text[0] == b'$' {
                if !self.flights.is_empty() {
                    return;
                }
                let mut up = [0u8; LINE_CAPACITY];
                let mut len = 0;
                for (u, &c) in up
                    .iter_mut()
                    .zip(text.iter().filter(|c| !c.is_ascii_whitespace()))
                {
                    *u = c.to_ascii_uppercase();
                    len += 1;
                }
                match self.command(board, up.get(..len).unwrap_or_default()) {
                    Step::Reply(r) => {
                        self.rx.consume(raw);
                        self.rx.answered(raw);
                        self.emit(r);
                    }
                    Step::Wait => return,
                    Step::Homing => {
                        self.rx.consume(raw);
                        self.busy = Busy::Homing { raw };
                        return;
                    }
                }
                continue;
            }
            let Ok(text) = core::str::from_utf8(text) else {
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::EXPECTED_LETTER));
                continue;
            };
            if has_negative_value(text.as_bytes()) {
                // grbl refuses a negative F, N, P, S or T as it reads the word (error 4).
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::NEGATIVE_VALUE));
                continue;
            }
            if has_spline(text.as_bytes()) {
                // grbl has no G5/G5.1 splines: its unsupported-command error, nothing run.
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::UNSUPPORTED));
                continue;
            }
            if !board.setup().grbl.m6_stop && has_m6(text.as_bytes()) {
                // grbl 1.1 has no tool change: its unsupported-command error, nothing run.
                self.rx.consume(raw);
                self.decided(raw, Reply::Error(codes::UNSUPPORTED));
                continue;
            }
            match board.state() {
                State::Alarm => {
                    self.rx.consume(raw);
                    self.decided(raw, Reply::Error(codes::LOCKED));
                    continue;
                }
                State::Idle => {
                    if self.door.blocks_start()
                        || self
                            .flights
                            .iter()
                            .any(|f| matches!(f.fate, Fate::OnBoard { .. }))
                    {
                        // Lines of the job that ended are not settled yet: never mix two jobs.
                        return;
                    }
                    let started = if self.check_mode {
                        board.start_check()
                    } else {
                        board.start_job_from(Streamer::LineSender)
                    };
                    if !started {
                        self.rx.consume(raw);
                        self.decided(raw, Reply::Error(codes::LOCKED));
                        continue;
                    }
                    if core::mem::take(&mut self.idle_hold) {
                        // The hold `!` asked for in Idle: the job waits for `~`.
                        board.feed_hold();
                    }
                }
                State::Homing | State::Jog => return,
                State::Run | State::Hold | State::ToolChange | State::Check => {}
            }
            let room = board.line_room();
            if room == 0 || room == usize::MAX || !board.push_line(0, self.next_line, text) {
                return;
            }
            self.rx.consume(raw);
            let _ = self.flights.push_back(Flight {
                line: self.next_line,
                raw,
                fate: Fate::OnBoard { error: None },
                startup: None,
                program_end: has_program_end(text.as_bytes()),
            });
            self.next_line = self.next_line.wrapping_add(1).max(1);
        }
    }

    /// A line answered without the board, in its turn.
    fn decided(&mut self, raw: usize, r: Reply) {
        let _ = self.flights.push_back(Flight {
            line: 0,
            raw,
            fate: Fate::Decided(r),
            startup: None,
            program_end: false,
        });
        self.settle_decided();
    }

    /// Answers decided lines at the front at once (nothing of the board's before them).
    fn settle_decided(&mut self) {
        while let Some(f) = self.flights.front().copied() {
            let Fate::Decided(r) = f.fate else {
                return;
            };
            self.flights.pop_front();
            self.rx.answered(f.raw);
            self.emit(r);
        }
    }

    /// Everything answered, nothing waiting, the machine at rest waiting for lines: the job ends
    /// (a new line starts the next one; the modal state stays).
    fn end_idle_job(&mut self, board: &mut Board) {
        if !self.flights.is_empty() || self.rx.has_line() || self.session != Session::Ready {
            return;
        }
        let idle = match board.state() {
            State::Run => board.waiting_for_lines(),
            State::Check => board.lines_buffered() == 0,
            _ => false,
        };
        if idle {
            board.end_of_lines(0);
        }
    }

    /// Commands that need the machine idle: `None` to go on, or the step to return (wait while
    /// a job that stands at rest ends; error 8 while something moves).
    fn idle_gate(&mut self, board: &mut Board, alarm_ok: bool) -> Option<Step> {
        match board.state() {
            State::Idle if self.idle_hold => Some(Step::Reply(Reply::Error(codes::IDLE_ONLY))),
            State::Idle => None,
            State::Alarm if alarm_ok => None,
            State::Run if board.waiting_for_lines() => {
                board.end_of_lines(0);
                Some(Step::Wait)
            }
            State::Check if board.lines_buffered() == 0 => {
                board.end_of_lines(0);
                Some(Step::Wait)
            }
            _ => Some(Step::Reply(Reply::Error(codes::IDLE_ONLY))),
        }
    }

    fn command(&mut self, board: &mut Board, line: &[u8]) -> Step {
        let cmd = match command::parse(line) {
            Ok(c) => c,
            Err(e) => return Step::Reply(Reply::Error(e)),
        };
        // The longest answers ($$, $#) need this much output room.
        if self.out.room() < 700 {
            return Step::Wait;
        }
        let ok = Step::Reply(Reply::Ok);
        match cmd {
            Command::Help => {
                self.out.line(
                    "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]",
                );
                ok
            }
            Command::Modes => {
                report::gcode_modes(&mut self.out, board, &Prefs::of(board.setup()));
                ok
            }
            Command::Info => {
                report::build_info(&mut self.out);
                ok
            }
            Command::StartupLines => {
                for (i, line) in board.setup().grbl.startup.iter().enumerate() {
                    self.out.str("$N");
                    self.out.uint(i as u64);
                    self.out.byte(b'=');
                    self.out.str(line);
                    self.out.eol();
                }
                ok
            }
            Command::SetStartupLine { index, line } => {
                if let Some(s) = self.idle_gate(board, false) {
                    return s;
                }
                Step::Reply(self.set_startup_line(board, index, line))
            }
            Command::Settings => {
                if let Some(s) = self.idle_gate(board, true) {
                    return s;
                }
                if !self.out.is_empty() {
                    // The listing (up to 52 lines) goes out whole: it waits for the output to
                    // drain rather than lose its tail to a full queue.
                    return Step::Wait;
                }
                self.settings(board);
                ok
            }
            Command::Params => {
                if let Some(s) = self.idle_gate(board, true) {
                    return s;
                }
                report::parameters(&mut self.out, board, &Prefs::of(board.setup()));
                ok
            }
            Command::Set { number, value } => {
                if let Some(s) = self.idle_gate(board, number == 10 || number == 13) {
                    return s;
                }
                Step::Reply(self.set(board, number, value))
            }
            Command::Check => {
                if self.check_mode {
                    // grbl soft-resets as check mode ends: the parser's position and modes
                    // come back from the machine.
                    self.check_mode = false;
                    if board.state() == State::Check {
                        board.abort();
                    }
                    self.out.line("[MSG:Disabled]");
                    self.session = Session::Resetting;
                    return ok;
                }
                if let Some(s) = self.idle_gate(board, false) {
                    return s;
                }
                self.check_mode = true;
                self.out.line("[MSG:Enabled]");
                ok
            }
            Command::Unlock => {
                if board.state() == State::Alarm {
                    board.unlock();
                    if board.state() == State::Alarm {
                        // Gantry keeps the homing lock (grbl would lift it), and the alarm
                        // while a limit switch is pressed (`board/pressed_switch.rs`): say so.
                        if board.pressed_limits() != 0 {
                            self.out
                                .line("[MSG:Limit switch pressed: jog off it ('$J='), then '$X']");
                        } else if board.alarm() == Some(AlarmCode::HomingRequired) {
                            self.out.line("[MSG:Homing required: '$H' to home]");
                        }
                        return Step::Reply(Reply::Error(codes::LOCKED));
                    }
                    self.out.line("[MSG:Caution: Unlocked]");
                }
                ok
            }
            // Nothing moves behind an open door (grbl: error 8).
            Command::Home(_) | Command::Jog(_) if self.door.blocks_start() => {
                Step::Reply(Reply::Error(codes::IDLE_ONLY))
            }
            Command::Home(axes) => {
                if let Some(s) = self.idle_gate(board, true) {
                    return s;
                }
                if board.pressed_limits() != 0 {
                    self.out
                        .line("[MSG:Limit switch pressed: jog off it ('$J='), then '$X']");
                    return Step::Reply(Reply::Error(codes::LOCKED));
                }
                if board.home(axes) {
                    Step::Homing
                } else {
                    Step::Reply(Reply::Error(codes::HOMING_DISABLED))
                }
            }
            Command::Jog(words) => {
                if board.state() != State::Jog {
                    // In the alarm, a jog off a pressed limit switch (the board decides).
                    let off_switch = board.pressed_limits() != 0;
                    if let Some(s) = self.idle_gate(board, off_switch) {
                        return s;
                    }
                }
                let modal = board.interpreter().state();
                let from = board.motion().queued_position();
                let axes = usize::from(board.setup().axis_count);
                let j = match jog::parse(words, modal, &from, axes) {
                    Ok(j) => j,
                    Err(e) => return Step::Reply(Reply::Error(e)),
                };
                match board.jog_to(j.to, j.feed) {
                    Ok(()) => ok,
                    Err(JogRefused::Busy) => Step::Wait,
                    Err(JogRefused::Travel) => Step::Reply(Reply::Error(codes::JOG_TRAVEL)),
                    Err(JogRefused::HomingRequired) => Step::Reply(Reply::Error(codes::LOCKED)),
                    Err(JogRefused::Invalid) => Step::Reply(Reply::Error(codes::JOG_INVALID)),
                    Err(JogRefused::LimitPressed) => Step::Reply(Reply::Error(codes::LOCKED)),
                }
            }
            Command::Restore(what) => {
                if let Some(s) = self.idle_gate(board, false) {
                    return s;
                }
                let r = self.restore(board, what);
                if r == Reply::Ok {
                    self.out.line("[MSG:Restoring defaults]");
                }
                Step::Reply(r)
            }
            // grbl stores the text to show in `$I`; Gantry's build info is fixed (docs/grbl.md).
            Command::SetInfo => ok,
            Command::Sleep => {
                board.abort();
                board.stop_outputs_at_rest();
                self.out.line("[MSG:Sleeping]");
                self.session = Session::Sleeping;
                ok
            }
        }
    }

    fn settings(&mut self, board: &Board) {
        let setup = board.setup();
        for n in settings::numbers(setup.axis_count) {
            if let Some(v) = settings::read(n, setup) {
                self.out.byte(b'$');
                self.out.uint(u64::from(n));
                self.out.byte(b'=');
                if v.decimals {
                    self.out.fixed(v.milli, 1000, 3);
                } else {
                    self.out.int(v.milli / 1000);
                }
                self.out.eol();
            }
        }
    }

    fn set(&mut self, board: &mut Board, number: u16, value: &[u8]) -> Reply {
        let Some(milli) = text::parse_scaled(value, 1000) else {
            return Reply::Error(codes::BAD_NUMBER);
        };
        let mut setup = board.setup().clone();
        if let Err(e) = settings::write(number, milli, &mut setup) {
            return Reply::Error(e);
        }
        // The same check as a setup push (machine/src/setup/validate.rs); refused, the
        // setting stays as it was.
        if let Err(e) = setup.validate() {
            return self.refuse(&e);
        }
        // $10 and $13 are the front end's own section (stored, nothing rebuilt); the rest are
        // setup keys. (No comparison of the whole setup: its derived equality costs the
        // firmware about 1 KiB of flash.)
        if number == 10 || number == 13 {
            board.set_grbl_setup(setup.grbl);
        } else if !board.set_setup(setup) {
            return Reply::Error(codes::IDLE_ONLY);
        }
        self.setup_changed = true;
        Reply::Ok
    }

    /// `$Nn=line`: checked as grbl does by parsing it as a block (its error answers; a `$`
    /// command is refused), then stored.
    fn set_startup_line(&mut self, board: &mut Board, index: u8, line: &[u8]) -> Reply {
        if line.first() == Some(&b'$') {
            return Reply::Error(codes::INVALID_STATEMENT);
        }
        let Ok(text) = core::str::from_utf8(line) else {
            return Reply::Error(codes::EXPECTED_LETTER);
        };
        let mut stored = heapless::String::new();
        if stored.push_str(text).is_err() {
            return Reply::Error(codes::LINE_TOO_LONG);
        }
        let mut lexer = crate::gcode::lexer::Lexer::new(line, true);
        if lexer.start() != crate::gcode::lexer::LineStart::Block {
            return Reply::Error(codes::INVALID_STATEMENT);
        }
        match crate::gcode::block::parse_block(&mut lexer, board.interpreter().config()) {
            Err((e, _)) => return Reply::Error(codes::error_number(e.number())),
            // grbl has no G5/G5.1 splines.
            Ok(b)
                if b.g(crate::gcode::block::GGroup::Motion).is_some_and(|c| {
                    matches!(c.code, crate::gcode::codes::G5 | crate::gcode::codes::G5_1)
                }) =>
            {
                return Reply::Error(codes::UNSUPPORTED)
            }
            Ok(_) => {}
        }
        let mut grbl = board.setup().grbl.clone();
        if let Some(line) = grbl.startup.get_mut(usize::from(index)) {
            *line = stored;
        }
        board.set_grbl_setup(grbl);
        self.setup_changed = true;
        Reply::Ok
    }

    fn restore(&mut self, board: &mut Board, what: Restore) -> Reply {
        let mut setup = board.setup().clone();
        if matches!(what, Restore::Settings | Restore::All) {
            let defaults = crate::setup::Setup::default();
            for n in settings::numbers(setup.axis_count) {
                if let Some(v) = settings::read(n, &defaults) {
                    let _ = settings::write(n, v.milli, &mut setup);
                }
            }
        }
        if what == Restore::All {
            setup.grbl.startup = Default::default();
        }
        if matches!(what, Restore::Offsets | Restore::All) {
            setup.program.work_offsets = Default::default();
            setup.program.g28_home = Default::default();
            setup.program.g30_home = Default::default();
        }
        if let Err(e) = setup.validate() {
            return self.refuse(&e);
        }
        if !board.set_setup(setup) {
            return Reply::Error(codes::IDLE_ONLY);
        }
        self.setup_changed = true;
        Reply::Ok
    }

    /// A setting refused by the setup's validation: `[MSG:Refused: <reason>]` (with the
    /// allowed range when out of range, in the setting's file units) and its grbl error.
    fn refuse(&mut self, e: &crate::setup::SetupError) -> Reply {
        self.out.str("[MSG:Refused: ");
        self.out.str(e.reason.text());
        if e.reason == crate::setup::Reason::OutOfRange {
            let row = e.key.row();
            let (scale, decimals) = match row.unit.scale() {
                1 => (1, 0),
                s => (s, 3),
            };
            self.out.byte(b' ');
            self.out.fixed(row.min(), scale, decimals);
            self.out.str(" to ");
            self.out.fixed(row.max(), scale, decimals);
        }
        self.out.line("]");
        Reply::Error(settings::refusal(e))
    }
}

/// The line (blanks and comments already dropped) has an `M6` word (`M6`, `M06`, `m6`).
fn has_m6(line: &[u8]) -> bool {
    line.iter().enumerate().any(|(i, &c)| {
        if c | 0x20 != b'm' {
            return false;
        }
        let digits = line.get(i + 1..).unwrap_or_default();
        let n = digits.iter().take_while(|d| d.is_ascii_digit()).count();
        let number = digits.get(..n).unwrap_or_default();
        let after = digits.get(n).copied();
        after != Some(b'.')
            && !number.is_empty()
            && number.iter().rev().skip(1).all(|&d| d == b'0')
            && number.last() == Some(&b'6')
    })
}

/// The M word number `n` (`M2`, `M02`, `m30`…) is in the line (blanks and comments dropped).
fn has_m_code(line: &[u8], n: u32) -> bool {
    line.iter().enumerate().any(|(i, &c)| {
        if c | 0x20 != b'm' {
            return false;
        }
        let digits = line.get(i + 1..).unwrap_or_default();
        let k = digits.iter().take_while(|d| d.is_ascii_digit()).count();
        let number = digits.get(..k).unwrap_or_default();
        k > 0
            && k <= 4
            && digits.get(k) != Some(&b'.')
            && number
                .iter()
                .fold(0u32, |v, &d| v * 10 + u32::from(d - b'0'))
                == n
    })
}

/// The line ends the program (`M2` or `M30`).
fn has_program_end(line: &[u8]) -> bool {
    has_m_code(line, 2) || has_m_code(line, 30)
}

/// The line (blanks and comments already dropped) has a G5 or G5.1 word (`G5`, `G05`, `g5.1`,
/// `G5.0`): a spline, which grbl does not know (Gantry's own dialect runs them as LinuxCNC does,
/// machine/src/gcode/spline.rs). Read from the text like [`has_m6`], not by parsing the block a
/// second time on every grbl line.
fn has_spline(line: &[u8]) -> bool {
    line.iter().enumerate().any(|(i, &c)| {
        if c | 0x20 != b'g' {
            return false;
        }
        let digits = line.get(i + 1..).unwrap_or_default();
        let n = digits.iter().take_while(|d| d.is_ascii_digit()).count();
        let number = digits.get(..n).unwrap_or_default();
        let whole_five = !number.is_empty()
            && number.iter().rev().skip(1).all(|&d| d == b'0')
            && number.last() == Some(&b'5');
        let rest = digits.get(n..).unwrap_or_default();
        let fraction = match rest.first() {
            Some(b'.') => {
                let f = rest.get(1..).unwrap_or_default();
                let k = f.iter().take_while(|d| d.is_ascii_digit()).count();
                let tail = f.get(..k).unwrap_or_default();
                // .0, .1, .10, …: G5 or G5.1; any other fraction is no spline.
                tail.iter().skip(1).all(|&d| d == b'0')
                    && matches!(tail.first(), None | Some(b'0' | b'1'))
            }
            _ => true,
        };
        whole_five && fraction
    })
}

/// A word grbl requires non-negative has a minus sign: `F-100`, `S-1`, `P-1`, `T-1`, `N-5`.
fn has_negative_value(line: &[u8]) -> bool {
    line.windows(2)
        .any(|w| matches!(w[0] | 0x20, b'f' | b'n' | b'p' | b's' | b't') && w[1] == b'-')
}

/// The line without leading and trailing blanks.
fn trim(mut s: &[u8]) -> &[u8] {
    while let [b' ' | b'\t', rest @ ..] = s {
        s = rest;
    }
    while let [rest @ .., b' ' | b'\t'] = s {
        s = rest;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::has_spline;

    #[test]
    fn a_spline_word_is_read_from_the_text() {
        for line in [
            "G5X1Y1I1J0P1Q1",
            "G05X1",
            "g5.1x1i1j1",
            "G5.0X1",
            "G5.10X1",
            "G1X1G5",
        ] {
            assert!(has_spline(line.as_bytes()), "{line}");
        }
        for line in [
            "G54X1", "G55", "G50", "G15", "G25", "G5.2X1", "G0X5", "G1X1F5",
        ] {
            assert!(!has_spline(line.as_bytes()), "{line}");
        }
    }
}
