//! What the board is doing, as one value: [`Mode`] says whether it is idle, running a job (and in
//! which phase: running, held, stopping), in an alarm, homing or jogging. The status's
//! [`State`] is derived from it ([`Mode::state`]); the rules that move between modes are in
//! `board/mod.rs` (jobs, alarms), `board/homing/` and `board/jog/`.
//!
//! Stops take precedence: once a job is [`JobPhase::Stopping`] (an abort, or an alarm stop such
//! as alarm 2 or 20 decelerating on the path) nothing but the rest of the machine ends it: a feed
//! hold, a cycle start or another abort leaves it as it is, and it ends at rest with the
//! program-stop sequence or its alarm.

use crate::board::homing::plan::Homing;
use crate::board::outputs::lists::ListRunner;
use crate::board::state::{AlarmCode, State};

/// The board's mode. Not `PartialEq`: a derived comparison would compare a homing cycle's lists
/// too (940 B of F411 flash, measured, for nothing); test a mode with `matches!`.
#[derive(Clone, Debug)]
pub(super) enum Mode {
    /// Nothing running.
    Idle,
    /// A streamed job.
    Job(Job),
    /// Motion refused until the alarm is cleared.
    Alarm(AlarmCode),
    /// A homing cycle: where it stands is in `phase`, nowhere else.
    Homing { phase: HomingPhase },
    /// Jogging (the moves themselves in `Board::jog`).
    Jog(Jogging),
}

impl Mode {
    /// The state the status reports.
    pub(super) fn state(&self) -> State {
        match self {
            Mode::Idle => State::Idle,
            Mode::Job(Job {
                kind: JobKind::Check,
                ..
            }) => State::Check,
            Mode::Job(Job {
                phase:
                    JobPhase::Hold {
                        why: HoldWhy::ToolChange { .. },
                        ..
                    },
                ..
            }) => State::ToolChange,
            Mode::Job(Job {
                phase: JobPhase::Hold { .. },
                ..
            }) => State::Hold,
            Mode::Job(_) => State::Run,
            Mode::Alarm(_) => State::Alarm,
            Mode::Homing { .. } => State::Homing,
            Mode::Jog(_) => State::Jog,
        }
    }
}

/// Who jogs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Jogging {
    /// Host jogs (a next one may start once the last is at rest), or joystick mode just left: back
    /// to Idle once at rest.
    Moves,
    /// Joystick jog mode (entered and left with Mark + Release): the switches and the stick jog.
    Joystick,
    /// A host jog off a pressed limit switch from this alarm (`board/pressed_switch.rs`): back
    /// in the alarm once at rest.
    OffSwitch(AlarmCode),
}

/// A homing cycle, running or aborted.
#[derive(Clone, Debug)]
pub(super) enum HomingPhase {
    /// Lists, seek, retract and set home, axis by axis (`board/homing/`).
    Cycle(HomingCycle),
    /// Aborted: the seek decelerates; alarm 6 at rest.
    Aborting,
}

/// A running homing cycle: the axis and its step ([`Homing`]) and the command list of that step
/// while one runs (before seek, before retract, after retract).
#[derive(Clone, Debug)]
pub(super) struct HomingCycle {
    pub homing: Homing,
    pub list: Option<ListRunner>,
}

/// A job: what kind, where it stands, and what it has queued (all of it ends with the job).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Job {
    pub kind: JobKind,
    pub phase: JobPhase,
    /// The job has queued an action (motion, spindle, …): from then on a block beyond the travel
    /// stops it with alarm 2 instead of error 900.
    pub queued: bool,
    /// Line of the last motion queued (0: none yet; single block pauses when it changes).
    pub last_motion_line: u32,
    /// Who streams the job's lines.
    pub streamer: Streamer,
}

/// Who streams a job's lines, which decides what a rejected block and a jump do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Streamer {
    /// Gantry's own link (`gantry stream`): the host serves program lines on request
    /// (subprograms, O-word loops: `board/source.rs`), and a rejected block ends the job (the
    /// motion queued before it completes, then the program-stop sequence; the host offers
    /// `--from-line`).
    ProgramServer,
    /// A line sender (grbl): lines in order only, so a jump is an error of its block; a
    /// rejected block is dropped alone: it executes nothing and changes nothing, the job reads on
    /// with its modal state and outputs unchanged, and the sender decides whether to stop
    /// (grbl's rule, docs/grbl.md "Errors").
    LineSender,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum JobKind {
    /// Motion and outputs.
    Machine,
    /// Interpreted and checked against the soft limits only (grbl `$C`).
    Check,
}

/// Where a job stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum JobPhase {
    /// Interpreting and moving.
    Running(Ending),
    /// Standing on the path, resumable.
    Hold { why: HoldWhy, ending: Ending },
    /// An abort or an alarm stop: decelerating on the path, nothing more interpreted; at rest the
    /// program-stop sequence, or `alarm` (with its line) instead. Nothing cancels it.
    Stopping {
        alarm: Option<(AlarmCode, u32)>,
        ramp: Ramp,
    },
}

/// A stopping job's deceleration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Ramp {
    /// The motion is still decelerating.
    Decelerating,
    /// The motion has stopped; the kernel runs out what it has.
    Done,
}

/// Why a job stands still.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum HoldWhy {
    /// A feed hold (input, host or link): motion stopped on the path, outputs as they were.
    Feed,
    /// An M0 / M1 / single-block stop at its sync point: spindle and coolant off, restored on
    /// cycle start.
    Pause,
    /// Both (a feed hold that came as the motion reached a pause).
    FeedAndPause,
    /// An M6 at its sync point: a manual tool change to `tool`, spindle and coolant off (not
    /// restored: the program starts the spindle for the new tool).
    ToolChange { tool: u32 },
    /// The host was lost (port closed, DTR dropped, silence): a feed hold whose spindle and
    /// coolant go off once the machine is at rest (`Board::poll`), restored on resume
    /// (docs/controller.md "Host lost").
    HostLost,
    /// A plasma torch lost its arc while cutting (docs/laser-plasma.md "Plasma"): a feed hold on
    /// the path with the torch off; cycle start re-fires it ([`HoldWhy::ArcWait`]).
    ArcLost,
    /// After an arc loss, cycle start re-fired the torch: the motion stays held until arc-OK
    /// comes (then it resumes by itself), alarm 22 after `arc_ok_timeout_ms`.
    ArcWait,
}

impl HoldWhy {
    pub(super) fn feed(self) -> bool {
        matches!(
            self,
            HoldWhy::Feed | HoldWhy::FeedAndPause | HoldWhy::HostLost | HoldWhy::ArcLost
        )
    }

    pub(super) fn pause(self) -> bool {
        matches!(
            self,
            HoldWhy::Pause | HoldWhy::FeedAndPause | HoldWhy::ToolChange { .. }
        )
    }
}

/// Whether, and how, a running job has reached its end. Every ending takes effect at rest (the
/// kernel drained, nothing left to prepare), in one place (`Board::poll`); only a hard limit
/// (alarm 1) ends a job at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Ending {
    /// Still running.
    No,
    /// M2/M30 (their sync point already ran the program-stop sequence) or the end of the
    /// streamed lines (outputs as the program left them: an MDI `M3` keeps the spindle on):
    /// finish the queued motion, then report.
    Finished,
    /// A rejected block: finish the motion queued before it, then at rest the program-stop
    /// sequence and report.
    Failed,
}
