//! The board: controller state machine, interpreter and motion pipeline, driven by the host link
//! and the inputs. The firmware and the emulated board both run exactly this.
//!
//! Data flows one way: streamed lines → [`StreamSource`] → interpreter → motion pipeline → step
//! segments. The step kernel itself stays outside (the timer interrupt on the board, a virtual
//! clock in the emulator): the owner of the kernel calls [`Board::next_segment`] to fill the
//! segment queue and tells [`Board::poll`] whether the kernel has drained it.

pub mod link;
pub mod source;

use crate::canon::{Action, Canon, Spindle, StopKind};
use crate::controller::{AlarmCode, State};
use crate::gcode::{GcodeError, Interpreter};
use crate::motion::config::MotionConfig;
use crate::motion::kernel::Segment;
use crate::motion::pipeline::{Motion, MotionState, PushError};
use crate::setup::Setup;
use crate::units::{Pos, MAX_AXES};
use heapless::Deque;
pub use source::{JumpRequest, JumpTarget, StreamSource, LINE_CAPACITY};

/// Planner ring size on the board (DESIGN §4: at least 128 blocks).
pub const PLANNER_BLOCKS: usize = 128;
/// Streamed lines the board buffers ahead of the interpreter.
pub const LINE_BUFFER: usize = 16;
/// Events waiting for the link.
const EVENT_QUEUE: usize = 8;

/// Error code reported when a move would leave the machine travel (soft limit).
pub const ERROR_SOFT_LIMIT: u16 = 900;

/// Something the host must hear about (in order, never dropped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardEvent {
    /// A block was rejected: `code` is the documented error number, `column` the bad word (0 = none).
    Error { line: u32, code: u16, column: u16 },
    /// The machine entered the alarm state.
    Alarm(AlarmCode),
    /// The job ended (M2/M30, end of the program, an error, or an abort); `line` is the last line run.
    JobDone { line: u32 },
    /// The interpreter jumped: the host must serve lines from the request's target.
    Jump(JumpRequest),
}

/// Output levels the controller drives (spindle, coolant, tool), as the program set them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outputs {
    pub spindle: Spindle,
    pub rpm: u32,
    pub mist: bool,
    pub flood: bool,
    pub tool: u32,
    /// The last user M code run (0 = none).
    pub last_user_mcode: u16,
}

impl Outputs {
    /// Everything off: the power-up and program-stop state (DESIGN §6).
    pub const SAFE: Outputs = Outputs {
        spindle: Spindle::Off,
        rpm: 0,
        mist: false,
        flood: false,
        tool: 0,
        last_user_mcode: 0,
    };
}

/// Why the job ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ending {
    /// Still running.
    No,
    /// M2/M30 or the end of the program: finish the queued motion, then report.
    Finished,
    /// A rejected block: finish the motion queued before it, then report (nothing after it runs).
    Failed,
}

/// The controller with everything it drives.
pub struct Board {
    setup: Setup,
    state: State,
    interp: Interpreter,
    source: StreamSource<LINE_BUFFER>,
    motion: Motion<PLANNER_BLOCKS>,
    /// An action the motion queue had no room for yet.
    pending: Option<Canon>,
    ending: Ending,
    /// M0/M1 reached: held at the sync point until cycle start/resume.
    paused: bool,
    /// Hold requested while running (resume continues).
    held: bool,
    aborting: bool,
    outputs: Outputs,
    /// Outputs to restore when a stopped program resumes (seed 003 stop/restore rules).
    saved_outputs: Option<Outputs>,
    events: Deque<BoardEvent, EVENT_QUEUE>,
    /// Last line the motion has reached (prep finished a block of it).
    line: u32,
    /// Where an abort stopped: the line to resume from.
    resume_line: u32,
    alarm: Option<AlarmCode>,
    homed: u8,
}

impl Board {
    /// A board at machine position 0, idle, outputs safe.
    pub fn new(setup: Setup) -> Self {
        let interp = Interpreter::new(&setup.interp_config());
        let motion = Motion::new(MotionConfig::from_setup(&setup));
        Board {
            setup,
            state: State::Idle,
            interp,
            source: StreamSource::new(),
            motion,
            pending: None,
            ending: Ending::No,
            paused: false,
            held: false,
            aborting: false,
            outputs: Outputs::SAFE,
            saved_outputs: None,
            events: Deque::new(),
            line: 0,
            resume_line: 0,
            alarm: None,
            homed: 0,
        }
    }

    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    pub fn state(&self) -> State {
        self.state
    }

    pub fn outputs(&self) -> Outputs {
        self.outputs
    }

    pub fn alarm(&self) -> Option<AlarmCode> {
        self.alarm
    }

    /// Axes whose home is known (bit 0 = X).
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// The interpreter (modal state, work offsets) for status reports.
    pub fn interpreter(&self) -> &Interpreter {
        &self.interp
    }

    pub fn motion(&self) -> &Motion<PLANNER_BLOCKS> {
        &self.motion
    }

    /// The motion configuration (step ratios) in use.
    pub fn motion_config(&self) -> &MotionConfig {
        self.motion.config()
    }

    /// Line the machine is executing (or last executed).
    pub fn line(&self) -> u32 {
        self.line
    }

    /// Where the last abort stopped (0 = none).
    pub fn resume_line(&self) -> u32 {
        self.resume_line
    }

    /// Lines buffered but not yet interpreted.
    pub fn lines_buffered(&self) -> usize {
        self.source.len()
    }

    /// Free slots for streamed lines; the link takes lines only while this is non-zero.
    pub fn line_room(&self) -> usize {
        self.source.free()
    }

    /// Replaces the setup (only while idle); false otherwise.
    pub fn set_setup(&mut self, setup: Setup) -> bool {
        if self.state != State::Idle {
            return false;
        }
        let position = self.motion.queued_position();
        *self = Board {
            homed: self.homed,
            ..Board::new(setup)
        };
        self.motion.set_position(position);
        self.sync_interpreter_position();
        true
    }

    /// The next event for the host.
    pub fn take_event(&mut self) -> Option<BoardEvent> {
        self.events.pop_front()
    }

    fn emit(&mut self, e: BoardEvent) {
        // The queue is drained every link poll; if it ever overflows, keep the newest alarm.
        if self.events.push_back(e).is_err() {
            self.events.pop_front();
            let _ = self.events.push_back(e);
        }
    }

    /// Starts a streamed job at the current position (only from idle).
    pub fn start_job(&mut self) -> bool {
        if self.state != State::Idle {
            return false;
        }
        self.source.reset();
        self.interp.rewind();
        self.sync_interpreter_position();
        self.pending = None;
        self.ending = Ending::No;
        self.paused = false;
        self.held = false;
        self.state = State::Run;
        true
    }

    /// A streamed line for place `id` (0 = the main stream). False when dropped (stale or full).
    pub fn push_line(&mut self, id: u16, line_no: u32, text: &str) -> bool {
        if self.state == State::Idle || self.state == State::Alarm {
            return false;
        }
        self.source.push(id, line_no, text)
    }

    /// A host (re)attached: if a job is running, ask it for every line after the last one the
    /// interpreter took, so a reconnect neither loses nor repeats a block.
    pub fn resync_stream(&mut self) {
        if matches!(self.state, State::Run | State::Hold) && self.ending == Ending::No {
            self.source.resync();
        }
    }

    /// The host has no more lines for place `id`.
    pub fn end_of_lines(&mut self, id: u16) {
        self.source.end(id);
    }

    /// Feed hold: decelerate on the path and stop there.
    pub fn feed_hold(&mut self) {
        if matches!(self.state, State::Run | State::Jog) {
            self.motion.feed_hold();
            self.held = true;
            self.state = State::Hold;
        }
    }

    /// Cycle start / resume: continue after a feed hold or an M0/M1 pause.
    pub fn resume(&mut self) {
        if self.state != State::Hold {
            return;
        }
        if self.paused {
            self.paused = false;
            if let Some(saved) = self.saved_outputs.take() {
                self.outputs = saved;
            }
            self.motion.release_sync();
        }
        if self.held {
            self.held = false;
            self.motion.resume();
        }
        self.state = State::Run;
    }

    /// Abort: stop on the path, run the program-stop sequence (spindle and coolant off), forget
    /// the rest of the job, and remember the line to resume from.
    pub fn abort(&mut self) {
        if !matches!(self.state, State::Run | State::Hold | State::Jog) {
            return;
        }
        self.resume_line = self.line;
        self.motion.abort();
        self.aborting = true;
        self.source.reset();
        self.pending = None;
        self.paused = false;
        self.held = false;
        self.outputs = Outputs {
            tool: self.outputs.tool,
            ..Outputs::SAFE
        };
        self.saved_outputs = None;
        self.ending = Ending::Failed;
        self.state = State::Run;
    }

    pub fn set_feed_override(&mut self, pct: u16) {
        self.motion.set_feed_override(pct);
    }

    pub fn set_rapid_override(&mut self, pct: u16) {
        self.motion.set_rapid_override(pct);
    }

    /// A hard limit tripped: the kernel has already stopped stepping (DESIGN §6). `kernel_steps`
    /// is where it stopped; the owner flushes its segment queue. The tripped axes lose home.
    pub fn hard_limit(&mut self, axes: u8, kernel_steps: &[i64; MAX_AXES]) {
        let cfg = *self.motion.config();
        self.motion = Motion::new(cfg);
        self.motion.set_position(cfg.to_nm(kernel_steps));
        self.source.reset();
        self.pending = None;
        self.homed &= !axes;
        self.outputs = Outputs {
            tool: self.outputs.tool,
            ..Outputs::SAFE
        };
        self.saved_outputs = None;
        self.enter_alarm(AlarmCode::HardLimit);
    }

    fn enter_alarm(&mut self, code: AlarmCode) {
        let was_running = matches!(self.state, State::Run | State::Hold | State::Jog);
        self.alarm = Some(code);
        self.state = State::Alarm;
        self.ending = Ending::No;
        self.paused = false;
        self.held = false;
        self.aborting = false;
        self.emit(BoardEvent::Alarm(code));
        if was_running {
            self.emit(BoardEvent::JobDone { line: self.line });
        }
        self.sync_interpreter_position();
    }

    /// Clears an alarm (unlock); motion is allowed again.
    pub fn unlock(&mut self) {
        if self.state == State::Alarm {
            self.alarm = None;
            self.state = State::Idle;
        }
    }

    /// The next step segment for the kernel's queue.
    pub fn next_segment(&mut self) -> Option<Segment> {
        let seg = self.motion.next_segment();
        while let Some(report) = self.motion.take_report() {
            self.line = report.line;
        }
        // The block being prepared is the one about to run (segments lead the kernel by a few ms).
        if let Some(head) = self.motion.planner().head() {
            if seg.is_some() {
                self.line = head.line;
            }
        }
        seg
    }

    /// Main-loop work: interpret while the motion queue takes actions, perform sync points once
    /// the kernel has drained (`kernel_drained`: the segment queue is empty and the kernel idle),
    /// and finish the job when everything has run.
    pub fn poll(&mut self, kernel_drained: bool) {
        if self.state == State::Run && self.ending == Ending::No && !self.aborting {
            self.interpret();
        }
        if let Some(req) = self.source.take_request() {
            self.emit(BoardEvent::Jump(req));
        }
        if kernel_drained {
            self.perform_sync();
        }
        if self.aborting && self.motion.state() == MotionState::Idle {
            self.aborting = false;
        }
        if self.state == State::Run
            && self.ending != Ending::No
            && !self.aborting
            && kernel_drained
            && self.motion.state() == MotionState::Idle
        {
            self.ending = Ending::No;
            self.state = State::Idle;
            self.sync_interpreter_position();
            self.emit(BoardEvent::JobDone { line: self.line });
        }
        if self.state == State::Hold && self.held && self.motion.state() == MotionState::Idle {
            // Held with nothing left to run: keep holding (resume continues the stream).
        }
    }

    fn interpret(&mut self) {
        loop {
            let canon = match self.pending.take() {
                Some(c) => c,
                None => match self.interp.next(&mut self.source) {
                    Some(Ok(c)) => c,
                    Some(Err(e)) => {
                        self.reject(e);
                        return;
                    }
                    None => {
                        if self.interp.is_finished() {
                            self.ending = Ending::Finished;
                        }
                        return;
                    }
                },
            };
            match self.motion.push(&canon) {
                Ok(()) => {}
                Err(PushError::Full) => {
                    self.pending = Some(canon);
                    return;
                }
                Err(PushError::Travel { .. }) => {
                    self.emit(BoardEvent::Error {
                        line: canon.line,
                        code: ERROR_SOFT_LIMIT,
                        column: 0,
                    });
                    self.ending = Ending::Failed;
                    return;
                }
            }
        }
    }

    fn reject(&mut self, e: GcodeError) {
        self.emit(BoardEvent::Error {
            line: e.line,
            code: e.code.number(),
            column: e.columns.map_or(0, |(start, _)| start + 1),
        });
        self.ending = Ending::Failed;
    }

    /// Performs the action the motion queue stopped at (the machine is at rest).
    fn perform_sync(&mut self) {
        let Some(canon) = self.motion.sync_point().copied() else {
            return;
        };
        if self.paused {
            return;
        }
        self.line = canon.line;
        match canon.action {
            Action::Spindle { state, rpm } => {
                self.outputs.spindle = state;
                self.outputs.rpm = rpm;
            }
            Action::Coolant { mist, flood } => {
                self.outputs.mist = mist;
                self.outputs.flood = flood;
            }
            Action::ToolChange { tool } => self.outputs.tool = tool,
            Action::UserMCode { code } => self.outputs.last_user_mcode = code,
            Action::Stop(StopKind::Pause | StopKind::OptionalPause) => {
                // Seed 003 stop rule: spindle and coolant off while stopped, restored on resume.
                self.saved_outputs = Some(self.outputs);
                self.outputs.spindle = Spindle::Off;
                self.outputs.mist = false;
                self.outputs.flood = false;
                self.paused = true;
                self.state = State::Hold;
                return;
            }
            Action::Stop(StopKind::End | StopKind::EndRewind) => {
                self.outputs = Outputs {
                    tool: self.outputs.tool,
                    ..Outputs::SAFE
                };
                self.ending = Ending::Finished;
            }
            _ => {}
        }
        self.motion.release_sync();
    }

    /// After the queue was dropped (abort, alarm, job end), the interpreter continues from where
    /// the machine really is.
    fn sync_interpreter_position(&mut self) {
        let mut state = *self.interp.state();
        state.position = self.motion.queued_position();
        self.interp.set_state(state);
    }

    /// Machine position (nm) of a kernel step position.
    pub fn machine_position(&self, kernel_steps: &[i64; MAX_AXES]) -> Pos {
        self.motion.config().to_nm(kernel_steps)
    }

    /// Work position: machine position minus the active offsets (work system, G92, tool length).
    pub fn work_position(&self, machine: &Pos) -> Pos {
        let offset = self.interp.state().offset();
        let mut w = [0; MAX_AXES];
        for i in 0..MAX_AXES {
            w[i] = machine[i] - offset[i];
        }
        w
    }
}
