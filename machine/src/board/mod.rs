//! The board: controller state machine, interpreter and motion pipeline, driven by the host link
//! and the inputs. The firmware and the emulated board both run exactly this.
//!
//! Data flows one way: streamed lines → [`StreamSource`] → interpreter → motion pipeline → step
//! segments. The step kernel itself stays outside (the timer interrupt on the board, a virtual
//! clock in the emulator): the owner of the kernel calls [`Board::next_segment`] to fill the
//! segment queue, tells [`Board::poll`] whether the kernel has drained it, and lets
//! [`Board::drop_queued`] take back queued segments when a stop or a speed change wants to act
//! from the kernel's running segment.

// Without the `link` feature nothing in this crate drives the board (its owner is
// `device::main_loop::MainLoop`), so the methods only the main loop and the link call are dead there.
#![cfg_attr(not(feature = "link"), allow(dead_code))]

pub mod executing;
mod homing;
pub mod inputs;
mod jog;
pub mod line_ring;
mod mode;
mod outbox;
mod outputs;
mod overrides;
pub mod power_up;
mod pressed_switch;
mod probing;
pub mod source;
mod state;
mod torch;

use crate::canon::{Action, Canon, Spindle, StopKind};
use crate::gcode::{GcodeError, Interpreter, OffPlaneOffset};
use crate::motion::config::MotionConfig;
use crate::motion::pipeline::{Motion, MotionState, PushError};
use crate::setup::Setup;
use crate::step::kernel::Segment;
use crate::step::output_event::OutputEvent;
use crate::units::{Pos, MAX_AXES};
use executing::{BlockModes, Executing};
use homing::plan::Phase;
use homing::PositionTrust;
use inputs::operator::Sensed;
pub use inputs::{fro_from_adc, AdcReadings};
use inputs::{InputBits, Signal, LIMIT_MAX_BIT, LIMIT_MIN_BIT};
pub use jog::plan::JOG_DEADMAN_MS;
pub use jog::JogRefused;
use jog::JogState;
pub use mode::Streamer;
use mode::{
    Ending, HoldWhy, HomingCycle, HomingPhase, Job, JobKind, JobPhase, Jogging, Mode, Ramp,
};
use outbox::Outbox;
pub use outbox::{BoardEvent, JobEnd, MarkEvent};
pub use outputs::levels::OutputLevels;
use outputs::lists::ListStatus;
use outputs::OutputState;
pub use outputs::{DoorOutputs, Outputs};
use overrides::Overrides;
use power_up::PowerUp;
pub use pressed_switch::ERROR_LIMIT_PRESSED;
pub use probing::ProbeResult;
use probing::Probing;
pub use source::{JumpRequest, JumpTarget, Pushed, StreamSource, LINE_CAPACITY};
pub use state::{AlarmCode, State};

/// Planner ring size on the board (look-ahead over at least 128 blocks, docs/architecture.md).
pub(crate) const PLANNER_BLOCKS: usize = 128;
/// Bytes of line records (`board/line_ring.rs`) the board buffers ahead of the interpreter: the
/// queued lane's credit. 4 KiB is ~250 short CAM lines, 25 ms of a 10 k lines/s program: more
/// than a USB or pty round trip plus a main-loop pass (docs/protocol.md "Flow control").
pub(crate) const LINE_RING: usize = 4096;
/// The line ring's buffer: the ring and the run-on room of one record (`line_ring.rs`).
const LINE_RING_BUFFER: usize = LINE_RING + line_ring::RECORD_MAX;

/// Error code reported when a move would leave the machine travel (soft limit).
pub const ERROR_SOFT_LIMIT: u16 = 900;
/// Error code reported when motion is refused: homing is required first.
pub const ERROR_HOMING_REQUIRED: u16 = 901;
/// Error code of a refused request: the board is busy (a job, a homing cycle, a jog not yet at
/// rest); jogs, homing and jobs start from Idle.
pub const ERROR_BUSY: u16 = 902;
/// Error code of a refused request that can never be carried out: no such axis, no feed, no axis
/// to home.
pub const ERROR_INVALID_REQUEST: u16 = 903;
/// Error code reported when the board ended a continuous host jog because no keepalive came for
/// [`JOG_DEADMAN_MS`] (the host was killed, stopped or cut off).
pub const ERROR_JOG_DEADMAN: u16 = 904;
/// Every limit-switch bit of [`InputBits`].
pub const LIMIT_BITS: u32 = (0x3f << LIMIT_MIN_BIT) | (0x3f << LIMIT_MAX_BIT);

/// The controller with everything it drives: the core components the data flows through
/// (setup, mode, interpreter, line source, motion) and the parts around them, each one job with
/// its own module.
pub struct Board {
    setup: Setup,
    /// Idle, a job (running, held, stopping), an alarm, homing or jogging.
    mode: Mode,
    interp: Interpreter,
    source: StreamSource<LINE_RING_BUFFER>,
    motion: Motion<PLANNER_BLOCKS>,
    /// Where the job stands on its program: the action waiting for room, the line reached, the
    /// line to resume from.
    progress: Progress,
    /// The offsets, units and programmed speed of the block being executed (`board/executing.rs`).
    executing: Executing,
    /// Spindle, coolant, tool and user outputs with what the stops saved (`board/outputs/mod.rs`).
    outputs: OutputState,
    /// Feed and spindle overrides and the run switches (`board/overrides.rs`).
    overrides: Overrides,
    /// Which axes are homed and whether the position is trusted (`board/homing/`).
    position: PositionTrust,
    /// Time, input levels and the kernel's drained flag, as last heard (`board/inputs/operator.rs`).
    sensed: Sensed,
    /// Host jogs and the joystick (`board/jog/`).
    jog: JogState,
    /// A G38 probe move of the job and the last result (`board/probing.rs`).
    probing: Probing,
    /// Events, Marks and offset changes for the owner (`board/outbox.rs`).
    outbox: Outbox,
    /// A plasma torch's arc (`board/torch.rs`).
    arc: torch::Arc,
}

/// Where a job stands on its program.
struct Progress {
    /// An action the motion queue had no room for yet.
    pending: Option<Canon>,
    /// Last line the motion has reached (prep finished a block of it).
    line: u32,
    /// Where an abort stopped: the line to resume from.
    resume_line: u32,
}

impl Board {
    /// A board at machine position 0, idle, outputs safe (a clean power-up).
    #[inline(always)]
    pub fn new(setup: Setup) -> Self {
        Self::power_up(setup, PowerUp::Clean)
    }

    /// A board at machine position 0, outputs safe, after a power-up of the kind `how`: a
    /// [`PowerUp::MotionInterrupted`] start is locked in alarm 3 with every axis unhomed (homing,
    /// where homing is set up, or unlock clears it); else idle, or alarm 11 when
    /// `homing.required`.
    ///
    /// One struct expression, inlined with the motion pipeline's and planner's constructors into
    /// the caller, and the planner's ring a `Deque` whose free slots are never written: that way
    /// the firmware's `StaticCell::init_with(|| Board::power_up(..))` needs one stack frame of
    /// about 25 KiB at boot instead of 48 KiB (the compiler cannot build a 27 KiB value directly
    /// in a static while calls such as `Interpreter::new` run in between; firmware/README.md).
    #[inline(always)]
    pub fn power_up(setup: Setup, how: PowerUp) -> Self {
        let needs_home = setup.homing.required && !homing::plan::order(&setup, 0).is_empty();
        let alarm = if how == PowerUp::MotionInterrupted {
            // grbl alarm 3: the steps in flight when the reset came are unknown.
            Some(AlarmCode::ResetDuringMotion)
        } else if needs_home {
            // Power-up with homing required: locked until homed (grbl's boot alarm).
            Some(AlarmCode::HomingRequired)
        } else {
            None
        };
        Board {
            executing: Executing::new(),
            interp: Interpreter::new(&setup.interp_config()),
            motion: Motion::new(MotionConfig::from_setup(&setup)),
            setup,
            mode: match alarm {
                Some(code) => Mode::Alarm(code),
                None => Mode::Idle,
            },
            source: StreamSource::new(),
            progress: Progress {
                pending: None,
                line: 0,
                resume_line: 0,
            },
            outputs: OutputState::new(),
            overrides: Overrides::new(),
            position: PositionTrust::new(how == PowerUp::MotionInterrupted),
            sensed: Sensed::new(),
            jog: JogState::default(),
            probing: Probing::new(),
            outbox: Outbox::new(),
            arc: torch::Arc::Off,
        }
    }

    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    pub fn state(&self) -> State {
        self.mode.state()
    }

    pub fn outputs(&self) -> Outputs {
        self.outputs.program()
    }

    /// Main-loop time from the last [`Board::on_inputs`], ms: the board's clock (the grbl door's
    /// spin-up wait, `machine/src/device/grbl/door.rs`; the jog dead-man, `board/jog/`).
    pub fn now_ms(&self) -> u32 {
        self.sensed.now_ms
    }

    pub fn alarm(&self) -> Option<AlarmCode> {
        match self.mode {
            Mode::Alarm(code) => Some(code),
            _ => None,
        }
    }

    /// The power-up was a [`PowerUp::MotionInterrupted`] one and neither homing nor an unlock has
    /// re-established the position yet. The firmware keeps its motion marker set meanwhile, so a
    /// further reset still powers up in alarm 3.
    pub fn position_lost(&self) -> bool {
        self.position.lost()
    }

    /// Axes whose home is known (bit 0 = X).
    pub fn homed(&self) -> u8 {
        self.position.homed()
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
        self.progress.line
    }

    /// The line a stopped job resumes from (0 = none): where an abort or an alarm stop (2, 20)
    /// left the machine, or the line whose error ended the job.
    pub fn resume_line(&self) -> u32 {
        self.progress.resume_line
    }

    /// Lines buffered but not yet interpreted.
    pub fn lines_buffered(&self) -> usize {
        self.source.len()
    }

    /// Free bytes for streamed line records (a line takes its text and 6 bytes); `usize::MAX`
    /// when lines are not taken (they are dropped at once).
    pub(crate) fn line_room(&self) -> usize {
        if self.takes_lines() {
            self.source.free()
        } else {
            // Lines for a job that is stopping or over are dropped at once ([`Board::push_line`]),
            // so they never stand in front of the next job's Start.
            usize::MAX
        }
    }

    /// A job that still runs its program: running or held, not stopping (an abort or an alarm
    /// decelerating) and not over.
    fn takes_lines(&self) -> bool {
        matches!(
            self.mode,
            Mode::Job(Job {
                phase: JobPhase::Running(_) | JobPhase::Hold { .. },
                ..
            })
        )
    }

    /// Replaces the grbl front end's section of the setup (`machine/src/device/grbl/`), in any state:
    /// nothing else of the core reads it, so nothing is rebuilt.
    pub(crate) fn set_grbl_setup(&mut self, grbl: crate::setup::GrblSetup) {
        self.setup.grbl = grbl;
    }

    /// Replaces the setup (only while idle); false otherwise.
    pub fn set_setup(&mut self, setup: Setup) -> bool {
        if !matches!(self.mode, Mode::Idle) {
            return false;
        }
        let position = self.motion.queued_position();
        // Rebuilt in place: a second `Board` (tens of KiB) must never sit on the MCU's stack.
        self.setup = setup;
        self.interp = Interpreter::new(&self.setup.interp_config());
        let cfg = MotionConfig::from_setup(&self.setup);
        self.motion.reconfigure(cfg, cfg.to_steps(&position));
        self.motion.set_feed_override(self.overrides.feed());
        self.source.reset();
        self.progress.pending = None;
        self.jog.end_all();
        self.outputs.safe();
        if self.homing_missing() {
            self.mode = Mode::Alarm(AlarmCode::HomingRequired);
        }
        self.sync_interpreter_position();
        true
    }

    /// Homing is required (setup, or the position was lost in a reset) and some axis with a
    /// homing priority is not homed.
    fn homing_missing(&self) -> bool {
        self.position.homing_missing(&self.setup)
    }

    /// Refuses motion (error 901) while homing is required and missing.
    fn refuse_unhomed(&mut self) -> bool {
        if self.homing_missing() {
            self.emit(BoardEvent::Error {
                line: 0,
                code: ERROR_HOMING_REQUIRED,
                column: 0,
            });
            return true;
        }
        false
    }

    /// The next Mark event for the host (joystick teach-in).
    pub fn take_mark(&mut self) -> Option<MarkEvent> {
        self.outbox.take_mark()
    }

    /// The next event for the host.
    pub fn take_event(&mut self) -> Option<BoardEvent> {
        self.outbox.take_event()
    }

    pub(crate) fn emit(&mut self, e: BoardEvent) {
        self.outbox.emit(e);
    }

    /// Starts a streamed job at the current position (only from idle), its lines served by the
    /// host's program server ([`Streamer::ProgramServer`]).
    pub fn start_job(&mut self) -> bool {
        self.start_job_from(Streamer::ProgramServer)
    }

    /// Starts a streamed job whose lines come from `streamer` (false when refused; a refusal
    /// for homing reports error 901).
    pub(crate) fn start_job_from(&mut self, streamer: Streamer) -> bool {
        match self.start(JobKind::Machine, streamer) {
            Ok(()) => true,
            Err(code) => {
                if code == ERROR_HOMING_REQUIRED {
                    self.emit(BoardEvent::Error {
                        line: 0,
                        code,
                        column: 0,
                    });
                }
                false
            }
        }
    }

    /// [`Board::start_job`] for a host request that is answered: the refusal's code (902 not
    /// idle, 901 homing required) instead of an error event.
    pub(crate) fn try_start_job(&mut self) -> Result<(), u16> {
        self.start(JobKind::Machine, Streamer::ProgramServer)
    }

    /// Starts a streamed job in check mode: interpreted and checked against the soft limits
    /// without any motion or output (grbl `$C`); each error is reported and the check reads on.
    pub fn start_check(&mut self) -> bool {
        self.start(JobKind::Check, Streamer::LineSender).is_ok()
    }

    fn start(&mut self, kind: JobKind, streamer: Streamer) -> Result<(), u16> {
        if !matches!(self.mode, Mode::Idle) {
            return Err(ERROR_BUSY);
        }
        if kind == JobKind::Machine && self.homing_missing() {
            return Err(ERROR_HOMING_REQUIRED);
        }
        // No line of this job has run yet (a job that runs nothing ends with `JobDone{0}`).
        self.progress.line = 0;
        self.source.reset();
        self.source.serve_jumps(streamer == Streamer::ProgramServer);
        self.interp.rewind();
        // grbl's parser ignores an arc's off-plane offset word (FreeCAD's grbl post writes K0
        // on G17 arcs); Gantry's own dialect refuses it as LinuxCNC does.
        self.interp
            .set_off_plane_offset(if streamer == Streamer::LineSender {
                OffPlaneOffset::Ignored
            } else {
                OffPlaneOffset::Refused
            });
        if kind == JobKind::Machine {
            // A check goes on from the program's own position, which no motion has followed
            // (grbl's `$C`: the machine position comes back with the reset that ends it).
            self.sync_interpreter_position();
        }
        self.progress.pending = None;
        self.probing.cancel();
        // Torch height control is on at every job's start (`M62 P2` switches it off).
        self.motion.set_thc_enabled(true);
        let phase = if kind == JobKind::Machine && self.hold_input_active() {
            // The feed-hold switch is open: the job waits, held, until it closes.
            JobPhase::Hold {
                why: HoldWhy::Feed,
                ending: Ending::No,
            }
        } else {
            JobPhase::Running(Ending::No)
        };
        self.mode = Mode::Job(Job {
            kind,
            phase,
            queued: false,
            last_motion_line: 0,
            streamer,
        });
        Ok(())
    }

    /// A streamed line for place `id` (0 = the main stream). False when dropped (stale or full).
    pub fn push_line(&mut self, id: u16, line_no: u32, text: &str) -> bool {
        if !self.takes_lines() {
            return false;
        }
        self.source.push(id, line_no, text)
    }

    /// Free bytes of the line ring, whether or not a job takes lines: the credit the link grants
    /// (a `Start` and the job's first lines may come in one burst).
    pub(crate) fn line_ring_free(&self) -> usize {
        self.source.free()
    }

    /// A valid run of `lines` line records from the link for place `id`, stored as it is. Lines
    /// of no running job are dropped ([`Pushed::Stale`]).
    pub(crate) fn push_lines(&mut self, id: u16, run: &[u8], lines: usize) -> Pushed {
        if !self.takes_lines() {
            return Pushed::Stale;
        }
        self.source.push_run(id, run, lines)
    }

    /// A host (re)attached: if a job is running, ask it for every line after the last one the
    /// interpreter took, so a reconnect neither loses nor repeats a block.
    pub(crate) fn resync_stream(&mut self) {
        if let Some(
            JobPhase::Running(Ending::No)
            | JobPhase::Hold {
                ending: Ending::No, ..
            },
        ) = self.machine_job()
        {
            self.source.resync();
        }
    }

    /// The host has no more lines for place `id`.
    pub fn end_of_lines(&mut self, id: u16) {
        self.source.end(id);
    }

    /// Feed hold: decelerate on the path and stop there. During a jog it stops the jog (like a
    /// jog stop); it does nothing in other states, and nothing to a stopping job (an abort or an
    /// alarm stop decelerating): stops take precedence.
    pub fn feed_hold(&mut self) {
        match self.mode {
            Mode::Job(Job {
                kind: JobKind::Machine,
                phase: JobPhase::Running(ending),
                ..
            }) => {
                self.motion.feed_hold();
                self.set_phase(JobPhase::Hold {
                    why: HoldWhy::Feed,
                    ending,
                });
            }
            Mode::Jog(_) => self.jog_stop(),
            _ => {}
        }
    }

    /// The host is gone (port closed, DTR dropped, or silent; docs/controller.md "Host lost"):
    /// a running job holds on its path, and once at rest its spindle and coolant go off (restored
    /// when a host resumes it); a job already in a feed hold switches them off the same way; a
    /// jog stops. M0/M1 and tool-change stops have them off already.
    pub fn host_lost(&mut self) {
        match self.machine_job() {
            Some(JobPhase::Running(ending)) => {
                self.motion.feed_hold();
                self.set_phase(JobPhase::Hold {
                    why: HoldWhy::HostLost,
                    ending,
                });
            }
            Some(JobPhase::Hold {
                why: HoldWhy::Feed,
                ending,
            }) => self.set_phase(JobPhase::Hold {
                why: HoldWhy::HostLost,
                ending,
            }),
            _ => {
                if matches!(self.mode, Mode::Jog(_)) {
                    self.jog_stop();
                }
            }
        }
    }

    /// The work offsets and G28/G30 positions a job set (G10 L2/L20, G28.1, G30.1, their
    /// parameters) become the setup's, which the board keeps in flash (`MainLoop` saves it once
    /// idle: [`Board::take_offsets_changed`]), so they survive a restart and a soft reset, and
    /// `gantry setup pull` shows them (docs/controller.md "Work offsets").
    fn keep_stored_offsets(&mut self) {
        let s = self.interp.state();
        let p = &mut self.setup.program;
        if p.work_offsets != s.work_offsets || p.g28_home != s.g28 || p.g30_home != s.g30 {
            p.work_offsets = s.work_offsets;
            p.g28_home = s.g28;
            p.g30_home = s.g30;
            self.outbox.offsets_changed();
        }
    }

    /// True once after a job changed the stored offsets ([`Board::keep_stored_offsets`]): the
    /// owner writes the setup to flash.
    pub(crate) fn take_offsets_changed(&mut self) -> bool {
        self.outbox.take_offsets_changed()
    }

    /// Spindle and coolant off if the machine stands idle (a grbl sender left, `device/grbl/mod.rs`
    /// `Grbl::disconnect`); a job's outputs go off when it stops.
    pub(crate) fn stop_outputs_at_rest(&mut self) {
        if matches!(self.mode, Mode::Idle) {
            self.outputs.program_stop();
        }
    }

    /// A job held for a lost host, at rest: spindle and coolant off, kept to restore on resume.
    fn host_lost_outputs_off(&mut self) {
        let held_at_rest = matches!(
            self.machine_job(),
            Some(JobPhase::Hold {
                why: HoldWhy::HostLost,
                ..
            })
        ) && self.sensed.drained
            && self.motion.state() == MotionState::Held;
        if held_at_rest {
            self.outputs.host_lost_off();
        }
    }

    /// A machine job is interpreting and moving: not held, not stopping after an abort or an
    /// alarm. Only then is a step kernel that runs dry with motion still to come an underrun.
    pub(crate) fn job_running(&self) -> bool {
        matches!(self.machine_job(), Some(JobPhase::Running(_)))
    }

    /// The phase of a machine job (not a check), if one runs. (Out of line: it was inlined 15
    /// times.)
    #[inline(never)]
    fn machine_job(&self) -> Option<JobPhase> {
        match self.mode {
            Mode::Job(Job {
                kind: JobKind::Machine,
                phase,
                ..
            }) => Some(phase),
            _ => None,
        }
    }

    /// Moves the job to `phase` (nothing outside a job).
    fn set_phase(&mut self, phase: JobPhase) {
        if let Mode::Job(job) = &mut self.mode {
            job.phase = phase;
        }
    }

    /// Records how a running (or held) job ends; a stopping job keeps its stop.
    fn set_ending(&mut self, e: Ending) {
        if let Mode::Job(job) = &mut self.mode {
            match &mut job.phase {
                JobPhase::Running(ending) | JobPhase::Hold { ending, .. } => *ending = e,
                JobPhase::Stopping { .. } => {}
            }
        }
    }

    /// The tool a job waits for at its M6 (the job stands at rest, [`State::ToolChange`]).
    pub fn tool_change(&self) -> Option<u32> {
        match self.machine_job() {
            Some(JobPhase::Hold {
                why: HoldWhy::ToolChange { tool },
                ..
            }) => Some(tool),
            _ => None,
        }
    }

    /// The job stands in a feed hold (input, host or link): motion stopped on the path with the
    /// outputs as they were. False for an M0 / M1 / single-block stop, which switched the spindle
    /// and coolant off.
    pub fn feed_held(&self) -> bool {
        matches!(self.machine_job(), Some(JobPhase::Hold { why, .. }) if why.feed())
    }

    /// The job stands in Run at rest waiting for program lines the host has not sent: the
    /// interpreter has consumed every line it was given, the end of the program has not come, and
    /// everything queued has run (the kernel drained at the last [`Board::poll`]) — the machine
    /// stands still with spindle and coolant as the program left them. With the host gone this
    /// wait never ends by itself; [`crate::device::link::BoardLink`] bounds it like a hold (alarm 20).
    pub fn waiting_for_lines(&self) -> bool {
        self.machine_job() == Some(JobPhase::Running(Ending::No))
            && self.progress.pending.is_none()
            && self.source.is_empty()
            && self.sensed.drained
            && self.motion.state() == MotionState::Idle
    }

    /// The job runs on its path (not held, not at a sync point) and its program has lines to
    /// come: the end of the program has not been received and read.
    pub(crate) fn lines_to_come(&self) -> bool {
        self.machine_job() == Some(JobPhase::Running(Ending::No))
            && !self.source.is_exhausted()
            && matches!(
                self.motion.state(),
                MotionState::Running | MotionState::Idle
            )
    }

    /// True while the feed-hold input is installed and open.
    fn hold_input_active(&self) -> bool {
        self.setup.inputs.feed_hold && self.sensed.levels.get(Signal::FeedHold)
    }

    /// Cycle start / resume: continue after a feed hold or an M0/M1 pause (refused while the
    /// feed-hold switch is still open).
    pub fn resume(&mut self) {
        let Some(JobPhase::Hold { why, ending }) = self.machine_job() else {
            return;
        };
        if self.hold_input_active() {
            return;
        }
        match why {
            // Plasma: the torch fires again and the motion waits for its arc (`board/torch.rs`).
            HoldWhy::ArcLost => return self.torch_resume(),
            HoldWhy::ArcWait => return,
            _ => {}
        }
        self.outputs.resume(why.pause() || why == HoldWhy::HostLost);
        if why.pause() {
            self.motion.release_sync();
        }
        if why.feed() {
            self.motion.resume();
        }
        self.set_phase(JobPhase::Running(ending));
    }

    /// The feed-hold switch closed again: continue the held motion (the GIXA controller's behaviour), unless the
    /// setup wants a cycle start for that.
    fn release_hold(&mut self) {
        if let Some(JobPhase::Hold { why, ending }) = self.machine_job() {
            // (A hold for a lost host waits for a host or a cycle start, not for the switch; one
            // for a lost arc waits for a cycle start, which re-fires the torch.)
            if why.feed() && why != HoldWhy::HostLost && why != HoldWhy::ArcLost {
                self.outputs.restore_stopped_spindle();
                self.motion.resume();
                self.set_phase(if why.pause() {
                    JobPhase::Hold {
                        why: HoldWhy::Pause,
                        ending,
                    }
                } else {
                    JobPhase::Running(ending)
                });
            }
        }
    }

    /// Abort: decelerate on the path, forget the rest of the job, remember the line to resume
    /// from, and run the program-stop sequence (spindle and coolant off) once the machine is at
    /// rest. During homing the seek decelerates and alarm 6 follows at rest (user outputs, which
    /// may enable a squared axis's drivers, stay as they are until then); during a jog it stops
    /// the jog and leaves joystick mode.
    /// A second abort while the job is stopping changes nothing (the first one, or an alarm
    /// stop, ends it).
    pub fn abort(&mut self) {
        match self.mode {
            Mode::Homing { .. } => {
                self.motion.abort();
                self.mode = Mode::Homing {
                    phase: HomingPhase::Aborting,
                };
            }
            Mode::Jog(who) => {
                // Leaves joystick mode too (a jog off a pressed switch goes back to its alarm).
                if who == Jogging::Joystick {
                    self.mode = Mode::Jog(Jogging::Moves);
                }
                self.jog_stop();
            }
            Mode::Job(Job {
                kind: JobKind::Check,
                ..
            }) => {
                self.source.reset();
                self.set_ending(Ending::Failed);
            }
            Mode::Job(Job {
                phase: JobPhase::Stopping { .. },
                ..
            }) => {}
            Mode::Job(_) => self.stop_job(None),
            Mode::Idle | Mode::Alarm(_) => {}
        }
    }

    /// Ends a running or held job: decelerate on the path, drop the rest, remember the resume
    /// line. Spindle and coolant keep running while the tool decelerates along the cut; once the
    /// machine is at rest [`Board::poll`] ends the job with the program-stop sequence, or, with
    /// `alarm`, raises that alarm (with its line) instead, which switches every output off.
    /// Callers check that the job is not stopping already: the first stop wins.
    fn stop_job(&mut self, alarm: Option<(AlarmCode, u32)>) {
        self.progress.resume_line = self.progress.line;
        self.motion.abort();
        self.source.reset();
        self.progress.pending = None;
        self.outputs.forget_restores();
        self.probing.cancel();
        self.set_phase(JobPhase::Stopping {
            alarm,
            ramp: Ramp::Decelerating,
        });
    }

    /// The host has stayed away for `link.host_lost_stop_s` while the job was held or waited for
    /// lines ([`crate::device::link::BoardLink`] decides): end the job and raise alarm 20 at rest (every output
    /// off), with the line it stopped in.
    pub(crate) fn host_lost_stop(&mut self) {
        if matches!(
            self.machine_job(),
            Some(JobPhase::Running(_) | JobPhase::Hold { .. })
        ) {
            self.stop_job(Some((AlarmCode::HostLost, self.progress.line)));
        }
    }

    /// A hard limit tripped: the kernel has already stopped stepping (docs/controller.md "Safety rules as built"). `kernel_steps`
    /// is where it stopped; the owner flushes its segment queue. The tripped axes lose home.
    pub(crate) fn hard_limit(&mut self, axes: u8, kernel_steps: &[i64; MAX_AXES]) {
        self.rebuild_motion(true, kernel_steps);
        self.source.reset();
        self.progress.pending = None;
        self.position.unhome(axes);
        let line = self.job_line();
        self.enter_alarm(AlarmCode::HardLimit, line);
    }

    /// The line a job is executing, for an alarm raised now (0 outside a job).
    fn job_line(&self) -> u32 {
        if self.machine_job().is_some() {
            self.progress.line
        } else {
            0
        }
    }

    /// Reports every switch of `bits` (limit input bits) to the host, X min first.
    fn report_limits(&mut self, bits: u32) {
        for bit in LIMIT_MIN_BIT..LIMIT_MAX_BIT + 6 {
            if bits & (1 << bit) != 0 {
                let max = bit >= LIMIT_MAX_BIT;
                let base = if max { LIMIT_MAX_BIT } else { LIMIT_MIN_BIT };
                self.emit(BoardEvent::Limit {
                    axis: (bit - base) as u8,
                    max,
                });
            }
        }
    }

    /// The step kernel latched a stop (its limit flag): `levels` are the logical input levels the
    /// interrupt saw (raw pins with the polarity applied), `kernel_steps` where it stopped. The
    /// owner has dropped its segment queue and re-arms the kernel after this call. The seek of a
    /// homing cycle ends here when its switch alone tripped (a list's `seek` is reported to the
    /// host unless the list disabled limit reports; the cycle's own seek never is); anything else
    /// is a hard limit on the tripped axes, reported switch by switch, then alarm 1.
    pub(crate) fn limit_stop(&mut self, levels: InputBits, kernel_steps: &[i64; MAX_AXES]) {
        let tripped = levels.0 & self.limit_arm();
        if let Some(c) = self.homing_cycle() {
            let h = &c.homing;
            let axis = h.axis();
            let bit = 1 << homing::plan::switch_bit(axis, &self.setup.homing.axes[axis]);
            let list_seek = h.list_seek;
            if h.seeking() && tripped == bit {
                let reported = list_seek && c.list.as_ref().is_none_or(|l| l.reports_limits());
                self.rebuild_motion(false, kernel_steps);
                if reported {
                    self.report_limits(bit);
                }
                if let Mode::Homing {
                    phase: HomingPhase::Cycle(HomingCycle { homing: h, .. }),
                } = &mut self.mode
                {
                    if list_seek {
                        h.list_seek = false;
                    } else if h.phase == Phase::Seek {
                        h.phase = Phase::SeekStopped;
                    } else {
                        h.phase = Phase::BeforeRetract;
                    }
                }
                return;
            }
        }
        self.report_limits(tripped);
        let t = InputBits(tripped);
        let mut axes = t.limits_min() | t.limits_max();
        if axes == 0 {
            // Stopped without a known switch: every axis's position is suspect.
            axes = (1u8 << self.setup.axis_count) - 1;
        }
        self.sensed.disarm(levels.0 & LIMIT_BITS);
        self.hard_limit(axes, kernel_steps);
    }

    /// Limit input bits whose switch must stop the step kernel now: the firmware's step interrupt
    /// stops when `logical_pins & limit_arm() != 0` (read it once per main-loop pass).
    /// Installed switches with hard limits on, minus switches still pressed since the last alarm
    /// (they re-arm when they release, so an axis can be jogged off its switch); during homing the
    /// seek switch is armed for the seek and ignored for the retract.
    pub fn limit_arm(&self) -> u32 {
        let i = &self.setup.inputs;
        let installed =
            (u32::from(i.limit_min) << LIMIT_MIN_BIT) | (u32::from(i.limit_max) << LIMIT_MAX_BIT);
        let mut arm = self.sensed.armed(if i.hard_limits { installed } else { 0 });
        if let Some(HomingCycle { homing: h, .. }) = self.homing_cycle() {
            let axis = h.axis();
            let bit = 1 << homing::plan::switch_bit(axis, &self.setup.homing.axes[axis]);
            if h.seeking() {
                arm |= bit;
            } else {
                arm &= !bit;
            }
        }
        arm & LIMIT_BITS
    }

    /// The homing cycle, while one runs (not while an aborted one decelerates).
    fn homing_cycle(&self) -> Option<&HomingCycle> {
        match &self.mode {
            Mode::Homing {
                phase: HomingPhase::Cycle(c),
            } => Some(c),
            _ => None,
        }
    }

    /// A new motion pipeline at a kernel step position (after a stop dropped the queue), with
    /// soft limits on or off (homing seeks beyond the box) and the feed override kept.
    fn rebuild_motion(&mut self, soft_limits: bool, kernel_steps: &[i64; MAX_AXES]) {
        let mut cfg = MotionConfig::from_setup(&self.setup);
        cfg.soft_limits = soft_limits;
        self.motion.reconfigure(cfg, *kernel_steps);
        self.motion.set_feed_override(self.overrides.feed());
    }

    /// Raises alarm `code` concerning program line `line` (0 = none): outputs safe, jog and job
    /// ended (`JobDone` when a job was running).
    fn enter_alarm(&mut self, code: AlarmCode, line: u32) {
        let was_running = matches!(self.mode, Mode::Job(_));
        self.probing.cancel();
        self.outputs.safe();
        self.arc = torch::Arc::Off;
        self.jog.end_all();
        self.mode = Mode::Alarm(code);
        self.emit(BoardEvent::Alarm { code, line });
        if was_running {
            self.emit(BoardEvent::JobDone {
                line: self.progress.line,
                end: JobEnd::Alarm,
            });
        }
        self.sync_interpreter_position();
    }

    /// Clears an alarm (unlock); motion is allowed again. While homing is required and an axis
    /// is unhomed the board stays in alarm 11 (only homing is allowed).
    pub fn unlock(&mut self) {
        let _ = self.try_unlock();
    }

    /// [`Board::unlock`], with its outcome: `Ok` when no alarm is left (or there was none),
    /// else [`ERROR_BUSY`] (still decelerating) or [`ERROR_HOMING_REQUIRED`] (alarm 11 stays).
    pub fn try_unlock(&mut self) -> Result<(), u16> {
        if !matches!(self.mode, Mode::Alarm(_)) {
            return Ok(());
        }
        if self.motion.state() != MotionState::Idle {
            return Err(ERROR_BUSY);
        }
        if self.pressed_limits() != 0 {
            // Unlocked, it would trip again on the switch it stands on (or be driven further
            // into it): the operator jogs off it first (`board/pressed_switch.rs`).
            return Err(ERROR_LIMIT_PRESSED);
        }
        if self.homing_missing() {
            if !matches!(self.mode, Mode::Alarm(AlarmCode::HomingRequired)) {
                self.mode = Mode::Alarm(AlarmCode::HomingRequired);
                self.emit(BoardEvent::Alarm {
                    code: AlarmCode::HomingRequired,
                    line: 0,
                });
            }
            return Err(ERROR_HOMING_REQUIRED);
        }
        // The operator takes the position as it is (no homing set up, or every axis homed).
        self.position.trust();
        if !self.motion.config().soft_limits {
            let steps = self.motion.prepared_steps();
            self.rebuild_motion(true, &steps);
        }
        self.mode = Mode::Idle;
        Ok(())
    }

    /// A stop (jog stop, stick release, feed hold, abort) or a jog's speed change wants to act
    /// from the kernel's running segment: when one is pending, `drop_newest(max)` must remove up
    /// to `max` of the *newest* segments from the kernel's queue that the kernel has not started
    /// and return how many it removed; segment prep then continues from the end of the last
    /// segment kept (its exact step position and speed). Call it every main-loop pass after
    /// [`Board::poll`] and before [`Board::next_segment`]; `drop_newest` is not called when
    /// nothing is pending.
    pub(crate) fn drop_queued(&mut self, drop_newest: impl FnOnce(usize) -> usize) {
        if let Some(max) = self.motion.drop_request() {
            let dropped = if max > 0 {
                drop_newest(max).min(max)
            } else {
                0
            };
            self.motion.segments_dropped(dropped);
        }
        if let Some(m) = self.jog.take_bend() {
            self.bend_stick_move(m);
        }
    }

    /// The next step segment for the kernel's queue.
    pub fn next_segment(&mut self) -> Option<Segment> {
        // Laser mode: the spindle override scales the power of the segments prepared from now.
        self.motion.set_laser_override(self.overrides.spindle());
        if self.torch() {
            self.motion.set_thc_command(self.thc_command());
            if !self.torch_firing() {
                // At a sync point after the torch went off (the next pierce's M3, a probe move,
                // the program's end) the height correction is taken out first.
                if let Some(seg) = self.motion.thc_return_segment() {
                    return Some(seg);
                }
            }
        }
        let seg = self.motion.next_segment();
        while let Some(report) = self.motion.take_report() {
            self.progress.line = report.line;
        }
        // The block being prepared is the one about to run (segments lead the kernel by a few ms).
        if let Some(head) = self.motion.planner().head() {
            if seg.is_some() {
                self.progress.line = head.line;
                let speed = if head.is_line() { head.programmed } else { 0 };
                self.executing.on_block(head.seq, head.line, speed);
            }
        }
        seg
    }

    /// Main-loop work: interpret while the motion queue takes actions, perform sync points once
    /// the kernel has drained (`kernel_drained`: the segment queue is empty and the kernel idle),
    /// and finish the job when everything has run.
    pub fn poll(&mut self, kernel_drained: bool) {
        self.sensed.drained = kernel_drained;
        if !self.motion.config().soft_limits
            && !matches!(self.mode, Mode::Homing { .. })
            && kernel_drained
            && self.motion.state() == MotionState::Idle
        {
            // A homing cycle ended early (alarm): soft limits apply again once at rest.
            let steps = self.motion.prepared_steps();
            self.rebuild_motion(true, &steps);
        }
        match self.mode {
            Mode::Homing { .. } => {
                self.poll_homing(kernel_drained);
                return;
            }
            Mode::Jog(_) => {
                self.poll_jog(kernel_drained);
                return;
            }
            _ => {}
        }
        self.poll_probe(kernel_drained);
        self.host_lost_outputs_off();
        let job = match self.mode {
            Mode::Job(job) => Some(job),
            _ => None,
        };
        if job.is_some_and(|j| self.interprets(&j)) {
            self.interpret();
        }
        if self.torch() {
            self.poll_arc_wait();
        }
        if let Some(req) = self.source.take_request() {
            self.emit(BoardEvent::Jump(req));
        }
        let ending_machine_job = match self.machine_job() {
            Some(JobPhase::Running(e) | JobPhase::Hold { ending: e, .. }) => e != Ending::No,
            Some(JobPhase::Stopping { ramp, .. }) => ramp == Ramp::Done,
            None => false,
        };
        if ending_machine_job {
            // No motion follows: an on-the-fly M code still waiting for a move runs once the
            // motion before it has ended (retried while the queue is full).
            let _ = self.motion.flush_output();
        }
        if kernel_drained {
            self.perform_sync();
        }
        if let Some(JobPhase::Stopping {
            alarm,
            ramp: Ramp::Decelerating,
        }) = self.machine_job()
        {
            if self.motion.state() == MotionState::Idle {
                // The deceleration may have carried the machine into the next block.
                self.progress.resume_line = self.progress.line;
                self.set_phase(JobPhase::Stopping {
                    alarm,
                    ramp: Ramp::Done,
                });
            }
        }
        let Mode::Job(job) = self.mode else {
            return;
        };
        // How the job ends at rest: (the alarm it raises, the program-stop sequence).
        let (end, how) = match job.phase {
            JobPhase::Running(Ending::Finished) => ((None, false), JobEnd::Completed),
            JobPhase::Running(Ending::Failed) => {
                ((None, job.kind == JobKind::Machine), JobEnd::Failed)
            }
            JobPhase::Stopping {
                alarm,
                ramp: Ramp::Done,
            } => ((alarm, true), JobEnd::Aborted),
            _ => return,
        };
        if kernel_drained && self.motion.state() == MotionState::Idle {
            // At rest: the one place where a job ends (alarm 1 aside). Lines the job did not
            // run are dropped with it.
            self.source.reset();
            if let (Some((code, line)), _) = end {
                self.enter_alarm(code, line);
                return;
            }
            if end.1 {
                self.outputs.program_stop();
            }
            self.mode = Mode::Idle;
            if job.kind == JobKind::Machine || how == JobEnd::Failed {
                self.sync_interpreter_position();
            }
            if job.kind == JobKind::Machine {
                self.keep_stored_offsets();
            }
            self.emit(BoardEvent::JobDone {
                line: self.progress.line,
                end: how,
            });
        }
    }

    /// Whether the interpreter takes lines now: in a running job; and, for a line sender (grbl),
    /// also in a feed hold or a program stop once the machine stands (not while it decelerates),
    /// as grbl plans the lines that come during a hold: a character-counting sender gets its
    /// `ok`s and keeps its receive buffer moving (docs/grbl.md "Streaming and the RX buffer").
    /// Nothing moves before cycle start; the planner simply fills. A hold for a lost host takes
    /// nothing.
    fn interprets(&self, job: &Job) -> bool {
        match job.phase {
            JobPhase::Running(Ending::No) => true,
            JobPhase::Hold {
                why,
                ending: Ending::No,
            } => {
                job.streamer == Streamer::LineSender
                    && why != HoldWhy::HostLost
                    && matches!(self.motion.state(), MotionState::Held | MotionState::Sync)
            }
            _ => false,
        }
    }

    fn interpret(&mut self) {
        loop {
            if self.probe_busy() {
                // Nothing after a probe move is interpreted before its result is known.
                return;
            }
            let canon = match self.progress.pending.take() {
                Some(c) => c,
                None => match self.interp.next(&mut self.source) {
                    Some(Ok(c)) => c,
                    Some(Err(e)) => {
                        if self.reject(e) == Streamer::ProgramServer {
                            return;
                        }
                        continue;
                    }
                    None => {
                        if self.interp.is_finished() {
                            self.set_ending(Ending::Finished);
                        }
                        return;
                    }
                },
            };
            let canon = self.dry_run_feed(canon);
            if matches!(
                self.mode,
                Mode::Job(Job {
                    kind: JobKind::Check,
                    ..
                })
            ) {
                if !self.check_only(&canon) {
                    return;
                }
                continue;
            }
            if is_motion(&canon) {
                let last = match &self.mode {
                    Mode::Job(job) => job.last_motion_line,
                    _ => 0,
                };
                if self.overrides.switches.single_block && last != 0 && canon.line != last {
                    // Single block: a breakpoint after each block (docs/controller.md "Run modes"), with
                    // the M0 stop/restore rules.
                    let pause = Canon {
                        line: last,
                        action: Action::Stop(StopKind::Pause),
                    };
                    if self.motion.push(&pause).is_err() {
                        self.progress.pending = Some(canon);
                        return;
                    }
                }
                if let Mode::Job(job) = &mut self.mode {
                    job.last_motion_line = canon.line;
                }
                let at_rest = self.motion.state() == MotionState::Idle;
                let seq = self.motion.planner().next_seq();
                self.executing
                    .note(at_rest, seq, canon.line, self.interp.state());
            }
            let pushed = match (self.on_the_fly(&canon), canon.action) {
                (Some((code, output)), _) => self.motion.push_output(canon.line, code, output),
                (None, Action::UserMCode { code, .. }) if self.thc_switch(code) => {
                    // Torch height control off / on with the next move (`motion/thc.rs`).
                    let output = OutputEvent::thc(code == 63);
                    self.motion.push_output(canon.line, code, output)
                }
                (None, Action::Spindle { state, rpm }) if self.setup.outputs.laser => {
                    // Laser mode: no sync point; the power rides on the moves after it
                    // (docs/laser-plasma.md), and the status shows the modal state at once, as
                    // grbl's does. A dry run never fires the beam.
                    if self.overrides.switches.dry_run {
                        Ok(())
                    } else {
                        let pushed = self.motion.push_program(&canon);
                        if pushed.is_ok() {
                            self.outputs.set_spindle(state, rpm);
                        }
                        pushed
                    }
                }
                (None, _) => self.motion.push_program(&canon),
            };
            match pushed {
                Ok(()) => {}
                Err(PushError::Full) => {
                    self.progress.pending = Some(canon);
                    return;
                }
                Err(PushError::Travel { .. }) => {
                    self.soft_limit(canon.line);
                    return;
                }
            }
            if let Mode::Job(job) = &mut self.mode {
                job.queued = true;
            }
            if matches!(canon.action, Action::Probe { .. }) {
                self.probing.queue();
            }
        }
    }

    /// A block of line `line` would leave the travel box. Before the job has queued anything
    /// (an MDI command, a program whose first move is out of reach) nothing has happened yet:
    /// error 900 and the job ends (grbl's line sender: alarm 2 all the same). Later, the job is stopped on its path like an abort and ends
    /// in alarm 2 (grbl's soft-limit alarm), position kept.
    fn soft_limit(&mut self, line: u32) {
        // A line sender's job (grbl) raises alarm 2 at once, as grbl does (nothing moved yet:
        // position kept).
        if matches!(
            self.mode,
            Mode::Job(Job { queued: true, .. })
                | Mode::Job(Job {
                    streamer: Streamer::LineSender,
                    kind: JobKind::Machine,
                    ..
                })
        ) {
            self.stop_job(Some((AlarmCode::SoftLimit, line)));
        } else {
            self.emit(BoardEvent::Error {
                line,
                code: ERROR_SOFT_LIMIT,
                column: 0,
            });
            self.fail_at(line);
        }
    }

    /// The job ends on an error at `line`: nothing from that line on runs; the motion queued
    /// before it completes, then [`Board::poll`] runs the program-stop sequence at rest. A later
    /// run resumes at that line.
    fn fail_at(&mut self, line: u32) {
        self.set_ending(Ending::Failed);
        if self.machine_job().is_some() {
            self.progress.resume_line = line;
        }
    }

    /// The code and output event of an on-the-fly M code (docs/controller.md "On-the-fly outputs"): a user M code
    /// whose list is exactly one `set n` or `clear n` (n < 16) switches that output at its exact
    /// place on the path without stopping the motion. `None` for everything else, which stays a
    /// sync point (an M code with no list or an empty one included). In a dry run a list flagged
    /// `dry_run_disabled` gives [`OutputEvent::NONE`]: nothing switches, the motion is the same.
    fn on_the_fly(&self, canon: &Canon) -> Option<(u16, OutputEvent)> {
        let Action::UserMCode {
            code,
            at_rest: false,
        } = canon.action
        else {
            return None;
        };
        let list = self
            .setup
            .outputs
            .mcode_lists
            .iter()
            .find(|l| l.code == code)?;
        let output = list.on_the_fly()?;
        let skipped = self.overrides.switches.dry_run && list.dry_run_disabled;
        Some((code, if skipped { OutputEvent::NONE } else { output }))
    }

    /// Dry run: every feed move at the setup's dry-run feed.
    fn dry_run_feed(&self, mut canon: Canon) -> Canon {
        if self.overrides.switches.dry_run {
            let dry = self.setup.operator.dry_run_feed;
            match &mut canon.action {
                Action::Feed { feed, .. } | Action::Arc { feed, .. } => *feed = dry,
                _ => {}
            }
        }
        canon
    }

    /// Check mode: soft-limit check of the end point, no motion. False when the job ended.
    fn check_only(&mut self, canon: &Canon) -> bool {
        match canon.action {
            Action::Rapid { to }
            | Action::Feed { to, .. }
            | Action::Arc { to, .. }
            | Action::Probe { to, .. }
                if self.motion.config().travel_violation(&to).is_some() =>
            {
                self.emit(BoardEvent::Error {
                    line: canon.line,
                    code: ERROR_SOFT_LIMIT,
                    column: 0,
                });
                self.set_ending(Ending::Failed);
                return false;
            }
            Action::Stop(StopKind::End | StopKind::EndRewind) => {
                self.progress.line = canon.line;
                self.set_ending(Ending::Finished);
                return false;
            }
            _ => {}
        }
        self.progress.line = canon.line;
        true
    }

    /// Reports a rejected block (the interpreter has undone it): a program server's job ends
    /// there, a line sender's reads on ([`Streamer`]); returns which.
    fn reject(&mut self, e: GcodeError) -> Streamer {
        self.emit(BoardEvent::Error {
            line: e.line,
            code: e.code.number(),
            column: e.columns.map_or(0, |(start, _)| start + 1),
        });
        let streamer = match self.mode {
            Mode::Job(job) => job.streamer,
            _ => Streamer::ProgramServer,
        };
        if streamer == Streamer::ProgramServer {
            self.fail_at(e.line);
        }
        streamer
    }

    /// Performs the action the motion queue stopped at (the machine is at rest).
    fn perform_sync(&mut self) {
        let Some(canon) = self.motion.sync_point().copied() else {
            return;
        };
        if self.torch() && !self.torch_firing() && self.motion.thc_correction() != 0 {
            // The height correction of the last cut comes out first (`Board::next_segment`).
            return;
        }
        if matches!(self.machine_job(), Some(JobPhase::Hold { why, .. }) if why.pause()) {
            return;
        }
        if let Some(status) = self
            .outputs
            .step_list(self.sensed.now_ms, self.sensed.levels)
        {
            match status {
                // `seek` means nothing outside homing: the next pass continues the list.
                ListStatus::Running | ListStatus::Seek => {}
                ListStatus::Done => self.motion.release_sync(),
                ListStatus::Timeout => {
                    let steps = self.motion.prepared_steps();
                    self.rebuild_motion(true, &steps);
                    self.source.reset();
                    self.progress.pending = None;
                    self.enter_alarm(AlarmCode::ListInputTimeout, canon.line);
                }
            }
            return;
        }
        self.progress.line = canon.line;
        match canon.action {
            // Dry run: spindle and coolant stay as they are (the GIXA controller: S has no effect).
            Action::Spindle { .. } | Action::SpindleOrient | Action::Coolant { .. }
                if self.overrides.switches.dry_run => {}
            Action::Spindle { state, rpm } if self.torch() && state != Spindle::Off => {
                // The torch fires and the motion waits for arc-OK (or the job ends in alarm 22).
                let established = self.torch_on_at_sync(state, rpm, canon.line);
                if !established {
                    return;
                }
            }
            Action::Spindle { state, rpm } => {
                if state != Spindle::Off {
                    // A spindle that starts is no longer held oriented.
                    self.outputs
                        .release_orient(self.setup.outputs.orient.output);
                }
                self.outputs.set_spindle(state, rpm);
                self.arc = torch::Arc::Off;
            }
            Action::SpindleOrient if self.setup.outputs.orient.present() => {
                // Set the orient output, then wait for its done input (or the dwell) at rest:
                // the shift away from the wall is the next motion (`gcode/cycles.rs`).
                self.outputs.run_list(&self.setup.outputs.orient.commands());
                self.perform_sync();
                return;
            }
            Action::Coolant { mist, flood } => {
                self.outputs.set_coolant(mist, flood);
            }
            Action::ToolChange { tool } => {
                // A manual tool change (docs/probing.md "Tool change"): at rest, spindle and
                // coolant off (not restored), until cycle start or the host resumes.
                self.outputs.tool_change(tool);
                let (why, ending) = match self.machine_job() {
                    Some(JobPhase::Hold { ending, .. }) => (HoldWhy::FeedAndPause, ending),
                    Some(JobPhase::Running(ending)) => (HoldWhy::ToolChange { tool }, ending),
                    _ => (HoldWhy::ToolChange { tool }, Ending::No),
                };
                self.set_phase(JobPhase::Hold { why, ending });
                return;
            }
            Action::Probe { .. } => {
                self.start_probe(&canon);
                return;
            }
            Action::UserMCode { code, .. } if self.thc_switch(code) => {
                // No move followed: the switch takes effect here.
                self.motion.set_thc_enabled(code == 63);
            }
            Action::UserMCode { code, .. } => {
                let list = self
                    .setup
                    .outputs
                    .mcode_lists
                    .iter()
                    .find(|l| l.code == code);
                if let Some(l) =
                    list.filter(|l| !(self.overrides.switches.dry_run && l.dry_run_disabled))
                {
                    self.outputs.run_list(&l.commands);
                    self.perform_sync();
                    return;
                }
            }
            Action::Stop(StopKind::Pause | StopKind::OptionalPause) => {
                // The GIXA controller's stop rule: spindle and coolant off while stopped, restored on resume.
                self.outputs.pause();
                let (why, ending) = match self.machine_job() {
                    Some(JobPhase::Hold { ending, .. }) => (HoldWhy::FeedAndPause, ending),
                    Some(JobPhase::Running(ending)) => (HoldWhy::Pause, ending),
                    _ => (HoldWhy::Pause, Ending::No),
                };
                self.set_phase(JobPhase::Hold { why, ending });
                return;
            }
            Action::Stop(StopKind::End | StopKind::EndRewind) => {
                self.outputs.program_stop();
                self.set_ending(Ending::Finished);
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

    /// The offsets and units of the move being executed: in a job with blocks in the planner,
    /// those the block the kernel runs was queued under (`board/executing.rs`), not the
    /// interpreter's, which has read ahead; otherwise (idle, jogging, homing, a job with nothing
    /// planned) the interpreter's.
    pub(crate) fn executing_modes(&self) -> BlockModes {
        if matches!(self.mode, Mode::Job(_)) && !self.motion.planner().is_empty() {
            *self.executing.active()
        } else {
            BlockModes::of(self.interp.state())
        }
    }

    /// Programmed speed of the block being executed, µm/min (rapids: their limit); 0 when
    /// nothing is planned.
    pub(crate) fn programmed_feed_um_min(&self) -> u32 {
        if self.motion.planner().is_empty() {
            return 0;
        }
        ((u64::from(self.executing.programmed()) * 60 + 500) / 1000) as u32
    }

    /// Output levels for the pins (spindle enable/direction/PWM, coolant, user outputs).
    pub fn output_levels(&self) -> OutputLevels {
        self.outputs
            .levels(&self.setup.outputs, self.overrides.spindle())
    }

    /// Exchanges the user output word with the owner of the step kernel, once per main-loop pass
    /// after [`Board::poll`] and the segment fill. `kernel_word` is `StepKernel::outputs()`: the
    /// levels on the pins, including the on-the-fly events the kernel has fired. When the board
    /// switched outputs itself since the last exchange (a command list at rest, an alarm's safe
    /// state) it returns the word the owner must load into the kernel (`StepKernel::set_outputs`)
    /// and drive onto the pins; otherwise it takes the kernel's word, so the board's levels (status,
    /// stop/restore rules) never lag the pins by more than one pass. The board only switches
    /// outputs at rest or with the kernel stopped, so the two never change the same word at once.
    pub(crate) fn sync_user_outputs(&mut self, kernel_word: u16) -> Option<u16> {
        self.outputs.sync_user(kernel_word)
    }

    /// A new step position for the kernel (homing set home): the owner loads it into the kernel
    /// (`StepKernel::set_position`) right after the [`Board::poll`] that produced it, before
    /// handing out new segments. The kernel is at rest then.
    pub(crate) fn take_position_reset(&mut self) -> Option<[i64; MAX_AXES]> {
        self.position.take_reset()
    }

    /// The debounced input levels the controller last saw.
    pub fn inputs(&self) -> InputBits {
        self.sensed.levels
    }
}

/// Actions that move (single block counts blocks by them).
fn is_motion(c: &Canon) -> bool {
    matches!(
        c.action,
        Action::Rapid { .. }
            | Action::Feed { .. }
            | Action::Arc { .. }
            | Action::Probe { .. }
            | Action::Dwell { .. }
    )
}
